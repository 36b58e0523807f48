/* face_detect.c: face detection as MediaPipe's BlazeFace graphs do it, on an image pyramid.
 * The network (TF.js graph, N x N RGB in [-1, 1]; the back model N = 256, the front model 128):
 *   1. a square window of the photo (level 0: the whole photo letterboxed, centred, black bars;
 *      finer levels: overlapping tiles, see hd_face_pyramid) sampled to N x N, antialiased;
 *   2. the network: 896 anchors, for each a score logit and 16 regressors (box centre offset, box
 *      size, 6 keypoint offsets, in network pixels);
 *   3. SSD anchors (fixed size 1, offset 0.5): 16 x 16 cells with 2 anchors each, then 8 x 8 cells
 *      with 6 anchors each;
 *   4. decoding: centre = raw / N + anchor, size = raw / N, keypoint = raw / N + anchor (normalised
 *      window coordinates), score = sigmoid(clip(logit, -100, 100)); boxes crossing a window edge
 *      that cuts through the photo are dropped (a neighbour sees that face whole);
 *   5. the threshold (0.75), then weighted non-maximum suppression over the candidates of every
 *      window (IoU > 0.3: the cluster's boxes and keypoints averaged with their scores as weights,
 *      the best score kept);
 *   6. back to the photo: photo = window origin + normalised coordinate x window side.
 * Input range: MediaPipe feeds these models [-1, 1] (its TFLite converter's zero_center); the TF.js
 * port's own code feeds x / 127.5 - 0.5. We feed [-1, 1]: on the bundled photo the front model
 * scores 0.922, [0, 1] 0.895, with the same box within 2 pixels. Keypoints are coarse (one network
 * pixel is side / N photo pixels); the face mesh refines them. */
#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "graph/tfjs_graph.h"
#include "align/face_detect.h"

#define MIN_NET_SIZE 64
#define MAX_NET_SIZE 1024
/* The smallest face found reliably, as a fraction of the window's side: measured on the bundled
 * faces (docs/face_detect.md), the front model scores 0.79-0.93 at 0.12 and the back model
 * 0.84-0.93 at 0.05 (both up to 0.9 of the side). */
#define FRONT_MIN_FACE 0.13f
#define BACK_MIN_FACE 0.07f
#define PYRAMID_OVERLAP 2.6f   /* window overlap in units of the smallest face of the level */
#define MIN_WINDOW_RATIO 0.5f  /* windows are at least half the network's side (2x enlargement) */
#define MAX_LEVELS 12
/* The zoom-outs tried on a photo in which the pyramid found no face: window sides in units of the
 * photo's longer side (a face filling a crop is ~0.9 of it; 1.5-2.5 bring it to the sizes the
 * detector scores highest, docs/face_detect.md). */
static const float ZOOM_OUT[] = {1.6f, 2.0f, 2.6f};
/* A photo under this many pixels a side is too small to hold a face the landmark model can use:
 * no zoom-out (on a few pixels of flat colour it would find faces in the grey around them). */
#define ZOOM_MIN_SIDE 48
/* When no zoom-out finds a face at the threshold, they are tried once more at this share of it: a
 * face under hard side light (half of it black) scores 0.3-0.7 on grey. The landmark model's
 * presence test (aligner.c) still rejects what is not a face. */
#define ZOOM_SCORE_SHARE 0.4f
#define NUM_COORDS 16
#define SCORE_CLIP 100.0f
#define MAX_SUPERSAMPLE 16

/* The model's outputs: scores and regressors of the stride-8 anchors, then of the stride-16 ones. */
static const struct {
    const char *scores, *boxes;
    int grid, per_cell;
} detect_heads[2] = {
    {"Identity", "Identity_2", 16, 2},
    {"Identity_1", "Identity_3", 8, 6},
};

struct hd_face_detector {
    hd_tfjs_graph *graph;
    int size;            /* the network's input side (128 front, 256 back) */
    float min_face_frac; /* the smallest face it finds, as a fraction of its window's side */
    int nanchors;
    float *anchors;      /* (nanchors, 2): centres in normalised window coordinates */
    float *input;        /* (size, size, 3) */
    hd_face_box *boxes;  /* candidates of the current photo, all windows */
    int nboxes, capacity;
};

/* ------------------------------------------------------------------ sampling */

