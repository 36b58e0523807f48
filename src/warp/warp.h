/* warp.h: warping back on an aligner's own canonical mesh (warp_back.c) instead of the process's
 * shared copy; the public hd_warp_back and hd_warp_back_blend are these on the shared mesh. */
#ifndef HD_WARP_H
#define HD_WARP_H

#include "hdnet.h"

/* hd_align_face, hd_warp_back and hd_warp_back_blend read the canonical mesh once per process (at
 * their first call; each file found by the data search path is read once) and then share it,
 * read-only, between calls and threads; an aligner reads its own at hd_aligner_load
 * (hd_aligner_run aligns on it) and these warp back on it. */
hd_status hd_aligner_warp_back(const hd_aligner *aligner, const hd_aligned_face *face, const hd_image *texture,
                               const hd_image *tex_mask, hd_image *warped, hd_image *coverage);
hd_status hd_aligner_warp_back_blend(const hd_aligner *aligner, const hd_aligned_face *face, const hd_image *texture,
                                     hd_warp_mode mode, double tolerance, hd_image *photo, hd_poisson_report *report);

#endif /* HD_WARP_H */
