/* test_train_gt.c: the training options for sets with ground truth (docs/training.md, "Beyond
 * the paper"): with --light-target gt the target l_hat of L_l is the batch's ground-truth light
 * (and L_l its mean absolute difference to L-Net's light), images without one keep the
 * least-squares fit, and the paper's fit is untouched when no image has one. Also the default
 * micro-batch that keeps the paper's configuration within 8 GB. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "test.h"
#include "train/train.h"

/* A pair batch of smooth random-looking faces: a sphere of normals, a mask disc, a lit albedo. */
static void fill_batch(hd_pair_batch *b)
{
    int S = b->size, B = 2 * b->pairs;
    size_t HW = (size_t)S * S;
    for (int i = 0; i < B; i++) {
        float l[HD_SH_COEFFS];
        hd_light_from_direction(-40.0f + 25.0f * i, 10.0f, 0.8f, 0.5f, l);
        b->has_normal[i] = 1;
        for (int y = 0; y < S; y++)
            for (int x = 0; x < S; x++) {
                size_t p = (size_t)y * S + x;
                float u = (x + 0.5f) / S * 2 - 1, v = 1 - (y + 0.5f) / S * 2, r2 = u * u + v * v;
                float n[3] = {0.8f * u, 0.8f * v, sqrtf(fmaxf(1 - 0.64f * r2, 0.05f))};
                float len = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
                for (int c = 0; c < 3; c++) b->coarse_normal[(size_t)i * 3 * HW + c * HW + p] = n[c] / len;
                b->mask[(size_t)i * HW + p] = r2 < 0.85f ? 1.0f : 0.0f;
                float s = hd_sh_shade(l, n);
                for (int c = 0; c < 3; c++)
                    b->image[(size_t)i * 3 * HW + c * HW + p] = fminf(fmaxf((0.4f + 0.1f * c) * s, 0.0f), 1.0f);
            }
    }
}

int main(void)
{
    hd_set_threads(1);
    hd_net_config cfg = {4, 32};
    hd_trainer t;
    if (hd_trainer_create(&t, &cfg, 2, 0, 3) != HD_OK) {
        fprintf(stderr, "trainer: %s\n", hd_error());
        return 1;
    }
    fill_batch(&t.batch);
    hd_step_result fit, gt;
    CHECK(hd_trainer_eval(&t, &fit, HD_EVAL_LOSS) == HD_OK);
    float fitted[4][HD_SH_COEFFS];
    memcpy(fitted, t.losses.light_hat, sizeof fitted);

    /* images 0, 1 and 3 have a ground-truth light; image 2 keeps the fit */
    for (int i = 0; i < 4; i++) {
        t.batch.has_light[i] = i != 2;
        for (int k = 0; k < HD_SH_COEFFS; k++) t.batch.light_gt[i * HD_SH_COEFFS + k] = 0.1f * (float)(k + 1) - 0.05f * (float)i;
    }
    CHECK(hd_trainer_eval(&t, &gt, HD_EVAL_LOSS) == HD_OK);
    double want = 0;
    for (int i = 0; i < 4; i++) {
        const float *target = t.batch.has_light[i] ? t.batch.light_gt + i * HD_SH_COEFFS : fitted[i];
        double d = 0;
        for (int k = 0; k < HD_SH_COEFFS; k++) {
            CHECK_NEAR(t.losses.light_hat[i * HD_SH_COEFFS + k], target[k], 1e-6);
            d += fabs(t.net.light[i * HD_SH_COEFFS + k] - target[k]);
        }
        want += d / HD_SH_COEFFS;
    }
    want /= 2; /* the mean over pairs of the i and j parts */
    CHECK_NEAR(gt.terms[HD_LOSS_LIGHT], want, 1e-5);
    CHECK(fabs(gt.terms[HD_LOSS_LIGHT] - fit.terms[HD_LOSS_LIGHT]) > 1e-3); /* the target did change */
    /* every other term is the same: only l_hat moved */
    CHECK_NEAR(gt.terms[HD_LOSS_REC], fit.terms[HD_LOSS_REC], 1e-9);
    CHECK_NEAR(gt.terms[HD_LOSS_SREC], fit.terms[HD_LOSS_SREC], 1e-9);

    /* no image with a truth: the paper's fit again, bit for bit */
    memset(t.batch.has_light, 0, 4);
    hd_step_result again;
    CHECK(hd_trainer_eval(&t, &again, HD_EVAL_LOSS) == HD_OK);
    CHECK(again.terms[HD_LOSS_LIGHT] == fit.terms[HD_LOSS_LIGHT]);
    hd_trainer_free(&t);

    /* the default micro-batch: 8 pairs at 256, width 48 in 2s (8 GB); small runs whole */
    hd_net_config paper = {48, 256}, small = {16, 64}, big = {48, 512};
    CHECK(hd_train_default_micro(&paper, 8) == 2);
    CHECK(hd_train_default_micro(&paper, 1) == 1);
    CHECK(hd_train_default_micro(&paper, 3) == 1);
    CHECK(hd_train_default_micro(&small, 4) == 4);
    CHECK(hd_train_default_micro(&big, 8) == 1);
    return test_summary("train_gt");
}
