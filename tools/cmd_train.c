/* cmd_train.c: `hdnet train`: trains HD-Net on a SPEC section 5 folder (docs/training.md):
 * stage 1 or 2, every loss weight, learning rate, batch and iteration count as options,
 * checkpoints with exact resume, SIGINT/SIGTERM and --time-limit stop cleanly after a checkpoint. */
#include <math.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include "cli.h"
#include "hdnet_tool.h"
#include "mpi.h"

CLI_COMMAND("train", cmd_train, "train HD-Net on pairs of face images (two stages, resumable)")

static volatile sig_atomic_t stop_requested;

static void on_signal(int sig)
{
    (void)sig;
    stop_requested = 1;
}

static void warn(const char *message)
{
    if (cli_mpi_ranks() > 1)
        fprintf(stderr, "hdnet train: rank %d: warning: %s\n", cli_mpi_rank(), message);
    else
        fprintf(stderr, "hdnet train: warning: %s\n", message);
}

/* Under mpirun every rank runs this; rank 0 writes the run folder and reports. A failure on any
 * rank ends the whole job (the others would wait in the next sum forever). */
static int train_failed(hd_status s, const char *out)
{
    if (cli_mpi_ranks() > 1) {
        fprintf(stderr, "hdnet train: rank %d of %d: %s\n", cli_mpi_rank(), cli_mpi_ranks(), hd_error());
        cli_mpi_abort(CLI_EXIT_FAIL);
    } else {
        cli_report("train");
    }
    if (s == HD_ERR_NUMERIC) fprintf(stderr, "hdnet train: stopped; the last good checkpoint in %s is kept\n", out);
    return CLI_EXIT_FAIL;
}

/* The progress line: the rate, the time left and the step's main losses. */
static void on_progress(const hd_train_progress *p, void *user)
{
    cli_progress *line = user;
    if (p->finished) {
        cli_progress_finish(line, p->iteration, NULL);
        return;
    }
    const hd_step_result *r = p->step;
    char extra[200];
    int len = snprintf(extra, sizeof extra, "loss %.4f rec %.4f alb %.4f n %.4f l %.4f srec %.4f adv %.3f D %.3f",
                       r->total, r->terms[HD_LOSS_REC], r->terms[HD_LOSS_ALBEDO], r->terms[HD_LOSS_NORMAL],
                       r->terms[HD_LOSS_LIGHT], r->terms[HD_LOSS_SREC], r->terms[HD_LOSS_ADV], r->disc);
    if (p->albedo_gt && len > 0 && (size_t)len < sizeof extra)
        snprintf(extra + len, sizeof extra - (size_t)len, " agt %.4f", r->terms[HD_LOSS_ALBEDO_GT]);
    cli_progress_update(line, p->iteration, extra);
}

/* The command line of `hdnet train`: what the option table fills. */
typedef struct train_args {
    const char *data, *out, *weights, *init, *dump, *prior, *light_target, *anchor_over, *prior_on, *light_fit,
        *rec_gain, *real_dir;
    int stage, iters, batch, size, width, resume, threads, every, seed, lnet_iters, quiet, micro, prior_iters;
    int mirror, same_light;
    float time_limit, lr, lnet_lr, shading_mean, real_share, real_weight;
    float w[HD_LOSS_TERMS]; /* NAN: the weight set's */
} train_args;

/* Checks the arguments and turns them into the trainer's options (o from hd_train_defaults):
 * 0, or the usage error's exit code. */
