/* conv3x3.c: the 3x3 convolution (padding 1, stride 1 or 2, bias, optional fused leaky ReLU),
 * the hot path of every network here. A plan per shape picks a path and owns its scratch memory:
 *   naive     direct loops, the reference the tests hold the others against;
 *   portable  im2col over bands of output rows + CBLAS sgemm (OpenBLAS);
 *   dnnl      oneDNN primitives (conv3x3_dnnl.c), when built with HD_HAVE_DNNL.
 * Backward ACCUMULATES into dinp, dw, db (a NULL one is skipped) and first turns dout, in place,
 * into the gradient before the activation.
 *
 * Letters: B batch, C / OC input / output channels, H, W input size, Ho, Wo output size,
 * K = 9 C the im2col depth, N = HoWo output pixels.
 */
#include <string.h>
#include <omp.h>
#include <cblas.h>
#ifdef __AVX2__
#include <immintrin.h>
#endif
#include "nn/conv3x3_impl.h"

/* Budget of one im2col band, in floats (8 MB): bands of output rows are processed in turn. */
#define COL_BUDGET (2u << 20)
/* Work (multiply-adds, or values / 8) below which loops stay on one thread: on a shared machine
 * a parallel region costs more than a small layer. */
#define PAR_MIN 2000000.0

/* oneDNN runs every primitive on all threads, however small; a layer of fewer multiply-adds than
 * this (the Common-Net's levels of 16 and 8 pixels, 0.02-0.3 ms on one thread) gains nothing from
 * a second thread and loses most when the machine is shared, where every parallel region waits
 * for its slowest thread: such plans are made and run with one OpenMP thread. */
#define SERIAL_MACS 25e6

int hd_conv3x3_out_h(const hd_conv3x3 *p) { return p->Ho; }

const char *hd_conv3x3_kernel(const hd_conv3x3 *p)
{
#ifdef HD_HAVE_DNNL
    if (p->dnnl) return hd_conv3x3_dnnl_winograd(p) ? "winograd" : "direct";
#endif
    return p->path == HD_CONV_NAIVE ? "naive" : "portable";
}

const char *hd_conv3x3_precision(const hd_conv3x3 *p)
{
#ifdef HD_HAVE_DNNL
    if (p->dnnl && hd_conv3x3_dnnl_is_bf16(p)) return "bf16";
#endif
    (void)p;
    return "fp32";
}

#ifdef HD_HAVE_DNNL
/* Around oneDNN calls of a serial plan: one thread, then the caller's count again. */
static int serial_begin(const hd_conv3x3 *p)
{
    if (!p->serial) return 0;
    int n = omp_get_max_threads();
    omp_set_num_threads(1);
    return n;
}
static void serial_end(int n)
{
    if (n) omp_set_num_threads(n);
}
#endif
int hd_conv3x3_out_w(const hd_conv3x3 *p) { return p->Wo; }

/* Fills the shape fields of a new plan; NULL (with reason) on a bad shape. */
static hd_conv3x3 *new_plan(int B, int C, int H, int W, int OC, int stride, hd_act act, float slope, int nc16)
{
    if (B < 1 || C < 1 || H < 1 || W < 1 || OC < 1 || (stride != 1 && stride != 2)) {
        hd_fail(HD_ERR_ARG, "conv3x3: bad shape B=%d C=%d H=%d W=%d OC=%d stride=%d", B, C, H, W, OC, stride);
        return NULL;
    }
    hd_conv3x3 *p = hd_calloc(1, sizeof *p);
    if (!p) return NULL;
    p->B = B, p->C = C, p->H = H, p->W = W, p->OC = OC, p->stride = stride;
    p->act = act, p->slope = slope, p->nc16 = nc16;
    p->bf16 = hd_conv_precision() == HD_PRECISION_BF16;
    p->Ho = (H - 1) / stride + 1;
    p->Wo = (W - 1) / stride + 1;
    p->macs = 9.0 * B * C * OC * p->Ho * p->Wo;
    p->serial = p->macs < SERIAL_MACS;
    p->in_n = (size_t)B * (nc16 ? hd_nc16_channels(C) : C) * H * W;
    p->out_n = (size_t)B * (nc16 ? hd_nc16_channels(OC) : OC) * p->Ho * p->Wo;
    return p;
}

