/* test_nn.c: every backward of src/nn (and the whole Common-Net) against central finite
 * differences. Each case is a scalar L = sum_i r_i y_i (a random linear functional of the layer's
 * output, accumulated in double) or a loss value, differentiated numerically with respect to a
 * sample of every input. Inputs are drawn on grids that keep them away from the kinks of max,
 * leaky ReLU and |.|: layer cases must have no kink crossing at all. The whole net cannot be kept
 * away from kinks as surely (its biases keep most pre-activations off zero), so there an index
 * where the step sizes disagree (a kink crossed) is skipped, and at most a quarter may be; a
 * directional derivative along the gradient must match as well. Prints the worst relative error per case; exits nonzero past
 * tolerance. */
#include <omp.h>
#include <stdlib.h>
#include <string.h>
#include "test.h"
#include "nn/nn.h"
#include "model/unet.h"

#define MAXIN 4
#define SAMPLES 48

typedef struct fd_case fd_case;
struct fd_case {
    char name[64];
    int nin;
    float *x[MAXIN], *g[MAXIN];
    size_t n[MAXIN];
    const char *xname[MAXIN];
    double (*loss)(fd_case *c);   /* L at the current inputs */
    void (*grad)(fd_case *c);     /* g (zeroed by the caller) += dL/dx */
    int allow_kinks;
    int samples; /* values checked per input (0: SAMPLES) */
    double floor, tol;
    /* layer state */
    int B, C, H, W, OC, stride, Ho, Wo, target;
    float slope, eps;
    hd_conv3x3 *plan;
    hd_unet *net;
    float *out, *r, *aux, *aux2, *r2;
    size_t nout;
};

static hd_rng rng;

static float *fa(size_t n) { return calloc(n ? n : 1, sizeof(float)); }

/* Uniform grid values k * step + offset, k in [-K, K]. */
static void fill_grid(float *x, size_t n, int K, float step, float offset)
{
    for (size_t i = 0; i < n; i++) x[i] = (float)((int)hd_rng_below(&rng, 2 * K + 1) - K) * step + offset;
}
static void fill_uniform(float *x, size_t n, float lo, float hi)
{
    for (size_t i = 0; i < n; i++) x[i] = hd_rng_range(&rng, lo, hi);
}
static double dot_r(const float *r, const float *y, size_t n)
{
    double s = 0.0;
    for (size_t i = 0; i < n; i++) s += (double)r[i] * y[i];
    return s;
}

/* ---- the checker */

static double eval_at(fd_case *c, int k, size_t i, double h)
{
    float saved = c->x[k][i];
    c->x[k][i] = (float)(saved + h);
    double lp = c->loss(c);
    c->x[k][i] = (float)(saved - h);
    double lm = c->loss(c);
    c->x[k][i] = saved;
    /* the step actually taken in float */
    double hp = (double)(float)(saved + h) - saved, hm = saved - (double)(float)(saved - h);
    return (lp - lm) / (hp + hm);
}