/* Bilinear value of the photo at continuous point (px, py) (pixel centres at +0.5). */
static void bilinear(const hd_image *im, float px, float py, hd_sample_border border, float rgb[3])
{
    int W = im->width, H = im->height;
    float fx = px - 0.5f, fy = py - 0.5f;
    if (border == HD_BORDER_REPLICATE) {
        fx = fx < 0.0f ? 0.0f : (fx > (float)(W - 1) ? (float)(W - 1) : fx);
        fy = fy < 0.0f ? 0.0f : (fy > (float)(H - 1) ? (float)(H - 1) : fy);
    } else if (!(fx > -1.0f && fy > -1.0f && fx < (float)W && fy < (float)H)) { /* also catches NaN */
        rgb[0] = rgb[1] = rgb[2] = border == HD_BORDER_GREY ? 0.5f : 0.0f;
        return;
    }
    int x0 = (int)floorf(fx), y0 = (int)floorf(fy);
    float tx = fx - (float)x0, ty = fy - (float)y0;
    float wgt[4] = {(1 - tx) * (1 - ty), tx * (1 - ty), (1 - tx) * ty, tx * ty};
    int xs[4] = {x0, x0 + 1, x0, x0 + 1}, ys[4] = {y0, y0, y0 + 1, y0 + 1};
    int gray = im->channels < 3;
    size_t plane = (size_t)W * H;
    rgb[0] = rgb[1] = rgb[2] = 0.0f;
    for (int k = 0; k < 4; k++) {
        int x = xs[k], y = ys[k];
        if (border == HD_BORDER_REPLICATE) {
            x = x < W ? x : W - 1;
            y = y < H ? y : H - 1;
        } else if (x < 0 || y < 0 || x >= W || y >= H) {
            if (border == HD_BORDER_GREY)
                for (int c = 0; c < 3; c++) rgb[c] += 0.5f * wgt[k];
            continue;
        }
        const float *p = im->data + (size_t)y * W + x;
        for (int c = 0; c < 3; c++) rgb[c] += wgt[k] * p[gray ? 0 : c * plane];
    }
}

void hd_face_sample(const hd_image *photo, const float origin[2], const float axis_x[2], const float axis_y[2],
                    int width, int height, float lo, float hi, hd_sample_border border, float *out)
{
    float lx = hypotf(axis_x[0], axis_x[1]), ly = hypotf(axis_y[0], axis_y[1]);
    float step = lx > ly ? lx : ly;
    int k = step > 1.0f ? (int)ceilf(step) : 1;
    if (!(k <= MAX_SUPERSAMPLE)) k = MAX_SUPERSAMPLE;
    float inv = 1.0f / (float)(k * k);
#pragma omp parallel for schedule(static) if ((size_t)width * height * k * k > ((size_t)1 << 20))
    for (int j = 0; j < height; j++)
        for (int i = 0; i < width; i++) {
            float acc[3] = {0, 0, 0}, rgb[3];
            for (int sj = 0; sj < k; sj++)
                for (int si = 0; si < k; si++) {
                    float u = (float)i + ((float)si + 0.5f) / (float)k, v = (float)j + ((float)sj + 0.5f) / (float)k;
                    bilinear(photo, origin[0] + u * axis_x[0] + v * axis_y[0], origin[1] + u * axis_x[1] + v * axis_y[1],
                             border, rgb);
                    acc[0] += rgb[0];
                    acc[1] += rgb[1];
                    acc[2] += rgb[2];
                }
            float *o = out + ((size_t)j * width + i) * 3;
            for (int c = 0; c < 3; c++) o[c] = lo + (hi - lo) * acc[c] * inv;
        }
}

/* ------------------------------------------------------------------ the detector */

void hd_face_detector_free(hd_face_detector *d)
{
    if (!d) return;
    hd_tfjs_free(d->graph);
    free(d->anchors);
    free(d->input);
    free(d->boxes);
    free(d);
}

