/* test_conv.c: every 3x3 convolution path (auto = oneDNN when built with it, portable = im2col +
 * sgemm) against the naive direct loops, for the forward, the input gradient, the weight and bias
 * gradients, on odd shapes with stride 1 and 2; the accumulation contract (two backward calls add
 * twice); bit-reproducibility of two identical runs; Adam against a hand-computed two-step case;
 * the initialisation's bounds and determinism. */
#include <stdlib.h>
#include <string.h>
#include "test.h"
#include "nn/nn.h"

static hd_rng rng;

static float *randn(size_t n, float lo, float hi)
{
    float *x = malloc((n ? n : 1) * sizeof(float));
    for (size_t i = 0; i < n; i++) x[i] = hd_rng_range(&rng, lo, hi);
    return x;
}
static float *dup(const float *x, size_t n)
{
    float *y = malloc((n ? n : 1) * sizeof(float));
    memcpy(y, x, n * sizeof(float));
    return y;
}

/* max |a - b| / max(max |b|, 1e-6); prints the first worst index */
static double rel_diff(const float *a, const float *b, size_t n, size_t *at)
{
    double m = 1e-6, d = 0.0;
    *at = 0;
    for (size_t i = 0; i < n; i++) m = fmax(m, fabs(b[i]));
    for (size_t i = 0; i < n; i++)
        if (fabs(a[i] - b[i]) > d) d = fabs(a[i] - b[i]), *at = i;
    return d / m;
}

typedef struct shape {
    int B, C, H, W, OC, stride;
    hd_act act;
} shape;

/* Runs forward and backward of one path; outputs: out, dinp, dw, db (starting from g0 values). */
typedef struct result {
    float *out, *dinp, *dw, *db;
} result;

static int run_path(const shape *s, hd_conv_path path, const float *x, const float *w, const float *b,
                    const float *dout, const float *g0x, const float *g0w, const float *g0b, int calls, result *r)
{
    hd_conv3x3 *p;
    if (hd_conv3x3_plan(&p, s->B, s->C, s->H, s->W, s->OC, s->stride, s->act, 0.1f, path) != HD_OK) {
        fprintf(stderr, "plan: %s\n", hd_error());
        return 0;
    }
    size_t nx = (size_t)s->B * s->C * s->H * s->W, nw = (size_t)s->OC * s->C * 9;
    size_t no = (size_t)s->B * s->OC * hd_conv3x3_out_h(p) * hd_conv3x3_out_w(p);
    r->out = malloc(no * sizeof(float));
    r->dinp = dup(g0x, nx), r->dw = dup(g0w, nw), r->db = dup(g0b, (size_t)s->OC);
    hd_conv3x3_forward(p, r->out, x, w, b);
    for (int k = 0; k < calls; k++) {
        float *g = dup(dout, no);
        hd_conv3x3_backward(p, r->dinp, r->dw, r->db, g, r->out, x, w);
        free(g);
    }
    hd_conv3x3_free(p);
    return 1;
}

static void free_result(result *r) { free(r->out), free(r->dinp), free(r->dw), free(r->db); }

