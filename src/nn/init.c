/* init.c: PyTorch's default initialisation of conv and linear layers from our seeded RNG. */
#include <math.h>
#include "nn/nn.h"

void hd_init_uniform_fan_in(float *w, size_t nw, float *b, size_t nb, int fan_in, hd_rng *rng)
{
    /* kaiming_uniform(a = sqrt(5)): bound = gain * sqrt(3 / fan_in), gain = sqrt(2 / (1 + 5)),
     * which is 1 / sqrt(fan_in); the bias uses the same bound. Weights first, then bias. */
    float bound = fan_in > 0 ? (float)(1.0 / sqrt((double)fan_in)) : 0.0f;
    for (size_t i = 0; i < nw; i++) w[i] = hd_rng_range(rng, -bound, bound);
    if (b)
        for (size_t i = 0; i < nb; i++) b[i] = hd_rng_range(rng, -bound, bound);
}
