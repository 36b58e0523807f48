/* face_detect.h: MediaPipe's short-range ("front") BlazeFace face detector run by our own graph
 * runner (tfjs_graph.h), with MediaPipe's post-processing: SSD anchors, box and keypoint
 * decoding, sigmoid scores, weighted non-maximum suppression; and the photo sampler that both the
 * detector (letterboxed 128 x 128 input) and the face mesh (rotated 192 x 192 crop) use.
 *
 * Photo coordinates are continuous pixels: x right, y down, pixel (i, j) covers [i, i+1) x [j, j+1)
 * (its centre is (i + 0.5, j + 0.5)), as in include/hdnet.h's alignment section. */
#ifndef HD_FACE_DETECT_H
#define HD_FACE_DETECT_H

#include "hdnet.h"

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

#define HD_FACE_MIN_SCORE 0.75f  /* default detection threshold */
#define HD_FACE_NMS_IOU 0.3f     /* boxes overlapping more than this are merged */

typedef struct hd_face_box {
    float score;                           /* in [0, 1] */
    float x0, y0, x1, y1;                  /* box corners in photo coordinates */
    float keypoints[HD_FACE_KEYPOINTS][2]; /* (x, y) in photo coordinates */
} hd_face_box;

/* Detects faces with the shipped model (face-models/blazeface-front.json, found with
 * hd_find_data) and the default threshold. *faces is malloc'ed (free with free()), sorted by
 * score, best first; a photo without a face gives HD_OK with *count 0 and *faces NULL. The photo
 * may have 1 (gray), 2 (gray + alpha), 3 (RGB) or 4 (RGBA) channels, any size. */
hd_status hd_face_detect(const hd_image *photo, hd_face_box **faces, int *count);

/* The same with a loaded detector, to run it on many photos. */
typedef struct hd_face_detector hd_face_detector;
/* json_path NULL loads the shipped model. */
hd_status hd_face_detector_load(const char *json_path, hd_face_detector **detector);
void hd_face_detector_free(hd_face_detector *detector);
/* min_score in (0, 1]. */
hd_status hd_face_detector_run(hd_face_detector *detector, const hd_image *photo, float min_score,
                               hd_face_box **faces, int *count);

/* How a sampler treats points outside the photo. */
typedef enum hd_sample_border {
    HD_BORDER_ZERO,     /* black */
    HD_BORDER_REPLICATE /* the nearest edge pixel */
} hd_sample_border;

/* Samples the photo into out (height, width, 3), NHWC RGB with values lo + (hi - lo) v for the
 * stored v in [0, 1], through the affine map from output pixel coordinates (i + s, j + t), s and t
 * in [0, 1), to photo coordinates: p = origin + (i + s) axis_x + (j + t) axis_y. Each output pixel
 * averages k x k bilinear samples, k = ceil of the larger axis length (capped at 16), so a strong
 * reduction does not alias. Gray photos are replicated to RGB; alpha is ignored. */
void hd_face_sample(const hd_image *photo, const float origin[2], const float axis_x[2], const float axis_y[2],
                    int width, int height, float lo, float hi, hd_sample_border border, float *out);

#endif /* HD_FACE_DETECT_H */
