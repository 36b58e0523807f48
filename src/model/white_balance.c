/* white_balance.c: the camera's colour cast of an aligned face, read from the whites of its eyes
 * (docs/usage.md, "White balance"). The sclera is the one part of a face whose colour varies
 * little from person to person, so the chroma of the brighter half of the texels inside the two eye
 * contours (the darker half is iris, pupil and lashes), against the chroma the synthetic faces'
 * sclera has, says how the camera tinted the picture. With HD_WHITE_BALANCE_EYES,
 * hd_model_decompose divides the tint out before the network sees the face (it was trained mostly
 * on faces of neutral balance) and puts it back into the reconstruction. Off by default: at 128
 * texels an eye opening is about five rows tall, and blur or JPEG's halved chroma mixes the skin's
 * colour into it (docs/usage.md has the figures). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "mesh/mesh.h"
#include "model/white_balance.h"

/* The sclera's chroma (rgb / mean of rgb) in the synthetic faces' albedo: the mean of this file's
 * estimate over the ground-truth albedo of 400 images of `hdnet synth --seed 3001 --size 128`
 * (per-image standard deviation 0.014, 0.003, 0.013). On the aligned studio photos of faces-london
 * (124 photos) the tint reads 1.035, 0.973, 0.992 (sd 0.041, 0.016, 0.033). */
const float hd_sclera_chroma[3] = {1.0544f, 0.9947f, 0.9509f};
/* The darkest texel that counts as an eye white (masked-out texels are 0) */
#define MIN_LUMINANCE 0.02f
/* Fewer eye-white texels than this: no estimate (tint 1, 1, 1) */
#define MIN_TEXELS 8

static const float LUMA[3] = {0.2126f, 0.7152f, 0.0722f};

static int by_value(const void *a, const void *b)
{
    float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

hd_status hd_eyes_uv(int size, hd_image *eyes)
{
    static const int *const EYES[2] = {hd_contour_right_eye, hd_contour_left_eye};
    return hd_mesh_contours_uv(EYES, 2, 0.0f, size, eyes);
}

hd_status hd_eye_tint(const float *rgb, int size, const float *eyes, float tint[3])
{
    tint[0] = tint[1] = tint[2] = 1.0f;
    const size_t P = (size_t)size * size;
    size_t n = 0;
    for (size_t p = 0; p < P; p++) n += eyes[p] > 0.5f;
    if (n < MIN_TEXELS) return HD_OK;
    float *lum = hd_malloc(n * sizeof *lum);
    if (!lum) return HD_ERR_NOMEM;
    size_t k = 0;
    for (size_t p = 0; p < P; p++)
        if (eyes[p] > 0.5f) lum[k++] = LUMA[0] * rgb[p] + LUMA[1] * rgb[P + p] + LUMA[2] * rgb[2 * P + p];
    qsort(lum, n, sizeof *lum, by_value);
    float median = lum[n / 2], lo = median > MIN_LUMINANCE ? median : MIN_LUMINANCE;
    free(lum);
    double sum[3] = {0, 0, 0};
    size_t used = 0;
    for (size_t p = 0; p < P; p++) {
        if (!(eyes[p] > 0.5f)) continue;
        float l = LUMA[0] * rgb[p] + LUMA[1] * rgb[P + p] + LUMA[2] * rgb[2 * P + p];
        if (!(l >= lo) || !isfinite(l)) continue;
        for (int c = 0; c < 3; c++) sum[c] += rgb[(size_t)c * P + p];
        used++;
    }
    double mean = (sum[0] + sum[1] + sum[2]) / 3;
    if (used < MIN_TEXELS / 2 || !(mean > 0)) return HD_OK;
    float t[3];
    double tmean = 0;
    for (int c = 0; c < 3; c++) t[c] = (float)(sum[c] / mean) / hd_sclera_chroma[c], tmean += t[c] / 3.0;
    for (int c = 0; c < 3; c++) {
        float v = (float)(t[c] / tmean);
        tint[c] = v < HD_TINT_MIN ? HD_TINT_MIN : v > HD_TINT_MAX ? HD_TINT_MAX : v;
    }
    return HD_OK;
}

hd_status hd_eye_white_balance(const hd_image *texture, float tint[3])
{
    tint[0] = tint[1] = tint[2] = 1.0f;
    if (!texture || !texture->data || texture->channels != 3 || texture->width != texture->height ||
        texture->width < 1)
        return hd_fail(HD_ERR_ARG, "white balance: an aligned face texture is a square RGB image");
    hd_image eyes = {0};
    hd_status st = hd_eyes_uv(texture->width, &eyes);
    if (st == HD_OK) st = hd_eye_tint(texture->data, texture->width, eyes.data, tint);
    hd_image_free(&eyes);
    return st;
}
