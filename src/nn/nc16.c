/* nc16.c: the layers that surround the convolutions in oneDNN's blocked channel layout nChw16c
 * ("nc16", see nn.h): conversion from and to plain NCHW, 2x2 max pooling and nearest 2x
 * upsampling. A block holds 16 channels of one pixel side by side, so every loop here runs over
 * (image, block, pixel) with the 16 lanes innermost. Padded lanes stay zero. */
#include <string.h>
#include "nn/nn.h"
#ifdef __AVX2__
#include <immintrin.h>
#endif

#define L HD_NC16_BLOCK

#ifdef __AVX2__
/* Transposes the 8 x 8 block r[k] (row k = channel k, 8 pixels) in place: r[j] = pixel j's 8
 * channels. Moves only. */
static inline void transpose8(__m256 r[8])
{
    __m256 t0 = _mm256_unpacklo_ps(r[0], r[1]), t1 = _mm256_unpackhi_ps(r[0], r[1]);
    __m256 t2 = _mm256_unpacklo_ps(r[2], r[3]), t3 = _mm256_unpackhi_ps(r[2], r[3]);
    __m256 t4 = _mm256_unpacklo_ps(r[4], r[5]), t5 = _mm256_unpackhi_ps(r[4], r[5]);
    __m256 t6 = _mm256_unpacklo_ps(r[6], r[7]), t7 = _mm256_unpackhi_ps(r[6], r[7]);
    __m256 u0 = _mm256_shuffle_ps(t0, t2, 0x44), u1 = _mm256_shuffle_ps(t0, t2, 0xEE);
    __m256 u2 = _mm256_shuffle_ps(t1, t3, 0x44), u3 = _mm256_shuffle_ps(t1, t3, 0xEE);
    __m256 u4 = _mm256_shuffle_ps(t4, t6, 0x44), u5 = _mm256_shuffle_ps(t4, t6, 0xEE);
    __m256 u6 = _mm256_shuffle_ps(t5, t7, 0x44), u7 = _mm256_shuffle_ps(t5, t7, 0xEE);
    r[0] = _mm256_permute2f128_ps(u0, u4, 0x20), r[1] = _mm256_permute2f128_ps(u1, u5, 0x20);
    r[2] = _mm256_permute2f128_ps(u2, u6, 0x20), r[3] = _mm256_permute2f128_ps(u3, u7, 0x20);
    r[4] = _mm256_permute2f128_ps(u0, u4, 0x31), r[5] = _mm256_permute2f128_ps(u1, u5, 0x31);
    r[6] = _mm256_permute2f128_ps(u2, u6, 0x31), r[7] = _mm256_permute2f128_ps(u3, u7, 0x31);
}
#endif

void hd_nc16_from_plain(float *nc16, const float *plain, int B, int C, int HW)
{
    /* nc16(n, c / 16, p, c % 16) = plain(n, c, p), 0 for c >= C */
    int CB = hd_nc16_channels(C) / L;
#pragma omp parallel for schedule(static) if ((double)B * CB * HW * L > 262144)
    for (long nb = 0; nb < (long)B * CB; nb++) {
        int n = (int)(nb / CB), cb = (int)(nb % CB);
        float *dst = nc16 + (size_t)nb * HW * L;
        int p = 0;
#ifdef __AVX2__
        if ((cb + 1) * L <= C) /* a whole block: 8 x 8 transposes of channels x pixels */
            for (const float *src = plain + ((size_t)n * C + (size_t)cb * L) * HW; p + 8 <= HW; p += 8)
                for (int h = 0; h < L; h += 8) {
                    __m256 r[8];
                    for (int k = 0; k < 8; k++) r[k] = _mm256_loadu_ps(src + (size_t)(h + k) * HW + p);
                    transpose8(r);
                    for (int j = 0; j < 8; j++) _mm256_storeu_ps(dst + (size_t)(p + j) * L + h, r[j]);
                }
#endif
        for (; p < HW; p++)
            for (int l = 0; l < L; l++) {
                int c = cb * L + l;
                dst[(size_t)p * L + l] = c < C ? plain[((size_t)n * C + c) * HW + p] : 0.0f;
            }
    }
}

