/* unet.h: Common-Net, the Noise2Noise U-Net of SPEC section 3 that A-, S- and N-Net all are:
 * forward and backward through the whole net over one activation arena, with conv plans made
 * once per (batch, size). Parameters live in caller-owned flat arrays (the model's parameter
 * arena); the net only points into them.
 *
 * Layers in order (their parameter names are PREFIX.LAYER.weight / PREFIX.LAYER.bias):
 * enc0..enc6, dec5a, dec5b, dec4a, dec4b, dec3a, dec3b, dec2a, dec2b, dec1a, dec1b, dec1c.
 */
#ifndef HD_UNET_H
#define HD_UNET_H

#include "core/core.h"
#include "nn/nn.h"

#define HD_UNET_LAYERS 18

/* One named parameter tensor of a flat parameter array. */
typedef struct hd_param {
    char name[64];
    int ndim;
    int64_t shape[4];
    size_t offset; /* in floats, into the flat array */
    size_t count;
} hd_param;

typedef struct hd_unet hd_unet;

/* Appends the net's parameter tensors (names prefixed "PREFIX.") to params[*n ...] starting at
 * float offset *offset, and advances both. params may be NULL to only count. */
void hd_unet_params(const char *prefix, int cin, int cout, int width, hd_param *params, int *n,
                    size_t *offset);
/* A net for batches of B images of H x W (multiples of 32) with cin -> cout channels. */
hd_status hd_unet_create(hd_unet **net, int cin, int cout, int width, int B, int H, int W, hd_conv_path path);
void hd_unet_free(hd_unet *net);
/* Points the net at its parameters and gradients (flat arrays laid out by hd_unet_params from
 * offset 0; grads may be NULL for inference). */
void hd_unet_bind(hd_unet *net, const float *params, float *grads);
/* out (B, cout, H, W) = net(inp (B, cin, H, W)); saves what backward needs. */
void hd_unet_forward(hd_unet *net, const float *inp, float *out);
/* The bottleneck activation after enc6 (B, width, H/32, W/32), valid after forward. */
const float *hd_unet_bottleneck(const hd_unet *net);
/* Backward of the last forward: dout (B, cout, H, W); dbottleneck (may be NULL) is an extra
 * gradient arriving at the bottleneck (L-Net reads it); parameter gradients accumulate into the
 * bound grads; dinp (may be NULL) accumulates. dout and dbottleneck are not modified. */
void hd_unet_backward(hd_unet *net, const float *dout, const float *dbottleneck, float *dinp);
/* Multiply-accumulates of one forward pass of one image (for GFLOP/s figures). */
double hd_unet_macs(int cin, int cout, int width, int H, int W);
/* Per-layer timing (hdnet bench): with seconds (2 * HD_UNET_LAYERS doubles) not NULL, every
 * forward adds convolution l's wall time (with its activation) to seconds[l] and every backward
 * its backward's (activation gradient, input and weight gradients) to seconds[HD_UNET_LAYERS + l];
 * pooling, upsampling, concatenation and conversions are not counted. NULL stops. */
void hd_unet_profile(hd_unet *net, double *seconds);
/* Bytes of activation memory the net holds. */
size_t hd_unet_memory(const hd_unet *net);

#endif /* HD_UNET_H */
