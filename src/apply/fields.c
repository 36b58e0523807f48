/* fields.c: the smooth scalar fields of the relighting rule: filling unknown values from what is
 * around them (push-pull), filling a region's holes, Gaussian blurring, and feather weights that
 * fall to 0 at a region's edge (inside it) or beyond it (outside). One plane of floats each, w x h,
 * row-major. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "apply/apply.h"

/* One level of the push-pull pyramid: values pre-multiplied by their weights. */
static hd_status fill_level(float *v, float *wt, int w, int h)
{
    int W2 = (w + 1) / 2, H2 = (h + 1) / 2;
    int done = 1;
    for (size_t p = 0; p < (size_t)w * h; p++) done &= wt[p] >= 1.0f;
    if (done) return HD_OK;
    if (w == 1 && h == 1) return HD_OK;
    float *cv = hd_calloc((size_t)W2 * H2, sizeof(float)), *cw = hd_calloc((size_t)W2 * H2, sizeof(float));
    if (!cv || !cw) {
        free(cv), free(cw);
        return HD_ERR_NOMEM;
    }
    /* push: 2 x 2 sums of the weighted values and weights (weights capped at 1 a coarse cell) */
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            size_t c = (size_t)(y / 2) * W2 + x / 2, p = (size_t)y * w + x;
            cv[c] += v[p] * wt[p];
            cw[c] += wt[p];
        }
    for (size_t c = 0; c < (size_t)W2 * H2; c++)
        if (cw[c] > 0) {
            cv[c] /= cw[c];
            if (cw[c] > 1.0f) cw[c] = 1.0f;
        }
    hd_status st = fill_level(cv, cw, W2, H2);
    /* pull: what a texel lacks in weight comes from the coarser level, bilinearly */
    for (int y = 0; st == HD_OK && y < h; y++)
        for (int x = 0; x < w; x++) {
            size_t p = (size_t)y * w + x;
            if (wt[p] >= 1.0f) continue;
            float fx = (x + 0.5f) / 2 - 0.5f, fy = (y + 0.5f) / 2 - 0.5f;
            int x0 = (int)floorf(fx), y0 = (int)floorf(fy);
            float ax = fx - x0, ay = fy - y0, acc = 0, wsum = 0;
            for (int dy = 0; dy < 2; dy++)
                for (int dx = 0; dx < 2; dx++) {
                    int sx = x0 + dx, sy = y0 + dy;
                    sx = sx < 0 ? 0 : sx >= W2 ? W2 - 1 : sx;
                    sy = sy < 0 ? 0 : sy >= H2 ? H2 - 1 : sy;
                    float k = (dx ? ax : 1 - ax) * (dy ? ay : 1 - ay);
                    acc += k * cv[(size_t)sy * W2 + sx];
                    wsum += k;
                }
            float coarse = acc / wsum, a = wt[p] < 0 ? 0 : wt[p];
            v[p] = a * v[p] + (1 - a) * coarse;
            wt[p] = 1.0f;
        }
    free(cv), free(cw);
    return st;
}

hd_status hd_field_fill(float *v, const float *known, int w, int h)
{
    size_t n = (size_t)w * h;
    float *wt = hd_malloc((n ? n : 1) * sizeof(float));
    if (!wt) return HD_ERR_NOMEM;
    int any = 0;
    for (size_t p = 0; p < n; p++) {
        wt[p] = known[p] > 0.5f ? 1.0f : 0.0f;
        if (wt[p] == 0.0f) v[p] = 0.0f;
        any |= wt[p] > 0;
    }
    hd_status st = any ? fill_level(v, wt, w, h) : HD_OK;
    free(wt);
    return st;
}

hd_status hd_field_blur(float *v, int w, int h, float sigma)
{
    if (sigma <= 0.3f) return HD_OK;
    int r = (int)ceilf(3.0f * sigma);
    float *k = hd_malloc((size_t)(2 * r + 1) * sizeof(float));
    size_t n = (size_t)w * h;
    float *tmp = hd_malloc((n ? n : 1) * sizeof(float));
    if (!k || !tmp) {
        free(k), free(tmp);
        return HD_ERR_NOMEM;
    }
    float sum = 0;
    for (int i = -r; i <= r; i++) sum += k[i + r] = expf(-0.5f * (float)(i * i) / (sigma * sigma));
    for (int i = 0; i <= 2 * r; i++) k[i] /= sum;
    /* separable; the picture's edge is extended (clamped indices) */
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            float acc = 0;
            for (int i = -r; i <= r; i++) {
                int sx = x + i < 0 ? 0 : x + i >= w ? w - 1 : x + i;
                acc += k[i + r] * v[(size_t)y * w + sx];
            }
            tmp[(size_t)y * w + x] = acc;
        }
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            float acc = 0;
            for (int i = -r; i <= r; i++) {
                int sy = y + i < 0 ? 0 : y + i >= h ? h - 1 : y + i;
                acc += k[i + r] * tmp[(size_t)sy * w + x];
            }
            v[(size_t)y * w + x] = acc;
        }
    free(k), free(tmp);
    return HD_OK;
}

