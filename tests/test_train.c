/* test_train.c: training HD-Net (src/train): finite differences of the total loss (and of each
 * term alone, and of the discriminator's loss) against the analytic gradient in every layer of
 * every net, each loss term by hand, a tiny pair overfitting, exact resume, NaN detection, and
 * clear errors for bad or mismatched checkpoint files. The network alone: tests/test_model.c. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "test.h"
#include "source_dir.h"
#include "light/light.h"
#include "mesh/mesh.h"
#include "model/hdnet_net.h"
#include "train/losses.h"
#include "train/train.h"
#include "model/checkpoint.h"
#include "train/train_log.h"
#include "io/image_io.h"
#include "io/safetensors.h"

/* ---- a synthetic pair: one smooth albedo on a sphere-like face under two lights */

static void make_pair(hd_pair_batch *b, int pair, unsigned seed)
{
    int S = b->size;
    size_t HW = (size_t)S * S;
    float lights[2][HD_SH_COEFFS];
    hd_light_from_direction(40.0f + 10.0f * seed, 20.0f, 0.8f, 0.5f, lights[0]);
    hd_light_from_direction(-50.0f, -10.0f + 5.0f * seed, 0.8f, 0.5f, lights[1]);
    for (int k = 0; k < 2; k++) {
        int slot = 2 * pair + k;
        float *I = b->image + (size_t)slot * 3 * HW, *m = b->mask + (size_t)slot * HW;
        float *N = b->coarse_normal + (size_t)slot * 3 * HW;
        b->has_normal[slot] = 1;
        b->has_albedo[slot] = k == 0;
        b->weight[slot] = 0.6f + 0.3f * (float)pair; /* a domain weight that is not 1 */
        for (int y = 0; y < S; y++)
            for (int x = 0; x < S; x++) {
                size_t p = (size_t)y * S + x;
                float u = (x + 0.5f) / S * 2 - 1, v = 1 - (y + 0.5f) / S * 2, r2 = u * u + v * v;
                float n[3] = {u * 0.8f, v * 0.8f, sqrtf(fmaxf(1 - 0.64f * r2, 0.05f))};
                float len = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
                for (int c = 0; c < 3; c++) N[c * HW + p] = n[c] / len;
                m[p] = r2 < 0.85f ? 1.0f : 0.0f;
                float s = hd_sh_shade(lights[k], n);
                float alb[3] = {0.55f + 0.2f * u, 0.4f + 0.1f * v, 0.35f + 0.05f * (u * v)};
                for (int c = 0; c < 3; c++) I[c * HW + p] = fminf(fmaxf(alb[c] * s * 0.6f, 0.0f), 1.0f);
                /* a ground-truth albedo for the albedo_gt term (on one image of the pair only) */
                for (int c = 0; c < 3; c++) b->albedo_gt[(size_t)slot * 3 * HW + c * HW + p] = k ? 0.0f : alb[c];
            }
    }
}

/* ---- finite differences */

static int tiny_trainer(hd_trainer *t, int width, int size, int pairs)
{
    hd_net_config cfg = {width, size};
    if (hd_trainer_create(t, &cfg, pairs, 0, 7) != HD_OK) {
        fprintf(stderr, "trainer: %s\n", hd_error());
        test_failures++;
        return 0;
    }
    for (int p = 0; p < pairs; p++) make_pair(&t->batch, p, (unsigned)p);
    return 1;
}

static double eval_loss(hd_trainer *t, int disc)
{
    hd_step_result r;
    if (hd_trainer_eval(t, &r, disc ? HD_EVAL_DISC : HD_EVAL_LOSS) != HD_OK) {
        fprintf(stderr, "eval: %s\n", hd_error());
        test_failures++;
        return 0;
    }
    return disc ? r.disc : r.total;
}

/* Directional finite differences: for each group of parameters [first, last) of the table
 * (a layer, or a whole sub-net), a random direction d over those parameters, and
 * (L(p + eps d) - L(p - eps d)) / (2 eps) against grad . d. Every parameter takes part. */
typedef struct fd_group {
    const char *first, *last; /* tensor names, inclusive */
} fd_group;

/* One directional derivative of layers i0..i1 against its central difference: 0 if they agree. */
static int direction_agrees(hd_trainer *t, int disc, int i0, int i1, float eps, const float *grad, double scale,
                            uint64_t seed, double *fd_out, double *gd_out)
{
    const hd_param_table *tab = disc ? &t->disc.table : &t->net.table;
    float *params = disc ? t->disc.params : t->net.params;
    size_t a = tab->p[i0].offset, b = tab->p[i1].offset + tab->p[i1].count;
    float *keep = malloc((b - a) * sizeof(float)), *dir = malloc((b - a) * sizeof(float));
    hd_rng rng;
    hd_rng_seed(&rng, 11 + seed, (uint64_t)i0);
    /* the step is eps relative to the layer's weights: d uniform in +-rms(p) */
    double gd = 0, ms = 0;
    for (size_t k = 0; k < b - a; k++) ms += (double)params[a + k] * params[a + k];
    float rms = (float)sqrt(ms / (double)(b - a)) + 1e-3f;
    for (size_t k = 0; k < b - a; k++) {
        keep[k] = params[a + k];
        dir[k] = rms * hd_rng_range(&rng, -1.0f, 1.0f);
        gd += (double)grad[a + k] * dir[k];
    }
    for (size_t k = 0; k < b - a; k++) params[a + k] = keep[k] + eps * dir[k];
    double up = eval_loss(t, disc);
    for (size_t k = 0; k < b - a; k++) params[a + k] = keep[k] - eps * dir[k];
    double down = eval_loss(t, disc);
    memcpy(params + a, keep, (b - a) * sizeof(float));
    free(keep);
    free(dir);
    double fd = (up - down) / (2 * eps);
    *fd_out = fd, *gd_out = gd;
    return fabs(fd - gd) <= 0.05 * fmax(fabs(fd), fabs(gd)) + 1e-4 * scale;
}

/* The check of layers i0..i1 in one random direction; with kinked, more in three, of which two
 * must agree: through the discriminator's leaky ReLUs a central difference can straddle a kink
 * (which one does is down to the CPU's BLAS kernels' rounding), but a wrong gradient fails in
 * every direction. */
static void check_direction(hd_trainer *t, const char *what, int disc, int i0, int i1, float eps, const float *grad,
                            double scale, int kinked)
{
    const hd_param_table *tab = disc ? &t->disc.table : &t->net.table;
    double fd, gd;
    int tries = kinked ? 3 : 1, agree = 0;
    for (int k = 0; k < tries; k++) {
        int ok = direction_agrees(t, disc, i0, i1, eps, grad, scale, (uint64_t)k, &fd, &gd);
        if (!ok) fprintf(stderr, "%s: %s .. %s: finite difference %.7g, analytic %.7g%s\n", what, tab->p[i0].name,
                         tab->p[i1].name, fd, gd, kinked ? " (one of three directions)" : "");
        agree += ok;
    }
    if (agree < (tries + 1) / 2) test_failures++;
}

/* Checks every layer (weight and bias together) or, with by_net, every sub-net as a whole. */
static void check_gradients(hd_trainer *t, const char *what, int disc, int by_net, float eps, int kinked)
{
    hd_step_result r;
    if (hd_trainer_eval(t, &r, disc ? HD_EVAL_DISC_GRAD : HD_EVAL_GRAD) != HD_OK) {
        fprintf(stderr, "eval: %s\n", hd_error());
        test_failures++;
        return;
    }
    const hd_param_table *tab = disc ? &t->disc.table : &t->net.table;
    size_t n = tab->total;
    float *grad = malloc(n * sizeof(float));
    memcpy(grad, disc ? t->disc.grads : t->net.grads, n * sizeof(float));
    /* what the analytic gradient treats as constants stays constant: N-Net's input S and l_hat */
    size_t HW = (size_t)t->net.H * t->net.W;
    float *held = malloc((size_t)t->net.B * HW * sizeof(float));
    memcpy(held, t->net.shading, (size_t)t->net.B * HW * sizeof(float));
    t->pass.n_input_hold = held;
    t->losses.hold_light_hat = 1;
    /* the size of a typical directional derivative, for the absolute tolerance */
    double scale = 0;
    for (size_t i = 0; i < n; i++) scale = fmax(scale, fabs(grad[i]));
    if (by_net) {
        static const char *const nets[] = {"conv_in", "a_net", "s_net", "n_net", "l_net"};
        for (int k = 0; k < 5; k++) {
            int i0 = -1, i1 = -1;
            for (int i = 0; i < tab->count; i++)
                if (strncmp(tab->p[i].name, nets[k], strlen(nets[k])) == 0) {
                    if (i0 < 0) i0 = i;
                    i1 = i;
                }
            check_direction(t, what, disc, i0, i1, eps, grad, scale, kinked);
        }
    } else {
        /* under the sanitizers (make check) every third layer, to stay fast */
        int step = getenv("HD_CHECK") ? 6 : 2;
        for (int i = 0; i + 1 < tab->count; i += step) check_direction(t, what, disc, i, i + 1, eps, grad, scale, kinked);
    }
    t->pass.n_input_hold = NULL;
    t->losses.hold_light_hat = 0;
    free(held);
    free(grad);
}

