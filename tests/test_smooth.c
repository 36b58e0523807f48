/* test_smooth.c: the temporal filters of src/video/smooth.c on signals whose answer is known:
 * the low-pass factor against its formula; the moving average's step response (1 - (1 - a)^k
 * after k steps); the one-euro filter with beta 0 equals a moving average of alpha(min_cutoff);
 * on a still value with noise it cuts the frame-to-frame change several times; on a ramp it
 * follows with a lag that shrinks as beta grows (its speed estimate raises the cutoff); reset
 * passes the next sample through; bad parameters are refused. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "test.h"
#include "core/core.h"
#include "video/smooth.h"

static void test_alpha(void)
{
    /* alpha = 1 / (1 + 1 / (2 pi fc dt)) */
    CHECK_NEAR(hd_lowpass_alpha(1.0f, 1.0f / 30.0f), 1.0 / (1.0 + 30.0 / (2.0 * M_PI)), 1e-6);
    CHECK_NEAR(hd_lowpass_alpha(10.0f, 0.01f), 1.0 / (1.0 + 1.0 / (2.0 * M_PI * 0.1)), 1e-6);
    CHECK(hd_lowpass_alpha(1e6f, 0.01f) > 0.999f);
}

static void test_ema(void)
{
    hd_ema f;
    CHECK(hd_ema_init(&f, 2, 0.25f) == HD_OK);
    float v[2] = {0.0f, 5.0f};
    hd_ema_step(&f, v); /* the first sample passes */
    CHECK(v[0] == 0.0f && v[1] == 5.0f);
    for (int k = 1; k <= 10; k++) {
        v[0] = 1.0f, v[1] = 5.0f;
        hd_ema_step(&f, v);
        CHECK_NEAR(v[0], 1.0 - pow(0.75, k), 1e-6);
        CHECK_NEAR(v[1], 5.0, 1e-6);
    }
    hd_ema_reset(&f);
    v[0] = -3.0f;
    hd_ema_step(&f, v);
    CHECK(v[0] == -3.0f);
    hd_ema_free(&f);
    CHECK(hd_ema_init(&f, 2, 0.0f) == HD_ERR_ARG);
    CHECK(hd_ema_init(&f, 2, 1.5f) == HD_ERR_ARG);
    CHECK(hd_ema_init(&f, 0, 0.5f) == HD_ERR_ARG);
}

/* beta 0: the cutoff never moves, so the filter is the moving average of alpha(min_cutoff). */
static void test_one_euro_is_ema(void)
{
    const float dt = 1.0f / 25.0f, fc = 2.0f;
    hd_one_euro f;
    CHECK(hd_one_euro_init(&f, 1, fc, 0.0f, 1.0f) == HD_OK);
    double a = 1.0 / (1.0 + 1.0 / (2.0 * M_PI * fc * dt)), x = 0.0;
    hd_rng r;
    hd_rng_seed(&r, 5, 1);
    for (int k = 0; k < 100; k++) {
        float v = hd_rng_range(&r, -1.0f, 1.0f) + 0.05f * (float)k;
        double want = k == 0 ? v : x + a * (v - x);
        x = want;
        hd_one_euro_step(&f, &v, dt);
        CHECK_NEAR(v, want, 1e-5);
    }
    hd_one_euro_free(&f);
}

/* A still value plus noise, and a ramp: returns the mean |change| between frames of the
 * filtered still signal and the lag (truth - filtered) at the end of the ramp. */
static void run_signals(float beta, double *still_change, double *raw_change, double *ramp_lag)
{
    const float dt = 1.0f / 30.0f;
    hd_one_euro f;
    CHECK(hd_one_euro_init(&f, 1, 1.0f, beta, 1.0f) == HD_OK);
    hd_rng r;
    hd_rng_seed(&r, 9, 2);
    float prev = 0.0f, prev_raw = 0.0f;
    *still_change = *raw_change = 0.0;
    for (int k = 0; k < 300; k++) {
        float raw = 10.0f + 0.1f * hd_rng_normal(&r), v = raw;
        hd_one_euro_step(&f, &v, dt);
        if (k >= 30) {
            *still_change += fabsf(v - prev) / 270.0;
            *raw_change += fabsf(raw - prev_raw) / 270.0;
        }
        prev = v, prev_raw = raw;
    }
    /* then a ramp of 3 units per second for 2 s */
    float truth = 10.0f, v = truth;
    for (int k = 0; k < 60; k++) {
        truth += 3.0f * dt;
        v = truth;
        hd_one_euro_step(&f, &v, dt);
    }
    *ramp_lag = truth - v;
    hd_one_euro_free(&f);
}

static void test_one_euro_signals(void)
{
    double still0, raw0, lag0, still1, raw1, lag1;
    run_signals(0.0f, &still0, &raw0, &lag0);
    run_signals(2.0f, &still1, &raw1, &lag1);
    fprintf(stderr, "one-euro: still change %.4f / %.4f raw (beta 0), %.4f (beta 2); ramp lag %.3f (beta 0), %.3f (beta 2)\n",
            still0, raw0, still1, lag0, lag1);
    CHECK(raw0 > 0.09 && raw0 < 0.14); /* |N(0, 2 x 0.01)| has mean 0.2 / sqrt(pi) = 0.113 */
    CHECK(still0 < raw0 / 4.0);        /* alpha 0.17 at 1 Hz, 30 fps: the noise's change cut ~6x */
    CHECK(still1 < raw0 / 2.0);
    /* a first-order low-pass lags a ramp of slope m by m tau = 3 / (2 pi) = 0.477 at 1 Hz (plus
     * half a step of discretisation) */
    CHECK(lag0 > 0.40 && lag0 < 0.60);
    CHECK(lag1 < lag0 / 3.0);
    CHECK(lag1 > 0.0);
}

static void test_reset_and_args(void)
{
    hd_one_euro f;
    CHECK(hd_one_euro_init(&f, 3, 1.0f, 0.5f, 1.0f) == HD_OK);
    float v[3] = {1, 2, 3};
    hd_one_euro_step(&f, v, 0.1f);
    float w[3] = {4, 5, 6};
    hd_one_euro_step(&f, w, 0.1f);
    CHECK(w[0] > 1.0f && w[0] < 4.0f);
    hd_one_euro_reset(&f);
    float u[3] = {7, 8, 9};
    hd_one_euro_step(&f, u, 0.1f);
    CHECK(u[0] == 7.0f && u[1] == 8.0f && u[2] == 9.0f);
    hd_one_euro_free(&f);
    CHECK(hd_one_euro_init(&f, 3, 0.0f, 0.5f, 1.0f) == HD_ERR_ARG);
    CHECK(hd_one_euro_init(&f, 3, 1.0f, -1.0f, 1.0f) == HD_ERR_ARG);
    CHECK(hd_one_euro_init(&f, 3, 1.0f, NAN, 1.0f) == HD_ERR_ARG);
    CHECK(hd_one_euro_init(&f, 3, 1.0f, 0.5f, 0.0f) == HD_ERR_ARG);
}

int main(void)
{
    test_alpha();
    test_ema();
    test_one_euro_is_ema();
    test_one_euro_signals();
    test_reset_and_args();
    return test_summary("smooth");
}
