/* camera.c: what a camera does to a rendered synthetic face, applied to the image only (the ground
 * truth stays that of the scene): a coloured light, defocus blur, sensor noise, the camera's white
 * balance and JPEG compression at a random quality, in that order. Each effect is applied with its
 * probability, its parameters drawn from the image's own stream (seed, subject, image) mixed with
 * SYN_CAMERA_STREAM, so a set is still a pure function of its seed, and the draws do not depend on
 * which effects are enabled (each effect draws all its numbers whether applied or not). */
#include <math.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <jpeglib.h>
#include "synth/synth_internal.h"
#include "synth/synth.h"

#define SYN_CAMERA_STREAM 0x63616d657261ull /* "camera" */

/* Per-channel gains with mean 1: a warm (t > 0) or cool (t < 0) tint of up to 30 % in red against
 * blue, and g of green against magenta. */
static void tint_gains(float t, float g, float gain[3])
{
    float r = 1.0f + 0.3f * t, gr = 1.0f + g, b = 1.0f - 0.3f * t, mean = (r + gr + b) / 3.0f;
    gain[0] = r / mean;
    gain[1] = gr / mean;
    gain[2] = b / mean;
}

/* Gaussian blur of the masked image, normalised by the blurred mask (the face's edge does not
 * darken): separable, radius 3 sigma. */
static hd_status blur_masked(float *img, const float *mask, int S, float sigma)
{
    int R = (int)ceilf(3.0f * sigma);
    size_t P = (size_t)S * S;
    float *k = malloc((size_t)(2 * R + 1) * sizeof(float)), *tmp = malloc(4 * P * sizeof(float));
    float *out = malloc(4 * P * sizeof(float));
    if (!k || !tmp || !out) {
        free(k);
        free(tmp);
        free(out);
        return HD_ERR_NOMEM;
    }
    for (int i = -R; i <= R; i++) k[i + R] = expf(-0.5f * (float)(i * i) / (sigma * sigma));
    /* planes: m*r, m*g, m*b, m */
    for (size_t p = 0; p < P; p++) {
        for (int c = 0; c < 3; c++) out[c * P + p] = img[c * P + p] * mask[p];
        out[3 * P + p] = mask[p];
    }
    for (int c = 0; c < 4; c++) {
        const float *src = out + c * P;
        float *dst = tmp + c * P;
        for (int y = 0; y < S; y++)
            for (int x = 0; x < S; x++) {
                float s = 0;
                for (int i = -R; i <= R; i++) {
                    int xx = x + i < 0 ? 0 : x + i >= S ? S - 1 : x + i;
                    s += k[i + R] * src[(size_t)y * S + xx];
                }
                dst[(size_t)y * S + x] = s;
            }
        for (int y = 0; y < S; y++)
            for (int x = 0; x < S; x++) {
                float s = 0;
                for (int i = -R; i <= R; i++) {
                    int yy = y + i < 0 ? 0 : y + i >= S ? S - 1 : y + i;
                    s += k[i + R] * dst[(size_t)yy * S + x];
                }
                out[c * P + (size_t)y * S + x] = s;
            }
    }
    for (size_t p = 0; p < P; p++) {
        if (mask[p] <= 0.0f) continue;
        float w = out[3 * P + p];
        for (int c = 0; c < 3; c++) img[c * P + p] = w > 1e-6f ? out[c * P + p] / w : img[c * P + p];
    }
    free(k);
    free(tmp);
    free(out);
    return HD_OK;
}

typedef struct jpeg_fail {
    struct jpeg_error_mgr mgr; /* first: the error manager pointer is the context */
    jmp_buf jump;
} jpeg_fail;

static void on_jpeg_error(j_common_ptr cinfo) { longjmp(((jpeg_fail *)cinfo->err)->jump, 1); }

