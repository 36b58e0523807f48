/* image.c: the in-memory image (planar float32, data[(c * H + y) * W + x]): allocation, channel
 * conversion and resizing (area filter down, bilinear up, per axis). Reading and writing files and
 * buffers: image_codec.c. */
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "io/image_io.h"

/* Files hold 1-4 channels; in memory an image may carry more (stacked maps). */
#define HD_IMAGE_MAX_CHANNELS 1024

hd_status hd_image_alloc(hd_image *img, int width, int height, int channels)
{
    if (width <= 0 || height <= 0 || channels <= 0 || width > HD_IMAGE_MAX_SIDE ||
        height > HD_IMAGE_MAX_SIDE || channels > HD_IMAGE_MAX_CHANNELS)
        return hd_fail(HD_ERR_RANGE, "image size %dx%d with %d channels is out of range (sides 1..%d, "
                       "channels 1..%d)", width, height, channels, HD_IMAGE_MAX_SIDE, HD_IMAGE_MAX_CHANNELS);
    size_t n;
    if (!hd_mul3_size((size_t)width, (size_t)height, (size_t)channels, &n) ||
        !hd_mul_size(n, sizeof(float), &n))
        return hd_fail(HD_ERR_RANGE, "image size %dx%dx%d overflows", width, height, channels);
    float *data = hd_calloc(n / sizeof(float), sizeof(float));
    if (!data) return HD_ERR_NOMEM;
    img->width = width;
    img->height = height;
    img->channels = channels;
    img->data = data;
    return HD_OK;
}

void hd_image_free(hd_image *img)
{
    if (!img) return;
    free(img->data);
    memset(img, 0, sizeof *img);
}

static long long max_pixels_set; /* 0: HDNET_MAX_PIXELS or the default */

void hd_set_max_pixels(long long pixels) { max_pixels_set = pixels > 0 ? pixels : 0; }

long long hd_max_pixels(void)
{
    if (max_pixels_set > 0) return max_pixels_set;
    const char *env = getenv("HDNET_MAX_PIXELS");
    if (env && *env) {
        char *end = NULL;
        errno = 0;
        long long v = strtoll(env, &end, 10);
        if (end != env && *end == '\0' && errno == 0 && v > 0) return v;
    }
    return HD_DEFAULT_MAX_PIXELS;
}

hd_status hd_image_check_dims(const char *path, long width, long height, int channels)
{
    if (width <= 0 || height <= 0)
        return hd_fail(HD_ERR_FORMAT, "%s: image size %ldx%ld is empty", path, width, height);
    if (width > HD_IMAGE_MAX_SIDE || height > HD_IMAGE_MAX_SIDE)
        return hd_fail(HD_ERR_RANGE, "%s: image size %ldx%ld exceeds the limit of %d per side", path,
                       width, height, HD_IMAGE_MAX_SIDE);
    long long limit = hd_max_pixels();
    if ((long long)width * height > limit)
        return hd_fail(HD_ERR_RANGE, "%s: image size %ldx%ld (%lld pixels) exceeds the limit of %lld pixels (raise it with "
                       "HDNET_MAX_PIXELS)", path, width, height, (long long)width * height, limit);
    size_t n;
    if (!hd_mul3_size((size_t)width, (size_t)height, (size_t)channels, &n) ||
        !hd_mul_size(n, sizeof(float), &n))
        return hd_fail(HD_ERR_RANGE, "%s: image size %ldx%ldx%d overflows", path, width, height, channels);
    return HD_OK;
}

hd_status hd_image_check_finite(const hd_image *img, const char *what)
{
    size_t plane = (size_t)img->width * img->height, n = plane * img->channels, bad = 0, first = 0;
    for (size_t i = 0; i < n; i++)
        if (!isfinite(img->data[i]) && bad++ == 0) first = i;
    if (!bad) return HD_OK;
    size_t c = first / plane, y = first % plane / img->width, x = first % img->width;
    return hd_fail(HD_ERR_NUMERIC, "%s: %zu of %zu samples are not finite (first at channel %zu, x %zu, y %zu)", what,
                   bad, n, c, x, y);
}