void hd_nc16_to_plain(float *plain, const float *nc16, int B, int C, int HW, int accumulate)
{
    int CB = hd_nc16_channels(C) / L;
#pragma omp parallel for schedule(static) if ((double)B * C * HW > 262144)
    for (long nc = 0; nc < (long)B * C; nc++) {
        int n = (int)(nc / C), c = (int)(nc % C);
        const float *src = nc16 + ((size_t)n * CB + c / L) * HW * L + c % L;
        float *dst = plain + (size_t)nc * HW;
        if (accumulate)
            for (int p = 0; p < HW; p++) dst[p] += src[(size_t)p * L];
        else
            for (int p = 0; p < HW; p++) dst[p] = src[(size_t)p * L];
    }
}

void hd_maxpool2_nc16_forward(float *out, const float *inp, int B, int C, int H, int W)
{
    /* out(y, x) = max over the 2x2 block at (2y, 2x), lane by lane */
    int CB = hd_nc16_channels(C) / L, Ho = H / 2, Wo = W / 2;
#pragma omp parallel for schedule(static) if ((double)B * CB * H * W * L > 262144)
    for (long nb = 0; nb < (long)B * CB; nb++) {
        const float *src = inp + (size_t)nb * H * W * L;
        float *dst = out + (size_t)nb * Ho * Wo * L;
        for (int y = 0; y < Ho; y++)
            for (int x = 0; x < Wo; x++) {
                const float *a = src + ((size_t)(2 * y) * W + 2 * x) * L, *b = a + L, *c = a + (size_t)W * L, *d = c + L;
                float *o = dst + ((size_t)y * Wo + x) * L;
                for (int l = 0; l < L; l++) {
                    float m = a[l];
                    if (b[l] > m) m = b[l];
                    if (c[l] > m) m = c[l];
                    if (d[l] > m) m = d[l];
                    o[l] = m;
                }
            }
    }
}

/* One pixel's 16 lanes of the max-pooling backward: a, b, c, d are the 2x2 block's inputs in row
 * order, g the gradient at the output; the gradient goes to the first maximum (the forward's
 * comparisons, in its order), the other three get 0. Written (overwrite) or added. */
static inline void pool_grad_px(float *da, float *db, float *dc, float *dd, const float *a, const float *b,
                                const float *c, const float *d, const float *g, int overwrite)
{
    int l = 0;
#ifdef __AVX2__
    for (; l < L; l += 8) {
        __m256 va = _mm256_loadu_ps(a + l), vb = _mm256_loadu_ps(b + l), vc = _mm256_loadu_ps(c + l),
               vd = _mm256_loadu_ps(d + l), vg = _mm256_loadu_ps(g + l);
        __m256 sb = _mm256_cmp_ps(vb, va, _CMP_GT_OQ), m = _mm256_blendv_ps(va, vb, sb);
        __m256 sc = _mm256_cmp_ps(vc, m, _CMP_GT_OQ);
        m = _mm256_blendv_ps(m, vc, sc);
        __m256 sd = _mm256_cmp_ps(vd, m, _CMP_GT_OQ);
        __m256 wc = _mm256_andnot_ps(sd, sc), wb = _mm256_andnot_ps(_mm256_or_ps(sc, sd), sb);
        __m256 wa = _mm256_andnot_ps(_mm256_or_ps(sb, _mm256_or_ps(sc, sd)), _mm256_castsi256_ps(_mm256_set1_epi32(-1)));
        __m256 ga = _mm256_and_ps(wa, vg), gb = _mm256_and_ps(wb, vg), gc = _mm256_and_ps(wc, vg), gd = _mm256_and_ps(sd, vg);
        if (!overwrite) {
            ga = _mm256_add_ps(_mm256_loadu_ps(da + l), ga), gb = _mm256_add_ps(_mm256_loadu_ps(db + l), gb);
            gc = _mm256_add_ps(_mm256_loadu_ps(dc + l), gc), gd = _mm256_add_ps(_mm256_loadu_ps(dd + l), gd);
        }
        _mm256_storeu_ps(da + l, ga), _mm256_storeu_ps(db + l, gb);
        _mm256_storeu_ps(dc + l, gc), _mm256_storeu_ps(dd + l, gd);
    }
#endif
    for (; l < L; l++) {
        float m = a[l], *best = da + l;
        if (overwrite) da[l] = db[l] = dc[l] = dd[l] = 0.0f;
        if (b[l] > m) best = db + l, m = b[l];
        if (c[l] > m) best = dc + l, m = c[l];
        if (d[l] > m) best = dd + l;
        *best += g[l];
    }
}

