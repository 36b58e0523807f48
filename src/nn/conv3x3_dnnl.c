/* conv3x3_dnnl.c: the oneDNN path of the 3x3 convolution (not yet built: plans fall back to the
 * portable path). */
#include "nn/conv3x3_impl.h"

#ifdef HD_HAVE_DNNL
hd_status hd_conv3x3_dnnl_plan(hd_conv3x3 *p)
{
    (void)p;
    return hd_fail(HD_ERR_ARG, "conv3x3: oneDNN path not available");
}
void hd_conv3x3_dnnl_free(hd_conv3x3 *p) { (void)p; }
void hd_conv3x3_dnnl_forward(hd_conv3x3 *p, float *out, const float *inp, const float *w, const float *b)
{
    (void)p, (void)out, (void)inp, (void)w, (void)b;
}
void hd_conv3x3_dnnl_backward(hd_conv3x3 *p, float *dinp, float *dw, float *db, const float *dout,
                              const float *inp, const float *w)
{
    (void)p, (void)dinp, (void)dw, (void)db, (void)dout, (void)inp, (void)w;
}
#endif
