/* person_segment.c: where the person is, about a face (issue 36; docs/face_detect.md, "Where the
 * person is"). MediaPipe's selfie segmentation network (face-models/selfie.json: 256 x 256 RGB in
 * [0, 1] in, the probability that each pixel shows a person out) is run by the graph runner on a
 * square crop about the face, posed by its mesh fit: PERSON_SIDE cm wide, centred PERSON_DROP cm
 * below the canonical mesh's origin, which frames the head, the neck and the shoulders as a selfie
 * does, whatever the photo's size or how many people it holds. Where the crop leaves the photo the
 * photo's edge pixels are repeated; each input pixel averages the photo over its own footprint
 * (a grid of bilinear samples), so a large photo is not aliased. The map is sampled back
 * (bilinear) over the crop's part of the photo: the face's person window. A map that does not
 * see the face itself as the person (PERSON_FACE_LEAST over its landmarks) is dropped: the face
 * then has no map, and the head falls back to telling it from its background by colour. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "graph/tfjs_graph.h"
#include "align/person_segment.h"

#define PERSON_OUTPUT "activation_10"
#define PERSON_SIDE 52.0f /* cm: the hair above the skull's top (13.5 cm up), the shoulders below */
#define PERSON_DROP 2.0f  /* cm below the mesh's origin (near the nose's tip) */
#define MAX_SUBSAMPLES 8  /* per axis, per input pixel */
/* The map must give the face's own landmarks (those in the photo) this mean probability of the
 * person, or it is dropped (hd_person_map_sees_face). */
#define PERSON_FACE_LEAST 0.5f

struct hd_person_segmenter {
    hd_tfjs_graph *graph;
    float *input; /* HD_PERSON_SIZE^2 x 3, interleaved */
};

void hd_person_segmenter_free(hd_person_segmenter *s)
{
    if (!s) return;
    hd_tfjs_free(s->graph);
    free(s->input);
    free(s);
}

hd_status hd_person_segmenter_load(const char *json_path, hd_person_segmenter **out)
{
    *out = NULL;
    char *found = NULL;
    if (!json_path) {
        found = hd_find_data("face-models/selfie.json");
        if (!found) return HD_ERR_NOTFOUND;
        json_path = found;
    }
    hd_person_segmenter *s = hd_calloc(1, sizeof *s);
    hd_status st = s ? hd_tfjs_load(json_path, &s->graph) : HD_ERR_NOMEM;
    if (st == HD_OK) {
        int h, w, c, nd, dims[HD_TFJS_MAX_DIMS];
        hd_tfjs_input_shape(s->graph, &h, &w, &c);
        if (h != HD_PERSON_SIZE || w != HD_PERSON_SIZE || c != 3 ||
            !hd_tfjs_output(s->graph, PERSON_OUTPUT, &nd, dims) || nd != 4 || dims[1] != HD_PERSON_SIZE ||
            dims[2] != HD_PERSON_SIZE || dims[3] != 1)
            st = hd_fail(HD_ERR_FORMAT, "%s: not the selfie segmentation model: a 256x256x3 input and an output %s "
                         "(1, 256, 256, 1) expected", json_path, PERSON_OUTPUT);
    }
    if (st == HD_OK && !(s->input = hd_malloc((size_t)HD_PERSON_SIZE * HD_PERSON_SIZE * 3 * sizeof(float))))
        st = HD_ERR_NOMEM;
    free(found);
    if (st != HD_OK) {
        hd_person_segmenter_free(s);
        return st;
    }
    *out = s;
    return HD_OK;
}

hd_status hd_person_segmenter_run(hd_person_segmenter *s, const float *rgb, const float **map)
{
    *map = NULL;
    hd_status st = hd_tfjs_run(s->graph, rgb);
    if (st != HD_OK) return st;
    *map = hd_tfjs_output(s->graph, PERSON_OUTPUT, NULL, NULL);
    return *map ? HD_OK : HD_ERR_FORMAT;
}

