/* hdnet_net.c: HD-Net (SPEC section 3): parameter tables in the checkpoint's order,
 * initialisation, the stage clock the profile reads, and the forward and backward passes over one
 * block of activations made at creation. Layers come from src/nn (conv, activations, pooling) and
 * Common-Net from src/model/unet; the discriminator is disc.c's. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "model/hdnet_net.h"

#define HD_NORMAL_EPS 1e-6f
#define HD_LRELU 0.1f

const char *const hd_net_stage_names[HD_NET_STAGES] = {"conv_in", "a_net", "s_net", "n_net", "l_net", "heads", "disc"};

/* The benchmarks' profiler (core.h, hd_prof_*) gets the same laps as phases of the same names. */
static const char *const stage_bwd_names[HD_NET_STAGES] = {"conv_in bwd", "a_net bwd", "s_net bwd", "n_net bwd",
                                                           "l_net bwd",   "heads bwd", "disc bwd"};

hd_net_stage_clock hd_net_stage_start(const hd_net_profile *profile)
{
    hd_net_stage_clock c = {profile ? hd_seconds() : 0.0, hd_prof_now()};
    return c;
}

void hd_net_stage_lap(hd_net_profile *profile, int bwd, hd_net_stage k, hd_net_stage_clock *c)
{
    hd_prof_lap(bwd ? stage_bwd_names[k] : hd_net_stage_names[k], &c->m);
    if (!profile) return;
    double now = hd_seconds();
    (bwd ? profile->bwd : profile->fwd)[k] += now - c->t;
    c->t = now;
}

/* ---------------------------------------------------------------- parameter tables */

static void table_add(hd_param_table *t, const char *name, int ndim, int64_t d0, int64_t d1, int64_t d2, int64_t d3)
{
    hd_param *p = &t->p[t->count++];
    memset(p, 0, sizeof *p);
    snprintf(p->name, sizeof p->name, "%s", name);
    p->ndim = ndim;
    int64_t d[4] = {d0, d1, d2, d3};
    p->count = 1;
    for (int i = 0; i < ndim; i++) {
        p->shape[i] = d[i];
        p->count *= (size_t)d[i];
    }
    p->offset = t->total;
    t->total += p->count;
}

void hd_param_table_conv(hd_param_table *t, const char *prefix, int cin, int cout)
{
    char name[64];
    snprintf(name, sizeof name, "%s.weight", prefix);
    table_add(t, name, 4, cout, cin, 3, 3);
    snprintf(name, sizeof name, "%s.bias", prefix);
    table_add(t, name, 1, cout, 0, 0, 0);
}

static void table_unet(hd_param_table *t, const char *prefix, int cin, int cout, int width)
{
    hd_unet_params(prefix, cin, cout, width, t->p, &t->count, &t->total);
}

void hd_net_param_table(const hd_net_config *cfg, hd_param_table *t)
{
    memset(t, 0, sizeof *t);
    int w = cfg->width;
    hd_param_table_conv(t, "conv_in", 3, HD_FEAT);
    table_unet(t, "a_net", HD_FEAT, 3, w);
    table_unet(t, "s_net", HD_FEAT, 1, w);
    table_unet(t, "n_net", 1, 3, w);
    hd_param_table_conv(t, "l_net.conv1", w, HD_LNET_HIDDEN);
    hd_param_table_conv(t, "l_net.conv2", HD_LNET_HIDDEN, HD_LNET_HIDDEN);
    table_add(t, "l_net.fc.weight", 2, HD_SH_COEFFS, HD_LNET_HIDDEN, 0, 0);
    table_add(t, "l_net.fc.bias", 1, HD_SH_COEFFS, 0, 0, 0);
}

int hd_param_find(const hd_param_table *t, const char *name)
{
    for (int i = 0; i < t->count; i++)
        if (strcmp(t->p[i].name, name) == 0) return i;
    return -1;
}

/* Every ".weight" is followed by its ".bias" in our tables; fan_in = product of the weight's
 * dimensions after the first (IC*3*3 for a convolution, IN for a linear layer). */
