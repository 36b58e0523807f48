/* fit.c: the masked least-squares light of SPEC section 2,
 *     l_hat = argmin_l sum_p m_p (b(n_p) . l - s_p)^2   over pixels with m_p > 0,
 * solved in double precision through the 9x9 normal equations (sum_p m_p b b^T + ridge I) l =
 * sum_p m_p s_p b with a Cholesky factorisation; ridge = 1e-6 * trace / 9, so a degenerate mask
 * (a handful of pixels, all normals alike) still gives a finite answer. The fit toward a prior
 * light adds strength * sum_p m_p * |l - prior|^2: the coefficients the normals pin down come from
 * the shading, those they hardly see (a face's normals fill only part of the sphere, so 1, z and
 * z^2 are nearly collinear there) stay near the prior. The lobe fit (hd_sh_fit_lobe) is the best
 * light of hd_light_from_direction's family, an ambient level plus one distant light of intensity
 * >= 0 from within 100 degrees of the viewer: a search over directions, each with its two
 * amplitudes in closed form from the same normal equations. Its 4 numbers are what a face's normals
 * do pin down, so it is the prior the face's own light is pulled toward (hd_sh_fit_toward_lobe,
 * which sums the normal equations once for both; src/apply/rule.c). */
#include <math.h>
#include <string.h>
#include "core/core.h"
#include "light/light.h"

#define K HD_SH_COEFFS
/* the lobe fit's first search: directions of a Fibonacci sphere (about 4.5 degrees apart) */
#define HD_LOBE_DIRECTIONS 2000
/* the lobe's direction stays within 100 degrees of the viewer (cos 100 = -0.1736): from further
 * behind, its light on the face's normals is what an ambient term and a weaker frontal light give */
#define HD_LOBE_MIN_Z (-0.17364818f)

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

/* The masked normal equations: A = sum_p m_p b b^T (both triangles), r = sum_p m_p s_p b (0 when
 * shading is NULL), with the count of pixels used (m_p > 0) and their total weight. */
static hd_status normal_equations(const float *normal, const float *shading, const float *mask, int npix,
                                  double A[K][K], double r[K], long *used_out, double *weight_out)
{
    memset(A, 0, sizeof(double) * K * K);
    memset(r, 0, sizeof(double) * K);
    const float *nx = normal, *ny = normal + npix, *nz = normal + 2 * (size_t)npix;
    long used = 0;
    double weight = 0.0;
    for (int p = 0; p < npix; p++) {
        float m = mask ? mask[p] : 1.0f;
        if (!isfinite(m)) return hd_fail(HD_ERR_NUMERIC, "sh fit: mask is not finite at pixel %d", p);
        if (!(m > 0.0f)) continue;
        const float sp = shading ? shading[p] : 0.0f;
        if (!isfinite(nx[p]) || !isfinite(ny[p]) || !isfinite(nz[p]) || !isfinite(sp))
            return hd_fail(HD_ERR_NUMERIC, "sh fit: normal or shading is not finite at pixel %d", p);
        const float n[3] = {nx[p], ny[p], nz[p]};
        float bf[K];
        hd_sh_basis(n, bf);
        double b[K];
        for (int i = 0; i < K; i++) b[i] = bf[i];
        for (int i = 0; i < K; i++) {
            double mb = m * b[i];
            r[i] += mb * sp;
            for (int j = 0; j <= i; j++) A[i][j] += mb * b[j]; /* lower triangle of sum m b b^T */
        }
        used++;
        weight += m;
    }
    for (int i = 0; i < K; i++)
        for (int j = 0; j < i; j++) A[j][i] = A[i][j];
    *used_out = used;
    *weight_out = weight;
    return HD_OK;
}

hd_status hd_sh_fit(const float *normal, const float *shading, const float *mask, int npix,
                    float light[HD_SH_COEFFS])
{
    return hd_sh_fit_toward(normal, shading, mask, npix, NULL, 0.0f, light);
}

