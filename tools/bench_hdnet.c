/* bench_hdnet.c: the whole-network section of `hdnet bench`: HD-Net's forward per image (the
 * three Common-Nets, conv_in and L-Net), one training step per pair (forward, the seven losses,
 * backward, the discriminator's loss and both Adam updates) at a->size and a->width, each the best
 * of a few timed runs after a warm-up, each also split by stage (hd_net_pass.profile: conv_in, A-, S-,
 * N-, L-Net, the output heads, the discriminator; the step's Adam and "losses and the rest"), and
 * memory: the bytes we count for training at a->batch pairs and at the paper's batch of 8 (whole,
 * and in micro-batches of 2), and the resident set measured during one such micro-batched step. */
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <unistd.h>
#include "bench.h"
#include "hdnet_tool.h"

/* A synthetic batch: smooth colours, a round mask, normals of a sphere (bench.h). */
void bench_fill_batch(hd_pair_batch *b)
{
    int S = b->size;
    size_t HW = (size_t)S * S;
    for (int k = 0; k < 2 * b->pairs; k++) {
        b->has_normal[k] = 1;
        for (int y = 0; y < S; y++)
            for (int x = 0; x < S; x++) {
                size_t p = (size_t)y * S + x;
                float u = (x + 0.5f) / S * 2 - 1, v = 1 - (y + 0.5f) / S * 2, r2 = u * u + v * v;
                float z = r2 < 1 ? 1 - r2 : 0;
                b->mask[(size_t)k * HW + p] = r2 < 0.9f;
                b->coarse_normal[(size_t)k * 3 * HW + p] = 0.6f * u;
                b->coarse_normal[(size_t)k * 3 * HW + HW + p] = 0.6f * v;
                b->coarse_normal[(size_t)k * 3 * HW + 2 * HW + p] = 0.5f + 0.5f * z;
                for (int c = 0; c < 3; c++)
                    b->image[(size_t)k * 3 * HW + c * HW + p] = 0.2f + 0.5f * z * (0.6f + 0.1f * c + 0.1f * (k & 1) * u);
            }
    }
}

/* Bytes a training run holds by our own count: parameters, gradients, Adam moments (HD-Net and
 * discriminator), the activation block, the Common-Nets' arenas, the losses' scratch and two
 * batches (the step's and the loader's next). oneDNN's own buffers (its scratchpads and the
 * reordered copies of the plain-layout layers) are not in it: the measured figures are. */
static size_t training_bytes(const hd_trainer *t)
{
    const hd_net *n = &t->net;
    size_t HW = (size_t)n->H * n->W, B = (size_t)n->B, batch_images = 2 * (size_t)t->batch.pairs;
    size_t floats = 4 * n->table.total + 4 * t->disc.table.total + n->act_floats + t->disc.act_floats;
    floats += B * HW * 12 + HW + B * HD_SH_COEFFS; /* losses */
    floats += 2 * batch_images * 10 * HW;          /* image, mask, coarse normal, albedo: twice */
    return floats * sizeof(float) + hd_unet_memory(n->a_net) + hd_unet_memory(n->s_net) + hd_unet_memory(n->n_net);
}

/* The resident set now, in bytes (Linux: /proc/self/statm), or 0. */
static size_t resident_bytes(void)
{
    FILE *f = fopen("/proc/self/statm", "r");
    long pages_total = 0, pages_resident = 0;
    int ok = f && fscanf(f, "%ld %ld", &pages_total, &pages_resident) == 2;
    if (f) fclose(f);
    long page = sysconf(_SC_PAGESIZE);
    return ok && page > 0 ? (size_t)pages_resident * (size_t)page : 0;
}

static size_t peak_resident_bytes(void)
{
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return (size_t)ru.ru_maxrss * 1024;
}

/* Keeps, stage by stage, the smallest time seen over repeated runs. */
static void profile_min(hd_net_profile *best, const hd_net_profile *p, int first)
{
    for (int k = 0; k < HD_NET_STAGES; k++) {
        if (first || p->fwd[k] < best->fwd[k]) best->fwd[k] = p->fwd[k];
        if (first || p->bwd[k] < best->bwd[k]) best->bwd[k] = p->bwd[k];
    }
}

static double stage_sum(const double *x)
{
    double s = 0;
    for (int k = 0; k < HD_NET_STAGES; k++) s += x[k];
    return s;
}

