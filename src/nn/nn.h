/* nn.h: the neural engine: layers as forward/backward pairs of free functions over float arrays
 * (NCHW, contiguous), loss pieces, Adam and initialisation. llm.c conventions: outputs first, then
 * what the forward saved, then inputs and weights, then sizes. Every backward ACCUMULATES (+=)
 * into its gradient outputs; a NULL gradient output is skipped.
 *
 * Letters: B batch, C / OC input / output channels, H, W input height / width, HW = H * W,
 * Ho, Wo output size. Convolution weights are OIHW (OC, C, 3, 3), biases (OC).
 */
#ifndef HD_NN_H
#define HD_NN_H

#include <stddef.h>
#include "core/core.h"

/* ---- 3x3 convolution, padding 1, stride 1 or 2, bias, optional fused leaky ReLU.
 * Output size: Ho = (H + 2 - 3) / stride + 1 (stride 2: ceil(H / 2)).
 * A plan is made once per shape (it holds the fast path's primitives and scratch memory) and
 * reused every step; nothing is allocated in forward or backward. */
typedef struct hd_conv3x3 hd_conv3x3;

typedef enum hd_act { HD_ACT_NONE = 0, HD_ACT_LRELU } hd_act;

typedef enum hd_conv_path {
    HD_CONV_AUTO = 0, /* the fastest available (oneDNN when built with it) */
    HD_CONV_PORTABLE, /* our own: im2col + CBLAS sgemm */
    HD_CONV_NAIVE     /* direct loops: the reference the tests hold the others against */
} hd_conv_path;

hd_status hd_conv3x3_plan(hd_conv3x3 **plan, int B, int C, int H, int W, int OC, int stride,
                          hd_act act, float slope, hd_conv_path path);
void hd_conv3x3_free(hd_conv3x3 *plan);
/* The kernels a plan runs, for reports: "winograd" or "direct" (oneDNN; winograd where its forward
 * takes it), "portable" or "naive". */
const char *hd_conv3x3_kernel(const hd_conv3x3 *plan);
int hd_conv3x3_out_h(const hd_conv3x3 *plan);
int hd_conv3x3_out_w(const hd_conv3x3 *plan);
/* out (B, OC, Ho, Wo) = act(conv(inp (B, C, H, W), w) + b) */
void hd_conv3x3_forward(hd_conv3x3 *plan, float *out, const float *inp, const float *w, const float *b);
/* dout is overwritten in place with the gradient before the activation.
 * forward: out = act(pre); dinp (may be NULL), dw, db accumulate. */
void hd_conv3x3_backward(hd_conv3x3 *plan, float *dinp, float *dw, float *db, float *dout,
                         const float *out, const float *inp, const float *w);
/* As hd_conv3x3_backward, but dinp (not NULL) is overwritten instead of accumulated into (saves
 * zeroing it first). dw, db still accumulate. */
void hd_conv3x3_backward_into(hd_conv3x3 *plan, float *dinp, float *dw, float *db, float *dout,
                              const float *out, const float *inp, const float *w);

/* ---- precision of the oneDNN convolutions (conv_precision.c). Process-wide, read when a plan is
 * made: FP32 (the default) or bf16, oneDNN's bf16 kernels where the CPU has them (avx512_bf16):
 * the inputs, weights and output gradients of each convolution rounded to bf16, every product
 * summed and every output (activations, input and weight gradients) written in FP32, so master
 * weights, Adam and the losses stay FP32. A plan asked for bf16 where the CPU lacks it runs FP32.
 * The portable and naive paths are always FP32. */
typedef enum hd_precision {
    HD_PRECISION_FP32 = 0,
    HD_PRECISION_BF16, /* where available */
    HD_PRECISION_AUTO  /* bf16 where available: the same as BF16, named for option parsing */
} hd_precision;
void hd_conv_set_precision(hd_precision p);
/* What plans made now get: HD_PRECISION_BF16 only where it was asked for and is available. */
hd_precision hd_conv_precision(void);
/* 1 when oneDNN runs bf16 convolutions with its JIT kernels on this CPU. */
int hd_conv_bf16_available(void);
/* The instruction set oneDNN uses on this CPU ("avx512_core_bf16", "avx2", ...), or "none"
 * (built without oneDNN). */
