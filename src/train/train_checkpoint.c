/* train_checkpoint.c: the trainer's state as safetensors: the training checkpoint (parameters,
 * Adam moments, RNG, iteration and configuration; exact resume) and the gradient dump of one step
 * (the batch, outputs, losses, parameters and gradients, for checks against a reference). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "train/trainer.h"
#include "model/checkpoint.h"
#include "io/safetensors.h"

static void trainer_meta(const hd_trainer *t, hd_meta *m)
{
    hd_meta_set(m, "kind", "checkpoint");
    hd_meta_set(m, "stage", "%d", (int)t->stage);
    hd_meta_set(m, "iteration", "%ld", t->iteration);
    hd_meta_set(m, "batch", "%d", t->batch.pairs);
    hd_meta_set(m, "micro_batch", "%d", t->micro);
    hd_meta_set(m, "seed", "%llu", (unsigned long long)t->seed);
    hd_meta_set(m, "rng_state", "%llu", (unsigned long long)t->rng.state);
    hd_meta_set(m, "rng_inc", "%llu", (unsigned long long)t->rng.inc);
    hd_meta_set(m, "adam_t", "%ld", t->adam_t);
    hd_meta_set(m, "disc_adam_t", "%ld", t->disc_adam_t);
    hd_meta_set(m, "lnet_iters", "%ld", t->lnet_iters);
    hd_meta_set(m, "lr", "%.9g", t->lr);
    char w[HD_LOSS_TERMS * 16] = "";
    for (int k = 0; k < HD_LOSS_TERMS; k++) snprintf(w + strlen(w), sizeof w - strlen(w), "%s%.6g", k ? "," : "", t->weights.w[k]);
    hd_meta_set(m, "weights", "%s", w);
}

/* The tensor groups of a training checkpoint: parameters, then the Adam moments. */
#define TRAINER_GROUPS 6
static void trainer_groups(const hd_trainer *t, hd_tensor_group g[TRAINER_GROUPS])
{
    const hd_net *net = &t->net;
    const hd_tensor_group all[TRAINER_GROUPS] = {
        {&net->table, "", net->params},           {&t->disc.table, "", t->disc.params},
        {&net->table, "adam.m.", t->adam_m},      {&net->table, "adam.v.", t->adam_v},
        {&t->disc.table, "adam.m.", t->disc_adam_m}, {&t->disc.table, "adam.v.", t->disc_adam_v},
    };
    memcpy(g, all, sizeof all);
}

hd_status hd_trainer_save(const hd_trainer *t, const char *path)
{
    hd_tensor_group g[TRAINER_GROUPS];
    trainer_groups(t, g);
    hd_meta m = {0};
    trainer_meta(t, &m);
    return hd_checkpoint_write(path, &t->net.cfg, g, TRAINER_GROUPS, &m);
}

hd_status hd_trainer_restore(hd_trainer *t, const hd_safetensors *st, const char *path)
{
    hd_status s;
    hd_net *net = &t->net;
    hd_net_config cfg;
    uint64_t stage, it, batch, seed, rs, ri, at, dat, lnet;
    if ((s = hd_checkpoint_config(st, path, &cfg)) != HD_OK) return s;
    const char *kind = hd_safetensors_meta(st, "kind");
    if (!kind || strcmp(kind, "checkpoint") != 0)
        return hd_fail(HD_ERR_FORMAT, "%s: a model, not a training checkpoint (use --init to start from it)", path);
    if ((s = hd_checkpoint_meta_u64(st, path, "stage", &stage)) || (s = hd_checkpoint_meta_u64(st, path, "iteration", &it)) ||
        (s = hd_checkpoint_meta_u64(st, path, "batch", &batch)) || (s = hd_checkpoint_meta_u64(st, path, "seed", &seed)) ||
        (s = hd_checkpoint_meta_u64(st, path, "rng_state", &rs)) || (s = hd_checkpoint_meta_u64(st, path, "rng_inc", &ri)) ||
        (s = hd_checkpoint_meta_u64(st, path, "adam_t", &at)) || (s = hd_checkpoint_meta_u64(st, path, "disc_adam_t", &dat)) ||
        (s = hd_checkpoint_meta_u64(st, path, "lnet_iters", &lnet)))
        return s;
    if (cfg.width != net->cfg.width || cfg.size != net->cfg.size)
        return hd_fail(HD_ERR_FORMAT, "%s: configuration mismatch: the checkpoint has width %d, size %d; this run has width %d, size %d",
                       path, cfg.width, cfg.size, net->cfg.width, net->cfg.size);
    if ((int)batch != t->batch.pairs)
        return hd_fail(HD_ERR_FORMAT, "%s: configuration mismatch: the checkpoint has batch %llu, this run %d", path,
                       (unsigned long long)batch, t->batch.pairs);
    if ((int)stage != (int)t->stage)
        return hd_fail(HD_ERR_FORMAT, "%s: configuration mismatch: the checkpoint is of stage %llu, this run is stage %d "
                       "(start stage 2 with --init RUN/model.safetensors)", path, (unsigned long long)stage, (int)t->stage);
    hd_tensor_group g[TRAINER_GROUPS];
    trainer_groups(t, g);
    for (int i = 0; i < TRAINER_GROUPS; i++)
        if ((s = hd_checkpoint_take(st, path, &g[i])) != HD_OK) return s;
    t->iteration = (long)it;
    t->seed = seed;
    t->rng.state = rs;
    t->rng.inc = ri;
    t->adam_t = (long)at;
    t->disc_adam_t = (long)dat;
    t->lnet_iters = (long)lnet;
    return HD_OK;
}

