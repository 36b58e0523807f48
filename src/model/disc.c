/* disc.c: the PatchGAN discriminator (SPEC section 3; disc.h), training only: its parameter table
 * in the checkpoint's order, its run state, and its forward and backward passes over one block of
 * activations made at creation. c1 = lrelu_0.2(conv(x)), c2..c4 = lrelu_0.2(instnorm(conv(prev))),
 * each a stride-2 3x3 convolution, then one stride-1 convolution to a logit per patch. */
#include <stdlib.h>
#include <string.h>
#include "model/disc.h"

#define HD_DISC_LRELU 0.2f
#define HD_INSTNORM_EPS 1e-5f

static const int disc_channels[5] = {3, 64, 128, 256, 512};

void hd_disc_param_table(hd_param_table *t)
{
    memset(t, 0, sizeof *t);
    static const char *const names[5] = {"disc.c1", "disc.c2", "disc.c3", "disc.c4", "disc.out"};
    for (int k = 0; k < 4; k++) hd_param_table_conv(t, names[k], disc_channels[k], disc_channels[k + 1]);
    hd_param_table_conv(t, names[4], 512, 1);
}

static void layout(hd_disc *d, hd_carver *c)
{
    size_t B = (size_t)d->B, HW = (size_t)d->H * d->W;
    d->in = hd_carve(c, B * 3 * HW);
    d->d_in = hd_carve(c, B * 3 * HW);
    size_t n1 = B * 64 * (size_t)d->Hd[0] * d->Wd[0];
    d->h1 = hd_carve(c, n1);
    d->d_h1 = hd_carve(c, n1);
    for (int k = 0; k < 3; k++) {
        size_t C = (size_t)disc_channels[k + 2], n = B * C * d->Hd[k + 1] * d->Wd[k + 1];
        d->pre[k] = hd_carve(c, n);
        d->norm[k] = hd_carve(c, n);
        d->act[k] = hd_carve(c, n);
        d->d_pre[k] = hd_carve(c, n);
        d->d_norm[k] = hd_carve(c, n);
        d->d_act[k] = hd_carve(c, n);
        d->mean[k] = hd_carve(c, B * C);
        d->rstd[k] = hd_carve(c, B * C);
    }
    d->logit = hd_carve(c, B * (size_t)d->Hp * d->Wp);
    d->d_logit = hd_carve(c, B * (size_t)d->Hp * d->Wp);
}

hd_status hd_disc_create(hd_disc *d, int B, int size, hd_conv_path path)
{
    memset(d, 0, sizeof *d);
    if (B < 1 || B > 4096) return hd_fail(HD_ERR_RANGE, "batch of %d images is out of range", B);
    if (size < 32 || size > 4096 || size % 32)
        return hd_fail(HD_ERR_RANGE, "model size %d is not a multiple of 32 in 32..4096", size);
    d->B = B;
    d->H = d->W = size;
    hd_disc_param_table(&d->table);
    hd_status st = HD_OK;
    hd_conv3x3 **plans[4] = {&d->c1, &d->c2, &d->c3, &d->c4};
    int h = size, w = size;
    for (int k = 0; k < 4 && st == HD_OK; k++) {
        st = hd_conv3x3_plan(plans[k], B, disc_channels[k], h, w, disc_channels[k + 1], 2,
                             k == 0 ? HD_ACT_LRELU : HD_ACT_NONE, HD_DISC_LRELU, path);
        if (st == HD_OK) {
            h = d->Hd[k] = hd_conv3x3_out_h(*plans[k]);
            w = d->Wd[k] = hd_conv3x3_out_w(*plans[k]);
        }
    }
    if (st == HD_OK) st = hd_conv3x3_plan(&d->out, B, 512, h, w, 1, 1, HD_ACT_NONE, 0.0f, path);
    if (st != HD_OK) {
        hd_disc_free(d);
        return st;
    }
    d->Hp = hd_conv3x3_out_h(d->out);
    d->Wp = hd_conv3x3_out_w(d->out);
    hd_carver c = {NULL, 0};
    layout(d, &c);
    d->act_floats = c.used;
    d->act_mem = hd_calloc(c.used, sizeof(float));
    d->params = hd_calloc(d->table.total, sizeof(float));
    d->grads = hd_calloc(d->table.total, sizeof(float));
    if (!d->act_mem || !d->params || !d->grads) {
        hd_disc_free(d);
        return HD_ERR_NOMEM;
    }
    c.base = d->act_mem;
    c.used = 0;
    layout(d, &c);
    return HD_OK;
}