hd_status hd_field_fill_holes(float *inside, int w, int h)
{
    const size_t n = (size_t)w * h;
    if (n == 0) return HD_OK;
    unsigned char *reached = hd_calloc(n, 1);
    size_t *queue = hd_malloc(n * sizeof *queue);
    if (!reached || !queue) {
        free(reached), free(queue);
        return HD_ERR_NOMEM;
    }
    /* breadth-first from the outside pixels on the picture's edge, through outside pixels */
    size_t head = 0, tail = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            const size_t p = (size_t)y * w + x;
            if ((x == 0 || y == 0 || x == w - 1 || y == h - 1) && inside[p] <= 0.5f) reached[p] = 1, queue[tail++] = p;
        }
    while (head < tail) {
        const size_t p = queue[head++];
        const int x = (int)(p % (size_t)w), y = (int)(p / (size_t)w);
        const size_t next[4] = {x > 0 ? p - 1 : p, x + 1 < w ? p + 1 : p, y > 0 ? p - (size_t)w : p,
                                y + 1 < h ? p + (size_t)w : p};
        for (int k = 0; k < 4; k++)
            if (!reached[next[k]] && inside[next[k]] <= 0.5f) reached[next[k]] = 1, queue[tail++] = next[k];
    }
    for (size_t p = 0; p < n; p++)
        if (!reached[p] && inside[p] <= 0.5f) inside[p] = 1.0f;
    free(reached), free(queue);
    return HD_OK;
}

float hd_field_smoothstep(float t) { return t <= 0 ? 0 : t >= 1 ? 1 : t * t * (3 - 2 * t); }

/* d = the chamfer distance of each pixel to the nearest pixel outside the region (0 there): the
 * region is where inside is > 0.5, or with invert where it is <= 0.5. With edge_outside the
 * picture's edge counts as outside too (a border pixel is one step in). */
static void chamfer_distance(const float *inside, int w, int h, int invert, int edge_outside, float *d)
{
    const float big = 1e30f, a = 1.0f, b = 1.41421356f; /* chamfer steps: edge and diagonal */
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            size_t p = (size_t)y * w + x;
            const int border = edge_outside && (x == 0 || y == 0 || x == w - 1 || y == h - 1);
            const int in = (inside[p] > 0.5f) != (invert != 0);
            d[p] = !in ? 0.0f : border ? a : big;
        }
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            size_t p = (size_t)y * w + x;
            float v = d[p];
            if (x > 0) v = fminf(v, d[p - 1] + a);
            if (y > 0) v = fminf(v, d[p - w] + a);
            if (x > 0 && y > 0) v = fminf(v, d[p - w - 1] + b);
            if (x + 1 < w && y > 0) v = fminf(v, d[p - w + 1] + b);
            d[p] = v;
        }
    for (int y = h - 1; y >= 0; y--)
        for (int x = w - 1; x >= 0; x--) {
            size_t p = (size_t)y * w + x;
            float v = d[p];
            if (x + 1 < w) v = fminf(v, d[p + 1] + a);
            if (y + 1 < h) v = fminf(v, d[p + w] + a);
            if (x + 1 < w && y + 1 < h) v = fminf(v, d[p + w + 1] + b);
            if (x > 0 && y + 1 < h) v = fminf(v, d[p + w - 1] + b);
            d[p] = v;
        }
}

hd_status hd_field_feather(const float *inside, int w, int h, float band, float *weight)
{
    size_t n = (size_t)w * h;
    chamfer_distance(inside, w, h, 0, 1, weight);
    const float inv = band > 0 ? 1.0f / band : 0.0f;
    for (size_t p = 0; p < n; p++)
        weight[p] = band > 0 ? hd_field_smoothstep(weight[p] * inv) : (weight[p] > 0 ? 1.0f : 0.0f);
    return HD_OK;
}

hd_status hd_field_feather_out(const float *inside, int w, int h, float band, float *weight)
{
    size_t n = (size_t)w * h;
    chamfer_distance(inside, w, h, 1, 0, weight); /* the distance from the region, 0 inside it */
    const float inv = band > 0 ? 1.0f / band : 0.0f;
    for (size_t p = 0; p < n; p++)
        weight[p] = band > 0 ? 1.0f - hd_field_smoothstep(weight[p] * inv) : (weight[p] > 0 ? 0.0f : 1.0f);
    return HD_OK;
}
