/* test_threads.c: one model and one aligner shared by 4 threads, 25 calls each (8 under the
 * sanitizers), on mixed work (decompositions of 1-4 images of several sizes and channel counts,
 * face alignment of photos, a photo without a face, whole-photo relighting, warping back and
 * aligning without an aligner), started together: every call's results (a hash of every output
 * byte), status and error text must equal those of the same call made serially beforehand. Also
 * run under ThreadSanitizer (`make tsan`). The model is a small one with random weights (width 16:
 * the oneDNN build's blocked layout), written here; the face models and the photo come from the
 * source tree. */
#include <pthread.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "test.h"
#include "hdnet.h"
#include "model/checkpoint.h"
#include "core/core.h"
#include "align/align.h"

#define THREADS 4
#define CALLS 25
/* Under the sanitizers (HD_CHECK: make check, make tsan) each thread makes CHECK_CALLS calls: every
 * kind is still made by two threads at once (kind_of), at a third of the time. */
#define CHECK_CALLS 8
static int calls = CALLS;

static char source_dir[4096];
static hd_model *model;
static hd_aligner *aligner;
static hd_image inputs[4], photo, photo_small, noise;
static hd_aligned_face *face0; /* the small photo's first face, for the calls without an aligner */
static int nface0;

/* One unit of work and what it gave. */
typedef struct outcome {
    hd_status status;
    uint64_t hash;
    char error[160];
} outcome;

static uint64_t fnv(uint64_t h, const void *data, size_t n)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < n; i++) h = (h ^ p[i]) * 0x100000001b3ull;
    return h;
}

static uint64_t hash_image(uint64_t h, const hd_image *im)
{
    int dims[3] = {im->width, im->height, im->channels};
    h = fnv(h, dims, sizeof dims);
    return im->data ? fnv(h, im->data, (size_t)im->width * im->height * im->channels * sizeof(float)) : h;
}

#define KINDS 10

/* Work item k: 0-3 decompose 1-4 of the inputs (from a different first one each), 4 and 5 align
 * the photo at two sizes, 6 aligns noise (no face), 7 relights the photo, 8 decomposes all four
 * inputs in reverse, 9 warps a face back and aligns it again from its landmarks without an
 * aligner (on the canonical mesh the library shares between threads). */
static void run_kind(int k, outcome *o)
{
    memset(o, 0, sizeof *o);
    uint64_t h = 0xcbf29ce484222325ull;
    if (k <= 3 || k == 8) {
        int count = k == 8 ? 4 : k + 1;
        hd_image set[4] = {{0}};
        for (int i = 0; i < count; i++) set[i] = inputs[k == 8 ? 3 - i : (k + i) % 4];
        hd_decomposition d[4];
        o->status = hd_model_decompose(model, set, count, d);
        for (int i = 0; o->status == HD_OK && i < count; i++) {
            h = hash_image(h, &d[i].albedo);
            h = hash_image(h, &d[i].shading);
            h = hash_image(h, &d[i].normal);
            h = hash_image(h, &d[i].reconstruction);
            h = fnv(h, d[i].light, sizeof d[i].light);
            hd_decomposition_free(&d[i]);
        }
    } else if (k <= 6) {
        hd_aligned_face *faces = NULL;
        int n = 0;
        o->status = hd_aligner_run(aligner, k == 4 ? &photo : k == 5 ? &photo_small : &noise, k == 4 ? 128 : 96,
                                   &faces, &n);
        for (int i = 0; i < n; i++) {
            h = hash_image(h, &faces[i].texture);
            h = hash_image(h, &faces[i].mask);
            h = hash_image(h, &faces[i].normal);
            h = fnv(h, faces[i].landmarks, sizeof faces[i].landmarks);
        }
        hd_aligned_faces_free(faces, n);
    } else if (k == 9) {
        hd_image warped = {0}, coverage = {0};
        hd_aligned_face again;
        o->status = hd_warp_back(&face0[0], &face0[0].texture, NULL, &warped, &coverage);
        if (o->status == HD_OK)
            o->status = hd_align_face(&photo_small, (const float (*)[3])face0[0].landmarks, 64, &again);
        if (o->status == HD_OK) {
            h = hash_image(h, &warped);
            h = hash_image(h, &coverage);
            h = hash_image(h, &again.texture);
            hd_aligned_face_free(&again);
        }
        hd_image_free(&warped);
        hd_image_free(&coverage);
    } else {
        float light[HD_SH_COEFFS];
        hd_light_preset(3, light);
        hd_image relit = {0};
        int nfaces = 0;
        o->status = hd_relight_photo(model, aligner, &photo_small, (const float (*)[HD_SH_COEFFS])light, 1,
                                     HD_BRIGHTNESS_KEEP, &relit, NULL, &nfaces);
        h = hash_image(h, &relit);
        h = fnv(h, &nfaces, sizeof nfaces);
        hd_image_free(&relit);
    }
    if (o->status != HD_OK) snprintf(o->error, sizeof o->error, "%s", hd_error());
    o->hash = h;
}

static outcome reference[KINDS], got[THREADS][CALLS];
static pthread_barrier_t start;

