/* face.c: relighting with a model, texture in and texture out (decompose, then relight.c). These
 * are the cores of `hdnet relight`, `transfer`, `delight`
 * and `estimate-light`; photo alignment wraps them (photo -> texture -> core -> texture -> photo). */
#include <string.h>
#include "core/core.h"

hd_status hd_relight_face(hd_model *model, const hd_image *image, const hd_image *mask,
                          const float light[HD_SH_COEFFS], hd_brightness brightness, hd_image *out)
{
    memset(out, 0, sizeof *out);
    hd_decomposition d;
    memset(&d, 0, sizeof d);
    hd_status st = hd_model_decompose(model, image, 1, &d);
    if (st == HD_OK) st = hd_relight(image, &d, mask, light, brightness, out);
    hd_decomposition_free(&d);
    return st;
}

hd_status hd_delight_face(hd_model *model, const hd_image *image, const hd_image *mask, hd_image *out)
{
    memset(out, 0, sizeof *out);
    hd_decomposition d;
    memset(&d, 0, sizeof d);
    hd_status st = hd_model_decompose(model, image, 1, &d);
    if (st == HD_OK) st = hd_delight(image, &d, mask, out);
    hd_decomposition_free(&d);
    return st;
}

hd_status hd_estimate_light(hd_model *model, const hd_image *image, float light[HD_SH_COEFFS])
{
    hd_decomposition d;
    memset(&d, 0, sizeof d);
    hd_status st = hd_model_decompose(model, image, 1, &d);
    if (st == HD_OK) memcpy(light, d.light, sizeof d.light);
    hd_decomposition_free(&d);
    return st;
}

/* Transfer decomposes the two faces one at a time (not as a batch of two) so that its result is
 * bit-identical to hd_relight_face under hd_estimate_light(ref). */
hd_status hd_transfer_face(hd_model *model, const hd_image *image, const hd_image *mask,
                           const hd_image *ref, hd_brightness brightness, hd_image *out)
{
    memset(out, 0, sizeof *out);
    float light[HD_SH_COEFFS];
    hd_status st = hd_estimate_light(model, ref, light);
    if (st == HD_OK) st = hd_relight_face(model, image, mask, light, brightness, out);
    return st;
}
