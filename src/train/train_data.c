/* train_data.c: the training data (train_data.h): the batch itself (hd_pair_batch_alloc/free),
 * the pairs of a dataset, pair q of (seed, iteration), loading one sample into a batch slot
 * (resized, masked where it has no normal, flipped with its normals and light, with its camera's
 * colour gain), and the loader
 * thread that fills the next batch. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "train/train_data.h"
#include "light/light.h"

#define HD_DATA_STREAM 0x5eedda7aULL
#define HD_LOAD_RETRIES 32

hd_status hd_pair_batch_alloc(hd_pair_batch *b, int pairs, int size)
{
    memset(b, 0, sizeof *b);
    size_t B = 2 * (size_t)pairs, HW = (size_t)size * size;
    b->pairs = pairs;
    b->size = size;
    b->image = hd_calloc(B * 3 * HW, sizeof(float));
    b->mask = hd_calloc(B * HW, sizeof(float));
    b->coarse_normal = hd_calloc(B * 3 * HW, sizeof(float));
    b->has_normal = hd_calloc(B, 1);
    b->albedo_gt = hd_calloc(B * 3 * HW, sizeof(float));
    b->has_albedo = hd_calloc(B, 1);
    b->light_gt = hd_calloc(B * HD_SH_COEFFS, sizeof(float));
    b->has_light = hd_calloc(B, 1);
    b->weight = hd_calloc(B, sizeof(float));
    b->pair_light = hd_calloc((size_t)pairs, 1);
    b->camera_gain = hd_calloc(B * 3, sizeof(float));
    if (b->weight)
        for (size_t i = 0; i < B; i++) b->weight[i] = 1.0f;
    if (b->camera_gain)
        for (size_t i = 0; i < B * 3; i++) b->camera_gain[i] = 1.0f;
    if (!b->camera_gain || !b->weight || !b->pair_light || !b->image || !b->mask || !b->coarse_normal || !b->has_normal || !b->albedo_gt || !b->has_albedo ||
        !b->light_gt || !b->has_light) {
        hd_pair_batch_free(b);
        return HD_ERR_NOMEM;
    }
    return HD_OK;
}

void hd_pair_batch_free(hd_pair_batch *b)
{
    free(b->image);
    free(b->mask);
    free(b->coarse_normal);
    free(b->has_normal);
    free(b->albedo_gt);
    free(b->has_albedo);
    free(b->light_gt);
    free(b->has_light);
    free(b->weight);
    free(b->pair_light);
    free(b->camera_gain);
    memset(b, 0, sizeof *b);
}

hd_status hd_pair_source_init(hd_pair_source *src, const hd_dataset *ds, int require_prior, int prior_gt, int *skipped,
                              int *first_skipped)
{
    memset(src, 0, sizeof *src);
    src->ds = ds;
    src->require_prior = require_prior;
    src->prior_gt = prior_gt;
    src->use = hd_calloc((size_t)ds->count + 1, sizeof(int));
    src->use_start = hd_calloc((size_t)ds->subject_count + 1, sizeof(int));
    src->cum = hd_calloc((size_t)ds->subject_count + 1, sizeof(long));
    if (!src->use || !src->use_start || !src->cum) return HD_ERR_NOMEM;
    int n = 0;
    *skipped = 0;
    *first_skipped = -1;
    for (int s = 0; s < ds->subject_count; s++) {
        src->use_start[s] = n;
        for (int i = ds->subject_start[s]; i < ds->subject_start[s + 1]; i++) {
            if (require_prior && !(prior_gt ? ds->samples[i].normal_gt : ds->samples[i].normal)) {
                if (*first_skipped < 0) *first_skipped = i;
                ++*skipped;
                continue;
            }
            src->use[n++] = i;
        }
        long k = n - src->use_start[s];
        src->cum[s + 1] = src->cum[s] + k * (k - 1) / 2;
    }
    src->use_start[ds->subject_count] = n;
    return HD_OK;
}

void hd_pair_source_free(hd_pair_source *src)
{
    free(src->use);
    free(src->use_start);
    free(src->cum);
    memset(src, 0, sizeof *src);
}

long hd_pair_source_count(const hd_pair_source *src) { return src->cum ? src->cum[src->ds->subject_count] : 0; }

/* The two sample indices of pair q (0 <= q < all pairs). */
static void pair_of(const hd_pair_source *src, long q, int *a, int *b)
{
    int s = 0;
    while (src->cum[s + 1] <= q) s++;
    long r = q - src->cum[s];
    int first = src->use_start[s], n = src->use_start[s + 1] - first;
    int i = 0;
    while (r >= n - 1 - i) {
        r -= n - 1 - i;
        i++;
    }
    *a = src->use[first + i];
    *b = src->use[first + i + 1 + (int)r];
}

