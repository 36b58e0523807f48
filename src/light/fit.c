/* fit.c: the masked least-squares light of SPEC section 2,
 *     l_hat = argmin_l sum_p m_p (b(n_p) . l - s_p)^2   over pixels with m_p > 0,
 * solved in double precision through the 9x9 normal equations (sum_p m_p b b^T + ridge I) l =
 * sum_p m_p s_p b with a Cholesky factorisation; ridge = 1e-6 * trace / 9, so a degenerate mask
 * (a handful of pixels, all normals alike) still gives a finite answer. The fit toward a prior
 * light adds strength * sum_p m_p * |l - prior|^2: the coefficients the normals pin down come from
 * the shading, those they hardly see (a face's normals fill only part of the sphere, so 1, z and
 * z^2 are nearly collinear there) stay near the prior. */
#include <math.h>
#include <string.h>
#include "core/core.h"
#include "light/light.h"

#define K HD_SH_COEFFS

/* Solves (A) x = r in place for symmetric positive definite A (lower Cholesky, A = L L^T).
 * Returns 0 on success, -1 if a pivot is not positive (A not numerically positive definite). */
static int cholesky_solve(double A[K][K], double r[K], double x[K])
{
    double L[K][K] = {{0}};
    for (int j = 0; j < K; j++) {
        double d = A[j][j];
        for (int k = 0; k < j; k++) d -= L[j][k] * L[j][k];
        if (!(d > 0.0)) return -1;
        L[j][j] = sqrt(d);
        for (int i = j + 1; i < K; i++) {
            double v = A[i][j];
            for (int k = 0; k < j; k++) v -= L[i][k] * L[j][k];
            L[i][j] = v / L[j][j];
        }
    }
    double y[K];
    for (int i = 0; i < K; i++) { /* L y = r */
        double v = r[i];
        for (int k = 0; k < i; k++) v -= L[i][k] * y[k];
        y[i] = v / L[i][i];
    }
    for (int i = K - 1; i >= 0; i--) { /* L^T x = y */
        double v = y[i];
        for (int k = i + 1; k < K; k++) v -= L[k][i] * x[k];
        x[i] = v / L[i][i];
    }
    return 0;
}

hd_status hd_sh_fit(const float *normal, const float *shading, const float *mask, int npix,
                    float light[HD_SH_COEFFS])
{
    return hd_sh_fit_toward(normal, shading, mask, npix, NULL, 0.0f, light);
}

hd_status hd_sh_fit_toward(const float *normal, const float *shading, const float *mask, int npix,
                           const float prior[HD_SH_COEFFS], float strength, float light[HD_SH_COEFFS])
{
    float pull[K] = {0};
    if (prior) memcpy(pull, prior, sizeof pull);
    memset(light, 0, K * sizeof *light);
    if (npix < 0 || (npix > 0 && (!normal || !shading)) || !(strength >= 0.0f) || !isfinite(strength))
        return hd_fail(HD_ERR_ARG, "sh fit: invalid arguments (npix %d, strength %g)", npix, strength);
    for (int k = 0; k < K; k++)
        if (!isfinite(pull[k])) return hd_fail(HD_ERR_NUMERIC, "sh fit: prior coefficient %d is not finite", k);
    const float *nx = normal, *ny = normal + npix, *nz = normal + 2 * (size_t)npix;
    double A[K][K] = {{0}}, r[K] = {0};
    long used = 0;
    double weight = 0.0;
    for (int p = 0; p < npix; p++) {
        float m = mask ? mask[p] : 1.0f;
        if (!isfinite(m)) return hd_fail(HD_ERR_NUMERIC, "sh fit: mask is not finite at pixel %d", p);
        if (!(m > 0.0f)) continue;
        if (!isfinite(nx[p]) || !isfinite(ny[p]) || !isfinite(nz[p]) || !isfinite(shading[p]))
            return hd_fail(HD_ERR_NUMERIC, "sh fit: normal or shading is not finite at pixel %d", p);
        const float n[3] = {nx[p], ny[p], nz[p]};
        float bf[K];
        hd_sh_basis(n, bf);
        double b[K];
        for (int i = 0; i < K; i++) b[i] = bf[i];
        for (int i = 0; i < K; i++) {
            double mb = m * b[i];
            r[i] += mb * shading[p];
            for (int j = 0; j <= i; j++) A[i][j] += mb * b[j]; /* lower triangle of sum m b b^T */
        }
        used++;
        weight += m;
    }
    if (used == 0) { /* nothing to fit: the prior (the zero light without one) */
        if (strength > 0.0f) memcpy(light, pull, sizeof pull);
        return HD_OK;
    }
    double trace = 0.0;
    for (int i = 0; i < K; i++) {
        for (int j = 0; j < i; j++) A[j][i] = A[i][j];
        trace += A[i][i];
    }
    if (!isfinite(trace)) return hd_fail(HD_ERR_NUMERIC, "sh fit: normal equations overflow");
    const double ridge = 1e-6 * trace / K, lambda = (double)strength * weight;
    for (int i = 0; i < K; i++) {
        A[i][i] += ridge + lambda;
        r[i] += lambda * pull[i];
    }
    double x[K];
    if (cholesky_solve(A, r, x) != 0)
        return hd_fail(HD_ERR_NUMERIC, "sh fit: normal equations are not positive definite");
    for (int i = 0; i < K; i++) {
        if (!isfinite(x[i]) || fabs(x[i]) > 3.4e38)
            return hd_fail(HD_ERR_NUMERIC, "sh fit: the solution is not finite");
        light[i] = (float)x[i];
    }
    return HD_OK;
}
