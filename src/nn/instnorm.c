/* instnorm.c: instance normalisation without affine parameters (the discriminator's), per
 * (image, channel) over space, with the biased variance as PyTorch's InstanceNorm2d. */
#include <math.h>
#include "nn/nn.h"

void hd_instnorm_forward(float *out, float *mean, float *rstd, const float *inp, int B, int C, int HW, float eps)
{
    /* out = (x - mean) * rstd, rstd = 1 / sqrt(var + eps), var = mean((x - mean)^2) */
    hd_prof_mark t0 = hd_prof_now();
#pragma omp parallel for schedule(static) if ((double)B * C * HW > 262144)
    for (long p = 0; p < (long)B * C; p++) {
        const float *x = inp + (size_t)p * HW;
        double s = 0.0;
        for (int i = 0; i < HW; i++) s += x[i];
        double m = s / HW, v = 0.0;
        for (int i = 0; i < HW; i++) v += ((double)x[i] - m) * ((double)x[i] - m);
        v /= HW;
        float r = (float)(1.0 / sqrt(v + eps));
        mean[p] = (float)m;
        rstd[p] = r;
        float *o = out + (size_t)p * HW;
        for (int i = 0; i < HW; i++) o[i] = (float)((x[i] - m) * r);
    }
    hd_prof_op("instnorm forward", C, C, HW, 0, t0);
}

void hd_instnorm_backward(float *dinp, const float *dout, const float *out, const float *rstd, int B, int C, int HW)
{
    /* forward: y = (x - mean) * rstd; dx = rstd * (dy - mean(dy) - y * mean(dy * y)) */
    hd_prof_mark t0 = hd_prof_now();
#pragma omp parallel for schedule(static) if ((double)B * C * HW > 262144)
    for (long p = 0; p < (long)B * C; p++) {
        const float *g = dout + (size_t)p * HW, *y = out + (size_t)p * HW;
        double sg = 0.0, sgy = 0.0;
        for (int i = 0; i < HW; i++) {
            sg += g[i];
            sgy += (double)g[i] * y[i];
        }
        float mg = (float)(sg / HW), mgy = (float)(sgy / HW), r = rstd[p];
        float *d = dinp + (size_t)p * HW;
        for (int i = 0; i < HW; i++) d[i] += r * (g[i] - mg - y[i] * mgy);
    }
    hd_prof_op("instnorm backward", C, C, HW, 0, t0);
}