hd_status hd_face_detector_load(const char *json_path, hd_face_detector **detector)
{
    *detector = NULL;
    char *found = NULL;
    if (!json_path) {
        found = hd_find_data(HD_FACE_DETECT_MODEL);
        if (!found) return hd_fail(HD_ERR_NOTFOUND, "%s: not found on the data search path", HD_FACE_DETECT_MODEL);
        json_path = found;
    }
    hd_face_detector *d = hd_calloc(1, sizeof *d);
    if (!d) {
        free(found);
        return HD_ERR_NOMEM;
    }
    hd_status st = hd_tfjs_load(json_path, &d->graph);
    if (st != HD_OK) goto fail;
    int h, w, c;
    hd_tfjs_input_shape(d->graph, &h, &w, &c);
    if (h != w || h < MIN_NET_SIZE || h > MAX_NET_SIZE || c != 3) {
        st = hd_fail(HD_ERR_FORMAT, "%s: input is %dx%dx%d, the detector wants a square RGB input of %d to %d pixels",
                     json_path, h, w, c, MIN_NET_SIZE, MAX_NET_SIZE);
        goto fail;
    }
    d->size = h;
    d->min_face_frac = h >= 256 ? BACK_MIN_FACE : FRONT_MIN_FACE;
    /* Anchors: for each head, cells in row order, per_cell anchors per cell, centred in the cell. */
    d->nanchors = 0;
    for (int k = 0; k < 2; k++) d->nanchors += detect_heads[k].grid * detect_heads[k].grid * detect_heads[k].per_cell;
    d->anchors = hd_malloc((size_t)d->nanchors * 2 * sizeof(float));
    d->input = hd_malloc((size_t)d->size * d->size * 3 * sizeof(float));
    if (!d->anchors || !d->input) {
        st = HD_ERR_NOMEM;
        goto fail;
    }
    int a = 0;
    for (int k = 0; k < 2; k++) {
        int g = detect_heads[k].grid;
        for (int y = 0; y < g; y++)
            for (int x = 0; x < g; x++)
                for (int n = 0; n < detect_heads[k].per_cell; n++) {
                    d->anchors[2 * a] = ((float)x + 0.5f) / (float)g;
                    d->anchors[2 * a + 1] = ((float)y + 0.5f) / (float)g;
                    a++;
                }
    }
    /* The outputs must be there with the shapes the anchors need (known from the load). */
    for (int k = 0; k < 2; k++) {
        int n = detect_heads[k].grid * detect_heads[k].grid * detect_heads[k].per_cell, nd, dims[4];
        if (!hd_tfjs_output(d->graph, detect_heads[k].scores, &nd, dims) || nd != 3 || dims[1] != n || dims[2] != 1 ||
            !hd_tfjs_output(d->graph, detect_heads[k].boxes, &nd, dims) || nd != 3 || dims[1] != n ||
            dims[2] != NUM_COORDS) {
            st = hd_fail(HD_ERR_FORMAT, "%s: not a BlazeFace model: outputs %s (1, %d, 1) and %s (1, %d, %d) expected",
                         json_path, detect_heads[k].scores, n, detect_heads[k].boxes, n, NUM_COORDS);
            goto fail;
        }
    }
    free(found);
    *detector = d;
    return HD_OK;
fail:
    free(found);
    hd_face_detector_free(d);
    return st;
}

int hd_face_detector_size(const hd_face_detector *d) { return d->size; }

float hd_face_detector_min_face(const hd_face_detector *d, int width, int height)
{
    return d->min_face_frac * (float)(width > height ? width : height);
}

static float box_iou(const hd_face_box *a, const hd_face_box *b)
{
    float ix = fminf(a->x1, b->x1) - fmaxf(a->x0, b->x0), iy = fminf(a->y1, b->y1) - fmaxf(a->y0, b->y0);
    if (ix <= 0.0f || iy <= 0.0f) return 0.0f;
    float inter = ix * iy;
    float uni = (a->x1 - a->x0) * (a->y1 - a->y0) + (b->x1 - b->x0) * (b->y1 - b->y0) - inter;
    return uni > 0.0f ? inter / uni : 0.0f;
}

static int cmp_score_desc(const void *pa, const void *pb)
{
    const hd_face_box *a = pa, *b = pb;
    return (a->score < b->score) - (a->score > b->score);
}

