/* light.h: internals of the spherical-harmonics lighting module shared by its files (the basis
 * constants of SPEC section 2 and the Lambertian factors they contain), the basis itself and the
 * fits the face's own light needs beyond the public hd_sh_fit. */
#ifndef HD_LIGHT_H
#define HD_LIGHT_H

#include "hdnet.h"

/* Basis constants: the real SH normalisations times pi*[1, 2/3, 1/4] (SPEC section 2). */
#define HD_SH_C0 0.8862269254527579f /* pi       * 0.2820947918 (l = 0) */
#define HD_SH_C1 1.023326707946488f  /* 2*pi/3   * 0.4886025119 (l = 1) */
#define HD_SH_C2 0.8580855308097834f /* pi/4     * 1.0925484306 (l = 2, xy yz xz) */
#define HD_SH_C3 0.2477079561003757f /* pi/4     * 0.3153915653 (l = 2, 3z^2-1) */
#define HD_SH_C4 0.4290427654048917f /* pi/4     * 0.5462742153 (l = 2, x^2-y^2) */

/* s(n) = sum_k l_k b_k(n) (hd_sh_shade) and its gradient wrt the normal (SPEC section 2 basis). */
float hd_sh_shade_grad(const float light[HD_SH_COEFFS], const float n[3], float dn[3]);

/* The band (0, 1 or 2) of coefficient k. */
static inline int hd_sh_band(int k) { return k == 0 ? 0 : k < 4 ? 1 : 2; }

/* The light of the mirror image (x -> -x, as a horizontally flipped face texture sees it): the
 * coefficients odd in x (1-based 4, 5 and 8: x, y x and x z in SPEC section 2) change sign, so
 * that s(mirror(n), mirror(l)) = s(n, l). */
static inline void hd_light_mirror(float light[HD_SH_COEFFS])
{
    light[3] = -light[3];
    light[4] = -light[4];
    light[7] = -light[7];
}

/* hd_sh_fit_toward(..., prior = hd_sh_fit_lobe(...), strength, light) with the normal equations
 * summed once: the face's own light (hd_face_light). With no pixel in the mask, the zero light. */
hd_status hd_sh_fit_toward_lobe(const float *normal, const float *shading, const float *mask, int npix,
                                float strength, float light[HD_SH_COEFFS]);

/* The adjoint of hd_sh_fit_toward with the prior held: y = M^-1 g, M = sum_p m_p b(n_p) b(n_p)^T +
 * (ridge + strength * sum_p m_p) I the fit's own system, so that for the fit l, dl . g = y . dr
 * - y . dM l (the training term fit_pair's backward; src/train/losses.c). No pixel: y = 0. */
hd_status hd_sh_fit_adjoint(const float *normal, const float *mask, int npix, float strength,
                            const float g[HD_SH_COEFFS], float y[HD_SH_COEFFS]);

/* ---- the basis and the constrained fits (the face's own light: src/mesh/face_light.c) */
/* The 9 basis values b_k(n) of SPEC section 2 for a camera-frame normal n. */
void hd_sh_basis(const float normal[3], float basis[HD_SH_COEFFS]);
/* The same pulled toward a prior light: argmin_l sum_p m_p (b(n_p).l - s_p)^2 + strength *
 * (sum_p m_p) * |l - prior|^2 (strength >= 0; 0: hd_sh_fit; prior NULL: the zero light). With
 * no pixel in the mask the answer is the prior (when strength > 0). */
hd_status hd_sh_fit_toward(const float *normal, const float *shading, const float *mask, int npix,
                           const float prior[HD_SH_COEFFS], float strength, float light[HD_SH_COEFFS]);
/* The best light of hd_light_from_direction's family (an ambient level plus one distant light
 * of intensity >= 0, from within 100 degrees of the viewer) for the masked shading: argmin over
 * that family of sum_p m_p (b(n_p).l - s_p)^2. A face's normals fill only part of the sphere, so a free 9-number
 * fit swings the coefficients they hardly see; this fit has 4 numbers, which they pin down. With
 * no pixel in the mask the answer is the zero light. */
hd_status hd_sh_fit_lobe(const float *normal, const float *shading, const float *mask, int npix,
                         float light[HD_SH_COEFFS]);

/* The distant light a light's first band carries (docs/usage.md, "Cast shadows"): its direction
 * (unit, camera frame, toward the light: (l3, l2, -l1) normalised) and the light of
 * hd_light_from_direction along it, no ambient, whose first band is the light's. A light with no
 * first band: direction (0, 0, 1) and the zero light. */
void hd_light_distant_part(const float light[HD_SH_COEFFS], float direction[3], float part[HD_SH_COEFFS]);

#endif /* HD_LIGHT_H */
