/* bench_hdnet.c: the whole-network section of `hdnet bench`: HD-Net's forward per image (the
 * three Common-Nets, conv_in and L-Net), one training step per pair (forward, the seven losses,
 * backward, the discriminator's loss and both Adam updates) at a->size and a->width, each the best
 * of a few timed runs after a warm-up, and memory: the activation and state bytes of a training
 * run at a->batch pairs and at the paper's batch of 8, and the peak resident set. */
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include "bench.h"
#include "core/core.h"
#include "model/hdnet_net.h"
#include "model/train.h"

/* A synthetic batch: smooth colours, a round mask, normals of a sphere. */
static void fill_batch(hd_pair_batch *b)
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

/* Bytes a training run holds: parameters, gradients, Adam moments (HD-Net and discriminator),
 * the activation block, the Common-Nets' arenas and the losses' scratch. */
static size_t training_bytes(const hd_trainer *t)
{
    const hd_net *n = &t->net;
    size_t HW = (size_t)n->H * n->W, B = (size_t)n->B;
    size_t floats = 4 * n->table.total + 4 * n->disc_table.total + n->act_floats;
    floats += B * HW * 12 + HW + B * HD_SH_COEFFS; /* losses */
    floats += 2 * B * 7 * HW;                      /* the batch and the loader's next batch */
    return floats * sizeof(float) + hd_unet_memory(n->a_net) + hd_unet_memory(n->s_net) + hd_unet_memory(n->n_net);
}

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

    /* forward */
    if (hd_net_create(&net, &cfg, images, HD_NET_INFER, HD_CONV_AUTO) != HD_OK) goto fail;
    hd_train_init_params(&cfg, 1, net.params, NULL);
    for (size_t i = 0; i < (size_t)images * 3 * size * size; i++) net.input[i] = 0.25f + 0.5f * (float)(i % 97) / 97;
    hd_net_forward(&net); /* warm-up */
    double fwd = 1e30;
    for (int r = 0; r < repeats; r++) {
        double t0 = hd_seconds();
        hd_net_forward(&net);
        double dt = hd_seconds() - t0;
        fwd = dt < fwd ? dt : fwd;
    }
    size_t infer_bytes = net.act_floats * sizeof(float) + net.table.total * sizeof(float) + hd_unet_memory(net.a_net) +
                         hd_unet_memory(net.s_net) + hd_unet_memory(net.n_net);
    hd_net_free(&net);
    double gflop = 2.0 * hd_net_macs(&cfg) * 1e-9; /* per image */

    /* training step at a->batch pairs */
    int pairs = images;
    if (hd_trainer_create(&t, &cfg, pairs, 0, 1) != HD_OK) goto fail;
    fill_batch(&t.batch);
    hd_step_result res;
    if (hd_trainer_step(&t, &res, NULL) != HD_OK) goto fail; /* warm-up */
    double step = 1e30;
    for (int r = 0; r < step_repeats; r++) {
        double t0 = hd_seconds();
        if (hd_trainer_step(&t, &res, NULL) != HD_OK) goto fail;
        double dt = hd_seconds() - t0;
        step = dt < step ? dt : step;
    }
    size_t train_bytes = training_bytes(&t);
    hd_trainer_free(&t);
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    /* the paper's batch of 8 pairs: allocated, not run */
    size_t train8_bytes = 0;
    if (hd_trainer_create(&t, &cfg, 8, 0, 1) == HD_OK) train8_bytes = training_bytes(&t);
    hd_trainer_free(&t);

    double per_image = fwd / images, per_pair = step / pairs;
    if (a->json) {
        fprintf(o, "\"hdnet_gflop_per_image\": %.3f,\n\"hdnet_fwd_s_per_image\": %.6f,\n\"hdnet_fwd_gflops\": %.1f,\n"
                   "\"hdnet_train_step_s_per_pair\": %.6f,\n\"hdnet_train_pairs\": %d,\n\"hdnet_infer_bytes\": %zu,\n"
                   "\"hdnet_train_bytes\": %zu,\n\"hdnet_train_bytes_batch8\": %zu,\n\"hdnet_peak_rss_bytes\": %ld,\n",
                gflop, per_image, gflop / per_image, per_pair, pairs, infer_bytes, train_bytes, train8_bytes,
                ru.ru_maxrss * 1024L);
    } else {
        fprintf(o, "\nHD-Net (width %d) at %dx%d: %.2f GFLOP per image forward\n"
                   "  forward            %8.1f ms per image (batch %d)  %7.1f GFLOP/s  (%.0f%% of SGEMM peak)\n"
                   "  training step      %8.1f ms per pair (batch %d pairs: forward, 7 losses, backward,\n"
                   "                     discriminator, both Adams)\n"
                   "  memory             inference %.0f MB; training %.0f MB at batch %d, %.0f MB at batch 8;\n"
                   "                     peak resident so far %.0f MB\n",
                width, size, size, gflop, per_image * 1e3, images, gflop / per_image,
                peak > 0 ? 100 * gflop / per_image / peak : 0.0, per_pair * 1e3, pairs, infer_bytes / 1048576.0,
                train_bytes / 1048576.0, pairs, train8_bytes / 1048576.0, ru.ru_maxrss / 1024.0);
    }
    fflush(o);
    return 0;
fail:
    fprintf(stderr, "hdnet bench: HD-Net: %s\n", hd_error());
    hd_trainer_free(&t);
    return 1;
}
