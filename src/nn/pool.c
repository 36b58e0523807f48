/* pool.c: spatial resampling layers: 2x2 max pooling, nearest 2x upsampling and global mean
 * pooling, NCHW, backwards accumulating into dinp. */
#include "nn/nn.h"

void hd_maxpool2_forward(float *out, const float *inp, int B, int C, int H, int W)
{
    /* out(y, x) = max over the 2x2 block at (2y, 2x); ties keep the first in row order */
    int Ho = H / 2, Wo = W / 2;
    long planes = (long)B * C;
#pragma omp parallel for schedule(static) if ((double)planes * H * W > 262144)
    for (long p = 0; p < planes; p++) {
        const float *src = inp + (size_t)p * H * W;
        float *dst = out + (size_t)p * Ho * Wo;
        for (int y = 0; y < Ho; y++) {
            const float *r0 = src + (size_t)(2 * y) * W, *r1 = r0 + W;
            for (int x = 0; x < Wo; x++) {
                float m = r0[2 * x];
                if (r0[2 * x + 1] > m) m = r0[2 * x + 1];
                if (r1[2 * x] > m) m = r1[2 * x];
                if (r1[2 * x + 1] > m) m = r1[2 * x + 1];
                dst[(size_t)y * Wo + x] = m;
            }
        }
    }
}

void hd_maxpool2_backward(float *dinp, const float *dout, const float *inp, int B, int C, int H, int W)
{
    /* forward: out = max of the block; the gradient goes to the (first) maximum */
    int Ho = H / 2, Wo = W / 2;
    long planes = (long)B * C;
#pragma omp parallel for schedule(static) if ((double)planes * H * W > 262144)
    for (long p = 0; p < planes; p++) {
        const float *src = inp + (size_t)p * H * W;
        float *dsrc = dinp + (size_t)p * H * W;
        const float *g = dout + (size_t)p * Ho * Wo;
        for (int y = 0; y < Ho; y++) {
            size_t r0 = (size_t)(2 * y) * W, r1 = r0 + W;
            for (int x = 0; x < Wo; x++) {
                size_t best = r0 + 2 * x;
                float m = src[best];
                if (src[r0 + 2 * x + 1] > m) { best = r0 + 2 * x + 1; m = src[best]; }
                if (src[r1 + 2 * x] > m) { best = r1 + 2 * x; m = src[best]; }
                if (src[r1 + 2 * x + 1] > m) best = r1 + 2 * x + 1;
                dsrc[best] += g[(size_t)y * Wo + x];
            }
        }
    }
}

void hd_upsample2_forward(float *out, const float *inp, int B, int C, int H, int W)
{
    /* out(y, x) = inp(y / 2, x / 2) */
    int W2 = 2 * W;
    long planes = (long)B * C;
#pragma omp parallel for schedule(static) if ((double)planes * H * W > 262144)
    for (long p = 0; p < planes; p++) {
        const float *src = inp + (size_t)p * H * W;
        float *dst = out + (size_t)p * 4 * H * W;
        for (int y = 0; y < H; y++) {
            float *d0 = dst + (size_t)(2 * y) * W2, *d1 = d0 + W2;
            const float *s = src + (size_t)y * W;
            for (int x = 0; x < W; x++) {
                d0[2 * x] = d0[2 * x + 1] = s[x];
                d1[2 * x] = d1[2 * x + 1] = s[x];
            }
        }
    }
}

void hd_upsample2_backward(float *dinp, const float *dout, int B, int C, int H, int W)
{
    /* forward: out(y, x) = inp(y / 2, x / 2); dinp sums its four copies */
    int W2 = 2 * W;
    long planes = (long)B * C;
#pragma omp parallel for schedule(static) if ((double)planes * H * W > 262144)
    for (long p = 0; p < planes; p++) {
        float *d = dinp + (size_t)p * H * W;
        const float *g = dout + (size_t)p * 4 * H * W;
        for (int y = 0; y < H; y++) {
            const float *g0 = g + (size_t)(2 * y) * W2, *g1 = g0 + W2;
            for (int x = 0; x < W; x++)
                d[(size_t)y * W + x] += (g0[2 * x] + g0[2 * x + 1]) + (g1[2 * x] + g1[2 * x + 1]);
        }
    }
}

void hd_meanpool_forward(float *out, const float *inp, int B, int C, int HW)
{
    /* out(b, c) = sum_p inp(b, c, p) / HW, summed in double */
    for (long p = 0; p < (long)B * C; p++) {
        const float *s = inp + (size_t)p * HW;
        double acc = 0.0;
        for (int i = 0; i < HW; i++) acc += s[i];
        out[p] = (float)(acc / HW);
    }
}

void hd_meanpool_backward(float *dinp, const float *dout, int B, int C, int HW)
{
    /* forward: out = mean over space; dinp += dout / HW */
    for (long p = 0; p < (long)B * C; p++) {
        float g = dout[p] / (float)HW;
        float *d = dinp + (size_t)p * HW;
        for (int i = 0; i < HW; i++) d[i] += g;
    }
}