hd_status hd_image_read_as(const char *path, int channels, hd_image *img)
{
    hd_image raw = {0};
    hd_status st = hd_image_read(path, &raw);
    if (st != HD_OK) return st;
    if (raw.channels == channels) {
        *img = raw;
        return HD_OK;
    }
    st = hd_image_convert(&raw, channels, img);
    hd_image_free(&raw);
    return st;
}

/* Converts between 1 (gray), 2 (gray+alpha), 3 (RGB) and 4 (RGBA) channels: gray from colour is
 * the luma y = 0.299 r + 0.587 g + 0.114 b, colour from gray replicates it, a missing alpha is 1
 * and an unwanted one is dropped. */
hd_status hd_image_convert(const hd_image *src, int channels, hd_image *dst)
{
    if (!src || !src->data || src->channels < 1 || src->channels > 4 || channels < 1 || channels > 4)
        return hd_fail(HD_ERR_ARG, "image conversion from %d to %d channels is not supported",
                       src ? src->channels : 0, channels);
    hd_image out = {0};
    hd_status st = hd_image_alloc(&out, src->width, src->height, channels);
    if (st != HD_OK) return st;
    size_t np = (size_t)src->width * src->height;
    int sc = src->channels;
    const float *s0 = src->data, *s1 = src->data + np, *s2 = src->data + 2 * np;
    int src_colour = sc >= 3, src_alpha = sc == 2 || sc == 4;
    const float *sa = src_alpha ? src->data + (size_t)(sc - 1) * np : NULL;
    int dst_colour = channels >= 3, dst_alpha = channels == 2 || channels == 4;
    for (size_t p = 0; p < np; p++) {
        float r, g, b;
        if (src_colour) {
            r = s0[p];
            g = s1[p];
            b = s2[p];
        } else {
            r = g = b = s0[p];
        }
        if (dst_colour) {
            out.data[p] = r;
            out.data[np + p] = g;
            out.data[2 * np + p] = b;
        } else {
            out.data[p] = src_colour ? 0.299f * r + 0.587f * g + 0.114f * b : r;
        }
        if (dst_alpha) out.data[(size_t)(channels - 1) * np + p] = sa ? sa[p] : 1.0f;
    }
    *dst = out;
    return HD_OK;
}

/* The resampling weights of one axis: output i reads taps[first[i] .. first[i] + count[i]). */
typedef struct axis_filter {
    int *first, *count;
    int *index;    /* source index of each tap */
    float *weight; /* weight of each tap */
} axis_filter;

static void axis_filter_free(axis_filter *a)
{
    free(a->first);
    free(a->count);
    free(a->index);
    free(a->weight);
}

/* Builds the filter mapping n source samples to m outputs.
 * Shrinking (m < n): exact box averaging. Output i covers source [i n/m, (i+1) n/m); in units of
 * 1/m, sample j covers [j m, (j+1) m), so its weight is |overlap| / n (integer overlaps: exact).
 * Enlarging (m > n): bilinear with half-pixel centres, x = (i + 0.5) n/m - 0.5 clamped to
 * [0, n-1], out = (1 - t) s[floor x] + t s[floor x + 1]. Equal sizes: identity. */