void hd_person_crop(const hd_aligned_face *f, float *x0, float *y0, float *side)
{
    /* the centre (0, -PERSON_DROP, 0) of the mesh's frame in the camera's, c = scale R P + t, and in
     * the photo (x, y) = (c0, -c1) */
    const float cx = f->scale * f->rotation[1] * -PERSON_DROP + f->translation[0];
    const float cy = -(f->scale * f->rotation[4] * -PERSON_DROP + f->translation[1]);
    *side = fmaxf(16.0f, PERSON_SIDE * f->scale);
    *x0 = cx - 0.5f * *side;
    *y0 = cy - 0.5f * *side;
}

/* Plane c of photo at (x, y), bilinear, the edge pixels repeated beyond the photo. */
static float sample(const hd_image *photo, int c, float x, float y)
{
    const int W = photo->width, H = photo->height;
    x = fminf(fmaxf(x, 0.0f), (float)(W - 1));
    y = fminf(fmaxf(y, 0.0f), (float)(H - 1));
    const int ix = (int)x, iy = (int)y, jx = ix + 1 < W ? ix + 1 : ix, jy = iy + 1 < H ? iy + 1 : iy;
    const float tx = x - (float)ix, ty = y - (float)iy;
    const float *p = photo->data + (size_t)c * W * H;
    const float top = p[(size_t)iy * W + ix] + (p[(size_t)iy * W + jx] - p[(size_t)iy * W + ix]) * tx;
    const float bottom = p[(size_t)jy * W + ix] + (p[(size_t)jy * W + jx] - p[(size_t)jy * W + ix]) * tx;
    return top + (bottom - top) * ty;
}

/* The network's input: the crop (x0, y0, side) of photo, each pixel the mean of a grid of samples
 * over its footprint, clamped to [0, 1]. */
static void crop_input(const hd_image *photo, float x0, float y0, float side, float *in)
{
    const float step = side / HD_PERSON_SIZE;
    int n = (int)ceilf(step);
    n = n < 1 ? 1 : n > MAX_SUBSAMPLES ? MAX_SUBSAMPLES : n;
#pragma omp parallel for schedule(static)
    for (int v = 0; v < HD_PERSON_SIZE; v++)
        for (int u = 0; u < HD_PERSON_SIZE; u++) {
            float acc[3] = {0, 0, 0};
            for (int j = 0; j < n; j++)
                for (int i = 0; i < n; i++) {
                    /* pixel centres: photo pixel k covers [k - 0.5, k + 0.5] */
                    const float x = x0 + ((float)u + ((float)i + 0.5f) / (float)n) * step - 0.5f;
                    const float y = y0 + ((float)v + ((float)j + 0.5f) / (float)n) * step - 0.5f;
                    for (int c = 0; c < 3; c++) acc[c] += sample(photo, c, x, y);
                }
            for (int c = 0; c < 3; c++) {
                const float m = acc[c] / (float)(n * n);
                in[((size_t)v * HD_PERSON_SIZE + u) * 3 + c] = m < 0 ? 0 : m > 1 ? 1 : m;
            }
        }
}

