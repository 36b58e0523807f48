/* face_detect.c: face detection as MediaPipe's short-range face detection graph does it, on the
 * BlazeFace "front" model (TF.js graph, 128 x 128 RGB in [-1, 1]):
 *   1. letterbox: the photo scaled to fit 128 x 128 keeping its aspect ratio, centred, black bars;
 *   2. the network: 896 anchors, for each a score logit and 16 regressors (box centre offset, box
 *      size, 6 keypoint offsets, in 128-pixel units);
 *   3. SSD anchors (strides 8, 16, 16, 16; fixed anchor size 1; offset 0.5): 16 x 16 cells with 2
 *      anchors each, then 8 x 8 cells with 6 anchors each;
 *   4. decoding: centre = raw / 128 + anchor, size = raw / 128, keypoint = raw / 128 + anchor
 *      (normalised letterbox coordinates), score = sigmoid(clip(logit, -100, 100));
 *   5. the threshold (0.75), weighted non-maximum suppression (IoU > 0.3: the cluster's boxes and
 *      keypoints averaged with their scores as weights, the best score kept);
 *   6. the letterbox undone: photo = (letterbox pixel - bar offset) / scale.
 * Input range: MediaPipe feeds this model [-1, 1] (its TFLite converter's zero_center); the TF.js
 * port's own code feeds x / 127.5 - 0.5. We feed [-1, 1]: on the bundled photo it scores 0.922,
 * [0, 1] scores 0.895, with the same box within 2 pixels. Keypoints are coarse (one network pixel
 * is max(W, H) / 128 photo pixels); the face mesh refines them. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "graph/tfjs_graph.h"
#include "align/face_detect.h"

#define DETECT_SIZE 128
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
    int nanchors;
    float *anchors; /* (nanchors, 2): centres in normalised letterbox coordinates */
    float *input;   /* (128, 128, 3) */
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
        rgb[0] = rgb[1] = rgb[2] = 0.0f;
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
        } else if (x < 0 || y < 0 || x >= W || y >= H) continue;
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
    free(d);
}

hd_status hd_face_detector_load(const char *json_path, hd_face_detector **detector)
{
    *detector = NULL;
    char *found = NULL;
    if (!json_path) {
        found = hd_find_data("face-models/blazeface-front.json");
        if (!found) return HD_ERR_NOTFOUND;
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
    if (h != DETECT_SIZE || w != DETECT_SIZE || c != 3) {
        st = hd_fail(HD_ERR_FORMAT, "%s: input is %dx%dx%d, the detector wants 128x128x3", json_path, h, w, c);
        goto fail;
    }
    /* Anchors: for each head, cells in row order, per_cell anchors per cell, centred in the cell. */
    d->nanchors = 0;
    for (int k = 0; k < 2; k++) d->nanchors += detect_heads[k].grid * detect_heads[k].grid * detect_heads[k].per_cell;
    d->anchors = hd_malloc((size_t)d->nanchors * 2 * sizeof(float));
    d->input = hd_malloc((size_t)DETECT_SIZE * DETECT_SIZE * 3 * sizeof(float));
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
            st = hd_fail(HD_ERR_FORMAT, "%s: not the BlazeFace front model: outputs %s (1, %d, 1) and %s (1, %d, %d) expected",
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

/* Weighted NMS over boxes sorted by score: the best remaining box takes every remaining box with
 * IoU > iou (itself included); the merged box is their score-weighted mean, with the best score.
 * Writes the merged boxes to the front of `boxes`; returns their count. */
static int weighted_nms(hd_face_box *boxes, int n, float iou)
{
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

hd_status hd_face_detector_run(hd_face_detector *d, const hd_image *photo, float min_score, hd_face_box **faces,
                               int *count)
{
    *faces = NULL;
    *count = 0;
    hd_status st = check_photo(photo);
    if (st != HD_OK) return st;
    if (!(min_score > 0.0f && min_score <= 1.0f))
        return hd_fail(HD_ERR_ARG, "face detection: the score threshold %g is not in (0, 1]", (double)min_score);
    /* Letterbox: scale s = 128 / max(W, H), bars (128 - W s) / 2 and (128 - H s) / 2; the
     * letterbox pixel t shows photo point p = (t - bar) / s. */
    float W = (float)photo->width, H = (float)photo->height;
    float s = (float)DETECT_SIZE / (W > H ? W : H);
    float bar_x = 0.5f * ((float)DETECT_SIZE - W * s), bar_y = 0.5f * ((float)DETECT_SIZE - H * s);
    float origin[2] = {-bar_x / s, -bar_y / s}, ax[2] = {1.0f / s, 0.0f}, ay[2] = {0.0f, 1.0f / s};
    hd_face_sample(photo, origin, ax, ay, DETECT_SIZE, DETECT_SIZE, -1.0f, 1.0f, HD_BORDER_ZERO, d->input);
    st = hd_tfjs_run(d->graph, d->input);
    if (st != HD_OK) return st;

    hd_face_box *boxes = hd_malloc((size_t)d->nanchors * sizeof *boxes);
    if (!boxes) return HD_ERR_NOMEM;
    int n = 0, a = 0;
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
            /* normalised letterbox coordinates -> letterbox pixels -> photo pixels */
            float cx = r[0] / DETECT_SIZE + acx, cy = r[1] / DETECT_SIZE + acy;
            float bw = r[2] / DETECT_SIZE, bh = r[3] / DETECT_SIZE;
            hd_face_box *b = &boxes[n++];
            b->score = score;
            b->x0 = ((cx - 0.5f * bw) * DETECT_SIZE - bar_x) / s;
            b->x1 = ((cx + 0.5f * bw) * DETECT_SIZE - bar_x) / s;
            b->y0 = ((cy - 0.5f * bh) * DETECT_SIZE - bar_y) / s;
            b->y1 = ((cy + 0.5f * bh) * DETECT_SIZE - bar_y) / s;
            for (int kp = 0; kp < HD_FACE_KEYPOINTS; kp++) {
                float kx = r[4 + 2 * kp] / DETECT_SIZE + acx, ky = r[5 + 2 * kp] / DETECT_SIZE + acy;
                b->keypoints[kp][0] = (kx * DETECT_SIZE - bar_x) / s;
                b->keypoints[kp][1] = (ky * DETECT_SIZE - bar_y) / s;
            }
        }
    }
    qsort(boxes, (size_t)n, sizeof *boxes, cmp_score_desc);
    n = weighted_nms(boxes, n, HD_FACE_NMS_IOU);
    if (n < 0) {
        free(boxes);
        return HD_ERR_NOMEM;
    }
    if (n == 0) {
        free(boxes);
        return HD_OK;
    }
    *faces = boxes; /* shrinking is optional: the array stays valid at its full size */
    *count = n;
    return HD_OK;
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
