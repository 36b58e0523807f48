/* train.h: HD-Net training (SPEC section 4): one optimisation step on a batch of pairs (the
 * trainer), and the whole run over a SPEC section 5 folder (background loading with flips,
 * stages 1, 2a and 2b, Adam, NaN checks, checkpoints with exact resume, loss CSV and plots,
 * sample sheets, the gradient dump). */
#ifndef HD_TRAIN_H
#define HD_TRAIN_H

#include <signal.h>
#include "model/hdnet_net.h"
#include "model/losses.h"

#define HD_ADAM_BETA1 0.9f
#define HD_ADAM_BETA2 0.999f
#define HD_ADAM_EPS 1e-8f

/* The optimisation state of one run: the network, the losses' scratch, both Adams. */
typedef struct hd_trainer {
    hd_net net;
    hd_losses losses;
    hd_pair_batch batch; /* what the next step trains on (filled by the caller or the loader) */
    int micro;           /* pairs per forward pass (divides batch.pairs): the network holds 2 micro images */
    hd_pair_batch chunk; /* view of the micro-batch the network saw last (points into batch) */
    float *adam_m, *adam_v;           /* (net.table.total) */
    float *disc_adam_m, *disc_adam_v; /* (net.disc_table.total) */
    long adam_t, disc_adam_t;         /* Adam steps taken (bias correction) */
    size_t lnet_offset;               /* first float of l_net in the parameter arena */
    hd_loss_weights weights;
    float lr;
    int stage;       /* 1 or 2 */
    long lnet_iters; /* stage 2: iterations of phase 2a (L-Net only) */
    long iteration;  /* steps done */
    uint64_t seed;
    hd_rng rng;      /* checkpointed; data order is derived from (seed, iteration) */
} hd_trainer;

/* The outcome of one step. */
typedef struct hd_step_result {
    double terms[HD_LOSS_TERMS];
    double total, disc;
} hd_step_result;

/* Makes a trainer for batches of `pairs` pairs, run through the network `micro` pairs at a time
 * (0: all at once; else it must divide pairs), with parameters initialised from seed
 * (hd_train_init_params). Every loss is a mean over pairs, so micro-batches accumulate exactly
 * the gradient of the whole batch (up to the order of float sums) in less memory. */
hd_status hd_trainer_create(hd_trainer *t, const hd_net_config *cfg, int pairs, int micro, uint64_t seed);
void hd_trainer_free(hd_trainer *t);
/* Initialises HD-Net and discriminator parameters exactly as a run with this seed does. */
void hd_train_init_params(const hd_net_config *cfg, uint64_t seed, float *params, float *disc_params);
/* The phase of iteration `it`: HD_TRAIN_ALL in stage 1 and 2b, HD_TRAIN_LNET in 2a. */
hd_net_train_set hd_trainer_phase(const hd_trainer *t, long it);
/* What hd_trainer_eval computes besides the generator's losses (flags). */
typedef enum hd_eval_what {
    HD_EVAL_LOSS = 0,      /* the generator's terms and total only */
    HD_EVAL_GRAD = 1,      /* and its gradient into net.grads */
    HD_EVAL_DISC = 2,      /* and the discriminator's loss */
    HD_EVAL_DISC_GRAD = 4  /* and its gradient into net.disc_grads */
} hd_eval_what;

/* Forward and every loss on t->batch without updating, plus what `what` asks for. Fails with
 * HD_ERR_NUMERIC naming the term if a loss is not finite. */
hd_status hd_trainer_eval(hd_trainer *t, hd_step_result *r, hd_eval_what what);
/* One training step on t->batch: eval, gradient checks (naming the tensor), both Adam updates;
 * t->iteration advances. dump_path (may be NULL) writes the gradient dump of this step. */
hd_status hd_trainer_step(hd_trainer *t, hd_step_result *r, const char *dump_path);
/* Training checkpoint: parameters, Adam moments, RNG, iteration and configuration. */
hd_status hd_trainer_save(const hd_trainer *t, const char *path);
/* Restores a checkpoint written by hd_trainer_save into a trainer of the same configuration;
 * a mismatch (width, size, batch, stage) fails naming the file and both values. */
hd_status hd_trainer_load(hd_trainer *t, const char *path);

/* Why a run ended. */
typedef enum hd_train_end {
    HD_TRAIN_DONE = 0,    /* reached the iteration count */
    HD_TRAIN_TIME_LIMIT,  /* stopped at --time-limit (checkpoint written) */
    HD_TRAIN_SIGNALLED    /* stopped by SIGINT/SIGTERM (checkpoint written) */
} hd_train_end;

typedef struct hd_train_options {
    const char *data_dir, *run_dir;
    int stage;             /* 1 or 2 */
    long iters;            /* iterations of this stage's run in total */
    long lnet_iters;       /* stage 2: phase 2a length; < 0: iters / 5 */
    int batch;             /* pairs; 0: 8 (or the checkpoint's) */
    int micro_batch;       /* pairs per forward pass; 0: the checkpoint's, else hd_train_default_micro */
    int size, width;       /* 0: 256 / 48 (or the checkpoint's / the init model's) */
    int resume;
    double time_limit_min; /* 0: none */
    float lr;              /* <= 0: 1e-3 in stage 1, 1e-4 in stage 2 */
    hd_loss_weights weights;
    int prior_normals_gt;  /* N_bar from NAME.normal_gt.png instead of NAME.normal.png (the paper's "-ft") */
    int light_target_gt;   /* l_hat = NAME.light.txt where there is one, instead of the least-squares fit */
    long every;            /* checkpoint, plot and samples every K iterations */
    uint64_t seed;
    const char *init_model; /* may be NULL */
    const char *dump_grads; /* may be NULL */
    volatile sig_atomic_t *stop; /* set by a signal handler (may be NULL) */
    void (*warn)(const char *message); /* skipped images and the like (may be NULL) */
    int quiet;             /* no progress line */
} hd_train_options;

typedef struct hd_train_result {
    hd_train_end end;
    long iteration;
    long steps; /* taken by this call (0 when a resumed run was already done) */
    hd_step_result last;
} hd_train_result;

/* The micro-batch a run takes when none is given: the most pairs per forward pass (a divisor of
 * pairs) whose estimated memory stays within about 6 GB, so that the default batch of 8 pairs at
 * 256 x 256, width 48 trains in 8 GB (2 pairs at a time); small configurations take the whole batch. */
int hd_train_default_micro(const hd_net_config *cfg, int pairs);
/* Defaults of every option (stage 1, gt weights, ...). */
void hd_train_defaults(hd_train_options *o);
hd_status hd_train(const hd_train_options *o, hd_train_result *r);

#endif /* HD_TRAIN_H */
