/* sh.c: the spherical-harmonics basis and shading of SPEC section 2 (9 coefficients, DPR's order,
 * frame and scale). The basis already carries the Lambertian factors pi*[1, 2/3, 1/4], so the
 * shading of a unit normal n under a light l is the plain dot product s(n) = sum_k l_k b_k(n). */
#include "light/light.h"

/* b_k(n) with X = x, Y = -z, Z = y (camera frame -> DPR/shtools frame: X right, Y into the screen,
 * Z up). The constants are the real SH normalisations times the Lambertian factors A_l. */
void hd_sh_basis(const float normal[3], float basis[HD_SH_COEFFS])
{
    const float X = normal[0], Y = -normal[2], Z = normal[1];
    basis[0] = HD_SH_C0;
    basis[1] = HD_SH_C1 * Y;
    basis[2] = HD_SH_C1 * Z;
    basis[3] = HD_SH_C1 * X;
    basis[4] = HD_SH_C2 * Y * X;
    basis[5] = HD_SH_C2 * Y * Z;
    basis[6] = HD_SH_C3 * (3.0f * Z * Z - 1.0f);
    basis[7] = HD_SH_C2 * X * Z;
    basis[8] = HD_SH_C4 * (X * X - Y * Y);
}

/* s(n) = sum_k l_k b_k(n). */
float hd_sh_shade(const float light[HD_SH_COEFFS], const float normal[3])
{
    float b[HD_SH_COEFFS];
    hd_sh_basis(normal, b);
    float s = 0.0f;
    for (int k = 0; k < HD_SH_COEFFS; k++) s += light[k] * b[k];
    return s;
}

void hd_sh_shading_map(const float *normal, const float *mask, int npix,
                       const float light[HD_SH_COEFFS], float *shading)
{
    const float *nx = normal, *ny = normal + npix, *nz = normal + 2 * (size_t)npix;
    for (int p = 0; p < npix; p++) {
        if (mask && !(mask[p] > 0.0f)) {
            shading[p] = 0.0f;
            continue;
        }
        const float n[3] = {nx[p], ny[p], nz[p]};
        shading[p] = hd_sh_shade(light, n);
    }
}