static void test_gradients(void)
{
    hd_trainer t;
    if (!tiny_trainer(&t, 4, 32, 1)) return;
    /* every weight on: the total, layer by layer */
    check_gradients(&t, "total", 0, 0, 1e-3f, 0);
    /* each term alone, sub-net by sub-net */
    hd_loss_weights all = t.weights;
    for (int k = 0; k < HD_LOSS_TERMS; k++) {
        memset(&t.weights, 0, sizeof t.weights);
        t.weights.w[k] = 1.0f;
        /* L_adv reaches HD-Net through the discriminator: a step of 1e-3 moves its value by a few
         * float ulps only, so 1e-2 */
        check_gradients(&t, hd_loss_names[k], 0, 1, k == HD_LOSS_ADV ? 1e-2f : 1e-3f, k == HD_LOSS_ADV);
    }
    /* the scale anchor on the pair's mean shading */
    memset(&t.weights, 0, sizeof t.weights);
    t.weights.w[HD_LOSS_SHADING_MEAN] = 1.0f;
    t.losses.shading_mean_pair = 1;
    check_gradients(&t, "shading_mean (pair)", 0, 1, 1e-3f, 0);
    t.losses.shading_mean_pair = 0;
    /* the shading prior on the predicted normals (their target detached, held by the check) */
    memset(&t.weights, 0, sizeof t.weights);
    t.weights.w[HD_LOSS_SHADING_PRIOR] = 1.0f;
    t.losses.prior_predicted = 1;
    check_gradients(&t, "shading_prior (predicted normals)", 0, 1, 1e-3f, 0);
    t.losses.prior_predicted = 0;
    /* L_Irec through a camera colour gain per image (--rec-gain camera): A*S*g against I */
    static const float gains[2][3] = {{1.25f, 0.98f, 0.76f}, {0.8f, 1.02f, 1.2f}};
    memcpy(t.batch.camera_gain, gains, sizeof gains);
    memset(&t.weights, 0, sizeof t.weights);
    t.weights.w[HD_LOSS_REC] = 1.0f;
    check_gradients(&t, "rec (camera gain)", 0, 1, 1e-3f, 0);
    for (int k = 0; k < 6; k++) t.batch.camera_gain[k] = 1.0f;
    t.weights = all;
    /* the domain weight scales every term but L_adv: at weight 0 they vanish, and doubling it
     * doubles them */
    hd_step_result r0, r1, r2;
    float keep = t.batch.weight[0];
    CHECK(hd_trainer_eval(&t, &r1, HD_EVAL_LOSS) == HD_OK);
    t.batch.weight[0] = t.batch.weight[1] = 2 * keep;
    CHECK(hd_trainer_eval(&t, &r2, HD_EVAL_LOSS) == HD_OK);
    t.batch.weight[0] = t.batch.weight[1] = 0.0f;
    CHECK(hd_trainer_eval(&t, &r0, HD_EVAL_LOSS) == HD_OK);
    t.batch.weight[0] = t.batch.weight[1] = keep;
    for (int k = 0; k < HD_LOSS_TERMS; k++) {
        if (k == HD_LOSS_ADV) {
            CHECK(r0.terms[k] == r1.terms[k]);
            continue;
        }
        CHECK(r0.terms[k] == 0.0);
        CHECK(fabs(r2.terms[k] - 2 * r1.terms[k]) <= 1e-6 * fabs(r1.terms[k]) + 1e-12);
    }
    check_gradients(&t, "discriminator", 1, 0, 3e-4f, 1);
    hd_trainer_free(&t);
}

/* ---- micro-batches: the same losses and gradients as the whole batch at once */

static void test_micro_batch(void)
{
    hd_net_config cfg = {4, 32};
    hd_trainer whole, micro, bad;
    CHECK(hd_trainer_create(&bad, &cfg, 3, 2, 9) != HD_OK && strstr(hd_error(), "divide"));
    if (hd_trainer_create(&whole, &cfg, 2, 0, 9) != HD_OK) {
        fprintf(stderr, "trainer: %s\n", hd_error());
        test_failures++;
        return;
    }
    if (hd_trainer_create(&micro, &cfg, 2, 1, 9) != HD_OK) {
        fprintf(stderr, "trainer: %s\n", hd_error());
        test_failures++;
        hd_trainer_free(&whole);
        return;
    }
    for (int p = 0; p < 2; p++) {
        make_pair(&whole.batch, p, (unsigned)p + 3);
        make_pair(&micro.batch, p, (unsigned)p + 3);
    }
    hd_step_result a, b;
    CHECK(hd_trainer_eval(&whole, &a, HD_EVAL_GRAD | HD_EVAL_DISC_GRAD) == HD_OK);
    CHECK(hd_trainer_eval(&micro, &b, HD_EVAL_GRAD | HD_EVAL_DISC_GRAD) == HD_OK);
    CHECK_NEAR(a.total, b.total, 1e-5 * fabs(a.total));
    CHECK_NEAR(a.disc, b.disc, 1e-5 * fabs(a.disc));
    for (int k = 0; k < HD_LOSS_TERMS; k++) CHECK_NEAR(a.terms[k], b.terms[k], 1e-5 * fabs(a.terms[k]) + 1e-9);
    double gmax = 0, dmax = 0, gdiff = 0, ddiff = 0;
    for (size_t i = 0; i < whole.net.table.total; i++) {
        gmax = fmax(gmax, fabs(whole.net.grads[i]));
        gdiff = fmax(gdiff, fabs(whole.net.grads[i] - micro.net.grads[i]));
    }
    for (size_t i = 0; i < whole.disc.table.total; i++) {
        dmax = fmax(dmax, fabs(whole.disc.grads[i]));
        ddiff = fmax(ddiff, fabs(whole.disc.grads[i] - micro.disc.grads[i]));
    }
    CHECK(gmax > 0 && gdiff <= 1e-4 * gmax);
    CHECK(dmax > 0 && ddiff <= 1e-4 * dmax);
    hd_trainer_free(&whole);
    hd_trainer_free(&micro);
}

/* ---- stage 2: phase 2a moves only L-Net (and the discriminator), 2b moves everything */

static void test_stage2(void)
{
    hd_trainer t;
    if (!tiny_trainer(&t, 4, 32, 1)) return;
    t.stage = 2;
    t.lnet_iters = 1;
    t.lr = 1e-3f;
    size_t n = t.net.table.total, lnet = t.lnet_offset;
    float *before = malloc(n * sizeof(float)), *disc0 = malloc(sizeof(float));
    memcpy(before, t.net.params, n * sizeof(float));
    disc0[0] = t.disc.params[0];
    hd_step_result r;
    CHECK(hd_trainer_phase(&t, 0) == HD_TRAIN_LNET && hd_trainer_phase(&t, 1) == HD_TRAIN_ALL);
    CHECK(hd_trainer_step(&t, &r, NULL) == HD_OK);
    CHECK(memcmp(before, t.net.params, lnet * sizeof(float)) == 0); /* conv_in, A-, S-, N-Net frozen */
    CHECK(memcmp(before + lnet, t.net.params + lnet, (n - lnet) * sizeof(float)) != 0);
    CHECK(t.disc.params[0] != disc0[0]);
    CHECK(hd_trainer_step(&t, &r, NULL) == HD_OK);
    int a = hd_param_find(&t.net.table, "a_net.enc0.weight"), nn = hd_param_find(&t.net.table, "n_net.dec1c.weight");
    CHECK(memcmp(before + t.net.table.p[a].offset, t.net.params + t.net.table.p[a].offset,
                 t.net.table.p[a].count * sizeof(float)) != 0);
    CHECK(memcmp(before + t.net.table.p[nn].offset, t.net.params + t.net.table.p[nn].offset,
                 t.net.table.p[nn].count * sizeof(float)) != 0);
    free(before);
    free(disc0);
    hd_trainer_free(&t);
    /* lnet_lr: phase 2a's step of L-Net at its own rate (Adam's first step moves a parameter by
     * about the rate), 2b and the discriminator at lr */
    float moved[2], disc_moved[2];
    for (int run = 0; run < 2; run++) {
        if (!tiny_trainer(&t, 4, 32, 1)) return;
        t.stage = 2;
        t.lnet_iters = 1;
        t.lr = 1e-4f;
        t.lnet_lr = run ? 1e-2f : 0.0f;
        n = t.net.table.total, lnet = t.lnet_offset;
        before = malloc(n * sizeof(float));
        memcpy(before, t.net.params, n * sizeof(float));
        float d0 = t.disc.params[0];
        CHECK(hd_trainer_step(&t, &r, NULL) == HD_OK);
        CHECK(memcmp(before, t.net.params, lnet * sizeof(float)) == 0);
        moved[run] = 0;
        for (size_t i = lnet; i < n; i++) moved[run] = fmaxf(moved[run], fabsf(t.net.params[i] - before[i]));
        disc_moved[run] = fabsf(t.disc.params[0] - d0);
        free(before);
        hd_trainer_free(&t);
    }
    CHECK(moved[0] > 0.9e-4f && moved[0] < 1.1e-4f);
    CHECK(moved[1] > 0.9e-2f && moved[1] < 1.1e-2f);
    CHECK(disc_moved[0] > 0 && disc_moved[0] == disc_moved[1]);
}

/* ---- a tiny pair overfits */

static void test_overfit(void)
{
    hd_trainer t;
    if (!tiny_trainer(&t, 4, 32, 1)) return;
    hd_step_result r;
    double first = 0, last = 0, rec_first = 0, rec_last = 0;
    int steps = 0;
    for (int i = 0; i < 300; i++) {
        if (hd_trainer_step(&t, &r, NULL) != HD_OK) {
            fprintf(stderr, "step: %s\n", hd_error());
            test_failures++;
            break;
        }
        if (i == 0) {
            first = r.total;
            rec_first = r.terms[HD_LOSS_REC];
        }
        last = r.total;
        rec_last = r.terms[HD_LOSS_REC];
        steps = i + 1;
        if (last <= 0.2 * first && rec_last <= 0.6 * rec_first) break;
    }
    fprintf(stderr, "overfit: total loss %.4f -> %.4f, reconstruction %.4f -> %.4f in %d steps\n", first, last, rec_first,
            rec_last, steps);
    CHECK(last <= 0.2 * first);
    CHECK(rec_last <= 0.6 * rec_first);
    hd_trainer_free(&t);
}

/* ---- runs on a folder: resume, NaN, errors */

