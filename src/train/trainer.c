/* trainer.c: the HD-Net trainer. One step = forward, the seven losses, backward (SPEC section 4's
 * gradient paths), NaN checks, the generator's Adam, then the discriminator's loss and Adam, in
 * micro-batches that sum to the whole batch's gradient. The stages and their phases. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "train/trainer.h"

#define HD_INIT_STREAM 1

void hd_train_init_params(const hd_net_config *cfg, uint64_t seed, float *params, float *disc_params)
{
    hd_param_table t, d;
    hd_net_param_table(cfg, &t);
    hd_disc_param_table(&d);
    hd_rng rng;
    hd_rng_seed(&rng, seed, HD_INIT_STREAM);
    hd_params_init(&t, params, &rng);
    if (disc_params) hd_params_init(&d, disc_params, &rng);
}

hd_status hd_trainer_create(hd_trainer *t, const hd_net_config *cfg, int pairs, int micro, uint64_t seed)
{
    memset(t, 0, sizeof *t);
    if (pairs < 1 || pairs > HD_TRAIN_MAX_PAIRS)
        return hd_fail(HD_ERR_RANGE, "batch of %d pairs is out of range (1..%d)", pairs, HD_TRAIN_MAX_PAIRS);
    if (micro <= 0) micro = pairs;
    if (micro > pairs || pairs % micro)
        return hd_fail(HD_ERR_ARG, "a micro-batch of %d pairs does not divide the batch of %d pairs", micro, pairs);
    t->micro = micro;
    hd_status s = hd_net_create(&t->net, cfg, 2 * micro, HD_NET_TRAIN, HD_CONV_AUTO);
    if (s != HD_OK) return s;
    if ((s = hd_disc_create(&t->disc, 2 * micro, cfg->size, HD_CONV_AUTO)) != HD_OK ||
        (s = hd_losses_create(&t->losses, &t->net, &t->disc, &t->pass)) != HD_OK ||
        (s = hd_pair_batch_alloc(&t->batch, pairs, cfg->size)) != HD_OK)
        goto fail;
    t->adam_m = hd_calloc(t->net.table.total, sizeof(float));
    t->adam_v = hd_calloc(t->net.table.total, sizeof(float));
    t->disc_adam_m = hd_calloc(t->disc.table.total, sizeof(float));
    t->disc_adam_v = hd_calloc(t->disc.table.total, sizeof(float));
    t->grad_sum = hd_calloc(t->net.table.total + t->disc.table.total, sizeof(double));
    if (!t->adam_m || !t->adam_v || !t->disc_adam_m || !t->disc_adam_v || !t->grad_sum) {
        s = HD_ERR_NOMEM;
        goto fail;
    }
    t->lnet_offset = t->net.table.p[hd_param_find(&t->net.table, "l_net.conv1.weight")].offset;
    hd_loss_weights_preset(HD_TRAIN_DEFAULT_WEIGHTS, &t->weights);
    t->lr = HD_TRAIN_DEFAULT_LR_STAGE1;
    t->stage = HD_TRAIN_STAGE_1;
    t->seed = seed;
    hd_rng_seed(&t->rng, seed, HD_INIT_STREAM);
    hd_train_init_params(cfg, seed, t->net.params, t->disc.params);
    return HD_OK;
fail:
    hd_trainer_free(t);
    return s;
}

void hd_trainer_free(hd_trainer *t)
{
    hd_losses_free(&t->losses);
    hd_pair_batch_free(&t->batch);
    hd_net_free(&t->net);
    hd_disc_free(&t->disc);
    free(t->adam_m);
    free(t->adam_v);
    free(t->disc_adam_m);
    free(t->disc_adam_v);
    free(t->grad_sum);
    memset(t, 0, sizeof *t);
}

float hd_trainer_prior_ramp(const hd_trainer *t, long it)
{
    if (t->shading_prior_iters <= 0) return 1.0f;
    return it >= t->shading_prior_iters ? 0.0f : 1.0f - (float)it / (float)t->shading_prior_iters;
}

hd_train_phase hd_trainer_stage_phase(const hd_trainer *t, long it)
{
    if (t->stage != HD_TRAIN_STAGE_2) return HD_PHASE_1;
    return it < t->lnet_iters ? HD_PHASE_2A : HD_PHASE_2B;
}

const char *hd_train_phase_name(hd_train_phase phase)
{
    return phase == HD_PHASE_2A ? "2a" : phase == HD_PHASE_2B ? "2b" : "1";
}

hd_net_train_set hd_trainer_phase(const hd_trainer *t, long it)
{
    return hd_trainer_stage_phase(t, it) == HD_PHASE_2A ? HD_TRAIN_LNET : HD_TRAIN_ALL;
}

/* The view of micro-batch c of the trainer's batch. */
static hd_pair_batch chunk_of(const hd_trainer *t, int c)
{
    const hd_pair_batch *b = &t->batch;
    size_t first = (size_t)2 * c * t->micro, HW = (size_t)b->size * b->size;
    hd_pair_batch v = {t->micro, b->size, b->image + first * 3 * HW, b->mask + first * HW,
                       b->coarse_normal + first * 3 * HW, b->has_normal + first,
                       b->albedo_gt + first * 3 * HW, b->has_albedo + first,
                       b->light_gt + first * HD_SH_COEFFS, b->has_light + first, b->weight ? b->weight + first : NULL,
                       b->pair_light ? b->pair_light + (size_t)c * t->micro : NULL,
                       b->camera_gain ? b->camera_gain + first * 3 : NULL};
    return v;
}

