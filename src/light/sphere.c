/* sphere.c: a preview of a light: the shading of a unit sphere seen from the front (orthographic,
 * the camera frame of SPEC section 2: x right, y up, the visible hemisphere z > 0), gray in all
 * three channels, displayed as s/2 clamped to [0, 1] (the same scale as shading PNGs, so shading
 * up to 2 shows without clipping), the background black. */
#include <math.h>
#include "core/core.h"
#include "light/light.h"

hd_status hd_light_sphere(const float light[HD_SH_COEFFS], int size, hd_image *out)
{
    if (size < 1 || size > HD_IMAGE_MAX_SIDE)
        return hd_fail(HD_ERR_RANGE, "light sphere: size %d is out of range (1..%d)", size, HD_IMAGE_MAX_SIDE);
    hd_status st = hd_image_alloc(out, size, size, 3);
    if (st != HD_OK) return st;
    const size_t plane = (size_t)size * size;
    for (int y = 0; y < size; y++) {
        for (int x = 0; x < size; x++) {
            /* pixel centre -> [-1, 1], y up */
            const float u = (2.0f * x + 1.0f) / size - 1.0f, v = 1.0f - (2.0f * y + 1.0f) / size;
            const float r2 = u * u + v * v;
            float value = 0.0f;
            if (r2 < 1.0f) {
                const float n[3] = {u, v, sqrtf(1.0f - r2)};
                value = 0.5f * hd_sh_shade(light, n);
                value = value < 0.0f ? 0.0f : value > 1.0f ? 1.0f : value;
            }
            for (int c = 0; c < 3; c++) out->data[c * plane + (size_t)y * size + x] = value;
        }
    }
    return HD_OK;
}