static int write_dataset(const char *dir, int size)
{
    hd_pair_batch b;
    if (hd_pair_batch_alloc(&b, 2, size) != HD_OK) return 0;
    size_t HW = (size_t)size * size;
    char path[256];
    int ok = 1;
    /* two persons of four images each (the i and j of two synthetic pairs) */
    for (int person = 0; person < 2 && ok; person++) {
        make_pair(&b, 0, 2u * person);
        make_pair(&b, 1, 2u * person + 1);
        snprintf(path, sizeof path, "%s/person%d", dir, person);
        ok = hd_mkdirs(path) == HD_OK;
        for (int slot = 0; slot < 4 && ok; slot++) {
            hd_image img = {size, size, 3, b.image + (size_t)slot * 3 * HW};
            hd_image mask = {size, size, 1, b.mask + (size_t)slot * HW};
            hd_image nrm = {size, size, 3, b.coarse_normal + (size_t)slot * 3 * HW}, enc = {0};
            snprintf(path, sizeof path, "%s/person%d/img%d.png", dir, person, slot);
            ok = ok && hd_image_write_png(path, &img, 8) == HD_OK;
            snprintf(path, sizeof path, "%s/person%d/img%d.mask.png", dir, person, slot);
            ok = ok && hd_image_write_png(path, &mask, 8) == HD_OK;
            snprintf(path, sizeof path, "%s/person%d/img%d.normal.png", dir, person, slot);
            ok = ok && hd_normal_encode(&nrm, &mask, &enc) == HD_OK && hd_image_write_png(path, &enc, 16) == HD_OK;
            hd_image_free(&enc);
        }
    }
    hd_pair_batch_free(&b);
    if (!ok) fprintf(stderr, "writing the dataset: %s\n", hd_error());
    return ok;
}

/* Records the progress calls of a run: each step's iteration and total, then the finishing call. */
typedef struct progress_log {
    int calls, finished, in_order;
    long last;
    double last_total;
} progress_log;

static void log_progress(const hd_train_progress *p, void *user)
{
    progress_log *l = user;
    l->calls++;
    if (p->finished) {
        l->finished++;
        return;
    }
    l->in_order &= p->iteration == l->last + 1 && p->step != NULL;
    l->last = p->iteration;
    l->last_total = p->step ? p->step->total : NAN;
}

static void run_options(hd_train_options *o, const char *run, long iters)
{
    hd_train_defaults(o);
    o->data_dir = "data";
    o->run_dir = run;
    o->iters = iters;
    o->batch = 2;
    o->size = 32;
    o->width = 4;
    o->every = 100; /* checkpoints at the end only: they are fsynced, and big (Adam moments) */
    o->seed = 5;
}

/* The loss columns (everything but the seconds) of a loss.csv. */
static char *loss_rows(const char *path)
{
    char *data = NULL;
    size_t n;
    if (hd_read_file(path, 1 << 20, &data, &n) != HD_OK) return NULL;
    char *out = calloc(n + 1, 1), *o = out;
    for (char *line = strtok(data, "\n"); line; line = strtok(NULL, "\n")) {
        char *last = strrchr(line, ',');
        if (last) *last = '\0';
        o += sprintf(o, "%s\n", line);
    }
    free(data);
    return out;
}

/* Largest difference between plane a and plane b (S x S), b mirrored left-right if flip. */
static float plane_diff(const float *a, const float *b, int S, int flip, float sign)
{
    float d = 0;
    for (int y = 0; y < S; y++)
        for (int x = 0; x < S; x++) {
            float v = sign * b[(size_t)y * S + (flip ? S - 1 - x : x)];
            d = fmaxf(d, fabsf(a[(size_t)y * S + x] - v));
        }
    return d;
}

/* The batch a run trains on is made of the set's images, each pair from one person, flipped
 * together: image, mask and coarse normals mirrored, the normals' x negated. Checked on the
 * gradient dump (the batch as the networks saw it) of a few seeds until both cases showed. */
static void test_augmentation(void)
{
    enum { S = 32, NIMG = 4 };
    size_t HW = (size_t)S * S;
    hd_image img[2][NIMG], nrm[2][NIMG], msk[2][NIMG];
    char path[128];
    int ok = 1;
    for (int p = 0; p < 2; p++)
        for (int k = 0; k < NIMG; k++) {
            hd_image raw = {0}, valid = {0};
            memset(&img[p][k], 0, sizeof(hd_image));
            memset(&nrm[p][k], 0, sizeof(hd_image));
            memset(&msk[p][k], 0, sizeof(hd_image));
            snprintf(path, sizeof path, "data/person%d/img%d.png", p, k);
            ok = ok && hd_image_read_as(path, 3, &img[p][k]) == HD_OK;
            snprintf(path, sizeof path, "data/person%d/img%d.mask.png", p, k);
            ok = ok && hd_image_read_as(path, 1, &msk[p][k]) == HD_OK;
            snprintf(path, sizeof path, "data/person%d/img%d.normal.png", p, k);
            ok = ok && hd_image_read_as(path, 3, &raw) == HD_OK && hd_normal_decode(&raw, &nrm[p][k], &valid) == HD_OK;
            hd_image_free(&raw);
            hd_image_free(&valid);
        }
    CHECK(ok);
    int seen_flip = 0, seen_plain = 0;
    for (int seed = 1; seed <= 12 && ok && !(seen_flip && seen_plain); seed++) {
        hd_train_options o;
        hd_train_result r;
        char run[32];
        snprintf(run, sizeof run, "aug%d", seed);
        run_options(&o, run, 1);
        o.seed = (uint64_t)seed;
        o.dump_grads = "aug.safetensors";
        if (hd_train(&o, &r) != HD_OK) {
            fprintf(stderr, "augmentation run: %s\n", hd_error());
            test_failures++;
            break;
        }
        hd_safetensors st = {0};
        CHECK(hd_safetensors_read("aug.safetensors", &st) == HD_OK);
        const hd_tensor *bi = hd_safetensors_find(&st, "batch.image"), *bm = hd_safetensors_find(&st, "batch.mask");
        const hd_tensor *bn = hd_safetensors_find(&st, "batch.coarse_normal");
        if (!bi || !bm || !bn) {
            test_failures++;
            hd_safetensors_free(&st);
            break;
        }
        for (int pair = 0; pair < 2; pair++) {
            int who[2] = {-1, -1}, flip[2] = {-1, -1};
            for (int e = 0; e < 2; e++) {
                int b = 2 * pair + e;
                for (int p = 0; p < 2; p++)
                    for (int k = 0; k < NIMG; k++)
                        for (int f = 0; f < 2; f++) {
                            if (!img[p][k].data || who[e] >= 0) continue;
                            float d = 0;
                            for (int c = 0; c < 3; c++)
                                d = fmaxf(d, plane_diff(bi->data + ((size_t)b * 3 + c) * HW, img[p][k].data + c * HW, S, f, 1));
                            if (d > 1e-6f) continue;
                            who[e] = p * NIMG + k;
                            flip[e] = f;
                            float dm = plane_diff(bm->data + (size_t)b * HW, msk[p][k].data, S, f, 1);
                            float dn = 0;
                            for (int c = 0; c < 3; c++)
                                dn = fmaxf(dn, plane_diff(bn->data + ((size_t)b * 3 + c) * HW, nrm[p][k].data + c * HW, S, f,
                                                          c == 0 && f ? -1.0f : 1.0f));
                            CHECK(dm < 1e-6f); /* binary masks, normals stored inside them */
                            CHECK(dn < 1e-5f);
                        }
                CHECK(who[e] >= 0);
            }
            CHECK(who[0] / NIMG == who[1] / NIMG && who[0] != who[1]); /* one person, two images */
            CHECK(flip[0] == flip[1]);                                 /* flipped together */
            seen_flip |= flip[0] == 1;
            seen_plain |= flip[0] == 0;
        }
        hd_safetensors_free(&st);
    }
    CHECK(seen_flip && seen_plain);
    for (int p = 0; p < 2; p++)
        for (int k = 0; k < NIMG; k++) {
            hd_image_free(&img[p][k]);
            hd_image_free(&nrm[p][k]);
            hd_image_free(&msk[p][k]);
        }
}

