/* test_light.c: the spherical-harmonics lighting core against independent truth: SPEC section 2's
 * test vectors, analytic cases (a constant light, a distant light peaking at its direction), the
 * least-squares fit recovering lights from their own renderings (with noise, small and empty
 * masks), the ambient + distant light fit,
 * light files (round trip and every kind of bad file), the presets and the sphere. */
#include <stdlib.h>
#include <string.h>
#include "test.h"
#include "core/core.h"
#include "light/light.h"
#include "eval/photo_metrics.h"

static const float dpr_light_00[9] = {
    1.084125496282453138f, -0.4642676300617166185f, 0.02837846795150648915f, 0.6765292733937575687f,
    -0.3594067725393816914f, 0.04790996460111427574f, -0.2280054643781863066f, -0.08125983081159608712f,
    0.2881082012687687932f};

static double dot3(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

/* A random unit vector; with hemisphere set, on the visible side (z > 0). */
static void random_normal(hd_rng *r, int hemisphere, float n[3])
{
    double v[3], len;
    do {
        for (int i = 0; i < 3; i++) v[i] = hd_rng_normal(r);
        len = sqrt(dot3(v, v));
    } while (len < 1e-3);
    if (hemisphere && v[2] < 0) v[2] = -v[2];
    for (int i = 0; i < 3; i++) n[i] = (float)(v[i] / len);
}

static void test_vectors(void)
{
    const float normals[5][3] = {{0, 0, 1}, {1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}};
    const double expected[5] = {1.368747, 1.833181, 0.448560, 0.876864, 0.818783};
    for (int i = 0; i < 5; i++) CHECK_NEAR(hd_sh_shade(dpr_light_00, normals[i]), expected[i], 1e-5);
    /* the planar map agrees and honours the mask */
    float planar[15], mask[5] = {1, 1, 0, 1, 0.5f}, s[5];
    for (int i = 0; i < 5; i++)
        for (int c = 0; c < 3; c++) planar[c * 5 + i] = normals[i][c];
    hd_sh_shading_map(planar, NULL, 5, dpr_light_00, s);
    for (int i = 0; i < 5; i++) CHECK_NEAR(s[i], expected[i], 1e-5);
    hd_sh_shading_map(planar, mask, 5, dpr_light_00, s);
    CHECK(s[2] == 0.0f);
    CHECK_NEAR(s[4], expected[4], 1e-5);
    /* the basis toward the viewer: X = 0, Y = -1, Z = 0 */
    float b[9];
    hd_sh_basis(normals[0], b);
    const double b_front[9] = {0.8862269254527579, -1.023326707946488, 0, 0, 0, 0, -0.2477079561003757, 0,
                               -0.4290427654048917};
    for (int k = 0; k < 9; k++) CHECK_NEAR(b[k], b_front[k], 1e-7);
    /* up: Z = 1 -> b2 = c1, b6 = 2 c3, b8 = 0 */
    hd_sh_basis(normals[3], b);
    CHECK_NEAR(b[2], 1.023326707946488, 1e-7);
    CHECK_NEAR(b[6], 2 * 0.2477079561003757, 1e-7);
    CHECK_NEAR(b[8], 0, 1e-7);
}

/* A light with only l0 shades every normal alike: s = c0 * l0. Each band-1 light is linear in n. */
static void test_constant_and_linear(void)
{
    hd_rng r;
    hd_rng_seed(&r, 1, 1);
    float l0[9] = {0.7f}, lx[9] = {0}, n[3];
    lx[3] = 2.0f; /* c1 * X * 2 */
    for (int i = 0; i < 1000; i++) {
        random_normal(&r, 0, n);
        CHECK_NEAR(hd_sh_shade(l0, n), 0.8862269254527579 * 0.7, 1e-6);
        CHECK_NEAR(hd_sh_shade(lx, n), 1.023326707946488 * 2.0 * n[0], 1e-5);
    }
}

/* Fills planar normals (hemisphere) and the shading of `light` plus Gaussian noise of sigma. */
/* npix normals on the visible hemisphere with z >= min_z (0.5: within 60 degrees of the viewer, about
 * what a face's normals fill), each shaded by light plus Gaussian noise of sigma. */
static void render_cone(hd_rng *r, int npix, const float light[9], float sigma, float min_z, float *normal,
                        float *shading)
{
    for (int p = 0; p < npix; p++) {
        float n[3];
        do random_normal(r, 1, n);
        while (n[2] < min_z);
        for (int c = 0; c < 3; c++) normal[c * npix + p] = n[c];
        shading[p] = hd_sh_shade(light, n) + sigma * hd_rng_normal(r);
    }
}

static void render(hd_rng *r, int npix, const float light[9], float sigma, float *normal, float *shading)
{
    render_cone(r, npix, light, sigma, -1.0f, normal, shading);
}

static double max_abs_diff(const float *a, const float *b, int n)
{
    double m = 0;
    for (int i = 0; i < n; i++) m = fmax(m, fabs((double)a[i] - b[i]));
    return m;
}

static void random_light(hd_rng *r, float light[9])
{
    light[0] = hd_rng_range(r, 0.6f, 1.4f);
    for (int k = 1; k < 9; k++) light[k] = hd_rng_range(r, -0.5f, 0.5f);
}

/* sum_p m_p (b.l - s_p)^2 + strength * (sum_p m_p) * |l - prior|^2, in double: the objective of
 * hd_sh_fit_toward, evaluated directly. */
static double fit_objective(const float *normal, const float *shading, const float *mask, int npix,
                            const float prior[9], double strength, const double l[9])
{
    double J = 0, W = 0;
    for (int p = 0; p < npix; p++) {
        double m = mask ? mask[p] : 1.0;
        if (!(m > 0)) continue;
        float n[3] = {normal[p], normal[npix + p], normal[2 * npix + p]}, b[9];
        hd_sh_basis(n, b);
        double e = -shading[p];
        for (int k = 0; k < 9; k++) e += b[k] * l[k];
        J += m * e * e;
        W += m;
    }
    for (int k = 0; k < 9; k++) J += strength * W * (l[k] - prior[k]) * (l[k] - prior[k]);
    return J;
}

/* The fit toward a prior: 0 is hd_sh_fit; the answer is the objective's minimum (every coefficient
 * nudged either way raises it); the truth as the prior gives the truth back; a strong pull gives
 * the prior; an empty mask gives the prior; a bad strength is refused. */
static void test_fit_toward(void)
{
    enum { NPIX = 2000 };
    hd_rng r;
    hd_rng_seed(&r, 21, 5);
    float *normal = malloc(3 * NPIX * sizeof(float)), *shading = malloc(NPIX * sizeof(float));
    float *mask = malloc(NPIX * sizeof(float));
    float light[9], prior[9], a[9], b[9];
    random_light(&r, light);
    random_light(&r, prior);
    render(&r, NPIX, light, 0.02f, normal, shading);
    for (int p = 0; p < NPIX; p++) mask[p] = p % 4 ? 1.0f : 0.5f;
    CHECK(hd_sh_fit(normal, shading, mask, NPIX, a) == HD_OK);
    CHECK(hd_sh_fit_toward(normal, shading, mask, NPIX, prior, 0.0f, b) == HD_OK);
    CHECK(memcmp(a, b, sizeof a) == 0);
    const float strengths[3] = {0.01f, 0.1f, 1.0f};
    double last = 0;
    for (int i = 0; i < 3; i++) {
        CHECK(hd_sh_fit_toward(normal, shading, mask, NPIX, prior, strengths[i], b) == HD_OK);
        double l[9];
        for (int k = 0; k < 9; k++) l[k] = b[k];
        double J = fit_objective(normal, shading, mask, NPIX, prior, strengths[i], l);
        int minimum = 1;
        for (int k = 0; k < 9; k++)
            for (int sgn = -1; sgn <= 1; sgn += 2) {
                double m[9];
                memcpy(m, l, sizeof m);
                m[k] += sgn * 1e-3;
                minimum &= fit_objective(normal, shading, mask, NPIX, prior, strengths[i], m) > J;
            }
        CHECK(minimum);
        /* a stronger pull lands nearer the prior (the Euclidean distance falls with the strength) */
        double d = 0;
        for (int k = 0; k < 9; k++) d += ((double)b[k] - prior[k]) * ((double)b[k] - prior[k]);
        if (i > 0) CHECK(d < last);
        last = d;
    }
    render(&r, NPIX, light, 0.0f, normal, shading);
    CHECK(hd_sh_fit_toward(normal, shading, NULL, NPIX, light, 0.5f, b) == HD_OK);
    CHECK(max_abs_diff(b, light, 9) <= 1e-4);
    CHECK(hd_sh_fit_toward(normal, shading, NULL, NPIX, prior, 1e6f, b) == HD_OK);
    CHECK(max_abs_diff(b, prior, 9) <= 1e-4);
    for (int p = 0; p < NPIX; p++) mask[p] = 0.0f;
    CHECK(hd_sh_fit_toward(normal, shading, mask, NPIX, prior, 0.1f, b) == HD_OK);
    CHECK(memcmp(b, prior, sizeof b) == 0);
    CHECK(hd_sh_fit_toward(normal, shading, NULL, NPIX, prior, -1.0f, b) == HD_ERR_ARG);
    CHECK(hd_sh_fit_toward(normal, shading, NULL, NPIX, prior, NAN, b) == HD_ERR_ARG);
    prior[3] = INFINITY;
    CHECK(hd_sh_fit_toward(normal, shading, NULL, NPIX, prior, 0.1f, b) == HD_ERR_NUMERIC);
    free(normal);
    free(shading);
    free(mask);
}

/* The lobe fit: it recovers an ambient + distant light from its own rendering on a cone of
 * normals (front, side, from below, just behind the profile); a light from behind the head is
 * answered from the front; its answer beats every neighbouring
 * light of the family; it scales with the shading; a flat shading is ambient only; two noisy
 * halves of one face agree far better than two free 9-number fits do (what it is for); the
 * one-pass fit toward it equals the two calls; an empty mask gives the zero light and bad input is
 * refused. */
static void test_fit_lobe(void)
{
    enum { NPIX = 3000 };
    hd_rng r;
    hd_rng_seed(&r, 23, 7);
    float *normal = malloc(3 * NPIX * sizeof(float)), *shading = malloc(NPIX * sizeof(float));
    float *mask = malloc(NPIX * sizeof(float));
    float light[9], fit[9], other[9];
    const float cases[5][4] = {{0, 0, 1.0f, 0.5f}, {35, 20, 1.2f, 0.4f}, {-80, -15, 1.5f, 0.1f},
                               {10, -50, 0.6f, 0.7f}, {95, 30, 0.8f, 0.6f}};
    for (int c = 0; c < 5; c++) {
        hd_light_from_direction(cases[c][0], cases[c][1], cases[c][2], cases[c][3], light);
        render_cone(&r, NPIX, light, 0.0f, 0.5f, normal, shading);
        CHECK(hd_sh_fit_lobe(normal, shading, NULL, NPIX, fit) == HD_OK);
        CHECK(max_abs_diff(fit, light, 9) <= 2e-3);
    }
    /* a light from behind: the fit's lobe is in front (l1 < 0: the light comes toward the screen) */
    hd_light_from_direction(180, 0, 1.0f, 0.8f, light);
    render_cone(&r, NPIX, light, 0.0f, 0.5f, normal, shading);
    CHECK(hd_sh_fit_lobe(normal, shading, NULL, NPIX, fit) == HD_OK);
    CHECK(fit[1] <= 1e-6f);
    /* with noise, the answer is the family's best: nudging direction or amplitudes raises the cost */
    hd_light_from_direction(25, 10, 1.1f, 0.5f, light);
    render_cone(&r, NPIX, light, 0.05f, 0.5f, normal, shading);
    for (int p = 0; p < NPIX; p++) mask[p] = p % 3 ? 1.0f : 0.5f;
    CHECK(hd_sh_fit_lobe(normal, shading, mask, NPIX, fit) == HD_OK);
    double l[9];
    for (int k = 0; k < 9; k++) l[k] = fit[k];
    const double J = fit_objective(normal, shading, mask, NPIX, fit, 0.0, l);
    /* the fitted light's own parameters are not returned; find them back by a fine grid around the
     * truth (the fit is the truth's neighbour at this noise) and check no neighbour beats it */
    int beaten = 0;
    for (float daz = -2.0f; daz <= 2.0f; daz += 0.5f)
        for (float del = -2.0f; del <= 2.0f; del += 0.5f)
            for (float di = 0.96f; di <= 1.04f; di += 0.02f)
                for (float da = 0.96f; da <= 1.04f; da += 0.02f) {
                    hd_light_from_direction(25 + daz, 10 + del, 1.1f * di, 0.5f * da, other);
                    double m[9];
                    for (int k = 0; k < 9; k++) m[k] = other[k];
                    beaten += fit_objective(normal, shading, mask, NPIX, fit, 0.0, m) < J - 1e-9 * fabs(J);
                }
    CHECK(beaten == 0);
    CHECK(hd_light_difference(light, fit) < 0.05);
    /* twice the shading, twice the light */
    for (int p = 0; p < NPIX; p++) shading[p] *= 2.0f;
    CHECK(hd_sh_fit_lobe(normal, shading, mask, NPIX, other) == HD_OK);
    for (int k = 0; k < 9; k++) CHECK_NEAR(other[k], 2.0f * fit[k], 1e-3);
    /* a flat shading: intensity 0, the ambient alone */
    for (int p = 0; p < NPIX; p++) shading[p] = 0.8f;
    CHECK(hd_sh_fit_lobe(normal, shading, NULL, NPIX, other) == HD_OK);
    CHECK_NEAR(other[0], 0.8 / 0.8862269254527579, 1e-4);
    for (int k = 1; k < 9; k++) CHECK_NEAR(other[k], 0.0, 1e-4);
    /* two halves of a noisy face: the lobe fits agree, the free fits swing the coefficients the
     * cone hardly sees */
    render_cone(&r, NPIX, light, 0.1f, 0.5f, normal, shading);
    for (int p = 0; p < NPIX; p++) mask[p] = p < NPIX / 2;
    float lobe_a[9], lobe_b[9], free_a[9], free_b[9];
    CHECK(hd_sh_fit_lobe(normal, shading, mask, NPIX, lobe_a) == HD_OK);
    CHECK(hd_sh_fit(normal, shading, mask, NPIX, free_a) == HD_OK);
    for (int p = 0; p < NPIX; p++) mask[p] = p >= NPIX / 2;
    CHECK(hd_sh_fit_lobe(normal, shading, mask, NPIX, lobe_b) == HD_OK);
    CHECK(hd_sh_fit(normal, shading, mask, NPIX, free_b) == HD_OK);
    const double lobe_diff = hd_light_difference(lobe_a, lobe_b), free_diff = hd_light_difference(free_a, free_b);
    printf("lobe fit, two noisy halves of a cone: lights differ by %.4f (free fits: %.4f)\n", lobe_diff, free_diff);
    CHECK(lobe_diff < 0.05);
    CHECK(lobe_diff < 0.25 * free_diff);
    /* the face's own light in one pass is the fit toward the lobe fit, bit for bit */
    float both[9];
    CHECK(hd_sh_fit_toward(normal, shading, mask, NPIX, lobe_b, 0.1f, other) == HD_OK);
    CHECK(hd_sh_fit_toward_lobe(normal, shading, mask, NPIX, 0.1f, both) == HD_OK);
    CHECK(memcmp(both, other, sizeof both) == 0);
    CHECK(hd_sh_fit_toward_lobe(normal, shading, mask, NPIX, -1.0f, both) == HD_ERR_ARG);
    /* nothing to fit, and bad input */
    for (int p = 0; p < NPIX; p++) mask[p] = 0.0f;
    CHECK(hd_sh_fit_lobe(normal, shading, mask, NPIX, other) == HD_OK);
    for (int k = 0; k < 9; k++) CHECK(other[k] == 0.0f);
    CHECK(hd_sh_fit_toward_lobe(normal, shading, mask, NPIX, 0.1f, both) == HD_OK);
    for (int k = 0; k < 9; k++) CHECK(both[k] == 0.0f);
    CHECK(hd_sh_fit_lobe(normal, shading, NULL, -1, other) == HD_ERR_ARG);
    CHECK(hd_sh_fit_lobe(NULL, shading, NULL, NPIX, other) == HD_ERR_ARG);
    shading[7] = NAN;
    CHECK(hd_sh_fit_lobe(normal, shading, NULL, NPIX, other) == HD_ERR_NUMERIC);
    free(normal);
    free(shading);
    free(mask);
}

static void test_fit(void)
{
    enum { NPIX = 4096 };
    hd_rng r;
    hd_rng_seed(&r, 7, 3);
    float *normal = malloc(3 * NPIX * sizeof(float)), *shading = malloc(NPIX * sizeof(float));
    float *mask = malloc(NPIX * sizeof(float));
    float light[9], fit[9];
    /* noise-free: recovered to 1e-4 */
    for (int trial = 0; trial < 5; trial++) {
        random_light(&r, light);
        render(&r, NPIX, light, 0.0f, normal, shading);
        CHECK(hd_sh_fit(normal, shading, NULL, NPIX, fit) == HD_OK);
        double err = max_abs_diff(fit, light, 9);
        if (err > 1e-4) fprintf(stderr, "noise-free fit, trial %d: max coefficient error %g\n", trial, err);
        CHECK(err <= 1e-4);
    }
    /* the DPR light itself */
    render(&r, NPIX, dpr_light_00, 0.0f, normal, shading);
    CHECK(hd_sh_fit(normal, shading, NULL, NPIX, fit) == HD_OK);
    CHECK(max_abs_diff(fit, dpr_light_00, 9) <= 1e-4);

    /* noise: the error grows with the noise level and stays bounded (a few sigma / sqrt(npix) times
     * the conditioning of the hemisphere) */
    random_light(&r, light);
    const float sigmas[4] = {0.003f, 0.01f, 0.03f, 0.1f};
    double errs[4];
    for (int i = 0; i < 4; i++) {
        hd_rng rn;
        hd_rng_seed(&rn, 99, 1); /* same normals and noise pattern, scaled */
        render(&rn, NPIX, light, sigmas[i], normal, shading);
        CHECK(hd_sh_fit(normal, shading, NULL, NPIX, fit) == HD_OK);
        errs[i] = max_abs_diff(fit, light, 9);
        printf("fit with noise sigma %.3f: max coefficient error %.5f\n", sigmas[i], errs[i]);
        CHECK(errs[i] <= 2.0 * sigmas[i]);
        if (i > 0) CHECK(errs[i] > errs[i - 1]);
    }
    CHECK(errs[3] / errs[0] > 10.0 && errs[3] / errs[0] < 100.0); /* roughly linear in sigma */

    /* the mask: masked-out pixels (even garbage) do not count */
    render(&r, NPIX, light, 0.0f, normal, shading);
    for (int p = 0; p < NPIX; p++) {
        mask[p] = p % 3 == 0 ? 0.0f : 1.0f;
        if (mask[p] == 0.0f) shading[p] = 100.0f;
    }
    shading[0] = NAN;
    CHECK(hd_sh_fit(normal, shading, mask, NPIX, fit) == HD_OK);
    CHECK(max_abs_diff(fit, light, 9) <= 1e-4);
    /* a non-finite value where it counts is an error */
    mask[0] = 1.0f;
    CHECK(hd_sh_fit(normal, shading, mask, NPIX, fit) == HD_ERR_NUMERIC);
    CHECK(strstr(hd_error(), "not finite") != NULL);
    shading[0] = 1.0f;
    normal[NPIX + 5] = INFINITY;
    CHECK(hd_sh_fit(normal, shading, NULL, NPIX, fit) == HD_ERR_NUMERIC);
    normal[NPIX + 5] = 0.0f;
    mask[1] = NAN;
    CHECK(hd_sh_fit(normal, shading, mask, NPIX, fit) == HD_ERR_NUMERIC);

    /* weights: a weight of 2 is the same as the pixel counted twice */
    {
        enum { N = 50 };
        float nw[3 * N], sw[N], mw[N], nd[3 * (N + 1)], sd[N + 1], a[9], b[9];
        random_light(&r, light);
        render(&r, N, light, 0.05f, nw, sw);
        for (int p = 0; p < N; p++) mw[p] = p == 0 ? 2.0f : 1.0f;
        for (int p = 0; p <= N; p++) {
            int q = p < N ? p : 0;
            for (int c = 0; c < 3; c++) nd[c * (N + 1) + p] = nw[c * N + q];
            sd[p] = sw[q];
        }
        CHECK(hd_sh_fit(nw, sw, mw, N, a) == HD_OK);
        CHECK(hd_sh_fit(nd, sd, NULL, N + 1, b) == HD_OK);
        CHECK(max_abs_diff(a, b, 9) <= 1e-4);
    }

    /* small masks: 20 pixels recover a noise-free light well, and a noisy one within bounds */
    random_light(&r, light);
    render(&r, NPIX, light, 0.0f, normal, shading);
    for (int p = 0; p < NPIX; p++) mask[p] = 0.0f;
    for (int i = 0; i < 20; i++) mask[hd_rng_below(&r, NPIX)] = 1.0f;
    CHECK(hd_sh_fit(normal, shading, mask, NPIX, fit) == HD_OK);
    double err20 = max_abs_diff(fit, light, 9);
    printf("fit from about 20 pixels, noise-free: max coefficient error %.6f\n", err20);
    CHECK(err20 < 0.05);
    render(&r, NPIX, light, 0.01f, normal, shading);
    CHECK(hd_sh_fit(normal, shading, mask, NPIX, fit) == HD_OK);
    double err20n = max_abs_diff(fit, light, 9);
    printf("fit from about 20 pixels, noise 0.01: max coefficient error %.6f\n", err20n);
    CHECK(err20n < 1.0);
    /* and the fitted shading still matches the data at those pixels */
    {
        double res = 0;
        for (int p = 0; p < NPIX; p++)
            if (mask[p] > 0) {
                float n[3] = {normal[p], normal[NPIX + p], normal[2 * NPIX + p]};
                res = fmax(res, fabs(hd_sh_shade(fit, n) - shading[p]));
            }
        CHECK(res < 0.05);
    }
    /* one pixel: finite, and it reproduces that pixel's shading */
    for (int p = 0; p < NPIX; p++) mask[p] = p == 17 ? 1.0f : 0.0f;
    CHECK(hd_sh_fit(normal, shading, mask, NPIX, fit) == HD_OK);
    for (int k = 0; k < 9; k++) CHECK(isfinite(fit[k]));
    {
        float n[3] = {normal[17], normal[NPIX + 17], normal[2 * NPIX + 17]};
        CHECK_NEAR(hd_sh_shade(fit, n), shading[17], 1e-3);
    }
    /* no pixel: the zero light, no error */
    for (int p = 0; p < NPIX; p++) mask[p] = 0.0f;
    fit[0] = 5.0f;
    CHECK(hd_sh_fit(normal, shading, mask, NPIX, fit) == HD_OK);
    for (int k = 0; k < 9; k++) CHECK(fit[k] == 0.0f);
    CHECK(hd_sh_fit(NULL, NULL, NULL, 0, fit) == HD_OK);
    CHECK(hd_sh_fit(normal, shading, NULL, -1, fit) == HD_ERR_ARG);
    /* all normals alike (a flat wall): finite, and it reproduces the shading there */
    for (int p = 0; p < NPIX; p++) {
        normal[p] = 0.6f, normal[NPIX + p] = 0.0f, normal[2 * NPIX + p] = 0.8f;
        shading[p] = 1.25f;
    }
    CHECK(hd_sh_fit(normal, shading, NULL, NPIX, fit) == HD_OK);
    for (int k = 0; k < 9; k++) CHECK(isfinite(fit[k]));
    {
        float n[3] = {0.6f, 0.0f, 0.8f};
        CHECK_NEAR(hd_sh_shade(fit, n), 1.25, 1e-3);
    }
    free(normal);
    free(shading);
    free(mask);
}

/* Scans a dense set of directions over the whole sphere (a Fibonacci lattice) for the largest and
 * smallest shading. */
static void scan_sphere(const float light[9], int front_only, double best[3], float *smax, float *smin)
{
    const int n = 20000;
    *smax = -1e30f;
    *smin = 1e30f;
    for (int i = 0; i < n; i++) {
        double z = 1.0 - (2.0 * i + 1.0) / n, r = sqrt(1.0 - z * z), phi = i * 2.399963229728653;
        float v[3] = {(float)(r * cos(phi)), (float)(r * sin(phi)), (float)z};
        if (front_only && v[2] <= 0) continue;
        float s = hd_sh_shade(light, v);
        if (s > *smax) {
            *smax = s;
            for (int c = 0; c < 3; c++) best[c] = v[c];
        }
        if (s < *smin) *smin = s;
    }
}

static void test_direction(void)
{
    const float cases[][4] = {{0, 0, 1, 0.5f}, {90, 0, 1, 0.5f},    {-90, 0, 2, 0},    {0, 90, 1, 0.2f},
                              {30, -20, 1.5f, 0.5f}, {135, 10, 1, 1}, {-60, 45, 0.7f, 0.3f}, {180, 0, 1, 0.5f}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        const float *c = cases[i];
        float light[9], smax, smin;
        hd_light_from_direction(c[0], c[1], c[2], c[3], light);
        const double az = c[0] * M_PI / 180, el = c[1] * M_PI / 180;
        const double d[3] = {cos(el) * sin(az), sin(el), cos(el) * cos(az)};
        double best[3];
        scan_sphere(light, 0, best, &smax, &smin);
        double angle = acos(fmin(1.0, dot3(best, d))) * 180 / M_PI;
        if (angle > 2.0) fprintf(stderr, "direction light az %g el %g: brightest %.2f degrees off\n", c[0], c[1], angle);
        CHECK(angle <= 2.0);
        const float df[3] = {(float)d[0], (float)d[1], (float)d[2]};
        CHECK_NEAR(hd_sh_shade(light, df), c[2] + c[3], 1e-5); /* s(d) = intensity + ambient */
        CHECK(hd_sh_shade(light, df) >= smax - 1e-6);
        CHECK(smin > c[3] - 0.05 * c[2]); /* never far below the ambient level */
    }
    /* the convention: azimuth 90 is a light from image right, elevation 90 from above */
    float light[9];
    const float right[3] = {1, 0, 0}, left[3] = {-1, 0, 0}, up[3] = {0, 1, 0}, down[3] = {0, -1, 0};
    hd_light_from_direction(90, 0, 1, 0.5f, light);
    CHECK(hd_sh_shade(light, right) > hd_sh_shade(light, left) + 0.5f);
    hd_light_from_direction(0, 90, 1, 0.5f, light);
    CHECK(hd_sh_shade(light, up) > hd_sh_shade(light, down) + 0.5f);
    /* zero intensity: the constant ambient */
    hd_light_from_direction(20, 30, 0, 0.8f, light);
    CHECK_NEAR(light[0] * 0.8862269254527579, 0.8, 1e-6);
    for (int k = 1; k < 9; k++) CHECK(light[k] == 0.0f);
    /* DPR-like magnitude with the defaults: DPR's light 00 shades the visible hemisphere between
     * about 0.43 and 2.05; a default light from 45 degrees off the axis spans a similar range */
    float smax, smin, dmax, dmin;
    double best[3];
    scan_sphere(dpr_light_00, 1, best, &dmax, &dmin);
    hd_light_from_direction(45, 0, HD_LIGHT_DEFAULT_INTENSITY, HD_LIGHT_DEFAULT_AMBIENT, light);
    scan_sphere(light, 1, best, &smax, &smin);
    printf("visible hemisphere: DPR light 00 %.3f..%.3f, default direction light %.3f..%.3f\n", dmin, dmax, smin,
           smax);
    CHECK(dmin > 0.4f && dmax < 2.1f);
    CHECK(smin > 0.3f && smin < 0.7f && smax > 1.6f && smax < 2.1f);
    CHECK(fabsf(smax - dmax) < 0.3f && fabsf(smin - dmin) < 0.3f);
}

static void write_text(const char *path, const char *text, size_t len)
{
    FILE *f = fopen(path, "wb");
    CHECK(f != NULL);
    if (!f) return;
    fwrite(text, 1, len, f);
    fclose(f);
}

/* Writes `text` as a light file and expects hd_light_read to fail with `code` and a reason that
 * names the file and contains `where` (e.g. ":3:"). */
static void expect_bad_light(const char *text, size_t len, hd_status code, const char *where)
{
    float light[9];
    write_text("bad.txt", text, len);
    hd_status st = hd_light_read("bad.txt", light);
    if (st != code || !strstr(hd_error(), "bad.txt") || !strstr(hd_error(), where)) {
        fprintf(stderr, "bad light file: got status %d, '%s'; expected %d and '%s'\n", st, hd_error(), code, where);
        test_failures++;
    }
}

static void test_light_files(void)
{
    /* DPR's own file loads unchanged */
    const char *dpr_text = "1.084125496282453138\n-0.4642676300617166185\n0.02837846795150648915\n"
                           "0.6765292733937575687\n-0.3594067725393816914\n0.04790996460111427574\n"
                           "-0.2280054643781863066\n-0.08125983081159608712\n0.2881082012687687932\n";
    float light[9], back[9];
    write_text("dpr00.txt", dpr_text, strlen(dpr_text));
    CHECK(hd_light_read("dpr00.txt", light) == HD_OK);
    CHECK(memcmp(light, dpr_light_00, sizeof light) == 0);
    /* any white space, CRLF, no final newline */
    const char *loose = "  1 2\t3\r\n4 5 6\n\n 7\r\n8\f9";
    write_text("loose.txt", loose, strlen(loose));
    CHECK(hd_light_read("loose.txt", light) == HD_OK);
    for (int k = 0; k < 9; k++) CHECK(light[k] == k + 1);
    /* round trip is exact */
    char *data;
    size_t size;
    hd_rng r;
    hd_rng_seed(&r, 5, 5);
    for (int trial = 0; trial < 20; trial++) {
        for (int k = 0; k < 9; k++) light[k] = hd_rng_normal(&r) * powf(10.0f, hd_rng_range(&r, -8, 5));
        CHECK(hd_light_write("round.txt", light) == HD_OK);
        CHECK(hd_light_read("round.txt", back) == HD_OK);
        CHECK(memcmp(light, back, sizeof light) == 0);
    }
    /* beyond HD_LIGHT_MAX_COEFF (a shading that could overflow): refused on reading and writing */
    const char *huge = "3.4e38 0 0 0 0 0 0 0 0\n";
    write_text("huge.txt", huge, strlen(huge));
    CHECK(hd_light_read("huge.txt", back) == HD_ERR_RANGE && strstr(hd_error(), "huge.txt:1: '3.4e38'") != NULL);
    const char *edge = "1e6 -1e6 0 0 0 0 0 0 0\n";
    write_text("edge.txt", edge, strlen(edge));
    CHECK(hd_light_read("edge.txt", back) == HD_OK && back[0] == 1e6f && back[1] == -1e6f);
    light[4] = 2e6f;
    CHECK(hd_light_write("huge_out.txt", light) == HD_ERR_RANGE);
    CHECK(hd_read_file("huge_out.txt", 4096, &data, &size) == HD_ERR_IO);
    /* one number per line */
    CHECK(hd_read_file("round.txt", 4096, &data, &size) == HD_OK);
    int lines = 0;
    for (size_t i = 0; i < size; i++) lines += data[i] == '\n';
    CHECK(lines == 9 && data[size - 1] == '\n');
    free(data);
    /* every kind of bad file, with the line named */
    expect_bad_light("", 0, HD_ERR_FORMAT, ":1:");
    expect_bad_light("1 2 3\n4 5 6\n7 8\n", 16, HD_ERR_FORMAT, ":3:");      /* 8 numbers */
    expect_bad_light("1\n2\n3\n4\n5\n6\n7\n8\n", 16, HD_ERR_FORMAT, ":8:"); /* 8, one per line */
    expect_bad_light("1 2 3 4 5 6 7 8 9\n10\n", 21, HD_ERR_FORMAT, ":2:");  /* 10 numbers */
    expect_bad_light("1 2 3\n4 nan 6\n7 8 9\n", 20, HD_ERR_NUMERIC, ":2:");
    expect_bad_light("1 2 3\n4 5 6\n7 8 inf\n", 20, HD_ERR_NUMERIC, ":3:");
    expect_bad_light("1 2 3\n4 5 6\n7 8 1e39\n", 21, HD_ERR_NUMERIC, ":3:"); /* beyond float */
    expect_bad_light("# light\n1 2 3 4 5 6 7 8 9\n", 26, HD_ERR_FORMAT, ":1:");
    expect_bad_light("1 2 3\n4 5 6x\n7 8 9\n", 19, HD_ERR_FORMAT, ":2:");
    expect_bad_light("1,2,3,4,5,6,7,8,9\n", 18, HD_ERR_FORMAT, ":1:");
    expect_bad_light("1 2 3\n4 5 6\n7 8 9\0", 18, HD_ERR_FORMAT, ":3:");
    expect_bad_light("1 2 3\n4 5 6\n7 8 9 hello\n", 24, HD_ERR_FORMAT, ":3:");
    {
        char big[70000];
        memset(big, ' ', sizeof big);
        expect_bad_light(big, sizeof big, HD_ERR_FORMAT, "bad.txt");
        memset(big, '1', 200);
        expect_bad_light(big, 200, HD_ERR_FORMAT, ":1:");
    }
    CHECK(hd_light_read("no-such-light.txt", light) == HD_ERR_IO);
    CHECK(strstr(hd_error(), "no-such-light.txt") != NULL);
    /* writing: a bad place or a bad value leaves no file */
    CHECK(hd_light_write("no/such/dir/l.txt", dpr_light_00) == HD_ERR_IO);
    light[4] = NAN;
    CHECK(hd_light_write("nan.txt", light) == HD_ERR_NUMERIC);
    FILE *f = fopen("nan.txt", "rb");
    CHECK(f == NULL);
    if (f) fclose(f);
}

static void test_presets(void)
{
    float p[HD_LIGHT_PRESETS][9];
    for (int k = 0; k < HD_LIGHT_PRESETS; k++) CHECK(hd_light_preset(k, p[k]) == HD_OK);
    CHECK(hd_light_preset(-1, p[0]) == HD_ERR_RANGE);
    CHECK(hd_light_preset(HD_LIGHT_PRESETS, p[0]) == HD_ERR_RANGE);
    hd_light_preset(0, p[0]);
    double band0 = p[0][0], band1 = 0, band2 = 0;
    for (int k = 1; k < 4; k++) band1 += p[0][k] * p[0][k];
    for (int k = 4; k < 9; k++) band2 += p[0][k] * p[0][k];
    for (int k = 0; k < HD_LIGHT_PRESETS; k++) {
        /* equal energy in every band (a rotation about the view axis keeps each band's norm) */
        double e1 = 0, e2 = 0;
        for (int i = 1; i < 4; i++) e1 += p[k][i] * p[k][i];
        for (int i = 4; i < 9; i++) e2 += p[k][i] * p[k][i];
        CHECK_NEAR(p[k][0], band0, 1e-6);
        CHECK_NEAR(e1, band1, 1e-5);
        CHECK_NEAR(e2, band2, 1e-5);
        /* distinct */
        for (int j = 0; j < k; j++) CHECK(max_abs_diff(p[k], p[j], 9) > 0.05);
        /* brightest 60 degrees off the view axis, at k * 360/7 degrees from image right */
        double best[3];
        float smax, smin;
        scan_sphere(p[k], 0, best, &smax, &smin);
        double cone = acos(best[2]) * 180 / M_PI;
        double around = atan2(best[1], best[0]) * 180 / M_PI;
        double want = k * 360.0 / HD_LIGHT_PRESETS;
        double off = fmod(around - want + 540.0, 360.0) - 180.0;
        CHECK(fabs(cone - 60.0) < 2.0);
        CHECK(fabs(off) < 3.0);
        CHECK_NEAR(smax, HD_LIGHT_DEFAULT_INTENSITY + HD_LIGHT_DEFAULT_AMBIENT, 0.01);
    }
}

static void test_sphere(void)
{
    hd_image img = {0};
    CHECK(hd_light_sphere(dpr_light_00, 65, &img) == HD_OK);
    CHECK(img.width == 65 && img.height == 65 && img.channels == 3);
    if (img.data) {
        const size_t plane = 65 * 65;
        CHECK(img.data[0] == 0.0f && img.data[plane - 1] == 0.0f); /* corners: background */
        /* centre pixel faces the viewer; shown as s/2 */
        CHECK_NEAR(img.data[32 * 65 + 32], 1.368747 / 2, 1e-4);
        CHECK(img.data[plane + 32 * 65 + 32] == img.data[32 * 65 + 32]); /* gray */
        /* the right edge is brighter than the left (light 00 comes from the right) */
        CHECK(img.data[32 * 65 + 62] > img.data[32 * 65 + 2] + 0.3f);
        for (size_t i = 0; i < 3 * plane; i++) CHECK(img.data[i] >= 0.0f && img.data[i] <= 1.0f);
    }
    hd_image_free(&img);
    CHECK(hd_light_sphere(dpr_light_00, 0, &img) == HD_ERR_RANGE);
    CHECK(hd_light_sphere(dpr_light_00, HD_IMAGE_MAX_SIDE + 1, &img) == HD_ERR_RANGE);
}

/* Mirroring: s(mirror(n), mirror(l)) = s(n, l) for random lights and normals, and mirroring
 * twice is the identity; a light from the right becomes the light from the left. */
static void test_mirror(void)
{
    hd_rng r;
    hd_rng_seed(&r, 5, 0);
    for (int t = 0; t < 200; t++) {
        float l[HD_SH_COEFFS], m[HD_SH_COEFFS], n[3] = {hd_rng_range(&r, -1, 1), hd_rng_range(&r, -1, 1), hd_rng_range(&r, 0, 1)};
        for (int k = 0; k < HD_SH_COEFFS; k++) l[k] = m[k] = hd_rng_range(&r, -1, 1);
        float len = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        for (int c = 0; c < 3; c++) n[c] /= len;
        float nm[3] = {-n[0], n[1], n[2]};
        hd_light_mirror(m);
        CHECK_NEAR(hd_sh_shade(m, nm), hd_sh_shade(l, n), 1e-5);
        hd_light_mirror(m);
        for (int k = 0; k < HD_SH_COEFFS; k++) CHECK(m[k] == l[k]);
    }
    float right[HD_SH_COEFFS], left[HD_SH_COEFFS];
    hd_light_from_direction(60.0f, 10.0f, 1.0f, 0.3f, right);
    hd_light_from_direction(-60.0f, 10.0f, 1.0f, 0.3f, left);
    hd_light_mirror(right);
    for (int k = 0; k < HD_SH_COEFFS; k++) CHECK_NEAR(right[k], left[k], 1e-6);
}

/* ---- the SH shading gradient against finite differences of hd_sh_shade */

static void test_shade_grad(void)
{
    float l[HD_SH_COEFFS] = {1.08f, -0.46f, 0.03f, 0.68f, -0.36f, 0.05f, -0.23f, -0.08f, 0.29f};
    float n[3] = {0.3f, -0.5f, 0.7f}, g[3];
    float s = hd_sh_shade_grad(l, n, g);
    CHECK_NEAR(s, hd_sh_shade(l, n), 1e-5);
    for (int k = 0; k < 3; k++) {
        float a[3] = {n[0], n[1], n[2]}, b[3] = {n[0], n[1], n[2]};
        a[k] += 1e-3f;
        b[k] -= 1e-3f;
        CHECK_NEAR(g[k], (hd_sh_shade(l, a) - hd_sh_shade(l, b)) / 2e-3f, 2e-3);
    }
}


/* hd_light_distant_part of ambient + a distant light gives back the direction and the distant
 * light alone (known vectors of hd_light_from_direction); of an ambient light, nothing. */
static void test_distant_part(void)
{
    static const float cases[][4] = {{0, 0, 1.5f, 0.5f}, {-50, 0, 1, 0}, {35, 40, 2, 0.3f}, {0, -35, 0.7f, 1}, {120, 10, 1, 0.2f}};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        float light[HD_SH_COEFFS], want[HD_SH_COEFFS], part[HD_SH_COEFFS], dir[3];
        hd_light_from_direction(cases[c][0], cases[c][1], cases[c][2], cases[c][3], light);
        hd_light_from_direction(cases[c][0], cases[c][1], cases[c][2], 0, want);
        hd_light_distant_part(light, dir, part);
        const float az = cases[c][0] * (float)M_PI / 180, el = cases[c][1] * (float)M_PI / 180;
        CHECK_NEAR(dir[0], cosf(el) * sinf(az), 1e-5);
        CHECK_NEAR(dir[1], sinf(el), 1e-5);
        CHECK_NEAR(dir[2], cosf(el) * cosf(az), 1e-5);
        for (int k = 0; k < HD_SH_COEFFS; k++) CHECK_NEAR(part[k], want[k], 1e-5);
    }
    float flat[HD_SH_COEFFS] = {1}, part[HD_SH_COEFFS], dir[3];
    hd_light_distant_part(flat, dir, part);
    CHECK(dir[0] == 0 && dir[1] == 0 && dir[2] == 1);
    for (int k = 0; k < HD_SH_COEFFS; k++) CHECK(part[k] == 0);
}

int main(void)
{
    test_distant_part();
    test_vectors();
    test_constant_and_linear();
    test_fit();
    test_fit_toward();
    test_fit_lobe();
    test_direction();
    test_mirror();
    test_light_files();
    test_presets();
    test_shade_grad();
#ifndef HD_TEST_LIGHT_NO_IMAGES
    test_sphere();
#endif
    return test_summary("light");
}
