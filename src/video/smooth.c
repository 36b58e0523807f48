/* smooth.c: the one-euro filter and the exponential moving average (smooth.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "video/smooth.h"

float hd_lowpass_alpha(float cutoff, float dt)
{
    float tau = 1.0f / (2.0f * (float)M_PI * cutoff);
    return 1.0f / (1.0f + tau / dt);
}

hd_status hd_one_euro_init(hd_one_euro *f, int n, float min_cutoff, float beta, float d_cutoff)
{
    memset(f, 0, sizeof *f);
    if (n < 1 || !(min_cutoff > 0.0f) || !(beta >= 0.0f) || !(d_cutoff > 0.0f) || !isfinite(min_cutoff) ||
        !isfinite(beta) || !isfinite(d_cutoff))
        return hd_fail(HD_ERR_ARG, "one-euro filter: n %d, min cutoff %g, beta %g, speed cutoff %g out of range", n,
                       (double)min_cutoff, (double)beta, (double)d_cutoff);
    f->x = hd_calloc((size_t)n, sizeof *f->x);
    f->dx = hd_calloc((size_t)n, sizeof *f->dx);
    if (!f->x || !f->dx) {
        hd_one_euro_free(f);
        return HD_ERR_NOMEM;
    }
    f->n = n;
    f->min_cutoff = min_cutoff;
    f->beta = beta;
    f->d_cutoff = d_cutoff;
    return HD_OK;
}

void hd_one_euro_free(hd_one_euro *f)
{
    free(f->x);
    free(f->dx);
    memset(f, 0, sizeof *f);
}

void hd_one_euro_reset(hd_one_euro *f) { f->started = 0; }

void hd_one_euro_step(hd_one_euro *f, float *v, float dt)
{
    if (!f->started || !(dt > 0.0f)) {
        memcpy(f->x, v, (size_t)f->n * sizeof *v);
        memset(f->dx, 0, (size_t)f->n * sizeof *f->dx);
        f->started = 1;
        return;
    }
    float ad = hd_lowpass_alpha(f->d_cutoff, dt);
    for (int i = 0; i < f->n; i++) {
        float speed = (v[i] - f->x[i]) / dt;
        f->dx[i] += ad * (speed - f->dx[i]);
        float a = hd_lowpass_alpha(f->min_cutoff + f->beta * fabsf(f->dx[i]), dt);
        f->x[i] += a * (v[i] - f->x[i]);
        v[i] = f->x[i];
    }
}

hd_status hd_ema_init(hd_ema *f, int n, float alpha)
{
    memset(f, 0, sizeof *f);
    if (n < 1 || !(alpha > 0.0f && alpha <= 1.0f))
        return hd_fail(HD_ERR_ARG, "moving average: n %d, weight %g out of range", n, (double)alpha);
    f->x = hd_calloc((size_t)n, sizeof *f->x);
    if (!f->x) return HD_ERR_NOMEM;
    f->n = n;
    f->alpha = alpha;
    return HD_OK;
}

void hd_ema_free(hd_ema *f)
{
    free(f->x);
    memset(f, 0, sizeof *f);
}

void hd_ema_reset(hd_ema *f) { f->started = 0; }

void hd_ema_step(hd_ema *f, float *v)
{
    if (!f->started) {
        memcpy(f->x, v, (size_t)f->n * sizeof *v);
        f->started = 1;
        return;
    }
    for (int i = 0; i < f->n; i++) {
        f->x[i] += f->alpha * (v[i] - f->x[i]);
        v[i] = f->x[i];
    }
}