static double run_case(fd_case *c)
{
    double t0 = hd_seconds();
    for (int k = 0; k < c->nin; k++) memset(c->g[k], 0, c->n[k] * sizeof(float));
    c->grad(c);
    double worst = 0.0;
    int checked = 0, skipped = 0;
    for (int k = 0; k < c->nin; k++) {
        /* relative errors are measured against the larger of the case's floor and 1 % of the
         * tensor's largest gradient (float noise in L is about 1e-7 |L| / h) */
        double gmax = 0.0;
        for (size_t i = 0; i < c->n[k]; i++) gmax = fmax(gmax, fabs(c->g[k][i]));
        double floor = fmax(c->floor, 1e-2 * gmax);
        size_t cap = c->samples ? (size_t)c->samples : SAMPLES;
        size_t count = c->n[k] <= cap ? c->n[k] : cap;
        for (size_t s = 0; s < count; s++) {
            size_t i = c->n[k] <= cap ? s : hd_rng_below(&rng, (uint32_t)c->n[k]);
            double a = c->g[k][i], num[3], e = INFINITY, lo = INFINITY, hi = -INFINITY;
            static const double steps[3] = {1e-2, 3e-3, 1e-3};
            for (int h = 0; h < 3; h++) {
                num[h] = eval_at(c, k, i, steps[h]);
                e = fmin(e, fabs(a - num[h]) / fmax(fabs(a) + fabs(num[h]), floor));
                lo = fmin(lo, num[h]), hi = fmax(hi, num[h]);
            }
            double spread = (hi - lo) / fmax(fabs(hi) + fabs(lo), floor);
            checked++;
            if (e > c->tol && c->allow_kinks && spread > c->tol) {
                skipped++; /* the step sizes disagree: a kink lies within reach */
                continue;
            }
            if (e > worst) worst = e;
            if (e > c->tol)
                fprintf(stderr, "%s: d%s[%zu]: analytic %.7g, numeric %.7g / %.7g / %.7g\n", c->name,
                        c->xname[k], i, a, num[0], num[1], num[2]);
        }
    }
    /* the directional derivative along v = g / max|g| plus 10 % noise per input: it sums many
     * values without cancellation, so the kinks it crosses average out and it must match even
     * where single values were skipped */
    for (int k = 0; k < c->nin && c->allow_kinks; k++) {
        float *v = fa(c->n[k]), *x0 = fa(c->n[k]);
        memcpy(x0, c->x[k], c->n[k] * sizeof(float));
        double a = 0.0, gmax = 1e-30;
        for (size_t i = 0; i < c->n[k]; i++) gmax = fmax(gmax, fabs(c->g[k][i]));
        for (size_t i = 0; i < c->n[k]; i++) {
            v[i] = (float)(c->g[k][i] / gmax) + hd_rng_range(&rng, -0.1f, 0.1f);
            a += (double)v[i] * c->g[k][i];
        }
        double e = INFINITY, num[3];
        static const double steps[3] = {1e-2, 3e-3, 1e-3};
        for (int h = 0; h < 3; h++) {
            for (size_t i = 0; i < c->n[k]; i++) c->x[k][i] = (float)(x0[i] + steps[h] * v[i]);
            double lp = c->loss(c);
            for (size_t i = 0; i < c->n[k]; i++) c->x[k][i] = (float)(x0[i] - steps[h] * v[i]);
            double lm = c->loss(c);
            num[h] = (lp - lm) / (2 * steps[h]);
            e = fmin(e, fabs(a - num[h]) / fmax(fabs(a) + fabs(num[h]), c->floor));
        }
        memcpy(c->x[k], x0, c->n[k] * sizeof(float));
        checked++;
        if (e > worst) worst = e;
        if (e > c->tol)
            fprintf(stderr, "%s: d%s . v: analytic %.7g, numeric %.7g / %.7g / %.7g\n", c->name, c->xname[k],
                    a, num[0], num[1], num[2]);
        free(v), free(x0);
    }
    int bad = worst > c->tol || skipped * 4 > checked;
    printf("%-34s worst relative error %.2e over %d values (%d skipped at kinks, %.2f s)%s\n", c->name, worst,
           checked, skipped, hd_seconds() - t0, bad ? "  FAIL" : "");
    if (bad) test_failures++;
    return worst;
}

static void add_input(fd_case *c, float *x, size_t n, const char *name)
{
    c->x[c->nin] = x;
    c->g[c->nin] = fa(n);
    c->n[c->nin] = n;
    c->xname[c->nin] = name;
    c->nin++;
}

static void free_case(fd_case *c)
{
    for (int k = 0; k < c->nin; k++) free(c->x[k]), free(c->g[k]);
    hd_conv3x3_free(c->plan);
    hd_unet_free(c->net);
    free(c->out), free(c->r), free(c->aux), free(c->aux2), free(c->r2);
}

static void with_output(fd_case *c, size_t nout)
{
    c->nout = nout;
    c->out = fa(nout);
    c->r = fa(nout);
    c->aux = fa(nout);
    fill_uniform(c->r, nout, -1.0f, 1.0f);
}

/* ---- convolution: inputs x, w, b on grids so that every pre-activation is an odd multiple of
 * 1/256 (|pre| >= 1/256), far from the leaky ReLU kink for steps up to 1e-2 * |x|, |w| <= 0.25. */