static void test_paths(void)
{
    static const shape shapes[] = {
        {2, 3, 7, 9, 5, 1, HD_ACT_NONE},    {2, 3, 7, 9, 5, 1, HD_ACT_LRELU}, {2, 5, 9, 12, 3, 2, HD_ACT_LRELU},
        {3, 1, 12, 7, 3, 2, HD_ACT_NONE},   {2, 5, 12, 12, 1, 1, HD_ACT_LRELU},
        {2, 16, 9, 7, 32, 1, HD_ACT_LRELU}, {1, 32, 12, 9, 48, 2, HD_ACT_NONE}, {1, 48, 16, 16, 48, 1, HD_ACT_LRELU},
    };
    static const char *names[] = {"auto", "portable", "naive"};
    for (size_t k = 0; k < sizeof shapes / sizeof shapes[0]; k++) {
        const shape *s = &shapes[k];
        int Ho = (s->H - 1) / s->stride + 1, Wo = (s->W - 1) / s->stride + 1;
        size_t nx = (size_t)s->B * s->C * s->H * s->W, nw = (size_t)s->OC * s->C * 9, no = (size_t)s->B * s->OC * Ho * Wo;
        float *x = randn(nx, -1, 1), *w = randn(nw, -0.3f, 0.3f), *b = randn(s->OC, -0.3f, 0.3f);
        float *dout = randn(no, -1, 1), *g0x = randn(nx, -1, 1), *g0w = randn(nw, -1, 1), *g0b = randn(s->OC, -1, 1);
        result ref;
        if (!run_path(s, HD_CONV_NAIVE, x, w, b, dout, g0x, g0w, g0b, 1, &ref)) {
            test_failures++;
            continue;
        }
        for (int path = HD_CONV_AUTO; path <= HD_CONV_PORTABLE; path++) {
            result r, r2, twice;
            if (!run_path(s, (hd_conv_path)path, x, w, b, dout, g0x, g0w, g0b, 1, &r)) {
                test_failures++;
                continue;
            }
            size_t at[4];
            double e[4] = {rel_diff(r.out, ref.out, no, &at[0]), rel_diff(r.dinp, ref.dinp, nx, &at[1]),
                           rel_diff(r.dw, ref.dw, nw, &at[2]), rel_diff(r.db, ref.db, (size_t)s->OC, &at[3])};
            double worst = fmax(fmax(e[0], e[1]), fmax(e[2], e[3]));
            printf("conv %-8s %dx%dx%dx%d->%d s%d%s: max relative difference to naive %.2e (out %.1e, dinp %.1e, dw %.1e, db %.1e)\n",
                   names[path], s->B, s->C, s->H, s->W, s->OC, s->stride, s->act ? " lrelu" : "", worst, e[0], e[1], e[2], e[3]);
            static const char *what[] = {"out", "dinp", "dw", "db"};
            for (int q = 0; q < 4; q++)
                if (e[q] > 1e-5) {
                    fprintf(stderr, "  %s: %s differs at %zu\n", names[path], what[q], at[q]);
                    test_failures++;
                }
            /* bit-reproducibility: the same run again gives the same bytes */
            run_path(s, (hd_conv_path)path, x, w, b, dout, g0x, g0w, g0b, 1, &r2);
            CHECK(memcmp(r.out, r2.out, no * sizeof(float)) == 0);
            CHECK(memcmp(r.dinp, r2.dinp, nx * sizeof(float)) == 0);
            CHECK(memcmp(r.dw, r2.dw, nw * sizeof(float)) == 0);
            CHECK(memcmp(r.db, r2.db, (size_t)s->OC * sizeof(float)) == 0);
            /* accumulation: two backward calls add the gradient twice onto g0 */
            run_path(s, (hd_conv_path)path, x, w, b, dout, g0x, g0w, g0b, 2, &twice);
            double acc = 0.0, scale = 1e-6;
            for (size_t i = 0; i < nx; i++) {
                acc = fmax(acc, fabs((twice.dinp[i] - g0x[i]) - 2 * (r.dinp[i] - g0x[i])));
                scale = fmax(scale, fabs(r.dinp[i] - g0x[i]));
            }
            for (size_t i = 0; i < nw; i++) {
                acc = fmax(acc, fabs((twice.dw[i] - g0w[i]) - 2 * (r.dw[i] - g0w[i])));
                scale = fmax(scale, fabs(r.dw[i] - g0w[i]));
            }
            for (int i = 0; i < s->OC; i++) acc = fmax(acc, fabs((twice.db[i] - g0b[i]) - 2 * (r.db[i] - g0b[i])));
            if (!(acc / scale < 1e-5)) {
                fprintf(stderr, "  %s: backward twice is not twice the gradient (%.3g)\n", names[path], acc / scale);
                test_failures++;
            }
            /* NULL gradients are skipped */
            hd_conv3x3 *p;
            if (hd_conv3x3_plan(&p, s->B, s->C, s->H, s->W, s->OC, s->stride, s->act, 0.1f, (hd_conv_path)path) == HD_OK) {
                float *g = dup(dout, no), *dw = dup(g0w, nw);
                hd_conv3x3_forward(p, r2.out, x, w, b);
                hd_conv3x3_backward(p, NULL, dw, NULL, g, r2.out, x, w);
                CHECK(rel_diff(dw, r.dw, nw, &at[0]) < 1e-5);
                free(g), free(dw);
                hd_conv3x3_free(p);
            }
            free_result(&r), free_result(&r2), free_result(&twice);
        }
        free_result(&ref);
        free(x), free(w), free(b), free(dout), free(g0x), free(g0w), free(g0b);
    }
    hd_conv3x3 *p = NULL;
    CHECK(hd_conv3x3_plan(&p, 1, 1, 5, 5, 1, 3, HD_ACT_NONE, 0.1f, HD_CONV_AUTO) == HD_ERR_ARG && !p);
    CHECK(hd_conv3x3_plan(&p, 0, 1, 5, 5, 1, 1, HD_ACT_NONE, 0.1f, HD_CONV_AUTO) == HD_ERR_ARG && !p);
}

