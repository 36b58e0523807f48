/* face_landmarks.c: the face mesh model (MediaPipe face landmarks, TF.js graph, 192 x 192 RGB in
 * [0, 1], outputs 468 x (x, y, z) in crop pixels and a face-presence probability) on a rotated
 * crop of the photo, and the crop rules of MediaPipe's face landmark pipeline.
 * Input range [0, 1] as the TF.js port feeds it (pixel / 255); on the bundled photo [-1, 1] gives
 * the same landmarks within a pixel, so the model is not sensitive to it. The crop's border is
 * replicated (MediaPipe's BORDER_REPLICATE). The second pass (crop from the first pass's
 * landmarks) is what MediaPipe does on the next video frame; on a still photo it centres the crop
 * on the face rather than on the coarse detection box. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "graph/tfjs_graph.h"
#include "align/face_landmarks.h"

#define MESH_SIZE 192
#define MESH_OUTPUT "Identity_2"     /* (1, 1404) */
#define PRESENCE_OUTPUT "Identity_1" /* (1, 1), after a sigmoid */
#define LANDMARK_RIGHT_EYE_OUTER 33
#define LANDMARK_LEFT_EYE_OUTER 263

struct hd_face_mesh {
    hd_tfjs_graph *graph;
    float *input; /* (192, 192, 3) */
};

void hd_face_roi_from_box(const hd_face_box *face, hd_face_roi *roi)
{
    float w = face->x1 - face->x0, h = face->y1 - face->y0;
    const float *r = face->keypoints[HD_FACE_KP_RIGHT_EYE], *l = face->keypoints[HD_FACE_KP_LEFT_EYE];
    roi->cx = 0.5f * (face->x0 + face->x1);
    roi->cy = 0.5f * (face->y0 + face->y1);
    roi->size = HD_FACE_ROI_SCALE * (w > h ? w : h);
    roi->angle = atan2f(l[1] - r[1], l[0] - r[0]); /* eyes level in the crop */
}

void hd_face_roi_from_landmarks(const float landmarks[HD_FACE_MESH_POINTS][3], hd_face_roi *roi)
{
    const float *r = landmarks[LANDMARK_RIGHT_EYE_OUTER], *l = landmarks[LANDMARK_LEFT_EYE_OUTER];
    float angle = atan2f(l[1] - r[1], l[0] - r[0]);
    float ux = cosf(angle), uy = sinf(angle);
    /* Extent along u = (ux, uy) and v = (-uy, ux). */
    float umin = INFINITY, umax = -INFINITY, vmin = INFINITY, vmax = -INFINITY;
    for (int i = 0; i < HD_FACE_MESH_POINTS; i++) {
        float pu = landmarks[i][0] * ux + landmarks[i][1] * uy, pv = -landmarks[i][0] * uy + landmarks[i][1] * ux;
        umin = fminf(umin, pu);
        umax = fmaxf(umax, pu);
        vmin = fminf(vmin, pv);
        vmax = fmaxf(vmax, pv);
    }
    float mu = 0.5f * (umin + umax), mv = 0.5f * (vmin + vmax);
    roi->cx = mu * ux - mv * uy;
    roi->cy = mu * uy + mv * ux;
    roi->size = HD_FACE_ROI_SCALE * fmaxf(umax - umin, vmax - vmin);
    roi->angle = angle;
}

void hd_face_mesh_free(hd_face_mesh *m)
{
    if (!m) return;
    hd_tfjs_free(m->graph);
    free(m->input);
    free(m);
}

hd_status hd_face_mesh_load(const char *json_path, hd_face_mesh **mesh)
{
    *mesh = NULL;
    char *found = NULL;
    if (!json_path) {
        found = hd_find_data("face-models/facemesh.json");
        if (!found) return HD_ERR_NOTFOUND;
        json_path = found;
    }
    hd_face_mesh *m = hd_calloc(1, sizeof *m);
    if (!m) {
        free(found);
        return HD_ERR_NOMEM;
    }
    hd_status st = hd_tfjs_load(json_path, &m->graph);
    if (st != HD_OK) goto fail;
    int h, w, c, nd, dims[4];
    hd_tfjs_input_shape(m->graph, &h, &w, &c);
    if (h != MESH_SIZE || w != MESH_SIZE || c != 3) {
        st = hd_fail(HD_ERR_FORMAT, "%s: input is %dx%dx%d, the face mesh wants 192x192x3", json_path, h, w, c);
        goto fail;
    }
    m->input = hd_calloc((size_t)MESH_SIZE * MESH_SIZE * 3, sizeof(float));
    if (!m->input) {
        st = HD_ERR_NOMEM;
        goto fail;
    }
    if (!hd_tfjs_output(m->graph, MESH_OUTPUT, &nd, dims) || nd != 2 || dims[1] != 3 * HD_FACE_MESH_POINTS ||
        !hd_tfjs_output(m->graph, PRESENCE_OUTPUT, &nd, dims) || nd != 2 || dims[1] != 1) {
        st = hd_fail(HD_ERR_FORMAT, "%s: not the face mesh model: outputs %s (1, 1404) and %s (1, 1) expected", json_path,
                     MESH_OUTPUT, PRESENCE_OUTPUT);
        goto fail;
    }
    free(found);
    *mesh = m;
    return HD_OK;
fail:
    free(found);
    hd_face_mesh_free(m);
    return st;
}