static void test_resume_and_errors(void)
{
    if (!write_dataset("data", 32)) {
        test_failures++;
        return;
    }
    hd_train_options o;
    hd_train_result r;
    run_options(&o, "straight", 6);
    o.dump_grads = "dump.safetensors";
    CHECK(hd_train(&o, &r) == HD_OK && r.iteration == 6);
    /* the dump holds the first step: its batch, parameters, losses and gradients */
    hd_safetensors st = {0};
    CHECK(hd_safetensors_read("dump.safetensors", &st) == HD_OK);
    const hd_tensor *img = hd_safetensors_find(&st, "batch.image"), *tot = hd_safetensors_find(&st, "loss.total");
    CHECK(img && img->ndim == 4 && img->shape[0] == 4 && img->shape[1] == 3 && img->shape[2] == 32);
    CHECK(hd_safetensors_find(&st, "grad.conv_in.weight") && hd_safetensors_find(&st, "grad.disc.out.bias") &&
          hd_safetensors_find(&st, "l_net.fc.weight") && hd_safetensors_find(&st, "batch.coarse_normal") &&
          hd_safetensors_find(&st, "loss.adv") && hd_safetensors_find(&st, "loss.disc"));
    char *rows = loss_rows("straight/loss.csv");
    if (tot && rows) {
        char *line = strchr(rows, '\n') + 1; /* "1,TOTAL,..." */
        CHECK_NEAR(strtod(strchr(line, ',') + 1, NULL), tot->data[0], 1e-5 * fabs(tot->data[0]));
    }
    free(rows);
    hd_safetensors_free(&st);
    run_options(&o, "resumed", 3);
    CHECK(hd_train(&o, &r) == HD_OK && r.iteration == 3);
    run_options(&o, "resumed", 6);
    o.resume = 1;
    o.batch = 0; /* taken from the checkpoint */
    progress_log plog = {0, 0, 1, 3, 0};
    o.progress = log_progress;
    o.progress_user = &plog;
    CHECK(hd_train(&o, &r) == HD_OK && r.iteration == 6);
    /* progress by callback: one call per step (iterations 4, 5, 6 of the resumed run), then the end */
    CHECK(plog.calls == 4 && plog.finished == 1 && plog.in_order && plog.last == 6);
    CHECK(plog.last_total == r.last.total);
    char *a = loss_rows("straight/loss.csv"), *b = loss_rows("resumed/loss.csv");
    CHECK(a && b && strcmp(a, b) == 0);
    if (a && b && strcmp(a, b)) fprintf(stderr, "uninterrupted:\n%sresumed:\n%s", a, b);
    CHECK(a && strlen(a) > 50);
    free(a);
    free(b);

    /* the model written by the run decomposes */
    hd_model *m = NULL;
    CHECK(hd_model_load("straight/model.safetensors", &m) == HD_OK);
    if (m) {
        CHECK(hd_model_size(m) == 32 && hd_model_width(m) == 4);
        hd_image img = {0};
        CHECK(hd_image_read("data/person0/img0.png", &img) == HD_OK);
        hd_decomposition d[2];
        hd_image two[2] = {img, img};
        CHECK(hd_model_decompose(m, two, 2, d) == HD_OK);
        CHECK(d[0].albedo.width == 32 && d[0].shading.channels == 1 && d[1].normal.channels == 3);
        float nn = d[0].normal.data[0] * d[0].normal.data[0] + d[0].normal.data[1024] * d[0].normal.data[1024] +
                   d[0].normal.data[2048] * d[0].normal.data[2048];
        CHECK_NEAR(nn, 1.0, 1e-3);
        CHECK(memcmp(d[0].light, d[1].light, sizeof d[0].light) == 0);
        hd_decomposition_free(&d[0]);
        hd_decomposition_free(&d[1]);
        hd_image_free(&img);
        hd_model_free(m);
    }

    /* mismatched configurations */
    run_options(&o, "resumed", 8);
    o.resume = 1;
    o.width = 8;
    CHECK(hd_train(&o, &r) != HD_OK && strstr(hd_error(), "width") && strstr(hd_error(), "checkpoint.safetensors"));
    run_options(&o, "resumed", 8);
    o.resume = 1;
    o.batch = 1;
    CHECK(hd_train(&o, &r) != HD_OK && strstr(hd_error(), "batch"));
    run_options(&o, "resumed", 8);
    o.resume = 1;
    o.stage = 2;
    o.batch = 0;
    CHECK(hd_train(&o, &r) != HD_OK && strstr(hd_error(), "stage"));

    /* a model file is not a checkpoint; a checkpoint loads as a model */
    hd_trainer t;
    if (tiny_trainer(&t, 4, 32, 2)) {
        CHECK(hd_trainer_load(&t, "straight/model.safetensors") != HD_OK && strstr(hd_error(), "model.safetensors"));
        CHECK(hd_trainer_load(&t, "straight/checkpoint.safetensors") == HD_OK && t.iteration == 6);
        hd_trainer_free(&t);
    }
    CHECK(hd_model_load("straight/checkpoint.safetensors", &m) == HD_OK);
    hd_model_free(m);

    /* broken files: truncated, missing tensor, wrong shape, not hdnet, missing */
    char *data = NULL;
    size_t n = 0;
    CHECK(hd_read_file("straight/model.safetensors", 1 << 24, &data, &n) == HD_OK);
    FILE *f = fopen("truncated.safetensors", "wb");
    if (f && data) {
        fwrite(data, 1, n / 2, f);
        fclose(f);
    }
    free(data);
    CHECK(hd_model_load("truncated.safetensors", &m) != HD_OK && strstr(hd_error(), "truncated.safetensors"));
    CHECK(hd_model_load("missing.safetensors", &m) != HD_OK && strstr(hd_error(), "missing.safetensors"));
    {
        float w[32 * 3 * 9] = {0};
        hd_tensor tt = {"conv_in.weight", 4, {32, 3, 3, 3}, w};
        const char *k[3] = {"format", "format_version", "width"}, *v[3] = {"hdnet", "1", "4"};
        const char *k2[4] = {"format", "format_version", "width", "size"}, *v2[4] = {"hdnet", "1", "4", "32"};
        CHECK(hd_safetensors_write("nosize.safetensors", &tt, 1, k, v, 3) == HD_OK);
        CHECK(hd_model_load("nosize.safetensors", &m) != HD_OK && strstr(hd_error(), "size"));
        CHECK(hd_safetensors_write("partial.safetensors", &tt, 1, k2, v2, 4) == HD_OK);
        CHECK(hd_model_load("partial.safetensors", &m) != HD_OK && strstr(hd_error(), "conv_in.bias") &&
              strstr(hd_error(), "partial.safetensors"));
        hd_tensor bad = {"conv_in.weight", 4, {32, 1, 3, 3}, w};
        CHECK(hd_safetensors_write("shape.safetensors", &bad, 1, k2, v2, 4) == HD_OK);
        CHECK(hd_model_load("shape.safetensors", &m) != HD_OK && strstr(hd_error(), "conv_in.weight") &&
              strstr(hd_error(), "shape"));
        CHECK(hd_safetensors_write("foreign.safetensors", &tt, 1, NULL, NULL, 0) == HD_OK);
        CHECK(hd_model_load("foreign.safetensors", &m) != HD_OK && strstr(hd_error(), "not an hdnet model"));
    }

    /* a diverging run stops at a NaN or infinity, naming it, and keeps the last good checkpoint */
    run_options(&o, "diverge", 50);
    o.every = 1;
    o.lr = 1e30f;
    hd_status s = hd_train(&o, &r);
    CHECK(s == HD_ERR_NUMERIC);
    CHECK(strstr(hd_error(), "iteration") != NULL);
    fprintf(stderr, "diverging run: %s\n", hd_error());
    if (tiny_trainer(&t, 4, 32, 2)) {
        CHECK(hd_trainer_load(&t, "diverge/checkpoint.safetensors") == HD_OK);
        CHECK(t.iteration == r.iteration && t.iteration >= 1);
        hd_trainer_free(&t);
    }
}

/* ---- the albedo_gt term by hand: mean over pairs of the masked L1 of the images with a truth */

static void test_albedo_supervised(void)
{
    hd_trainer t;
    if (!tiny_trainer(&t, 4, 32, 2)) return;
    hd_step_result r;
    CHECK(hd_trainer_eval(&t, &r, HD_EVAL_LOSS) == HD_OK);
    size_t HW = 32 * 32;
    double want = 0;
    for (int b = 0; b < 4; b++) {
        if (!t.batch.has_albedo[b]) continue;
        double num = 0, den = 0;
        for (int c = 0; c < 3; c++)
            for (size_t p = 0; p < HW; p++) {
                double m = t.batch.mask[b * HW + p];
                num += m * fabs(t.net.albedo[(b * 3 + c) * HW + p] - t.batch.albedo_gt[(b * 3 + c) * HW + p]);
                den += m;
            }
        want += t.batch.weight[b] * num / den; /* the domain weight of make_pair */
    }
    want /= 2; /* pairs */
    CHECK(want > 0.01);
    CHECK_NEAR(r.terms[HD_LOSS_ALBEDO_GT], want, 1e-5);
    /* images without a truth do not count */
    memset(t.batch.has_albedo, 0, 4);
    CHECK(hd_trainer_eval(&t, &r, HD_EVAL_LOSS) == HD_OK);
    CHECK(r.terms[HD_LOSS_ALBEDO_GT] == 0.0);
    hd_trainer_free(&t);
}

/* ---- the camera's colour gain: L_Irec by hand with and without it, NAME.camera.txt read into the
 * batch by the loader, and clear errors for a malformed record */

static hd_status write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "wb");
    if (!f) return HD_ERR_IO;
    int ok = fputs(text, f) >= 0;
    return fclose(f) == 0 && ok ? HD_OK : HD_ERR_IO;
}