int hd_face_boxes_merge(hd_face_box *boxes, int n, float iou)
{
    qsort(boxes, (size_t)n, sizeof *boxes, cmp_score_desc);
    char *taken = hd_calloc((size_t)n + 1, 1);
    if (!taken) return -1;
    int out = 0;
    for (int i = 0; i < n; i++) {
        if (taken[i]) continue;
        hd_face_box best = boxes[i], sum;
        memset(&sum, 0, sizeof sum);
        float wsum = 0.0f;
        for (int j = i; j < n; j++) {
            if (taken[j] || box_iou(&best, &boxes[j]) <= iou) continue;
            float w = boxes[j].score;
            taken[j] = 1;
            wsum += w;
            sum.x0 += w * boxes[j].x0;
            sum.y0 += w * boxes[j].y0;
            sum.x1 += w * boxes[j].x1;
            sum.y1 += w * boxes[j].y1;
            for (int k = 0; k < HD_FACE_KEYPOINTS; k++) {
                sum.keypoints[k][0] += w * boxes[j].keypoints[k][0];
                sum.keypoints[k][1] += w * boxes[j].keypoints[k][1];
            }
        }
        taken[i] = 1;
        if (wsum > 0.0f) {
            best.x0 = sum.x0 / wsum;
            best.y0 = sum.y0 / wsum;
            best.x1 = sum.x1 / wsum;
            best.y1 = sum.y1 / wsum;
            for (int k = 0; k < HD_FACE_KEYPOINTS; k++) {
                best.keypoints[k][0] = sum.keypoints[k][0] / wsum;
                best.keypoints[k][1] = sum.keypoints[k][1] / wsum;
            }
        }
        boxes[out++] = best;
    }
    free(taken);
    return out;
}

static hd_status check_photo(const hd_image *photo)
{
    if (!photo || !photo->data || photo->width < 1 || photo->height < 1 || photo->channels < 1 || photo->channels > 4)
        return hd_fail(HD_ERR_ARG, "face detection: the photo is empty or has an unsupported channel count");
    if (photo->width > HD_IMAGE_MAX_SIDE || photo->height > HD_IMAGE_MAX_SIDE)
        return hd_fail(HD_ERR_RANGE, "face detection: a %dx%d photo is larger than %d pixels a side", photo->width,
                       photo->height, HD_IMAGE_MAX_SIDE);
    return HD_OK;
}

/* Room for n more boxes in the detector's candidate list. */
static hd_status reserve_boxes(hd_face_detector *d, int n)
{
    if (d->nboxes + n <= d->capacity) return HD_OK;
    if (d->nboxes > INT_MAX / 2 - n) return hd_fail(HD_ERR_RANGE, "face detection: too many candidate boxes");
    int cap = 2 * (d->nboxes + n);
    hd_face_box *b = realloc(d->boxes, (size_t)cap * sizeof *b);
    if (!b) return HD_ERR_NOMEM;
    d->boxes = b;
    d->capacity = cap;
    return HD_OK;
}

hd_status hd_face_detector_window(hd_face_detector *d, const hd_image *photo, const hd_face_window *win,
                                  float min_score)
{
    int N = d->size;
    float side = win->side, step = side / (float)N;
    float origin[2] = {win->x, win->y}, ax[2] = {step, 0.0f}, ay[2] = {0.0f, step};
    /* a window wider than the photo (the zoom-out of a tight crop) sees it on grey, not black */
    float longer = (float)(photo->width > photo->height ? photo->width : photo->height);
    hd_face_sample(photo, origin, ax, ay, N, N, -1.0f, 1.0f, side > longer ? HD_BORDER_GREY : HD_BORDER_ZERO, d->input);
    hd_status st = hd_tfjs_run(d->graph, d->input);
    if (st != HD_OK) return st;
    if ((st = reserve_boxes(d, d->nanchors))) return st;
    float x_hi = win->x + side, y_hi = win->y + side;
    int a = 0;
    for (int k = 0; k < 2; k++) {
        const float *scores = hd_tfjs_output(d->graph, detect_heads[k].scores, NULL, NULL);
        const float *raw = hd_tfjs_output(d->graph, detect_heads[k].boxes, NULL, NULL);
        int na = detect_heads[k].grid * detect_heads[k].grid * detect_heads[k].per_cell;
        for (int i = 0; i < na; i++, a++) {
            float logit = fminf(fmaxf(scores[i], -SCORE_CLIP), SCORE_CLIP);
            float score = 1.0f / (1.0f + expf(-logit)); /* sigmoid */
            if (score < min_score) continue;
            const float *r = raw + (size_t)i * NUM_COORDS;
            float acx = d->anchors[2 * a], acy = d->anchors[2 * a + 1];
            /* network pixels / N + anchor = normalised window coordinates -> photo pixels */
            float cx = r[0] / (float)N + acx, cy = r[1] / (float)N + acy;
            float bw = r[2] / (float)N, bh = r[3] / (float)N;
            hd_face_box b;
            b.score = score;
            b.x0 = win->x + (cx - 0.5f * bw) * side;
            b.x1 = win->x + (cx + 0.5f * bw) * side;
            b.y0 = win->y + (cy - 0.5f * bh) * side;
            b.y1 = win->y + (cy + 0.5f * bh) * side;
            /* A box that crosses an edge the window cuts through the photo may be part of a face:
             * the neighbouring window, which overlaps this one by more than a face, sees it whole. */
            if ((win->cut & HD_CUT_LEFT && b.x0 < win->x) || (win->cut & HD_CUT_TOP && b.y0 < win->y) ||
                (win->cut & HD_CUT_RIGHT && b.x1 > x_hi) || (win->cut & HD_CUT_BOTTOM && b.y1 > y_hi))
                continue;
            for (int kp = 0; kp < HD_FACE_KEYPOINTS; kp++) {
                b.keypoints[kp][0] = win->x + (r[4 + 2 * kp] / (float)N + acx) * side;
                b.keypoints[kp][1] = win->y + (r[5 + 2 * kp] / (float)N + acy) * side;
            }
            d->boxes[d->nboxes++] = b;
        }
    }
    return HD_OK;
}

