/* l2norm.c: per-pixel L2 normalisation of a 3-channel map (the normal head), as PyTorch's
 * F.normalize(x, dim=1, eps): out = x / max(||x||, eps). */
#include <math.h>
#include "nn/nn.h"

void hd_l2norm3_forward(float *out, const float *inp, int B, int HW, float eps)
{
    for (int n = 0; n < B; n++) {
        const float *x = inp + (size_t)n * 3 * HW;
        float *o = out + (size_t)n * 3 * HW;
#pragma omp parallel for schedule(static) if (HW > 65536)
        for (int p = 0; p < HW; p++) {
            float a = x[p], b = x[HW + p], c = x[2 * HW + p];
            float len = sqrtf(a * a + b * b + c * c);
            float d = len > eps ? len : eps;
            o[p] = a / d;
            o[HW + p] = b / d;
            o[2 * HW + p] = c / d;
        }
    }
}

void hd_l2norm3_backward(float *dinp, const float *dout, const float *inp, int B, int HW, float eps)
{
    /* forward: out = x / max(|x|, eps).
     * |x| > eps: dx = (g - u (u . g)) / |x| with u = x / |x|; otherwise dx = g / eps. */
    for (int n = 0; n < B; n++) {
        const float *x = inp + (size_t)n * 3 * HW, *g = dout + (size_t)n * 3 * HW;
        float *d = dinp + (size_t)n * 3 * HW;
#pragma omp parallel for schedule(static) if (HW > 65536)
        for (int p = 0; p < HW; p++) {
            float a = x[p], b = x[HW + p], c = x[2 * HW + p];
            float ga = g[p], gb = g[HW + p], gc = g[2 * HW + p];
            float len = sqrtf(a * a + b * b + c * c);
            if (len > eps) {
                float inv = 1.0f / len;
                float ua = a * inv, ub = b * inv, uc = c * inv;
                float dot = ua * ga + ub * gb + uc * gc;
                d[p] += (ga - ua * dot) * inv;
                d[HW + p] += (gb - ub * dot) * inv;
                d[2 * HW + p] += (gc - uc * dot) * inv;
            } else {
                d[p] += ga / eps;
                d[HW + p] += gb / eps;
                d[2 * HW + p] += gc / eps;
            }
        }
    }
}
