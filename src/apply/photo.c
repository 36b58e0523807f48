/* photo.c: relighting whole photographs (docs/usage.md, "Photos and aligned textures"). A photo is
 * aligned (every face detected, its landmarks found and the face unwarped into the aligned texture
 * space), each face texture goes through the texture-in, texture-out cores of face.c / relight.c,
 * and each result is warped back with the mesh and Poisson-blended into a copy of the photo at
 * full resolution (hd_warp_back_blend, HD_WARP_CHANGE: only the change the model makes is added,
 * so the photo keeps its own detail and everything outside the face stays as it was). */
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "core/core.h"

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

/* A copy of src into dst (allocated). */
static hd_status copy_image(const hd_image *src, hd_image *dst)
{
    hd_status st = hd_image_alloc(dst, src->width, src->height, src->channels);
    if (st == HD_OK)
        memcpy(dst->data, src->data, (size_t)src->width * (size_t)src->height * (size_t)src->channels * sizeof(float));
    return st;
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

hd_status hd_relight_photo(hd_model *model, hd_aligner *aligner, const hd_image *photo,
                           const float (*lights)[HD_SH_COEFFS], int count, hd_brightness brightness, hd_image *relit,
                           hd_image *delit, int *nfaces)
{
    for (int i = 0; i < count; i++) memset(&relit[i], 0, sizeof relit[i]);
    if (delit) memset(delit, 0, sizeof *delit);
    if (nfaces) *nfaces = 0;
    if (!photo || !photo->data || photo->channels != 3)
        return hd_fail(HD_ERR_ARG, "relight: a photo has 3 channels (has %d)", photo ? photo->channels : 0);
    hd_aligned_face *faces = NULL;
    int n = 0;
    hd_status st = hd_photo_faces(aligner, model, photo, &faces, &n);
    for (int i = 0; i < count && st == HD_OK; i++) st = copy_image(photo, &relit[i]);
    if (st == HD_OK && delit) st = copy_image(photo, delit);
    hd_image tex_out = {0};
    for (int k = 0; k < n && st == HD_OK; k++) {
        /* one decomposition per face, then every light: texture in, texture out, photo back */
        const hd_aligned_face *f = &faces[k];
        hd_decomposition d;
        memset(&d, 0, sizeof d);
        st = hd_model_decompose(model, &f->texture, 1, &d);
        for (int i = 0; i < count && st == HD_OK; i++) {
            st = hd_relight(&f->texture, &d, &f->mask, lights[i], brightness, &tex_out);
            if (st == HD_OK) st = hd_aligner_warp_back_blend(aligner, f, &tex_out, HD_WARP_CHANGE, 0, &relit[i], NULL);
            hd_image_free(&tex_out);
        }
        if (st == HD_OK && delit) {
            st = hd_delight(&f->texture, &d, &f->mask, &tex_out);
            if (st == HD_OK) st = hd_aligner_warp_back_blend(aligner, f, &tex_out, HD_WARP_CHANGE, 0, delit, NULL);
            hd_image_free(&tex_out);
        }
        hd_decomposition_free(&d);
    }
    hd_aligned_faces_free(faces, n);
    if (st != HD_OK) {
        for (int i = 0; i < count; i++) hd_image_free(&relit[i]);
        if (delit) hd_image_free(delit);
        return st;
    }
    if (nfaces) *nfaces = n;
    return HD_OK;
}

hd_status hd_estimate_light_photo(hd_model *model, hd_aligner *aligner, const hd_image *photo,
                                  float light[HD_SH_COEFFS], int *nfaces)
{
    if (nfaces) *nfaces = 0;
    hd_aligned_face *faces = NULL;
    int n = 0;
    hd_status st = hd_photo_faces(aligner, model, photo, &faces, &n);
    if (st == HD_OK) st = hd_estimate_light(model, &faces[0].texture, light);
    hd_aligned_faces_free(faces, n);
    if (st == HD_OK && nfaces) *nfaces = n;
    return st;
}