void hd_disc_free(hd_disc *d)
{
    if (!d) return;
    hd_conv3x3 *plans[] = {d->c1, d->c2, d->c3, d->c4, d->out};
    for (size_t i = 0; i < sizeof plans / sizeof plans[0]; i++) hd_conv3x3_free(plans[i]);
    free(d->act_mem);
    free(d->params);
    free(d->grads);
    memset(d, 0, sizeof *d);
}

int hd_disc_patches(const hd_disc *d) { return d->Hp * d->Wp; }

#define DP(name) hd_param_of(&d->table, d->params, name)
#define DG(name) (want_params ? hd_param_of(&d->table, d->grads, name) : NULL)

void hd_disc_forward(hd_disc *d, hd_net_profile *profile)
{
    static const char *const wn[3] = {"disc.c2.weight", "disc.c3.weight", "disc.c4.weight"};
    static const char *const bn[3] = {"disc.c2.bias", "disc.c3.bias", "disc.c4.bias"};
    hd_conv3x3 *plans[3] = {d->c2, d->c3, d->c4};
    hd_net_stage_clock t = hd_net_stage_start(profile);
    /* c1: lrelu_0.2(conv(x)) */
    hd_conv3x3_forward(d->c1, d->h1, d->in, DP("disc.c1.weight"), DP("disc.c1.bias"));
    const float *prev = d->h1;
    for (int k = 0; k < 3; k++) {
        int C = disc_channels[k + 2], hw = d->Hd[k + 1] * d->Wd[k + 1];
        /* ck: lrelu_0.2(instnorm(conv(prev))) */
        hd_conv3x3_forward(plans[k], d->pre[k], prev, DP(wn[k]), DP(bn[k]));
        hd_instnorm_forward(d->norm[k], d->mean[k], d->rstd[k], d->pre[k], d->B, C, hw, HD_INSTNORM_EPS);
        hd_lrelu_forward(d->act[k], d->norm[k], (size_t)d->B * C * hw, HD_DISC_LRELU);
        prev = d->act[k];
    }
    hd_conv3x3_forward(d->out, d->logit, prev, DP("disc.out.weight"), DP("disc.out.bias"));
    hd_net_stage_lap(profile, 0, HD_STAGE_DISC, &t);
}

void hd_disc_backward(hd_disc *d, int want_input, int want_params, hd_net_profile *profile)
{
    static const char *const wn[3] = {"disc.c2.weight", "disc.c3.weight", "disc.c4.weight"};
    static const char *const bn[3] = {"disc.c2.bias", "disc.c3.bias", "disc.c4.bias"};
    hd_conv3x3 *plans[3] = {d->c2, d->c3, d->c4};
    size_t B = (size_t)d->B;
    hd_net_stage_clock t = hd_net_stage_start(profile);
    memset(d->d_h1, 0, B * 64 * (size_t)d->Hd[0] * d->Wd[0] * sizeof(float));
    for (int k = 0; k < 3; k++) {
        size_t n = B * (size_t)disc_channels[k + 2] * d->Hd[k + 1] * d->Wd[k + 1] * sizeof(float);
        memset(d->d_pre[k], 0, n);
        memset(d->d_norm[k], 0, n);
        memset(d->d_act[k], 0, n);
    }
    /* forward: logit = conv(act3) */
    hd_conv3x3_backward(d->out, d->d_act[2], DG("disc.out.weight"), DG("disc.out.bias"), d->d_logit, d->logit,
                        d->act[2], DP("disc.out.weight"));
    for (int k = 2; k >= 0; k--) {
        int C = disc_channels[k + 2], hw = d->Hd[k + 1] * d->Wd[k + 1];
        /* forward: act = lrelu_0.2(norm), norm = instnorm(pre), pre = conv(prev) */
        hd_lrelu_backward(d->d_norm[k], d->d_act[k], d->norm[k], B * C * hw, HD_DISC_LRELU);
        hd_instnorm_backward(d->d_pre[k], d->d_norm[k], d->norm[k], d->rstd[k], d->B, C, hw);
        float *gprev = k ? d->d_act[k - 1] : d->d_h1;
        const float *prev = k ? d->act[k - 1] : d->h1;
        hd_conv3x3_backward(plans[k], gprev, DG(wn[k]), DG(bn[k]), d->d_pre[k], d->pre[k], prev, DP(wn[k]));
    }
    /* forward: c1 = lrelu_0.2(conv(x)) */
    hd_conv3x3_backward(d->c1, want_input ? d->d_in : NULL, DG("disc.c1.weight"), DG("disc.c1.bias"), d->d_h1, d->h1,
                        d->in, DP("disc.c1.weight"));
    hd_net_stage_lap(profile, 1, HD_STAGE_DISC, &t);
}