/* The windows along one axis of length L for windows of side T overlapping by at least ov:
 * one centred window when L <= T, else n evenly spread from 0 to L - T. */
static int axis_windows(float L, float T, float ov, int *n, float *stride)
{
    if (L <= T) {
        *n = 1;
        *stride = 0.0f;
        return 1;
    }
    int k = (int)ceilf((L - ov) / (T - ov));
    if (k < 2) k = 2;
    *n = k;
    *stride = (L - T) / (float)(k - 1);
    return k;
}

int hd_face_pyramid(const hd_face_detector *d, int width, int height, float min_face, hd_face_window *out, int cap)
{
    float W = (float)width, H = (float)height, T0 = W > H ? W : H, frac = d->min_face_frac;
    int n = 0;
    /* Level 0: the whole photo letterboxed, as MediaPipe does; it finds faces from frac T0 up. */
    if (n < cap) out[n] = (hd_face_window){0.5f * (W - T0), 0.5f * (H - T0), T0, 0, 0};
    n++;
    if (!(min_face > 0.0f) || frac * T0 <= min_face) return n;
    /* The finest level's windows make a min_face face just large enough (frac of the side), but
     * enlarge the photo at most 1 / MIN_WINDOW_RATIO times; coarser levels double the side while it
     * stays under T0. A level finds every face from frac T up; the faces the next coarser level
     * misses are under frac 2T wide, so its windows overlap by PYRAMID_OVERLAP frac T. */
    float T = min_face / frac, T_min = MIN_WINDOW_RATIO * (float)d->size;
    if (T < T_min) T = T_min;
    int levels = 0;
    for (float t = T; t < T0 && levels < MAX_LEVELS; t *= 2.0f) levels++;
    for (int level = levels; level >= 1; level--, T *= 2.0f) {
        float ov = PYRAMID_OVERLAP * frac * T;
        int nx, ny;
        float sx, sy;
        axis_windows(W, T, ov, &nx, &sx);
        axis_windows(H, T, ov, &ny, &sy);
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++, n++) {
                if (n >= cap) continue;
                hd_face_window *w = &out[n];
                w->x = nx == 1 ? 0.5f * (W - T) : (float)i * sx;
                w->y = ny == 1 ? 0.5f * (H - T) : (float)j * sy;
                w->side = T;
                w->level = level;
                w->cut = (i > 0 ? HD_CUT_LEFT : 0) | (i < nx - 1 ? HD_CUT_RIGHT : 0) | (j > 0 ? HD_CUT_TOP : 0) |
                         (j < ny - 1 ? HD_CUT_BOTTOM : 0);
            }
    }
    return n;
}

/* A tight crop (the face filling the photo, as in the Yale and Multi-PIE crops) has no context
 * around the face, which the detector needs: the photo seen again zoomed out, centred on grey,
 * until a window finds a face (at the threshold, then at ZOOM_SCORE_SHARE of it). */
