/* face_light.c: the face's own light, the one place it is computed: the source light of the
 * relighting rule (src/apply, hd_face_light) and the training's --light-target face and fit-pair
 * term (src/train) both call hd_face_light_fit, so the light a model is trained toward is the
 * light the rule relights from. */
#include <string.h>
#include "core/core.h"
#include "mesh/mesh.h"
#include "light/light.h"

hd_status hd_face_light_layout(int size, hd_image *layout)
{
    memset(layout, 0, sizeof *layout);
    hd_image regions = {0};
    hd_status st = hd_face_regions_uv(size, &regions);
    if (st == HD_OK) st = hd_face_fit_weight_uv(size, HD_FIT_LOWER_FACE, layout);
    for (size_t p = 0; st == HD_OK && p < (size_t)size * size; p++)
        if (regions.data[p] > 0.5f) layout->data[p] = 0.0f;
    hd_image_free(&regions);
    if (st != HD_OK) hd_image_free(layout);
    return st;
}

void hd_face_light_weight(const float *layout, const float *mask, int npix, float *weight)
{
    for (int p = 0; p < npix; p++) weight[p] = !mask || mask[p] > 0.5f ? layout[p] : 0.0f;
}

hd_status hd_face_light_fit(const float *normal, const float *shading, const float *layout, const float *mask,
                            int npix, float *weight, float lobe[HD_SH_COEFFS], int hold_lobe,
                            float light[HD_SH_COEFFS])
{
    memset(light, 0, HD_SH_COEFFS * sizeof *light);
    if (npix < 0 || !layout || !weight || !lobe) return hd_fail(HD_ERR_ARG, "face light: invalid arguments");
    hd_face_light_weight(layout, mask, npix, weight);
    hd_status st = hold_lobe ? HD_OK : hd_sh_fit_lobe(normal, shading, weight, npix, lobe);
    if (st == HD_OK) st = hd_sh_fit_toward(normal, shading, weight, npix, lobe, HD_SOURCE_PRIOR, light);
    return st;
}
