/* test_model.c: the network alone (src/model): parameter counts of SPEC section 3, and the fast
 * path (oneDNN, the blocked layout) against the naive one in every output and gradient. Training
 * is tests/test_train.c. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "test.h"
#include "core/core.h"
#include "model/disc.h"
#include "model/hdnet_net.h"
#include "train/trainer.h" /* hd_train_init_params: the starting weights */

/* ---- parameter counts */

static void test_param_counts(void)
{
    hd_net_config cfg = {48, 256};
    hd_param_table t, d;
    hd_net_param_table(&cfg, &t);
    hd_disc_param_table(&d);
    CHECK(t.total == 3095600);
    CHECK(d.total == 1555585);
    if (t.total != 3095600) fprintf(stderr, "HD-Net has %zu parameters\n", t.total);
    CHECK(strcmp(t.p[0].name, "conv_in.weight") == 0 && t.p[0].shape[0] == 32 && t.p[0].shape[1] == 3);
    CHECK(strcmp(t.p[t.count - 1].name, "l_net.fc.bias") == 0);
    CHECK(hd_param_find(&t, "a_net.enc0.weight") == 2);
    CHECK(hd_param_find(&t, "n_net.dec1c.weight") > hd_param_find(&t, "s_net.dec1c.weight"));
    int fc = hd_param_find(&t, "l_net.fc.weight");
    CHECK(fc > 0 && t.p[fc].ndim == 2 && t.p[fc].shape[0] == 9 && t.p[fc].shape[1] == 64);
    int c1 = hd_param_find(&t, "l_net.conv1.weight");
    CHECK(c1 > 0 && t.p[c1].shape[0] == 64 && t.p[c1].shape[1] == 48);
    CHECK(strcmp(d.p[0].name, "disc.c1.weight") == 0 && strcmp(d.p[d.count - 1].name, "disc.out.bias") == 0);
    /* offsets tile the arena */
    size_t off = 0;
    for (int i = 0; i < t.count; i++) {
        CHECK(t.p[i].offset == off);
        off += t.p[i].count;
    }
    CHECK(off == t.total);
}

/* ---- the fast path (oneDNN, Common-Nets in the blocked layout at a width that is a multiple of
 * 16, N-Net's 1-channel input read through zero-padded enc0 weights) against the naive one:
 * every output, every parameter gradient of HD-Net and of the discriminator, and the
 * discriminator's input gradient. A profiled pass computes exactly the same. */

static double max_rel_diff(const float *a, const float *b, size_t n)
{
    double m = 1e-12, d = 0;
    for (size_t i = 0; i < n; i++) m = fmax(m, fabs(b[i]));
    for (size_t i = 0; i < n; i++) d = fmax(d, fabs(a[i] - b[i]));
    return d / m;
}