/* Solves the normal equations A, r of `used` pixels of total weight `weight`, pulled toward
 * pull with strength (A and r are changed). With no pixel the answer is pull (the zero light
 * when strength is 0). */
static hd_status solve_toward(double A[K][K], double r[K], long used, double weight, const float pull[K],
                              float strength, float light[HD_SH_COEFFS])
{
    if (used == 0) { /* nothing to fit: the prior (the zero light without one) */
        if (strength > 0.0f) memcpy(light, pull, K * sizeof *light);
        return HD_OK;
    }
    double trace = 0.0;
    for (int i = 0; i < K; i++) trace += A[i][i];
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
    double A[K][K], r[K], weight;
    long used;
    hd_status st = normal_equations(normal, shading, mask, npix, A, r, &used, &weight);
    return st == HD_OK ? solve_toward(A, r, used, weight, pull, strength, light) : st;
}

hd_status hd_sh_fit_adjoint(const float *normal, const float *mask, int npix, float strength,
                            const float g[HD_SH_COEFFS], float y[HD_SH_COEFFS])
{
    memset(y, 0, K * sizeof *y);
    if (npix < 0 || (npix > 0 && !normal) || !(strength >= 0.0f) || !isfinite(strength))
        return hd_fail(HD_ERR_ARG, "sh fit adjoint: invalid arguments (npix %d, strength %g)", npix, strength);
    for (int k = 0; k < K; k++)
        if (!isfinite(g[k])) return hd_fail(HD_ERR_NUMERIC, "sh fit adjoint: coefficient %d is not finite", k);
    double A[K][K], r[K], weight;
    long used;
    hd_status st = normal_equations(normal, NULL, mask, npix, A, r, &used, &weight);
    if (st != HD_OK || used == 0) return st; /* no pixel: the fit is the prior, which S does not move */
    /* the system solve_toward factors (A + ridge + lambda) with g for r and no pull: y = M^-1 g */
    static const float none[K] = {0};
    for (int k = 0; k < K; k++) r[k] = g[k];
    return solve_toward(A, r, used, weight, none, strength, y);
}

/* The lobe fit's cost at one direction: the best ambient a and intensity i >= 0 of
 * a * e0 / c0 + i * v (v: the unit distant light from (az, el)) by the 2 x 2 normal equations, and
 * the objective l^T A l - 2 r^T l (the squared residual less a constant) of that light. */
static double lobe_cost(const double A[K][K], const double r[K], float az, float el, double *ambient,
                        double *intensity)
{
    float vf[K];
    hd_light_from_direction(az, el, 1.0f, 0.0f, vf);
    double v[K], Av0 = 0.0, vAv = 0.0, rv = 0.0;
    for (int i = 0; i < K; i++) v[i] = vf[i];
    for (int i = 0; i < K; i++) {
        double Avi = 0.0;
        for (int j = 0; j < K; j++) Avi += A[i][j] * v[j];
        vAv += v[i] * Avi;
        rv += r[i] * v[i];
        if (i == 0) Av0 = Avi;
    }
    const double c0 = HD_SH_C0, uAu = A[0][0] / (c0 * c0), uAv = Av0 / c0, ru = r[0] / c0;
    const double det = uAu * vAv - uAv * uAv;
    double a = ru / uAu, in = 0.0;
    if (det > 1e-12 * uAu * vAv) {
        double ai = (vAv * ru - uAv * rv) / det, ii = (uAu * rv - uAv * ru) / det;
        if (ii > 0.0) a = ai, in = ii;
    }
    *ambient = a, *intensity = in;
    return a * a * uAu + 2.0 * a * in * uAv + in * in * vAv - 2.0 * (a * ru + in * rv);
}

