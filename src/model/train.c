/* train.c: the HD-Net trainer. One step = forward, the seven losses, backward (SPEC section 4's
 * gradient paths), NaN checks, the generator's Adam, then the discriminator's loss and Adam.
 * A run draws each iteration's pairs and flips from (seed, iteration) alone, so a background
 * thread can load batch t+1 while step t runs and a resumed run sees exactly the same data. */
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "model/train.h"
#include "model/checkpoint.h"
#include "io/dataset.h"
#include "light/light.h"

#define HD_DATA_STREAM 0x5eedda7aULL
#define HD_INIT_STREAM 1
#define HD_LOAD_RETRIES 32

/* ---------------------------------------------------------------- the trainer */

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
    if (pairs < 1 || pairs > 1024) return hd_fail(HD_ERR_RANGE, "batch of %d pairs is out of range (1..1024)", pairs);
    if (micro <= 0) micro = pairs;
    if (micro > pairs || pairs % micro)
        return hd_fail(HD_ERR_ARG, "a micro-batch of %d pairs does not divide the batch of %d pairs", micro, pairs);
    t->micro = micro;
    hd_status s = hd_net_create(&t->net, cfg, 2 * micro, HD_NET_TRAIN, HD_CONV_AUTO);
    if (s != HD_OK) return s;
    if ((s = hd_losses_create(&t->losses, &t->net)) != HD_OK || (s = hd_pair_batch_alloc(&t->batch, pairs, cfg->size)) != HD_OK)
        goto fail;
    t->adam_m = hd_calloc(t->net.table.total, sizeof(float));
    t->adam_v = hd_calloc(t->net.table.total, sizeof(float));
    t->disc_adam_m = hd_calloc(t->net.disc_table.total, sizeof(float));
    t->disc_adam_v = hd_calloc(t->net.disc_table.total, sizeof(float));
    if (!t->adam_m || !t->adam_v || !t->disc_adam_m || !t->disc_adam_v) {
        s = HD_ERR_NOMEM;
        goto fail;
    }
    t->lnet_offset = t->net.table.p[hd_param_find(&t->net.table, "l_net.conv1.weight")].offset;
    hd_loss_weights_preset("gt", &t->weights);
    t->lr = 1e-3f;
    t->stage = 1;
    t->seed = seed;
    hd_rng_seed(&t->rng, seed, HD_INIT_STREAM);
    hd_train_init_params(cfg, seed, t->net.params, t->net.disc_params);
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
    free(t->adam_m);
    free(t->adam_v);
    free(t->disc_adam_m);
    free(t->disc_adam_v);
    memset(t, 0, sizeof *t);
}

hd_net_train_set hd_trainer_phase(const hd_trainer *t, long it)
{
    return t->stage == 2 && it < t->lnet_iters ? HD_TRAIN_LNET : HD_TRAIN_ALL;
}

