/* face.c: relighting with a model, texture in and texture out (decompose, then relight.c), and
 * finding the mask of a face image. These are the cores of `hdnet relight`, `transfer`, `delight`
 * and `estimate-light`; photo alignment wraps them (photo -> texture -> core -> texture -> photo). */
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "core/core.h"

hd_status hd_relight_face(hd_model *model, const hd_image *image, const hd_image *mask,
                          const float light[HD_SH_COEFFS], hd_brightness brightness, hd_image *out)
{
    memset(out, 0, sizeof *out);
    hd_decomposition d;
    memset(&d, 0, sizeof d);
    hd_status st = hd_model_decompose(model, image, 1, &d);
    if (st == HD_OK) st = hd_relight(image, &d, mask, light, brightness, out);
    hd_decomposition_free(&d);
    return st;
}

hd_status hd_delight_face(hd_model *model, const hd_image *image, const hd_image *mask, hd_image *out)
{
    memset(out, 0, sizeof *out);
    hd_decomposition d;
    memset(&d, 0, sizeof d);
    hd_status st = hd_model_decompose(model, image, 1, &d);
    if (st == HD_OK) st = hd_delight(image, &d, mask, out);
    hd_decomposition_free(&d);
    return st;
}

hd_status hd_estimate_light(hd_model *model, const hd_image *image, float light[HD_SH_COEFFS])
{
    hd_decomposition d;
    memset(&d, 0, sizeof d);
    hd_status st = hd_model_decompose(model, image, 1, &d);
    if (st == HD_OK) memcpy(light, d.light, sizeof d.light);
    hd_decomposition_free(&d);
    return st;
}

/* Transfer decomposes the two faces one at a time (not as a batch of two) so that its result is
 * bit-identical to hd_relight_face under hd_estimate_light(ref). */
hd_status hd_transfer_face(hd_model *model, const hd_image *image, const hd_image *mask,
                           const hd_image *ref, hd_brightness brightness, hd_image *out)
{
    memset(out, 0, sizeof *out);
    float light[HD_SH_COEFFS];
    hd_status st = hd_estimate_light(model, ref, light);
    if (st == HD_OK) st = hd_relight_face(model, image, mask, light, brightness, out);
    return st;
}

/* "dir/NAME.ext" -> "dir/NAME.mask.png" (malloc'ed). */
static char *companion_mask_path(const char *image_path)
{
    const char *slash = strrchr(image_path, '/');
    const char *base = slash ? slash + 1 : image_path;
    const char *dot = strrchr(base, '.');
    size_t stem = dot && dot != base ? (size_t)(dot - image_path) : strlen(image_path);
    static const char suffix[] = ".mask.png";
    char *path = hd_malloc(stem + sizeof suffix);
    if (!path) return NULL;
    memcpy(path, image_path, stem);
    memcpy(path + stem, suffix, sizeof suffix);
    return path;
}

hd_status hd_face_mask_read(const char *image_path, const char *fallback, int width, int height,
                            hd_image *mask, char **source)
{
    memset(mask, 0, sizeof *mask);
    if (source) *source = NULL;
    if (width < 1 || height < 1 || width > HD_IMAGE_MAX_SIDE || height > HD_IMAGE_MAX_SIDE)
        return hd_fail(HD_ERR_ARG, "mask of %d x %d pixels is out of range", width, height);
    char *path = image_path ? companion_mask_path(image_path) : NULL;
    if (image_path && !path) return HD_ERR_NOMEM;
    if (path && access(path, F_OK) != 0) {
        free(path);
        path = NULL;
    }
    if (!path && fallback) {
        size_t n = strlen(fallback) + 1;
        path = hd_malloc(n);
        if (!path) return HD_ERR_NOMEM;
        memcpy(path, fallback, n);
    }
    hd_status st;
    if (!path) {
        st = hd_image_alloc(mask, width, height, 1);
        if (st != HD_OK) return st;
        for (size_t p = 0; p < (size_t)width * (size_t)height; p++) mask->data[p] = 1.0f;
        return HD_OK;
    }
    hd_image raw = {0};
    st = hd_image_read_as(path, 1, &raw);
    if (st == HD_OK) {
        if (raw.width == width && raw.height == height) {
            *mask = raw;
            raw.data = NULL;
        } else {
            st = hd_image_resize(&raw, width, height, mask);
        }
    }
    hd_image_free(&raw);
    if (st == HD_OK && source) *source = path;
    else free(path);
    return st;
}