static void test_rec_camera_gain(void)
{
    hd_trainer t;
    if (!tiny_trainer(&t, 4, 32, 2)) return;
    size_t HW = 32 * 32;
    static const float gains[4][3] = {{1.2f, 1.0f, 0.8f}, {1.0f, 1.0f, 1.0f}, {0.85f, 1.05f, 1.1f}, {1.3f, 0.9f, 0.7f}};
    hd_step_result r1, rg;
    CHECK(hd_trainer_eval(&t, &r1, HD_EVAL_LOSS) == HD_OK);
    memcpy(t.batch.camera_gain, gains, sizeof gains);
    CHECK(hd_trainer_eval(&t, &rg, HD_EVAL_LOSS) == HD_OK);
    double want[2] = {0, 0};
    for (int b = 0; b < 4; b++)
        for (int k = 0; k < 2; k++) {
            double num = 0, den = 0;
            for (int c = 0; c < 3; c++)
                for (size_t p = 0; p < HW; p++) {
                    double m = t.batch.mask[b * HW + p], g = k ? gains[b][c] : 1.0;
                    double rec = (double)t.net.albedo[(b * 3 + c) * HW + p] * t.net.shading[b * HW + p] * g;
                    num += m * fabs(t.batch.image[(b * 3 + c) * HW + p] - rec);
                    den += m;
                }
            want[k] += t.batch.weight[b] * num / den / 2; /* the mean over 2 pairs */
        }
    CHECK_NEAR(r1.terms[HD_LOSS_REC], want[0], 1e-5);
    CHECK_NEAR(rg.terms[HD_LOSS_REC], want[1], 1e-5);
    CHECK(fabs(rg.terms[HD_LOSS_REC] - r1.terms[HD_LOSS_REC]) > 1e-3); /* the gain matters */
    for (int k = HD_LOSS_REC + 1; k < HD_LOSS_TERMS; k++) CHECK(rg.terms[k] == r1.terms[k]); /* only L_Irec sees it */
    hd_trainer_free(&t);

    /* the record: light colour times white balance; the other effects' lines skipped */
    const char *path = "camera_gain.txt";
    float g[3] = {0, 0, 0};
    CHECK(write_text(path, "light_colour 1.1000 1.0000 0.9000\nblur_sigma 0.74\nnoise 0.018 0.000044\n"
                              "white_balance 1.2000 0.9900 0.8000\njpeg_quality 62\n") == HD_OK);
    CHECK(hd_camera_gain_read(path, g) == HD_OK);
    CHECK_NEAR(g[0], 1.32, 1e-5);
    CHECK_NEAR(g[1], 0.99, 1e-5);
    CHECK_NEAR(g[2], 0.72, 1e-5);
    CHECK(write_text(path, "blur_sigma 1.2\n") == HD_OK);
    CHECK(hd_camera_gain_read(path, g) == HD_OK);
    CHECK(g[0] == 1.0f && g[1] == 1.0f && g[2] == 1.0f);
    static const char *const bad[] = {"white_balance 1.2 1.0\n", "white_balance 1.2 1.0 0.8 0.9\n", "light_colour 1.2 x 0.8\n",
                                      "white_balance 1.2 -1 0.8\n", "white_balance 1.2 nan 0.8\n", "blur 0.7\n",
                                      "jpeg_quality\n"};
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
        g[0] = g[1] = g[2] = 5.0f;
        CHECK(write_text(path, bad[k]) == HD_OK);
        CHECK(hd_camera_gain_read(path, g) == HD_ERR_FORMAT);
        CHECK(strstr(hd_error(), "camera_gain.txt:1:") != NULL);
        CHECK(g[0] == 5.0f); /* untouched on failure */
    }
    CHECK(hd_camera_gain_read("no_such.camera.txt", g) == HD_ERR_IO && strstr(hd_error(), "no_such.camera.txt"));
    remove(path);

    /* the loader: every image of camdata has a record; its gain reaches the batch only when the
     * source reads it, and a malformed record skips the pair with a warning naming the file */
    if (!write_dataset("camdata", 32)) {
        test_failures++;
        return;
    }
    char file[128];
    for (int person = 0; person < 2; person++)
        for (int k = 0; k < 4; k++) {
            snprintf(file, sizeof file, "camdata/person%d/img%d.camera.txt", person, k);
            CHECK(write_text(file, "white_balance 1.2000 1.0000 0.8000\nlight_colour 0.9000 1.0000 1.1000\n") == HD_OK);
        }
    hd_dataset ds;
    hd_pair_source src;
    int skipped, first;
    CHECK(hd_dataset_scan("camdata", &ds, NULL) == HD_OK);
    CHECK(ds.count == 8 && ds.samples[0].camera && strstr(ds.samples[0].camera, "img0.camera.txt"));
    CHECK(hd_pair_source_init(&src, &ds, 0, 0, &skipped, &first) == HD_OK);
    src.size = 32;
    src.seed = 3;
    hd_pair_batch b;
    CHECK(hd_pair_batch_alloc(&b, 2, 32) == HD_OK);
    for (int on = 0; on < 2; on++) {
        src.camera_gain = on;
        hd_loader L = {0};
        L.src = &src;
        L.batch = &b;
        hd_loader_start(&L, 0);
        CHECK(hd_loader_wait(&L, NULL) == HD_OK);
        for (int slot = 0; slot < 4; slot++) {
            CHECK_NEAR(b.camera_gain[slot * 3 + 0], on ? 1.08 : 1.0, 1e-5);
            CHECK_NEAR(b.camera_gain[slot * 3 + 1], 1.0, 1e-6);
            CHECK_NEAR(b.camera_gain[slot * 3 + 2], on ? 0.88 : 1.0, 1e-5);
        }
    }
    CHECK(write_text("camdata/person1/img2.camera.txt", "white_balance 1.2 1.0\n") == HD_OK);
    int warned = 0;
    for (long it = 0; it < 40 && !warned; it++) {
        hd_loader L = {0};
        L.src = &src;
        L.batch = &b;
        hd_loader_start(&L, it);
        CHECK(hd_loader_wait(&L, NULL) == HD_OK); /* replaced by the slot's next draw */
        warned = strstr(L.warnings, "camdata/person1/img2.camera.txt:1: white_balance takes 3 numbers") != NULL;
    }
    CHECK(warned);
    hd_pair_batch_free(&b);
    hd_pair_source_free(&src);
    hd_dataset_free(&ds);
}

/* ---- the scale anchor by hand, per image and on the pair: |mean_m S - c| */

/* ---- the shading prior: its target on a grey face under a known light, its value, its warm-up */
static void test_shading_prior(void)
{
    hd_trainer t;
    if (!tiny_trainer(&t, 4, 32, 2)) return;
    size_t HW = 32 * 32;
    float l[HD_SH_COEFFS];
    hd_light_from_direction(30.0f, 15.0f, 0.8f, 0.5f, l);
    /* image 1 is an even grey albedo 0.5 under l: its luminance is 0.5 s(N_bar, l) exactly, so
     * the target is s(N_bar, l) scaled to the anchor's mean c over the face */
    float *I = t.batch.image + 3 * HW, *N = t.batch.coarse_normal + 3 * HW, *m = t.batch.mask + HW;
    double ms = 0, msum = 0;
    for (size_t p = 0; p < HW; p++) {
        float n[3] = {N[p], N[HW + p], N[2 * HW + p]}, s = hd_sh_shade(l, n);
        CHECK(s > 0.0f && 0.5f * s < 1.0f);
        for (int c = 0; c < 3; c++) I[c * HW + p] = 0.5f * s;
        ms += m[p];
        msum += m[p] * s;
    }
    memset(&t.weights, 0, sizeof t.weights);
    t.weights.w[HD_LOSS_SHADING_PRIOR] = 1.0f;
    hd_step_result r;
    CHECK(hd_trainer_eval(&t, &r, HD_EVAL_LOSS) == HD_OK);
    double k = t.losses.shading_mean * ms / msum, worst = 0;
    for (size_t p = 0; p < HW; p++) {
        if (m[p] == 0.0f) continue;
        float n[3] = {N[p], N[HW + p], N[2 * HW + p]};
        worst = fmax(worst, fabs(t.losses.prior[HW + p] - k * hd_sh_shade(l, n)));
    }
    CHECK(worst < 1e-4);
    /* the value: sum over images of w_b mean_m |S - target| / P, from the buffers */
    double want = 0;
    for (int b = 0; b < 4; b++) {
        double num = 0, den = 0;
        for (size_t p = 0; p < HW; p++) {
            num += t.batch.mask[b * HW + p] * fabs(t.net.shading[b * HW + p] - t.losses.prior[b * HW + p]);
            den += t.batch.mask[b * HW + p];
        }
        want += t.batch.weight[b] * num / den;
    }
    CHECK(want > 1e-3);
    CHECK_NEAR(r.terms[HD_LOSS_SHADING_PRIOR], want / 2, 1e-5);
    CHECK_NEAR(r.total, r.terms[HD_LOSS_SHADING_PRIOR], 1e-6);
    /* images without coarse normals have no prior */
    t.batch.has_normal[0] = t.batch.has_normal[1] = t.batch.has_normal[2] = t.batch.has_normal[3] = 0;
    CHECK(hd_trainer_eval(&t, &r, HD_EVAL_LOSS) == HD_OK);
    CHECK(r.terms[HD_LOSS_SHADING_PRIOR] == 0.0);
    t.batch.has_normal[0] = t.batch.has_normal[1] = t.batch.has_normal[2] = t.batch.has_normal[3] = 1;
    /* the warm-up: the weight falls linearly over K iterations, then the term leaves the total */
    t.shading_prior_iters = 10;
    CHECK(hd_trainer_prior_ramp(&t, 0) == 1.0f && hd_trainer_prior_ramp(&t, 10) == 0.0f && hd_trainer_prior_ramp(&t, 99) == 0.0f);
    CHECK_NEAR(hd_trainer_prior_ramp(&t, 4), 0.6, 1e-6);
    t.iteration = 5;
    CHECK(hd_trainer_eval(&t, &r, HD_EVAL_LOSS) == HD_OK);
    CHECK_NEAR(r.total, 0.5 * r.terms[HD_LOSS_SHADING_PRIOR], 1e-6);
    t.iteration = 10;
    CHECK(hd_trainer_eval(&t, &r, HD_EVAL_LOSS) == HD_OK);
    CHECK(r.total == 0.0 && r.terms[HD_LOSS_SHADING_PRIOR] > 1e-3);
    t.shading_prior_iters = 0;
    CHECK(hd_trainer_prior_ramp(&t, 1000000) == 1.0f);
    t.iteration = 0;
    /* the anchor on the pair: image 0 is the same grey face under 0.6 l. Per image, each target's
     * mean over the face is c; on the pair, one scale for both, so the targets are
     * c s(N_bar, l_b) / ((mean_0 + mean_1) / 2) with mean_b the mean of s(N_bar, l_b): the pair's
     * mean is c and the dimmer image keeps its 0.6 */
    float l0[HD_SH_COEFFS];
    for (int c = 0; c < HD_SH_COEFFS; c++) l0[c] = 0.6f * l[c];
    const float *lb[2] = {l0, l};
    double mean[2];
    for (int b = 0; b < 2; b++) {
        float *Ib = t.batch.image + (size_t)b * 3 * HW, *Nb = t.batch.coarse_normal + (size_t)b * 3 * HW;
        const float *mb = t.batch.mask + (size_t)b * HW;
        double sm = 0, ss = 0;
        for (size_t p = 0; p < HW; p++) {
            float n[3] = {Nb[p], Nb[HW + p], Nb[2 * HW + p]}, v = hd_sh_shade(lb[b], n);
            for (int c = 0; c < 3; c++) Ib[c * HW + p] = 0.5f * v;
            sm += mb[p];
            ss += mb[p] * v;
        }
        mean[b] = ss / sm;
    }
    for (int pair = 0; pair < 2; pair++) {
        t.losses.shading_mean_pair = pair;
        CHECK(hd_trainer_eval(&t, &r, HD_EVAL_LOSS) == HD_OK);
        double got[2], err = 0;
        for (int b = 0; b < 2; b++) {
            const float *Nb = t.batch.coarse_normal + (size_t)b * 3 * HW, *mb = t.batch.mask + (size_t)b * HW;
            double kb = t.losses.shading_mean / (pair ? 0.5 * (mean[0] + mean[1]) : mean[b]), sm = 0, st = 0;
            for (size_t p = 0; p < HW; p++) {
                if (mb[p] == 0.0f) continue;
                float n[3] = {Nb[p], Nb[HW + p], Nb[2 * HW + p]};
                err = fmax(err, fabs(t.losses.prior[b * HW + p] - kb * hd_sh_shade(lb[b], n)));
                sm += mb[p];
                st += mb[p] * t.losses.prior[b * HW + p];
            }
            got[b] = st / sm;
        }
        CHECK(err < 1e-4);
        if (pair) {
            CHECK_NEAR(0.5 * (got[0] + got[1]), t.losses.shading_mean, 1e-4);
            CHECK_NEAR(got[0] / got[1], mean[0] / mean[1], 1e-4);
            CHECK_NEAR(mean[0] / mean[1], 0.6, 1e-4);
        } else {
            CHECK_NEAR(got[0], t.losses.shading_mean, 1e-4);
            CHECK_NEAR(got[1], t.losses.shading_mean, 1e-4);
        }
    }
    t.losses.shading_mean_pair = 0;
    hd_trainer_free(&t);
}

