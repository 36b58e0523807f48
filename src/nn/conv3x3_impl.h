/* conv3x3_impl.h: private to src/nn: the convolution plan's fields, shared by the path
 * dispatcher (conv3x3.c) and the oneDNN path (conv3x3_dnnl.c). */
#ifndef HD_CONV3X3_IMPL_H
#define HD_CONV3X3_IMPL_H

#include <stdlib.h>
#include "nn/nn.h"

struct hd_conv3x3 {
    int B, C, H, W, OC, stride, Ho, Wo;
    double macs; /* multiply-adds of one forward */
    int serial;        /* oneDNN plans: made and run on one OpenMP thread (small layers) */
    hd_act act;
    float slope;
    hd_conv_path path; /* the path actually taken: AUTO means oneDNN */
    int nc16;          /* tensors in the blocked layout nc16 (oneDNN only) */
    int bf16;          /* oneDNN in bf16 (asked for at plan time; cleared where it is not had) */
    size_t in_n, out_n; /* floats of inp and out, with nc16 padding */
    int band_rows;     /* portable: output rows per im2col band */
    float *col;        /* portable: (9 C, band_rows Wo) */
    void *dnnl;        /* oneDNN state, or NULL */
};

/* x = x > 0 ? x : slope x over n values, in place (conv3x3.c). */
void hd_conv3x3_lrelu(float *x, size_t n, float slope);

#ifdef HD_HAVE_DNNL
/* Builds the oneDNN primitives of plan p (shape fields set); HD_OK or a reason. */
hd_status hd_conv3x3_dnnl_plan(hd_conv3x3 *p);
void hd_conv3x3_dnnl_free(hd_conv3x3 *p);
void hd_conv3x3_dnnl_forward(hd_conv3x3 *p, float *out, const float *inp, const float *w, const float *b);
/* dout already holds the gradient before the activation; dinp is overwritten when `overwrite`,
 * otherwise accumulated into. */
void hd_conv3x3_dnnl_backward(hd_conv3x3 *p, float *dinp, float *dw, float *db, const float *dout,
                              const float *inp, const float *w, int overwrite);
int hd_conv3x3_dnnl_winograd(const hd_conv3x3 *p); /* the forward runs Winograd */
int hd_conv3x3_dnnl_is_bf16(const hd_conv3x3 *p);  /* the plan runs bf16 */
int hd_conv3x3_dnnl_bf16_available(void);          /* oneDNN has bf16 JIT kernels on this CPU */
const char *hd_conv3x3_dnnl_isa(void);             /* oneDNN's instruction set on this CPU */
/* The backward-data primitive onto the first c_head input channels (nc16 plans). */
hd_status hd_conv3x3_dnnl_plan_head(hd_conv3x3 *p, int c_head);
int hd_conv3x3_dnnl_head(const hd_conv3x3 *p); /* c_head, or 0 */
/* dinp's first c_head channels of every image = conv^T(dout, w) there (overwritten). */
void hd_conv3x3_dnnl_backward_head(hd_conv3x3 *p, float *dinp, const float *dout, const float *w);
#endif

#endif /* HD_CONV3X3_IMPL_H */
