/* train_data.h: the training data: a batch of pairs as the networks see it, and the pairs a run
 * draws from a SPEC section 5 folder. Each iteration's pairs, order within a pair and flips come
 * from (seed, iteration) alone, so a background thread (the loader) fills batch t+1 while step t
 * runs and a resumed run sees exactly the same data. */
#ifndef HD_TRAIN_DATA_H
#define HD_TRAIN_DATA_H

#include <pthread.h>
#include "core/core.h"
#include "io/dataset.h"

/* The most pairs a batch may hold (the data streams of a batch's slots are numbered below it). */
#define HD_TRAIN_MAX_PAIRS 1024

/* A batch of pairs as the networks see it (weight may be NULL in a view: all 1). */
typedef struct hd_pair_batch {
    int pairs, size;
    float *image;         /* (B, 3, HW) */
    float *mask;          /* (B, HW), 1 where absent */
    float *coarse_normal; /* (B, 3, HW), 0 where absent */
    unsigned char *has_normal; /* (B) */
    float *albedo_gt;          /* (B, 3, HW) ground-truth albedo, 0 where absent */
    unsigned char *has_albedo; /* (B) */
    float *light_gt;           /* (B, 9) ground-truth light: l_hat where has_light (not the paper's) */
    unsigned char *has_light;  /* (B) */
    float *weight;             /* (B) domain weight of the image: multiplies its part of every term but
                                * L_adv (a pair term takes image i's); 1 unless set (mixed batches) */
    unsigned char *pair_light; /* (P) how the pair's two lights relate, an hd_pair_light; NULL in a view:
                                * HD_PAIR_LIGHT_NONE (not the paper's; read by L_lpair only) */
    float *camera_gain;        /* (B, 3) the colour gain g the camera put on the image (NAME.camera.txt,
                                * with --rec-gain camera), 1 where none; NULL in a view: all 1. L_Irec
                                * compares A * S * g with I (not the paper's) */
} hd_pair_batch;

/* How the two lights of a pair relate, where the data says so (L_lpair, not the paper's). */
typedef enum hd_pair_light {
    HD_PAIR_LIGHT_NONE = 0, /* unknown or different (synthetic pairs, real pairs by default) */
    HD_PAIR_LIGHT_SAME,     /* one light: two photos of one person in one studio (--real-same-light) */
    HD_PAIR_LIGHT_MIRROR    /* l_j = mirror(l_i): a photo and its own mirror image (--mirror-pairs) */
} hd_pair_light;

/* (defined in losses.c, for now) */
hd_status hd_pair_batch_alloc(hd_pair_batch *b, int pairs, int size);
void hd_pair_batch_free(hd_pair_batch *b);

/* The pairs of a dataset: every unordered pair of usable images of one subject. */
typedef struct hd_pair_source {
    const hd_dataset *ds;
    int *use;       /* the usable samples (with prior normals when those are required), by subject */
    int *use_start; /* subject s uses use[use_start[s] .. use_start[s + 1]) */
    long *cum;      /* cum[s] = pairs in subjects before s; cum[subject_count] = all pairs */
    int size;
    int require_prior; /* every image needs its prior normals N_bar (stage 1) */
    int prior_gt;  /* the prior normals N_bar are the ground-truth normals (NAME.normal_gt.png) */
    int albedo_gt; /* load the ground-truth albedo (NAME.albedo.png) for the albedo_gt term */
    int light_gt;  /* l_hat is the ground-truth light (NAME.light.txt) where there is one */
    int camera_gain; /* read each image's colour gain from NAME.camera.txt where there is one (else 1) */
    uint64_t seed;
} hd_pair_source;

/* Lists the usable samples and counts the pairs; *skipped = samples left out for want of prior
 * normals (the first of them in *first_skipped, else -1). */
hd_status hd_pair_source_init(hd_pair_source *src, const hd_dataset *ds, int require_prior, int prior_gt, int *skipped,
                              int *first_skipped);
void hd_pair_source_free(hd_pair_source *src);
/* All pairs of the source. */
long hd_pair_source_count(const hd_pair_source *src);

/* Fills a batch in the background. */
typedef struct hd_loader {
    const hd_pair_source *src;
    const hd_pair_source *real; /* the second domain (aligned photos, no ground truth), or NULL */
    float real_share;           /* probability that a pair comes from real */
    float real_weight;          /* the domain weight of real pairs (synthetic ones: 1) */
    int mirror;                 /* a real pair is, with probability 1/2, a photo and its mirror image */
    int real_same_light;        /* the real pairs of one person share one light (HD_PAIR_LIGHT_SAME) */
    hd_pair_batch *batch;
    long iteration;
    int first, count; /* the slots to fill (count 0: the whole batch) */
    hd_status status;
    char error[512];
    char warnings[2048]; /* whole lines only; the ones that did not fit are counted */
    int warnings_dropped;
    pthread_t thread;
    int running;
} hd_loader;

/* Starts filling L->batch with the pairs of `iteration` (in the foreground if no thread starts). */
void hd_loader_start(hd_loader *L, long iteration);
/* Waits for the batch; the pairs skipped on the way (unreadable files, replaced by the next draw)
 * go to warn (may be NULL). Fails with the reason of a batch that could not be filled. */
hd_status hd_loader_wait(hd_loader *L, void (*warn)(const char *));
/* Waits for a running loader and drops its batch (the end of a run, also after a failure). */
void hd_loader_stop(hd_loader *L);

#endif /* HD_TRAIN_DATA_H */
