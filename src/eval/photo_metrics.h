/* photo_metrics.h: internal to src/eval (and its tests): relighting measured on real photos
 * without ground truth (photo_metrics.c, docs/usage.md "Measuring relighting"), which
 * hd_photo_eval_run and hd_pair_eval_run report. */
#ifndef HD_EVAL_PHOTO_METRICS_H
#define HD_EVAL_PHOTO_METRICS_H

#include "hdnet.h"

/* Each compares a relit photo with its input (RGB, same size) over the
 * pixels the relighting changed (`changed`, one byte a pixel, from hd_photo_changed). */
hd_status hd_photo_changed(const hd_image *input, const hd_image *relit, unsigned char **changed, long *count);
/* 1000 x the mean over changed pixels of sum_c |rgb_c / (r + g + b) change| (pixels whose r + g + b
 * is 0.06 or less in either picture left out): 0 when every colour is kept. */
double hd_photo_chroma(const hd_image *input, const hd_image *relit, const unsigned char *changed);
/* The correlation of the 5-point Laplacian of log(luminance + 1/255) of relit and input over the
 * changed pixels: 1 when all detail is kept. Luminance: Rec. 709 weights of the stored values. */
double hd_photo_detail(const hd_image *input, const hd_image *relit, const unsigned char *changed);
/* The mean relit / input luminance ratio over discs of radius 0.12 x the pupils' distance around
 * the two pupils (photo pixels, x y) over the same mean across the changed pixels (ratios where
 * the input's luminance exceeds 0.02): 1 when the eyes follow the light. */
double hd_photo_glow(const hd_image *input, const hd_image *relit, const unsigned char *changed,
                     const float pupils[2][2]);
/* The mean gradient magnitude (forward differences) of the luminance change relit - input on the
 * border of the changed region (the changed pixels closed by a 5 x 5 square, so that the line where
 * a smooth change crosses zero, whose pixels round to the input's, is no border; pixels with a
 * 4-neighbour on the other side, no edge of the input's own between them: a log-luminance step
 * above 0.1 is the person's outline, where the change may stop) over the same inside it: about 1
 * or less when there is no seam. NAN only for want of memory. */
double hd_photo_seam(const hd_image *input, const hd_image *relit, const unsigned char *changed);
/* Mean absolute difference over the 3 channels of the pixels in `where` (NULL: all). */
double hd_photo_mae(const hd_image *a, const hd_image *b, const unsigned char *where);
/* The mean luminance of relit over that of input, over `where` (NULL: all). */
double hd_photo_mean_lum_ratio(const hd_image *input, const hd_image *relit, const unsigned char *where);
/* |a - b| / |a| (Euclidean norms of the 9 coefficients). */
double hd_light_difference(const float a[HD_SH_COEFFS], const float b[HD_SH_COEFFS]);
/* SSIM of two pictures of one size (up to 3 channels, clamped to [0, 1]) averaged over the pixels
 * with mask > 0.5 (NULL: all): 1 for equal pictures. NAN only for want of memory. */
double hd_ssim_masked(const hd_image *a, const hd_image *b, const float *mask);

#endif /* HD_EVAL_PHOTO_METRICS_H */