const char *hd_conv_isa(void);
/* Parses "fp32", "bf16" or "auto" (HD_ERR_ARG naming `what` otherwise). */
hd_status hd_precision_parse(const char *s, const char *what, hd_precision *p);
/* The precision a plan runs: "bf16" or "fp32". */
const char *hd_conv3x3_precision(const hd_conv3x3 *plan);

/* ---- the blocked channel layout of the oneDNN path ("nc16", oneDNN's nChw16c): a tensor
 * (B, C, H, W) is stored as (B, ceil(C / 16), H, W, 16), channel c at block c / 16, lane c % 16;
 * the lanes past C are zero. Layers of the Common-Net run in it end to end, without reorders. */
#define HD_NC16_BLOCK 16
static inline int hd_nc16_channels(int C) { return (C + 15) / 16 * 16; }
/* A convolution plan whose inp, out, dinp and dout are nc16 (weights and bias stay OIHW / (OC));
 * only with oneDNN (HD_ERR_ARG otherwise). */
hd_status hd_conv3x3_plan_nc16(hd_conv3x3 **plan, int B, int C, int H, int W, int OC, int stride,
                               hd_act act, float slope);
/* Backward data onto the first c_head input channels only (a multiple of 16, at most C), for an
 * input whose other channels need no gradient (the Common-Net's own input in its last
 * concatenation): prepares the plan once (HD_ERR_ARG if it is not an nc16 plan); then
 * hd_conv3x3_backward_head_into overwrites those channels of dinp in every image, leaves the rest
 * unspecified (on a plan without a head: as hd_conv3x3_backward_into), and accumulates dw, db. */
hd_status hd_conv3x3_plan_dinp_head(hd_conv3x3 *plan, int c_head);
void hd_conv3x3_backward_head_into(hd_conv3x3 *plan, float *dinp, float *dw, float *db, float *dout,
                                   const float *out, const float *inp, const float *w);
/* Layout conversions: plain (B, C, HW) <-> nc16; to_plain accumulates when `accumulate`. */
void hd_nc16_from_plain(float *nc16, const float *plain, int B, int C, int HW);
void hd_nc16_to_plain(float *plain, const float *nc16, int B, int C, int HW, int accumulate);
/* 2x2 max pooling and nearest 2x upsampling in nc16 (C counts real channels). */
void hd_maxpool2_nc16_forward(float *out, const float *inp, int B, int C, int H, int W);
void hd_maxpool2_nc16_backward(float *dinp, const float *dout, const float *inp, int B, int C, int H, int W);
/* As hd_maxpool2_nc16_backward, but dinp is overwritten (no zeroing needed first). */
void hd_maxpool2_nc16_backward_into(float *dinp, const float *dout, const float *inp, int B, int C, int H, int W);
void hd_upsample2_nc16_forward(float *out, const float *inp, int B, int C, int H, int W);
void hd_upsample2_nc16_backward(float *dinp, const float *dout, int B, int C, int H, int W);

/* ---- elementwise (n values) */
void hd_lrelu_forward(float *out, const float *inp, size_t n, float slope);
void hd_lrelu_backward(float *dinp, const float *dout, const float *inp, size_t n, float slope);
void hd_sigmoid_forward(float *out, const float *inp, size_t n);
void hd_sigmoid_backward(float *dinp, const float *dout, const float *out, size_t n);
void hd_softplus_forward(float *out, const float *inp, size_t n);
void hd_softplus_backward(float *dinp, const float *dout, const float *inp, size_t n);
void hd_tanh_forward(float *out, const float *inp, size_t n);
void hd_tanh_backward(float *dinp, const float *dout, const float *out, size_t n);

/* ---- per-pixel L2 normalisation of a 3-channel map: out = x / max(||x||, eps) (PyTorch's
 * F.normalize), inp and out (B, 3, HW). */
void hd_l2norm3_forward(float *out, const float *inp, int B, int HW, float eps);
void hd_l2norm3_backward(float *dinp, const float *dout, const float *inp, int B, int HW, float eps);