/* --shading-prior-normals predicted and --light-fit skin: the prior's target on the predicted
 * normals is the coarse-normal target with N_bar := N; the skin mask leaves out the eyes, brows
 * and inner lips; a face whose parts are black on an even grey skin gets its light exactly from
 * the skin alone, and a biased one from the whole face. */
static void test_shading_prior_options(void)
{
    hd_trainer t;
    if (!tiny_trainer(&t, 4, 32, 2)) return;
    const size_t HW = 32 * 32, B = 4;
    memset(&t.weights, 0, sizeof t.weights);
    t.weights.w[HD_LOSS_SHADING_PRIOR] = 1.0f;
    hd_step_result r;
    float *coarse = malloc(B * HW * sizeof(float)), *on_n = malloc(B * HW * sizeof(float));
    CHECK(hd_trainer_eval(&t, &r, HD_EVAL_LOSS) == HD_OK);
    memcpy(coarse, t.losses.prior, B * HW * sizeof(float));
    t.losses.prior_predicted = 1;
    CHECK(hd_trainer_eval(&t, &r, HD_EVAL_LOSS) == HD_OK);
    memcpy(on_n, t.losses.prior, B * HW * sizeof(float));
    double moved = 0, same = 0;
    for (size_t p = 0; p < B * HW; p++) moved = fmax(moved, fabs(on_n[p] - coarse[p]));
    CHECK(moved > 1e-3); /* the untrained net's normals are not N_bar */
    float *keep = malloc(B * 3 * HW * sizeof(float));
    memcpy(keep, t.batch.coarse_normal, B * 3 * HW * sizeof(float));
    memcpy(t.batch.coarse_normal, t.net.normal, B * 3 * HW * sizeof(float));
    t.losses.prior_predicted = 0;
    CHECK(hd_trainer_eval(&t, &r, HD_EVAL_LOSS) == HD_OK);
    for (size_t p = 0; p < B * HW; p++) same = fmax(same, fabs(t.losses.prior[p] - on_n[p]));
    CHECK(same < 1e-6);
    memcpy(t.batch.coarse_normal, keep, B * 3 * HW * sizeof(float));
    free(keep);

    /* the skin mask: out on the eye contours' centres, in at the nose tip and a cheek */
    CHECK(hd_losses_fit_skin_only(&t.losses) == HD_OK);
    const hd_mesh *mesh;
    CHECK(hd_mesh_canonical(&mesh) == HD_OK);
    const int *eyes[2] = {hd_contour_right_eye, hd_contour_left_eye};
    for (int e = 0; e < 2; e++) {
        double x = 0, y = 0;
        int n = 0;
        for (; eyes[e][n] >= 0; n++) x += mesh->uv[2 * eyes[e][n]], y += mesh->uv[2 * eyes[e][n] + 1];
        CHECK(t.losses.skin[(size_t)(y / n * 32) * 32 + (size_t)(x / n * 32)] == 0.0f);
    }
    const int skin_at[2] = {1, 50}; /* MediaPipe's nose tip and right cheek */
    for (int k = 0; k < 2; k++) {
        const float *uv = mesh->uv + 2 * skin_at[k];
        CHECK(t.losses.skin[(size_t)(uv[1] * 32) * 32 + (size_t)(uv[0] * 32)] == 1.0f);
    }
    /* image 1: grey skin 0.5 s(N_bar, l), black parts */
    float l[HD_SH_COEFFS];
    hd_light_from_direction(30.0f, 15.0f, 0.8f, 0.5f, l);
    float *I = t.batch.image + 3 * HW, *N = t.batch.coarse_normal + 3 * HW, *m = t.batch.mask + HW;
    double ms = 0, msum = 0, parts = 0;
    for (size_t p = 0; p < HW; p++) {
        float n[3] = {N[p], N[HW + p], N[2 * HW + p]}, sh = hd_sh_shade(l, n);
        for (int c = 0; c < 3; c++) I[c * HW + p] = 0.5f * sh * t.losses.skin[p];
        ms += m[p];
        msum += m[p] * sh;
        parts += m[p] * (1.0f - t.losses.skin[p]);
    }
    CHECK(parts > 10);
    double k = t.losses.shading_mean * ms / msum, skin_err = 0, face_err = 0;
    CHECK(hd_trainer_eval(&t, &r, HD_EVAL_LOSS) == HD_OK);
    for (size_t p = 0; p < HW; p++) {
        float n[3] = {N[p], N[HW + p], N[2 * HW + p]};
        if (m[p] != 0.0f) skin_err = fmax(skin_err, fabs(t.losses.prior[HW + p] - k * hd_sh_shade(l, n)));
    }
    free(t.losses.skin), free(t.losses.fit_weight);
    t.losses.skin = t.losses.fit_weight = NULL;
    CHECK(hd_trainer_eval(&t, &r, HD_EVAL_LOSS) == HD_OK);
    for (size_t p = 0; p < HW; p++) {
        float n[3] = {N[p], N[HW + p], N[2 * HW + p]};
        if (m[p] != 0.0f) face_err = fmax(face_err, fabs(t.losses.prior[HW + p] - k * hd_sh_shade(l, n)));
    }
    CHECK(skin_err < 1e-4);
    CHECK(face_err > 1e-2);
    free(coarse), free(on_n);
    hd_trainer_free(&t);
}

static void test_shading_mean(void)
{
    hd_trainer t;
    if (!tiny_trainer(&t, 4, 32, 2)) return;
    hd_step_result r;
    CHECK(hd_trainer_eval(&t, &r, HD_EVAL_LOSS) == HD_OK);
    size_t HW = 32 * 32;
    double mean[4];
    for (int b = 0; b < 4; b++) {
        double num = 0, den = 0;
        for (size_t p = 0; p < HW; p++) {
            num += t.batch.mask[b * HW + p] * t.net.shading[b * HW + p];
            den += t.batch.mask[b * HW + p];
        }
        mean[b] = num / den;
    }
    double c = t.losses.shading_mean, want_image = 0, want_pair = 0;
    for (int b = 0; b < 4; b++) {
        want_image += t.batch.weight[b] * fabs(mean[b] - c);
        want_pair += t.batch.weight[b] * fabs(0.5 * (mean[b & ~1] + mean[b | 1]) - c);
    }
    CHECK(want_image > 1e-3);
    CHECK_NEAR(r.terms[HD_LOSS_SHADING_MEAN], want_image / 2, 1e-5);
    t.losses.shading_mean_pair = 1;
    CHECK(hd_trainer_eval(&t, &r, HD_EVAL_LOSS) == HD_OK);
    CHECK_NEAR(r.terms[HD_LOSS_SHADING_MEAN], want_pair / 2, 1e-5);
    /* a target between the pair's two means: the pair term is smaller than the image term */
    t.losses.shading_mean = (float)(0.5 * (mean[0] + mean[1]));
    t.losses.shading_mean_pair = 0;
    CHECK(hd_trainer_eval(&t, &r, HD_EVAL_LOSS) == HD_OK);
    double image_term = r.terms[HD_LOSS_SHADING_MEAN];
    t.losses.shading_mean_pair = 1;
    CHECK(hd_trainer_eval(&t, &r, HD_EVAL_LOSS) == HD_OK);
    CHECK(r.terms[HD_LOSS_SHADING_MEAN] < image_term || mean[0] == mean[1]);
    hd_trainer_free(&t);
}

/* ---- L_lpair: its value from the L-Net outputs (the identity for a same-light pair, the mirror
 * for a mirror pair, nothing for an unrelated one, each pair by image i's domain weight), its
 * gradient wrt every light by central differences at set lights away from the kinks of |d|, and
 * zero for a pair of one image twice. (Its path from l into L-Net is L_l's, checked above.) */