static int train_check(const cli_cmd_spec *spec, const train_args *a, hd_train_options *o)
{
    if (!a->out) return cli_usage_error(spec, "-o RUN is required");
    if (a->stage != 1 && a->stage != 2) return cli_usage_error(spec, "--stage must be 1 or 2");
    if (a->iters < 1) return cli_usage_error(spec, "--iters must be positive");
    if (a->every < 1) return cli_usage_error(spec, "--every must be positive");
    if (a->batch < 0 || a->micro < 0 || a->size < 0 || a->width < 0 || a->threads < 0 || a->seed < 0 || a->time_limit < 0 || a->lr < 0)
        return cli_usage_error(spec, "sizes, counts, the seed, the time limit and the learning rate must not be negative");
    if (a->size && a->size % 32) return cli_usage_error(spec, "--size must be a multiple of 32");
    if (a->resume && a->init) return cli_usage_error(spec, "--resume and --init exclude each other");
    if (strcmp(a->prior, "coarse") != 0 && strcmp(a->prior, "gt") != 0)
        return cli_usage_error(spec, "--prior-normals must be coarse or gt, not '%s'", a->prior);
    if (strcmp(a->light_target, "fit") != 0 && strcmp(a->light_target, "face") != 0 && strcmp(a->light_target, "gt") != 0 &&
        strcmp(a->light_target, "image") != 0)
        return cli_usage_error(spec, "--light-target must be fit, face, gt or image, not '%s'", a->light_target);
    if (strcmp(a->prior_on, "coarse") != 0 && strcmp(a->prior_on, "predicted") != 0)
        return cli_usage_error(spec, "--shading-prior-normals must be coarse or predicted, not '%s'", a->prior_on);
    if (strcmp(a->light_fit, "face") != 0 && strcmp(a->light_fit, "skin") != 0)
        return cli_usage_error(spec, "--light-fit must be face or skin, not '%s'", a->light_fit);

    if (hd_loss_weights_preset(a->weights, &o->weights) != HD_OK) return cli_usage_error(spec, "%s", hd_error());
    for (int k = 0; k < HD_LOSS_TERMS; k++) {
        if (isnan(a->w[k])) continue;
        if (a->w[k] < 0) {
            char opt[40]; /* the option's name: the term's with '-' for '_' */
            snprintf(opt, sizeof opt, "%s", hd_loss_names[k]);
            for (char *c = opt; *c; c++)
                if (*c == '_') *c = '-';
            return cli_usage_error(spec, "--w-%s must not be negative", opt);
        }
        o->weights.w[k] = a->w[k];
    }
    o->data_dir = a->data;
    o->run_dir = a->out;
    o->stage = a->stage;
    o->iters = a->iters;
    o->lnet_iters = a->lnet_iters;
    o->batch = a->batch;
    o->micro_batch = a->micro;
    o->size = a->size;
    o->width = a->width;
    o->resume = a->resume;
    o->time_limit_min = a->time_limit;
    o->lr = a->lr;
    if (!(a->lnet_lr >= 0.0f && a->lnet_lr < 1.0f)) return cli_usage_error(spec, "--lnet-lr must be in [0, 1)");
    if (a->lnet_lr > 0.0f && a->stage != 2) return cli_usage_error(spec, "--lnet-lr goes with --stage 2 (phase 2a)");
    o->lnet_lr = a->lnet_lr;
    o->every = a->every;
    o->prior_normals_gt = strcmp(a->prior, "gt") == 0;
    o->light_target_gt = strcmp(a->light_target, "gt") == 0;
    o->light_target_image = strcmp(a->light_target, "image") == 0;
    o->light_target_face = strcmp(a->light_target, "face") == 0;
    o->shading_prior_predicted = strcmp(a->prior_on, "predicted") == 0;
    o->light_fit_skin = strcmp(a->light_fit, "skin") == 0;
    if (strcmp(a->rec_gain, "none") != 0 && strcmp(a->rec_gain, "camera") != 0)
        return cli_usage_error(spec, "--rec-gain must be none or camera, not '%s'", a->rec_gain);
    o->rec_gain = strcmp(a->rec_gain, "camera") == 0 ? HD_REC_GAIN_CAMERA : HD_REC_GAIN_NONE;
    if (!(a->shading_mean > 0.0f && a->shading_mean < 100.0f)) return cli_usage_error(spec, "--shading-mean must be in (0, 100)");
    o->shading_mean = a->shading_mean;
    if (a->prior_iters < 0) return cli_usage_error(spec, "--shading-prior-iters must not be negative");
    o->shading_prior_iters = a->prior_iters;
    if (strcmp(a->anchor_over, "image") != 0 && strcmp(a->anchor_over, "pair") != 0)
        return cli_usage_error(spec, "--shading-mean-over must be image or pair, not '%s'", a->anchor_over);
    o->shading_mean_pair = strcmp(a->anchor_over, "pair") == 0;
    if (!(a->real_share >= 0.0f && a->real_share <= 1.0f)) return cli_usage_error(spec, "--real-share must be in [0, 1]");
    if (!(a->real_weight >= 0.0f && a->real_weight < 1e6f)) return cli_usage_error(spec, "--real-weight must not be negative");
    if (a->mirror && !a->real_dir) return cli_usage_error(spec, "--mirror-pairs needs --real DIR");
    if (a->same_light && !a->real_dir) return cli_usage_error(spec, "--real-same-light needs --real DIR");
    o->real_dir = a->real_dir;
    o->real_share = a->real_share;
    o->real_weight = a->real_weight;
    o->mirror_pairs = a->mirror;
    o->real_same_light = a->same_light;
    o->seed = (uint64_t)a->seed;
    o->init_model = a->init;
    o->dump_grads = a->dump;
    o->stop = &stop_requested;
    o->warn = warn;
    return 0;
}