static void test_paths(void)
{
    enum { B = 2, S = 32 };
    hd_net_config cfg = {16, S};
    hd_net fast, ref;
    hd_disc fast_d, ref_d;
    if (hd_net_create(&fast, &cfg, B, HD_NET_TRAIN, HD_CONV_AUTO) != HD_OK ||
        hd_net_create(&ref, &cfg, B, HD_NET_TRAIN, HD_CONV_NAIVE) != HD_OK ||
        hd_disc_create(&fast_d, B, S, HD_CONV_AUTO) != HD_OK || hd_disc_create(&ref_d, B, S, HD_CONV_NAIVE) != HD_OK) {
        fprintf(stderr, "net: %s\n", hd_error());
        test_failures++;
        return;
    }
    hd_train_init_params(&cfg, 5, fast.params, fast_d.params);
    /* biases of +-(0.5 .. 1.5) keep pre-activations away from the leaky ReLU kink, where the two
     * paths' rounding could pick different slopes */
    hd_rng rng;
    hd_rng_seed(&rng, 77, 1);
    for (int i = 0; i < fast.table.count; i++) {
        const hd_param *p = &fast.table.p[i];
        if (!strstr(p->name, ".bias")) continue;
        for (size_t k = 0; k < p->count; k++)
            fast.params[p->offset + k] = (hd_rng_below(&rng, 2) ? 1.0f : -1.0f) * hd_rng_range(&rng, 0.5f, 1.5f);
    }
    memcpy(ref.params, fast.params, fast.table.total * sizeof(float));
    memcpy(ref_d.params, fast_d.params, fast_d.table.total * sizeof(float));
    size_t HW = (size_t)S * S;
    for (size_t i = 0; i < B * 3 * HW; i++) fast.input[i] = ref.input[i] = hd_rng_range(&rng, 0.0f, 1.0f);

    hd_net *nets[2] = {&fast, &ref};
    hd_disc *discs[2] = {&fast_d, &ref_d};
    for (int k = 0; k < 2; k++) {
        hd_net *n = nets[k];
        hd_disc *D = discs[k];
        hd_net_forward(n, NULL);
        hd_net_zero_grad(n);
        hd_rng g;
        hd_rng_seed(&g, 78, 1); /* the same output gradients for both */
        for (size_t i = 0; i < B * 3 * HW; i++) n->d_albedo[i] = hd_rng_range(&g, -1.0f, 1.0f);
        for (size_t i = 0; i < B * HW; i++) n->d_shading[i] = hd_rng_range(&g, -1.0f, 1.0f);
        for (size_t i = 0; i < B * 3 * HW; i++) n->d_normal[i] = hd_rng_range(&g, -1.0f, 1.0f);
        for (size_t i = 0; i < B * HD_SH_COEFFS; i++) n->d_light[i] = hd_rng_range(&g, -1.0f, 1.0f);
        hd_net_backward(n, HD_TRAIN_ALL, NULL);
        /* the discriminator on the albedo */
        memcpy(D->in, n->albedo, B * 3 * HW * sizeof(float));
        hd_disc_forward(D, NULL);
        size_t np = (size_t)B * hd_disc_patches(D);
        for (size_t i = 0; i < np; i++) D->d_logit[i] = hd_rng_range(&g, -1.0f, 1.0f);
        memset(D->d_in, 0, B * 3 * HW * sizeof(float));
        memset(D->grads, 0, D->table.total * sizeof(float));
        hd_disc_backward(D, 1, 1, NULL);
    }
    struct { const char *name; const float *a, *b; size_t n; } cmp[] = {
        {"albedo", fast.albedo, ref.albedo, B * 3 * HW},
        {"shading", fast.shading, ref.shading, B * HW},
        {"normal", fast.normal, ref.normal, B * 3 * HW},
        {"light", fast.light, ref.light, B * HD_SH_COEFFS},
        {"HD-Net gradients", fast.grads, ref.grads, fast.table.total},
        {"discriminator logits", fast_d.logit, ref_d.logit, (size_t)B * hd_disc_patches(&fast_d)},
        {"discriminator gradients", fast_d.grads, ref_d.grads, fast_d.table.total},
        {"discriminator input gradient", fast_d.d_in, ref_d.d_in, B * 3 * HW},
    };
    for (size_t k = 0; k < sizeof cmp / sizeof cmp[0]; k++) {
        double d = max_rel_diff(cmp[k].a, cmp[k].b, cmp[k].n);
        double tol = k < 5 ? 1e-4 : 1e-3; /* instance normalisation amplifies the rounding */
        printf("HD-Net fast vs naive path, w16 %dx%d batch %d: %-28s max relative difference %.2e%s\n", S, S, B,
               cmp[k].name, d, d <= tol ? "" : "  FAIL");
        if (!(d <= tol)) test_failures++;
    }
    /* and tensor by tensor, each against its own largest value (a small tensor's error would
     * hide under the largest gradient of the net), naming the worst. The encoders' weight
     * gradients sum many terms that cancel: float rounding reaches 1e-4 of their largest value
     * there (the naive path sums in double), a wrong gradient differs by its own size. */
    double worst = 0;
    int worst_i = 0;
    for (int i = 0; i < fast.table.count; i++) {
        const hd_param *p = &fast.table.p[i];
        double d = max_rel_diff(fast.grads + p->offset, ref.grads + p->offset, p->count);
        if (d > worst) worst = d, worst_i = i;
    }
    printf("HD-Net fast vs naive path, w16 %dx%d batch %d: worst gradient tensor %-15s max relative difference %.2e%s\n",
           S, S, B, fast.table.p[worst_i].name, worst, worst <= 1e-3 ? "" : "  FAIL");
    if (!(worst <= 1e-3)) test_failures++;

    /* profiling: the same results bit for bit, and stage times that add up to at most the pass */
    size_t nout = B * 3 * HW;
    float *keep = malloc(nout * sizeof(float));
    memcpy(keep, fast.normal, nout * sizeof(float));
    hd_net_profile prof;
    memset(&prof, 0, sizeof prof);
    hd_net_pass profiled = {.profile = &prof};
    double t0 = hd_seconds();
    hd_net_forward(&fast, &profiled);
    double dt = hd_seconds() - t0;
    CHECK(memcmp(keep, fast.normal, nout * sizeof(float)) == 0);
    double sum = 0;
    for (int k = 0; k < HD_NET_STAGES; k++) {
        CHECK(prof.fwd[k] >= 0.0 && prof.bwd[k] == 0.0);
        sum += prof.fwd[k];
    }
    CHECK(sum > 0.0 && sum <= dt + 1e-6);
    CHECK(prof.fwd[HD_STAGE_N_NET] > 0.0 && prof.fwd[HD_STAGE_DISC] == 0.0);
    free(keep);
    hd_net_free(&fast);
    hd_net_free(&ref);
    hd_disc_free(&fast_d);
    hd_disc_free(&ref_d);
}

int main(void)
{
    hd_set_threads(1); /* tiny shapes: threads only add overhead */
    test_param_counts();
    test_paths();
    return test_summary("test_model");
}