static double conv_loss(fd_case *c)
{
    hd_conv3x3_forward(c->plan, c->out, c->x[0], c->x[1], c->x[2]);
    return dot_r(c->r, c->out, c->nout);
}
static void conv_grad(fd_case *c)
{
    hd_conv3x3_forward(c->plan, c->out, c->x[0], c->x[1], c->x[2]);
    memcpy(c->aux, c->r, c->nout * sizeof(float));
    hd_conv3x3_backward(c->plan, c->g[0], c->g[1], c->g[2], c->aux, c->out, c->x[0], c->x[1]);
}
static void setup_conv(fd_case *c, int B, int C, int H, int W, int OC, int stride, hd_act act, hd_conv_path path)
{
    static const char *paths[] = {"auto", "portable", "naive"};
    snprintf(c->name, sizeof c->name, "conv3x3 %s %dx%dx%dx%d->%d s%d%s", paths[path], B, C, H, W, OC,
             stride, act ? " lrelu" : "");
    if (hd_conv3x3_plan(&c->plan, B, C, H, W, OC, stride, act, 0.1f, path) != HD_OK) {
        fprintf(stderr, "plan failed: %s\n", hd_error());
        exit(1);
    }
    size_t nx = (size_t)B * C * H * W, nw = (size_t)OC * C * 9;
    float *x = fa(nx), *w = fa(nw), *b = fa(OC);
    fill_grid(x, nx, 8, 0.125f, 0.0f);        /* multiples of 1/8 in [-1, 1] */
    fill_grid(w, nw, 4, 1.0f / 16, 0.0f);     /* multiples of 1/16 in [-1/4, 1/4] */
    fill_grid(b, OC, 8, 1.0f / 128, 1.0f / 256);
    add_input(c, x, nx, "inp");
    add_input(c, w, nw, "w");
    add_input(c, b, OC, "b");
    with_output(c, (size_t)B * OC * hd_conv3x3_out_h(c->plan) * hd_conv3x3_out_w(c->plan));
    c->loss = conv_loss, c->grad = conv_grad;
}

/* ---- elementwise */

enum { EL_LRELU, EL_SIGMOID, EL_SOFTPLUS, EL_TANH };
static double elem_loss(fd_case *c)
{
    switch (c->target) {
    case EL_LRELU: hd_lrelu_forward(c->out, c->x[0], c->nout, c->slope); break;
    case EL_SIGMOID: hd_sigmoid_forward(c->out, c->x[0], c->nout); break;
    case EL_SOFTPLUS: hd_softplus_forward(c->out, c->x[0], c->nout); break;
    default: hd_tanh_forward(c->out, c->x[0], c->nout); break;
    }
    return dot_r(c->r, c->out, c->nout);
}
static void elem_grad(fd_case *c)
{
    elem_loss(c);
    switch (c->target) {
    case EL_LRELU: hd_lrelu_backward(c->g[0], c->r, c->x[0], c->nout, c->slope); break;
    case EL_SIGMOID: hd_sigmoid_backward(c->g[0], c->r, c->out, c->nout); break;
    case EL_SOFTPLUS: hd_softplus_backward(c->g[0], c->r, c->x[0], c->nout); break;
    default: hd_tanh_backward(c->g[0], c->r, c->out, c->nout); break;
    }
}
static void setup_elem(fd_case *c, int kind, const char *name)
{
    snprintf(c->name, sizeof c->name, "%s 2x3x7x9", name);
    size_t n = 2 * 3 * 7 * 9;
    float *x = fa(n);
    fill_grid(x, n, 12, 0.25f, 0.125f); /* |x| >= 1/8, away from 0 */
    add_input(c, x, n, "inp");
    with_output(c, n);
    c->target = kind, c->slope = 0.2f;
    c->loss = elem_loss, c->grad = elem_grad;
}

/* ---- l2norm3 */

static double l2_loss(fd_case *c)
{
    hd_l2norm3_forward(c->out, c->x[0], c->B, c->H * c->W, 1e-6f);
    return dot_r(c->r, c->out, c->nout);
}
static void l2_grad(fd_case *c) { hd_l2norm3_backward(c->g[0], c->r, c->x[0], c->B, c->H * c->W, 1e-6f); }
static void setup_l2(fd_case *c)
{
    snprintf(c->name, sizeof c->name, "l2norm3 2x3x9x7");
    c->B = 2, c->H = 9, c->W = 7;
    size_t n = 2 * 3 * 63;
    float *x = fa(n);
    fill_uniform(x, n, 0.5f, 1.5f);
    for (size_t i = 0; i < n; i++)
        if (hd_rng_below(&rng, 2)) x[i] = -x[i];
    add_input(c, x, n, "inp");
    with_output(c, n);
    c->loss = l2_loss, c->grad = l2_grad;
}