static hd_status axis_filter_build(axis_filter *a, int n, int m)
{
    memset(a, 0, sizeof *a);
    int max_taps = m < n ? n / m + 2 : 2;
    size_t ntaps = (size_t)m * (size_t)max_taps;
    a->first = hd_malloc((size_t)m * sizeof(int));
    a->count = hd_malloc((size_t)m * sizeof(int));
    a->index = hd_malloc(ntaps * sizeof(int));
    a->weight = hd_malloc(ntaps * sizeof(float));
    if (!a->first || !a->count || !a->index || !a->weight) {
        axis_filter_free(a);
        return HD_ERR_NOMEM;
    }
    int t = 0;
    for (int i = 0; i < m; i++) {
        a->first[i] = t;
        if (m == n) {
            a->index[t] = i;
            a->weight[t++] = 1.0f;
        } else if (m < n) {
            int64_t lo = (int64_t)i * n, hi = (int64_t)(i + 1) * n;
            for (int j = (int)(lo / m); j < n && (int64_t)j * m < hi; j++) {
                int64_t a0 = (int64_t)j * m > lo ? (int64_t)j * m : lo;
                int64_t a1 = (int64_t)(j + 1) * m < hi ? (int64_t)(j + 1) * m : hi;
                if (a1 <= a0) continue;
                a->index[t] = j;
                a->weight[t++] = (float)((double)(a1 - a0) / (double)n);
            }
        } else {
            double x = ((double)i + 0.5) * (double)n / (double)m - 0.5;
            if (x < 0) x = 0;
            if (x > n - 1) x = n - 1;
            int x0 = (int)floor(x);
            double frac = x - x0;
            int x1 = x0 + 1 < n ? x0 + 1 : n - 1;
            a->index[t] = x0;
            a->weight[t++] = (float)(1.0 - frac);
            if (frac > 0) {
                a->index[t] = x1;
                a->weight[t++] = (float)frac;
            }
        }
        a->count[i] = t - a->first[i];
    }
    return HD_OK;
}

hd_status hd_image_resize(const hd_image *src, int width, int height, hd_image *dst)
{
    if (!src || !src->data || src->width <= 0 || src->height <= 0)
        return hd_fail(HD_ERR_ARG, "resize of an empty image");
    hd_image out = {0}, tmp = {0};
    hd_status st = hd_image_alloc(&out, width, height, src->channels);
    if (st != HD_OK) return st;
    st = hd_image_alloc(&tmp, width, src->height, src->channels);
    if (st != HD_OK) {
        hd_image_free(&out);
        return st;
    }
    axis_filter fx, fy;
    if ((st = axis_filter_build(&fx, src->width, width)) != HD_OK) goto done;
    if ((st = axis_filter_build(&fy, src->height, height)) != HD_OK) {
        axis_filter_free(&fx);
        goto done;
    }
    /* Horizontal pass: src (C, H, W) -> tmp (C, H, width). */
    int rows = src->channels * src->height;
#pragma omp parallel for schedule(static) if ((long)rows * width > 65536)
    for (int r = 0; r < rows; r++) {
        const float *s = src->data + (size_t)r * src->width;
        float *d = tmp.data + (size_t)r * width;
        for (int i = 0; i < width; i++) {
            float acc = 0;
            for (int k = fx.first[i]; k < fx.first[i] + fx.count[i]; k++) acc += fx.weight[k] * s[fx.index[k]];
            d[i] = acc;
        }
    }
    /* Vertical pass: tmp (C, H, width) -> out (C, height, width). */
    int orows = src->channels * height;
#pragma omp parallel for schedule(static) if ((long)orows * width > 65536)
    for (int r = 0; r < orows; r++) {
        int c = r / height, y = r % height;
        float *d = out.data + (size_t)r * width;
        for (int x = 0; x < width; x++) d[x] = 0;
        for (int k = fy.first[y]; k < fy.first[y] + fy.count[y]; k++) {
            const float *s = tmp.data + ((size_t)c * src->height + fy.index[k]) * width;
            float w = fy.weight[k];
            for (int x = 0; x < width; x++) d[x] += w * s[x];
        }
    }
    axis_filter_free(&fx);
    axis_filter_free(&fy);
done:
    hd_image_free(&tmp);
    if (st != HD_OK) {
        hd_image_free(&out);
        return st;
    }
    *dst = out;
    return HD_OK;
}
