/* photo_metrics.c: how a relit photograph holds up without ground truth (issue 12, docs/usage.md
 * "Measuring relighting"). Each score compares a relit photo with its input over the pixels the
 * relighting changed: chroma (colour shift), detail (Laplacian of log-luminance kept), glow (the
 * eyes follow the light), seam (the change has no edge), self (identity under the face's own light).
 * Pure functions on in-memory images; the run over folders is photo_eval.c. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "eval/photo_metrics.h"

/* Chroma is undefined on black: a pixel counts when both r + g + b exceed this. */
#define CHROMA_MIN_SUM 0.06
/* log-luminance offset (one 8-bit step) and the luminance below which a ratio is not taken */
#define LOG_EPS (1.0 / 255.0)
#define RATIO_MIN_LUM 0.02
/* seam when the inside of the change has no gradient at all */
#define SEAM_EPS 1e-9
/* a step of the photo's own log luminance this large between two pixels is an edge of the photo
 * (the person's outline), where the change may stop */
#define SEAM_PHOTO_EDGE 0.1
/* the changed region's gaps this wide (pixels) or less are closed before its edge is taken */
#define SEAM_CLOSE 5

/* Channel c of pixel p as a picture shows it: clamped to [0, 1] (NaN as 0). */
static double px(const hd_image *im, int c, size_t p)
{
    float v = im->data[(size_t)c * im->width * im->height + p];
    return v > 0.0f ? (v < 1.0f ? v : 1.0) : 0.0;
}

static double lum_at(const hd_image *im, size_t p) { return 0.2126 * px(im, 0, p) + 0.7152 * px(im, 1, p) + 0.0722 * px(im, 2, p); }

hd_status hd_photo_changed(const hd_image *input, const hd_image *relit, unsigned char **changed, long *count)
{
    *changed = NULL;
    if (count) *count = 0;
    if (!input || !relit || !input->data || !relit->data || input->channels != 3 || relit->channels != 3 ||
        input->width != relit->width || input->height != relit->height)
        return hd_fail(HD_ERR_ARG, "photo metrics: the input and the relit photo must be RGB of the same size");
    const size_t P = (size_t)input->width * (size_t)input->height;
    unsigned char *c = hd_malloc(P ? P : 1);
    if (!c) return HD_ERR_NOMEM;
    long n = 0;
    for (size_t p = 0; p < P; p++) {
        int d = 0;
        for (int k = 0; k < 3; k++) d |= input->data[k * P + p] != relit->data[k * P + p];
        c[p] = (unsigned char)d;
        n += d;
    }
    *changed = c;
    if (count) *count = n;
    return HD_OK;
}

double hd_photo_chroma(const hd_image *input, const hd_image *relit, const unsigned char *changed)
{
    const size_t P = (size_t)input->width * (size_t)input->height;
    double acc = 0.0;
    long n = 0;
    for (size_t p = 0; p < P; p++) {
        if (!changed[p]) continue;
        double si = 0, so = 0;
        for (int c = 0; c < 3; c++) si += px(input, c, p), so += px(relit, c, p);
        if (si <= CHROMA_MIN_SUM || so <= CHROMA_MIN_SUM) continue;
        double e = 0;
        for (int c = 0; c < 3; c++) e += fabs(px(relit, c, p) / so - px(input, c, p) / si);
        acc += e;
        n++;
    }
    return n ? 1000.0 * acc / (double)n : 0.0;
}

/* The 5-point Laplacian of log(lum + eps) at interior pixel (x, y). */
static double log_lap(const hd_image *im, int x, int y)
{
    const int W = im->width;
    size_t p = (size_t)y * W + x;
    double c = log(lum_at(im, p) + LOG_EPS);
    return log(lum_at(im, p - 1) + LOG_EPS) + log(lum_at(im, p + 1) + LOG_EPS) + log(lum_at(im, p - W) + LOG_EPS) +
           log(lum_at(im, p + W) + LOG_EPS) - 4.0 * c;
}

double hd_photo_detail(const hd_image *input, const hd_image *relit, const unsigned char *changed)
{
    const int W = input->width, H = input->height;
    double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
    long n = 0;
    for (int y = 1; y + 1 < H; y++)
        for (int x = 1; x + 1 < W; x++) {
            if (!changed[(size_t)y * W + x]) continue;
            double a = log_lap(input, x, y), b = log_lap(relit, x, y);
            sa += a, sb += b, saa += a * a, sbb += b * b, sab += a * b;
            n++;
        }
    if (n < 2) return 1.0;
    double va = saa - sa * sa / n, vb = sbb - sb * sb / n, cov = sab - sa * sb / n;
    if (va <= 0 || vb <= 0) return va <= 0 && vb <= 0 ? 1.0 : 0.0;
    return cov / sqrt(va * vb);
}