/* The view of micro-batch c of the trainer's batch. */
static hd_pair_batch chunk_of(const hd_trainer *t, int c)
{
    const hd_pair_batch *b = &t->batch;
    size_t first = (size_t)2 * c * t->micro, HW = (size_t)b->size * b->size;
    hd_pair_batch v = {t->micro, b->size, b->image + first * 3 * HW, b->mask + first * HW,
                       b->coarse_normal + first * 3 * HW, b->has_normal + first,
                       b->albedo_gt + first * 3 * HW, b->has_albedo + first,
                       b->light_gt + first * HD_SH_COEFFS, b->has_light + first};
    return v;
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
    memset(r, 0, sizeof *r);
    if (grad) memset(net->grads, 0, net->table.total * sizeof(float));
    if (what & HD_EVAL_DISC_GRAD) memset(net->disc_grads, 0, net->disc_table.total * sizeof(float));
    for (int c = 0; c < chunks; c++) {
        t->chunk = chunk_of(t, c);
        memcpy(net->input, t->chunk.image, n * sizeof(float));
        hd_net_forward(net);
        hd_net_zero_act_grad(net);
        hd_status s = hd_losses_prepare(&t->losses, &t->chunk, t->stage == 1 ? HD_LIGHT_FROM_COARSE : HD_LIGHT_FROM_PREDICTED);
        if (s != HD_OK) {
            char why[400];
            snprintf(why, sizeof why, "%s", hd_error());
            return hd_fail(s, "loss term 'light' (its least-squares target) failed at iteration %ld: %s", t->iteration + 1, why);
        }
        double terms[HD_LOSS_TERMS];
        r->total += hd_losses_generator(&t->losses, &w, terms, grad);
        for (int k = 0; k < HD_LOSS_TERMS; k++) {
            if (!isfinite(terms[k]))
                return hd_fail(HD_ERR_NUMERIC, "loss term '%s' is %s at iteration %ld", hd_loss_names[k],
                               isnan(terms[k]) ? "NaN" : "infinite", t->iteration + 1);
            r->terms[k] += terms[k] * part;
        }
        if (grad) hd_net_backward(net, hd_trainer_phase(t, t->iteration));
        if (!disc) continue;
        double d = hd_loss_discriminator(&t->losses, what & HD_EVAL_DISC_GRAD ? part : 0.0f);
        if (!isfinite(d))
            return hd_fail(HD_ERR_NUMERIC, "the discriminator's loss is %s at iteration %ld", isnan(d) ? "NaN" : "infinite",
                           t->iteration + 1);
        r->disc += d * part;
    }
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

static hd_status write_dump(const hd_trainer *t, const hd_step_result *r, const char *path);

hd_status hd_trainer_step(hd_trainer *t, hd_step_result *r, const char *dump_path)
{
    hd_net *net = &t->net;
    hd_status s = hd_trainer_eval(t, r, HD_EVAL_GRAD | HD_EVAL_DISC_GRAD);
    if (s != HD_OK) return s;
    const char *which;
    if (check_finite(&net->table, net->grads, &which))
        return hd_fail(HD_ERR_NUMERIC, "the gradient of '%s' is not finite at iteration %ld", which, t->iteration + 1);
    if (check_finite(&net->disc_table, net->disc_grads, &which))
        return hd_fail(HD_ERR_NUMERIC, "the gradient of '%s' is not finite at iteration %ld", which, t->iteration + 1);
    if (dump_path && (s = write_dump(t, r, dump_path)) != HD_OK) return s;
    /* Stage 2b starts with fresh Adam moments (2a only moved L-Net's). */
    if (t->stage == 2 && t->iteration == t->lnet_iters && t->lnet_iters > 0) {
        memset(t->adam_m, 0, net->table.total * sizeof(float));
        memset(t->adam_v, 0, net->table.total * sizeof(float));
        t->adam_t = 0;
    }
    size_t first = hd_trainer_phase(t, t->iteration) == HD_TRAIN_LNET ? t->lnet_offset : 0;
    t->adam_t++;
    hd_adam_step(net->params + first, net->grads + first, t->adam_m + first, t->adam_v + first,
                 net->table.total - first, t->lr, HD_ADAM_BETA1, HD_ADAM_BETA2, HD_ADAM_EPS, t->adam_t);
    t->disc_adam_t++;
    hd_adam_step(net->disc_params, net->disc_grads, t->disc_adam_m, t->disc_adam_v, net->disc_table.total, t->lr,
                 HD_ADAM_BETA1, HD_ADAM_BETA2, HD_ADAM_EPS, t->disc_adam_t);
    t->iteration++;
    return HD_OK;
}

static void trainer_meta(const hd_trainer *t, hd_meta *m)
{
    hd_meta_set(m, "kind", "checkpoint");
    hd_meta_set(m, "stage", "%d", t->stage);
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
    char w[96] = "";
    for (int k = 0; k < HD_LOSS_TERMS; k++) snprintf(w + strlen(w), sizeof w - strlen(w), "%s%.6g", k ? "," : "", t->weights.w[k]);
    hd_meta_set(m, "weights", "%s", w);
}

hd_status hd_trainer_save(const hd_trainer *t, const char *path)
{
    const hd_net *net = &t->net;
    hd_tensor_group g[6] = {
        {&net->table, "", net->params},           {&net->disc_table, "", net->disc_params},
        {&net->table, "adam.m.", t->adam_m},      {&net->table, "adam.v.", t->adam_v},
        {&net->disc_table, "adam.m.", t->disc_adam_m}, {&net->disc_table, "adam.v.", t->disc_adam_v},
    };
    hd_meta m = {0};
    trainer_meta(t, &m);
    return hd_checkpoint_write(path, &net->cfg, g, 6, &m);
}

static hd_status meta_u64(const hd_safetensors *st, const char *path, const char *key, uint64_t *v)
{
    const char *s = hd_safetensors_meta(st, key);
    if (!s) return hd_fail(HD_ERR_FORMAT, "%s: metadata has no '%s' (not a training checkpoint?)", path, key);
    char *end;
    unsigned long long x = strtoull(s, &end, 10);
    if (end == s || *end) return hd_fail(HD_ERR_FORMAT, "%s: metadata '%s' is not an integer: '%s'", path, key, s);
    *v = x;
    return HD_OK;
}

hd_status hd_trainer_load(hd_trainer *t, const char *path)
{
    hd_safetensors st = {0};
    hd_status s = hd_safetensors_read(path, &st);
    if (s != HD_OK) return s;
    hd_net *net = &t->net;
    hd_net_config cfg;
    uint64_t stage, it, batch, seed, rs, ri, at, dat, lnet;
    if ((s = hd_checkpoint_config(&st, path, &cfg)) != HD_OK) goto done;
    const char *kind = hd_safetensors_meta(&st, "kind");
    if (!kind || strcmp(kind, "checkpoint") != 0) {
        s = hd_fail(HD_ERR_FORMAT, "%s: a model, not a training checkpoint (use --init to start from it)", path);
        goto done;
    }
    if ((s = meta_u64(&st, path, "stage", &stage)) || (s = meta_u64(&st, path, "iteration", &it)) ||
        (s = meta_u64(&st, path, "batch", &batch)) || (s = meta_u64(&st, path, "seed", &seed)) ||
        (s = meta_u64(&st, path, "rng_state", &rs)) || (s = meta_u64(&st, path, "rng_inc", &ri)) ||
        (s = meta_u64(&st, path, "adam_t", &at)) || (s = meta_u64(&st, path, "disc_adam_t", &dat)) ||
        (s = meta_u64(&st, path, "lnet_iters", &lnet)))
        goto done;
    if (cfg.width != net->cfg.width || cfg.size != net->cfg.size) {
        s = hd_fail(HD_ERR_FORMAT, "%s: configuration mismatch: the checkpoint has width %d, size %d; this run has width %d, size %d",
                    path, cfg.width, cfg.size, net->cfg.width, net->cfg.size);
        goto done;
    }
    if ((int)batch != t->batch.pairs) {
        s = hd_fail(HD_ERR_FORMAT, "%s: configuration mismatch: the checkpoint has batch %llu, this run %d", path,
                    (unsigned long long)batch, t->batch.pairs);
        goto done;
    }
    if ((int)stage != t->stage) {
        s = hd_fail(HD_ERR_FORMAT, "%s: configuration mismatch: the checkpoint is of stage %llu, this run is stage %d "
                    "(start stage 2 with --init RUN/model.safetensors)", path, (unsigned long long)stage, t->stage);
        goto done;
    }
    hd_tensor_group g[6] = {
        {&net->table, "", net->params},           {&net->disc_table, "", net->disc_params},
        {&net->table, "adam.m.", t->adam_m},      {&net->table, "adam.v.", t->adam_v},
        {&net->disc_table, "adam.m.", t->disc_adam_m}, {&net->disc_table, "adam.v.", t->disc_adam_v},
    };
    for (int i = 0; i < 6; i++)
        if ((s = hd_checkpoint_take(&st, path, &g[i])) != HD_OK) goto done;
    t->iteration = (long)it;
    t->seed = seed;
    t->rng.state = rs;
    t->rng.inc = ri;
    t->adam_t = (long)at;
    t->disc_adam_t = (long)dat;
    t->lnet_iters = (long)lnet;
done:
    hd_safetensors_free(&st);
    return s;
}

/* ---------------------------------------------------------------- the gradient dump */

static hd_status write_dump(const hd_trainer *t, const hd_step_result *r, const char *path)
{
    const hd_net *net = &t->net;
    int B = net->B, H = net->H, W = net->W, ng = net->table.count, nd = net->disc_table.count;
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
    const hd_param_table *tabs[2] = {&net->table, &net->disc_table};
    const float *vals[2] = {net->params, net->disc_params}, *grads[2] = {net->grads, net->disc_grads};
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
    hd_meta_set(&m, "width", "%d", net->cfg.width);
    hd_meta_set(&m, "size", "%d", net->cfg.size);
    hd_meta_set(&m, "format", "hdnet");
    hd_meta_set(&m, "format_version", "%d", HD_NET_FORMAT_VERSION);
    hd_meta_set(&m, "phase", "%s", hd_trainer_phase(t, t->iteration) == HD_TRAIN_LNET ? "2a" : t->stage == 2 ? "2b" : "1");
    const char *keys[HD_CHECKPOINT_MAX_META], *values[HD_CHECKPOINT_MAX_META];
    for (int i = 0; i < m.count; i++) {
        keys[i] = m.keys[i];
        values[i] = m.values[i];
    }
    s = hd_safetensors_write(path, ts, n, keys, values, m.count);
done:
    free(ts);
    free(names);
    free(scalars);
    return s;
}

/* ---------------------------------------------------------------- data: pairs of (seed, iteration) */

typedef struct pair_source {
    const hd_dataset *ds;
    int *use;       /* the usable samples (stage 1: those with coarse normals), by subject */
    int *use_start; /* subject s uses use[use_start[s] .. use_start[s + 1]) */
    long *cum;      /* cum[s] = pairs in subjects before s; cum[subject_count] = all pairs */
    int size, stage;
    int prior_gt;  /* the prior normals N_bar are the ground-truth normals (NAME.normal_gt.png) */
    int albedo_gt; /* load the ground-truth albedo (NAME.albedo.png) for the albedo_gt term */
    int light_gt;  /* l_hat is the ground-truth light (NAME.light.txt) where there is one */
    uint64_t seed;
} pair_source;

/* Lists the usable samples and counts the pairs; *skipped = samples left out. */
static hd_status pair_source_init(pair_source *src, const hd_dataset *ds, int stage, int prior_gt, int *skipped,
                                  int *first_skipped)
{
    src->ds = ds;
    src->stage = stage;
    src->prior_gt = prior_gt;
    src->use = hd_calloc((size_t)ds->count + 1, sizeof(int));
    src->use_start = hd_calloc((size_t)ds->subject_count + 1, sizeof(int));
    src->cum = hd_calloc((size_t)ds->subject_count + 1, sizeof(long));
    if (!src->use || !src->use_start || !src->cum) return HD_ERR_NOMEM;
    int n = 0;
    *skipped = 0;
    *first_skipped = -1;
    for (int s = 0; s < ds->subject_count; s++) {
        src->use_start[s] = n;
        for (int i = ds->subject_start[s]; i < ds->subject_start[s + 1]; i++) {
            if (stage == 1 && !(prior_gt ? ds->samples[i].normal_gt : ds->samples[i].normal)) {
                if (*first_skipped < 0) *first_skipped = i;
                ++*skipped;
                continue;
            }
            src->use[n++] = i;
        }
        long k = n - src->use_start[s];
        src->cum[s + 1] = src->cum[s] + k * (k - 1) / 2;
    }
    src->use_start[ds->subject_count] = n;
    return HD_OK;
}

static void pair_source_free(pair_source *src)
{
    free(src->use);
    free(src->use_start);
    free(src->cum);
}

/* The two sample indices of pair q (0 <= q < all pairs). */
static void pair_of(const pair_source *src, long q, int *a, int *b)
{
    int s = 0;
    while (src->cum[s + 1] <= q) s++;
    long r = q - src->cum[s];
    int first = src->use_start[s], n = src->use_start[s + 1] - first;
    int i = 0;
    while (r >= n - 1 - i) {
        r -= n - 1 - i;
        i++;
    }
    *a = src->use[first + i];
    *b = src->use[first + i + 1 + (int)r];
}

/* Reads an image as `channels` at size x size. */
static hd_status read_sized(const char *path, int channels, int size, hd_image *out)
{
    hd_image img = {0};
    hd_status s = hd_image_read_as(path, channels, &img);
    if (s != HD_OK) return s;
    if (img.width == size && img.height == size) {
        *out = img;
        return HD_OK;
    }
    s = hd_image_resize(&img, size, size, out);
    hd_image_free(&img);
    return s;
}

/* Loads sample i into slot `slot` of batch, flipped horizontally if flip (normal x negated). */
static hd_status load_sample(const pair_source *src, int i, int flip, hd_pair_batch *batch, int slot)
{
    const hd_sample *smp = &src->ds->samples[i];
    int size = src->size;
    size_t HW = (size_t)size * size;
    float *img = batch->image + (size_t)slot * 3 * HW, *mask = batch->mask + (size_t)slot * HW;
    float *nrm = batch->coarse_normal + (size_t)slot * 3 * HW, *alb = batch->albedo_gt + (size_t)slot * 3 * HW;
    const char *prior = src->prior_gt ? smp->normal_gt : smp->normal;
    hd_image im = {0}, mk = {0}, nr = {0}, nd = {0}, nv = {0}, al = {0};
    hd_status s;
    if ((s = read_sized(smp->image, 3, size, &im)) != HD_OK) goto done;
    memcpy(img, im.data, 3 * HW * sizeof(float));
    if (smp->mask) {
        if ((s = read_sized(smp->mask, 1, size, &mk)) != HD_OK) goto done;
        memcpy(mask, mk.data, HW * sizeof(float));
    } else {
        for (size_t p = 0; p < HW; p++) mask[p] = 1.0f;
    }
    batch->has_normal[slot] = prior != NULL;
    if (prior) {
        if ((s = read_sized(prior, 3, size, &nr)) != HD_OK || (s = hd_normal_decode(&nr, &nd, &nv)) != HD_OK) goto done;
        memcpy(nrm, nd.data, 3 * HW * sizeof(float));
        /* texels without a stored normal are outside the face */
        for (size_t p = 0; p < HW; p++) mask[p] *= nv.data[p] > 0.5f ? 1.0f : 0.0f;
    } else {
        if (src->stage == 1) {
            s = hd_fail(HD_ERR_NOTFOUND, "%s: no prior normals (%s.%s.png); stage 1 needs them", smp->image, smp->name,
                        src->prior_gt ? "normal_gt" : "normal");
            goto done;
        }
        memset(nrm, 0, 3 * HW * sizeof(float));
    }
    float *lgt = batch->light_gt + (size_t)slot * HD_SH_COEFFS;
    batch->has_light[slot] = src->light_gt && smp->light;
    if (batch->has_light[slot]) {
        if ((s = hd_light_read(smp->light, lgt)) != HD_OK) goto done;
        /* a mirrored face sees the mirrored light: the coefficients odd in x change sign */
        if (flip) hd_light_mirror(lgt);
    } else {
        memset(lgt, 0, HD_SH_COEFFS * sizeof(float));
    }
    batch->has_albedo[slot] = src->albedo_gt && smp->albedo;
    if (batch->has_albedo[slot]) {
        if ((s = read_sized(smp->albedo, 3, size, &al)) != HD_OK) goto done;
        memcpy(alb, al.data, 3 * HW * sizeof(float));
    } else {
        memset(alb, 0, 3 * HW * sizeof(float));
    }
    if (flip) {
        float *planes[10] = {img, img + HW, img + 2 * HW, mask, nrm, nrm + HW, nrm + 2 * HW, alb, alb + HW, alb + 2 * HW};
        for (int k = 0; k < 10; k++)
            for (int y = 0; y < size; y++) {
                float *row = planes[k] + (size_t)y * size;
                for (int x = 0; x < size / 2; x++) {
                    float tmp = row[x];
                    row[x] = row[size - 1 - x];
                    row[size - 1 - x] = tmp;
                }
            }
        for (size_t p = 0; p < HW; p++) nrm[p] = -nrm[p]; /* x points the other way */
    }
done:
    hd_image_free(&im);
    hd_image_free(&mk);
    hd_image_free(&nr);
    hd_image_free(&nd);
    hd_image_free(&nv);
    hd_image_free(&al);
    return s;
}

typedef struct loader {
    const pair_source *src;
    hd_pair_batch *batch;
    long iteration;
    hd_status status;
    char error[512];
    char warnings[2048];
    pthread_t thread;
    int running;
} loader;

/* Fills the batch of iteration it: pair q and flip f of slot p come from an RNG seeded with
 * (seed, it) only. A pair that fails to load is reported and replaced by the next draw. */
static void load_batch(loader *L)
{
    const pair_source *src = L->src;
    hd_rng rng;
    hd_rng_seed(&rng, src->seed ^ HD_DATA_STREAM, (uint64_t)L->iteration);
    long total = src->cum[src->ds->subject_count];
    L->status = HD_OK;
    L->warnings[0] = '\0';
    for (int p = 0; p < L->batch->pairs; p++) {
        int tries = 0;
        for (;;) {
            long q = (long)(((uint64_t)hd_rng_u32(&rng) << 32 | hd_rng_u32(&rng)) % (uint64_t)total);
            int flip = hd_rng_u32(&rng) & 1, swap = hd_rng_u32(&rng) & 1, a, b;
            pair_of(src, q, &a, &b);
            if (swap) {
                int tmp = a;
                a = b;
                b = tmp;
            }
            hd_status s = load_sample(src, a, flip, L->batch, 2 * p);
            if (s == HD_OK) s = load_sample(src, b, flip, L->batch, 2 * p + 1);
            if (s == HD_OK) break;
            if (s == HD_ERR_NOMEM || ++tries >= HD_LOAD_RETRIES || (s == HD_ERR_NOTFOUND && src->stage == 1)) {
                L->status = s;
                snprintf(L->error, sizeof L->error, "%s", hd_error());
                return;
            }
            size_t len = strlen(L->warnings);
            if (len + 2 < sizeof L->warnings)
                snprintf(L->warnings + len, sizeof L->warnings - len, "%sskipping a pair: %s", len ? "\n" : "", hd_error());
        }
    }
}

static void *loader_main(void *arg)
{
    load_batch(arg);
    return NULL;
}

static hd_status loader_start(loader *L, long iteration)
{
    L->iteration = iteration;
    if (pthread_create(&L->thread, NULL, loader_main, L) != 0) {
        load_batch(L); /* no thread: load in the foreground */
        return HD_OK;
    }
    L->running = 1;
    return HD_OK;
}

static hd_status loader_wait(loader *L, void (*warn)(const char *))
{
    if (L->running) pthread_join(L->thread, NULL);
    L->running = 0;
    if (warn && L->warnings[0]) warn(L->warnings);
    if (L->status != HD_OK) return hd_fail(L->status, "%s", L->error);
    return HD_OK;
}

/* ---------------------------------------------------------------- outputs: CSV, plot, samples */

typedef struct history {
    long n, cap;
    float *v; /* n rows of HD_LOSS_TERMS + 2 values (terms, total, disc) */
} history;

#define HIST_COLS (HD_LOSS_TERMS + 2)

static hd_status history_push(history *h, const float *row)
{
    if (h->n == h->cap) {
        long cap = h->cap ? 2 * h->cap : 1024;
        float *v = realloc(h->v, (size_t)cap * HIST_COLS * sizeof(float));
        if (!v) return hd_fail(HD_ERR_NOMEM, "out of memory keeping the loss history");
        h->v = v;
        h->cap = cap;
    }
    memcpy(h->v + (size_t)h->n * HIST_COLS, row, HIST_COLS * sizeof(float));
    h->n++;
    return HD_OK;
}

static void csv_header(FILE *f)
{
    fprintf(f, "iteration,total");
    for (int k = 0; k < HD_LOSS_TERMS; k++) fprintf(f, ",%s", hd_loss_names[k]);
    fprintf(f, ",disc,seconds\n");
}

/* Rewrites loss.csv keeping rows up to `iteration` (a resumed run continues from its checkpoint)
 * and loads them into the history. */
static hd_status csv_restore(const char *path, long iteration, history *h)
{
    char *data = NULL;
    size_t size;
    h->n = 0;
    if (hd_read_file(path, (size_t)1 << 31, &data, &size) != HD_OK) data = NULL;
    hd_atomic_file af;
    hd_status s = hd_atomic_open(&af, path);
    if (s != HD_OK) {
        free(data);
        return s;
    }
    csv_header(af.f);
    char *line = data ? strchr(data, '\n') : NULL; /* skip the header */
    while (line && *++line) {
        char *next = strchr(line, '\n');
        if (next) *next = '\0';
        char *end;
        long it = strtol(line, &end, 10);
        if (end != line && it >= 1 && it <= iteration) {
            float row[HIST_COLS] = {0};
            const char *p = end;
            /* columns: total, terms..., disc */
            for (int c = 0; c < HIST_COLS && *p == ','; c++) {
                float v = strtof(p + 1, &end);
                p = end;
                if (c == 0) row[HD_LOSS_TERMS] = v;
                else if (c <= HD_LOSS_TERMS) row[c - 1] = v;
                else row[HD_LOSS_TERMS + 1] = v;
            }
            fprintf(af.f, "%s\n", line);
            if ((s = history_push(h, row)) != HD_OK) break;
        }
        line = next;
    }
    free(data);
    if (s != HD_OK) {
        hd_atomic_abort(&af);
        return s;
    }
    return hd_atomic_commit(&af);
}

static void plot_line(hd_image *img, int x0, int y0, int x1, int y1, const float rgb[3])
{
    int dx = abs(x1 - x0), dy = -abs(y1 - y0), sx = x0 < x1 ? 1 : -1, sy = y0 < y1 ? 1 : -1, err = dx + dy;
    size_t HW = (size_t)img->width * img->height;
    for (;;) {
        if (x0 >= 0 && x0 < img->width && y0 >= 0 && y0 < img->height)
            for (int c = 0; c < 3; c++) img->data[c * HW + (size_t)y0 * img->width + x0] = rgb[c];
        if (x0 == x1 && y0 == y1) break;
        int e2 = 2 * err;
        if (e2 >= dy) {
            err += dy;
            x0 += sx;
        }
        if (e2 <= dx) {
            err += dx;
            y0 += sy;
        }
    }
}

/* The loss curves: log10 of the weighted total (black) and of each unweighted term (colours),
 * averaged over buckets of iterations, on a white 800 x 400 canvas with a grid per decade. */
static hd_status write_loss_plot(const char *path, const history *h)
{
    static const float colours[HIST_COLS][3] = {
        {0.85f, 0.1f, 0.1f}, {0.1f, 0.6f, 0.1f}, {0.1f, 0.3f, 0.9f}, {0.9f, 0.6f, 0.0f}, {0.6f, 0.1f, 0.7f},
        {0.0f, 0.7f, 0.7f},  {0.5f, 0.5f, 0.5f}, {0.9f, 0.4f, 0.7f}, {0.0f, 0.0f, 0.0f}, {0.7f, 0.4f, 0.2f}};
    const int Wd = 800, Ht = 400, margin = 10;
    hd_image img = {0};
    hd_status s = hd_image_alloc(&img, Wd, Ht, 3);
    if (s != HD_OK) return s;
    for (size_t i = 0; i < (size_t)3 * Wd * Ht; i++) img.data[i] = 1.0f;
    double lo = 1e30, hi = -1e30;
    for (long i = 0; i < h->n * HIST_COLS; i++) {
        float v = h->v[i];
        if (v > 0 && isfinite(v)) {
            double l = log10(v);
            lo = l < lo ? l : lo;
            hi = l > hi ? l : hi;
        }
    }
    if (h->n >= 1 && lo < hi + 1) {
        lo = floor(lo);
        hi = ceil(hi);
        if (hi <= lo) hi = lo + 1;
        const float grid[3] = {0.85f, 0.85f, 0.85f};
        for (double d = lo; d <= hi; d += 1) {
            int y = margin + (int)((hi - d) / (hi - lo) * (Ht - 2 * margin));
            plot_line(&img, margin, y, Wd - margin, y, grid);
        }
        int cols = Wd - 2 * margin;
        long bucket = h->n / cols + 1;
        for (int c = 0; c < HIST_COLS; c++) {
            int px = -1, py = 0;
            for (long start = 0; start < h->n; start += bucket) {
                double sum = 0;
                long cnt = 0;
                for (long i = start; i < start + bucket && i < h->n; i++) {
                    float v = h->v[(size_t)i * HIST_COLS + c];
                    if (v > 0 && isfinite(v)) {
                        sum += v;
                        cnt++;
                    }
                }
                if (!cnt) continue;
                int x = margin + (int)((double)start / (h->n > 1 ? h->n - 1 : 1) * cols);
                int y = margin + (int)((hi - log10(sum / cnt)) / (hi - lo) * (Ht - 2 * margin));
                if (px >= 0) plot_line(&img, px, py, x, y, colours[c]);
                else plot_line(&img, x, y, x, y, colours[c]);
                px = x;
                py = y;
            }
        }
    }
    s = hd_image_write_png(path, &img, 8);
    hd_image_free(&img);
    return s;
}

/* Sample sheet of the last forward: per image of the first pairs (at most 4 rows):
 * input | albedo | shading | normal | reconstruction | relit (A * s(N, light of its pair partner)). */
static hd_status write_samples(const char *path, const hd_trainer *t)
{
    const hd_net *net = &t->net;
    int S = net->H, rows = net->B < 4 ? net->B : 4, cols = 6;
    size_t HW = (size_t)S * S;
    hd_image sheet = {0};
    hd_status s = hd_image_alloc(&sheet, S * cols, S * rows, 3);
    if (s != HD_OK) return s;
    size_t SW = (size_t)sheet.width * sheet.height;
    float *relit_s = hd_malloc(HW * sizeof(float));
    if (!relit_s) {
        hd_image_free(&sheet);
        return HD_ERR_NOMEM;
    }
    for (int r = 0; r < rows; r++) {
        const float *I = t->chunk.image + (size_t)r * 3 * HW, *A = net->albedo + (size_t)r * 3 * HW;
        const float *Sh = net->shading + (size_t)r * HW, *N = net->normal + (size_t)r * 3 * HW;
        const float *m = t->chunk.mask + (size_t)r * HW;
        hd_sh_shading_map(N, NULL, (int)HW, net->light + (size_t)(r ^ 1) * HD_SH_COEFFS, relit_s);
        for (int col = 0; col < cols; col++)
            for (int c = 0; c < 3; c++)
                for (size_t p = 0; p < HW; p++) {
                    float v = 0;
                    switch (col) {
                    case 0: v = I[c * HW + p]; break;
                    case 1: v = A[c * HW + p]; break;
                    case 2: v = Sh[p] * 0.5f; break;
                    case 3: v = m[p] > 0 ? (N[c * HW + p] + 1) * 0.5f : 0.0f; break;
                    case 4: v = A[c * HW + p] * Sh[p]; break;
                    default: v = A[c * HW + p] * relit_s[p]; break;
                    }
                    size_t y = (size_t)r * S + p / S, x = (size_t)col * S + p % S;
                    sheet.data[c * SW + y * sheet.width + x] = v;
                }
    }
    s = hd_image_write_png(path, &sheet, 8);
    free(relit_s);
    hd_image_free(&sheet);
    return s;
}

/* ---------------------------------------------------------------- the run */

int hd_train_default_micro(const hd_net_config *cfg, int pairs)
{
    /* measured (docs/performance.md): about 2.9 GB per pair at 256 x 256, width 48, most of it
     * activations and oneDNN's buffers, which grow with the pixels and the width */
    const double per_pair = 2.9e9 * ((double)cfg->size * cfg->size / (256.0 * 256.0)) * ((double)cfg->width / 48.0);
    const double budget = 6.0e9;
    for (int d = pairs; d > 1; d--)
        if (pairs % d == 0 && d * per_pair <= budget) return d;
    return 1;
}

void hd_train_defaults(hd_train_options *o)
{
    memset(o, 0, sizeof *o);
    o->stage = 1;
    o->iters = 1000;
    o->lnet_iters = -1;
    o->every = 100;
    o->seed = 1;
    hd_loss_weights_preset("gt", &o->weights);
}

/* Writes the checkpoint, the inference model and the plot. */
static hd_status save_all(const hd_trainer *t, const char *ckpt, const char *model, const char *plot, const history *h)
{
    hd_status s = hd_trainer_save(t, ckpt);
    if (s == HD_OK) s = hd_model_write(model, &t->net.cfg, t->net.params, t->iteration, t->stage);
    if (s == HD_OK) s = write_loss_plot(plot, h);
    return s;
}

hd_status hd_train(const hd_train_options *o, hd_train_result *r)
{
    memset(r, 0, sizeof *r);
    if (o->stage != 1 && o->stage != 2) return hd_fail(HD_ERR_ARG, "stage must be 1 or 2, not %d", o->stage);
    if (o->iters < 1) return hd_fail(HD_ERR_ARG, "the iteration count must be positive");
    if (o->every < 1) return hd_fail(HD_ERR_ARG, "--every must be positive");
    hd_status s;
    hd_dataset ds = {0};
    hd_trainer t = {0};
    pair_source src = {0};
    loader ld = {0};
    history hist = {0};
    hd_model *init_model = NULL;
    char *ckpt = NULL, *model = NULL, *plot = NULL, *csv = NULL, *samples = NULL;
    FILE *csvf = NULL;
    hd_pair_batch next = {0};

    ckpt = hd_path_join(o->run_dir, "checkpoint.safetensors");
    model = hd_path_join(o->run_dir, "model.safetensors");
    plot = hd_path_join(o->run_dir, "loss.png");
    csv = hd_path_join(o->run_dir, "loss.csv");
    samples = hd_path_join(o->run_dir, "samples");
    if (!ckpt || !model || !plot || !csv || !samples) {
        s = HD_ERR_NOMEM;
        goto done;
    }
    if ((s = hd_dataset_scan(o->data_dir, &ds, o->warn)) != HD_OK) goto done;
    int skipped, first_skipped;
    if ((s = pair_source_init(&src, &ds, o->stage, o->prior_normals_gt, &skipped, &first_skipped)) != HD_OK) goto done;
    src.albedo_gt = o->weights.w[HD_LOSS_ALBEDO_GT] > 0.0f;
    src.light_gt = o->light_target_gt;
    if (skipped && o->warn) {
        char msg[600];
        snprintf(msg, sizeof msg, "stage 1 needs coarse normals: %d image(s) without NAME.normal.png left out (first: %s)",
                 skipped, ds.samples[first_skipped].image);
        o->warn(msg);
    }
    if (src.cum[ds.subject_count] < 1) {
        s = hd_fail(HD_ERR_ARG, "%s: no pairs to train on (a subject folder needs at least two images%s)", o->data_dir,
                    o->stage == 1 ? " with coarse normals" : "");
        goto done;
    }

    /* The configuration: options, else the checkpoint's (resume) or the init model's, else defaults. */
    hd_net_config cfg = {o->width, o->size};
    int batch = o->batch, micro = o->micro_batch;
    uint64_t seed = o->seed;
    if (o->resume) {
        hd_safetensors st = {0};
        if ((s = hd_safetensors_read(ckpt, &st)) != HD_OK) {
            char why[400];
            snprintf(why, sizeof why, "%s", hd_error());
            s = hd_fail(s, "cannot resume: %s", why);
            goto done;
        }
        hd_net_config c;
        long long b = 0, sd = 0;
        s = hd_checkpoint_config(&st, ckpt, &c);
        if (s == HD_OK) s = hd_checkpoint_meta_long(&st, ckpt, "batch", &b);
        if (s == HD_OK) s = hd_checkpoint_meta_long(&st, ckpt, "seed", &sd);
        const char *mb = hd_safetensors_meta(&st, "micro_batch");
        if (!micro && mb && !batch) micro = atoi(mb); /* the same split sums in the same order */
        hd_safetensors_free(&st);
        if (s != HD_OK) goto done;
        if (!cfg.width) cfg.width = c.width;
        if (!cfg.size) cfg.size = c.size;
        if (!batch) batch = (int)b;
        seed = (uint64_t)sd;
    } else if (o->init_model) {
        if ((s = hd_model_load(o->init_model, &init_model)) != HD_OK) goto done;
        int w = hd_model_width(init_model), sz = hd_model_size(init_model);
        if (cfg.width && cfg.width != w) {
            s = hd_fail(HD_ERR_ARG, "%s: configuration mismatch: the model has width %d, --width asks %d", o->init_model, w, cfg.width);
            goto done;
        }
        cfg.width = w;
        if (!cfg.size) cfg.size = sz; /* the weights do not depend on the size */
    }
    if (!cfg.width) cfg.width = 48;
    if (!cfg.size) cfg.size = 256;
    if (!batch) batch = 8;
    if ((s = hd_net_config_check(&cfg)) != HD_OK) goto done;
    if (!micro) micro = hd_train_default_micro(&cfg, batch);

    if ((s = hd_trainer_create(&t, &cfg, batch, micro, seed)) != HD_OK) goto done;
    t.weights = o->weights;
    t.stage = o->stage;
    t.lr = o->lr > 0 ? o->lr : o->stage == 1 ? 1e-3f : 1e-4f;
    t.lnet_iters = o->stage == 2 ? (o->lnet_iters >= 0 ? o->lnet_iters : o->iters / 5) : 0;
    if (o->resume) {
        long lnet = t.lnet_iters;
        if ((s = hd_trainer_load(&t, ckpt)) != HD_OK) goto done;
        if (o->stage == 2 && o->lnet_iters >= 0) t.lnet_iters = lnet;
    } else if (init_model) {
        hd_safetensors st = {0};
        if ((s = hd_safetensors_read(o->init_model, &st)) != HD_OK) goto done;
        hd_tensor_group g = {&t.net.table, "", t.net.params};
        s = hd_checkpoint_take(&st, o->init_model, &g);
        /* a training checkpoint given as --init also brings its discriminator */
        if (s == HD_OK && hd_safetensors_find(&st, "disc.c1.weight")) {
            hd_tensor_group d = {&t.net.disc_table, "", t.net.disc_params};
            s = hd_checkpoint_take(&st, o->init_model, &d);
        }
        hd_safetensors_free(&st);
        if (s != HD_OK) goto done;
    }
    if ((s = hd_mkdirs(o->run_dir)) != HD_OK || (s = hd_mkdirs(samples)) != HD_OK) goto done;
    if (o->resume) {
        if ((s = csv_restore(csv, t.iteration, &hist)) != HD_OK) goto done;
    } else {
        hd_atomic_file af;
        if ((s = hd_atomic_open(&af, csv)) != HD_OK) goto done;
        csv_header(af.f);
        if ((s = hd_atomic_commit(&af)) != HD_OK) goto done;
    }
    csvf = fopen(csv, "a");
    if (!csvf) {
        s = hd_fail(HD_ERR_IO, "%s: cannot open for appending", csv);
        goto done;
    }

    src.size = cfg.size;
    src.seed = t.seed;
    if ((s = hd_pair_batch_alloc(&next, batch, cfg.size)) != HD_OK) goto done;
    ld.src = &src;
    ld.batch = &next;

    double start = hd_seconds();
    hd_progress prog;
    hd_progress_start(&prog, o->stage == 1 ? "train stage 1" : "train stage 2", o->iters);
    r->iteration = t.iteration;
    if (t.iteration < o->iters) loader_start(&ld, t.iteration);
    int first_step = 1;
    while (t.iteration < o->iters) {
        if ((s = loader_wait(&ld, o->warn)) != HD_OK) goto done;
        hd_pair_batch tmp = t.batch;
        t.batch = next;
        next = tmp;
        ld.batch = &next;
        if (t.iteration + 1 < o->iters) loader_start(&ld, t.iteration + 1);
        hd_step_result res;
        s = hd_trainer_step(&t, &res, first_step ? o->dump_grads : NULL);
        first_step = 0;
        if (s != HD_OK) goto done; /* the last good checkpoint stays as it is */
        r->last = res;
        r->iteration = t.iteration;
        r->steps++;
        float row[HIST_COLS];
        for (int k = 0; k < HD_LOSS_TERMS; k++) row[k] = (float)res.terms[k];
        row[HD_LOSS_TERMS] = (float)res.total;
        row[HD_LOSS_TERMS + 1] = (float)res.disc;
        if ((s = history_push(&hist, row)) != HD_OK) goto done;
        fprintf(csvf, "%ld,%.9g", t.iteration, res.total);
        for (int k = 0; k < HD_LOSS_TERMS; k++) fprintf(csvf, ",%.9g", res.terms[k]);
        fprintf(csvf, ",%.9g,%.3f\n", res.disc, hd_seconds() - start);
        fflush(csvf);
        if (!o->quiet) {
            char extra[200];
            int len = snprintf(extra, sizeof extra, "loss %.4f rec %.4f alb %.4f n %.4f l %.4f srec %.4f adv %.3f D %.3f",
                               res.total, res.terms[HD_LOSS_REC], res.terms[HD_LOSS_ALBEDO], res.terms[HD_LOSS_NORMAL],
                               res.terms[HD_LOSS_LIGHT], res.terms[HD_LOSS_SREC], res.terms[HD_LOSS_ADV], res.disc);
            if (t.weights.w[HD_LOSS_ALBEDO_GT] > 0.0f && len > 0 && (size_t)len < sizeof extra)
                snprintf(extra + len, sizeof extra - (size_t)len, " agt %.4f", res.terms[HD_LOSS_ALBEDO_GT]);
            hd_progress_update(&prog, t.iteration, extra);
        }
        int stop_signal = o->stop && *o->stop;
        int stop_time = o->time_limit_min > 0 && hd_seconds() - start >= o->time_limit_min * 60.0;
        if (t.iteration % o->every == 0 || t.iteration == o->iters || stop_signal || stop_time) {
            if ((s = save_all(&t, ckpt, model, plot, &hist)) != HD_OK) goto done;
            char name[64];
            snprintf(name, sizeof name, "iter_%07ld.png", t.iteration);
            char *sp = hd_path_join(samples, name);
            if (!sp) {
                s = HD_ERR_NOMEM;
                goto done;
            }
            s = write_samples(sp, &t);
            free(sp);
            if (s != HD_OK) goto done;
        }
        if (stop_signal || stop_time) {
            r->end = stop_signal ? HD_TRAIN_SIGNALLED : HD_TRAIN_TIME_LIMIT;
            break;
        }
    }
    if (!o->quiet) hd_progress_finish(&prog, t.iteration, NULL);
    if (t.iteration >= o->iters && r->end == HD_TRAIN_DONE && hist.n == 0) {
        /* nothing left to do (resumed at the end): still leave a model */
        s = hd_model_write(model, &t.net.cfg, t.net.params, t.iteration, t.stage);
    }
    r->iteration = t.iteration;
done:
    if (ld.running) {
        pthread_join(ld.thread, NULL);
        ld.running = 0;
    }
    if (csvf) fclose(csvf);
    hd_model_free(init_model);
    hd_pair_batch_free(&next);
    pair_source_free(&src);
    free(hist.v);
    hd_trainer_free(&t);
    hd_dataset_free(&ds);
    free(ckpt);
    free(model);
    free(plot);
    free(csv);
    free(samples);
    return s;
}