void hd_params_init(const hd_param_table *t, float *params, hd_rng *rng)
{
    for (int i = 0; i < t->count; i++) {
        const hd_param *w = &t->p[i];
        size_t len = strlen(w->name);
        if (len < 7 || strcmp(w->name + len - 7, ".weight") != 0) continue;
        const hd_param *b = i + 1 < t->count ? &t->p[i + 1] : NULL;
        int fan_in = 1;
        for (int d = 1; d < w->ndim; d++) fan_in *= (int)w->shape[d];
        hd_init_uniform_fan_in(params + w->offset, w->count, b ? params + b->offset : NULL, b ? b->count : 0,
                               fan_in, rng);
    }
}

hd_status hd_net_config_check(const hd_net_config *cfg)
{
    if (cfg->width < 1 || cfg->width > 1024)
        return hd_fail(HD_ERR_RANGE, "model width %d is out of range (1..1024)", cfg->width);
    if (cfg->size < 32 || cfg->size > 4096 || cfg->size % 32)
        return hd_fail(HD_ERR_RANGE, "model size %d is not a multiple of 32 in 32..4096", cfg->size);
    return HD_OK;
}

double hd_net_macs(const hd_net_config *cfg)
{
    double hw = (double)cfg->size * cfg->size, w = cfg->width;
    double m = 9.0 * 3 * HD_FEAT * hw;
    m += hd_unet_macs(HD_FEAT, 3, cfg->width, cfg->size, cfg->size);
    m += hd_unet_macs(HD_FEAT, 1, cfg->width, cfg->size, cfg->size);
    m += hd_unet_macs(1, 3, cfg->width, cfg->size, cfg->size);
    double hb = cfg->size / 32.0, h1 = (hb + 1) / 2 > 1 ? (int)((hb + 1) / 2) : 1, h2 = (int)((h1 + 1) / 2);
    m += 9.0 * w * HD_LNET_HIDDEN * h1 * h1 + 9.0 * HD_LNET_HIDDEN * HD_LNET_HIDDEN * h2 * h2;
    m += (double)HD_LNET_HIDDEN * HD_SH_COEFFS;
    return m;
}

/* ---------------------------------------------------------------- creation */

static void layout(hd_net *net, hd_carver *c)
{
    size_t B = (size_t)net->B, HW = (size_t)net->H * net->W;
    int train = net->mode == HD_NET_TRAIN;
    net->input = hd_carve(c, B * 3 * HW);
    net->feat = hd_carve(c, B * HD_FEAT * HW);
    net->a_logit = hd_carve(c, B * 3 * HW);
    net->albedo = hd_carve(c, B * 3 * HW);
    net->s_logit = hd_carve(c, B * HW);
    net->shading = hd_carve(c, B * HW);
    net->n_logit = hd_carve(c, B * 3 * HW);
    net->n_tanh = hd_carve(c, B * 3 * HW);
    net->normal = hd_carve(c, B * 3 * HW);
    size_t n1 = B * HD_LNET_HIDDEN * (size_t)net->H1 * net->W1, n2 = B * HD_LNET_HIDDEN * (size_t)net->H2 * net->W2;
    net->l_h1 = hd_carve(c, n1);
    net->l_h2 = hd_carve(c, n2);
    net->l_pool = hd_carve(c, B * HD_LNET_HIDDEN);
    net->light = hd_carve(c, B * HD_SH_COEFFS);
    if (!train) return;
    net->d_feat = hd_carve(c, B * HD_FEAT * HW);
    net->d_a_logit = hd_carve(c, B * 3 * HW);
    net->d_albedo = hd_carve(c, B * 3 * HW);
    net->d_s_logit = hd_carve(c, B * HW);
    net->d_shading = hd_carve(c, B * HW);
    net->d_n_logit = hd_carve(c, B * 3 * HW);
    net->d_n_tanh = hd_carve(c, B * 3 * HW);
    net->d_normal = hd_carve(c, B * 3 * HW);
    net->d_bottleneck = hd_carve(c, B * (size_t)net->cfg.width * net->Hb * net->Wb);
    net->d_l_h1 = hd_carve(c, n1);
    net->d_l_h2 = hd_carve(c, n2);
    net->d_l_pool = hd_carve(c, B * HD_LNET_HIDDEN);
    net->d_light = hd_carve(c, B * HD_SH_COEFFS);
}

