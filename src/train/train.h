/* train.h: a whole HD-Net training run over a SPEC section 5 folder (hd_train): the options and
 * their defaults, stages 1, 2a and 2b, background loading, checkpoints with exact resume, the
 * training log, a stop on signal or time limit. Progress goes to a callback (the library prints
 * nothing; `hdnet train` draws the progress line). */
#ifndef HD_TRAIN_H
#define HD_TRAIN_H

#include <signal.h>
#include "train/trainer.h"

/* Why a run ended. */
typedef enum hd_train_end {
    HD_TRAIN_DONE = 0,    /* reached the iteration count */
    HD_TRAIN_TIME_LIMIT,  /* stopped at --time-limit (checkpoint written) */
    HD_TRAIN_SIGNALLED    /* stopped by SIGINT/SIGTERM (checkpoint written) */
} hd_train_end;

/* What a run reports after each step, to hd_train_options.progress. */
typedef struct hd_train_progress {
    hd_train_stage stage;
    long iteration, iters;      /* steps done in total (counting resumed ones), the run's count */
    const hd_step_result *step; /* the losses of the step just taken */
    int albedo_gt;              /* the albedo_gt term is on (its weight is positive) */
    int finished;               /* 1 on the extra call after the run's last step */
} hd_train_progress;

/* What L_Irec's A*S is compared with the image through (not the paper's). */
typedef enum hd_rec_gain {
    HD_REC_GAIN_NONE = 0, /* A*S against I (the paper's) */
    HD_REC_GAIN_CAMERA    /* A*S*g against I, g the colour gain of the image's NAME.camera.txt (light colour
                           * times white balance; 1 without one): the albedo stays the scene's (--rec-gain camera) */
} hd_rec_gain;

typedef struct hd_train_options {
    const char *data_dir, *run_dir;
    hd_train_stage stage;
    long iters;            /* iterations of this stage's run in total */
    long lnet_iters;       /* stage 2: phase 2a length; < 0: iters / 5 */
    int batch;             /* pairs; 0: 8 (or the checkpoint's) */
    int micro_batch;       /* pairs per forward pass; 0: the checkpoint's, else hd_train_default_micro */
    int size, width;       /* 0: 256 / 48 (or the checkpoint's / the init model's) */
    int resume;
    double time_limit_min; /* 0: none */
    float lr;              /* <= 0: 1e-3 in stage 1, 1e-4 in stage 2 */
    float lnet_lr;         /* stage 2: L-Net's learning rate in phase 2a; <= 0: lr */
    hd_loss_weights weights;
    int prior_normals_gt;  /* N_bar from NAME.normal_gt.png instead of NAME.normal.png (the paper's "-ft") */
    int light_target_gt;   /* l_hat = NAME.light.txt where there is one, instead of the least-squares fit */
    int light_target_image; /* l_hat fitted to the image's luminance, not to S (not the paper's) */
    int light_target_face; /* l_hat = the relighting rule's face light of S (hd_losses_light_from_face) */
    int shading_prior_predicted; /* the shading prior on the predicted normals, not N_bar (stage 2) */
    int light_fit_skin;    /* the photo's own light fitted to the skin alone (hd_losses_fit_skin_only) */
    float shading_mean;    /* c of the scale anchor (HD_SHADING_MEAN_DEFAULT) */
    int shading_mean_pair; /* the anchor on the pair's mean shading instead of each image's */
    long shading_prior_iters; /* > 0: the shading prior's weight falls linearly to 0 over these iterations */
    const char *real_dir;  /* a second set (aligned photos) mixed into every batch, or NULL */
    float real_share;      /* probability that a pair is drawn from real_dir (default 0.5) */
    float real_weight;     /* domain weight of real pairs in every term but L_adv (default 1) */
    int mirror_pairs;      /* a real pair is, half the time, one photo and its mirror image */
    int real_same_light;   /* the real pairs of one person were taken under one light (L_lpair) */
    hd_rec_gain rec_gain;  /* L_Irec through the recorded camera colour gain (default none) */
    long every;            /* checkpoint, plot and samples every K iterations */
    uint64_t seed;
    const char *init_model; /* may be NULL */
    const char *dump_grads; /* may be NULL */
    volatile sig_atomic_t *stop; /* set by a signal handler (may be NULL) */
    void (*warn)(const char *message); /* skipped images and the like (may be NULL) */
    void (*progress)(const hd_train_progress *p, void *user); /* after every step (may be NULL) */
    void *progress_user;
    /* Data-parallel training (docs/scaling.md): rank, rank count and the sum over ranks (zero:
     * alone). Every rank runs hd_train with the same options; rank 0 alone writes the run folder
     * and shows progress; the batch's micro-batches must divide among the ranks. */
    hd_reducer reducer;
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