/* Parses the command line into a and checks it into o: -1 to go on, or the exit code. */
static int train_options(int argc, char **argv, train_args *a, hd_train_options *o)
{
    *a = (train_args){.weights = "gt", .prior = "coarse", .light_target = "fit", .anchor_over = "image",
                      .prior_on = "coarse", .light_fit = "face", .rec_gain = "none", .stage = 1, .iters = 1000,
                      .every = 100, .seed = 1, .lnet_iters = -1, .shading_mean = HD_SHADING_MEAN_DEFAULT,
                      .real_share = 0.5f, .real_weight = 1.0f};
    for (int k = 0; k < HD_LOSS_TERMS; k++) a->w[k] = NAN;
    const cli_opt opts[] = {
        {"output", 'o', CLI_OPT_STRING, &a->out, "RUN", "the run folder (model, checkpoint, loss.csv, loss.png, samples/)"},
        {"stage", 0, CLI_OPT_INT, &a->stage, "1|2", "training stage (default 1; stage 2 starts from --init RUN1/model.safetensors)"},
        {"iters", 0, CLI_OPT_INT, &a->iters, "N", "iterations of this run in total, counting resumed ones (default 1000)"},
        {"lnet-iters", 0, CLI_OPT_INT, &a->lnet_iters, "N", "stage 2: iterations training L-Net only first (default iters/5)"},
        {"batch", 0, CLI_OPT_INT, &a->batch, "B", "pairs per iteration (default 8, or the checkpoint's)"},
        {"micro-batch", 0, CLI_OPT_INT, &a->micro, "M", "pairs per forward pass, dividing B: same gradient, less memory (default: B, or what fits 6 GB)"},
        {"size", 0, CLI_OPT_INT, &a->size, "S", "model input side, a multiple of 32 (default 256, or the checkpoint's)"},
        {"width", 0, CLI_OPT_INT, &a->width, "W", "Common-Net width (default 48, or the checkpoint's / --init model's)"},
        {"resume", 0, CLI_OPT_FLAG, &a->resume, NULL, "continue RUN/checkpoint.safetensors exactly"},
        {"time-limit", 0, CLI_OPT_FLOAT, &a->time_limit, "MINUTES", "checkpoint and stop after this long"},
        CLI_OPT_THREADS_ROW(a->threads),
        {"lr", 0, CLI_OPT_FLOAT, &a->lr, "X", "learning rate (default 1e-3 in stage 1, 1e-4 in stage 2)"},
        {"lnet-lr", 0, CLI_OPT_FLOAT, &a->lnet_lr, "X", "stage 2: L-Net's learning rate in phase 2a (default: --lr)"},
        {"weights", 0, CLI_OPT_STRING, &a->weights, "gt|dpr", "loss weight set of SPEC section 4 (default gt)"},
        {"w-rec", 0, CLI_OPT_FLOAT, &a->w[HD_LOSS_REC], "X", "weight of L_Irec (gt 0.25, dpr 0.25)"},
        {"w-albedo", 0, CLI_OPT_FLOAT, &a->w[HD_LOSS_ALBEDO], "X", "weight of L_a (gt 0.25, dpr 0.15)"},
        {"w-smooth", 0, CLI_OPT_FLOAT, &a->w[HD_LOSS_SMOOTH], "X", "weight of L_s (gt 0.1, dpr 0.01)"},
        {"w-normal", 0, CLI_OPT_FLOAT, &a->w[HD_LOSS_NORMAL], "X", "weight of L_n (0.5)"},
        {"w-light", 0, CLI_OPT_FLOAT, &a->w[HD_LOSS_LIGHT], "X", "weight of L_l (0.01)"},
        {"w-srec", 0, CLI_OPT_FLOAT, &a->w[HD_LOSS_SREC], "X", "weight of L_Srec (0.01)"},
        {"w-adv", 0, CLI_OPT_FLOAT, &a->w[HD_LOSS_ADV], "X", "weight of L_adv (gt 0.001, dpr 0.0001)"},
        {"w-albedo-gt", 0, CLI_OPT_FLOAT, &a->w[HD_LOSS_ALBEDO_GT], "X",
         "not the paper's: weight of mean_m|A - A_gt| on sets with NAME.albedo.png (default 0)"},
        {"w-shading-mean", 0, CLI_OPT_FLOAT, &a->w[HD_LOSS_SHADING_MEAN], "X",
         "not the paper's: weight of the scale anchor |mean_m S - c| (default 1; 0 turns it off)"},
        {"w-shading-prior", 0, CLI_OPT_FLOAT, &a->w[HD_LOSS_SHADING_PRIOR], "X",
         "not the paper's: weight of the shading prior |S - s(N_bar, l_img)| (default 1; 0 turns it off)"},
        {"w-light-pair", 0, CLI_OPT_FLOAT, &a->w[HD_LOSS_LIGHT_PAIR], "X",
         "not the paper's: weight of L_lpair |l_j - R l_i| on mirror pairs and --real-same-light pairs (default 0)"},
        {"w-fit-pair", 0, CLI_OPT_FLOAT, &a->w[HD_LOSS_FIT_PAIR], "X",
         "not the paper's: weight of L_fpair |f_j - R f_i|, f the face's own light relighting fits to S on N,"
         " on the same pairs (default 0)"},
        {"shading-prior-iters", 0, CLI_OPT_INT, &a->prior_iters, "K",
         "the shading prior's weight falls linearly to 0 over the first K iterations (default 0: constant)"},
        {"shading-mean", 0, CLI_OPT_FLOAT, &a->shading_mean, "C",
         "the scale anchor's target mean shading over the face (default 0.8)"},
        {"shading-mean-over", 0, CLI_OPT_STRING, &a->anchor_over, "image|pair",
         "the scale anchor on each image's mean shading (default) or on the mean of the pair's two"},
        {"real", 0, CLI_OPT_STRING, &a->real_dir, "DIR",
         "a second set (aligned photos, no ground truth) whose pairs are mixed into every batch"},
        {"real-share", 0, CLI_OPT_FLOAT, &a->real_share, "F", "probability that a pair comes from --real (default 0.5)"},
        {"real-weight", 0, CLI_OPT_FLOAT, &a->real_weight, "X", "loss weight of --real pairs, every term but L_adv (default 1)"},
        {"mirror-pairs", 0, CLI_OPT_FLAG, &a->mirror, NULL, "half the --real pairs are a photo and its mirror image"},
        {"real-same-light", 0, CLI_OPT_FLAG, &a->same_light, NULL,
         "the --real photos of one person were taken under one light (their pairs get L_lpair and L_fpair)"},
        {"prior-normals", 0, CLI_OPT_STRING, &a->prior, "coarse|gt",
         "N_bar of L_n and l_hat: NAME.normal.png (default) or NAME.normal_gt.png (the paper's -ft)"},
        {"light-target", 0, CLI_OPT_STRING, &a->light_target, "fit|face|gt|image",
         "l_hat of L_l: the least-squares fit of S (default) or, not the paper's, the face's own light"
         " of S as relighting fits it (skin, lower face down-weighted, pulled toward the lobe), "
         "NAME.light.txt where present, or the fit of the image's luminance scaled to --shading-mean"
         " (no ground truth)"},
        {"shading-prior-normals", 0, CLI_OPT_STRING, &a->prior_on, "coarse|predicted",
         "not the paper's: the shading prior's normals, N_bar (default) or, in stage 2, the predicted N"},
        {"light-fit", 0, CLI_OPT_STRING, &a->light_fit, "face|skin",
         "not the paper's: the photo's own light (the shading prior's, --light-target image's) fitted"
         " to the whole face (default) or to the skin alone, without the eyes, brows and lips"},
        {"rec-gain", 0, CLI_OPT_STRING, &a->rec_gain, "none|camera",
         "not the paper's: L_Irec compares A*S with the image (default) or A*S*g, g the colour gain"
         " (light colour times white balance) of NAME.camera.txt where there is one"},
        {"every", 0, CLI_OPT_INT, &a->every, "K", "checkpoint, loss plot and sample sheet every K iterations (default 100)"},
        {"seed", 0, CLI_OPT_INT, &a->seed, "N", "seed of the initialisation and the data order (default 1)"},
        {"init", 0, CLI_OPT_STRING, &a->init, "MODEL", "start from this model (or checkpoint) instead of a fresh init"},
        {"dump-grads", 0, CLI_OPT_STRING, &a->dump, "FILE", "write the first step's batch, parameters, losses and gradients"},
        {"quiet", 'q', CLI_OPT_FLAG, &a->quiet, NULL, "print only problems (no progress line)"},
        {NULL, 0, 0, NULL, NULL, NULL},
    };
    const cli_cmd_spec spec = {
        "train", "DATA -o RUN [options]",
        "Trains HD-Net on DATA, a folder of subject folders of aligned faces with companions\n"
        "(NAME.mask.png, NAME.normal.png; stage 1 needs the coarse normals). Each iteration takes\n"
        "--batch random pairs of images of one subject (flipped together at random). RUN receives\n"
        "model.safetensors (the weights, for decompose/relight), checkpoint.safetensors (for\n"
        "--resume), loss.csv (every term, every iteration), loss.png and samples/iter_N.png\n"
        "(input | albedo | shading | normal | reconstruction | relit with the partner's light).\n"
        "Ctrl-C saves a checkpoint and stops; --resume continues exactly. See docs/training.md.",
        opts, 1, 1};
    char **pos = NULL;
    int npos = 0, code = 0;
    if (cli_opts_parse(&spec, argc, argv, &pos, &npos, &code)) return code;
    a->data = pos[0];
    free(pos);
    hd_train_defaults(o);
    code = train_check(&spec, a, o);
    return code ? code : -1;
}