/* weights NULL: the net owns zeroed parameters; else it reads the caller's (inference only). */
static hd_status net_create(hd_net *net, const hd_net_config *cfg, int B, hd_net_mode mode, hd_conv_path path,
                            const float *weights)
{
    memset(net, 0, sizeof *net);
    hd_status st = hd_net_config_check(cfg);
    if (st != HD_OK) return st;
    if (B < 1 || B > 4096) return hd_fail(HD_ERR_RANGE, "batch of %d images is out of range", B);
    net->cfg = *cfg;
    net->mode = mode;
    net->B = B;
    net->H = net->W = cfg->size;
    int w = cfg->width, H = cfg->size;
    hd_net_param_table(cfg, &net->table);
    net->off_a = net->table.p[hd_param_find(&net->table, "a_net.enc0.weight")].offset;
    net->off_s = net->table.p[hd_param_find(&net->table, "s_net.enc0.weight")].offset;
    net->off_n = net->table.p[hd_param_find(&net->table, "n_net.enc0.weight")].offset;
    net->Hb = net->Wb = H / 32;

#define TRY(x) do { if ((st = (x)) != HD_OK) goto fail; } while (0)
    TRY(hd_conv3x3_plan(&net->conv_in, B, 3, H, H, HD_FEAT, 1, HD_ACT_NONE, 0.0f, path));
    TRY(hd_unet_create(&net->a_net, HD_FEAT, 3, w, B, H, H, path));
    TRY(hd_unet_create(&net->s_net, HD_FEAT, 1, w, B, H, H, path));
    TRY(hd_unet_create(&net->n_net, 1, 3, w, B, H, H, path));
    TRY(hd_conv3x3_plan(&net->l_conv1, B, w, net->Hb, net->Wb, HD_LNET_HIDDEN, 2, HD_ACT_LRELU, HD_LRELU, path));
    net->H1 = hd_conv3x3_out_h(net->l_conv1);
    net->W1 = hd_conv3x3_out_w(net->l_conv1);
    TRY(hd_conv3x3_plan(&net->l_conv2, B, HD_LNET_HIDDEN, net->H1, net->W1, HD_LNET_HIDDEN, 2, HD_ACT_LRELU,
                        HD_LRELU, path));
    net->H2 = hd_conv3x3_out_h(net->l_conv2);
    net->W2 = hd_conv3x3_out_w(net->l_conv2);
#undef TRY

    hd_carver c = {NULL, 0};
    layout(net, &c);
    size_t bytes;
    if (!hd_mul_size(c.used, sizeof(float), &bytes)) {
        st = hd_fail(HD_ERR_NOMEM, "activations of a batch of %d at %d x %d do not fit in memory", B, H, H);
        goto fail;
    }
    net->act_floats = c.used;
    net->act_mem = hd_calloc(c.used, sizeof(float));
    net->weights_borrowed = weights != NULL;
    net->params = weights ? (float *)weights : hd_calloc(net->table.total, sizeof(float));
    if (!net->act_mem || !net->params) {
        st = HD_ERR_NOMEM;
        goto fail;
    }
    c.base = net->act_mem;
    c.used = 0;
    layout(net, &c);
    if (mode == HD_NET_TRAIN && !(net->grads = hd_calloc(net->table.total, sizeof(float)))) {
        st = HD_ERR_NOMEM;
        goto fail;
    }
    hd_unet_bind(net->a_net, net->params + net->off_a, net->grads ? net->grads + net->off_a : NULL);
    hd_unet_bind(net->s_net, net->params + net->off_s, net->grads ? net->grads + net->off_s : NULL);
    hd_unet_bind(net->n_net, net->params + net->off_n, net->grads ? net->grads + net->off_n : NULL);
    return HD_OK;
fail:
    hd_net_free(net);
    return st;
}

hd_status hd_net_create(hd_net *net, const hd_net_config *cfg, int B, hd_net_mode mode, hd_conv_path path)
{
    return net_create(net, cfg, B, mode, path, NULL);
}

hd_status hd_net_create_run(hd_net *net, const hd_net_config *cfg, int B, hd_conv_path path, const float *weights)
{
    if (!weights) return hd_fail(HD_ERR_ARG, "hd_net_create_run: no weights");
    return net_create(net, cfg, B, HD_NET_INFER, path, weights);
}