/* ---- maxpool: distinct values 1/16 apart, so no step changes an argmax */

static double mp_loss(fd_case *c)
{
    hd_maxpool2_forward(c->out, c->x[0], c->B, c->C, c->H, c->W);
    return dot_r(c->r, c->out, c->nout);
}
static void mp_grad(fd_case *c) { hd_maxpool2_backward(c->g[0], c->r, c->x[0], c->B, c->C, c->H, c->W); }
static void setup_maxpool(fd_case *c)
{
    c->B = 2, c->C = 3, c->H = 12, c->W = 8;
    snprintf(c->name, sizeof c->name, "maxpool2 2x3x12x8");
    size_t n = (size_t)c->B * c->C * c->H * c->W;
    float *x = fa(n);
    for (size_t i = 0; i < n; i++) x[i] = (float)i / 16.0f - 10.0f;
    for (size_t i = n - 1; i > 0; i--) { /* shuffle */
        size_t j = hd_rng_below(&rng, (uint32_t)(i + 1));
        float t = x[i];
        x[i] = x[j], x[j] = t;
    }
    add_input(c, x, n, "inp");
    with_output(c, n / 4);
    c->loss = mp_loss, c->grad = mp_grad;
}

/* ---- upsample */

static double up_loss(fd_case *c)
{
    hd_upsample2_forward(c->out, c->x[0], c->B, c->C, c->H, c->W);
    return dot_r(c->r, c->out, c->nout);
}
static void up_grad(fd_case *c) { hd_upsample2_backward(c->g[0], c->r, c->B, c->C, c->H, c->W); }
static void setup_upsample(fd_case *c)
{
    c->B = 2, c->C = 3, c->H = 7, c->W = 9;
    snprintf(c->name, sizeof c->name, "upsample2 2x3x7x9");
    size_t n = (size_t)c->B * c->C * c->H * c->W;
    float *x = fa(n);
    fill_uniform(x, n, -1, 1);
    add_input(c, x, n, "inp");
    with_output(c, 4 * n);
    c->loss = up_loss, c->grad = up_grad;
}

/* ---- concat (Ca = C, Cb = OC) */

static double cat_loss(fd_case *c)
{
    hd_concat_forward(c->out, c->x[0], c->C, c->x[1], c->OC, c->B, c->H * c->W);
    return dot_r(c->r, c->out, c->nout);
}
static void cat_grad(fd_case *c) { hd_concat_backward(c->g[0], c->g[1], c->r, c->C, c->OC, c->B, c->H * c->W); }
static void setup_concat(fd_case *c)
{
    c->B = 2, c->C = 1, c->OC = 3, c->H = 7, c->W = 9;
    snprintf(c->name, sizeof c->name, "concat 2x(1+3)x7x9");
    size_t na = 2 * 1 * 63, nb = 2 * 3 * 63;
    float *a = fa(na), *b = fa(nb);
    fill_uniform(a, na, -1, 1);
    fill_uniform(b, nb, -1, 1);
    add_input(c, a, na, "a");
    add_input(c, b, nb, "b");
    with_output(c, na + nb);
    c->loss = cat_loss, c->grad = cat_grad;
}

/* ---- meanpool */

static double mean_loss(fd_case *c)
{
    hd_meanpool_forward(c->out, c->x[0], c->B, c->C, c->H * c->W);
    return dot_r(c->r, c->out, c->nout);
}
static void mean_grad(fd_case *c) { hd_meanpool_backward(c->g[0], c->r, c->B, c->C, c->H * c->W); }
static void setup_meanpool(fd_case *c)
{
    c->B = 2, c->C = 5, c->H = 7, c->W = 9;
    snprintf(c->name, sizeof c->name, "meanpool 2x5x7x9");
    size_t n = 2 * 5 * 63;
    float *x = fa(n);
    fill_uniform(x, n, -1, 1);
    add_input(c, x, n, "inp");
    with_output(c, 10);
    c->loss = mean_loss, c->grad = mean_grad;
}