void hd_trainer_share(const hd_trainer *t, int *first, int *count)
{
    int chunks = t->batch.pairs / t->micro, R = t->red.ranks > 1 ? t->red.ranks : 1, k = t->red.ranks > 1 ? t->red.rank : 0;
    *first = k * chunks / R * t->micro;
    *count = ((k + 1) * chunks / R - k * chunks / R) * t->micro;
}

/* Sums this rank's gradients (in double, t->grad_sum) and losses with every other rank's. */
static hd_status reduce_over_ranks(hd_trainer *t, hd_step_result *r, size_t n)
{
    const hd_reducer *red = &t->red;
    hd_status s = red->sum_doubles(red->ctx, t->grad_sum, n);
    if (s != HD_OK) return s;
    double v[HD_LOSS_TERMS + 2];
    memcpy(v, r->terms, sizeof r->terms);
    v[HD_LOSS_TERMS] = r->total;
    v[HD_LOSS_TERMS + 1] = r->disc;
    if ((s = red->sum_doubles(red->ctx, v, HD_LOSS_TERMS + 2)) != HD_OK) return s;
    memcpy(r->terms, v, sizeof r->terms);
    r->total = v[HD_LOSS_TERMS];
    r->disc = v[HD_LOSS_TERMS + 1];
    return HD_OK;
}

static void add_to(double *sum, const float *x, size_t n)
{
    for (size_t i = 0; i < n; i++) sum[i] += x[i];
}

hd_status hd_trainer_eval(hd_trainer *t, hd_step_result *r, hd_eval_what what)
{
    hd_net *net = &t->net;
    size_t n = (size_t)net->B * 3 * net->H * net->W;
    int grad = what & HD_EVAL_GRAD, chunks = t->batch.pairs / t->micro;
    int disc = what & (HD_EVAL_DISC | HD_EVAL_DISC_GRAD);
    /* a batch term is the mean over pairs = the mean over micro-batches of their means */
    float part = 1.0f / (float)chunks;
    hd_loss_weights w = t->weights;
    for (int k = 0; k < HD_LOSS_TERMS; k++) w.w[k] *= part;
    w.w[HD_LOSS_SHADING_PRIOR] *= hd_trainer_prior_ramp(t, t->iteration);
    memset(r, 0, sizeof *r);
    /* Each micro-batch's gradient is summed in double (grad_sum: HD-Net's, then the
     * discriminator's), so the float result does not depend on how the micro-batches were split
     * among ranks: the same --micro-batch gives the same weights on any number of ranks. */
    hd_disc *D = &t->disc;
    size_t ng = net->table.total, nd = D->table.total;
    int disc_grad = (what & HD_EVAL_DISC_GRAD) != 0;
    if (grad || disc_grad) memset(t->grad_sum, 0, (ng + nd) * sizeof(double));
    int first, count;
    hd_trainer_share(t, &first, &count);
    for (int c = first / t->micro; c < (first + count) / t->micro; c++) {
        if (grad) memset(net->grads, 0, ng * sizeof(float));
        if (disc_grad) memset(D->grads, 0, nd * sizeof(float));
        t->chunk = chunk_of(t, c);
        memcpy(net->input, t->chunk.image, n * sizeof(float));
        hd_prof_begin("forward"); /* phases of the benchmarks' profile (core.h) */
        hd_net_forward(net, &t->pass);
        hd_prof_end();
        hd_net_zero_act_grad(net);
        hd_prof_begin("loss targets");
        hd_status s = hd_losses_prepare(&t->losses, &t->chunk, t->stage == HD_TRAIN_STAGE_1 ? HD_LIGHT_FROM_COARSE : HD_LIGHT_FROM_PREDICTED);
        hd_prof_end();
        if (s != HD_OK) {
            char why[400];
            snprintf(why, sizeof why, "%s", hd_error());
            return hd_fail(s, "the losses' least-squares targets (l_hat, the shading prior) failed at iteration %ld: %s", t->iteration + 1, why);
        }
        double terms[HD_LOSS_TERMS];
        hd_prof_begin("losses");
        r->total += hd_losses_generator(&t->losses, &w, terms, grad);
        hd_prof_end();
        for (int k = 0; k < HD_LOSS_TERMS; k++) {
            if (!isfinite(terms[k]))
                return hd_fail(HD_ERR_NUMERIC, "loss term '%s' is %s at iteration %ld", hd_loss_names[k],
                               isnan(terms[k]) ? "NaN" : "infinite", t->iteration + 1);
            r->terms[k] += terms[k] * part;
        }
        if (grad) {
            hd_prof_begin("backward");
            hd_net_backward(net, hd_trainer_phase(t, t->iteration), &t->pass);
            hd_prof_end();
            hd_prof_begin("gradient sums");
            add_to(t->grad_sum, net->grads, ng);
            hd_prof_end();
        }
        if (!disc) continue;
        hd_prof_begin("discriminator update");
        double d = hd_loss_discriminator(&t->losses, disc_grad ? part : 0.0f);
        hd_prof_end();
        if (!isfinite(d))
            return hd_fail(HD_ERR_NUMERIC, "the discriminator's loss is %s at iteration %ld", isnan(d) ? "NaN" : "infinite",
                           t->iteration + 1);
        r->disc += d * part;
        if (disc_grad) add_to(t->grad_sum + ng, D->grads, nd);
    }
    if (t->red.ranks > 1) {
        hd_status s = reduce_over_ranks(t, r, ng + nd);
        if (s != HD_OK) return s;
    }
    hd_prof_begin("gradient sums");
    if (grad)
        for (size_t i = 0; i < ng; i++) net->grads[i] = (float)t->grad_sum[i];
    if (disc_grad)
        for (size_t i = 0; i < nd; i++) D->grads[i] = (float)t->grad_sum[ng + i];
    hd_prof_end();
    return HD_OK;
}

