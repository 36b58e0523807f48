/* train.c: a whole training run (hd_train): the options' defaults, the run's configuration (from
 * the options, a resumed checkpoint or an --init model, read once), the start state, then the loop:
 * the loader fills batch t+1 while step t runs, each step is logged, and every K iterations (and
 * at a stop) the checkpoint, the model, the loss plot and a sample sheet are written. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "train/train.h"
#include "model/checkpoint.h"
#include "train/train_log.h"
#include "io/safetensors.h"

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
    o->stage = HD_TRAIN_STAGE_1;
    o->iters = HD_TRAIN_DEFAULT_ITERS;
    o->lnet_iters = -1;
    o->every = HD_TRAIN_DEFAULT_EVERY;
    o->seed = HD_TRAIN_DEFAULT_SEED;
    o->shading_mean = HD_SHADING_MEAN_DEFAULT;
    o->real_share = 0.5f;
    o->real_weight = 1.0f;
    hd_loss_weights_preset(HD_TRAIN_DEFAULT_WEIGHTS, &o->weights);
}

/* The files of a run folder. */
typedef struct run_paths {
    char *ckpt, *model, *plot, *csv, *samples;
} run_paths;

static hd_status run_paths_make(run_paths *p, const char *run_dir)
{
    p->ckpt = hd_path_join(run_dir, "checkpoint.safetensors");
    p->model = hd_path_join(run_dir, "model.safetensors");
    p->plot = hd_path_join(run_dir, "loss.png");
    p->csv = hd_path_join(run_dir, "loss.csv");
    p->samples = hd_path_join(run_dir, "samples");
    return p->ckpt && p->model && p->plot && p->csv && p->samples ? HD_OK : HD_ERR_NOMEM;
}

static void run_paths_free(run_paths *p)
{
    free(p->ckpt);
    free(p->model);
    free(p->plot);
    free(p->csv);
    free(p->samples);
}

/* Scans the data and lists its pairs (stage 1 leaves out, and reports, images without prior normals). */
static hd_status open_data(const hd_train_options *o, hd_dataset *ds, hd_pair_source *src)
{
    hd_status s = hd_dataset_scan(o->data_dir, ds, o->warn);
    if (s != HD_OK) return s;
    int stage1 = o->stage == HD_TRAIN_STAGE_1, skipped, first_skipped;
    if ((s = hd_pair_source_init(src, ds, stage1, o->prior_normals_gt, &skipped, &first_skipped)) != HD_OK) return s;
    src->albedo_gt = o->weights.w[HD_LOSS_ALBEDO_GT] > 0.0f;
    src->light_gt = o->light_target_gt;
    src->camera_gain = o->rec_gain == HD_REC_GAIN_CAMERA;
    if (skipped && o->warn) {
        char msg[600];
        snprintf(msg, sizeof msg, "stage 1 needs coarse normals: %d image(s) without NAME.normal.png left out (first: %s)",
                 skipped, ds->samples[first_skipped].image);
        o->warn(msg);
    }
    if (hd_pair_source_count(src) < 1)
        return hd_fail(HD_ERR_ARG, "%s: no pairs to train on (a subject folder needs at least two images%s)", o->data_dir,
                       stage1 ? " with coarse normals" : "");
    return HD_OK;
}

/* The second domain (--real): its own coarse normals as N_bar, no ground truth read. */
static hd_status open_real(const hd_train_options *o, hd_dataset *ds, hd_pair_source *src)
{
    hd_status s = hd_dataset_scan(o->real_dir, ds, o->warn);
    if (s != HD_OK) return s;
    int stage1 = o->stage == HD_TRAIN_STAGE_1, skipped, first_skipped;
    if ((s = hd_pair_source_init(src, ds, stage1, 0, &skipped, &first_skipped)) != HD_OK) return s;
    if (skipped && o->warn) {
        char msg[600];
        snprintf(msg, sizeof msg, "stage 1 needs coarse normals: %d real image(s) without NAME.normal.png left out (first: %s)",
                 skipped, ds->samples[first_skipped].image);
        o->warn(msg);
    }
    if (hd_pair_source_count(src) < 1 && !(o->mirror_pairs && src->use_start[ds->subject_count] > 0))
        return hd_fail(HD_ERR_ARG, "%s: no real pairs to train on (a subject folder needs two images, or --mirror-pairs)",
                       o->real_dir);
    return HD_OK;
}