/* ---- linear (IN = C, OUT = OC) */

static double lin_loss(fd_case *c)
{
    hd_linear_forward(c->out, c->x[0], c->x[1], c->x[2], c->B, c->C, c->OC);
    return dot_r(c->r, c->out, c->nout);
}
static void lin_grad(fd_case *c)
{
    hd_linear_backward(c->g[0], c->g[1], c->g[2], c->r, c->x[0], c->x[1], c->B, c->C, c->OC);
}
static void setup_linear(fd_case *c)
{
    c->B = 3, c->C = 7, c->OC = 5;
    snprintf(c->name, sizeof c->name, "linear 3x7->5");
    float *x = fa(21), *w = fa(35), *b = fa(5);
    fill_uniform(x, 21, -1, 1);
    fill_uniform(w, 35, -1, 1);
    fill_uniform(b, 5, -1, 1);
    add_input(c, x, 21, "inp");
    add_input(c, w, 35, "w");
    add_input(c, b, 5, "b");
    with_output(c, 15);
    c->loss = lin_loss, c->grad = lin_grad;
}

/* ---- instnorm (aux2 holds mean and rstd) */

static double in_loss(fd_case *c)
{
    size_t bc = (size_t)c->B * c->C;
    hd_instnorm_forward(c->out, c->aux2, c->aux2 + bc, c->x[0], c->B, c->C, c->H * c->W, 1e-5f);
    return dot_r(c->r, c->out, c->nout);
}
static void in_grad(fd_case *c)
{
    in_loss(c);
    hd_instnorm_backward(c->g[0], c->r, c->out, c->aux2 + (size_t)c->B * c->C, c->B, c->C, c->H * c->W);
}
static void setup_instnorm(fd_case *c)
{
    c->B = 2, c->C = 3, c->H = 9, c->W = 7;
    snprintf(c->name, sizeof c->name, "instnorm 2x3x9x7");
    size_t n = 2 * 3 * 63;
    float *x = fa(n);
    fill_uniform(x, n, -2, 2);
    add_input(c, x, n, "inp");
    with_output(c, n);
    c->aux2 = fa(12);
    c->loss = in_loss, c->grad = in_grad;
}

/* ---- losses (C = 3 channels over HW = 63 pixels, weights in aux2) */

