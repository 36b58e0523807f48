/* bench.h: what `hdnet bench` measures, shared between the engine part (tools/cmd_bench.c: SGEMM
 * peak, per-layer convolutions, Common-Net) and the whole-network part (tools/bench_hdnet.c:
 * HD-Net forward per image, training step per pair, peak memory) and the alignment part
 * (tools/bench_align.c: alignment time per photo) and the photo throughput part
 * (tools/bench_photos.c: photos per second end to end). */
#ifndef HD_BENCH_H
#define HD_BENCH_H

#include <stdio.h>

typedef struct bench_args {
    int size, batch, threads, width, json, repeats;
    const char *data; /* --profile: a training set whose loading to time, or NULL */
    double sgemm_peak_gflops; /* measured first by cmd_bench.c */
    FILE *out;                /* where the human-readable table goes */
} bench_args;

/* Each section prints its table (or, with json, one JSON object member per figure, as
 * `"key": value,` lines) and returns 0, or nonzero on failure. A section whose file is not
 * linked in is skipped (weak symbols). */
int bench_hdnet(const bench_args *a) __attribute__((weak));
int bench_align(const bench_args *a) __attribute__((weak));
int bench_photos(const bench_args *a) __attribute__((weak));
/* `hdnet bench --profile`: a training step at a->size, a->width, a->batch pairs split into phases
 * (tools/bench_profile.c). */
int bench_profile(const bench_args *a) __attribute__((weak));
/* The engine's instruction set, convolution path and precision, one line (bench_profile.c). */
void bench_print_engine(FILE *o, int json);

/* Shared by the sections (bench_align.c): the bundled photo examples/astronaut.png (., or beside
 * the executable; its path into path), and the median of n values (sorts v). */
#include "hdnet.h"
hd_status bench_read_photo(hd_image *photo, char *path, size_t cap);
double bench_median(double *v, int n);
/* A synthetic batch: smooth colours, a round mask, normals of a sphere (bench_hdnet.c). */
struct hd_pair_batch;
void bench_fill_batch(struct hd_pair_batch *b);

#endif /* HD_BENCH_H */