/* The blocked-layout plans (nc16, the Common-Net's, oneDNN only) against the naive loops: forward,
 * backward accumulating and backward_into overwriting, on shapes that take oneDNN's Winograd
 * kernels (stride 1, channels in whole blocks, at least 32 pixels a side, odd sizes) and shapes
 * that do not; and two runs giving the same bytes. */
static void test_nc16(void)
{
#ifdef HD_HAVE_DNNL
    static const shape shapes[] = {
        {2, 16, 33, 35, 32, 1, HD_ACT_LRELU}, {1, 32, 37, 32, 48, 1, HD_ACT_NONE}, {1, 48, 32, 34, 16, 1, HD_ACT_LRELU},
        {2, 32, 33, 33, 3, 1, HD_ACT_NONE},   {1, 20, 34, 33, 16, 1, HD_ACT_LRELU}, {2, 16, 15, 13, 16, 1, HD_ACT_LRELU},
    };
    /* where oneDNN has only its reference kernels for the layout (no AVX-512), a plan refuses, by
     * name, so that the Common-Nets take the plain layout; the numerics below then run on those
     * kernels (HD_DNNL_REFERENCE=1) */
    hd_conv3x3 *probe = NULL;
    if (hd_conv3x3_plan_nc16(&probe, 1, 16, 32, 32, 16, 1, HD_ACT_LRELU, 0.1f) == HD_OK) {
        printf("conv nc16: this CPU has oneDNN JIT kernels for the blocked layout\n");
        hd_conv3x3_free(probe);
    } else {
        CHECK(probe == NULL && strstr(hd_error(), "only its reference kernel") != NULL);
        printf("conv nc16: this CPU has only oneDNN's reference kernels for the blocked layout: the plans refuse"
               " (%s); the comparisons below run on the reference kernels\n", hd_error());
        hd_clear_error();
    }
    setenv("HD_DNNL_REFERENCE", "1", 1);
    for (size_t k = 0; k < sizeof shapes / sizeof shapes[0]; k++) {
        const shape *s = &shapes[k];
        int HW = s->H * s->W, Cp = hd_nc16_channels(s->C), OCp = hd_nc16_channels(s->OC);
        size_t nx = (size_t)s->B * s->C * HW, nw = (size_t)s->OC * s->C * 9, no = (size_t)s->B * s->OC * HW;
        size_t nxp = (size_t)s->B * Cp * HW, nop = (size_t)s->B * OCp * HW;
        float *x = randn(nx, -1, 1), *w = randn(nw, -0.3f, 0.3f), *b = randn(s->OC, -0.3f, 0.3f);
        float *dout = randn(no, -1, 1), *g0x = randn(nx, -1, 1), *g0w = randn(nw, -1, 1), *g0b = randn(s->OC, -1, 1);
        result ref;
        if (!run_path(s, HD_CONV_NAIVE, x, w, b, dout, g0x, g0w, g0b, 1, &ref)) {
            test_failures++;
            continue;
        }
        float *xb = malloc(nxp * sizeof(float)), *ob = malloc(nop * sizeof(float)), *gb = malloc(nop * sizeof(float));
        float *dxb = malloc(nxp * sizeof(float)), *out[2], *dinp[2], *dw[2], *db[2], *into = malloc(nx * sizeof(float));
        hd_nc16_from_plain(xb, x, s->B, s->C, HW);
        for (int run = 0; run < 2; run++) {
            out[run] = malloc(no * sizeof(float));
            dinp[run] = dup(g0x, nx), dw[run] = dup(g0w, nw), db[run] = dup(g0b, (size_t)s->OC);
            hd_conv3x3 *p;
            if (hd_conv3x3_plan_nc16(&p, s->B, s->C, s->H, s->W, s->OC, s->stride, s->act, 0.1f) != HD_OK) {
                fprintf(stderr, "plan nc16: %s\n", hd_error());
                test_failures++;
                continue;
            }
            hd_conv3x3_forward(p, ob, xb, w, b);
            hd_nc16_to_plain(out[run], ob, s->B, s->OC, HW, 0);
            /* accumulating: dinp = g0x + dx */
            hd_nc16_from_plain(gb, dout, s->B, s->OC, HW);
            hd_nc16_from_plain(dxb, g0x, s->B, s->C, HW);
            hd_conv3x3_backward(p, dxb, dw[run], db[run], gb, ob, xb, w);
            hd_nc16_to_plain(dinp[run], dxb, s->B, s->C, HW, 0);
            /* overwriting: into = dx, over a buffer of garbage */
            hd_nc16_from_plain(gb, dout, s->B, s->OC, HW);
            for (size_t i = 0; i < nxp; i++) dxb[i] = 1e30f;
            hd_conv3x3_backward_into(p, dxb, NULL, NULL, gb, ob, xb, w);
            hd_nc16_to_plain(into, dxb, s->B, s->C, HW, 0);
            /* the first 16 channels only (a head), where there are more */
            if (run == 0 && s->C > 16) {
                CHECK(hd_conv3x3_plan_dinp_head(p, 16) == HD_OK);
                float *dwh = dup(g0w, nw), *dbh = dup(g0b, (size_t)s->OC), *head = malloc(nx * sizeof(float));
                hd_nc16_from_plain(gb, dout, s->B, s->OC, HW);
                for (size_t i = 0; i < nxp; i++) dxb[i] = 1e30f;
                hd_conv3x3_backward_head_into(p, dxb, dwh, dbh, gb, ob, xb, w);
                hd_nc16_to_plain(head, dxb, s->B, s->C, HW, 0);
                double eh = 0.0, mh = 1e-6;
                for (int n = 0; n < s->B; n++)
                    for (size_t i = 0; i < (size_t)16 * HW; i++) {
                        size_t at = (size_t)n * s->C * HW + i;
                        mh = fmax(mh, fabs(ref.dinp[at] - g0x[at]));
                        eh = fmax(eh, fabs(head[at] + g0x[at] - ref.dinp[at]));
                    }
                printf("conv nc16     %dx%dx%dx%d->%d: backward data onto the first 16 channels: max relative difference %.2e\n",
                       s->B, s->C, s->H, s->W, s->OC, eh / mh);
                CHECK(eh / mh < 1e-5);
                CHECK(memcmp(dwh, dw[0], nw * sizeof(float)) == 0 && memcmp(dbh, db[0], (size_t)s->OC * sizeof(float)) == 0);
                free(dwh), free(dbh), free(head);
            }
            hd_conv3x3_free(p);
        }
        for (size_t i = 0; i < nx; i++) into[i] += g0x[i];
        size_t at;
        double e[5] = {rel_diff(out[0], ref.out, no, &at), rel_diff(dinp[0], ref.dinp, nx, &at), rel_diff(into, ref.dinp, nx, &at),
                       rel_diff(dw[0], ref.dw, nw, &at), rel_diff(db[0], ref.db, (size_t)s->OC, &at)};
        double worst = fmax(fmax(fmax(e[0], e[1]), fmax(e[2], e[3])), e[4]);
        printf("conv nc16     %dx%dx%dx%d->%d s%d%s: max relative difference to naive %.2e (out %.1e, dinp %.1e, into %.1e, dw %.1e, db %.1e)\n",
               s->B, s->C, s->H, s->W, s->OC, s->stride, s->act ? " lrelu" : "", worst, e[0], e[1], e[2], e[3], e[4]);
        if (!(worst <= 1e-5)) {
            fprintf(stderr, "  nc16: differs from naive\n");
            test_failures++;
        }
        CHECK(memcmp(out[0], out[1], no * sizeof(float)) == 0);
        CHECK(memcmp(dinp[0], dinp[1], nx * sizeof(float)) == 0);
        CHECK(memcmp(dw[0], dw[1], nw * sizeof(float)) == 0);
        CHECK(memcmp(db[0], db[1], (size_t)s->OC * sizeof(float)) == 0);
        for (int run = 0; run < 2; run++) free(out[run]), free(dinp[run]), free(dw[run]), free(db[run]);
        free(xb), free(ob), free(gb), free(dxb), free(into);
        free_result(&ref);
        free(x), free(w), free(b), free(dout), free(g0x), free(g0w), free(g0b);
    }
    unsetenv("HD_DNNL_REFERENCE");
#else
    /* The nc16 plans exist only on the oneDNN path: a portable build (HD_DNNL=0) has none. */
    printf("SKIP test_nc16 (the nc16 convolution plans against naive): needs oneDNN, built with HD_DNNL=0\n");
    hd_conv3x3 *p = NULL;
    CHECK(hd_conv3x3_plan_nc16(&p, 1, 16, 8, 8, 16, 1, HD_ACT_NONE, 0.0f) == HD_ERR_ARG && p == NULL);
#endif
}