enum { LS_L1, LS_SQ, LS_BCE1, LS_BCE0, LS_SMOOTH };
static double loss_loss(fd_case *c)
{
    const float *w = c->aux2;
    int HW = c->H * c->W;
    switch (c->target) {
    case LS_L1: return hd_loss_l1(NULL, NULL, c->x[0], c->x[1], w, c->C, HW, 0.7f) * 0.7;
    case LS_SQ: return hd_loss_sqdist(NULL, NULL, c->x[0], c->x[1], w, c->C, HW, 0.7f) * 0.7;
    case LS_BCE1: return hd_loss_bce_logits(NULL, c->x[0], c->n[0], 1, 0.7f) * 0.7;
    case LS_BCE0: return hd_loss_bce_logits(NULL, c->x[0], c->n[0], 0, 0.7f) * 0.7;
    default: return hd_loss_smooth(NULL, c->x[0], w, c->H, c->W, c->eps, 0.7f) * 0.7;
    }
}
static void loss_grad(fd_case *c)
{
    const float *w = c->aux2;
    int HW = c->H * c->W;
    switch (c->target) {
    case LS_L1: hd_loss_l1(c->g[0], c->g[1], c->x[0], c->x[1], w, c->C, HW, 0.7f); break;
    case LS_SQ: hd_loss_sqdist(c->g[0], c->g[1], c->x[0], c->x[1], w, c->C, HW, 0.7f); break;
    case LS_BCE1: hd_loss_bce_logits(c->g[0], c->x[0], c->n[0], 1, 0.7f); break;
    case LS_BCE0: hd_loss_bce_logits(c->g[0], c->x[0], c->n[0], 0, 0.7f); break;
    default: hd_loss_smooth(c->g[0], c->x[0], w, c->H, c->W, c->eps, 0.7f); break;
    }
}
static void setup_loss(fd_case *c, int kind, const char *name)
{
    c->C = 3, c->H = 9, c->W = 7, c->target = kind;
    snprintf(c->name, sizeof c->name, "loss %s", name);
    int HW = 63;
    c->aux2 = fa(HW);
    fill_uniform(c->aux2, HW, 0.0f, 1.0f);
    for (int p = 0; p < HW; p += 5) c->aux2[p] = 0.0f; /* masked out */
    if (kind == LS_SMOOTH) {
        /* s = 0.2 k + 0.05 (x odd) + 0.1 (y odd): |dx| in {0.05, 0.15, 0.25, ...}, |dy| in
         * {0.1, 0.3, ...}: at least 0.05 from 0 and from eps = 0.2 */
        float *s = fa(HW);
        for (int y = 0; y < c->H; y++)
            for (int x = 0; x < c->W; x++)
                s[y * c->W + x] = 0.2f * ((int)hd_rng_below(&rng, 7) - 3) + 0.05f * (x & 1) + 0.1f * (y & 1);
        c->eps = 0.2f;
        add_input(c, s, HW, "s");
    } else if (kind == LS_L1 || kind == LS_SQ) {
        size_t n = 3 * 63;
        float *x = fa(n), *y = fa(n);
        fill_uniform(y, n, -1, 1);
        for (size_t i = 0; i < n; i++) /* |x - y| >= 0.05 */
            x[i] = y[i] + (hd_rng_below(&rng, 2) ? 1.0f : -1.0f) * hd_rng_range(&rng, 0.05f, 0.5f);
        add_input(c, x, n, "x");
        add_input(c, y, n, "y");
    } else {
        float *x = fa(50);
        fill_uniform(x, 50, -4, 4);
        add_input(c, x, 50, "x");
    }
    c->loss = loss_loss, c->grad = loss_grad;
}

/* ---- the whole Common-Net: width 4, 32x32, cin 2 -> cout 3, batch 2. Inputs: the parameters,
 * the net's input; the functional also reads the bottleneck (r2), exercising dbottleneck. */

static double net_loss(fd_case *c)
{
    hd_unet_forward(c->net, c->x[1], c->out);
    size_t nb = (size_t)c->B * 4 * 1 * 1;
    return dot_r(c->r, c->out, c->nout) + dot_r(c->r2, hd_unet_bottleneck(c->net), nb);
}
static void net_grad(fd_case *c)
{
    hd_unet_bind(c->net, c->x[0], c->g[0]);
    hd_unet_forward(c->net, c->x[1], c->out);
    hd_unet_backward(c->net, c->r, c->r2, c->g[1]);
}
static void setup_net(fd_case *c, hd_conv_path path)
{
    static const char *paths[] = {"auto", "portable", "naive"};
    c->B = 2;
    snprintf(c->name, sizeof c->name, "common-net %s w4 2x2x32x32->3", paths[path]);
    if (hd_unet_create(&c->net, 2, 3, 4, 2, 32, 32, path) != HD_OK) {
        fprintf(stderr, "unet: %s\n", hd_error());
        exit(1);
    }
    int np = 0;
    size_t total = 0;
    hd_unet_params("a_net", 2, 3, 4, NULL, &np, &total);
    hd_param params[2 * HD_UNET_LAYERS];
    np = 0;
    size_t off = 0;
    hd_unet_params("a_net", 2, 3, 4, params, &np, &off);
    CHECK(np == 2 * HD_UNET_LAYERS && off == total);
    CHECK(strcmp(params[0].name, "a_net.enc0.weight") == 0 && params[0].shape[0] == 4 && params[0].shape[1] == 2);
    CHECK(strcmp(params[31].name, "a_net.dec1a.bias") == 0 && params[31].shape[0] == 64);
    CHECK(params[30].shape[1] == 2 * 4 + 2);
    float *p = fa(total);
    for (int k = 0; k < np; k++) {
        hd_param *q = &params[k];
        if (q->ndim == 4)
            hd_init_uniform_fan_in(p + q->offset, q->count, p + q->offset + q->count, (size_t)q->shape[0],
                                   (int)(q->shape[1] * 9), &rng);
    }
    /* Away from the kinks: weights at half the default scale and biases of +-(0.5 .. 1.5), so that
     * each channel's pre-activations keep one sign (both signs occur across channels). */
    for (int k = 0; k < np; k++) {
        hd_param *q = &params[k];
        for (size_t i = 0; i < q->count; i++)
            p[q->offset + i] = q->ndim == 4 ? 0.5f * p[q->offset + i]
                                            : (hd_rng_below(&rng, 2) ? 1.0f : -1.0f) * hd_rng_range(&rng, 0.5f, 1.5f);
    }
    size_t nx = (size_t)2 * 2 * 32 * 32;
    float *x = fa(nx);
    fill_uniform(x, nx, -1, 1);
    add_input(c, p, total, "param");
    add_input(c, x, nx, "inp");
    hd_unet_bind(c->net, p, NULL);
    with_output(c, (size_t)2 * 3 * 32 * 32);
    c->r2 = fa(2 * 4);
    fill_uniform(c->r2, 8, -1, 1);
    c->loss = net_loss, c->grad = net_grad;
    c->allow_kinks = 1;
    c->samples = 20;
    c->floor = 3e-2, c->tol = 3e-2;
}