void hd_net_free(hd_net *net)
{
    if (!net) return;
    hd_unet_free(net->a_net);
    hd_unet_free(net->s_net);
    hd_unet_free(net->n_net);
    hd_conv3x3 *plans[] = {net->conv_in, net->l_conv1, net->l_conv2};
    for (size_t i = 0; i < sizeof plans / sizeof plans[0]; i++) hd_conv3x3_free(plans[i]);
    free(net->act_mem);
    if (!net->weights_borrowed) free(net->params);
    free(net->grads);
    memset(net, 0, sizeof *net);
}

/* ---------------------------------------------------------------- HD-Net forward / backward */

float *hd_param_of(const hd_param_table *t, float *base, const char *name)
{
    int i = hd_param_find(t, name);
    return i < 0 ? NULL : base + t->p[i].offset;
}

#define P(name) hd_param_of(&net->table, net->params, name)
#define G(name) hd_param_of(&net->table, net->grads, name)

void hd_net_forward(hd_net *net, const hd_net_pass *pass)
{
    hd_net_profile *prof = pass ? pass->profile : NULL;
    const float *held = pass ? pass->n_input_hold : NULL;
    size_t B = (size_t)net->B, HW = (size_t)net->H * net->W;
    hd_net_stage_clock t = hd_net_stage_start(prof);
    /* f = conv_in(I) */
    hd_conv3x3_forward(net->conv_in, net->feat, net->input, P("conv_in.weight"), P("conv_in.bias"));
    hd_net_stage_lap(prof, 0, HD_STAGE_CONV_IN, &t);
    /* A = sigmoid(a_net(f)) */
    hd_unet_forward(net->a_net, net->feat, net->a_logit);
    hd_net_stage_lap(prof, 0, HD_STAGE_A_NET, &t);
    hd_sigmoid_forward(net->albedo, net->a_logit, B * 3 * HW);
    hd_net_stage_lap(prof, 0, HD_STAGE_HEADS, &t);
    /* S = softplus(s_net(f)) */
    hd_unet_forward(net->s_net, net->feat, net->s_logit);
    hd_net_stage_lap(prof, 0, HD_STAGE_S_NET, &t);
    hd_softplus_forward(net->shading, net->s_logit, B * HW);
    hd_net_stage_lap(prof, 0, HD_STAGE_HEADS, &t);
    /* N = normalize(tanh(n_net(S))), S detached */
    hd_unet_forward(net->n_net, held ? held : net->shading, net->n_logit);
    hd_net_stage_lap(prof, 0, HD_STAGE_N_NET, &t);
    hd_tanh_forward(net->n_tanh, net->n_logit, B * 3 * HW);
    hd_l2norm3_forward(net->normal, net->n_tanh, net->B, (int)HW, HD_NORMAL_EPS);
    hd_net_stage_lap(prof, 0, HD_STAGE_HEADS, &t);
    /* l = fc(mean(lrelu(conv2(lrelu(conv1(bottleneck)))))) */
    const float *bott = hd_unet_bottleneck(net->n_net);
    hd_conv3x3_forward(net->l_conv1, net->l_h1, bott, P("l_net.conv1.weight"), P("l_net.conv1.bias"));
    hd_conv3x3_forward(net->l_conv2, net->l_h2, net->l_h1, P("l_net.conv2.weight"), P("l_net.conv2.bias"));
    hd_meanpool_forward(net->l_pool, net->l_h2, net->B, HD_LNET_HIDDEN, net->H2 * net->W2);
    hd_linear_forward(net->light, net->l_pool, P("l_net.fc.weight"), P("l_net.fc.bias"), net->B, HD_LNET_HIDDEN,
                      HD_SH_COEFFS);
    hd_net_stage_lap(prof, 0, HD_STAGE_L_NET, &t);
}

void hd_net_zero_grad(hd_net *net)
{
    memset(net->grads, 0, net->table.total * sizeof(float));
    hd_net_zero_act_grad(net);
}

void hd_net_zero_act_grad(hd_net *net)
{
    size_t B = (size_t)net->B, HW = (size_t)net->H * net->W;
    memset(net->d_albedo, 0, B * 3 * HW * sizeof(float));
    memset(net->d_shading, 0, B * HW * sizeof(float));
    memset(net->d_normal, 0, B * 3 * HW * sizeof(float));
    memset(net->d_light, 0, B * HD_SH_COEFFS * sizeof(float));
}

