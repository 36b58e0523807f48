/* smooth.h: temporal filters for video: the one-euro filter (Casiez, Roussel and Vogel 2012), a
 * low-pass whose cutoff rises with the signal's speed, so a still face stops jittering and a moving
 * one is followed without much lag; and the exponential moving average. Both work on n values at
 * once (a landmark set, a light, a texture map) with one state per value. */
#ifndef HD_VIDEO_SMOOTH_H
#define HD_VIDEO_SMOOTH_H

#include "hdnet.h"

/* The smoothing factor of a first-order low-pass with cutoff `cutoff` Hz sampled every dt
 * seconds: alpha = 1 / (1 + tau / dt), tau = 1 / (2 pi cutoff). */
float hd_lowpass_alpha(float cutoff, float dt);

typedef struct hd_one_euro {
    int n, started;
    float min_cutoff; /* Hz: the cutoff when the signal is still */
    float beta;       /* how much the cutoff rises per unit of speed (1 / signal unit) */
    float d_cutoff;   /* Hz: the cutoff of the speed estimate */
    float *x, *dx;    /* (n) the filtered values and their filtered speeds */
} hd_one_euro;

/* n values; min_cutoff > 0, beta >= 0, d_cutoff > 0. */
hd_status hd_one_euro_init(hd_one_euro *f, int n, float min_cutoff, float beta, float d_cutoff);
void hd_one_euro_free(hd_one_euro *f);
/* Forgets the past: the next sample passes unchanged. */
void hd_one_euro_reset(hd_one_euro *f);
/* Filters one sample of the n values taken dt > 0 seconds after the previous one, in place:
 *   speed  = (v - x) / dt, dx = dx + a(d_cutoff) (speed - dx)
 *   cutoff = min_cutoff + beta |dx|, x = x + a(cutoff) (v - x)      (per value) */
void hd_one_euro_step(hd_one_euro *f, float *v, float dt);

/* Exponential moving average of n values: x = x + alpha (v - x), the first sample passes. */
typedef struct hd_ema {
    int n, started;
    float alpha; /* (0, 1]: the weight of the new sample */
    float *x;
} hd_ema;
hd_status hd_ema_init(hd_ema *f, int n, float alpha);
void hd_ema_free(hd_ema *f);
void hd_ema_reset(hd_ema *f);
void hd_ema_step(hd_ema *f, float *v);

#endif /* HD_VIDEO_SMOOTH_H */
