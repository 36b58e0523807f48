/* normal_map.c: normal maps in files (SPEC section 2): rgb = (n + 1) / 2 for unit camera-frame
 * normals, and 0 for masked-out pixels; and normal maps resized or renormalised in memory. */
#include <math.h>
#include <string.h>
#include "core/core.h"

/* Decoding: n' = 2 rgb - 1, n = n' / |n'|. A pixel is masked out (mask 0, normal 0) when the
 * stored rgb is near zero (|rgb| < 0.5: every visible-side unit normal has |rgb| >= 0.54, so this
 * catches the written-as-0 pixels and nothing valid) or when |n'| < 0.5 (too short to be a
 * normal, e.g. mid gray). */
hd_status hd_normal_decode(const hd_image *rgb, hd_image *normal, hd_image *mask)
{
    if (!rgb || !rgb->data || rgb->channels < 3)
        return hd_fail(HD_ERR_ARG, "a normal map needs 3 channels, not %d", rgb ? rgb->channels : 0);
    hd_image n = {0}, m = {0};
    hd_status st = hd_image_alloc(&n, rgb->width, rgb->height, 3);
    if (st != HD_OK) return st;
    if (mask && (st = hd_image_alloc(&m, rgb->width, rgb->height, 1)) != HD_OK) {
        hd_image_free(&n);
        return st;
    }
    size_t np = (size_t)rgb->width * rgb->height;
    for (size_t p = 0; p < np; p++) {
        float r = rgb->data[p], g = rgb->data[np + p], b = rgb->data[2 * np + p];
        float x = 2 * r - 1, y = 2 * g - 1, z = 2 * b - 1;
        float stored = sqrtf(r * r + g * g + b * b), len = sqrtf(x * x + y * y + z * z);
        int valid = stored >= 0.5f && len >= 0.5f;
        if (valid) {
            n.data[p] = x / len;
            n.data[np + p] = y / len;
            n.data[2 * np + p] = z / len;
        }
        if (mask) m.data[p] = valid ? 1.0f : 0.0f;
    }
    *normal = n;
    if (mask) *mask = m;
    return HD_OK;
}

/* Encoding: rgb = (n + 1) / 2 where mask > 0.5 (or no mask), else 0. */
hd_status hd_normal_encode(const hd_image *normal, const hd_image *mask, hd_image *rgb)
{
    if (!normal || !normal->data || normal->channels != 3)
        return hd_fail(HD_ERR_ARG, "normals need 3 channels, not %d", normal ? normal->channels : 0);
    if (mask && (!mask->data || mask->width != normal->width || mask->height != normal->height))
        return hd_fail(HD_ERR_ARG, "mask size %dx%d differs from the normals' %dx%d", mask->width,
                       mask->height, normal->width, normal->height);
    hd_image out = {0};
    hd_status st = hd_image_alloc(&out, normal->width, normal->height, 3);
    if (st != HD_OK) return st;
    size_t np = (size_t)normal->width * normal->height;
    for (size_t p = 0; p < np; p++) {
        if (mask && !(mask->data[p] > 0.5f)) continue;
        for (int c = 0; c < 3; c++) out.data[c * np + p] = (normal->data[c * np + p] + 1.0f) * 0.5f;
    }
    *rgb = out;
    return HD_OK;
}

/* Renormalising: n / |n| per pixel, 0 where |n| <= 1e-6 (no direction to keep). */
void hd_normal_renormalise(hd_image *normal)
{
    if (!normal || !normal->data || normal->channels != 3) return;
    const size_t np = (size_t)normal->width * normal->height;
    float *x = normal->data, *y = x + np, *z = y + np;
    for (size_t p = 0; p < np; p++) {
        float len = sqrtf(x[p] * x[p] + y[p] * y[p] + z[p] * z[p]);
        float inv = len > 1e-6f ? 1.0f / len : 0.0f;
        x[p] *= inv, y[p] *= inv, z[p] *= inv;
    }
}

hd_status hd_normal_resize(const hd_image *normal, int width, int height, hd_image *out)
{
    memset(out, 0, sizeof *out);
    if (!normal || !normal->data || normal->channels != 3)
        return hd_fail(HD_ERR_ARG, "normals need 3 channels, not %d", normal ? normal->channels : 0);
    hd_status st = hd_image_resize(normal, width, height, out);
    if (st == HD_OK) hd_normal_renormalise(out);
    return st;
}
