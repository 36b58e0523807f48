/* forehead.c: where and how strongly a photo's change of light applies around one face
 * (docs/usage.md, "The relighting rule": no seam, up to the hairline). The canonical mesh stops
 * short of the hairline, so a relit forehead kept a strip of the old light between the mesh's top
 * edge and the hair. The face's region is grown from the mesh's upper edge into the pixels above
 * it that look like the face's own skin (chroma, luminance and texture, measured robustly on the
 * mesh's cheeks and nose), up to a set share of the eye distance. The feather weights fade the
 * change over 0.3 eye distances inside the mesh's edge (jaw, ears, temples), and above the brows,
 * where the grown region's edge is the hairline, over a narrower band *outside* it, into the hair:
 * the skin keeps the whole change up to the hair (a band inside left a strip of the old light under
 * the hairline), and the hair, lit by the same light, takes its first few pixels of it. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "apply/apply.h"
#include "mesh/mesh.h"

/* Heights are in eye distances above the line through the eyes, along the chin-to-forehead axis. */
#define SAMPLE_LOW -0.8f  /* the face's skin is sampled on the mesh between these heights (cheeks, nose) */
#define SAMPLE_HIGH -0.25f
#define SAMPLE_SIDE 0.7f  /* ... and at most this far either side of the face's axis */
#define GROW_FROM 0.5f    /* the region grows only above this height */
#define SMOOTH 0.03f      /* the photo is blurred by this share of the eye distance before the skin test */
#define TOL_MAD 2.5f      /* a pixel is skin within TOL_MAD median absolute deviations of the median */
#define TOL_CHROMA 0.012f /* ... plus this much chroma */
#define TOL_LOG_LUM 0.15f /* ... plus this much log luminance */
#define TOL_TEXTURE 0.005f /* ... plus this much texture (above only) */
#define FEATHER_FACE 0.30f     /* the feather inside the mesh's edge, in eye distances */
#define FEATHER_HAIRLINE 0.12f /* the feather outside the grown region's edge, above the brows */
#define HAIRLINE_FROM 0.3f     /* the narrow band takes over between these two heights */
#define HAIRLINE_TO 0.6f
#define FACE_FOREHEAD 10  /* FaceMesh: the top of the forehead */
#define FACE_CHIN 152     /* FaceMesh: the chin */

static int cmp_float(const void *a, const void *b)
{
    float x = *(const float *)a, y = *(const float *)b;
    return x < y ? -1 : x > y;
}

/* (apply.h) */
void hd_median_mad(float *v, size_t n, float *med, float *mad)
{
    qsort(v, n, sizeof *v, cmp_float);
    float m = v[n / 2];
    for (size_t i = 0; i < n; i++) v[i] = fabsf(v[i] - m);
    qsort(v, n, sizeof *v, cmp_float);
    *med = m;
    *mad = v[n / 2];
}

/* (apply.h) */
float hd_luma(float r, float g, float b) { return 0.2126f * r + 0.7152f * g + 0.0722f * b; }

/* (apply.h) */
void hd_colour_features(float r, float g, float b, float f[F_TEXTURE])
{
    const float sum = r + g + b, lum = hd_luma(r, g, b);
    f[F_CHROMA_R] = sum > 1e-6f ? r / sum : 1.0f / 3;
    f[F_CHROMA_G] = sum > 1e-6f ? g / sum : 1.0f / 3;
    f[F_LOG_LUM] = logf(lum > 1e-3f ? lum : 1e-3f);
}

/* (apply.h) */
hd_status hd_skin_features(float *rgb, int w, int h, float smooth, float *feat)
{
    const size_t n = (size_t)w * h;
    float *fine = feat + (size_t)F_TEXTURE * n;
    for (size_t p = 0; p < n; p++) {
        float lum = hd_luma(rgb[p], rgb[n + p], rgb[2 * n + p]);
        fine[p] = logf(lum > 1e-3f ? lum : 1e-3f);
    }
    hd_status st = hd_field_blur(fine, w, h, 0.8f);
    for (int c = 0; c < 3 && st == HD_OK; c++) st = hd_field_blur(rgb + (size_t)c * n, w, h, smooth);
    for (size_t p = 0; st == HD_OK && p < n; p++) {
        float f[F_TEXTURE];
        hd_colour_features(rgb[p], rgb[n + p], rgb[2 * n + p], f);
        for (int k = 0; k < F_TEXTURE; k++) feat[(size_t)k * n + p] = f[k];
        fine[p] = fabsf(fine[p] - feat[(size_t)F_LOG_LUM * n + p]);
    }
    if (st == HD_OK) st = hd_field_blur(fine, w, h, smooth);
    return st;
}