/* Encodes the image as an 8-bit JPEG of this quality in memory and decodes it back. */
static hd_status jpeg_round_trip(float *img, int S, int quality)
{
    size_t P = (size_t)S * S;
    unsigned char *rgb = malloc(3 * P), *buf = NULL;
    unsigned long len = 0;
    if (!rgb) return HD_ERR_NOMEM;
    for (size_t p = 0; p < P; p++)
        for (int c = 0; c < 3; c++) {
            float v = img[c * P + p];
            rgb[3 * p + (size_t)c] = (unsigned char)lrintf(255.0f * (v < 0 ? 0 : v > 1 ? 1 : v));
        }
    struct jpeg_compress_struct ci;
    struct jpeg_decompress_struct di;
    jpeg_fail fail;
    volatile int made_c = 0, made_d = 0;
    ci.err = jpeg_std_error(&fail.mgr);
    di.err = ci.err;
    fail.mgr.error_exit = on_jpeg_error;
    if (setjmp(fail.jump)) {
        if (made_c) jpeg_destroy_compress(&ci);
        if (made_d) jpeg_destroy_decompress(&di);
        free(rgb);
        free(buf);
        return hd_fail(HD_ERR_FORMAT, "synth: the in-memory JPEG round trip failed");
    }
    jpeg_create_compress(&ci);
    made_c = 1;
    jpeg_mem_dest(&ci, &buf, &len);
    ci.image_width = (JDIMENSION)S;
    ci.image_height = (JDIMENSION)S;
    ci.input_components = 3;
    ci.in_color_space = JCS_RGB;
    jpeg_set_defaults(&ci);
    jpeg_set_quality(&ci, quality, TRUE);
    jpeg_start_compress(&ci, TRUE);
    while (ci.next_scanline < ci.image_height) {
        JSAMPROW row = rgb + (size_t)ci.next_scanline * 3 * S;
        jpeg_write_scanlines(&ci, &row, 1);
    }
    jpeg_finish_compress(&ci);
    jpeg_destroy_compress(&ci);
    made_c = 0;
    jpeg_create_decompress(&di);
    made_d = 1;
    jpeg_mem_src(&di, buf, len);
    jpeg_read_header(&di, TRUE);
    di.out_color_space = JCS_RGB;
    jpeg_start_decompress(&di);
    while (di.output_scanline < di.output_height) {
        JSAMPROW row = rgb + (size_t)di.output_scanline * 3 * S;
        jpeg_read_scanlines(&di, &row, 1);
    }
    jpeg_finish_decompress(&di);
    jpeg_destroy_decompress(&di);
    made_d = 0;
    for (size_t p = 0; p < P; p++)
        for (int c = 0; c < 3; c++) img[c * P + p] = rgb[3 * p + (size_t)c] / 255.0f;
    free(rgb);
    free(buf);
    return HD_OK;
}

static float gauss(hd_rng *r)
{
    float u = hd_rng_range(r, 1e-7f, 1.0f), v = hd_rng_uniform(r);
    return sqrtf(-2.0f * logf(u)) * cosf(2.0f * (float)M_PI * v);
}

