/* activations.c: elementwise layers (leaky ReLU, sigmoid, softplus, tanh) as forward/backward
 * pairs over n contiguous floats. Backwards accumulate into dinp. */
#include <math.h>
#include "nn/nn.h"

void hd_lrelu_forward(float *out, const float *inp, size_t n, float slope)
{
    /* out = x > 0 ? x : slope * x */
#pragma omp parallel for schedule(static) if (n > 65536)
    for (size_t i = 0; i < n; i++) out[i] = inp[i] > 0.0f ? inp[i] : slope * inp[i];
}

void hd_lrelu_backward(float *dinp, const float *dout, const float *inp, size_t n, float slope)
{
    /* forward: out = x > 0 ? x : slope * x */
#pragma omp parallel for schedule(static) if (n > 65536)
    for (size_t i = 0; i < n; i++) dinp[i] += inp[i] > 0.0f ? dout[i] : slope * dout[i];
}

/* Logistic function without overflow for large |x|. */
static float sigmoidf(float x)
{
    if (x >= 0.0f) return 1.0f / (1.0f + expf(-x));
    float e = expf(x);
    return e / (1.0f + e);
}

void hd_sigmoid_forward(float *out, const float *inp, size_t n)
{
#pragma omp parallel for schedule(static) if (n > 65536)
    for (size_t i = 0; i < n; i++) out[i] = sigmoidf(inp[i]);
}

void hd_sigmoid_backward(float *dinp, const float *dout, const float *out, size_t n)
{
    /* forward: out = 1 / (1 + exp(-x)); dout/dx = out (1 - out) */
#pragma omp parallel for schedule(static) if (n > 65536)
    for (size_t i = 0; i < n; i++) dinp[i] += dout[i] * out[i] * (1.0f - out[i]);
}

void hd_softplus_forward(float *out, const float *inp, size_t n)
{
    /* out = log(1 + exp(x)) = max(x, 0) + log1p(exp(-|x|)) */
#pragma omp parallel for schedule(static) if (n > 65536)
    for (size_t i = 0; i < n; i++) {
        float x = inp[i];
        out[i] = (x > 0.0f ? x : 0.0f) + log1pf(expf(-fabsf(x)));
    }
}

void hd_softplus_backward(float *dinp, const float *dout, const float *inp, size_t n)
{
    /* forward: out = log(1 + exp(x)); dout/dx = sigmoid(x) */
#pragma omp parallel for schedule(static) if (n > 65536)
    for (size_t i = 0; i < n; i++) dinp[i] += dout[i] * sigmoidf(inp[i]);
}

void hd_tanh_forward(float *out, const float *inp, size_t n)
{
#pragma omp parallel for schedule(static) if (n > 65536)
    for (size_t i = 0; i < n; i++) out[i] = tanhf(inp[i]);
}

void hd_tanh_backward(float *dinp, const float *dout, const float *out, size_t n)
{
    /* forward: out = tanh(x); dout/dx = 1 - out^2 */
#pragma omp parallel for schedule(static) if (n > 65536)
    for (size_t i = 0; i < n; i++) dinp[i] += dout[i] * (1.0f - out[i] * out[i]);
}