hd_status hd_trainer_load(hd_trainer *t, const char *path)
{
    hd_safetensors st = {0};
    hd_status s = hd_safetensors_read(path, &st);
    if (s == HD_OK) s = hd_trainer_restore(t, &st, path);
    hd_safetensors_free(&st);
    return s;
}

hd_status hd_trainer_write_dump(const hd_trainer *t, const hd_step_result *r, const char *path)
{
    const hd_net *net = &t->net;
    int B = net->B, H = net->H, W = net->W, ng = net->table.count, nd = t->disc.table.count;
    int count = 2 * ng + 2 * nd + 8 + HD_LOSS_TERMS + 3;
    hd_tensor *ts = hd_calloc((size_t)count, sizeof *ts);
    char (*names)[160] = hd_calloc((size_t)count, sizeof *names);
    float *scalars = hd_calloc(HD_LOSS_TERMS + 2, sizeof(float));
    hd_status s = HD_ERR_NOMEM;
    if (!ts || !names || !scalars) goto done;
    int n = 0;
#define ADD(nm, ptr, nd_, d0, d1, d2, d3)                                                     \
    do {                                                                                      \
        snprintf(names[n], sizeof names[n], "%s", nm);                                        \
        ts[n].name = names[n];                                                                \
        ts[n].ndim = nd_;                                                                     \
        int64_t dd[4] = {d0, d1, d2, d3};                                                     \
        for (int q = 0; q < nd_; q++) ts[n].shape[q] = dd[q];                                 \
        ts[n].data = (float *)(ptr);                                                          \
        n++;                                                                                  \
    } while (0)
    int BB = 2 * t->batch.pairs;
    ADD("batch.image", t->batch.image, 4, BB, 3, H, W);
    ADD("batch.mask", t->batch.mask, 4, BB, 1, H, W);
    ADD("batch.coarse_normal", t->batch.coarse_normal, 4, BB, 3, H, W);
    if (t->micro == t->batch.pairs) { /* the outputs of the whole batch are at hand */
        ADD("out.albedo", net->albedo, 4, B, 3, H, W);
        ADD("out.shading", net->shading, 4, B, 1, H, W);
        ADD("out.normal", net->normal, 4, B, 3, H, W);
        ADD("out.light", net->light, 2, B, HD_SH_COEFFS, 0, 0);
        ADD("out.light_hat", t->losses.light_hat, 2, B, HD_SH_COEFFS, 0, 0);
    }
    char nm[160];
    for (int k = 0; k < HD_LOSS_TERMS; k++) {
        scalars[k] = (float)r->terms[k];
        snprintf(nm, sizeof nm, "loss.%s", hd_loss_names[k]);
        ADD(nm, &scalars[k], 1, 1, 0, 0, 0);
    }
    scalars[HD_LOSS_TERMS] = (float)r->total;
    scalars[HD_LOSS_TERMS + 1] = (float)r->disc;
    ADD("loss.total", &scalars[HD_LOSS_TERMS], 1, 1, 0, 0, 0);
    ADD("loss.disc", &scalars[HD_LOSS_TERMS + 1], 1, 1, 0, 0, 0);
    const hd_param_table *tabs[2] = {&net->table, &t->disc.table};
    const float *vals[2] = {net->params, t->disc.params}, *grads[2] = {net->grads, t->disc.grads};
    for (int k = 0; k < 2; k++)
        for (int i = 0; i < tabs[k]->count; i++) {
            const hd_param *p = &tabs[k]->p[i];
            ADD(p->name, vals[k] + p->offset, p->ndim, p->shape[0], p->shape[1], p->shape[2], p->shape[3]);
            snprintf(nm, sizeof nm, "grad.%s", p->name);
            ADD(nm, grads[k] + p->offset, p->ndim, p->shape[0], p->shape[1], p->shape[2], p->shape[3]);
        }
#undef ADD
    hd_meta m = {0};
    trainer_meta(t, &m);
    hd_meta_set(&m, "kind", "gradient-dump");
    hd_meta_set(&m, "phase", "%s", hd_train_phase_name(hd_trainer_stage_phase(t, t->iteration)));
    s = hd_checkpoint_write_tensors(path, &net->cfg, ts, n, &m);
done:
    free(ts);
    free(names);
    free(scalars);
    return s;
}

