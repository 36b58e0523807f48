/* loss.c: the loss pieces of SPEC section 4 (masked L1, masked squared distance, binary
 * cross-entropy with logits, the smoothness term), each returning its value and accumulating
 * scale * gradient where a gradient pointer is given. Sums are taken in double. */
#include <math.h>
#include "nn/nn.h"

static double weight_sum(const float *w, int HW)
{
    if (!w) return HW;
    double s = 0.0;
    for (int p = 0; p < HW; p++) s += w[p];
    return s;
}

float hd_loss_l1(float *dx, float *dy, const float *x, const float *y, const float *w, int C, int HW, float scale)
{
    /* L = sum_p w_p sum_c |x - y| / (C sum_p w_p); dL/dx = w_p sign(x - y) / (C sum_p w_p) */
    double ws = weight_sum(w, HW);
    if (ws <= 0.0) return 0.0f;
    double acc = 0.0;
    float k = (float)(scale / (C * ws));
    for (int c = 0; c < C; c++)
        for (int p = 0; p < HW; p++) {
            size_t i = (size_t)c * HW + p;
            float wp = w ? w[p] : 1.0f, diff = x[i] - y[i];
            acc += (double)wp * fabsf(diff);
            float g = diff > 0.0f ? k * wp : diff < 0.0f ? -k * wp : 0.0f;
            if (dx) dx[i] += g;
            if (dy) dy[i] -= g;
        }
    return (float)(acc / (C * ws));
}

float hd_loss_sqdist(float *dx, float *dy, const float *x, const float *y, const float *w, int C, int HW, float scale)
{
    /* L = sum_p w_p sum_c (x - y)^2 / sum_p w_p; dL/dx = 2 w_p (x - y) / sum_p w_p */
    double ws = weight_sum(w, HW);
    if (ws <= 0.0) return 0.0f;
    double acc = 0.0;
    float k = (float)(2.0 * scale / ws);
    for (int c = 0; c < C; c++)
        for (int p = 0; p < HW; p++) {
            size_t i = (size_t)c * HW + p;
            float wp = w ? w[p] : 1.0f, diff = x[i] - y[i];
            acc += (double)wp * diff * diff;
            float g = k * wp * diff;
            if (dx) dx[i] += g;
            if (dy) dy[i] -= g;
        }
    return (float)(acc / ws);
}

float hd_loss_bce_logits(float *dx, const float *x, size_t n, int target, float scale)
{
    /* t = 1: L = mean softplus(-x), dL/dx = -sigmoid(-x) / n;
     * t = 0: L = mean softplus(x),  dL/dx = sigmoid(x) / n */
    if (n == 0) return 0.0f;
    double acc = 0.0;
    float k = scale / (float)n;
    for (size_t i = 0; i < n; i++) {
        float z = target ? -x[i] : x[i];
        acc += (z > 0.0f ? z : 0.0f) + log1pf(expf(-fabsf(z)));
        if (dx) {
            float s = z >= 0.0f ? 1.0f / (1.0f + expf(-z)) : expf(z) / (1.0f + expf(z));
            dx[i] += target ? -k * s : k * s;
        }
    }
    return (float)(acc / n);
}

float hd_loss_smooth(float *ds, const float *s, const float *m, int H, int W, float eps, float scale)
{
    /* L = mean_wx(|dx s| / max(|dx s|, eps)) + mean_wy(likewise); f(d) = |d| / max(|d|, eps)
     * is 1 for |d| > eps (gradient 0) and |d| / eps below (gradient sign(d) / eps). */
    double total = 0.0;
    for (int dir = 0; dir < 2; dir++) {
        int ny = dir ? H - 1 : H, nx = dir ? W : W - 1;
        size_t step = dir ? (size_t)W : 1;
        double wsum = 0.0, acc = 0.0;
        for (int y = 0; y < ny; y++)
            for (int x = 0; x < nx; x++) {
                size_t i = (size_t)y * W + x;
                wsum += m ? (double)m[i] * m[i + step] : 1.0;
            }
        if (wsum <= 0.0) continue;
        float k = (float)(scale / wsum);
        for (int y = 0; y < ny; y++)
            for (int x = 0; x < nx; x++) {
                size_t i = (size_t)y * W + x;
                float wp = m ? m[i] * m[i + step] : 1.0f;
                float d = s[i + step] - s[i], ad = fabsf(d);
                if (ad > eps) {
                    acc += wp;
                } else {
                    acc += (double)wp * ad / eps;
                    if (ds && d != 0.0f) {
                        float g = k * wp / eps * (d > 0.0f ? 1.0f : -1.0f);
                        ds[i + step] += g;
                        ds[i] -= g;
                    }
                }
            }
        total += acc / wsum;
    }
    return (float)total;
}
