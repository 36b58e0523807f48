/* align.h: the aligning calls beyond the public ones: one face from landmarks already found
 * (align_face.c; the video relighter's tracking and the tests) and an aligner's detection settings
 * (aligner.c), and where the person is about a face (aligner.c, person_segment.c). */
#ifndef HD_ALIGN_H
#define HD_ALIGN_H

#include "hdnet.h"

/* Aligns one face given its landmarks in `photo` (3 channels): fits the canonical mesh, unwarps
 * the photo into an S x S texture (barycentric position of each texel in its UV triangle mapped
 * through the landmark triangle, bilinear sampling), and computes the mask and coarse normals.
 * size in [16, 4096]. Fails (HD_ERR_NUMERIC / HD_ERR_RANGE) on non-finite or degenerate
 * landmarks. The face owns its images: free with hd_aligned_face_free. */
hd_status hd_align_face(const hd_image *photo, const float landmarks[HD_FACE_LANDMARKS][3], int size,
                        hd_aligned_face *face);
/* Face detection settings of an aligner (docs/face_detect.md): the score threshold in (0, 1]
 * (default HD_DETECT_MIN_SCORE) and the smallest face looked for, in photo pixels wide (default
 * HD_DETECT_MIN_FACE; the photo is searched over an image pyramid down to that size; 0: one pass
 * over the whole photo, which finds faces from about 7 % of its longer side up). */
#define HD_DETECT_MIN_SCORE 0.75f
#define HD_DETECT_MIN_FACE 40.0f
hd_status hd_aligner_set_detection(hd_aligner *aligner, float min_score, float min_face);
/* Fills face->person (where the person is, about the face; person_segment.h) with one of the
 * aligner's segmentation networks, for a face aligned from landmarks (a video's tracked face).
 * photo: 3 channels, the one the face was aligned in. */
hd_status hd_aligner_segment(hd_aligner *aligner, const hd_image *photo, hd_aligned_face *face);

/* The rotation R (row-major) that maximises sum_i w_i c_i . (R p_i), from S_ab = sum_i w_i p_ia c_ib
 * (Horn 1987, unit quaternions): the similarity fit's, and the one that turns the model's normals
 * to the landmark fit's pose (hd_face_repose). */
void hd_best_rotation(const double S[3][3], double R[9]);

#endif /* HD_ALIGN_H */