/* Whether pixel p of the features looks like the skin of medians med within tolerances tol. */
static int is_skin(const float *feat, size_t n, size_t p, const float med[NFEAT], const float tol[NFEAT])
{
    int skin = feat[(size_t)F_TEXTURE * n + p] - med[F_TEXTURE] <= tol[F_TEXTURE];
    for (int c = 0; c < F_TEXTURE; c++) skin &= fabsf(feat[(size_t)c * n + p] - med[c]) <= tol[c];
    return skin;
}

/* The window the work is done in: the coverage's bounding box grown by margin, within the photo. */
typedef struct window {
    int x0, y0, w, h;
} window;

static window window_of(const float *coverage, int W, int H, float margin)
{
    int x0 = W, y0 = H, x1 = -1, y1 = -1;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            if (coverage[(size_t)y * W + x] > 0.5f) {
                x0 = x < x0 ? x : x0, x1 = x > x1 ? x : x1;
                y0 = y < y0 ? y : y0, y1 = y > y1 ? y : y1;
            }
    if (x1 < 0) return (window){0, 0, 0, 0};
    int m = (int)ceilf(margin);
    x0 = x0 - m < 0 ? 0 : x0 - m, y0 = y0 - m < 0 ? 0 : y0 - m;
    x1 = x1 + m >= W ? W - 1 : x1 + m, y1 = y1 + m >= H ? H - 1 : y1 + m;
    return (window){x0, y0, x1 - x0 + 1, y1 - y0 + 1};
}

/* (apply.h) */
int hd_face_frame_of(const hd_aligned_face *f, hd_face_frame *fr)
{
    float eyes[2][2];
    hd_face_eye_centres((const float (*)[3])f->landmarks, eyes);
    *fr = (hd_face_frame){0.5f * (eyes[0][0] + eyes[1][0]), 0.5f * (eyes[0][1] + eyes[1][1]),
                       hypotf(eyes[1][0] - eyes[0][0], eyes[1][1] - eyes[0][1]),
                       f->landmarks[FACE_FOREHEAD][0] - f->landmarks[FACE_CHIN][0],
                       f->landmarks[FACE_FOREHEAD][1] - f->landmarks[FACE_CHIN][1]};
    const float ul = hypotf(fr->ux, fr->uy);
    if (!(fr->e >= 2.0f) || !(ul > 0) || !isfinite(fr->e) || !isfinite(ul)) return 0;
    fr->ux /= ul, fr->uy /= ul;
    return 1;
}


