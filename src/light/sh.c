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

/* SPEC section 2 with X = x, Y = -z, Z = y:
 * s = l0 c0 - l1 c1 z + l2 c1 y + l3 c1 x - l4 c2 z x - l5 c2 z y + l6 c3 (3 y^2 - 1) + l7 c2 x y
 *     + l8 c4 (x^2 - z^2) */
float hd_sh_shade_grad(const float l[HD_SH_COEFFS], const float n[3], float dn[3])
{
    const float c0 = HD_SH_C0, c1 = HD_SH_C1, c2 = HD_SH_C2, c3 = HD_SH_C3, c4 = HD_SH_C4; /* light.h's basis */
    float x = n[0], y = n[1], z = n[2];
    dn[0] = l[3] * c1 - l[4] * c2 * z + l[7] * c2 * y + 2 * l[8] * c4 * x;
    dn[1] = l[2] * c1 - l[5] * c2 * z + 6 * l[6] * c3 * y + l[7] * c2 * x;
    dn[2] = -l[1] * c1 - l[4] * c2 * x - l[5] * c2 * y - 2 * l[8] * c4 * z;
    return l[0] * c0 - l[1] * c1 * z + l[2] * c1 * y + l[3] * c1 * x - l[4] * c2 * z * x - l[5] * c2 * z * y +
           l[6] * c3 * (3 * y * y - 1) + l[7] * c2 * x * y + l[8] * c4 * (x * x - z * z);
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