double hd_photo_glow(const hd_image *input, const hd_image *relit, const unsigned char *changed,
                     const float pupils[2][2])
{
    const int W = input->width, H = input->height;
    double dx = pupils[1][0] - pupils[0][0], dy = pupils[1][1] - pupils[0][1];
    double r = 0.12 * sqrt(dx * dx + dy * dy), r2 = r * r;
    double eye = 0, face = 0;
    long ne = 0, nf = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            size_t p = (size_t)y * W + x;
            double li = lum_at(input, p);
            if (li <= RATIO_MIN_LUM) continue;
            double q = lum_at(relit, p) / li;
            if (changed[p]) face += q, nf++;
            for (int e = 0; e < 2; e++) {
                double ex = x + 0.5 - pupils[e][0], ey = y + 0.5 - pupils[e][1];
                if (ex * ex + ey * ey <= r2) eye += q, ne++;
            }
        }
    if (!ne || !nf || face <= 0) return 1.0;
    return (eye / ne) / (face / nf);
}

/* One pass of the max (grow) or min (shrink) of the W x H 0 / 1 mask m over the 2 r + 1 pixels
 * centred on each, along x or along y, into out; pixels beyond the picture count for nothing. */
static void morph_pass(const unsigned char *m, int W, int H, int along_x, int grow, int r, unsigned char *out)
{
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            int v = grow ? 0 : 1;
            for (int k = -r; k <= r; k++) {
                const int xx = along_x ? x + k : x, yy = along_x ? y : y + k;
                if (xx < 0 || yy < 0 || xx >= W || yy >= H) continue;
                const int u = m[(size_t)yy * W + xx];
                v = grow ? (v | u) : (v & u);
            }
            out[(size_t)y * W + x] = (unsigned char)v;
        }
}

double hd_photo_seam(const hd_image *input, const hd_image *relit, const unsigned char *changed_pixels)
{
    const int W = input->width, H = input->height;
    const size_t P = (size_t)W * (size_t)H;
    float *d = hd_malloc((P ? P : 1) * sizeof(float));
    unsigned char *changed = hd_malloc(P ? P : 1), *tmp = hd_malloc(P ? P : 1);
    if (!d || !changed || !tmp) {
        free(d), free(changed), free(tmp);
        return NAN;
    }
    /* the region: the changed pixels closed by a SEAM_CLOSE-pixel square, so the line where a smooth
     * change crosses zero (its pixels round to the input's) is inside it, not its edge */
    morph_pass(changed_pixels, W, H, 1, 1, SEAM_CLOSE / 2, tmp);
    morph_pass(tmp, W, H, 0, 1, SEAM_CLOSE / 2, changed);
    morph_pass(changed, W, H, 1, 0, SEAM_CLOSE / 2, tmp);
    morph_pass(tmp, W, H, 0, 0, SEAM_CLOSE / 2, changed);
    for (size_t p = 0; p < P; p++) d[p] = (float)(lum_at(relit, p) - lum_at(input, p));
    double gb = 0, gi = 0;
    long nb = 0, ni = 0;
    for (int y = 0; y + 1 < H; y++)
        for (int x = 0; x + 1 < W; x++) {
            size_t p = (size_t)y * W + x;
            /* on the border: a 4-neighbour on the other side of the changed region's edge, with
             * no edge of the photo's own between them (where the change stops at the person's
             * outline against the background, which keeps the photo, its step is no seam) */
            const size_t q[4] = {x > 0 ? p - 1 : p, p + 1, y > 0 ? p - W : p, p + W};
            int border = 0, outline = 0;
            const double lp = log(lum_at(input, p) + LOG_EPS);
            for (int k = 0; k < 4; k++)
                if (changed[q[k]] != changed[p]) {
                    border = 1;
                    outline |= fabs(log(lum_at(input, q[k]) + LOG_EPS) - lp) > SEAM_PHOTO_EDGE;
                }
            if (border && outline) continue;
            if (!border && !changed[p]) continue;
            double gx = d[p + 1] - d[p], gy = d[p + W] - d[p], g = sqrt(gx * gx + gy * gy);
            if (border) gb += g, nb++;
            else gi += g, ni++;
        }
    free(d), free(changed), free(tmp);
    if (!nb) return 1.0;
    gb /= nb;
    gi = ni ? gi / ni : 0.0;
    return (gb + SEAM_EPS) / (gi + SEAM_EPS);
}

double hd_photo_mae(const hd_image *a, const hd_image *b, const unsigned char *where)
{
    const size_t P = (size_t)a->width * (size_t)a->height;
    double acc = 0;
    long n = 0;
    for (size_t p = 0; p < P; p++) {
        if (where && !where[p]) continue;
        for (int c = 0; c < 3; c++) acc += fabs(px(a, c, p) - px(b, c, p));
        n += 3;
    }
    return n ? acc / (double)n : 0.0;
}

double hd_photo_mean_lum_ratio(const hd_image *input, const hd_image *relit, const unsigned char *where)
{
    const size_t P = (size_t)input->width * (size_t)input->height;
    double a = 0, b = 0;
    for (size_t p = 0; p < P; p++)
        if (!where || where[p]) a += lum_at(input, p), b += lum_at(relit, p);
    return a > 0 ? b / a : 1.0;
}

double hd_light_difference(const float a[HD_SH_COEFFS], const float b[HD_SH_COEFFS])
{
    double d = 0, n = 0;
    for (int k = 0; k < HD_SH_COEFFS; k++) d += ((double)a[k] - b[k]) * ((double)a[k] - b[k]), n += (double)a[k] * a[k];
    return n > 0 ? sqrt(d / n) : (d > 0 ? INFINITY : 0.0);
}
