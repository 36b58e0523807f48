/* calls.c: the thin public calls of the relighting section of hdnet.h, each one request to apply.c
 * (the one home of applying a model) or one look at photo.c's faces: grey lights, one picture
 * each, texture in, texture out (hd_relight_face, hd_delight_face, hd_transfer_face) or photo in,
 * photo out (hd_relight_photo, hd_transfer_photo); a face's own light (hd_estimate_light and its
 * photo and source variants); the best face of a photo decomposed (hd_decompose_photo). Each names
 * its operation in the request, so that a reason says delight or transfer, not relight. */
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "apply/apply.h"

/* Runs q on a texture (aligner NULL) or a photo and moves the one picture asked for into out. */
static hd_status one_picture(hd_model *model, hd_aligner *aligner, const hd_image *image, const hd_image *mask,
                             const hd_apply_request *q, hd_image *out, int *nfaces)
{
    memset(out, 0, sizeof *out);
    hd_apply_result r;
    hd_status st = aligner ? hd_apply_photo(model, aligner, image, q, &r) : hd_apply_texture(model, image, mask, q, &r);
    if (st != HD_OK) return st;
    hd_image *picked = q->delight ? &r.delit : &r.relit[0];
    *out = *picked;
    memset(picked, 0, sizeof *picked);
    if (nfaces) *nfaces = r.nfaces;
    hd_apply_result_free(&r);
    return HD_OK;
}

/* hd_relight_face for the operation op (its reasons' name). */
static hd_status relight_face(hd_model *model, const hd_image *image, const hd_image *mask,
                              const float light[HD_SH_COEFFS], hd_brightness brightness, const char *op, hd_image *out)
{
    hd_light_rgb l;
    hd_light_rgb_from_grey(light, &l);
    hd_apply_request q = {&l, 1, 0, 0, HD_RULE_RATIO, brightness, HD_SOURCE_FIT, 0.0f, op};
    return one_picture(model, NULL, image, mask, &q, out, NULL);
}

hd_status hd_relight_face(hd_model *model, const hd_image *image, const hd_image *mask,
                          const float light[HD_SH_COEFFS], hd_brightness brightness, hd_image *out)
{
    return relight_face(model, image, mask, light, brightness, "relight", out);
}

hd_status hd_delight_face(hd_model *model, const hd_image *image, const hd_image *mask, hd_image *out)
{
    hd_apply_request q = {NULL, 0, 1, 0, HD_RULE_RATIO, HD_BRIGHTNESS_KEEP, HD_SOURCE_FIT, 0.0f, "delight"};
    return one_picture(model, NULL, image, mask, &q, out, NULL);
}

hd_status hd_estimate_face_light(hd_model *model, const hd_image *image, const hd_image *mask, hd_source_light source,
                                 float light[HD_SH_COEFFS])
{
    hd_decomposition d;
    memset(&d, 0, sizeof d);
    hd_status st = hd_model_decompose(model, image, 1, &d);
    if (st == HD_OK) st = hd_reference_light(&d, mask, source, light);
    hd_decomposition_free(&d);
    return st;
}

hd_status hd_estimate_light(hd_model *model, const hd_image *image, float light[HD_SH_COEFFS])
{
    return hd_estimate_face_light(model, image, NULL, HD_SOURCE_FIT, light);
}

/* Transfer decomposes the two faces one at a time (not as a batch of two) so that its result is
 * bit-identical to hd_relight_face under hd_estimate_light(ref). */
hd_status hd_transfer_face(hd_model *model, const hd_image *image, const hd_image *mask,
                           const hd_image *ref, hd_brightness brightness, hd_image *out)
{
    memset(out, 0, sizeof *out);
    float light[HD_SH_COEFFS];
    hd_status st = hd_estimate_light(model, ref, light);
    if (st == HD_OK) st = relight_face(model, image, mask, light, brightness, "transfer", out);
    return st;
}