static void test_light_pair(void)
{
    hd_trainer t;
    if (!tiny_trainer(&t, 4, 32, 3)) return;
    memset(&t.weights, 0, sizeof t.weights);
    t.weights.w[HD_LOSS_LIGHT_PAIR] = 1.0f;
    t.batch.pair_light[0] = HD_PAIR_LIGHT_SAME;
    t.batch.pair_light[1] = HD_PAIR_LIGHT_MIRROR;
    t.batch.pair_light[2] = HD_PAIR_LIGHT_NONE;
    t.batch.weight[0] = t.batch.weight[1] = 1.0f;
    t.batch.weight[2] = t.batch.weight[3] = 0.5f; /* pair 1 counts half */
    hd_step_result r;
    CHECK(hd_trainer_eval(&t, &r, HD_EVAL_LOSS) == HD_OK);
    /* lights set by hand: every difference at least 0.05 */
    hd_rng g;
    hd_rng_seed(&g, 5, 1);
    float *l = t.net.light;
    for (int k = 0; k < 6 * HD_SH_COEFFS; k++) l[k] = hd_rng_range(&g, -1.0f, 1.0f);
    for (int k = 0; k < HD_SH_COEFFS; k++) {
        l[HD_SH_COEFFS + k] = l[k] + (k % 2 ? 0.3f : -0.2f) - 0.01f * k; /* pair 0: l_j = l_i + d */
        float m = k == 3 || k == 4 || k == 7 ? -l[2 * HD_SH_COEFFS + k] : l[2 * HD_SH_COEFFS + k];
        l[3 * HD_SH_COEFFS + k] = m + (k % 3 ? 0.25f : -0.15f); /* pair 1: l_j = mirror(l_i) + d */
    }
    double want = 0;
    for (int k = 0; k < HD_SH_COEFFS; k++)
        want += (fabs((k % 2 ? 0.3 : -0.2) - 0.01 * k) + 0.5 * fabs(k % 3 ? 0.25 : -0.15)) / HD_SH_COEFFS;
    memset(t.net.d_light, 0, 6 * HD_SH_COEFFS * sizeof(float));
    CHECK_NEAR(hd_loss_light_pair(&t.losses, 1.0f), want / 3, 1e-6);
    for (int k = 0; k < 6 * HD_SH_COEFFS; k++) {
        float keep = l[k];
        l[k] = keep + 1e-3f;
        double up = hd_loss_light_pair(&t.losses, 0.0f);
        l[k] = keep - 1e-3f;
        double down = hd_loss_light_pair(&t.losses, 0.0f);
        l[k] = keep;
        CHECK_NEAR(t.net.d_light[k], (up - down) / 2e-3, 1e-4);
    }
    /* pair 2 is unrelated: no gradient reaches its lights */
    for (int k = 4 * HD_SH_COEFFS; k < 6 * HD_SH_COEFFS; k++) CHECK(t.net.d_light[k] == 0.0f);
    /* through the trainer: the value from L-Net's own outputs */
    CHECK(hd_trainer_eval(&t, &r, HD_EVAL_LOSS) == HD_OK);
    want = 0;
    for (int p = 0; p < 2; p++) {
        float ri[HD_SH_COEFFS];
        memcpy(ri, l + 2 * p * HD_SH_COEFFS, sizeof ri);
        if (p == 1) ri[3] = -ri[3], ri[4] = -ri[4], ri[7] = -ri[7]; /* x, yx and xz change sign */
        double s = 0;
        for (int k = 0; k < HD_SH_COEFFS; k++) s += fabs(l[(2 * p + 1) * HD_SH_COEFFS + k] - ri[k]);
        want += (p == 1 ? 0.5 : 1.0) * s / HD_SH_COEFFS;
    }
    CHECK(want > 1e-4);
    CHECK_NEAR(r.terms[HD_LOSS_LIGHT_PAIR], want / 3, 1e-6);
    CHECK_NEAR(r.total, r.terms[HD_LOSS_LIGHT_PAIR], 1e-7);
    /* a same-light pair of one image twice: one light, no loss */
    size_t HW = 32 * 32;
    memcpy(t.batch.image + 3 * HW, t.batch.image, 3 * HW * sizeof(float));
    memcpy(t.batch.mask + HW, t.batch.mask, HW * sizeof(float));
    memcpy(t.batch.coarse_normal + 3 * HW, t.batch.coarse_normal, 3 * HW * sizeof(float));
    t.batch.pair_light[1] = t.batch.pair_light[2] = HD_PAIR_LIGHT_NONE;
    CHECK(hd_trainer_eval(&t, &r, HD_EVAL_LOSS) == HD_OK);
    CHECK(r.terms[HD_LOSS_LIGHT_PAIR] < 1e-7);
    /* no relation anywhere (the presets, synthetic pairs): the term is 0 */
    t.batch.pair_light[0] = HD_PAIR_LIGHT_NONE;
    memcpy(t.batch.image + 3 * HW, t.batch.image + 6 * HW, 3 * HW * sizeof(float));
    CHECK(hd_trainer_eval(&t, &r, HD_EVAL_LOSS) == HD_OK);
    CHECK(r.terms[HD_LOSS_LIGHT_PAIR] == 0.0);
    hd_trainer_free(&t);
}

/* ---- L_fpair: f is the light hd_face_light fits to the network's own S on N (the relighting
 * rule's source light), the value is L_lpair's on those lights, the gradient wrt S and N agrees
 * with central differences on the activations (the lobe held) and through every sub-net, an
 * unrelated pair gets none, a pair of one image twice has no loss, and the term is off until
 * hd_losses_fit_pair_on. */

/* One directional derivative of L_fpair wrt the activations x (S or N of every image): 0 if the
 * central difference and the analytic gradient dx agree. */
static int fit_pair_direction(hd_trainer *t, float *x, const float *dx, size_t n, float eps, uint64_t seed)
{
    float *keep = malloc(n * sizeof(float)), *dir = malloc(n * sizeof(float));
    hd_rng g;
    hd_rng_seed(&g, 31, seed);
    double gd = 0;
    for (size_t i = 0; i < n; i++) {
        keep[i] = x[i];
        dir[i] = hd_rng_range(&g, -1.0f, 1.0f);
        gd += (double)dx[i] * dir[i];
    }
    double v[2];
    for (int k = 0; k < 2; k++) {
        for (size_t i = 0; i < n; i++) x[i] = keep[i] + (k ? -eps : eps) * dir[i];
        CHECK(hd_losses_prepare(&t->losses, &t->batch, HD_LIGHT_FROM_COARSE) == HD_OK);
        v[k] = hd_loss_fit_pair(&t->losses, 0.0f);
    }
    memcpy(x, keep, n * sizeof(float));
    free(keep);
    free(dir);
    double fd = (v[0] - v[1]) / (2 * eps);
    int ok = fabs(fd - gd) <= 0.02 * fmax(fabs(fd), fabs(gd)) + 1e-7;
    if (!ok) fprintf(stderr, "fit_pair: finite difference %.7g, analytic %.7g\n", fd, gd);
    return ok;
}

static void test_fit_pair(void)
{
    enum { S = 32, B = 6 };
    const size_t HW = (size_t)S * S;
    hd_trainer t;
    if (!tiny_trainer(&t, 4, S, 3)) return;
    memset(&t.weights, 0, sizeof t.weights);
    t.weights.w[HD_LOSS_FIT_PAIR] = 1.0f;
    t.batch.pair_light[0] = HD_PAIR_LIGHT_SAME;
    t.batch.pair_light[1] = HD_PAIR_LIGHT_MIRROR;
    t.batch.pair_light[2] = HD_PAIR_LIGHT_NONE;
    hd_step_result r;
    CHECK(hd_trainer_eval(&t, &r, HD_EVAL_LOSS) == HD_OK);
    CHECK(r.terms[HD_LOSS_FIT_PAIR] == 0.0); /* off */
    CHECK(hd_losses_fit_pair_on(&t.losses) == HD_OK);
    CHECK(hd_trainer_eval(&t, &r, HD_EVAL_LOSS) == HD_OK);
    /* f of every related image is the rule's source light of the network's maps */
    float f[4][HD_SH_COEFFS];
    for (int b = 0; b < 4; b++) {
        hd_decomposition d = {0};
        d.shading = (hd_image){S, S, 1, t.net.shading + b * HW};
        d.normal = (hd_image){S, S, 3, t.net.normal + b * 3 * HW};
        hd_image mask = {S, S, 1, t.batch.mask + b * HW};
        CHECK(hd_face_light(&d, &mask, HD_SOURCE_FIT, f[b]) == HD_OK);
        for (int k = 0; k < HD_SH_COEFFS; k++)
            CHECK_NEAR(t.losses.fit_light[b * HD_SH_COEFFS + k], f[b][k], 1e-5 * (1 + fabs(f[b][k])));
    }
    double want = 0;
    for (int p = 0; p < 2; p++) {
        float ri[HD_SH_COEFFS];
        memcpy(ri, f[2 * p], sizeof ri);
        if (p == 1) ri[3] = -ri[3], ri[4] = -ri[4], ri[7] = -ri[7];
        double s = 0;
        for (int k = 0; k < HD_SH_COEFFS; k++) s += fabs(f[2 * p + 1][k] - ri[k]);
        want += t.batch.weight[2 * p] * s / HD_SH_COEFFS;
    }
    CHECK(want > 1e-4);
    CHECK_NEAR(r.terms[HD_LOSS_FIT_PAIR], want / 3, 1e-6);
    CHECK_NEAR(r.total, r.terms[HD_LOSS_FIT_PAIR], 1e-7);
    /* the gradient wrt S and N against central differences, the lobe held */
    CHECK(hd_losses_prepare(&t.losses, &t.batch, HD_LIGHT_FROM_COARSE) == HD_OK);
    memset(t.net.d_shading, 0, B * HW * sizeof(float));
    memset(t.net.d_normal, 0, B * 3 * HW * sizeof(float));
    hd_loss_fit_pair(&t.losses, 1.0f);
    t.losses.hold_light_hat = 1;
    for (uint64_t k = 0; k < 2; k++) {
        if (!fit_pair_direction(&t, t.net.shading, t.net.d_shading, 4 * HW, 1e-2f, k)) test_failures++;
        if (!fit_pair_direction(&t, t.net.normal, t.net.d_normal, 4 * 3 * HW, 1e-3f, 10 + k)) test_failures++;
    }
    t.losses.hold_light_hat = 0;
    double none = 0;
    for (size_t i = 4 * HW; i < B * HW; i++) none += fabsf(t.net.d_shading[i]);
    for (size_t i = 4 * 3 * HW; i < B * 3 * HW; i++) none += fabsf(t.net.d_normal[i]);
    CHECK(none == 0.0); /* pair 2 is unrelated */
    /* through the network, sub-net by sub-net */
    check_gradients(&t, "fit_pair", 0, 1, 1e-3f, 0);
    /* a same-light pair of one image twice: one light, no loss */
    memcpy(t.batch.image + 3 * HW, t.batch.image, 3 * HW * sizeof(float));
    memcpy(t.batch.mask + HW, t.batch.mask, HW * sizeof(float));
    memcpy(t.batch.coarse_normal + 3 * HW, t.batch.coarse_normal, 3 * HW * sizeof(float));
    t.batch.pair_light[1] = HD_PAIR_LIGHT_NONE;
    CHECK(hd_trainer_eval(&t, &r, HD_EVAL_LOSS) == HD_OK);
    CHECK(r.terms[HD_LOSS_FIT_PAIR] < 1e-7);
    hd_trainer_free(&t);
}

