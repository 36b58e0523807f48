/* white_balance.h: internal to src/model: the eyes and the eye-white tint on planar data (white_balance.c). */
#ifndef HD_WHITE_BALANCE_H
#define HD_WHITE_BALANCE_H

#include "hdnet.h"

/* The sclera's chroma (rgb / mean of rgb) the estimate takes as neutral (white_balance.c says whence) */
extern const float hd_sclera_chroma[3];
/* The bounds of each channel's tint (the estimate is clamped to them) */
#define HD_TINT_MIN 0.7f
#define HD_TINT_MAX 1.4f

/* The eyes' openings (their contours, not grown) at size x size in the aligned texture's layout. */
hd_status hd_eyes_uv(int size, hd_image *eyes);
/* The tint (per-channel gains of mean 1) of a size x size planar RGB texture from the texels where
 * eyes > 0.5 (hd_eyes_uv at the same size); 1, 1, 1 when too few are bright enough. Fails only
 * for want of memory. */
hd_status hd_eye_tint(const float *rgb, int size, const float *eyes, float tint[3]);

/* The colour cast of an aligned face texture (square RGB, docs/spec.md section 2) from the whites of
 * its eyes: the chroma of the brighter half of the texels inside the two eye contours against the
 * sclera's chroma in the synthetic faces, as per-channel gains of mean 1 clamped to 0.7..1.4; 1, 1, 1
 * when the eyes hold fewer than 8 texels brighter than 0.02 (closed or masked out). */
hd_status hd_eye_white_balance(const hd_image *texture, float tint[3]);

#endif
