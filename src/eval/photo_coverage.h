/* photo_coverage.h: internal to src/eval: whether a relit photo relit the whole head or only a face
 * mask (issue 36; docs/usage.md, "Measuring relighting"), on the face's own landmarks and a skin
 * model of its own cheeks. photo_eval.c adds these to `hdnet eval --photos`. */
#ifndef HD_PHOTO_COVERAGE_H
#define HD_PHOTO_COVERAGE_H

#include "hdnet.h"

/* The skin of a photo (one byte a pixel, 1 = skin; malloc'ed into *skin): pixels whose chroma
 * (r / sum, g / sum) lies within 3 median absolute deviations (plus 0.01) of the median of the
 * face's cheeks and nose (inside the face's outline, 0.25 .. 0.8 eye distances below the eyes, at
 * most 0.7 to either side of the face's axis) and whose log luminance lies between 1.2 below and
 * 0.6 above the cheeks' median (a shadowed neck is still skin). landmarks: the 468 of FaceMesh in
 * the photo's pixels. */
hd_status hd_photo_skin(const hd_image *input, const float (*landmarks)[3], unsigned char **skin);

/* Coverage, in two parts: *ring, the median |log change of luminance| (log(lum + 1/255), relit
 * against input) over the skin pixels in a ring outside the face's outline (FaceMesh's face oval:
 * 0.03 to 0.5 eye distances outside it: ears, temples, jaw line, neck), and *face, the same over
 * the skin of the nose and cheeks (the cheek sample of hd_photo_skin). coverage = ring / face:
 * 0 when only a mask changed, about 1 when the whole head did. Either part is NAN where it has no
 * pixel. */
hd_status hd_photo_coverage_parts(const hd_image *input, const hd_image *relit, const float (*landmarks)[3],
                                  const unsigned char *skin, double *ring, double *face);

/* Forehead band: the log change of luminance averaged over the skin of boxes along the forehead's
 * centre line (0.02 eye distances or 2 pixels tall, 0.3 eye distances wide, from the first box above 0.45 eye distances over
 * the eyes that is at least half skin up to the last such box in a row: the hairline, at most 2.0
 * eye distances), and the largest step between neighbouring boxes over their median step, each
 * plus 0.002: about 1 for a smooth change, large for a jump. NAN with fewer than 4 boxes (a
 * fringe over the forehead). */
double hd_photo_band(const hd_image *input, const hd_image *relit, const float (*landmarks)[3],
                     const unsigned char *skin);

#endif /* HD_PHOTO_COVERAGE_H */