hd_status hd_conv3x3_plan(hd_conv3x3 **plan, int B, int C, int H, int W, int OC, int stride,
                          hd_act act, float slope, hd_conv_path path)
{
    *plan = NULL;
    hd_conv3x3 *p = new_plan(B, C, H, W, OC, stride, act, slope, 0);
    if (!p) return C < 1 || B < 1 || H < 1 || W < 1 || OC < 1 || (stride != 1 && stride != 2) ? HD_ERR_ARG : HD_ERR_NOMEM;
    hd_status st = HD_OK;
#ifdef HD_HAVE_DNNL
    if (path == HD_CONV_AUTO) {
        int nt = serial_begin(p);
        st = hd_conv3x3_dnnl_plan(p);
        serial_end(nt);
        if (st == HD_OK) {
            p->path = HD_CONV_AUTO;
            *plan = p;
            return HD_OK;
        }
        hd_clear_error(); /* fall back to the portable path */
        st = HD_OK;
    }
#endif
    if (path == HD_CONV_NAIVE) {
        p->path = HD_CONV_NAIVE;
    } else {
        p->path = HD_CONV_PORTABLE;
        size_t K = (size_t)9 * C, row = K * p->Wo, rows = COL_BUDGET / (row ? row : 1);
        if (rows < 1) rows = 1;
        if (rows > (size_t)p->Ho) rows = p->Ho;
        p->band_rows = (int)rows;
        size_t n;
        if (!hd_mul_size(row, rows, &n)) st = hd_fail(HD_ERR_RANGE, "conv3x3: im2col band too large");
        else if (!(p->col = hd_malloc(n * sizeof(float)))) st = HD_ERR_NOMEM;
    }
    if (st != HD_OK) {
        hd_conv3x3_free(p);
        return st;
    }
    *plan = p;
    return HD_OK;
}

hd_status hd_conv3x3_plan_nc16(hd_conv3x3 **plan, int B, int C, int H, int W, int OC, int stride,
                               hd_act act, float slope)
{
    *plan = NULL;
#ifdef HD_HAVE_DNNL
    hd_conv3x3 *p = new_plan(B, C, H, W, OC, stride, act, slope, 1);
    if (!p) return C < 1 || B < 1 || H < 1 || W < 1 || OC < 1 || (stride != 1 && stride != 2) ? HD_ERR_ARG : HD_ERR_NOMEM;
    int nt = serial_begin(p);
    hd_status st = hd_conv3x3_dnnl_plan(p);
    serial_end(nt);
    if (st != HD_OK) {
        hd_conv3x3_free(p);
        return st;
    }
    p->path = HD_CONV_AUTO;
    *plan = p;
    return HD_OK;
#else
    (void)B, (void)C, (void)H, (void)W, (void)OC, (void)stride, (void)act, (void)slope;
    return hd_fail(HD_ERR_ARG, "conv3x3: the nc16 layout needs oneDNN (built without it)");
#endif
}

void hd_conv3x3_free(hd_conv3x3 *p)
{
    if (!p) return;
#ifdef HD_HAVE_DNNL
    hd_conv3x3_dnnl_free(p);
#endif
    free(p->col);
    free(p);
}

/* ---- naive: direct loops */

