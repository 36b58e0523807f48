/* adam.c: one Adam step with bias correction over a flat parameter array (a frozen group is
 * simply not stepped). */
#include <math.h>
#include "nn/nn.h"

void hd_adam_step(float *param, const float *grad, float *m, float *v, size_t n, float lr,
                  float beta1, float beta2, float eps, long t)
{
    /* m = b1 m + (1-b1) g; v = b2 v + (1-b2) g^2;
     * p -= lr * (m / (1 - b1^t)) / (sqrt(v / (1 - b2^t)) + eps) */
    float c1 = (float)(1.0 - pow(beta1, (double)t));
    float c2 = (float)(1.0 - pow(beta2, (double)t));
#pragma omp parallel for schedule(static) if (n > 65536)
    for (size_t i = 0; i < n; i++) {
        float g = grad[i];
        m[i] = beta1 * m[i] + (1.0f - beta1) * g;
        v[i] = beta2 * v[i] + (1.0f - beta2) * g * g;
        float mh = m[i] / c1, vh = v[i] / c2;
        param[i] -= lr * mh / (sqrtf(vh) + eps);
    }
}
