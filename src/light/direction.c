/* direction.c: a gray SH light of DPR's scale from a direction, an intensity and an ambient level.
 *
 * Direction convention (camera frame, see docs/conventions.md): the light comes FROM the unit
 * direction d = (cos(el) sin(az), sin(el), cos(el) cos(az)): azimuth 0, elevation 0 is a light at
 * the viewer (d = +z); positive azimuth moves it toward image right (+x); positive elevation up (+y).
 *
 * The light is ambient + a distant light of the given intensity. A distant light toward d has the
 * radiance coefficients L_k = Y_k(d) (the real SH without the Lambertian factors); with the basis
 * b_k = A_l Y_k of SPEC section 2 its shading is s(n) = sum_l A_l (2l+1)/(4 pi) P_l(n . d), the
 * order-2 approximation of max(0, n . d), whose value at n = d is 1/4 + 1/2 + 5/16 = 17/16. We
 * scale by 16/17 so that s(d) = ambient + intensity exactly; s falls monotonically with the angle
 * from d down to about ambient - 0.037 * intensity at 122 degrees. The ambient term is a constant
 * shading: l_0 += ambient / c0. */
#include <math.h>
#include "light/light.h"

/* s(d) of the unscaled distant light: sum over bands of A_l (2l+1) / (4 pi). */
#define HD_SH_PEAK (17.0 / 16.0)

/* The light of hd_light_from_direction for a unit vector d (the direction the light comes from). */
static void light_from_vector(const double d[3], float intensity, float ambient, float light[HD_SH_COEFFS])
{
    /* Y_k(d) = b_k(d) / A_l, with A = pi * [1, 2/3, 1/4]. */
    static const double band_factor[3] = {M_PI, 2.0 * M_PI / 3.0, M_PI / 4.0};
    const float df[3] = {(float)d[0], (float)d[1], (float)d[2]};
    float b[HD_SH_COEFFS];
    hd_sh_basis(df, b);
    for (int k = 0; k < HD_SH_COEFFS; k++)
        light[k] = (float)(intensity / HD_SH_PEAK * b[k] / band_factor[hd_sh_band(k)]);
    light[0] += (float)(ambient / (double)HD_SH_C0);
}

void hd_light_from_direction(float azimuth_deg, float elevation_deg, float intensity, float ambient,
                             float light[HD_SH_COEFFS])
{
    const double az = azimuth_deg * (M_PI / 180.0), el = elevation_deg * (M_PI / 180.0);
    const double d[3] = {cos(el) * sin(az), sin(el), cos(el) * cos(az)};
    light_from_vector(d, intensity, ambient, light);
}

void hd_light_distant_part(const float light[HD_SH_COEFFS], float direction[3], float part[HD_SH_COEFFS])
{
    /* band 1 of the unit distant light from the viewer fixes the scale: the band's length is the
     * same for every direction */
    float unit[HD_SH_COEFFS];
    const double z[3] = {0, 0, 1};
    light_from_vector(z, 1.0f, 0.0f, unit);
    const double u = sqrt((double)unit[1] * unit[1] + (double)unit[2] * unit[2] + (double)unit[3] * unit[3]);
    const double v[3] = {light[3], light[2], -light[1]};
    const double len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (!(len > 1e-12) || !isfinite(len)) {
        direction[0] = direction[1] = 0.0f, direction[2] = 1.0f;
        for (int k = 0; k < HD_SH_COEFFS; k++) part[k] = 0.0f;
        return;
    }
    const double d[3] = {v[0] / len, v[1] / len, v[2] / len};
    for (int a = 0; a < 3; a++) direction[a] = (float)d[a];
    light_from_vector(d, (float)(len / u), 0.0f, part);
}