/* Reads an image as `channels` at size x size. */
static hd_status read_sized(const char *path, int channels, int size, hd_image *out)
{
    hd_image img = {0};
    hd_status s = hd_image_read_as(path, channels, &img);
    if (s != HD_OK) return s;
    if (img.width == size && img.height == size) {
        *out = img;
        return HD_OK;
    }
    s = hd_image_resize(&img, size, size, out);
    hd_image_free(&img);
    return s;
}

/* Loads sample i into slot `slot` of batch, flipped horizontally if flip (normal x negated). */
static hd_status load_sample(const hd_pair_source *src, int i, int flip, hd_pair_batch *batch, int slot)
{
    const hd_sample *smp = &src->ds->samples[i];
    int size = src->size;
    size_t HW = (size_t)size * size;
    float *img = batch->image + (size_t)slot * 3 * HW, *mask = batch->mask + (size_t)slot * HW;
    float *nrm = batch->coarse_normal + (size_t)slot * 3 * HW, *alb = batch->albedo_gt + (size_t)slot * 3 * HW;
    const char *prior = src->prior_gt ? smp->normal_gt : smp->normal;
    hd_image im = {0}, mk = {0}, nr = {0}, nd = {0}, nv = {0}, al = {0};
    hd_status s;
    if ((s = read_sized(smp->image, 3, size, &im)) != HD_OK) goto done;
    memcpy(img, im.data, 3 * HW * sizeof(float));
    if (smp->mask) {
        if ((s = read_sized(smp->mask, 1, size, &mk)) != HD_OK) goto done;
        memcpy(mask, mk.data, HW * sizeof(float));
    } else {
        for (size_t p = 0; p < HW; p++) mask[p] = 1.0f;
    }
    batch->has_normal[slot] = prior != NULL;
    if (prior) {
        if ((s = read_sized(prior, 3, size, &nr)) != HD_OK || (s = hd_normal_decode(&nr, &nd, &nv)) != HD_OK) goto done;
        memcpy(nrm, nd.data, 3 * HW * sizeof(float));
        /* texels without a stored normal are outside the face */
        for (size_t p = 0; p < HW; p++) mask[p] *= nv.data[p] > 0.5f ? 1.0f : 0.0f;
    } else {
        if (src->require_prior) {
            s = hd_fail(HD_ERR_NOTFOUND, "%s: no prior normals (%s.%s.png); stage 1 needs them", smp->image, smp->name,
                        src->prior_gt ? "normal_gt" : "normal");
            goto done;
        }
        memset(nrm, 0, 3 * HW * sizeof(float));
    }
    float *lgt = batch->light_gt + (size_t)slot * HD_SH_COEFFS;
    batch->has_light[slot] = src->light_gt && smp->light;
    if (batch->has_light[slot]) {
        if ((s = hd_light_read(smp->light, lgt)) != HD_OK) goto done;
        /* a mirrored face sees the mirrored light: the coefficients odd in x change sign */
        if (flip) hd_light_mirror(lgt);
    } else {
        memset(lgt, 0, HD_SH_COEFFS * sizeof(float));
    }
    float *gain = batch->camera_gain + (size_t)slot * 3;
    gain[0] = gain[1] = gain[2] = 1.0f; /* a flip leaves the colour as it is */
    if (src->camera_gain && smp->camera && (s = hd_camera_gain_read(smp->camera, gain)) != HD_OK) goto done;
    batch->has_albedo[slot] = src->albedo_gt && smp->albedo;
    if (batch->has_albedo[slot]) {
        if ((s = read_sized(smp->albedo, 3, size, &al)) != HD_OK) goto done;
        memcpy(alb, al.data, 3 * HW * sizeof(float));
    } else {
        memset(alb, 0, 3 * HW * sizeof(float));
    }
    if (flip) {
        float *planes[10] = {img, img + HW, img + 2 * HW, mask, nrm, nrm + HW, nrm + 2 * HW, alb, alb + HW, alb + 2 * HW};
        for (int k = 0; k < 10; k++)
            for (int y = 0; y < size; y++) {
                float *row = planes[k] + (size_t)y * size;
                for (int x = 0; x < size / 2; x++) {
                    float tmp = row[x];
                    row[x] = row[size - 1 - x];
                    row[size - 1 - x] = tmp;
                }
            }
        for (size_t p = 0; p < HW; p++) nrm[p] = -nrm[p]; /* x points the other way */
    }
done:
    hd_image_free(&im);
    hd_image_free(&mk);
    hd_image_free(&nr);
    hd_image_free(&nd);
    hd_image_free(&nv);
    hd_image_free(&al);
    return s;
}

/* Draws pair slot p of a batch from src: a random pair of one subject's images (or, with mirror,
 * one image and its own mirror image: a face is close to symmetric, its light is mirrored) in
 * random order, flipped together at random; records how the pair's lights relate. */