/* The nc16 max pooling and upsampling against the plain ones, bit for bit (the same comparisons and
 * sums), with many ties (values from a set of 4) and odd sizes; backward accumulating and
 * overwriting (over garbage). */
static void test_nc16_layers(void)
{
    static const int sizes[][4] = {{2, 20, 6, 10}, {1, 16, 7, 9}, {2, 3, 8, 4}};
    for (size_t k = 0; k < sizeof sizes / sizeof sizes[0]; k++) {
        int B = sizes[k][0], C = sizes[k][1], H = sizes[k][2], W = sizes[k][3], Ho = H / 2, Wo = W / 2;
        int Cp = hd_nc16_channels(C);
        size_t n = (size_t)B * C * H * W, no = (size_t)B * C * Ho * Wo, np = (size_t)B * Cp * H * W, nop = (size_t)B * Cp * Ho * Wo;
        float *x = malloc(n * sizeof(float)), *g = randn(no, -1, 1), *g0 = randn(n, -1, 1);
        for (size_t i = 0; i < n; i++) x[i] = (float)hd_rng_below(&rng, 4) - 1.5f;
        float *out = malloc(no * sizeof(float)), *dx = dup(g0, n), *xb = malloc(np * sizeof(float));
        float *ob = malloc(nop * sizeof(float)), *gb = malloc(nop * sizeof(float)), *dxb = malloc(np * sizeof(float));
        float *plain = malloc(n * sizeof(float)), *into = malloc(n * sizeof(float));
        hd_maxpool2_forward(out, x, B, C, H, W);
        hd_maxpool2_backward(dx, g, x, B, C, H, W);
        hd_nc16_from_plain(xb, x, B, C, H * W);
        hd_nc16_from_plain(gb, g, B, C, Ho * Wo);
        hd_maxpool2_nc16_forward(ob, xb, B, C, H, W);
        hd_nc16_to_plain(plain, ob, B, C, Ho * Wo, 0);
        CHECK(memcmp(plain, out, no * sizeof(float)) == 0);
        hd_nc16_from_plain(dxb, g0, B, C, H * W);
        hd_maxpool2_nc16_backward(dxb, gb, xb, B, C, H, W);
        hd_nc16_to_plain(plain, dxb, B, C, H * W, 0);
        CHECK(memcmp(plain, dx, n * sizeof(float)) == 0);
        for (size_t i = 0; i < np; i++) dxb[i] = 1e30f;
        hd_maxpool2_nc16_backward_into(dxb, gb, xb, B, C, H, W);
        hd_nc16_to_plain(into, dxb, B, C, H * W, 1); /* into = g0 + the gradient */
        memcpy(plain, g0, n * sizeof(float));
        hd_nc16_to_plain(plain, dxb, B, C, H * W, 1);
        for (size_t i = 0; i < n; i++) CHECK(plain[i] == dx[i] || fabsf(plain[i] - dx[i]) <= 1e-6f * fabsf(dx[i]));
        int padded_zero = 1;
        for (long nb = 0; nb < (long)B * (Cp / 16); nb++)
            for (size_t q = 0; q < (size_t)H * W; q++)
                for (int l = 0; l < 16; l++)
                    if ((nb % (Cp / 16)) * 16 + l >= C && dxb[((size_t)nb * H * W + q) * 16 + l] != 0.0f) padded_zero = 0;
        CHECK(padded_zero);
        printf("nc16 maxpool2 %dx%dx%dx%d: forward and backward (accumulating, overwriting) as the plain layer\n", B, C, H, W);
        /* upsampling: nc16 against plain */
        float *up = malloc(4 * n * sizeof(float)), *upb = malloc(4 * np * sizeof(float)), *du = dup(g0, n);
        float *gu = randn(4 * n, -1, 1), *gub = malloc(4 * np * sizeof(float));
        hd_upsample2_forward(up, x, B, C, H, W);
        hd_upsample2_nc16_forward(upb, xb, B, C, H, W);
        float *upp = malloc(4 * n * sizeof(float));
        hd_nc16_to_plain(upp, upb, B, C, 4 * H * W, 0);
        CHECK(memcmp(upp, up, 4 * n * sizeof(float)) == 0);
        hd_upsample2_backward(du, gu, B, C, H, W);
        hd_nc16_from_plain(gub, gu, B, C, 4 * H * W);
        hd_nc16_from_plain(dxb, g0, B, C, H * W);
        hd_upsample2_nc16_backward(dxb, gub, B, C, H, W);
        hd_nc16_to_plain(plain, dxb, B, C, H * W, 0);
        CHECK(memcmp(plain, du, n * sizeof(float)) == 0);
        free(up), free(upb), free(du), free(gu), free(gub), free(upp);
        free(x), free(g), free(g0), free(out), free(dx), free(xb), free(ob), free(gb), free(dxb), free(plain), free(into);
    }
}