/* The first non-finite value of a table's flat array, or -1 (and its tensor in *which). */
static int check_finite(const hd_param_table *tab, const float *x, const char **which)
{
    for (int i = 0; i < tab->count; i++)
        for (size_t k = 0; k < tab->p[i].count; k++)
            if (!isfinite(x[tab->p[i].offset + k])) {
                *which = tab->p[i].name;
                return 1;
            }
    return 0;
}

hd_status hd_trainer_step(hd_trainer *t, hd_step_result *r, const char *dump_path)
{
    hd_net *net = &t->net;
    hd_status s = hd_trainer_eval(t, r, HD_EVAL_GRAD | HD_EVAL_DISC_GRAD);
    if (s != HD_OK) return s;
    const char *which;
    if (check_finite(&net->table, net->grads, &which))
        return hd_fail(HD_ERR_NUMERIC, "the gradient of '%s' is not finite at iteration %ld", which, t->iteration + 1);
    if (check_finite(&t->disc.table, t->disc.grads, &which))
        return hd_fail(HD_ERR_NUMERIC, "the gradient of '%s' is not finite at iteration %ld", which, t->iteration + 1);
    if (dump_path && (s = hd_trainer_write_dump(t, r, dump_path)) != HD_OK) return s;
    /* Stage 2b starts with fresh Adam moments (2a only moved L-Net's). */
    if (t->iteration > 0 && hd_trainer_stage_phase(t, t->iteration) == HD_PHASE_2B &&
        hd_trainer_stage_phase(t, t->iteration - 1) == HD_PHASE_2A) {
        memset(t->adam_m, 0, net->table.total * sizeof(float));
        memset(t->adam_v, 0, net->table.total * sizeof(float));
        t->adam_t = 0;
    }
    const int lnet_only = hd_trainer_phase(t, t->iteration) == HD_TRAIN_LNET;
    size_t first = lnet_only ? t->lnet_offset : 0;
    float lr = lnet_only && t->lnet_lr > 0 ? t->lnet_lr : t->lr; /* the discriminator keeps t->lr */
    hd_prof_begin("adam");
    t->adam_t++;
    hd_adam_step(net->params + first, net->grads + first, t->adam_m + first, t->adam_v + first,
                 net->table.total - first, lr, HD_ADAM_BETA1, HD_ADAM_BETA2, HD_ADAM_EPS, t->adam_t);
    t->disc_adam_t++;
    hd_adam_step(t->disc.params, t->disc.grads, t->disc_adam_m, t->disc_adam_v, t->disc.table.total, t->lr,
                 HD_ADAM_BETA1, HD_ADAM_BETA2, HD_ADAM_EPS, t->disc_adam_t);
    hd_prof_end();
    t->iteration++;
    return HD_OK;
}
