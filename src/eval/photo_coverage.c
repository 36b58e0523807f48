/* photo_coverage.c: did a relit photo relight the whole head or a face mask (issue 36; docs/usage.md,
 * "Measuring relighting")? Coverage compares the change of luminance on the skin in a ring outside
 * the face's outline (ears, temples, jaw, neck) with the change on the nose and cheeks; the forehead
 * band looks for a jump of the change along the forehead's centre line. Both stand on the face's
 * 468 landmarks and a skin model of its own cheeks. Pure functions on in-memory images. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "mesh/mesh.h"
#include "eval/photo_coverage.h"

#define LOG_EPS (1.0 / 255.0)
#define CHEEK_LOW -0.8f /* the cheek sample, in eye distances above the eye line ... */
#define CHEEK_HIGH -0.25f
#define CHEEK_SIDE 0.7f /* ... and across the face's axis */
#define SKIN_MAD 3.0f
#define SKIN_CHROMA 0.01f
#define SKIN_DARKER 1.2f /* log luminance below the cheeks' median still skin */
#define SKIN_BRIGHTER 0.6f
#define RING_FROM 0.03f /* the ring outside the outline, in eye distances */
#define RING_TO 0.5f
#define BAND_FROM 0.45f /* the forehead's boxes, in eye distances above the eye line */
#define BAND_TO 2.0f
#define BAND_STEP 0.02f     /* the boxes' height, in eye distances ... */
#define BAND_STEP_PIXELS 2.0f /* ... and at least this many pixels, so that none is empty */
#define BAND_HALF_WIDTH 0.15f
#define BAND_SEARCH 0.3f /* the first skin box is looked for this far above BAND_FROM */
#define BAND_EPS 0.002
#define BAND_MIN_BOXES 4
#define FACE_FOREHEAD 10
#define FACE_CHIN 152

/* The face's frame: eyes' midpoint, eye distance, unit chin-to-forehead axis; its outline. */
typedef struct frame {
    float mx, my, e, ux, uy;
    float ox[HD_FACE_LANDMARKS], oy[HD_FACE_LANDMARKS];
    int n;
} frame;

static int frame_of(const float (*lm)[3], frame *f)
{
    float eyes[2][2];
    hd_face_eye_centres(lm, eyes);
    f->mx = 0.5f * (eyes[0][0] + eyes[1][0]), f->my = 0.5f * (eyes[0][1] + eyes[1][1]);
    f->e = hypotf(eyes[1][0] - eyes[0][0], eyes[1][1] - eyes[0][1]);
    f->ux = lm[FACE_FOREHEAD][0] - lm[FACE_CHIN][0], f->uy = lm[FACE_FOREHEAD][1] - lm[FACE_CHIN][1];
    float ul = hypotf(f->ux, f->uy);
    if (!(f->e >= 2.0f) || !(ul > 0) || !isfinite(f->e) || !isfinite(ul)) return 0;
    f->ux /= ul, f->uy /= ul;
    f->n = 0;
    for (const int *i = hd_contour_face_oval; *i >= 0; i++) f->ox[f->n] = lm[*i][0], f->oy[f->n++] = lm[*i][1];
    return 1;
}

static float height_of(const frame *f, int x, int y) { return ((x + 0.5f - f->mx) * f->ux + (y + 0.5f - f->my) * f->uy) / f->e; }
static float side_of(const frame *f, int x, int y) { return ((x + 0.5f - f->mx) * -f->uy + (y + 0.5f - f->my) * f->ux) / f->e; }

static int in_cheeks(const frame *f, int x, int y)
{
    float h = height_of(f, x, y);
    return h >= CHEEK_LOW && h <= CHEEK_HIGH && fabsf(side_of(f, x, y)) <= CHEEK_SIDE &&
           hd_inside_polygon(f->ox, f->oy, f->n, x + 0.5f, y + 0.5f);
}

/* Pixel p's value in channel c, clamped to [0, 1] as a picture shows it. */
static double px(const hd_image *im, int c, size_t p)
{
    float v = im->data[(size_t)c * im->width * im->height + p];
    return v > 0.0f ? (v < 1.0f ? v : 1.0) : 0.0;
}