static void maxpool_nc16_backward(float *dinp, const float *dout, const float *inp, int B, int C, int H, int W,
                                  int overwrite)
{
    /* forward: out = max of the block; the gradient goes to the first maximum in row order */
    int CB = hd_nc16_channels(C) / L, Ho = H / 2, Wo = W / 2;
#pragma omp parallel for schedule(static) if ((double)B * CB * H * W * L > 262144)
    for (long nb = 0; nb < (long)B * CB; nb++) {
        const float *src = inp + (size_t)nb * H * W * L;
        float *dsrc = dinp + (size_t)nb * H * W * L;
        const float *g = dout + (size_t)nb * Ho * Wo * L;
        for (int y = 0; y < Ho; y++)
            for (int x = 0; x < Wo; x++) {
                size_t ia = ((size_t)(2 * y) * W + 2 * x) * L, ib = ia + L, ic = ia + (size_t)W * L, id = ic + L;
                pool_grad_px(dsrc + ia, dsrc + ib, dsrc + ic, dsrc + id, src + ia, src + ib, src + ic, src + id,
                             g + ((size_t)y * Wo + x) * L, overwrite);
            }
        if (overwrite && (H % 2 || W % 2)) { /* rows and columns the pooling never read */
            for (int y = 0; y < H; y++)
                for (int x = (y < 2 * Ho ? 2 * Wo : 0); x < W; x++) memset(dsrc + ((size_t)y * W + x) * L, 0, L * sizeof(float));
        }
    }
}

void hd_maxpool2_nc16_backward(float *dinp, const float *dout, const float *inp, int B, int C, int H, int W)
{
    maxpool_nc16_backward(dinp, dout, inp, B, C, H, W, 0);
}

void hd_maxpool2_nc16_backward_into(float *dinp, const float *dout, const float *inp, int B, int C, int H, int W)
{
    maxpool_nc16_backward(dinp, dout, inp, B, C, H, W, 1);
}

void hd_upsample2_nc16_forward(float *out, const float *inp, int B, int C, int H, int W)
{
    /* out(y, x) = inp(y / 2, x / 2) */
    int CB = hd_nc16_channels(C) / L, W2 = 2 * W;
#pragma omp parallel for schedule(static) if ((double)B * CB * H * W * L > 65536)
    for (long nb = 0; nb < (long)B * CB; nb++) {
        const float *src = inp + (size_t)nb * H * W * L;
        float *dst = out + (size_t)nb * 4 * H * W * L;
        for (int y = 0; y < H; y++) {
            float *d0 = dst + (size_t)(2 * y) * W2 * L, *d1 = d0 + (size_t)W2 * L;
            for (int x = 0; x < W; x++) {
                const float *s = src + ((size_t)y * W + x) * L;
                memcpy(d0 + (size_t)(2 * x) * L, s, L * sizeof(float));
                memcpy(d0 + (size_t)(2 * x + 1) * L, s, L * sizeof(float));
                memcpy(d1 + (size_t)(2 * x) * L, s, L * sizeof(float));
                memcpy(d1 + (size_t)(2 * x + 1) * L, s, L * sizeof(float));
            }
        }
    }
}

void hd_upsample2_nc16_backward(float *dinp, const float *dout, int B, int C, int H, int W)
{
    /* forward: out(y, x) = inp(y / 2, x / 2); dinp sums its four copies */
    int CB = hd_nc16_channels(C) / L, W2 = 2 * W;
#pragma omp parallel for schedule(static) if ((double)B * CB * H * W * L > 65536)
    for (long nb = 0; nb < (long)B * CB; nb++) {
        float *d = dinp + (size_t)nb * H * W * L;
        const float *g = dout + (size_t)nb * 4 * H * W * L;
        for (int y = 0; y < H; y++) {
            const float *g0 = g + (size_t)(2 * y) * W2 * L, *g1 = g0 + (size_t)W2 * L;
            for (int x = 0; x < W; x++) {
                const float *a = g0 + (size_t)(2 * x) * L, *b = a + L, *c = g1 + (size_t)(2 * x) * L, *e = c + L;
                float *o = d + ((size_t)y * W + x) * L;
                for (int l = 0; l < L; l++) o[l] += (a[l] + b[l]) + (c[l] + e[l]);
            }
        }
    }
}