static void test_adam(void)
{
    /* p = 1, g = 0.5 then -0.25, lr 0.1, (0.9, 0.999, 1e-8), by hand:
     * t = 1: m = 0.05, v = 2.5e-4, m^ = 0.5, v^ = 0.25, p = 1 - 0.1 * 0.5 / (0.5 + 1e-8) = 0.900000002
     * t = 2: m = 0.02, v = 3.1225e-4, m^ = 0.02 / 0.19, v^ = 3.1225e-4 / 1.999e-3, p = 0.8733662987 */
    float p[2] = {1.0f, -2.0f}, m[2] = {0}, v[2] = {0};
    float g1[2] = {0.5f, 0.0f}, g2[2] = {-0.25f, 0.0f};
    hd_adam_step(p, g1, m, v, 2, 0.1f, 0.9f, 0.999f, 1e-8f, 1);
    CHECK_NEAR(p[0], 0.900000002, 1e-6);
    CHECK_NEAR(m[0], 0.05, 1e-7);
    CHECK_NEAR(v[0], 2.5e-4, 1e-8); /* 1 - 0.999 is inexact in float */
    hd_adam_step(p, g2, m, v, 2, 0.1f, 0.9f, 0.999f, 1e-8f, 2);
    CHECK_NEAR(p[0], 0.8733662987, 2e-6);
    CHECK_NEAR(m[0], 0.02, 1e-7);
    CHECK_NEAR(v[0], 3.1225e-4, 1e-8);
    CHECK(p[1] == -2.0f); /* zero gradient, zero moments: no step */
}