/* The lobe fit on the normal equations A, r of at least one pixel. */
static hd_status lobe_from(const double A[K][K], const double r[K], float light[HD_SH_COEFFS])
{
    if (!isfinite(A[0][0]) || !(A[0][0] > 0.0))
        return hd_fail(HD_ERR_NUMERIC, "sh fit: normal equations overflow");
    /* every direction of a Fibonacci sphere, then a pattern search in azimuth and elevation */
    float best_az = 0.0f, best_el = 0.0f;
    double best = INFINITY, a, in;
    for (int k = 0; k < HD_LOBE_DIRECTIONS; k++) {
        double z = 1.0 - 2.0 * (k + 0.5) / HD_LOBE_DIRECTIONS, rho = sqrt(fmax(0.0, 1.0 - z * z));
        double phi = M_PI * (1.0 + sqrt(5.0)) * (k + 0.5), x = rho * cos(phi), y = rho * sin(phi);
        if (z < HD_LOBE_MIN_Z) continue;
        float az = (float)(atan2(x, z) * (180.0 / M_PI));
        float el = (float)(asin(fmin(1.0, fmax(-1.0, y))) * (180.0 / M_PI));
        double c = lobe_cost(A, r, az, el, &a, &in);
        if (c < best) best = c, best_az = az, best_el = el;
    }
    for (float step = 4.0f; step > 1e-4f; step *= 0.5f) {
        for (int moved = 1, rounds = 0; moved && rounds < 1000; rounds++) {
            moved = 0;
            const float daz[4] = {step, -step, 0.0f, 0.0f}, del[4] = {0.0f, 0.0f, step, -step};
            for (int t = 0; t < 4; t++) {
                float az = best_az + daz[t], el = fminf(90.0f, fmaxf(-90.0f, best_el + del[t]));
                if (cos(el * (M_PI / 180.0)) * cos(az * (M_PI / 180.0)) < HD_LOBE_MIN_Z) continue;
                double c = lobe_cost(A, r, az, el, &a, &in);
                if (c < best) best = c, best_az = az, best_el = el, moved = 1;
            }
        }
    }
    lobe_cost(A, r, best_az, best_el, &a, &in);
    if (!isfinite(a) || !isfinite(in) || fabs(a) > 1e30 || in > 1e30)
        return hd_fail(HD_ERR_NUMERIC, "sh fit: the lobe fit is not finite");
    hd_light_from_direction(best_az, best_el, (float)in, (float)a, light);
    return HD_OK;
}

hd_status hd_sh_fit_lobe(const float *normal, const float *shading, const float *mask, int npix,
                         float light[HD_SH_COEFFS])
{
    memset(light, 0, K * sizeof *light);
    if (npix < 0 || (npix > 0 && (!normal || !shading)))
        return hd_fail(HD_ERR_ARG, "sh fit: invalid arguments (npix %d)", npix);
    double A[K][K], r[K], weight;
    long used;
    hd_status st = normal_equations(normal, shading, mask, npix, A, r, &used, &weight);
    if (st != HD_OK || used == 0) return st; /* nothing to fit: the zero light */
    return lobe_from(A, r, light);
}

hd_status hd_sh_fit_toward_lobe(const float *normal, const float *shading, const float *mask, int npix,
                                float strength, float light[HD_SH_COEFFS])
{
    memset(light, 0, K * sizeof *light);
    if (npix < 0 || (npix > 0 && (!normal || !shading)) || !(strength >= 0.0f) || !isfinite(strength))
        return hd_fail(HD_ERR_ARG, "sh fit: invalid arguments (npix %d, strength %g)", npix, strength);
    double A[K][K], r[K], weight;
    long used;
    float lobe[K];
    hd_status st = normal_equations(normal, shading, mask, npix, A, r, &used, &weight);
    if (st != HD_OK || used == 0) return st; /* nothing to fit: the zero light */
    if ((st = lobe_from(A, r, lobe)) != HD_OK) return st;
    return solve_toward(A, r, used, weight, lobe, strength, light);
}