static void naive_forward(const hd_conv3x3 *p, float *out, const float *inp, const float *w, const float *b)
{
    /* out(n, o, y, x) = b(o) + sum_{c, i, j} w(o, c, i, j) inp(n, c, s y + i - 1, s x + j - 1) */
    int C = p->C, H = p->H, W = p->W, OC = p->OC, Ho = p->Ho, Wo = p->Wo, s = p->stride;
#pragma omp parallel for schedule(static) if (p->macs > PAR_MIN)
    for (long no = 0; no < (long)p->B * OC; no++) {
        int n = (int)(no / OC), o = (int)(no % OC);
        float *dst = out + (size_t)no * Ho * Wo;
        for (int y = 0; y < Ho; y++)
            for (int x = 0; x < Wo; x++) {
                float acc = b ? b[o] : 0.0f;
                for (int c = 0; c < C; c++) {
                    const float *src = inp + ((size_t)n * C + c) * H * W;
                    const float *k = w + ((size_t)o * C + c) * 9;
                    for (int i = 0; i < 3; i++) {
                        int iy = s * y + i - 1;
                        if (iy < 0 || iy >= H) continue;
                        for (int j = 0; j < 3; j++) {
                            int ix = s * x + j - 1;
                            if (ix < 0 || ix >= W) continue;
                            acc += k[i * 3 + j] * src[(size_t)iy * W + ix];
                        }
                    }
                }
                dst[(size_t)y * Wo + x] = acc;
            }
    }
}

static void naive_backward(const hd_conv3x3 *p, float *dinp, float *dw, float *db, const float *dout,
                           const float *inp, const float *w)
{
    int B = p->B, C = p->C, H = p->H, W = p->W, OC = p->OC, Ho = p->Ho, Wo = p->Wo, s = p->stride;
    /* dinp(n, c, s y + i - 1, s x + j - 1) += w(o, c, i, j) dout(n, o, y, x) */
    if (dinp) {
#pragma omp parallel for schedule(static) if (p->macs > PAR_MIN)
        for (long nc = 0; nc < (long)B * C; nc++) {
            int n = (int)(nc / C), c = (int)(nc % C);
            float *d = dinp + (size_t)nc * H * W;
            for (int o = 0; o < OC; o++) {
                const float *g = dout + ((size_t)n * OC + o) * Ho * Wo;
                const float *k = w + ((size_t)o * C + c) * 9;
                for (int y = 0; y < Ho; y++)
                    for (int x = 0; x < Wo; x++) {
                        float gv = g[(size_t)y * Wo + x];
                        for (int i = 0; i < 3; i++) {
                            int iy = s * y + i - 1;
                            if (iy < 0 || iy >= H) continue;
                            for (int j = 0; j < 3; j++) {
                                int ix = s * x + j - 1;
                                if (ix < 0 || ix >= W) continue;
                                d[(size_t)iy * W + ix] += k[i * 3 + j] * gv;
                            }
                        }
                    }
            }
        }
    }
    /* dw(o, c, i, j) += sum_{n, y, x} dout(n, o, y, x) inp(n, c, s y + i - 1, s x + j - 1);
     * db(o) += sum_{n, y, x} dout(n, o, y, x) */
    if (dw || db) {
#pragma omp parallel for schedule(static) if (p->macs > PAR_MIN)
        for (int o = 0; o < OC; o++) {
            if (db) {
                double acc = 0.0;
                for (int n = 0; n < B; n++) {
                    const float *g = dout + ((size_t)n * OC + o) * Ho * Wo;
                    for (int q = 0; q < Ho * Wo; q++) acc += g[q];
                }
                db[o] += (float)acc;
            }
            if (!dw) continue;
            for (int c = 0; c < C; c++)
                for (int i = 0; i < 3; i++)
                    for (int j = 0; j < 3; j++) {
                        double acc = 0.0;
                        for (int n = 0; n < B; n++) {
                            const float *g = dout + ((size_t)n * OC + o) * Ho * Wo;
                            const float *src = inp + ((size_t)n * C + c) * H * W;
                            for (int y = 0; y < Ho; y++) {
                                int iy = s * y + i - 1;
                                if (iy < 0 || iy >= H) continue;
                                for (int x = 0; x < Wo; x++) {
                                    int ix = s * x + j - 1;
                                    if (ix < 0 || ix >= W) continue;
                                    acc += (double)g[(size_t)y * Wo + x] * src[(size_t)iy * W + ix];
                                }
                            }
                        }
                        dw[((size_t)o * C + c) * 9 + i * 3 + j] += (float)acc;
                    }
        }
    }
}