/* ---- --light-target face: l_hat is the relighting rule's face light (hd_face_light, src/apply) of
 * the network's own S on its normals, in stage 2 on the predicted N and in stage 1 on N_bar; L_l is
 * mean |l - l_hat| against it; the plain fit over the mask is another light */

static void test_light_from_face(void)
{
    enum { S = 32 };
    const size_t HW = (size_t)S * S;
    hd_trainer t;
    if (!tiny_trainer(&t, 4, S, 2)) return;
    memset(&t.weights, 0, sizeof t.weights);
    t.weights.w[HD_LOSS_LIGHT] = 1.0f;
    hd_step_result r;
    for (int stage = 1; stage <= 2; stage++) {
        t.stage = stage;
        t.losses.light_from_face = 0;
        CHECK(hd_trainer_eval(&t, &r, HD_EVAL_LOSS) == HD_OK);
        float plain[4 * HD_SH_COEFFS];
        memcpy(plain, t.losses.light_hat, sizeof plain);
        CHECK(hd_losses_light_from_face(&t.losses) == HD_OK && t.losses.light_from_face && !t.losses.fit_pair);
        CHECK(hd_trainer_eval(&t, &r, HD_EVAL_LOSS) == HD_OK);
        double want = 0, apart = 0;
        for (int b = 0; b < 4; b++) {
            hd_decomposition d = {0};
            float f[HD_SH_COEFFS];
            d.shading = (hd_image){S, S, 1, t.net.shading + b * HW};
            d.normal = (hd_image){S, S, 3, (stage == 1 ? t.batch.coarse_normal : t.net.normal) + b * 3 * HW};
            hd_image mask = {S, S, 1, t.batch.mask + b * HW};
            CHECK(hd_face_light(&d, &mask, HD_SOURCE_FIT, f) == HD_OK);
            double s = 0;
            for (int k = 0; k < HD_SH_COEFFS; k++) {
                float lh = t.losses.light_hat[b * HD_SH_COEFFS + k];
                CHECK_NEAR(lh, f[k], 1e-5 * (1 + fabs(f[k])));
                s += fabs(t.net.light[b * HD_SH_COEFFS + k] - lh);
                apart += fabs(plain[b * HD_SH_COEFFS + k] - lh);
            }
            want += t.batch.weight[b] * s / HD_SH_COEFFS;
        }
        CHECK_NEAR(r.terms[HD_LOSS_LIGHT], want / 2, 1e-5); /* the sum over a pair's two, mean over pairs */
        CHECK(apart > 1e-3);
        CHECK(r.terms[HD_LOSS_FIT_PAIR] == 0.0); /* the layout alone does not turn fit_pair on */
    }
    hd_trainer_free(&t);
}

/* ---- --light-target image: on a face of even albedo a under the light l0 over the coarse
 * normals, l_hat is the least-squares light of the luminance a s(n, l0), scaled so that the mean
 * of its shading over the mask is c: the same light whatever a is (0.2 .. 0.5 here) */

static double masked_mean_shading(const float *l, const float *n, const float *m, size_t HW)
{
    double ms = 0, mS = 0;
    for (size_t p = 0; p < HW; p++) {
        float q[3] = {n[p], n[HW + p], n[2 * HW + p]}, g[3];
        ms += m[p];
        mS += m[p] * hd_sh_shade_grad(l, q, g);
    }
    return mS / ms;
}

static void test_light_from_image(void)
{
    hd_trainer t;
    if (!tiny_trainer(&t, 4, 32, 2)) return;
    size_t HW = 32 * 32;
    const float l0[HD_SH_COEFFS] = {0.9f, 0.1f, 0.3f, -0.25f, 0.05f, 0.02f, -0.04f, 0.03f, 0.06f};
    const float *n = t.batch.coarse_normal;
    float *s0 = malloc(HW * sizeof(float)), fit[HD_SH_COEFFS];
    for (size_t p = 0; p < HW; p++) {
        float q[3] = {n[p], n[HW + p], n[2 * HW + p]}, g[3];
        s0[p] = hd_sh_shade_grad(l0, q, g);
        for (int b = 0; b < 4; b++) /* every image alike (make_pair gives them one geometry): the */
            for (int c = 0; c < 3; c++) /* last micro-batch's l_hat is the one left to read */
                t.batch.image[(b * 3 + c) * HW + p] = (0.2f + 0.1f * b) * s0[p];
    }
    for (int b = 0; b < 4; b++) CHECK(t.batch.has_normal[b] && t.batch.mask[b * HW + HW / 2 + 16] == t.batch.mask[HW / 2 + 16]);
    CHECK(hd_sh_fit(n, s0, t.batch.mask, (int)HW, fit) == HD_OK);
    t.losses.light_from_image = 1;
    t.stage = HD_TRAIN_STAGE_1;
    hd_step_result r;
    CHECK(hd_trainer_eval(&t, &r, HD_EVAL_LOSS) == HD_OK);
    const float *lh = t.losses.light_hat;
    double c = t.losses.shading_mean, k = c / masked_mean_shading(fit, n, t.batch.mask, HW);
    CHECK_NEAR(masked_mean_shading(lh, n, t.batch.mask, HW), c, 1e-4);
    for (int i = 0; i < HD_SH_COEFFS; i++) CHECK_NEAR(lh[i], k * fit[i], 1e-4);
    /* the fit is of the photo: close to l0's direction (the cap of normals a face covers leaves
     * the low orders only loosely determined, so this is a sanity bound, not the check above) */
    CHECK(fabs(lh[3] / lh[0] - l0[3] / l0[0]) < 0.05 && fabs(lh[2] / lh[0] - l0[2] / l0[0]) < 0.05);
    /* the fit leaves the backward's accumulator clear */
    for (size_t p = 0; p < 4 * HW; p++) CHECK(t.losses.d_shade[p] == 0.0f);
    free(s0);
    hd_trainer_free(&t);
}

/* ---- the loss plot: labelled axes and a legend, the curves inside the plot area */

/* Pixels of the box with all channels below t (dark) or, with any, at least one (ink of any colour). */
static int count_in(const hd_image *img, int x0, int y0, int x1, int y1, float t, int any)
{
    size_t HW = (size_t)img->width * img->height;
    int n = 0;
    for (int y = y0; y < y1; y++)
        for (int x = x0; x < x1; x++) {
            size_t p = (size_t)y * img->width + x;
            int below = (img->data[p] < t) + (img->data[HW + p] < t) + (img->data[2 * HW + p] < t);
            n += any ? below > 0 : below == 3;
        }
    return n;
}

static int dark_in(const hd_image *img, int x0, int y0, int x1, int y1) { return count_in(img, x0, y0, x1, y1, 0.5f, 0); }
static int ink_in(const hd_image *img, int x0, int y0, int x1, int y1) { return count_in(img, x0, y0, x1, y1, 0.8f, 1); }

static void test_loss_plot(void)
{
    enum { ROWS = 40 };
    hd_train_log h = {0};
    h.n = h.cap = ROWS;
    h.v = malloc(sizeof(float) * ROWS * HD_TRAIN_LOG_COLS);
    for (int i = 0; i < ROWS; i++) /* every curve from 1 down to 0.001 */
        for (int c = 0; c < HD_TRAIN_LOG_COLS; c++)
            h.v[i * HD_TRAIN_LOG_COLS + c] = powf(10.0f, -3.0f * i / (ROWS - 1)) * (c == HD_LOSS_TERMS ? 3.0f : 1.0f);
    CHECK(hd_train_log_plot(&h, "plot_test.png") == HD_OK);
    hd_image img = {0};
    CHECK(hd_image_read("plot_test.png", &img) == HD_OK);
    CHECK(img.width == 900 && img.height == 478);
    if (img.width == 900 && img.height == 478) {
        CHECK(dark_in(&img, 0, 78, 60, 418) > 100);   /* the decades' labels left of the y axis */
        CHECK(dark_in(&img, 64, 442, 900, 458) > 100); /* the iterations' labels under the x axis */
        CHECK(dark_in(&img, 0, 464, 400, 478) > 100);  /* the axis titles */
        CHECK(ink_in(&img, 0, 0, 900, 40) > 100);      /* the legend's first two rows (the terms) */
        CHECK(dark_in(&img, 0, 40, 900, 60) > 20);     /* its third row (fit_pair, the total in black, disc) */
        /* the curves: the total (black) apart from the terms, which all fall from 1 to 0.001 */
        CHECK(dark_in(&img, 70, 68, 880, 436) > 100);
    }
    hd_image_free(&img);
    remove("plot_test.png");
    free(h.v);
}

int main(void)
{
    char models[4300]; /* the shared mesh (the skin mask) from the source tree */
    snprintf(models, sizeof models, "%s/models", test_source_dir());
    setenv("HDNET_DATA", models, 1);
    hd_set_threads(1); /* tiny shapes: threads only add overhead */
    double t0 = hd_seconds();
    test_micro_batch();
    test_albedo_supervised();
    test_rec_camera_gain();
    test_shading_mean();
    test_shading_prior();
    test_shading_prior_options();
    test_light_from_image();
    test_light_pair();
    test_fit_pair();
    test_light_from_face();
    test_loss_plot();
    test_gradients();
    fprintf(stderr, "gradients %.1f s\n", hd_seconds() - t0);
    t0 = hd_seconds();
    test_overfit();
    test_stage2();
    fprintf(stderr, "overfit %.1f s\n", hd_seconds() - t0);
    t0 = hd_seconds();
    test_resume_and_errors();
    test_augmentation();
    fprintf(stderr, "runs %.1f s\n", hd_seconds() - t0);
    return test_summary("test_train");
}
