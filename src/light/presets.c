/* presets.c: the built-in lights. Preset k (0..6) is one distant light on a cone of 60 degrees
 * around the view axis, at the angle k * 360/7 degrees counter-clockwise from image right as seen
 * by the viewer (0 = right, then toward up, left, down), with intensity 1.5 and ambient 0.5 (the
 * defaults of `hdnet light`; DPR-like shading between about 0.44 and 2.0 on the visible
 * hemisphere): a light circling the face. Generated, not stored; all seven have the same energy in
 * every SH band. */
#include <math.h>
#include "core/core.h"
#include "light/light.h"

#define PRESET_CONE_DEG 60.0
#define PRESET_INTENSITY HD_LIGHT_DEFAULT_INTENSITY
#define PRESET_AMBIENT HD_LIGHT_DEFAULT_AMBIENT

hd_status hd_light_preset(int k, float light[HD_SH_COEFFS])
{
    if (k < 0 || k >= HD_LIGHT_PRESETS)
        return hd_fail(HD_ERR_RANGE, "light preset %d does not exist (0..%d)", k, HD_LIGHT_PRESETS - 1);
    /* d = cos(cone) z + sin(cone) (cos(phi) x + sin(phi) y), as azimuth and elevation */
    const double cone = PRESET_CONE_DEG * M_PI / 180.0, phi = 2.0 * M_PI * k / HD_LIGHT_PRESETS;
    const double dx = sin(cone) * cos(phi), dy = sin(cone) * sin(phi), dz = cos(cone);
    const double elevation = asin(dy), azimuth = atan2(dx, dz);
    hd_light_from_direction((float)(azimuth * 180.0 / M_PI), (float)(elevation * 180.0 / M_PI), PRESET_INTENSITY,
                            PRESET_AMBIENT, light);
    return HD_OK;
}