void hd_net_backward(hd_net *net, hd_net_train_set set, const hd_net_pass *pass)
{
    hd_net_profile *prof = pass ? pass->profile : NULL;
    size_t B = (size_t)net->B, HW = (size_t)net->H * net->W;
    size_t n1 = B * HD_LNET_HIDDEN * (size_t)net->H1 * net->W1, n2 = B * HD_LNET_HIDDEN * (size_t)net->H2 * net->W2;
    size_t nb = B * (size_t)net->cfg.width * net->Hb * net->Wb;
    int all = set == HD_TRAIN_ALL;
    hd_net_stage_clock t = hd_net_stage_start(prof);

    /* L-Net. forward: l = fc(pool); pool = mean(h2); h2 = lrelu(conv2(h1)); h1 = lrelu(conv1(bottleneck)) */
    memset(net->d_l_pool, 0, B * HD_LNET_HIDDEN * sizeof(float));
    memset(net->d_l_h2, 0, n2 * sizeof(float));
    memset(net->d_l_h1, 0, n1 * sizeof(float));
    memset(net->d_bottleneck, 0, nb * sizeof(float));
    hd_linear_backward(net->d_l_pool, G("l_net.fc.weight"), G("l_net.fc.bias"), net->d_light, net->l_pool,
                       P("l_net.fc.weight"), net->B, HD_LNET_HIDDEN, HD_SH_COEFFS);
    hd_meanpool_backward(net->d_l_h2, net->d_l_pool, net->B, HD_LNET_HIDDEN, net->H2 * net->W2);
    hd_conv3x3_backward(net->l_conv2, net->d_l_h1, G("l_net.conv2.weight"), G("l_net.conv2.bias"), net->d_l_h2,
                        net->l_h2, net->l_h1, P("l_net.conv2.weight"));
    hd_conv3x3_backward(net->l_conv1, all ? net->d_bottleneck : NULL, G("l_net.conv1.weight"), G("l_net.conv1.bias"),
                        net->d_l_h1, net->l_h1, hd_unet_bottleneck(net->n_net), P("l_net.conv1.weight"));
    hd_net_stage_lap(prof, 1, HD_STAGE_L_NET, &t);
    if (!all) return;

    /* N-Net. forward: N = t / max(|t|, eps), t = tanh(n_logit); its input S is detached (dinp NULL) */
    memset(net->d_n_tanh, 0, B * 3 * HW * sizeof(float));
    memset(net->d_n_logit, 0, B * 3 * HW * sizeof(float));
    hd_l2norm3_backward(net->d_n_tanh, net->d_normal, net->n_tanh, net->B, (int)HW, HD_NORMAL_EPS);
    hd_tanh_backward(net->d_n_logit, net->d_n_tanh, net->n_tanh, B * 3 * HW);
    hd_net_stage_lap(prof, 1, HD_STAGE_HEADS, &t);
    hd_unet_backward(net->n_net, net->d_n_logit, net->d_bottleneck, NULL);
    hd_net_stage_lap(prof, 1, HD_STAGE_N_NET, &t);

    /* ASD-Net. forward: A = sigmoid(a_logit), S = softplus(s_logit), both from f = conv_in(I) */
    memset(net->d_a_logit, 0, B * 3 * HW * sizeof(float));
    memset(net->d_s_logit, 0, B * HW * sizeof(float));
    memset(net->d_feat, 0, B * HD_FEAT * HW * sizeof(float));
    hd_sigmoid_backward(net->d_a_logit, net->d_albedo, net->albedo, B * 3 * HW);
    hd_softplus_backward(net->d_s_logit, net->d_shading, net->s_logit, B * HW);
    hd_net_stage_lap(prof, 1, HD_STAGE_HEADS, &t);
    hd_unet_backward(net->a_net, net->d_a_logit, NULL, net->d_feat);
    hd_net_stage_lap(prof, 1, HD_STAGE_A_NET, &t);
    hd_unet_backward(net->s_net, net->d_s_logit, NULL, net->d_feat);
    hd_net_stage_lap(prof, 1, HD_STAGE_S_NET, &t);
    hd_conv3x3_backward(net->conv_in, NULL, G("conv_in.weight"), G("conv_in.bias"), net->d_feat, net->feat,
                        net->input, P("conv_in.weight"));
    hd_net_stage_lap(prof, 1, HD_STAGE_CONV_IN, &t);
}