/* hd_relight_photo for the operation op (its reasons' name). */
static hd_status relight_photo(hd_model *model, hd_aligner *aligner, const hd_image *photo,
                               const float (*lights)[HD_SH_COEFFS], int count, hd_brightness brightness,
                               const char *op, hd_image *relit, hd_image *delit, int *nfaces)
{
    for (int i = 0; i < count; i++) memset(&relit[i], 0, sizeof relit[i]);
    if (delit) memset(delit, 0, sizeof *delit);
    if (nfaces) *nfaces = 0;
    hd_light_rgb *l = hd_malloc((size_t)(count > 0 ? count : 1) * sizeof *l);
    if (!l) return HD_ERR_NOMEM;
    for (int i = 0; i < count; i++) hd_light_rgb_from_grey(lights[i], &l[i]);
    hd_apply_request q = {l, count, delit != NULL, 0, HD_RULE_RATIO, brightness, HD_SOURCE_FIT, 0.0f, op};
    hd_apply_result r;
    hd_status st = hd_apply_photo(model, aligner, photo, &q, &r);
    free(l);
    if (st != HD_OK) return st;
    for (int i = 0; i < count; i++) {
        relit[i] = r.relit[i];
        memset(&r.relit[i], 0, sizeof r.relit[i]);
    }
    if (delit) {
        *delit = r.delit;
        memset(&r.delit, 0, sizeof r.delit);
    }
    if (nfaces) *nfaces = r.nfaces;
    hd_apply_result_free(&r);
    return HD_OK;
}

hd_status hd_relight_photo(hd_model *model, hd_aligner *aligner, const hd_image *photo,
                           const float (*lights)[HD_SH_COEFFS], int count, hd_brightness brightness, hd_image *relit,
                           hd_image *delit, int *nfaces)
{
    /* the delit faces alone are a delight */
    const char *op = count == 0 && delit ? "delight" : "relight";
    return relight_photo(model, aligner, photo, lights, count, brightness, op, relit, delit, nfaces);
}

hd_status hd_estimate_face_light_photo(hd_model *model, hd_aligner *aligner, const hd_image *photo,
                                       hd_source_light source, float light[HD_SH_COEFFS], int *nfaces)
{
    if (nfaces) *nfaces = 0;
    hd_aligned_face *faces = NULL;
    int n = 0;
    hd_status st = hd_photo_faces(aligner, model, photo, &faces, &n);
    /* the face's normals turned toward the fit's pose, as the photo it is transferred to is relit on */
    hd_decomposition d;
    memset(&d, 0, sizeof d);
    if (st == HD_OK) st = hd_face_decompose(model, &faces[0], &d);
    if (st == HD_OK) st = hd_reference_light(&d, &faces[0].mask, source, light);
    hd_decomposition_free(&d);
    hd_aligned_faces_free(faces, n);
    if (st == HD_OK && nfaces) *nfaces = n;
    return st;
}

hd_status hd_estimate_light_photo(hd_model *model, hd_aligner *aligner, const hd_image *photo,
                                  float light[HD_SH_COEFFS], int *nfaces)
{
    return hd_estimate_face_light_photo(model, aligner, photo, HD_SOURCE_FIT, light, nfaces);
}

hd_status hd_decompose_photo(hd_model *model, hd_aligner *aligner, const hd_image *photo, hd_decomposition *d,
                             hd_aligned_face *face)
{
    memset(d, 0, sizeof *d);
    if (face) memset(face, 0, sizeof *face);
    hd_aligned_face *faces = NULL;
    int n = 0;
    hd_status st = hd_photo_faces(aligner, model, photo, &faces, &n);
    if (st == HD_OK) st = hd_face_decompose(model, &faces[0], d);
    if (st == HD_OK && face) {
        *face = faces[0]; /* the best face moves to the caller */
        memset(&faces[0], 0, sizeof faces[0]);
    }
    hd_aligned_faces_free(faces, n);
    return st;
}

hd_status hd_transfer_photo(hd_model *model, hd_aligner *aligner, const hd_image *photo, const hd_image *reference,
                            hd_brightness brightness, hd_image *out, int *nfaces)
{
    memset(out, 0, sizeof *out);
    if (nfaces) *nfaces = 0;
    float light[HD_SH_COEFFS];
    hd_status st = hd_estimate_light_photo(model, aligner, reference, light, NULL);
    if (st != HD_OK) return st;
    return relight_photo(model, aligner, photo, (const float (*)[HD_SH_COEFFS])light, 1, brightness, "transfer", out,
                         NULL, nfaces);
}
