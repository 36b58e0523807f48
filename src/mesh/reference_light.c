/* reference_light.c: the light of a REFERENCE face, the target light `hdnet transfer --ref` and
 * `hdnet estimate-light` give (not the source light of the relighting rule, face_light.c). The
 * face's own-light fit is tuned to explain the face it relights; a reference's light is wanted
 * for its direction, and the own-light fit's direction is 12.9 degrees off the truth on the Yale
 * tuning photos (docs/evaluation.md). Two changes move it toward the truth there:
 *   - each texel's weight is divided by max(n_z, HD_REF_NZ_FLOOR)^2 (n_z the normal's camera
 *     component): the texels that turn away from the camera (cheeks, jaw, the sides of the nose)
 *     see the light's side-to-side and up-down change most, and a face's normals fill only a cap of
 *     the sphere around +z, so the frontal texels outnumber them;
 *   - the pull toward the best ambient + distant light is weaker (HD_REF_PRIOR instead of the own
 *     light's HD_SOURCE_PRIOR): the least-squares light, less the lobe.
 * Both constants were chosen on the Yale tuning subjects only (docs/model-card.md). */
#include <math.h>
#include <string.h>
#include "core/core.h"
#include "mesh/mesh.h"
#include "light/light.h"

hd_status hd_reference_light_fit(const float *normal, const float *shading, const float *layout, const float *mask,
                                 int npix, float *weight, float light[HD_SH_COEFFS])
{
    memset(light, 0, HD_SH_COEFFS * sizeof *light);
    if (npix < 0 || !layout || !weight || (npix > 0 && !normal)) return hd_fail(HD_ERR_ARG, "reference light: invalid arguments");
    hd_face_light_weight(layout, mask, npix, weight);
    const float *nz = normal + 2 * (size_t)npix;
    for (int p = 0; p < npix; p++)
        if (weight[p] > 0.0f) {
            const float z = isfinite(nz[p]) && nz[p] > HD_REF_NZ_FLOOR ? nz[p] : HD_REF_NZ_FLOOR;
            weight[p] /= z * z;
        }
    float lobe[HD_SH_COEFFS];
    hd_status st = hd_sh_fit_lobe(normal, shading, weight, npix, lobe);
    if (st == HD_OK) st = hd_sh_fit_toward(normal, shading, weight, npix, lobe, HD_REF_PRIOR, light);
    return st;
}
