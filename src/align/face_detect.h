/* face_detect.h: MediaPipe's BlazeFace face detectors (the back-camera model shipped as the
 * default, 256 x 256; the short-range front model, 128 x 128, loads too) run by our own graph
 * runner (tfjs_graph.h) over an image pyramid of overlapping windows, with MediaPipe's
 * post-processing: SSD anchors, box and keypoint decoding, sigmoid scores, weighted non-maximum
 * suppression across windows and levels; and the photo sampler that both the detector and the
 * face mesh (rotated 192 x 192 crop) use.
 *
 * Photo coordinates are continuous pixels: x right, y down, pixel (i, j) covers [i, i+1) x [j, j+1)
 * (its centre is (i + 0.5, j + 0.5)), as in include/hdnet.h's alignment section. */
#ifndef HD_FACE_DETECT_H
#define HD_FACE_DETECT_H

#include "hdnet.h"
#include "align/align.h" /* HD_DETECT_MIN_SCORE, HD_DETECT_MIN_FACE */

/* The detector's six keypoints, in MediaPipe's order. "Right" is the person's right: on a
 * frontal photo the right eye is the one on the image's left. */
enum {
    HD_FACE_KP_RIGHT_EYE = 0,
    HD_FACE_KP_LEFT_EYE,
    HD_FACE_KP_NOSE_TIP,
    HD_FACE_KP_MOUTH,
    HD_FACE_KP_RIGHT_EAR,
    HD_FACE_KP_LEFT_EAR,
    HD_FACE_KEYPOINTS
};

#define HD_FACE_MIN_SCORE HD_DETECT_MIN_SCORE /* default detection threshold (hdnet.h) */
#define HD_FACE_NMS_IOU 0.3f     /* boxes overlapping more than this are merged */
#define HD_FACE_MIN_SIZE HD_DETECT_MIN_FACE   /* default smallest face looked for, photo pixels wide */
#define HD_FACE_DETECT_MODEL "face-models/blazeface-back.json" /* the shipped detector */

typedef struct hd_face_box {
    float score;                           /* in [0, 1] */
    float x0, y0, x1, y1;                  /* box corners in photo coordinates */
    float keypoints[HD_FACE_KEYPOINTS][2]; /* (x, y) in photo coordinates */
} hd_face_box;

/* Detects faces with the shipped model (HD_FACE_DETECT_MODEL, found with hd_find_data), the
 * default threshold and smallest face. *faces is malloc'ed (free with free()), sorted by score,
 * best first; a photo without a face gives HD_OK with *count 0 and *faces NULL. The photo may have
 * 1 (gray), 2 (gray + alpha), 3 (RGB) or 4 (RGBA) channels, any size. */
hd_status hd_face_detect(const hd_image *photo, hd_face_box **faces, int *count);

/* The same with a loaded detector, to run it on many photos: any BlazeFace TF.js graph with the
 * front model's heads (896 anchors on 16 x 16 and 8 x 8 grids) and a square input (the front
 * model 128, the back model 256). json_path NULL loads the shipped model. */
typedef struct hd_face_detector hd_face_detector;
hd_status hd_face_detector_load(const char *json_path, hd_face_detector **detector);
void hd_face_detector_free(hd_face_detector *detector);
int hd_face_detector_size(const hd_face_detector *detector);
/* The smallest face (box width, photo pixels) that one pass over the whole photo finds. */
float hd_face_detector_min_face(const hd_face_detector *detector, int width, int height);

/* Finds faces down to min_face pixels wide: the network runs on the image pyramid of
 * hd_face_pyramid and the candidates of every window are merged by weighted NMS
 * (hd_face_boxes_merge). min_score in (0, 1]; min_face 0 is the whole photo once (letterboxed). */
hd_status hd_face_detector_find(hd_face_detector *detector, const hd_image *photo, float min_score, float min_face,
                                hd_face_box **faces, int *count);
/* Only the zoom-out of a tight crop that hd_face_detector_find tries when its pyramid finds nothing:
 * for when what the pyramid found was not a face (the landmark model's presence test). */
hd_status hd_face_detector_find_zoomed(hd_face_detector *detector, const hd_image *photo, float min_score,
                                       hd_face_box **faces, int *count);
/* hd_face_detector_find with min_face HD_FACE_MIN_SIZE. */
hd_status hd_face_detector_run(hd_face_detector *detector, const hd_image *photo, float min_score,
                               hd_face_box **faces, int *count);

/* One square window of the pyramid: photo points [x, x + side) x [y, y + side), zero outside the
 * photo. `cut` marks the edges that cut through the photo (boxes crossing them are dropped: the
 * neighbouring window, overlapping by more than the level's largest face, sees the face whole). */
enum { HD_CUT_LEFT = 1, HD_CUT_TOP = 2, HD_CUT_RIGHT = 4, HD_CUT_BOTTOM = 8 };
typedef struct hd_face_window {
    float x, y, side;
    int level; /* 0: the whole photo letterboxed; then from the coarsest tiled level to the finest */
    int cut;
} hd_face_window;
/* The windows for a width x height photo and smallest face min_face: level 0; then, if level 0
 * does not see faces that small, tiled levels whose windows double in side from the finest (the
 * side at which a min_face face is just found, at least half the network's side) while under the
 * photo's longer side, neighbours overlapping by more than the faces the next coarser level misses.
 * Writes up to cap windows to out (may be NULL with cap 0) and returns how many there are. */
int hd_face_pyramid(const hd_face_detector *detector, int width, int height, float min_face, hd_face_window *out,
                    int cap);
/* Runs the network on one window and appends its candidates scoring >= min_score to the
 * detector's list (the list hd_face_detector_find clears and merges). */
hd_status hd_face_detector_window(hd_face_detector *detector, const hd_image *photo, const hd_face_window *window,
                                  float min_score);
/* Weighted non-maximum suppression: sorts by score; the best remaining box takes every remaining
 * box with IoU > iou (itself included) and becomes their score-weighted mean with the best score.
 * Writes the merged boxes to the front; returns their count (-1: out of memory). */
int hd_face_boxes_merge(hd_face_box *boxes, int n, float iou);

/* How a sampler treats points outside the photo. */
typedef enum hd_sample_border {
    HD_BORDER_ZERO,      /* black */
    HD_BORDER_REPLICATE, /* the nearest edge pixel */
    HD_BORDER_GREY       /* mid grey (0.5): the context a tight face crop lacks, without an edge of black */
} hd_sample_border;

/* Samples the photo into out (height, width, 3), NHWC RGB with values lo + (hi - lo) v for the
 * stored v in [0, 1], through the affine map from output pixel coordinates (i + s, j + t), s and t
 * in [0, 1), to photo coordinates: p = origin + (i + s) axis_x + (j + t) axis_y. Each output pixel
 * averages k x k bilinear samples, k = ceil of the larger axis length (capped at 16), so a strong
 * reduction does not alias. Gray photos are replicated to RGB; alpha is ignored. */
void hd_face_sample(const hd_image *photo, const float origin[2], const float axis_x[2], const float axis_y[2],
                    int width, int height, float lo, float hi, hd_sample_border border, float *out);

#endif /* HD_FACE_DETECT_H */