int cmd_train(int argc, char **argv)
{
    train_args a;
    hd_train_options o;
    int code = train_options(argc, argv, &a, &o);
    if (code >= 0) return code;
    cli_progress line;
    cli_progress_start(&line, a.stage == 1 ? "train stage 1" : "train stage 2", a.iters);
    if (!a.quiet) {
        o.progress = on_progress;
        o.progress_user = &line;
    }
    if (a.threads) hd_set_threads(a.threads);
    if (cli_mpi_init(NULL, NULL)) return CLI_EXIT_FAIL;
    o.reducer = (hd_reducer){cli_mpi_rank(), cli_mpi_ranks(), cli_mpi_sum_floats, cli_mpi_sum_doubles, NULL};

    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sa.sa_flags = SA_RESTART; /* the loader thread's reads must not fail with EINTR */
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);

    hd_train_result r;
    double t0 = hd_seconds();
    hd_status s = hd_train(&o, &r);
    if (s != HD_OK) return train_failed(s, a.out);
    double seconds = hd_seconds() - t0;
    int rank = cli_mpi_rank(), ranks = cli_mpi_ranks();
    cli_mpi_finish();
    if (rank != 0) return r.end == HD_TRAIN_SIGNALLED ? CLI_EXIT_FAIL : CLI_EXIT_OK;
    if (ranks > 1 && r.steps > 0)
        fprintf(stderr, "hdnet train: %d ranks, %ld steps in %.2f s (%.3f s per step), %.2f s of it in MPI_Allreduce on rank 0\n",
                ranks, r.steps, seconds, seconds / (double)r.steps, cli_mpi_seconds());
    if (r.steps == 0) {
        printf("nothing to do: %s is at iteration %ld (--iters %d)\n", a.out, r.iteration, a.iters);
        return CLI_EXIT_OK;
    }
    const char *how = r.end == HD_TRAIN_TIME_LIMIT ? "time limit reached" : r.end == HD_TRAIN_SIGNALLED ? "interrupted" : "done";
    printf("%s at iteration %ld: loss %.6f (", how, r.iteration, r.last.total);
    for (int k = 0; k < HD_LOSS_TERMS; k++) printf("%s%s %.5f", k ? " " : "", hd_loss_names[k], r.last.terms[k]);
    printf(", disc %.5f); %s/checkpoint.safetensors written\n", r.last.disc, a.out);
    if (r.end == HD_TRAIN_SIGNALLED) {
        fprintf(stderr, "hdnet train: stopped by a signal; continue with --resume\n");
        return CLI_EXIT_FAIL;
    }
    return CLI_EXIT_OK;
}
