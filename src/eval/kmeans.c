/* kmeans.c: k-means with k-means++ seeding (Arthur and Vassilvitskii 2007), and the paper's
 * lighting classification: cluster the ground-truth lights of a set, then count how many
 * predicted lights fall into the cluster of their ground-truth light. Deterministic for a seed:
 * distances in double, ties to the lower index. */
#include <float.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "eval/metrics.h"
#include "eval/eval.h"

static double dist2(const float *a, const float *b, int dim)
{
    double d = 0;
    for (int j = 0; j < dim; j++) {
        double e = (double)a[j] - (double)b[j];
        d += e * e;
    }
    return d;
}

/* Index of the centroid nearest to p (the lower index on ties). */
static int nearest(const float *p, const float *centroids, int k, int dim)
{
    int best = 0;
    double bd = DBL_MAX;
    for (int c = 0; c < k; c++) {
        double d = dist2(p, centroids + (size_t)c * dim, dim);
        if (d < bd) bd = d, best = c;
    }
    return best;
}

hd_status hd_kmeans(const float *points, int n, int dim, int k, uint64_t seed, int max_iter, float *centroids,
                    int *assign)
{
    if (!points || !centroids || !assign || n < 1 || dim < 1 || k < 1 || max_iter < 0)
        return hd_fail(HD_ERR_ARG, "kmeans: bad arguments (n %d, dim %d, k %d)", n, dim, k);
    if (k > n) k = n;
    for (size_t i = 0; i < (size_t)n * dim; i++)
        if (!(points[i] == points[i]) || points[i] > FLT_MAX || points[i] < -FLT_MAX)
            return hd_fail(HD_ERR_NUMERIC, "kmeans: point %zu is not finite", i / (size_t)dim);
    double *d2 = hd_malloc((size_t)n * sizeof(double));
    double *sum = hd_malloc((size_t)k * dim * sizeof(double));
    long *count = hd_malloc((size_t)k * sizeof(long));
    if (!d2 || !sum || !count) {
        free(d2), free(sum), free(count);
        return HD_ERR_NOMEM;
    }
    hd_rng r;
    hd_rng_seed(&r, seed, 1);
    /* k-means++: the first centre uniformly, each next one with probability D(x)^2 / sum D^2 */
    int first = (int)hd_rng_below(&r, (uint32_t)n);
    memcpy(centroids, points + (size_t)first * dim, (size_t)dim * sizeof(float));
    for (int i = 0; i < n; i++) d2[i] = dist2(points + (size_t)i * dim, centroids, dim);
    for (int c = 1; c < k; c++) {
        double total = 0;
        for (int i = 0; i < n; i++) total += d2[i];
        int pick = n - 1;
        if (total > 0) {
            double u = (double)hd_rng_uniform(&r) * total, acc = 0;
            for (int i = 0; i < n; i++) {
                acc += d2[i];
                if (u < acc && d2[i] > 0) {
                    pick = i;
                    break;
                }
            }
        } else {
            pick = (int)hd_rng_below(&r, (uint32_t)n); /* all points coincide with centres */
        }
        memcpy(centroids + (size_t)c * dim, points + (size_t)pick * dim, (size_t)dim * sizeof(float));
        for (int i = 0; i < n; i++) {
            double d = dist2(points + (size_t)i * dim, centroids + (size_t)c * dim, dim);
            if (d < d2[i]) d2[i] = d;
        }
    }
    /* Lloyd: assign to the nearest centre, move each centre to its points' mean (an empty
     * cluster keeps its centre) */
    for (int i = 0; i < n; i++) assign[i] = -1;
    for (int it = 0; it <= max_iter; it++) {
        int moved = 0;
        for (int i = 0; i < n; i++) {
            int c = nearest(points + (size_t)i * dim, centroids, k, dim);
            if (c != assign[i]) assign[i] = c, moved++;
        }
        if (!moved || it == max_iter) break;
        memset(sum, 0, (size_t)k * dim * sizeof(double));
        memset(count, 0, (size_t)k * sizeof(long));
        for (int i = 0; i < n; i++) {
            count[assign[i]]++;
            for (int j = 0; j < dim; j++) sum[(size_t)assign[i] * dim + j] += points[(size_t)i * dim + j];
        }
        for (int c = 0; c < k; c++)
            if (count[c])
                for (int j = 0; j < dim; j++) centroids[(size_t)c * dim + j] = (float)(sum[(size_t)c * dim + j] / (double)count[c]);
    }
    free(d2), free(sum), free(count);
    return HD_OK;
}

hd_status hd_eval_light_accuracy(const float *gt, const float *pred, int n, int k, uint64_t seed, double *accuracy)
{
    *accuracy = 0;
    if (n < 1) return hd_fail(HD_ERR_ARG, "light accuracy: no lights");
    if (k > n) k = n;
    float *centroids = hd_malloc((size_t)k * HD_SH_COEFFS * sizeof(float));
    int *assign = hd_malloc((size_t)n * sizeof(int));
    if (!centroids || !assign) {
        free(centroids), free(assign);
        return HD_ERR_NOMEM;
    }
    hd_status st = hd_kmeans(gt, n, HD_SH_COEFFS, k, seed, 300, centroids, assign);
    if (st == HD_OK) {
        long hit = 0;
        for (int i = 0; i < n; i++) {
            const float *p = pred + (size_t)i * HD_SH_COEFFS;
            int finite = 1;
            for (int j = 0; j < HD_SH_COEFFS; j++) finite &= p[j] == p[j] && p[j] <= FLT_MAX && p[j] >= -FLT_MAX;
            if (finite) hit += nearest(p, centroids, k, HD_SH_COEFFS) == assign[i]; /* a NaN light is a miss */
        }
        *accuracy = 100.0 * (double)hit / (double)n;
    }
    free(centroids), free(assign);
    return st;
}