hd_status hd_synth_camera_apply(hd_synth_face *f, const hd_synth_camera *cam, uint64_t seed, int subject, int image,
                                hd_synth_camera_record *rec)
{
    hd_synth_camera_record none;
    if (!rec) rec = &none;
    memset(rec, 0, sizeof *rec);
    if (!(cam->probability >= 0.0f && cam->probability <= 1.0f))
        return hd_fail(HD_ERR_RANGE, "synth: camera effect probability %g outside [0, 1]", cam->probability);
    if (cam->probability == 0.0f || cam->effects == 0) return HD_OK;
    int S = f->image.width;
    size_t P = (size_t)S * S;
    float *img = f->image.data;
    const float *m = f->mask.data, *A = f->albedo.data, *sh = f->shading.data;
    hd_rng r;
    syn_rng(&r, seed ^ SYN_CAMERA_STREAM, subject, image);
    /* every draw is made whatever is enabled, so that one effect's parameters do not depend on
     * another's switch */
    float pc = hd_rng_uniform(&r), lt = hd_rng_range(&r, -1.0f, 1.0f), lg = hd_rng_range(&r, -0.05f, 0.05f);
    float pb = hd_rng_uniform(&r), sigma = hd_rng_range(&r, 0.3f, 1.5f);
    float pn = hd_rng_uniform(&r), nread = hd_rng_range(&r, 0.003f, 0.02f), nshot = hd_rng_range(&r, 0.0f, 0.0004f);
    float pw = hd_rng_uniform(&r), wt = hd_rng_range(&r, -1.0f, 1.0f), wg = hd_rng_range(&r, -0.05f, 0.05f);
    float pj = hd_rng_uniform(&r);
    int quality = 40 + (int)hd_rng_below(&r, 56); /* 40 .. 95 */
    uint64_t noise_seed = hd_rng_u32(&r);
    float p = cam->probability;
    if ((cam->effects & HD_SYNTH_CAMERA_LIGHT_COLOUR) && pc < p) {
        /* the scene's light is coloured: image = clamp(A * s * gain) */
        tint_gains(lt, lg, rec->light_gain);
        rec->applied |= HD_SYNTH_CAMERA_LIGHT_COLOUR;
        for (size_t q = 0; q < P; q++) {
            if (m[q] <= 0.0f) continue;
            for (int c = 0; c < 3; c++) {
                float v = A[c * P + q] * sh[q] * rec->light_gain[c];
                img[c * P + q] = v < 0 ? 0 : v > 1 ? 1 : v;
            }
        }
    }
    if ((cam->effects & HD_SYNTH_CAMERA_BLUR) && pb < p) {
        rec->blur_sigma = sigma;
        rec->applied |= HD_SYNTH_CAMERA_BLUR;
        hd_status s = blur_masked(img, m, S, sigma);
        if (s != HD_OK) return s;
    }
    if ((cam->effects & HD_SYNTH_CAMERA_NOISE) && pn < p) {
        /* read noise plus shot noise: variance nread^2 + nshot * I */
        rec->noise_read = nread;
        rec->noise_shot = nshot;
        rec->applied |= HD_SYNTH_CAMERA_NOISE;
        hd_rng nr;
        syn_rng(&nr, seed ^ SYN_CAMERA_STREAM ^ noise_seed, subject, image);
        for (size_t q = 0; q < P; q++)
            for (int c = 0; c < 3; c++) {
                float v = img[c * P + q], sd = sqrtf(nread * nread + nshot * (v > 0 ? v : 0));
                v += sd * gauss(&nr);
                img[c * P + q] = v < 0 ? 0 : v > 1 ? 1 : v;
            }
    }
    if ((cam->effects & HD_SYNTH_CAMERA_WHITE_BALANCE) && pw < p) {
        tint_gains(wt, wg, rec->wb_gain);
        rec->applied |= HD_SYNTH_CAMERA_WHITE_BALANCE;
        for (size_t q = 0; q < P; q++)
            for (int c = 0; c < 3; c++) {
                float v = img[c * P + q] * rec->wb_gain[c];
                img[c * P + q] = v > 1 ? 1 : v;
            }
    }
    if ((cam->effects & HD_SYNTH_CAMERA_JPEG) && pj < p) {
        rec->jpeg_quality = quality;
        rec->applied |= HD_SYNTH_CAMERA_JPEG;
        hd_status s = jpeg_round_trip(img, S, quality);
        if (s != HD_OK) return s;
    }
    /* outside the mask stays 0, as in every synthetic image */
    for (size_t q = 0; q < P; q++)
        if (m[q] <= 0.0f)
            for (int c = 0; c < 3; c++) img[c * P + q] = 0.0f;
    return HD_OK;
}
