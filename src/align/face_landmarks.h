/* face_landmarks.h: MediaPipe's face mesh (468 landmarks, the vertex order of
 * models/canonical_face_model.obj) run by our own graph runner on a rotated crop of the photo, as
 * MediaPipe's face landmark pipeline does: the crop is a square around the detection box, turned
 * so that the eyes lie level, 1.5 times the box's longer side, sampled to 192 x 192; the model's
 * crop-pixel landmarks are mapped back through the inverse of that crop.
 *
 * Landmarks are (x, y, z): x, y in photo coordinates (continuous pixels, x right, y down, pixel
 * centres at +0.5; see face_detect.h); z is the model's relative depth in the same units as x,
 * with MediaPipe's sign: smaller is closer to the camera (the nose tip has the smallest z). */
#ifndef HD_FACE_LANDMARKS_H
#define HD_FACE_LANDMARKS_H

#include "hdnet.h"
#include "align/face_detect.h"

#define HD_FACE_MESH_POINTS 468
#define HD_FACE_ROI_SCALE 1.5f /* crop side / face extent */

/* A rotated square crop of the photo: centre, side (photo pixels) and the angle (radians) of the
 * crop's x axis in photo coordinates: the axis is (cos angle, sin angle), the crop's y axis
 * (-sin angle, cos angle). */
typedef struct hd_face_roi {
    float cx, cy, size, angle;
} hd_face_roi;

/* The crop MediaPipe takes from a detection: centred on the box, angle from the right eye to the
 * left eye keypoint, side HD_FACE_ROI_SCALE times the box's longer side. */
void hd_face_roi_from_box(const hd_face_box *face, hd_face_roi *roi);
/* The crop MediaPipe takes from landmarks (to track, or to refine): angle from the right eye's
 * outer corner (33) to the left eye's (263), the landmarks' bounding box in that rotated frame,
 * side HD_FACE_ROI_SCALE times its longer side. */
void hd_face_roi_from_landmarks(const float landmarks[HD_FACE_MESH_POINTS][3], hd_face_roi *roi);

/* Finds the 468 landmarks of the face detected as `face` with the shipped model
 * (face-models/facemesh.json): one pass on the crop from the detection, a second on the crop from
 * the first pass's landmarks. presence (may be NULL) is the model's face-presence probability
 * in [0, 1] for the final crop (MediaPipe rejects below 0.5). */
hd_status hd_face_landmarks(const hd_image *photo, const hd_face_box *face,
                            float landmarks[HD_FACE_MESH_POINTS][3], float *presence);

/* The same with a loaded model, one pass on a given crop. */
typedef struct hd_face_mesh hd_face_mesh;
/* json_path NULL loads the shipped model. */
hd_status hd_face_mesh_load(const char *json_path, hd_face_mesh **mesh);
void hd_face_mesh_free(hd_face_mesh *mesh);
hd_status hd_face_mesh_run(hd_face_mesh *mesh, const hd_image *photo, const hd_face_roi *roi,
                           float landmarks[HD_FACE_MESH_POINTS][3], float *presence);
/* Detection-to-landmarks as hd_face_landmarks does it (passes: 1 = the detection crop only,
 * 2 = refined once from the landmarks). */
hd_status hd_face_mesh_fit(hd_face_mesh *mesh, const hd_image *photo, const hd_face_box *face, int passes,
                           float landmarks[HD_FACE_MESH_POINTS][3], float *presence);

#endif /* HD_FACE_LANDMARKS_H */
