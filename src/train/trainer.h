/* trainer.h: the HD-Net trainer (SPEC section 4): the training stages, one optimisation step on a
 * batch of pairs (forward, losses, backward, NaN checks, both Adams), the training defaults, and
 * the trainer's state as a file (train_checkpoint.c: checkpoint, exact resume, gradient dump). */
#ifndef HD_TRAINER_H
#define HD_TRAINER_H

#include "model/hdnet_net.h"
#include "train/losses.h"
#include "train/train_data.h"

#define HD_ADAM_BETA1 0.9f
#define HD_ADAM_BETA2 0.999f
#define HD_ADAM_EPS 1e-8f

/* The training defaults, in one place (the trainer, hd_train_defaults and `hdnet train` use these). */
#define HD_TRAIN_DEFAULT_ITERS 1000
#define HD_TRAIN_DEFAULT_EVERY 100
#define HD_TRAIN_DEFAULT_SEED 1
#define HD_TRAIN_DEFAULT_BATCH 8
#define HD_TRAIN_DEFAULT_WIDTH 48
#define HD_TRAIN_DEFAULT_SIZE 256
#define HD_TRAIN_DEFAULT_WEIGHTS "gt"
#define HD_TRAIN_DEFAULT_LR_STAGE1 1e-3f
#define HD_TRAIN_DEFAULT_LR_STAGE2 1e-4f
#define HD_TRAIN_DEFAULT_LNET_SHARE 5 /* stage 2: phase 2a is iters / 5 when not given */

/* The paper's two training stages: stage 1 trains everything against the coarse normals' light;
 * stage 2 starts from stage 1's model, trains L-Net alone first (phase 2a), then everything (2b). */
typedef enum hd_train_stage {
    HD_TRAIN_STAGE_1 = 1,
    HD_TRAIN_STAGE_2 = 2
} hd_train_stage;

/* What one iteration trains: stage 1, or phase 2a / 2b of stage 2. */
typedef enum hd_train_phase {
    HD_PHASE_1 = 0,
    HD_PHASE_2A, /* L-Net only (and the discriminator) */
    HD_PHASE_2B  /* everything, with fresh Adam moments */
} hd_train_phase;

/* Data-parallel training (docs/scaling.md): this process is rank `rank` of `ranks`; it computes
 * the gradients of its share of every batch (micro-batches rank * C / ranks up to (rank + 1) * C /
 * ranks of the batch's C), and sum_floats / sum_doubles sum a buffer over every rank in place (the
 * caller's MPI_Allreduce), so that every rank takes the same Adam step. ranks <= 1: alone, and the
 * sums are not called. The library knows nothing of MPI. */
typedef struct hd_reducer {
    int rank, ranks;
    hd_status (*sum_floats)(void *ctx, float *x, size_t n);
    hd_status (*sum_doubles)(void *ctx, double *x, size_t n);
    void *ctx;
} hd_reducer;

/* The optimisation state of one run: the network and its discriminator, the losses' scratch, both
 * Adams. */
typedef struct hd_trainer {
    hd_net net;
    hd_disc disc;
    hd_losses losses;
    hd_net_pass pass;    /* how the passes run: zero for training; the benchmarks' profile, the gradient
                          * checks' hook (hdnet_net.h) */
    hd_pair_batch batch; /* what the next step trains on (filled by the caller or the loader) */
    int micro;           /* pairs per forward pass (divides batch.pairs): the network holds 2 micro images */
    hd_pair_batch chunk; /* view of the micro-batch the network saw last (points into batch) */
    float *adam_m, *adam_v;           /* (net.table.total) */
    float *disc_adam_m, *disc_adam_v; /* (disc.table.total) */
    long adam_t, disc_adam_t;         /* Adam steps taken (bias correction) */
    size_t lnet_offset;               /* first float of l_net in the parameter arena */
    hd_loss_weights weights;
    float lr;
    float lnet_lr;   /* stage 2: L-Net's learning rate in phase 2a; <= 0: lr */
    hd_train_stage stage;
    long lnet_iters; /* stage 2: iterations of phase 2a (L-Net only) */
    long shading_prior_iters; /* > 0: the shading prior's weight is w (1 - it / K), 0 from it = K on */
    long iteration;  /* steps done */
    uint64_t seed;
    hd_rng rng;      /* checkpointed; data order is derived from (seed, iteration) */
    hd_reducer red;  /* this rank's share and the sum over ranks (zero: alone) */
    double *grad_sum; /* (net.table.total + disc.table.total) the step's gradients, summed in double */
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
/* The factor of the shading prior's weight at iteration `it` (0-based): 1 - it / K over the
 * warm-up of K = shading_prior_iters iterations, then 0; always 1 when K is 0. */
float hd_trainer_prior_ramp(const hd_trainer *t, long it);
/* The phase of iteration `it` (0-based): HD_PHASE_2A for the first lnet_iters of stage 2. */
hd_train_phase hd_trainer_stage_phase(const hd_trainer *t, long it);
/* "1", "2a" or "2b". */
const char *hd_train_phase_name(hd_train_phase phase);
/* What the backward pass of iteration `it` trains: HD_TRAIN_LNET in phase 2a, else HD_TRAIN_ALL. */
hd_net_train_set hd_trainer_phase(const hd_trainer *t, long it);
/* The pairs of the batch this rank computes: [*first, *first + *count). Alone: the whole batch. */
void hd_trainer_share(const hd_trainer *t, int *first, int *count);
/* What hd_trainer_eval computes besides the generator's losses (flags). */
typedef enum hd_eval_what {
    HD_EVAL_LOSS = 0,      /* the generator's terms and total only */
    HD_EVAL_GRAD = 1,      /* and its gradient into net.grads */
    HD_EVAL_DISC = 2,      /* and the discriminator's loss */
    HD_EVAL_DISC_GRAD = 4  /* and its gradient into disc.grads */
} hd_eval_what;

/* Forward and every loss on t->batch without updating, plus what `what` asks for. Fails with
 * HD_ERR_NUMERIC naming the term if a loss is not finite. With several ranks it computes this
 * rank's share, then sums the gradients and the losses over all ranks (every rank ends with the
 * whole batch's). */
hd_status hd_trainer_eval(hd_trainer *t, hd_step_result *r, hd_eval_what what);
/* One training step on t->batch: eval, gradient checks (naming the tensor), both Adam updates;
 * t->iteration advances. dump_path (may be NULL) writes the gradient dump of this step. */
hd_status hd_trainer_step(hd_trainer *t, hd_step_result *r, const char *dump_path);
/* train_checkpoint.c. Training checkpoint: parameters, Adam moments, RNG, iteration and configuration. */
hd_status hd_trainer_save(const hd_trainer *t, const char *path);
/* Restores a checkpoint written by hd_trainer_save into a trainer of the same configuration;
 * a mismatch (width, size, batch, stage) fails naming the file and both values. */
hd_status hd_trainer_load(hd_trainer *t, const char *path);
/* The same from a checkpoint already read (path names it in errors). */
hd_status hd_trainer_restore(hd_trainer *t, const hd_safetensors *st, const char *path);
/* The gradient dump of the step just evaluated: the batch, the outputs (when the whole batch went
 * through at once), every loss, every parameter and its gradient, with the trainer's metadata. */
hd_status hd_trainer_write_dump(const hd_trainer *t, const hd_step_result *r, const char *path);

#endif /* HD_TRAINER_H */