/* ---- 2x2 max pooling (H, W even): out (B, C, H/2, W/2). Ties go to the first in row order. */
void hd_maxpool2_forward(float *out, const float *inp, int B, int C, int H, int W);
void hd_maxpool2_backward(float *dinp, const float *dout, const float *inp, int B, int C, int H, int W);

/* ---- nearest 2x upsampling: inp (B, C, H, W) -> out (B, C, 2H, 2W). */
void hd_upsample2_forward(float *out, const float *inp, int B, int C, int H, int W);
void hd_upsample2_backward(float *dinp, const float *dout, int B, int C, int H, int W);

/* ---- channel concatenation: out (B, Ca + Cb, HW) = [a (B, Ca, HW), b (B, Cb, HW)]. */
void hd_concat_forward(float *out, const float *a, int Ca, const float *b, int Cb, int B, int HW);
void hd_concat_backward(float *da, float *db, const float *dout, int Ca, int Cb, int B, int HW);

/* ---- global mean over space: inp (B, C, HW) -> out (B, C). */
void hd_meanpool_forward(float *out, const float *inp, int B, int C, int HW);
void hd_meanpool_backward(float *dinp, const float *dout, int B, int C, int HW);

/* ---- linear: out (B, OUT) = inp (B, IN) w^T + b, w (OUT, IN). */
void hd_linear_forward(float *out, const float *inp, const float *w, const float *b, int B, int IN, int OUT);
void hd_linear_backward(float *dinp, float *dw, float *db, const float *dout, const float *inp,
                        const float *w, int B, int IN, int OUT);

/* ---- instance normalisation, no affine: out = (x - mean) * rstd per (b, c) over HW,
 * rstd = 1 / sqrt(var + eps) with the biased variance. mean, rstd (B, C) are saved. */
void hd_instnorm_forward(float *out, float *mean, float *rstd, const float *inp, int B, int C, int HW, float eps);
void hd_instnorm_backward(float *dinp, const float *dout, const float *out, const float *rstd, int B, int C, int HW);

/* ---- loss pieces. Each returns the loss value and, where a gradient pointer is not NULL,
 * accumulates scale * dLoss/dx into it. Weights w are per pixel (HW), NULL meaning all ones;
 * mean_w(x) = sum_p w_p sum_c x_cp / (C * sum_p w_p) (0 when sum_p w_p = 0). */
/* mean_w(|x - y|), x and y (C, HW). */
float hd_loss_l1(float *dx, float *dy, const float *x, const float *y, const float *w, int C, int HW, float scale);
/* sum_p w_p sum_c (x - y)^2 / sum_p w_p: squared distance per pixel, averaged over pixels. */
float hd_loss_sqdist(float *dx, float *dy, const float *x, const float *y, const float *w, int C, int HW, float scale);
/* Binary cross-entropy with logits against a constant target t in {0, 1}:
 * mean over n of softplus(-x) (t = 1) or softplus(x) (t = 0). */
float hd_loss_bce_logits(float *dx, const float *x, size_t n, int target, float scale);
/* SPEC section 4 smoothness of one map s (H, W):
 * mean_wx(|dx s| / max(|dx s|, eps)) + mean_wy(|dy s| / max(|dy s|, eps)), forward differences,
 * wx(y, x) = m(y, x) m(y, x+1), wy likewise; m may be NULL. */
float hd_loss_smooth(float *ds, const float *s, const float *m, int H, int W, float eps, float scale);

/* ---- Adam with bias correction (t counts from 1): m = b1 m + (1-b1) g; v = b2 v + (1-b2) g^2;
 * p -= lr * (m / (1 - b1^t)) / (sqrt(v / (1 - b2^t)) + eps). */
void hd_adam_step(float *param, const float *grad, float *m, float *v, size_t n, float lr,
                  float beta1, float beta2, float eps, long t);

/* ---- PyTorch's default initialisation for conv and linear layers: weights and bias uniform in
 * [-1/sqrt(fan_in), 1/sqrt(fan_in)] (kaiming_uniform with a = sqrt(5)). b may be NULL. */
void hd_init_uniform_fan_in(float *w, size_t nw, float *b, size_t nb, int fan_in, hd_rng *rng);

#endif /* HD_NN_H */