static void test_init(void)
{
    enum { NW = 48 * 32 * 9, NB = 48 };
    static float w1[NW], b1[NB], w2[NW], b2[NB];
    hd_rng a, b;
    hd_rng_seed(&a, 7, 3);
    hd_rng_seed(&b, 7, 3);
    hd_init_uniform_fan_in(w1, NW, b1, NB, 32 * 9, &a);
    hd_init_uniform_fan_in(w2, NW, b2, NB, 32 * 9, &b);
    CHECK(memcmp(w1, w2, sizeof w1) == 0 && memcmp(b1, b2, sizeof b1) == 0);
    float bound = 1.0f / sqrtf(32 * 9), lo = 1, hi = -1;
    double mean = 0.0;
    for (int i = 0; i < NW; i++) {
        CHECK(w1[i] >= -bound && w1[i] <= bound);
        lo = fminf(lo, w1[i]), hi = fmaxf(hi, w1[i]);
        mean += w1[i];
    }
    for (int i = 0; i < NB; i++) CHECK(b1[i] >= -bound && b1[i] <= bound);
    CHECK(lo < -0.99f * bound && hi > 0.99f * bound); /* the whole range is used */
    CHECK_NEAR(mean / NW, 0.0, 0.02 * bound);
    hd_init_uniform_fan_in(w2, NW, NULL, 0, 32 * 9, &b); /* the next draw differs */
    CHECK(memcmp(w1, w2, sizeof w1) != 0);
}

int main(void)
{
    hd_rng_seed(&rng, 99, 2);
    test_paths();
    test_nc16();
    test_nc16_layers();
    test_adam();
    test_init();
    return test_summary("test_conv");
}
