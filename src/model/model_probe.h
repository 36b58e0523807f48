/* model_probe.h: a model's stages taken apart, for measuring them (hdnet eval --true-shading), not
 * part of the public API: N-Net run on a shading given from outside instead of S-Net's. */
#ifndef HD_MODEL_PROBE_H
#define HD_MODEL_PROBE_H

#include "hdnet.h"

/* The normals N-Net gives for `image` when it reads `shading` (1 channel, any size: resized to the
 * model's) instead of the shading S-Net predicts, everything else as hd_model_decompose (the white
 * balance included). The given shading is first scaled so that its mean over `mask` (1 channel,
 * the shading's size; NULL: every pixel) is S-Net's own: shading and albedo share an unknown scale,
 * and N-Net reads S at the level it was trained on. normal receives (3, size, size) at the model's
 * size; light, when not NULL, L-Net's light on that pass. */
hd_status hd_model_normals_from_shading(hd_model *model, const hd_image *image, const hd_image *shading,
                                        const hd_image *mask, hd_image *normal, float light[HD_SH_COEFFS]);

#endif