/* ---- portable: im2col bands + sgemm */

/* col(k = (c, i, j), q) for output rows y0 .. y0 + rows - 1 of image `src` (C, H, W):
 * col = inp(c, s y + i - 1, s x + j - 1), 0 outside. col is (K, rows Wo). */
static void im2col(const hd_conv3x3 *p, float *col, const float *src, int y0, int rows)
{
    int H = p->H, W = p->W, Wo = p->Wo, s = p->stride;
    size_t N = (size_t)rows * Wo;
#pragma omp parallel for schedule(static) if (N * p->C > PAR_MIN / 8)
    for (int k = 0; k < 9 * p->C; k++) {
        int c = k / 9, i = (k / 3) % 3, j = k % 3;
        const float *plane = src + (size_t)c * H * W;
        float *dst = col + (size_t)k * N;
        for (int r = 0; r < rows; r++) {
            int iy = s * (y0 + r) + i - 1;
            float *d = dst + (size_t)r * Wo;
            if (iy < 0 || iy >= H) {
                memset(d, 0, (size_t)Wo * sizeof(float));
                continue;
            }
            const float *row = plane + (size_t)iy * W;
            for (int x = 0; x < Wo; x++) {
                int ix = s * x + j - 1;
                d[x] = (ix >= 0 && ix < W) ? row[ix] : 0.0f;
            }
        }
    }
}

/* The adjoint of im2col: dsrc(c, s y + i - 1, s x + j - 1) += col(k, q). Parallel over c, so that
 * no two threads write the same plane. */
static void col2im(const hd_conv3x3 *p, float *dsrc, const float *col, int y0, int rows)
{
    int H = p->H, W = p->W, Wo = p->Wo, s = p->stride;
    size_t N = (size_t)rows * Wo;
#pragma omp parallel for schedule(static) if (N * p->C > PAR_MIN / 8)
    for (int c = 0; c < p->C; c++) {
        float *plane = dsrc + (size_t)c * H * W;
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++) {
                const float *srow = col + (size_t)(c * 9 + i * 3 + j) * N;
                for (int r = 0; r < rows; r++) {
                    int iy = s * (y0 + r) + i - 1;
                    if (iy < 0 || iy >= H) continue;
                    float *d = plane + (size_t)iy * W;
                    const float *g = srow + (size_t)r * Wo;
                    for (int x = 0; x < Wo; x++) {
                        int ix = s * x + j - 1;
                        if (ix >= 0 && ix < W) d[ix] += g[x];
                    }
                }
            }
    }
}

static void portable_forward(hd_conv3x3 *p, float *out, const float *inp, const float *w, const float *b)
{
    /* out(o, q) = b(o) + sum_k w(o, k) col(k, q): sgemm (OC x K) (K x N) per band */
    int C = p->C, OC = p->OC, Wo = p->Wo, K = 9 * C;
    size_t HWi = (size_t)p->H * p->W, HWo = (size_t)p->Ho * Wo;
    for (int n = 0; n < p->B; n++) {
        float *dst = out + (size_t)n * OC * HWo;
        for (int o = 0; o < OC; o++) {
            float bv = b ? b[o] : 0.0f;
            for (size_t q = 0; q < HWo; q++) dst[o * HWo + q] = bv;
        }
        for (int y0 = 0; y0 < p->Ho; y0 += p->band_rows) {
            int rows = p->Ho - y0 < p->band_rows ? p->Ho - y0 : p->band_rows;
            int N = rows * Wo;
            im2col(p, p->col, inp + (size_t)n * C * HWi, y0, rows);
            cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, OC, N, K, 1.0f, w, K, p->col, N,
                        1.0f, dst + (size_t)y0 * Wo, (int)HWo);
        }
    }
}