/* One line of stage times in ms, scaled by `per` (1 / images or 1 / pairs). */
static void print_stages(FILE *o, const char *label, const double *x, double per)
{
    fprintf(o, "    %-16s", label);
    for (int k = 0; k < HD_NET_STAGES; k++) fprintf(o, " %s %.1f", hd_net_stage_names[k], x[k] * per * 1e3);
    fprintf(o, "  (ms)\n");
}

static void json_stages(FILE *o, const char *prefix, const double *x, double per)
{
    for (int k = 0; k < HD_NET_STAGES; k++) fprintf(o, "\"%s_%s_s\": %.6f,\n", prefix, hd_net_stage_names[k], x[k] * per);
}

/* The paper's batch: 8 pairs at the bench's size and width, micro-batches of 2 pairs. */
#define PAPER_BATCH 8
#define PAPER_MICRO 2

int bench_hdnet(const bench_args *a)
{
    FILE *o = a->out ? a->out : stdout;
    int size = a->size > 0 ? a->size : 256, width = a->width > 0 ? a->width : 48;
    int images = a->batch > 0 ? a->batch : 1, repeats = a->repeats > 0 ? a->repeats : 3;
    int step_repeats = repeats < 3 ? repeats : 3;
    hd_net_config cfg = {width, size};
    double peak = a->sgemm_peak_gflops;
    hd_net net;
    hd_trainer t;
    memset(&t, 0, sizeof t);
    hd_net_profile prof, fwd_prof, step_prof;

    /* forward: the best time, and per stage the best over the same runs */
    if (hd_net_create(&net, &cfg, images, HD_NET_INFER, HD_CONV_AUTO) != HD_OK) goto fail;
    hd_train_init_params(&cfg, 1, net.params, NULL);
    for (size_t i = 0; i < (size_t)images * 3 * size * size; i++) net.input[i] = 0.25f + 0.5f * (float)(i % 97) / 97;
    hd_net_forward(&net, NULL); /* warm-up */
    double fwd = 1e30;
    hd_net_pass profiled = {.profile = &prof};
    for (int r = 0; r < repeats; r++) {
        memset(&prof, 0, sizeof prof);
        double t0 = hd_seconds();
        hd_net_forward(&net, &profiled);
        double dt = hd_seconds() - t0;
        fwd = dt < fwd ? dt : fwd;
        profile_min(&fwd_prof, &prof, r == 0);
    }
    size_t infer_bytes = net.act_floats * sizeof(float) + net.table.total * sizeof(float) + hd_unet_memory(net.a_net) +
                         hd_unet_memory(net.s_net) + hd_unet_memory(net.n_net);
    hd_net_free(&net);
    double gflop = 2.0 * hd_net_macs(&cfg) * 1e-9; /* per image */

    /* training step at a->batch pairs; what the stages leave is the losses, Adam and the glue */
    int pairs = images;
    if (hd_trainer_create(&t, &cfg, pairs, 0, 1) != HD_OK) goto fail;
    bench_fill_batch(&t.batch);
    hd_step_result res;
    if (hd_trainer_step(&t, &res, NULL) != HD_OK) goto fail; /* warm-up */
    double step = 1e30;
    t.pass.profile = &prof;
    for (int r = 0; r < step_repeats; r++) {
        memset(&prof, 0, sizeof prof);
        double t0 = hd_seconds();
        if (hd_trainer_step(&t, &res, NULL) != HD_OK) goto fail;
        double dt = hd_seconds() - t0;
        step = dt < step ? dt : step;
        profile_min(&step_prof, &prof, r == 0);
    }
    t.pass.profile = NULL;
    /* both Adam updates alone, as the step makes them */
    double adam = 1e30;
    for (int r = 0; r < step_repeats; r++) {
        double t0 = hd_seconds();
        hd_adam_step(t.net.params, t.net.grads, t.adam_m, t.adam_v, t.net.table.total, t.lr, HD_ADAM_BETA1,
                     HD_ADAM_BETA2, HD_ADAM_EPS, t.adam_t + 1);
        hd_adam_step(t.disc.params, t.disc.grads, t.disc_adam_m, t.disc_adam_v, t.disc.table.total, t.lr,
                     HD_ADAM_BETA1, HD_ADAM_BETA2, HD_ADAM_EPS, t.disc_adam_t + 1);
        double dt = hd_seconds() - t0;
        adam = dt < adam ? dt : adam;
    }
    double staged = stage_sum(step_prof.fwd) + stage_sum(step_prof.bwd);
    double rest = step - staged - adam > 0 ? step - staged - adam : 0.0;
    size_t train_bytes = training_bytes(&t);
    hd_trainer_free(&t);

    /* the paper's batch of 8 pairs: counted whole; counted and run (one step) in micro-batches */
    size_t train8_bytes = 0, train8m_bytes = 0, train8m_resident = 0;
    if (hd_trainer_create(&t, &cfg, PAPER_BATCH, 0, 1) == HD_OK) train8_bytes = training_bytes(&t);
    hd_trainer_free(&t);
    hd_clear_error();
    if (hd_trainer_create(&t, &cfg, PAPER_BATCH, PAPER_MICRO, 1) != HD_OK) goto fail;
    bench_fill_batch(&t.batch);
    train8m_bytes = training_bytes(&t);
    /* (not timed: a first step also pays for touching every page of its memory once) */
    if (hd_trainer_step(&t, &res, NULL) != HD_OK) goto fail;
    train8m_resident = resident_bytes();
    hd_trainer_free(&t);
    size_t peak_rss = peak_resident_bytes();

    double per_image = fwd / images, per_pair = step / pairs;
    if (a->json) {
        fprintf(o, "\"hdnet_gflop_per_image\": %.3f,\n\"hdnet_fwd_s_per_image\": %.6f,\n\"hdnet_fwd_gflops\": %.1f,\n"
                   "\"hdnet_train_step_s_per_pair\": %.6f,\n\"hdnet_train_pairs\": %d,\n\"hdnet_infer_bytes\": %zu,\n"
                   "\"hdnet_train_bytes\": %zu,\n\"hdnet_train_bytes_batch8\": %zu,\n\"hdnet_peak_rss_bytes\": %zu,\n",
                gflop, per_image, gflop / per_image, per_pair, pairs, infer_bytes, train_bytes, train8_bytes, peak_rss);
        json_stages(o, "hdnet_fwd", fwd_prof.fwd, 1.0 / images);
        json_stages(o, "hdnet_step_fwd", step_prof.fwd, 1.0 / pairs);
        json_stages(o, "hdnet_step_bwd", step_prof.bwd, 1.0 / pairs);
        fprintf(o, "\"hdnet_step_adam_s\": %.6f,\n\"hdnet_step_losses_rest_s\": %.6f,\n"
                   "\"hdnet_train_bytes_batch8_micro2\": %zu,\n\"hdnet_train_resident_bytes_batch8_micro2\": %zu,\n",
                adam, rest / pairs, train8m_bytes, train8m_resident);
    } else {
        fprintf(o, "\nHD-Net (width %d) at %dx%d: %.2f GFLOP per image forward\n"
                   "  forward            %8.1f ms per image (batch %d)  %7.1f GFLOP/s  (%.0f%% of SGEMM peak)\n",
                width, size, size, gflop, per_image * 1e3, images, gflop / per_image,
                peak > 0 ? 100 * gflop / per_image / peak : 0.0);
        print_stages(o, "by stage", fwd_prof.fwd, 1.0 / images);
        fprintf(o, "  training step      %8.1f ms per pair (batch %d pairs: forward, losses, backward,\n"
                   "                     discriminator, both Adams)\n",
                per_pair * 1e3, pairs);
        print_stages(o, "forward", step_prof.fwd, 1.0 / pairs);
        print_stages(o, "backward", step_prof.bwd, 1.0 / pairs);
        fprintf(o, "    %-16s Adam (both) %.1f, losses and the rest %.1f  (ms)\n", "besides", adam / pairs * 1e3,
                rest / pairs * 1e3);
        fprintf(o, "  memory             inference %.0f MB; training %.0f MB at batch %d (counted)\n"
                   "                     batch %d: %.0f MB counted whole; in micro-batches of %d: %.0f MB counted,\n"
                   "                     %.0f MB resident measured after one step; peak resident %.0f MB\n",
                infer_bytes / 1048576.0, train_bytes / 1048576.0, pairs, PAPER_BATCH, train8_bytes / 1048576.0,
                PAPER_MICRO, train8m_bytes / 1048576.0, train8m_resident / 1048576.0, peak_rss / 1048576.0);
    }
    fflush(o);
    return 0;
fail:
    fprintf(stderr, "hdnet bench: HD-Net: %s\n", hd_error());
    hd_trainer_free(&t);
    return 1;
}
