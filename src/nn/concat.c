/* concat.c: channel concatenation of two NCHW tensors and its backward (a split that
 * accumulates). */
#include <string.h>
#include "nn/nn.h"

void hd_concat_forward(float *out, const float *a, int Ca, const float *b, int Cb, int B, int HW)
{
    /* out(n) = [a(n); b(n)] along channels */
    size_t na = (size_t)Ca * HW, nb = (size_t)Cb * HW;
    for (int n = 0; n < B; n++) {
        memcpy(out + n * (na + nb), a + n * na, na * sizeof(float));
        memcpy(out + n * (na + nb) + na, b + n * nb, nb * sizeof(float));
    }
}

void hd_concat_backward(float *da, float *db, const float *dout, int Ca, int Cb, int B, int HW)
{
    /* forward: out = [a; b]; da += dout[:Ca], db += dout[Ca:] */
    size_t na = (size_t)Ca * HW, nb = (size_t)Cb * HW;
    for (int n = 0; n < B; n++) {
        const float *g = dout + n * (na + nb);
        if (da)
            for (size_t i = 0; i < na; i++) da[n * na + i] += g[i];
        if (db)
            for (size_t i = 0; i < nb; i++) db[n * nb + i] += g[na + i];
    }
}