/* The run's starting point: the checkpoint to resume or the --init file, read once. */
typedef struct run_start {
    hd_safetensors st; /* the checkpoint (resume) or the --init file; empty for a fresh start */
    const char *path;
    hd_net_config cfg;
    int batch, micro;
    uint64_t seed;
} run_start;

static hd_status read_start(const hd_train_options *o, const char *ckpt, run_start *rs)
{
    hd_net_config cfg = {o->width, o->size};
    int batch = o->batch, micro = o->micro_batch;
    uint64_t seed = o->seed;
    hd_status s = HD_OK;
    if (o->resume) {
        rs->path = ckpt;
        if ((s = hd_safetensors_read(ckpt, &rs->st)) != HD_OK) {
            char why[400];
            snprintf(why, sizeof why, "%s", hd_error());
            return hd_fail(s, "cannot resume: %s", why);
        }
        hd_net_config c;
        long long b = 0, sd = 0;
        if ((s = hd_checkpoint_config(&rs->st, ckpt, &c)) != HD_OK ||
            (s = hd_checkpoint_meta_long(&rs->st, ckpt, "batch", &b)) != HD_OK ||
            (s = hd_checkpoint_meta_long(&rs->st, ckpt, "seed", &sd)) != HD_OK)
            return s;
        const char *mb = hd_safetensors_meta(&rs->st, "micro_batch");
        if (!micro && mb && !batch) micro = atoi(mb); /* the same split sums in the same order */
        if (!cfg.width) cfg.width = c.width;
        if (!cfg.size) cfg.size = c.size;
        if (!batch) batch = (int)b;
        seed = (uint64_t)sd;
    } else if (o->init_model) {
        rs->path = o->init_model;
        hd_net_config c;
        if ((s = hd_safetensors_read(o->init_model, &rs->st)) != HD_OK ||
            (s = hd_checkpoint_config(&rs->st, o->init_model, &c)) != HD_OK)
            return s;
        if (cfg.width && cfg.width != c.width)
            return hd_fail(HD_ERR_ARG, "%s: configuration mismatch: the model has width %d, --width asks %d", o->init_model,
                           c.width, cfg.width);
        cfg.width = c.width;
        if (!cfg.size) cfg.size = c.size; /* the weights do not depend on the size */
    }
    if (!cfg.width) cfg.width = HD_TRAIN_DEFAULT_WIDTH;
    if (!cfg.size) cfg.size = HD_TRAIN_DEFAULT_SIZE;
    if (!batch) batch = HD_TRAIN_DEFAULT_BATCH;
    if ((s = hd_net_config_check(&cfg)) != HD_OK) return s;
    int R = o->reducer.ranks > 1 ? o->reducer.ranks : 1;
    if (batch % R)
        return hd_fail(HD_ERR_ARG, "a batch of %d pairs does not divide among %d ranks", batch, R);
    /* a checkpoint's micro-batch that does not divide among this run's ranks gives way */
    if (micro && micro != o->micro_batch && (batch % micro || (batch / micro) % R)) micro = 0;
    if (!micro) micro = hd_train_default_micro(&cfg, batch / R);
    if (batch % micro == 0 && (batch / micro) % R)
        return hd_fail(HD_ERR_ARG, "a batch of %d pairs in micro-batches of %d is %d micro-batches, which do not divide "
                       "among %d ranks (the batch must divide by ranks x micro-batch)", batch, micro, batch / micro, R);
    rs->cfg = cfg;
    rs->batch = batch;
    rs->micro = micro;
    rs->seed = seed;
    return HD_OK;
}