static void portable_backward(hd_conv3x3 *p, float *dinp, float *dw, float *db, const float *dout,
                              const float *inp, const float *w)
{
    int C = p->C, OC = p->OC, Wo = p->Wo, K = 9 * C;
    size_t HWi = (size_t)p->H * p->W, HWo = (size_t)p->Ho * Wo;
    for (int n = 0; n < p->B; n++) {
        const float *g = dout + (size_t)n * OC * HWo;
        if (db)
            for (int o = 0; o < OC; o++) {
                double acc = 0.0;
                for (size_t q = 0; q < HWo; q++) acc += g[o * HWo + q];
                db[o] += (float)acc;
            }
        for (int y0 = 0; y0 < p->Ho; y0 += p->band_rows) {
            int rows = p->Ho - y0 < p->band_rows ? p->Ho - y0 : p->band_rows;
            int N = rows * Wo;
            const float *gb = g + (size_t)y0 * Wo;
            if (dw) {
                /* dw(o, k) += sum_q dout(o, q) col(k, q) */
                im2col(p, p->col, inp + (size_t)n * C * HWi, y0, rows);
                cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasTrans, OC, K, N, 1.0f, gb, (int)HWo,
                            p->col, N, 1.0f, dw, K);
            }
            if (dinp) {
                /* dcol(k, q) = sum_o w(o, k) dout(o, q); dinp += col2im(dcol) */
                cblas_sgemm(CblasRowMajor, CblasTrans, CblasNoTrans, K, N, OC, 1.0f, w, K, gb,
                            (int)HWo, 0.0f, p->col, N);
                col2im(p, dinp + (size_t)n * C * HWi, p->col, y0, rows);
            }
        }
    }
}

/* ---- dispatch */

/* The profile's op names (core.h, profiling): a convolution's three parts and its activation's
 * backward, keyed by the plan's shape. */
#define PROF_OP(name, p, since) hd_prof_op(name, (p)->C, (p)->OC, (p)->H, (p)->stride, since)

void hd_conv3x3_forward(hd_conv3x3 *p, float *out, const float *inp, const float *w, const float *b)
{
    hd_prof_mark t0 = hd_prof_now();
#ifdef HD_HAVE_DNNL
    if (p->dnnl) {
        int nt = serial_begin(p);
        hd_conv3x3_dnnl_forward(p, out, inp, w, b);
        serial_end(nt);
        PROF_OP("conv forward", p, t0);
        return;
    }
#endif
    if (p->path == HD_CONV_NAIVE) naive_forward(p, out, inp, w, b);
    else portable_forward(p, out, inp, w, b);
    if (p->act == HD_ACT_LRELU) hd_conv3x3_lrelu(out, p->out_n, p->slope);
    PROF_OP("conv forward", p, t0);
}

/* g[i] *= (ref[i] > 0 ? 1 : slope) for i < n: the leaky ReLU in place (ref = g) and its backward
 * (ref = the forward's output). Vectorised by hand: the compiler turns the select into a branch,
 * a coin toss per value, which cost more than the large layers' convolutions themselves. Each
 * value is multiplied by exactly 1 or slope, as the scalar tail does. */
static void lrelu_scale(float *g, const float *ref, size_t n, float slope)
{
    size_t i = 0;
#ifdef __AVX2__
    const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f), sl = _mm256_set1_ps(slope);
    for (; i + 8 <= n; i += 8) {
        __m256 f = _mm256_blendv_ps(sl, one, _mm256_cmp_ps(_mm256_loadu_ps(ref + i), zero, _CMP_GT_OQ));
        _mm256_storeu_ps(g + i, _mm256_mul_ps(_mm256_loadu_ps(g + i), f));
    }
#endif
    for (; i < n; i++) g[i] *= ref[i] > 0.0f ? 1.0f : slope;
}

/* lrelu_scale over n values in chunks, the chunks shared among threads when n is large */
static void lrelu_scale_par(float *g, const float *ref, size_t n, float slope)
{
    enum { CHUNK = 16384 };
    long chunks = (long)((n + CHUNK - 1) / CHUNK);
#pragma omp parallel for schedule(static) if (n > PAR_MIN / 8)
    for (long c = 0; c < chunks; c++) {
        size_t at = (size_t)c * CHUNK, len = n - at < CHUNK ? n - at : CHUNK;
        lrelu_scale(g + at, ref + at, len, slope);
    }
}