hd_status hd_person_segment(hd_person_segmenter *s, const hd_image *photo, hd_aligned_face *face)
{
    if (!s || !photo || !photo->data || photo->channels != 3 || photo->width < 1 || photo->height < 1 || !face)
        return hd_fail(HD_ERR_ARG, "segment: a face and its 3-channel photo are needed");
    if (!(face->scale > 0) || !isfinite(face->scale))
        return hd_fail(HD_ERR_ARG, "segment: the face has no mesh fit");
    float cx0, cy0, side;
    hd_person_crop(face, &cx0, &cy0, &side);
    /* the window: photo pixels whose centres fall inside the crop */
    const int W = photo->width, H = photo->height;
    const float fx0 = fmaxf(0.0f, ceilf(cx0 - 0.5f)), fy0 = fmaxf(0.0f, ceilf(cy0 - 0.5f));
    const float fx1 = fminf((float)(W - 1), floorf(cx0 + side - 0.5f)), fy1 = fminf((float)(H - 1), floorf(cy0 + side - 0.5f));
    hd_image_free(&face->person);
    face->person_x0 = face->person_y0 = 0;
    if (!(fx1 >= fx0 && fy1 >= fy0)) return HD_OK; /* the crop misses the photo: no person here */
    crop_input(photo, cx0, cy0, side, s->input);
    const float *map;
    hd_status st = hd_person_segmenter_run(s, s->input, &map);
    if (st != HD_OK) return st;
    const int x0 = (int)fx0, y0 = (int)fy0, w = (int)fx1 - x0 + 1, h = (int)fy1 - y0 + 1;
    if ((st = hd_image_alloc(&face->person, w, h, 1)) != HD_OK) return st;
    face->person_x0 = x0, face->person_y0 = y0;
    const float scale = HD_PERSON_SIZE / side, last = HD_PERSON_SIZE - 1;
    for (int y = 0; y < h; y++) {
        const float v = fminf(fmaxf(((float)(y + y0) + 0.5f - cy0) * scale - 0.5f, 0.0f), last);
        const int iv = (int)v, jv = iv + 1 < HD_PERSON_SIZE ? iv + 1 : iv;
        const float tv = v - (float)iv;
        for (int x = 0; x < w; x++) {
            const float u = fminf(fmaxf(((float)(x + x0) + 0.5f - cx0) * scale - 0.5f, 0.0f), last);
            const int iu = (int)u, ju = iu + 1 < HD_PERSON_SIZE ? iu + 1 : iu;
            const float tu = u - (float)iu;
            const float *r0 = map + (size_t)iv * HD_PERSON_SIZE, *r1 = map + (size_t)jv * HD_PERSON_SIZE;
            const float top = r0[iu] + (r0[ju] - r0[iu]) * tu, bottom = r1[iu] + (r1[ju] - r1[iu]) * tu;
            const float p = top + (bottom - top) * tv;
            face->person.data[(size_t)y * w + x] = p < 0 ? 0 : p > 1 ? 1 : p;
        }
    }
    /* a map that does not see the face it was made for is no map (the face alone in a tight,
     * grey crop under hard light, as in Yale B's: the network saw no person at all, and the head
     * took the whole face for background) */
    if (!hd_person_map_sees_face(face)) {
        hd_image_free(&face->person);
        face->person_x0 = face->person_y0 = 0;
    }
    return HD_OK;
}

int hd_person_map_sees_face(const hd_aligned_face *face)
{
    const hd_image *m = &face->person;
    if (!m->data) return 0;
    double sum = 0;
    int count = 0;
    for (int i = 0; i < HD_FACE_LANDMARKS; i++) {
        const int x = (int)floorf(face->landmarks[i][0]) - face->person_x0;
        const int y = (int)floorf(face->landmarks[i][1]) - face->person_y0;
        if (x < 0 || y < 0 || x >= m->width || y >= m->height) continue;
        sum += m->data[(size_t)y * m->width + x], count++;
    }
    return count > 0 && sum >= PERSON_FACE_LEAST * count;
}

void hd_person_map_max(const hd_aligned_face *f, int W, int H, int body, float *to)
{
    const hd_image *m = &f->person;
    if (!m->data || m->width < 1 || m->height < 1) return;
    const int y_end = body ? H : f->person_y0 + m->height;
    for (int gy = f->person_y0 > 0 ? f->person_y0 : 0; gy < y_end && gy < H; gy++)
        for (int gx = 0; gx < W; gx++) {
            int x = gx - f->person_x0, y = gy - f->person_y0;
            if (y >= m->height) { /* below the window, with body: its last row, its nearest pixel */
                y = m->height - 1;
                x = x < 0 ? 0 : x >= m->width ? m->width - 1 : x;
            } else if (x < 0 || x >= m->width) {
                continue;
            }
            const float v = m->data[(size_t)y * m->width + x];
            float *q = &to[(size_t)gy * W + gx];
            if (v > *q) *q = v;
        }
}