static hd_status zoom_out(hd_face_detector *d, const hd_image *photo, float min_score)
{
    const float T0 = (float)(photo->width > photo->height ? photo->width : photo->height);
    if (photo->width < ZOOM_MIN_SIDE || photo->height < ZOOM_MIN_SIDE) return HD_OK;
    const int nzoom = (int)(sizeof ZOOM_OUT / sizeof ZOOM_OUT[0]);
    hd_status st = HD_OK;
    for (int z = 0; z < 2 * nzoom && !st && d->nboxes == 0; z++) {
        const float side = ZOOM_OUT[z % nzoom] * T0;
        hd_face_window w = {0.5f * ((float)photo->width - side), 0.5f * ((float)photo->height - side), side, 0, 0};
        st = hd_face_detector_window(d, photo, &w, z < nzoom ? min_score : ZOOM_SCORE_SHARE * min_score);
    }
    return st;
}

/* The detector's list, merged, as a new array. */
static hd_status boxes_out(hd_face_detector *d, hd_face_box **faces, int *count)
{
    int n = d->nboxes;
    if (n == 0) return HD_OK;
    hd_face_box *boxes = hd_malloc((size_t)n * sizeof *boxes);
    if (!boxes) return HD_ERR_NOMEM;
    memcpy(boxes, d->boxes, (size_t)n * sizeof *boxes);
    n = hd_face_boxes_merge(boxes, n, HD_FACE_NMS_IOU);
    if (n <= 0) {
        free(boxes);
        return n < 0 ? HD_ERR_NOMEM : HD_OK;
    }
    *faces = boxes; /* shrinking is optional: the array stays valid at its full size */
    *count = n;
    return HD_OK;
}

static hd_status check_score(float min_score)
{
    if (!(min_score > 0.0f && min_score <= 1.0f))
        return hd_fail(HD_ERR_ARG, "face detection: the score threshold %g is not in (0, 1]", (double)min_score);
    return HD_OK;
}

hd_status hd_face_detector_find(hd_face_detector *d, const hd_image *photo, float min_score, float min_face,
                                hd_face_box **faces, int *count)
{
    *faces = NULL;
    *count = 0;
    hd_status st = check_photo(photo);
    if (st == HD_OK) st = check_score(min_score);
    if (st != HD_OK) return st;
    if (!(min_face >= 0.0f && min_face < 1e9f))
        return hd_fail(HD_ERR_ARG, "face detection: the smallest face size %g is not a size in pixels", (double)min_face);
    int nwin = hd_face_pyramid(d, photo->width, photo->height, min_face, NULL, 0);
    hd_face_window *wins = hd_malloc((size_t)nwin * sizeof *wins);
    if (!wins) return HD_ERR_NOMEM;
    hd_face_pyramid(d, photo->width, photo->height, min_face, wins, nwin);
    d->nboxes = 0;
    for (int i = 0; i < nwin && !st; i++) st = hd_face_detector_window(d, photo, &wins[i], min_score);
    free(wins);
    if (st == HD_OK && d->nboxes == 0) st = zoom_out(d, photo, min_score);
    return st ? st : boxes_out(d, faces, count);
}

hd_status hd_face_detector_find_zoomed(hd_face_detector *d, const hd_image *photo, float min_score,
                                       hd_face_box **faces, int *count)
{
    *faces = NULL;
    *count = 0;
    hd_status st = check_photo(photo);
    if (st == HD_OK) st = check_score(min_score);
    if (st != HD_OK) return st;
    d->nboxes = 0;
    st = zoom_out(d, photo, min_score);
    return st ? st : boxes_out(d, faces, count);
}

hd_status hd_face_detector_run(hd_face_detector *d, const hd_image *photo, float min_score, hd_face_box **faces,
                               int *count)
{
    return hd_face_detector_find(d, photo, min_score, HD_FACE_MIN_SIZE, faces, count);
}

hd_status hd_face_detect(const hd_image *photo, hd_face_box **faces, int *count)
{
    *faces = NULL;
    *count = 0;
    hd_status st = check_photo(photo);
    if (st != HD_OK) return st;
    hd_face_detector *d;
    st = hd_face_detector_load(NULL, &d);
    if (st != HD_OK) return st;
    st = hd_face_detector_run(d, photo, HD_FACE_MIN_SCORE, faces, count);
    hd_face_detector_free(d);
    return st;
}