static double lum_at(const hd_image *im, size_t p) { return 0.2126 * px(im, 0, p) + 0.7152 * px(im, 1, p) + 0.0722 * px(im, 2, p); }

static double log_change(const hd_image *in, const hd_image *out, size_t p)
{
    return log(lum_at(out, p) + LOG_EPS) - log(lum_at(in, p) + LOG_EPS);
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* The median of v[0..n) (reordered); NAN when n is 0. */
static double median_of(double *v, size_t n)
{
    if (!n) return NAN;
    qsort(v, n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

static hd_status check(const hd_image *input, const hd_image *relit, const float (*lm)[3], frame *f)
{
    if (!input || !input->data || input->channels != 3 || !lm ||
        (relit && (!relit->data || relit->channels != 3 || relit->width != input->width || relit->height != input->height)))
        return hd_fail(HD_ERR_ARG, "photo coverage: an RGB input, a relit photo of its size and the landmarks are needed");
    if (!frame_of(lm, f)) return hd_fail(HD_ERR_ARG, "photo coverage: the landmarks give no face frame");
    return HD_OK;
}

hd_status hd_photo_skin(const hd_image *input, const float (*landmarks)[3], unsigned char **skin)
{
    *skin = NULL;
    frame f;
    hd_status st = check(input, NULL, landmarks, &f);
    if (st != HD_OK) return st;
    const int W = input->width, H = input->height;
    const size_t P = (size_t)W * H;
    double *feat = hd_malloc((P ? P : 1) * 3 * sizeof *feat), *sample = hd_malloc((P ? P : 1) * sizeof *sample);
    unsigned char *s = hd_calloc(P ? P : 1, 1);
    if (!feat || !sample || !s) {
        free(feat), free(sample), free(s);
        return HD_ERR_NOMEM;
    }
    for (size_t p = 0; p < P; p++) {
        double r = px(input, 0, p), g = px(input, 1, p), b = px(input, 2, p), sum = r + g + b;
        feat[p] = sum > 1e-6 ? r / sum : 1.0 / 3;
        feat[P + p] = sum > 1e-6 ? g / sum : 1.0 / 3;
        feat[2 * P + p] = log(lum_at(input, p) + LOG_EPS);
    }
    double med[3], lo[3], hi[3];
    for (int k = 0; k < 3; k++) {
        size_t n = 0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++)
                if (in_cheeks(&f, x, y)) sample[n++] = feat[(size_t)k * P + (size_t)y * W + x];
        med[k] = median_of(sample, n);
        for (size_t i = 0; i < n; i++) sample[i] = fabs(sample[i] - med[k]);
        double mad = median_of(sample, n);
        lo[k] = med[k] - SKIN_MAD * mad - SKIN_CHROMA, hi[k] = med[k] + SKIN_MAD * mad + SKIN_CHROMA;
    }
    lo[2] = med[2] - SKIN_DARKER, hi[2] = med[2] + SKIN_BRIGHTER;
    for (size_t p = 0; isfinite(med[0]) && p < P; p++) {
        int in = 1;
        for (int k = 0; k < 3; k++) in &= feat[(size_t)k * P + p] >= lo[k] && feat[(size_t)k * P + p] <= hi[k];
        s[p] = (unsigned char)in;
    }
    free(feat), free(sample);
    *skin = s;
    return HD_OK;
}

/* The distance from (x, y) to the outline, in pixels. */
static float outline_distance(const frame *f, float x, float y)
{
    float d = INFINITY;
    for (int i = 0, j = f->n - 1; i < f->n; j = i++) {
        float s = hd_segment_distance(x, y, f->ox[j], f->oy[j], f->ox[i], f->oy[i]);
        d = s < d ? s : d;
    }
    return d;
}

hd_status hd_photo_coverage_parts(const hd_image *input, const hd_image *relit, const float (*landmarks)[3],
                                  const unsigned char *skin, double *ring, double *face)
{
    *ring = *face = NAN;
    frame f;
    hd_status st = check(input, relit, landmarks, &f);
    if (st != HD_OK) return st;
    if (!skin) return hd_fail(HD_ERR_ARG, "photo coverage: no skin map");
    const int W = input->width, H = input->height;
    const size_t P = (size_t)W * H;
    double *vr = hd_malloc((P ? P : 1) * sizeof *vr), *vf = hd_malloc((P ? P : 1) * sizeof *vf);
    if (!vr || !vf) {
        free(vr), free(vf);
        return HD_ERR_NOMEM;
    }
    /* only the outline's box grown by the ring can hold ring pixels */
    float x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY;
    for (int i = 0; i < f.n; i++)
        x0 = fminf(x0, f.ox[i]), x1 = fmaxf(x1, f.ox[i]), y0 = fminf(y0, f.oy[i]), y1 = fmaxf(y1, f.oy[i]);
    const float m = RING_TO * f.e + 1.0f;
    const int bx0 = (int)fmaxf(0.0f, floorf(x0 - m)), bx1 = (int)fminf((float)W - 1, ceilf(x1 + m));
    const int by0 = (int)fmaxf(0.0f, floorf(y0 - m)), by1 = (int)fminf((float)H - 1, ceilf(y1 + m));
    size_t nr = 0, nf = 0;
    for (int y = by0; y <= by1; y++)
        for (int x = bx0; x <= bx1; x++) {
            const size_t p = (size_t)y * W + x;
            if (!skin[p]) continue;
            const float cx = x + 0.5f, cy = y + 0.5f;
            if (hd_inside_polygon(f.ox, f.oy, f.n, cx, cy)) {
                if (in_cheeks(&f, x, y)) vf[nf++] = fabs(log_change(input, relit, p));
                continue;
            }
            const float d = outline_distance(&f, cx, cy) / f.e;
            if (d > RING_FROM && d <= RING_TO) vr[nr++] = fabs(log_change(input, relit, p));
        }
    *ring = median_of(vr, nr);
    *face = median_of(vf, nf);
    free(vr), free(vf);
    return HD_OK;
}

double hd_photo_band(const hd_image *input, const hd_image *relit, const float (*landmarks)[3],
                     const unsigned char *skin)
{
    frame f;
    if (!skin || check(input, relit, landmarks, &f) != HD_OK) return NAN;
    enum { MAX_BOXES = (int)((BAND_TO - BAND_FROM) / BAND_STEP + 1.5f) };
    const float step = fmaxf(BAND_STEP, BAND_STEP_PIXELS / f.e);
    const int boxes = (int)((BAND_TO - BAND_FROM) / step + 1.5f);
    double sum[MAX_BOXES] = {0};
    long nskin[MAX_BOXES] = {0}, nall[MAX_BOXES] = {0};
    const int W = input->width, H = input->height;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            const float h = height_of(&f, x, y);
            if (h < BAND_FROM - 0.5f * step || h >= BAND_TO + 0.5f * step || fabsf(side_of(&f, x, y)) > BAND_HALF_WIDTH)
                continue;
            int k = (int)floorf((h - BAND_FROM) / step + 0.5f);
            if (k < 0 || k >= boxes) continue;
            const size_t p = (size_t)y * W + x;
            nall[k]++;
            if (skin[p]) sum[k] += log_change(input, relit, p), nskin[k]++;
        }
    /* the boxes that are at least half skin, from the first near the brows up to the hairline */
    int first = -1, last = -1;
    for (int k = 0; k < boxes; k++) {
        const int skinny = nall[k] > 0 && 2 * nskin[k] >= nall[k];
        if (first < 0) {
            if (k * step > BAND_SEARCH) break;
            if (skinny) first = last = k;
        } else if (skinny) last = k;
        else break;
    }
    if (first < 0 || last - first + 1 < BAND_MIN_BOXES) return NAN;
    double steps[MAX_BOXES], top = 0;
    int n = 0;
    for (int k = first; k < last; k++) {
        double a = sum[k] / nskin[k], b = sum[k + 1] / nskin[k + 1];
        steps[n] = fabs(b - a);
        top = steps[n] > top ? steps[n] : top;
        n++;
    }
    return (top + BAND_EPS) / (median_of(steps, (size_t)n) + BAND_EPS);
}
