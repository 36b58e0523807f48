/* linear.c: the fully connected layer out = inp w^T + b (small: L-Net's 64 -> 9), plain loops. */
#include "nn/nn.h"

void hd_linear_forward(float *out, const float *inp, const float *w, const float *b, int B, int IN, int OUT)
{
    /* out(n, o) = b(o) + sum_i inp(n, i) w(o, i) */
    for (int n = 0; n < B; n++)
        for (int o = 0; o < OUT; o++) {
            float acc = b ? b[o] : 0.0f;
            for (int i = 0; i < IN; i++) acc += inp[(size_t)n * IN + i] * w[(size_t)o * IN + i];
            out[(size_t)n * OUT + o] = acc;
        }
}

void hd_linear_backward(float *dinp, float *dw, float *db, const float *dout, const float *inp,
                        const float *w, int B, int IN, int OUT)
{
    /* forward: out(n, o) = b(o) + sum_i inp(n, i) w(o, i) */
    for (int n = 0; n < B; n++)
        for (int o = 0; o < OUT; o++) {
            float g = dout[(size_t)n * OUT + o];
            if (db) db[o] += g;
            for (int i = 0; i < IN; i++) {
                if (dinp) dinp[(size_t)n * IN + i] += g * w[(size_t)o * IN + i];
                if (dw) dw[(size_t)o * IN + i] += g * inp[(size_t)n * IN + i];
            }
        }
}