hd_status hd_face_mesh_run(hd_face_mesh *m, const hd_image *photo, const hd_face_roi *roi,
                           float landmarks[HD_FACE_MESH_POINTS][3], float *presence)
{
    if (!photo || !photo->data || photo->width < 1 || photo->height < 1 || photo->channels < 1 || photo->channels > 4)
        return hd_fail(HD_ERR_ARG, "face landmarks: the photo is empty or has an unsupported channel count");
    if (!(isfinite(roi->cx) && isfinite(roi->cy) && isfinite(roi->angle) && roi->size >= 1.0f && roi->size < 1e6f))
        return hd_fail(HD_ERR_ARG, "face landmarks: the face region (centre %g, %g, side %g) is degenerate",
                       (double)roi->cx, (double)roi->cy, (double)roi->size);
    /* Crop pixel (i + s, j + t) shows photo point
     *   p = c + ((i + s) / 192 - 1/2) S u + ((j + t) / 192 - 1/2) S v,  u = (cos a, sin a), v = (-sin a, cos a). */
    float ux = cosf(roi->angle), uy = sinf(roi->angle), k = roi->size / MESH_SIZE;
    float ax[2] = {k * ux, k * uy}, ay[2] = {-k * uy, k * ux};
    float origin[2] = {roi->cx - 0.5f * MESH_SIZE * (ax[0] + ay[0]), roi->cy - 0.5f * MESH_SIZE * (ax[1] + ay[1])};
    hd_face_sample(photo, origin, ax, ay, MESH_SIZE, MESH_SIZE, 0.0f, 1.0f, HD_BORDER_REPLICATE, m->input);
    hd_status st = hd_tfjs_run(m->graph, m->input);
    if (st != HD_OK) return st;
    const float *out = hd_tfjs_output(m->graph, MESH_OUTPUT, NULL, NULL);
    const float *flag = hd_tfjs_output(m->graph, PRESENCE_OUTPUT, NULL, NULL);
    for (int i = 0; i < HD_FACE_MESH_POINTS; i++) {
        float lx = out[3 * i], ly = out[3 * i + 1], lz = out[3 * i + 2];
        landmarks[i][0] = origin[0] + lx * ax[0] + ly * ay[0];
        landmarks[i][1] = origin[1] + lx * ax[1] + ly * ay[1];
        landmarks[i][2] = lz * k; /* depth scaled like x */
    }
    if (presence) *presence = flag[0];
    return HD_OK;
}

hd_status hd_face_mesh_fit(hd_face_mesh *m, const hd_image *photo, const hd_face_box *face, int passes,
                           float landmarks[HD_FACE_MESH_POINTS][3], float *presence)
{
    hd_face_roi roi;
    hd_face_roi_from_box(face, &roi);
    hd_status st = hd_face_mesh_run(m, photo, &roi, landmarks, presence);
    for (int p = 1; p < passes && st == HD_OK; p++) {
        hd_face_roi_from_landmarks((const float(*)[3])landmarks, &roi);
        st = hd_face_mesh_run(m, photo, &roi, landmarks, presence);
    }
    return st;
}

hd_status hd_face_landmarks(const hd_image *photo, const hd_face_box *face,
                            float landmarks[HD_FACE_MESH_POINTS][3], float *presence)
{
    hd_face_mesh *m;
    hd_status st = hd_face_mesh_load(NULL, &m);
    if (st != HD_OK) return st;
    st = hd_face_mesh_fit(m, photo, face, 2, landmarks, presence);
    hd_face_mesh_free(m);
    return st;
}