static int kind_of(int thread, int call) { return (thread * 5 + call * 2) % KINDS; }

static void *worker(void *arg)
{
    int t = (int)(intptr_t)arg;
    pthread_barrier_wait(&start);
    for (int c = 0; c < calls; c++) run_kind(kind_of(t, c), &got[t][c]);
    return NULL;
}

static void find_source_dir(void)
{
    const char *td = getenv("HDNET_TESTDATA"); /* <source>/tests/data */
    snprintf(source_dir, sizeof source_dir, "%s", td ? td : "tests/data");
    for (int up = 0; up < 2; up++) {
        char *slash = strrchr(source_dir, '/');
        if (slash) *slash = '\0';
        else snprintf(source_dir, sizeof source_dir, ".");
    }
}

static void random_image(hd_image *im, int w, int h, int c, hd_rng *rng)
{
    hd_image_alloc(im, w, h, c);
    for (size_t i = 0; i < (size_t)w * h * c; i++) im->data[i] = hd_rng_uniform(rng);
}

int main(void)
{
    if (getenv("HD_CHECK")) calls = CHECK_CALLS;
    find_source_dir();
    char path[4400];
    snprintf(path, sizeof path, "%s/models", source_dir);
    setenv("HDNET_DATA", path, 1);

    /* a small model with random weights */
    hd_net_config cfg = {16, 64};
    hd_param_table table;
    hd_net_param_table(&cfg, &table);
    float *params = calloc(table.total, sizeof(float));
    hd_rng rng;
    hd_rng_seed(&rng, 14, 1);
    hd_params_init(&table, params, &rng);
    hd_status st = hd_model_write("threads_model.safetensors", &cfg, params, 0, 1);
    free(params);
    if (st == HD_OK) st = hd_model_load("threads_model.safetensors", &model);
    if (st == HD_OK) st = hd_aligner_load(&aligner);
    snprintf(path, sizeof path, "%s/examples/astronaut.png", source_dir);
    if (st == HD_OK) st = hd_image_read_as(path, 3, &photo);
    if (st == HD_OK) st = hd_image_resize(&photo, 300, 280, &photo_small);
    if (st == HD_OK) st = hd_aligner_run(aligner, &photo_small, 96, &face0, &nface0);
    if (st == HD_OK && nface0 < 1) st = hd_fail(HD_ERR_NOTFOUND, "no face in the small photo");
    if (st != HD_OK) {
        fprintf(stderr, "test_threads: %s\n", hd_error());
        return 1;
    }
    random_image(&inputs[0], 64, 64, 3, &rng);
    random_image(&inputs[1], 48, 40, 3, &rng);
    random_image(&inputs[2], 100, 80, 1, &rng);
    random_image(&inputs[3], 64, 64, 4, &rng);
    random_image(&noise, 160, 120, 3, &rng);

    double t0 = hd_seconds();
    for (int k = 0; k < KINDS; k++) run_kind(k, &reference[k]);
    double serial = hd_seconds() - t0;
    for (int k = 0; k < KINDS; k++) {
        CHECK(reference[k].status == (k == 6 ? HD_ERR_NOTFOUND : HD_OK));
        if (reference[k].status != (k == 6 ? HD_ERR_NOTFOUND : HD_OK))
            fprintf(stderr, "  kind %d: %s\n", k, reference[k].error);
    }

    pthread_t th[THREADS];
    pthread_barrier_init(&start, NULL, THREADS);
    t0 = hd_seconds();
    for (int t = 0; t < THREADS; t++) pthread_create(&th[t], NULL, worker, (void *)(intptr_t)t);
    for (int t = 0; t < THREADS; t++) pthread_join(th[t], NULL);
    double threaded = hd_seconds() - t0;
    pthread_barrier_destroy(&start);

    int same = 0;
    for (int t = 0; t < THREADS; t++)
        for (int c = 0; c < calls; c++) {
            const outcome *r = &reference[kind_of(t, c)], *g = &got[t][c];
            int ok = g->status == r->status && g->hash == r->hash && strcmp(g->error, r->error) == 0;
            if (!ok)
                fprintf(stderr, "  thread %d call %d (kind %d): status %d hash %016llx '%s', serially %d %016llx '%s'\n", t,
                        c, kind_of(t, c), g->status, (unsigned long long)g->hash, g->error, r->status,
                        (unsigned long long)r->hash, r->error);
            CHECK(ok);
            same += ok;
        }
    printf("%d threads x %d calls on one model and one aligner: %d of %d bit-identical to the serial calls "
           "(serial pass of %d kinds %.2f s, threaded %.2f s, %d OpenMP threads per call)\n",
           THREADS, calls, same, THREADS * calls, KINDS, serial, threaded, hd_threads());

    for (int i = 0; i < 4; i++) hd_image_free(&inputs[i]);
    hd_image_free(&photo);
    hd_image_free(&photo_small);
    hd_image_free(&noise);
    hd_aligned_faces_free(face0, nface0);
    hd_aligner_free(aligner);
    hd_model_free(model);
    return test_summary("test_threads");
}