/* Makes the trainer of the run and puts it in its start state. */
static hd_status start_trainer(const hd_train_options *o, run_start *rs, hd_trainer *t)
{
    hd_status s = hd_trainer_create(t, &rs->cfg, rs->batch, rs->micro, rs->seed);
    if (s != HD_OK) return s;
    t->red = o->reducer;
    t->weights = o->weights;
    t->losses.shading_mean = o->shading_mean;
    t->losses.shading_mean_pair = o->shading_mean_pair;
    t->losses.light_from_image = o->light_target_image;
    t->losses.prior_predicted = o->shading_prior_predicted;
    if (o->light_fit_skin && (s = hd_losses_fit_skin_only(&t->losses)) != HD_OK) return s;
    if (o->weights.w[HD_LOSS_FIT_PAIR] > 0 && (s = hd_losses_fit_pair_on(&t->losses)) != HD_OK) return s;
    if (o->light_target_face && (s = hd_losses_light_from_face(&t->losses)) != HD_OK) return s;
    t->shading_prior_iters = o->shading_prior_iters;
    t->stage = o->stage;
    t->lr = o->lr > 0 ? o->lr : o->stage == HD_TRAIN_STAGE_1 ? HD_TRAIN_DEFAULT_LR_STAGE1 : HD_TRAIN_DEFAULT_LR_STAGE2;
    t->lnet_lr = o->stage == HD_TRAIN_STAGE_2 ? o->lnet_lr : 0.0f;
    t->lnet_iters = 0;
    if (o->stage == HD_TRAIN_STAGE_2) t->lnet_iters = o->lnet_iters >= 0 ? o->lnet_iters : o->iters / HD_TRAIN_DEFAULT_LNET_SHARE;
    if (o->resume) {
        long lnet = t->lnet_iters;
        if ((s = hd_trainer_restore(t, &rs->st, rs->path)) != HD_OK) return s;
        if (o->stage == HD_TRAIN_STAGE_2 && o->lnet_iters >= 0) t->lnet_iters = lnet;
    } else if (o->init_model) {
        hd_tensor_group g = {&t->net.table, "", t->net.params};
        if ((s = hd_checkpoint_take(&rs->st, rs->path, &g)) != HD_OK) return s;
        /* a training checkpoint given as --init also brings its discriminator */
        if (hd_safetensors_find(&rs->st, "disc.c1.weight")) {
            hd_tensor_group d = {&t->disc.table, "", t->disc.params};
            if ((s = hd_checkpoint_take(&rs->st, rs->path, &d)) != HD_OK) return s;
        }
    }
    return HD_OK;
}

/* Writes the checkpoint, the inference model, the plot and the sample sheet of iteration t. */
static hd_status save_all(const hd_trainer *t, const run_paths *p, const hd_train_log *log)
{
    hd_status s = hd_trainer_save(t, p->ckpt);
    if (s == HD_OK) s = hd_model_write(p->model, &t->net.cfg, t->net.params, t->iteration, t->stage);
    if (s == HD_OK) s = hd_train_log_plot(log, p->plot);
    if (s != HD_OK) return s;
    char name[64];
    snprintf(name, sizeof name, "iter_%07ld.png", t->iteration);
    char *sp = hd_path_join(p->samples, name);
    if (!sp) return HD_ERR_NOMEM;
    s = hd_train_write_samples(t, sp);
    free(sp);
    return s;
}

static int all_finite(const float *v, size_t n)
{
    int ok = 1;
    for (size_t i = 0; i < n; i++) ok &= isfinite(v[i]) != 0;
    return ok;
}

/* A step whose loss is not finite (as the float32 the model trains in), or that left the weights
 * or Adam's moments non-finite (a huge gradient overflows the second moment first), stops
 * training before anything of it is written: loss.csv, the checkpoint and the model keep the last
 * good state. */