static hd_status load_pair(const hd_pair_source *src, hd_rng *rng, int mirror, int same_light, hd_pair_batch *batch,
                           int p)
{
    long total = src->cum[src->ds->subject_count];
    int images = src->use_start[src->ds->subject_count];
    if (mirror && images > 0 && (hd_rng_u32(rng) & 1)) {
        int a = src->use[hd_rng_u32(rng) % (uint32_t)images], flip = hd_rng_u32(rng) & 1;
        batch->pair_light[p] = HD_PAIR_LIGHT_MIRROR;
        hd_status s = load_sample(src, a, flip, batch, 2 * p);
        return s == HD_OK ? load_sample(src, a, !flip, batch, 2 * p + 1) : s;
    }
    batch->pair_light[p] = same_light ? HD_PAIR_LIGHT_SAME : HD_PAIR_LIGHT_NONE;
    if (total < 1) return hd_fail(HD_ERR_ARG, "a set without pairs (and no mirror pairs)");
    long q = (long)(((uint64_t)hd_rng_u32(rng) << 32 | hd_rng_u32(rng)) % (uint64_t)total);
    int flip = hd_rng_u32(rng) & 1, swap = hd_rng_u32(rng) & 1, a, b;
    pair_of(src, q, &a, &b);
    if (swap) {
        int tmp = a;
        a = b;
        b = tmp;
    }
    hd_status s = load_sample(src, a, flip, batch, 2 * p);
    return s == HD_OK ? load_sample(src, b, flip, batch, 2 * p + 1) : s;
}

/* Fills the batch of iteration it: the domain, pair q and flip f of slot p come from an RNG seeded
 * with (seed, it, p) only, so a slot's pair does not depend on which process loads it or on the
 * other slots. A pair that fails to load is reported and replaced by the slot's next draw. Only the
 * slots [L->first, L->first + L->count) are loaded (count 0: all): a rank's share of the batch. */
static void load_batch(hd_loader *L)
{
    const hd_pair_source *src = L->src;
    L->status = HD_OK;
    L->warnings[0] = '\0';
    L->warnings_dropped = 0;
    int end = L->count > 0 ? L->first + L->count : L->batch->pairs;
    for (int p = L->count > 0 ? L->first : 0; p < end; p++) {
        hd_rng rng;
        hd_rng_seed(&rng, src->seed ^ HD_DATA_STREAM, (uint64_t)L->iteration * HD_TRAIN_MAX_PAIRS + (uint64_t)p);
        int tries = 0;
        for (;;) {
            /* the domain coin only where there are two domains: one-domain runs draw as before */
            int real = L->real && hd_rng_range(&rng, 0.0f, 1.0f) < L->real_share;
            const hd_pair_source *from = real ? L->real : src;
            hd_status s = load_pair(from, &rng, real && L->mirror, real && L->real_same_light, L->batch, p);
            L->batch->weight[2 * p] = L->batch->weight[2 * p + 1] = real ? L->real_weight : 1.0f;
            if (s == HD_OK) break;
            if (s == HD_ERR_NOMEM || ++tries >= HD_LOAD_RETRIES || (s == HD_ERR_NOTFOUND && from->require_prior)) {
                L->status = s;
                snprintf(L->error, sizeof L->error, "%s", hd_error());
                return;
            }
            char line[1100];
            snprintf(line, sizeof line, "%sskipping a pair: %s", L->warnings[0] ? "\n" : "", hd_error());
            size_t len = strlen(L->warnings), add = strlen(line);
            if (len + add + 40 < sizeof L->warnings) memcpy(L->warnings + len, line, add + 1); /* room for the count */
            else L->warnings_dropped++;
        }
    }
}

static void *loader_main(void *arg)
{
    hd_prof_begin("data loading (loader thread)"); /* the benchmarks' profile (core.h) */
    load_batch(arg);
    hd_prof_end();
    return NULL;
}

void hd_loader_start(hd_loader *L, long iteration)
{
    L->iteration = iteration;
    if (pthread_create(&L->thread, NULL, loader_main, L) != 0) {
        load_batch(L); /* no thread: load in the foreground */
        return;
    }
    L->running = 1;
}

hd_status hd_loader_wait(hd_loader *L, void (*warn)(const char *))
{
    hd_prof_begin("data wait");
    if (L->running) pthread_join(L->thread, NULL);
    hd_prof_end();
    L->running = 0;
    if (L->warnings_dropped) {
        size_t len = strlen(L->warnings);
        snprintf(L->warnings + len, sizeof L->warnings - len, "%s(%d more pair%s skipped)", len ? "\n" : "",
                 L->warnings_dropped, L->warnings_dropped == 1 ? "" : "s");
    }
    if (warn && L->warnings[0]) warn(L->warnings);
    if (L->status != HD_OK) return hd_fail(L->status, "%s", L->error);
    return HD_OK;
}

void hd_loader_stop(hd_loader *L)
{
    if (L->running) pthread_join(L->thread, NULL);
    L->running = 0;
}