/* The blocked-layout Common-Net (auto at a width that is a multiple of 16, cin 1 so that the
 * input's channel block is padded) against the naive plain one: output, bottleneck, parameter and
 * input gradients. Same parameters, inputs and output gradients (with a bottleneck gradient). */
static void test_net_layouts(void)
{
    enum { B = 2, CIN = 1, COUT = 3, WIDTH = 16, S = 32 };
    hd_unet *fast, *ref;
    if (hd_unet_create(&fast, CIN, COUT, WIDTH, B, S, S, HD_CONV_AUTO) != HD_OK ||
        hd_unet_create(&ref, CIN, COUT, WIDTH, B, S, S, HD_CONV_NAIVE) != HD_OK) {
        fprintf(stderr, "unet: %s\n", hd_error());
        test_failures++;
        return;
    }
    int np = 0;
    size_t total = 0;
    hd_unet_params("n_net", CIN, COUT, WIDTH, NULL, &np, &total);
    size_t nx = (size_t)B * CIN * S * S, no = (size_t)B * COUT * S * S, nb = (size_t)B * WIDTH * (S / 32) * (S / 32);
    float *p = fa(total), *g1 = fa(total), *g2 = fa(total), *x = fa(nx), *o1 = fa(no), *o2 = fa(no);
    float *dout = fa(no), *dbn = fa(nb), *dx1 = fa(nx), *dx2 = fa(nx);
    fill_uniform(p, total, -0.15f, 0.15f);
    /* biases of +-(0.5 .. 1.5) keep pre-activations away from the leaky ReLU kink, where the
     * two paths' rounding could otherwise pick different slopes */
    hd_param table[2 * HD_UNET_LAYERS];
    int nt = 0;
    size_t off = 0;
    hd_unet_params("n_net", CIN, COUT, WIDTH, table, &nt, &off);
    for (int k = 1; k < nt; k += 2)
        for (size_t i = 0; i < table[k].count; i++)
            p[table[k].offset + i] = (hd_rng_below(&rng, 2) ? 1.0f : -1.0f) * hd_rng_range(&rng, 0.5f, 1.5f);
    fill_uniform(x, nx, -1, 1);
    fill_uniform(dout, no, -1, 1);
    fill_uniform(dbn, nb, -1, 1);
    hd_unet_bind(fast, p, g1);
    hd_unet_bind(ref, p, g2);
    double worst[5] = {0};
    for (int rep = 0; rep < 2; rep++) { /* twice: gradients must accumulate alike */
        hd_unet_forward(fast, x, o1);
        hd_unet_forward(ref, x, o2);
        hd_unet_backward(fast, dout, dbn, dx1);
        hd_unet_backward(ref, dout, dbn, dx2);
    }
    const float *pairs[5][2] = {{o1, o2}, {hd_unet_bottleneck(fast), hd_unet_bottleneck(ref)}, {g1, g2}, {dx1, dx2}, {NULL, NULL}};
    size_t counts[4] = {no, nb, total, nx};
    static const char *what[4] = {"out", "bottleneck", "param grads", "input grads"};
    for (int k = 0; k < 4; k++) {
        double m = 1e-6;
        for (size_t i = 0; i < counts[k]; i++) m = fmax(m, fabs(pairs[k][1][i]));
        for (size_t i = 0; i < counts[k]; i++) worst[k] = fmax(worst[k], fabs(pairs[k][0][i] - pairs[k][1][i]) / m);
        printf("common-net auto (blocked when built with oneDNN) vs naive, w16 1->3 32x32 batch 2: %-11s max relative difference %.2e%s\n",
               what[k], worst[k], worst[k] > 1e-4 ? "  FAIL" : "");
        if (worst[k] > 1e-4) test_failures++;
    }
    /* without an input gradient (the blocked net then skips the input's channels in dec1a) */
    memset(g1, 0, total * sizeof(float)), memset(g2, 0, total * sizeof(float));
    hd_unet_forward(fast, x, o1);
    hd_unet_forward(ref, x, o2);
    hd_unet_backward(fast, dout, dbn, NULL);
    hd_unet_backward(ref, dout, dbn, NULL);
    double m = 1e-6, e = 0.0;
    for (size_t i = 0; i < total; i++) m = fmax(m, fabs(g2[i]));
    for (size_t i = 0; i < total; i++) e = fmax(e, fabs(g1[i] - g2[i]) / m);
    printf("common-net auto vs naive, no input gradient: param grads max relative difference %.2e%s\n", e, e > 1e-4 ? "  FAIL" : "");
    if (e > 1e-4) test_failures++;
    free(p), free(g1), free(g2), free(x), free(o1), free(o2), free(dout), free(dbn), free(dx1), free(dx2);
    hd_unet_free(fast);
    hd_unet_free(ref);
}