static hd_status check_step_finite(const hd_trainer *t, const hd_step_result *res, const char *run_dir)
{
    int ok = isfinite((float)res->total) && isfinite((float)res->disc);
    for (int k = 0; k < HD_LOSS_TERMS; k++) ok = ok && isfinite((float)res->terms[k]);
    if (!ok)
        return hd_fail(HD_ERR_NUMERIC, "%s: training stopped at iteration %ld: the loss is not finite (total %g, "
                       "adversarial %g, discriminator %g); nothing of this step was written, the last checkpoint stays",
                       run_dir, t->iteration, res->total, res->terms[HD_LOSS_ADV], res->disc);
    size_t n = t->net.table.total, nd = t->disc.table.total;
    ok = all_finite(t->net.params, n) && all_finite(t->adam_m, n) && all_finite(t->adam_v, n);
    if (ok && nd && t->disc.params) ok = all_finite(t->disc.params, nd);
    if (ok && nd && t->disc_adam_m) ok = all_finite(t->disc_adam_m, nd) && all_finite(t->disc_adam_v, nd);
    if (!ok)
        return hd_fail(HD_ERR_NUMERIC, "%s: training stopped at iteration %ld: the weights or the optimizer state "
                       "became not finite (loss %g); nothing of this step was written, the last checkpoint stays",
                       run_dir, t->iteration, res->total);
    return HD_OK;
}

/* Steps until the iteration count, a signal or the time limit. */
/* Whether any rank was asked to stop (a signal, its time limit): every rank stops at the same
 * iteration, with rank 0's checkpoint. */
static hd_status agree_stop(const hd_trainer *t, int *stop_signal, int *stop_time)
{
    if (t->red.ranks <= 1) return HD_OK;
    double v[2] = {*stop_signal, *stop_time};
    hd_status s = t->red.sum_doubles(t->red.ctx, v, 2);
    *stop_signal = v[0] > 0;
    *stop_time = !*stop_signal && v[1] > 0;
    return s;
}

static hd_status run_loop(const hd_train_options *o, hd_trainer *t, hd_loader *ld, hd_pair_batch *next,
                          const run_paths *p, hd_train_log *log, hd_train_result *r)
{
    int writer = t->red.ranks <= 1 || t->red.rank == 0; /* rank 0 alone writes and reports */
    double start = hd_seconds();
    hd_train_progress prog = {o->stage, 0, o->iters, NULL, t->weights.w[HD_LOSS_ALBEDO_GT] > 0.0f, 0};
    if (t->iteration < o->iters) hd_loader_start(ld, t->iteration);
    int first_step = 1;
    hd_status s;
    while (t->iteration < o->iters) {
        if ((s = hd_loader_wait(ld, o->warn)) != HD_OK) return s;
        hd_pair_batch tmp = t->batch;
        t->batch = *next;
        *next = tmp;
        if (t->iteration + 1 < o->iters) hd_loader_start(ld, t->iteration + 1);
        hd_step_result res;
        s = hd_trainer_step(t, &res, first_step ? o->dump_grads : NULL);
        first_step = 0;
        if (s != HD_OK) return s; /* the last good checkpoint stays as it is */
        if ((s = check_step_finite(t, &res, o->run_dir)) != HD_OK) return s;
        r->last = res;
        r->iteration = t->iteration;
        r->steps++;
        if (writer && (s = hd_train_log_add(log, t->iteration, &res, hd_seconds() - start)) != HD_OK) return s;
        if (writer && o->progress) {
            prog.iteration = t->iteration;
            prog.step = &r->last;
            o->progress(&prog, o->progress_user);
        }
        int stop_signal = o->stop && *o->stop;
        int stop_time = o->time_limit_min > 0 && hd_seconds() - start >= o->time_limit_min * 60.0;
        if ((s = agree_stop(t, &stop_signal, &stop_time)) != HD_OK) return s;
        if (writer && (t->iteration % o->every == 0 || t->iteration == o->iters || stop_signal || stop_time))
            if ((s = save_all(t, p, log)) != HD_OK) return s;
        if (stop_signal || stop_time) {
            r->end = stop_signal ? HD_TRAIN_SIGNALLED : HD_TRAIN_TIME_LIMIT;
            break;
        }
    }
    if (writer && o->progress) {
        prog.finished = 1;
        o->progress(&prog, o->progress_user);
    }
    return HD_OK;
}