hd_status hd_photo_face_region(const hd_aligned_face *f, const hd_image *photo, const float *coverage, float grow,
                               float *region)
{
    if (!f || !photo || !photo->data || photo->channels != 3 || !coverage || !region)
        return hd_fail(HD_ERR_ARG, "relight: the face region needs a face, a 3-channel photo and its coverage");
    const int W = photo->width, H = photo->height;
    const size_t P = (size_t)W * (size_t)H;
    for (size_t p = 0; p < P; p++) region[p] = coverage[p] > 0.5f ? 1.0f : 0.0f;
    hd_face_frame fr;
    if (!(grow > 0) || !hd_face_frame_of(f, &fr)) return HD_OK;
    const float reach = grow * fr.e;
    const window win = window_of(coverage, W, H, reach + 4.0f * SMOOTH * fr.e + 2.0f);
    const size_t N = (size_t)win.w * (size_t)win.h;
    if (N == 0) return HD_OK;
    if (N > (size_t)INT32_MAX) return hd_fail(HD_ERR_ARG, "relight: a %d x %d face is too large", win.w, win.h);

    /* the window's skin features */
    float *rgb = hd_malloc(3 * N * sizeof(float)), *feat = hd_malloc(NFEAT * N * sizeof(float));
    float *samples = hd_malloc(N * sizeof(float)), *dist = hd_malloc(N * sizeof(float));
    int *queue = hd_malloc(N * sizeof(int)), *seed = hd_malloc(N * sizeof(int));
    hd_status st = rgb && feat && samples && dist && queue && seed ? HD_OK : HD_ERR_NOMEM;
    for (int c = 0; c < 3 && st == HD_OK; c++)
        for (int y = 0; y < win.h; y++)
            memcpy(rgb + (size_t)c * N + (size_t)y * win.w,
                   photo->data + (size_t)c * P + (size_t)(y + win.y0) * W + win.x0, (size_t)win.w * sizeof(float));
    if (st == HD_OK) st = hd_skin_features(rgb, win.w, win.h, SMOOTH * fr.e, feat);

    /* the face's skin: medians and deviations over the mesh's cheeks and nose (the forehead may be
     * under a fringe); the texture is tested on one side only (smoother than the skin is skin) */
    float med[NFEAT] = {0}, tol[NFEAT] = {0};
    const float extra[NFEAT] = {TOL_CHROMA, TOL_CHROMA, TOL_LOG_LUM, TOL_TEXTURE};
    size_t n = 0;
    for (int k = 0; k < NFEAT && st == HD_OK; k++) {
        n = 0;
        for (int y = 0; y < win.h; y++)
            for (int x = 0; x < win.w; x++) {
                const int gx = x + win.x0, gy = y + win.y0;
                const float h = hd_face_height(&fr, gx, gy);
                if (region[(size_t)gy * W + gx] > 0.5f && h >= SAMPLE_LOW && h <= SAMPLE_HIGH &&
                    fabsf(hd_face_side(&fr, gx, gy)) <= SAMPLE_SIDE)
                    samples[n++] = feat[(size_t)k * N + (size_t)y * win.w + x];
            }
        if (n == 0) break;
        float mad;
        hd_median_mad(samples, n, &med[k], &mad);
        tol[k] = TOL_MAD * mad + extra[k];
    }

    /* breadth-first growth from the mesh's pixels above GROW_FROM, through skin, within reach of
     * the seed each path started from (Euclidean, so that the grown edge is round) */
    size_t head = 0, tail = 0;
    for (int y = 0; st == HD_OK && n > 0 && y < win.h; y++)
        for (int x = 0; x < win.w; x++) {
            const size_t i = (size_t)y * win.w + x;
            const int gx = x + win.x0, gy = y + win.y0;
            dist[i] = -1.0f;
            if (region[(size_t)gy * W + gx] <= 0.5f || hd_face_height(&fr, gx, gy) < GROW_FROM) continue;
            if (!is_skin(feat, N, i, med, tol)) continue; /* a fringe over the mesh: no growth from it */
            dist[i] = 0.0f;
            seed[i] = (int)i;
            queue[tail++] = (int)i;
        }
    static const int DX[4] = {1, -1, 0, 0}, DY[4] = {0, 0, 1, -1};
    while (st == HD_OK && head < tail) {
        const int i = queue[head++], x = i % win.w, y = i / win.w;
        const int s = seed[i], sx = s % win.w, sy = s / win.w;
        for (int k = 0; k < 4; k++) {
            const int qx = x + DX[k], qy = y + DY[k];
            if (qx < 0 || qy < 0 || qx >= win.w || qy >= win.h) continue;
            const size_t q = (size_t)qy * win.w + qx;
            if (dist[q] >= 0.0f || region[(size_t)(qy + win.y0) * W + qx + win.x0] > 0.5f) continue;
            const float d = hypotf((float)(qx - sx), (float)(qy - sy));
            if (d > reach || hd_face_height(&fr, qx + win.x0, qy + win.y0) < GROW_FROM) continue;
            if (!is_skin(feat, N, q, med, tol)) continue;
            dist[q] = d;
            seed[q] = s;
            queue[tail++] = (int)q;
        }
    }
    for (int y = 0; st == HD_OK && n > 0 && y < win.h; y++)
        for (int x = 0; x < win.w; x++)
            if (dist[(size_t)y * win.w + x] > 0.0f) region[(size_t)(y + win.y0) * W + x + win.x0] = 1.0f;
    free(rgb), free(feat), free(samples), free(dist), free(queue), free(seed);
    return st;
}

hd_status hd_photo_face_feather(const hd_aligned_face *f, const hd_image *photo, const float *coverage, float *weight)
{
    if (!f || !photo || !photo->data || !coverage || !weight)
        return hd_fail(HD_ERR_ARG, "relight: the feather needs a face, a photo and the face's coverage");
    const int W = photo->width, H = photo->height;
    const size_t P = (size_t)W * (size_t)H;
    hd_face_frame fr;
    const int framed = hd_face_frame_of(f, &fr);
    const float e = framed ? fr.e : 0.0f, band = FEATHER_FACE * e > 2.0f ? FEATHER_FACE * e : 2.0f;
    hd_status st = hd_field_feather(coverage, W, H, band, weight);
    if (st != HD_OK || !framed) return st;
    float *region = hd_malloc((P ? P : 1) * sizeof(float)), *narrow = hd_malloc((P ? P : 1) * sizeof(float));
    st = region && narrow ? HD_OK : HD_ERR_NOMEM;
    if (st == HD_OK) st = hd_photo_face_region(f, photo, coverage, HD_FOREHEAD_GROW, region);
    const float nb = FEATHER_HAIRLINE * e > 2.0f ? FEATHER_HAIRLINE * e : 2.0f;
    if (st == HD_OK) st = hd_field_feather_out(region, W, H, nb, narrow);
    /* above the brows the narrow band beyond the grown edge; below, the mesh's; between, a blend */
    for (int y = 0; st == HD_OK && y < H; y++)
        for (int x = 0; x < W; x++) {
            const size_t p = (size_t)y * W + x;
            const float t = hd_field_smoothstep((hd_face_height(&fr, x, y) - HAIRLINE_FROM) / (HAIRLINE_TO - HAIRLINE_FROM));
            const float up = t * narrow[p];
            weight[p] = up > weight[p] ? up : weight[p];
        }
    free(region), free(narrow);
    return st;
}