int main(void)
{
    /* one thread: thousands of tiny layers, where a shared machine makes every parallel region
     * wait (test_conv exercises the threaded loops) */
    omp_set_num_threads(1);
    hd_rng_seed(&rng, 1234, 1);
    static const struct { int B, C, H, W, OC, stride; hd_act act; } convs[] = {
        {2, 3, 7, 9, 5, 1, HD_ACT_NONE}, {2, 3, 7, 9, 5, 1, HD_ACT_LRELU}, {2, 5, 9, 12, 3, 2, HD_ACT_LRELU},
        {3, 1, 12, 7, 3, 2, HD_ACT_NONE}, {2, 5, 7, 9, 1, 1, HD_ACT_LRELU},
    };
    for (int path = 0; path < 3; path++)
        for (size_t k = 0; k < sizeof convs / sizeof convs[0]; k++) {
            fd_case c = {0};
            setup_conv(&c, convs[k].B, convs[k].C, convs[k].H, convs[k].W, convs[k].OC, convs[k].stride,
                       convs[k].act, (hd_conv_path)path);
            c.floor = 1e-3, c.tol = 1e-2;
            run_case(&c);
            free_case(&c);
        }
    void (*setups[])(fd_case *) = {setup_l2, setup_maxpool, setup_upsample, setup_concat, setup_meanpool,
                                   setup_linear, setup_instnorm};
    for (size_t k = 0; k < sizeof setups / sizeof setups[0]; k++) {
        fd_case c = {0};
        setups[k](&c);
        c.floor = 1e-3, c.tol = 1e-2;
        run_case(&c);
        free_case(&c);
    }
    static const char *el[] = {"lrelu", "sigmoid", "softplus", "tanh"};
    for (int k = 0; k < 4; k++) {
        fd_case c = {0};
        setup_elem(&c, k, el[k]);
        c.floor = 1e-3, c.tol = 1e-2;
        run_case(&c);
        free_case(&c);
    }
    static const char *ls[] = {"l1 masked", "sqdist masked", "bce target 1", "bce target 0", "smooth masked"};
    for (int k = 0; k < 5; k++) {
        fd_case c = {0};
        setup_loss(&c, k, ls[k]);
        c.floor = 1e-3, c.tol = 1e-2;
        run_case(&c);
        free_case(&c);
    }
    test_net_layouts();
    /* the whole net through the fastest path (the naive net is held against it above) */
    {
        fd_case c = {0};
        setup_net(&c, HD_CONV_AUTO);
        run_case(&c);
        free_case(&c);
    }
    return test_summary("test_nn");
}