hd_status hd_train(const hd_train_options *o, hd_train_result *r)
{
    memset(r, 0, sizeof *r);
    if (o->stage != HD_TRAIN_STAGE_1 && o->stage != HD_TRAIN_STAGE_2)
        return hd_fail(HD_ERR_ARG, "stage must be 1 or 2, not %d", (int)o->stage);
    if (o->iters < 1) return hd_fail(HD_ERR_ARG, "the iteration count must be positive");
    if (o->every < 1) return hd_fail(HD_ERR_ARG, "--every must be positive");
    hd_dataset ds = {0}, rds = {0};
    hd_pair_source src = {0}, real = {0};
    run_paths paths = {0};
    run_start rs = {0};
    hd_trainer t = {0};
    hd_train_log log = {0};
    hd_pair_batch next = {0};
    hd_loader ld = {0};
    hd_status s;
    int lock_fd = -1, made_samples = 0;
    int writer = o->reducer.ranks <= 1 || o->reducer.rank == 0; /* rank 0 alone writes the run folder */
    if ((s = run_paths_make(&paths, o->run_dir)) != HD_OK || (s = open_data(o, &ds, &src)) != HD_OK ||
        (o->real_dir && (s = open_real(o, &rds, &real)) != HD_OK))
        goto done;
    /* one writer per run folder; temporaries of killed runs go */
    if (writer) {
        if ((s = hd_mkdirs(o->run_dir)) != HD_OK || (s = hd_lock_folder(o->run_dir, &lock_fd)) != HD_OK) goto done;
        hd_remove_stale_temporaries(o->run_dir);
        if (hd_is_dir(paths.samples)) hd_remove_stale_temporaries(paths.samples);
    }
    if ((s = read_start(o, paths.ckpt, &rs)) != HD_OK || (s = start_trainer(o, &rs, &t)) != HD_OK) goto done;
    hd_safetensors_free(&rs.st); /* read once: the trainer holds what it needed */
    made_samples = writer && !hd_is_dir(paths.samples);
    if (writer && ((s = hd_mkdirs(paths.samples)) != HD_OK ||
                   (s = hd_train_log_open(&log, paths.csv, o->resume, t.iteration)) != HD_OK))
        goto done;
    src.size = real.size = rs.cfg.size;
    src.seed = real.seed = t.seed;
    if ((s = hd_pair_batch_alloc(&next, rs.batch, rs.cfg.size)) != HD_OK) goto done;
    ld.src = &src;
    if (o->real_dir) {
        ld.real = &real;
        ld.real_share = o->real_share;
        ld.real_weight = o->real_weight;
        ld.mirror = o->mirror_pairs;
        ld.real_same_light = o->real_same_light;
    }
    ld.batch = &next;
    hd_trainer_share(&t, &ld.first, &ld.count);
    r->iteration = t.iteration;
    if ((s = run_loop(o, &t, &ld, &next, &paths, &log, r)) != HD_OK) goto done;
    if (writer && t.iteration >= o->iters && r->end == HD_TRAIN_DONE && log.n == 0) {
        /* nothing left to do (resumed at the end): still leave a model */
        s = hd_model_write(paths.model, &t.net.cfg, t.net.params, t.iteration, t.stage);
    }
    r->iteration = t.iteration;
done:
    hd_loader_stop(&ld);
    hd_train_log_close(&log);
    if (writer && s != HD_OK && r->steps == 0 && !o->resume && paths.csv && paths.samples) {
        /* nothing trained: no header-only loss.csv, no empty samples/ */
        unlink(paths.csv);
        if (made_samples) rmdir(paths.samples);
    }
    hd_unlock_folder(lock_fd);
    hd_pair_batch_free(&next);
    hd_safetensors_free(&rs.st);
    hd_pair_source_free(&src);
    hd_pair_source_free(&real);
    hd_trainer_free(&t);
    hd_dataset_free(&ds);
    hd_dataset_free(&rds);
    run_paths_free(&paths);
    return s;
}
