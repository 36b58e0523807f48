/* photo.c: photos and aligned textures (docs/usage.md, "Photos and aligned textures"): which an
 * input is (by its companions), the texture size faces are unwarped at, every face of a photo
 * aligned (hd_photo_faces, which apply.c and calls.c take), and a photo's decomposition as maps at
 * its full size (hd_decompose_photo_maps). It calls no other file of src/apply: what is done to
 * the faces is apply.c's. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "core/core.h"
#include "apply/apply.h"
#include "align/person_segment.h"

/* Whether "dir/NAME.ext" has the companion "dir/NAME<suffix>" beside it. */
static int has_companion(const char *path, const char *suffix)
{
    char *p = hd_path_companion(path, suffix);
    if (!p) return 0;
    int yes = access(p, F_OK) == 0;
    free(p);
    return yes;
}

hd_input_kind hd_input_kind_of(const char *path)
{
    return has_companion(path, ".mask.png") || has_companion(path, ".normal.png") ? HD_INPUT_TEXTURE : HD_INPUT_PHOTO;
}

int hd_photo_texture_size(const hd_model *model)
{
    int s = hd_model_size(model);
    return s > HD_PHOTO_TEXTURE_SIZE ? s : HD_PHOTO_TEXTURE_SIZE;
}

hd_status hd_photo_faces(hd_aligner *aligner, const hd_model *model, const hd_image *photo, hd_aligned_face **faces,
                         int *count)
{
    *faces = NULL;
    *count = 0;
    hd_status st = hd_aligner_run(aligner, photo, hd_photo_texture_size(model), faces, count);
    if (st == HD_OK && *count == 0) st = hd_fail(HD_ERR_NOTFOUND, "no face found");
    return st;
}

void hd_photo_maps_free(hd_photo_maps *m)
{
    if (!m) return;
    for (int k = 0; m->d && k < m->nfaces; k++) hd_decomposition_free(&m->d[k]);
    free(m->d);
    hd_aligned_faces_free(m->faces, m->nfaces);
    hd_image_free(&m->recon);
    hd_image_free(&m->albedo);
    hd_image_free(&m->shading);
    hd_image_free(&m->normal);
    hd_image_free(&m->mask);
    hd_image_free(&m->person);
    memset(m, 0, sizeof *m);
}

/* Paints texture map tex of face f into the photo-frame map out where it lands (renormalising
 * normals); marks mask. */
static hd_status paint_map(const hd_aligned_face *f, const hd_image *tex, int normals, hd_image *out, hd_image *mask)
{
    hd_image warped = {0}, coverage = {0};
    hd_status st = hd_warp_back(f, tex, NULL, &warped, &coverage);
    if (st != HD_OK) return st;
    const size_t P = (size_t)out->width * (size_t)out->height;
    for (size_t p = 0; p < P; p++) {
        if (coverage.data[p] <= 0.5f) continue;
        float len = 1.0f;
        if (normals) {
            float x = warped.data[p], y = warped.data[P + p], z = warped.data[2 * P + p];
            len = sqrtf(x * x + y * y + z * z);
            if (!(len > 1e-6f)) len = 1.0f;
        }
        for (int c = 0; c < out->channels; c++) out->data[c * P + p] = warped.data[c * P + p] / len;
        if (mask) mask->data[p] = 1.0f;
    }
    hd_image_free(&warped);
    hd_image_free(&coverage);
    return HD_OK;
}

hd_status hd_decompose_photo_maps(hd_model *model, hd_aligner *aligner, const hd_image *photo, hd_photo_maps *m)
{
    memset(m, 0, sizeof *m);
    if (!photo || !photo->data || photo->channels != 3)
        return hd_fail(HD_ERR_ARG, "decompose: a photo has 3 channels (has %d)", photo ? photo->channels : 0);
    hd_status st = hd_photo_faces(aligner, model, photo, &m->faces, &m->nfaces);
    if (st != HD_OK) return st;
    const int W = photo->width, H = photo->height;
    if (!(m->d = hd_calloc((size_t)m->nfaces, sizeof *m->d))) st = HD_ERR_NOMEM;
    hd_image *tex = st == HD_OK ? hd_calloc((size_t)m->nfaces, sizeof *tex) : NULL;
    if (st == HD_OK && !tex) st = HD_ERR_NOMEM;
    for (int k = 0; st == HD_OK && k < m->nfaces; k++) tex[k] = m->faces[k].texture; /* borrowed */
    if (st == HD_OK) st = hd_model_decompose(model, tex, m->nfaces, m->d);
    for (int k = 0; st == HD_OK && k < m->nfaces; k++) /* hd_face_decompose's, for the batch */
        st = hd_face_repose(&m->faces[k], &m->d[k], HD_REPOSE_SHARE, NULL);
    free(tex);
    if (st == HD_OK) st = hd_image_alloc(&m->recon, W, H, 3);
    if (st == HD_OK) memcpy(m->recon.data, photo->data, (size_t)W * H * 3 * sizeof(float));
    if (st == HD_OK) st = hd_image_alloc(&m->albedo, W, H, 3);
    if (st == HD_OK) st = hd_image_alloc(&m->shading, W, H, 1);
    if (st == HD_OK) st = hd_image_alloc(&m->normal, W, H, 3);
    if (st == HD_OK) st = hd_image_alloc(&m->mask, W, H, 1);
    if (st == HD_OK) st = hd_image_alloc(&m->person, W, H, 1);
    for (int k = 0; k < m->nfaces && st == HD_OK; k++) hd_person_map_max(&m->faces[k], W, H, 0, m->person.data);
    /* the worst-scoring face first, so that the best one is painted last and wins */
    for (int k = m->nfaces - 1; k >= 0 && st == HD_OK; k--) {
        const hd_aligned_face *f = &m->faces[k];
        st = paint_map(f, &m->d[k].albedo, 0, &m->albedo, &m->mask);
        if (st == HD_OK) st = paint_map(f, &m->d[k].shading, 0, &m->shading, NULL);
        if (st == HD_OK) st = paint_map(f, &m->d[k].normal, 1, &m->normal, NULL);
    }
    for (int k = 0; k < m->nfaces && st == HD_OK; k++)
        st = hd_warp_back_blend(&m->faces[k], &m->d[k].reconstruction, HD_WARP_REPLACE, 0, &m->recon, NULL);
    if (st != HD_OK) {
        /* the decompositions exist only if the model ran: free what is there */
        hd_photo_maps_free(m);
    }
    return st;
}