void hd_conv3x3_lrelu(float *x, size_t n, float slope) { lrelu_scale_par(x, x, n, slope); }

/* The backward after the activation's: dinp (overwritten when `overwrite`, onto the plan's head
 * when `head`), dw and db from dout, the gradient before the activation. */
static void backward_parts(hd_conv3x3 *p, float *dinp, float *dw, float *db, const float *dout, const float *inp,
                           const float *w, int overwrite, int head)
{
#ifdef HD_HAVE_DNNL
    if (p->dnnl) {
        int nt = serial_begin(p);
        if (head && dinp && hd_conv3x3_dnnl_head(p)) {
            hd_conv3x3_dnnl_backward_head(p, dinp, dout, w);
            dinp = NULL; /* done */
        }
        if (dinp || dw || db) hd_conv3x3_dnnl_backward(p, dinp, dw, db, dout, inp, w, overwrite);
        serial_end(nt);
        return;
    }
#else
    (void)head;
#endif
    if (dinp && overwrite) memset(dinp, 0, p->in_n * sizeof(float));
    if (p->path == HD_CONV_NAIVE) naive_backward(p, dinp, dw, db, dout, inp, w);
    else portable_backward(p, dinp, dw, db, dout, inp, w);
}

/* Shared by both backward entries: overwrite says whether dinp is overwritten. */
static void backward(hd_conv3x3 *p, float *dinp, float *dw, float *db, float *dout, const float *out,
                     const float *inp, const float *w, int overwrite, int head)
{
    /* forward: out = lrelu(pre) = pre > 0 ? pre : slope pre, and out > 0 exactly when pre > 0
     * (slope > 0), so dpre = dout * (out > 0 ? 1 : slope), in place */
    hd_prof_mark t0 = hd_prof_now();
    if (p->act == HD_ACT_LRELU) lrelu_scale_par(dout, out, p->out_n, p->slope);
    if (hd_prof_enabled()) {
        /* profiled: the activation's backward, backward-data and backward-weights timed apart
         * (each part is independent of the other: the same results) */
        PROF_OP("conv act backward", p, t0);
        t0 = hd_prof_now();
        if (dinp) backward_parts(p, dinp, NULL, NULL, dout, inp, w, overwrite, head);
        PROF_OP("conv backward-data", p, t0);
        t0 = hd_prof_now();
        if (dw || db) backward_parts(p, NULL, dw, db, dout, inp, w, overwrite, head);
        PROF_OP("conv backward-weights", p, t0);
        return;
    }
    backward_parts(p, dinp, dw, db, dout, inp, w, overwrite, head);
}

void hd_conv3x3_backward(hd_conv3x3 *p, float *dinp, float *dw, float *db, float *dout,
                         const float *out, const float *inp, const float *w)
{
    backward(p, dinp, dw, db, dout, out, inp, w, 0, 0);
}

void hd_conv3x3_backward_into(hd_conv3x3 *p, float *dinp, float *dw, float *db, float *dout,
                              const float *out, const float *inp, const float *w)
{
    backward(p, dinp, dw, db, dout, out, inp, w, 1, 0);
}

hd_status hd_conv3x3_plan_dinp_head(hd_conv3x3 *p, int c_head)
{
#ifdef HD_HAVE_DNNL
    if (p->dnnl && p->nc16) {
        int nt = serial_begin(p);
        hd_status st = hd_conv3x3_dnnl_plan_head(p, c_head);
        serial_end(nt);
        return st;
    }
#endif
    (void)p, (void)c_head;
    return hd_fail(HD_ERR_ARG, "conv3x3: a gradient head needs an nc16 plan (oneDNN)");
}

void hd_conv3x3_backward_head_into(hd_conv3x3 *p, float *dinp, float *dw, float *db, float *dout,
                                   const float *out, const float *inp, const float *w)
{
    backward(p, dinp, dw, db, dout, out, inp, w, 1, 1);
}
