/* train_log.h: what a training run leaves to look at: loss.csv (every term, every iteration),
 * loss.png (the curves) and the sample sheets samples/iter_N.png. */
#ifndef HD_TRAIN_LOG_H
#define HD_TRAIN_LOG_H

#include <stdio.h>
#include "train/trainer.h"

#define HD_TRAIN_LOG_COLS (HD_LOSS_TERMS + 2)

typedef struct hd_train_log {
    long n, cap;
    float *v;  /* n rows of HD_TRAIN_LOG_COLS values (the terms, total, disc) */
    FILE *csv; /* loss.csv, open for appending */
} hd_train_log;

/* Opens loss.csv: a fresh one with its header, or (resume) the rows up to `iteration` kept (a
 * resumed run continues from its checkpoint) and loaded into the history. */
hd_status hd_train_log_open(hd_train_log *log, const char *csv_path, int resume, long iteration);
/* Appends the row of an iteration, `seconds` into the run. */
hd_status hd_train_log_add(hd_train_log *log, long iteration, const hd_step_result *r, double seconds);
/* The loss curves: log10 of the weighted total (black) and of each unweighted term (colours),
 * averaged over buckets of iterations, on a white 900 x 460 canvas with a grid per decade, both
 * axes labelled and a legend. */
hd_status hd_train_log_plot(const hd_train_log *log, const char *path);
void hd_train_log_close(hd_train_log *log);

/* The sample sheet of the trainer's last forward: per image of the first pairs (at most 4 rows),
 * input | albedo | shading | normal | reconstruction | relit (A * s(N, light of its pair partner)). */
hd_status hd_train_write_samples(const hd_trainer *t, const char *path);

#endif /* HD_TRAIN_LOG_H */
