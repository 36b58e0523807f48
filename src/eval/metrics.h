/* metrics.h: internal to src/eval (and its tests): the SPEC section 7 metrics' accumulators behind
 * hd_eval_run (metrics.c: accumulate image by image into hd_eval_sums, then read the row) and the
 * lighting classification's k-means (kmeans.c). */
#ifndef HD_EVAL_METRICS_H
#define HD_EVAL_METRICS_H

#include "eval/eval.h"

#define HD_EVAL_KMEANS_K 10
#define HD_EVAL_KMEANS_SEED 20240601u

typedef struct hd_eval_sums {
    double normal_sum, normal_sum2; /* angular error, degrees */
    long normal_n, normal_under[HD_EVAL_THRESHOLDS];
    double albedo_abs, albedo_sq;   /* over pixels x 3 channels */
    long albedo_n;
    double albedo_si_abs;           /* |k A - A_gt| with each image's best scale k (same count) */
    double recon_abs, recon_sq;
    long recon_n;
    double shading_abs;
    long shading_n;
} hd_eval_sums;

/* Each adds the masked pixels of one image (planar maps of npix pixels; mask may be NULL = all).
 * Normals: angle between unit vectors, atan2(|a x b|, a . b) (exact near 0). Albedo and
 * reconstruction: |p - t| and (p - t)^2 per channel (3 channels); the reconstruction is clamped to
 * [0, 1] first, as a picture is. Shading: |p - t|. The albedo also adds the scale-invariant error
 * |k p - t|, k >= 0 the image's scale that minimises it (the weighted median of t / p, weights |p|),
 * as intrinsic-image benchmarks score an albedo whose overall brightness is free. */
void hd_eval_add_normals(hd_eval_sums *sums, const float *pred, const float *gt, const float *mask, int npix);
void hd_eval_add_albedo(hd_eval_sums *sums, const float *pred, const float *gt, const float *mask, int npix);
void hd_eval_add_recon(hd_eval_sums *sums, const float *pred, const float *input, const float *mask, int npix);
void hd_eval_add_shading(hd_eval_sums *sums, const float *pred, const float *gt, const float *mask, int npix);
/* Fills the metric columns that received pixels (sets has_*); leaves name and light alone. */
void hd_eval_row_from_sums(const hd_eval_sums *sums, hd_eval_row *row);

/* k-means (k-means++ seeding from `seed`, then Lloyd's iterations until no point moves, at most
 * max_iter) of n points of dim floats. centroids (k, dim) and assign (n) are filled. Ties go to the
 * lower centroid index. k is clamped to n. */
hd_status hd_kmeans(const float *points, int n, int dim, int k, uint64_t seed, int max_iter, float *centroids,
                    int *assign);
/* Lighting classification: k-means on the ground-truth lights (n, 9); each predicted light goes to
 * its nearest centroid; the percentage that lands in its ground-truth light's cluster. */
hd_status hd_eval_light_accuracy(const float *gt, const float *pred, int n, int k, uint64_t seed, double *accuracy);

#endif /* HD_EVAL_METRICS_H */
