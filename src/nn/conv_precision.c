/* conv_precision.c: the process-wide precision of the oneDNN convolutions (nn.h): FP32 by
 * default, bf16 where asked for and the CPU has oneDNN's bf16 kernels; and what the reports print
 * about it (the instruction set). */
#include <string.h>
#include "nn/conv3x3_impl.h"

static volatile int wanted = HD_PRECISION_FP32;

void hd_conv_set_precision(hd_precision p) { wanted = p == HD_PRECISION_FP32 ? HD_PRECISION_FP32 : HD_PRECISION_BF16; }

int hd_conv_bf16_available(void)
{
#ifdef HD_HAVE_DNNL
    return hd_conv3x3_dnnl_bf16_available();
#else
    return 0;
#endif
}

hd_precision hd_conv_precision(void)
{
    return wanted == HD_PRECISION_BF16 && hd_conv_bf16_available() ? HD_PRECISION_BF16 : HD_PRECISION_FP32;
}

const char *hd_conv_isa(void)
{
#ifdef HD_HAVE_DNNL
    return hd_conv3x3_dnnl_isa();
#else
    return "none";
#endif
}

hd_status hd_precision_parse(const char *s, const char *what, hd_precision *p)
{
    if (s && strcmp(s, "fp32") == 0) *p = HD_PRECISION_FP32;
    else if (s && strcmp(s, "bf16") == 0) *p = HD_PRECISION_BF16;
    else if (s && strcmp(s, "auto") == 0) *p = HD_PRECISION_AUTO;
    else return hd_fail(HD_ERR_ARG, "%s: precision '%s' is not fp32, bf16 or auto", what, s ? s : "");
    return HD_OK;
}
