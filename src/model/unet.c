/* unet.c: Common-Net (SPEC section 3), the Noise2Noise U-Net that A-, S- and N-Net all are:
 * seven encoder convolutions with 2x2 max pooling, a decoder of nearest upsampling, skip
 * concatenation ("upsampled first, skip second") and convolution pairs, the last block also
 * concatenating the net's input. LReLU 0.1 after every convolution but dec1c.
 *
 * Letters: B batch, H, W input size, w width, cin / cout channels; level l has size H >> l.
 * Activations and their gradients live in one arena carved at creation; backward zeroes each
 * gradient buffer that several layers add into just before the first of them.
 *
 * Layout: with oneDNN and a width that is a multiple of 16, every tensor inside the net is kept in
 * oneDNN's blocked layout nc16 (nn.h), so that no convolution reorders its input or output; the
 * concatenations are then copies of whole channel blocks (the net's input, padded to 16 channels,
 * goes last, where the padding of dec1a's input belongs). Only the net's input, output and
 * bottleneck are converted from and to plain NCHW. Otherwise everything is plain NCHW.
 * In nc16, a layer whose input has padded lanes (enc0 and dec1a when cin is not a multiple of
 * 16) reads them as real channels through weights padded with zeros (wpad): oneDNN's blocked
 * kernels refuse 1..3 input channels (its "first layer" case wants a plain input) and fall back to
 * a reference kernel about 100x slower (N-Net's 1-channel input took 0.75 s of a 0.23 s net at
 * 256x256), and take the direct kernel instead of Winograd for partial blocks (N-Net's dec1a,
 * 97 channels: 0.35 s against 0.22 s at 112, forward and backward, batch 2).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "model/unet.h"

enum { ENC0, ENC1, ENC2, ENC3, ENC4, ENC5, ENC6, DEC5A, DEC5B, DEC4A, DEC4B, DEC3A, DEC3B,
       DEC2A, DEC2B, DEC1A, DEC1B, DEC1C };

static const char *const layer_names[HD_UNET_LAYERS] = {
    "enc0", "enc1", "enc2", "enc3", "enc4", "enc5", "enc6", "dec5a", "dec5b",
    "dec4a", "dec4b", "dec3a", "dec3b", "dec2a", "dec2b", "dec1a", "dec1b", "dec1c"};

/* Input channels, output channels and level (size H >> level) of layer l. */
static void layer_shape(int l, int cin, int cout, int w, int *ci, int *co, int *level)
{
    static const int lev[HD_UNET_LAYERS] = {0, 0, 1, 2, 3, 4, 5, 4, 4, 3, 3, 2, 2, 1, 1, 0, 0, 0};
    *level = lev[l];
    switch (l) {
    case ENC0: *ci = cin, *co = w; break;
    case DEC5A: *ci = 2 * w, *co = 2 * w; break;
    case DEC4A: case DEC3A: case DEC2A: *ci = 3 * w, *co = 2 * w; break;
    case DEC5B: case DEC4B: case DEC3B: case DEC2B: *ci = 2 * w, *co = 2 * w; break;
    case DEC1A: *ci = 2 * w + cin, *co = 64; break;
    case DEC1B: *ci = 64, *co = 32; break;
    case DEC1C: *ci = 32, *co = cout; break;
    default: *ci = w, *co = w; break; /* enc1 .. enc6 */
    }
}

/* A tensor: activation x and its gradient g, (B, c, h, w); cp = c, or c padded to 16 in nc16. */
typedef struct tensor {
    float *x, *g;
    int c, cp, h, w;
} tensor;

struct hd_unet {
    int cin, cout, width, B, H, W;
    int nc16;       /* tensors in the blocked layout */
    float *bneck;   /* the bottleneck in plain NCHW (B, w, H/32, W/32) */
    float *bneck_g; /* nc16: dbottleneck converted */
    /* nc16, layers whose input has padded lanes: the weights padded to (co, cpad, 3, 3) with
     * zeros past ci (copied at each forward) and the gradient's scratch; else NULL */
    float *wpad[HD_UNET_LAYERS], *dwpad[HD_UNET_LAYERS];
    int cpad[HD_UNET_LAYERS];
    double *prof;   /* hd_unet_profile's seconds, or NULL */
    hd_conv3x3 *conv[HD_UNET_LAYERS];
    const float *wt[HD_UNET_LAYERS], *bias[HD_UNET_LAYERS]; /* bound parameters */
    float *dwt[HD_UNET_LAYERS], *dbias[HD_UNET_LAYERS];     /* bound gradients, or NULL */
    /* inp: a copy of the input; e[l]: output of enc l; p[l]: pooled e (p[1] = pool(e1), ...
     * p[5] = pool(e5)); cat[l]: decoder input of level l (upsampled, then skip); da/db: decoder
     * pair outputs; d1a, d1b, out: the last block. */
    tensor inp, e[7], p[6], cat[6], da[6], dbk[6], d1a, d1b, out;
    hd_arena arena;
};

void hd_unet_params(const char *prefix, int cin, int cout, int width, hd_param *params, int *n,
                    size_t *offset)
{
    for (int l = 0; l < HD_UNET_LAYERS; l++) {
        int ci, co, lev;
        layer_shape(l, cin, cout, width, &ci, &co, &lev);
        for (int k = 0; k < 2; k++) {
            if (params) {
                hd_param *q = &params[*n];
                memset(q, 0, sizeof *q);
                snprintf(q->name, sizeof q->name, "%s.%s.%s", prefix, layer_names[l], k ? "bias" : "weight");
                if (k) {
                    q->ndim = 1, q->shape[0] = co, q->count = (size_t)co;
                } else {
                    q->ndim = 4, q->shape[0] = co, q->shape[1] = ci, q->shape[2] = 3, q->shape[3] = 3;
                    q->count = (size_t)co * ci * 9;
                }
                q->offset = *offset;
            }
            *offset += k ? (size_t)co : (size_t)co * ci * 9;
            (*n)++;
        }
    }
}

double hd_unet_macs(int cin, int cout, int width, int H, int W)
{
    double macs = 0.0;
    for (int l = 0; l < HD_UNET_LAYERS; l++) {
        int ci, co, lev;
        layer_shape(l, cin, cout, width, &ci, &co, &lev);
        macs += 9.0 * ci * co * (double)(H >> lev) * (double)(W >> lev);
    }
    return macs;
}

/* Carves x and g of t from the arena (a first pass with a NULL base only counts). */
static void carve(hd_arena *a, size_t *total, tensor *t, int B, int c, int h, int w, int nc16)
{
    int cp = nc16 ? hd_nc16_channels(c) : c;
    size_t n = (size_t)B * cp * h * w;
    n = (n + 15) & ~(size_t)15; /* keep 64-byte alignment */
    t->c = c, t->cp = cp, t->h = h, t->w = w;
    if (a->base) {
        t->x = hd_arena_floats(a, n);
        t->g = hd_arena_floats(a, n);
    }
    *total += 2 * n * sizeof(float);
}

static void carve_all(hd_unet *u, hd_arena *a, size_t *total)
{
    int B = u->B, H = u->H, W = u->W, w = u->width;
    carve(a, total, &u->inp, B, u->cin, H, W, u->nc16);
    for (int l = 0; l <= 6; l++) {
        int lev = l == 0 ? 0 : l - 1; /* enc0, enc1 at level 0, enc l at level l - 1 */
        carve(a, total, &u->e[l], B, w, H >> lev, W >> lev, u->nc16);
    }
    for (int l = 1; l <= 5; l++) carve(a, total, &u->p[l], B, w, H >> l, W >> l, u->nc16);
    for (int l = 1; l <= 5; l++) {
        /* decoder level l works at level l - 1 (cat[5] at H/16, cat[1] at H) */
        int lev = l - 1, up = l == 5 ? w : 2 * w, skip = l == 1 ? u->cin : w;
        carve(a, total, &u->cat[l], B, up + skip, H >> lev, W >> lev, u->nc16);
        if (l >= 2) {
            carve(a, total, &u->da[l], B, 2 * w, H >> lev, W >> lev, u->nc16);
            carve(a, total, &u->dbk[l], B, 2 * w, H >> lev, W >> lev, u->nc16);
        }
    }
    carve(a, total, &u->d1a, B, 64, H, W, u->nc16);
    carve(a, total, &u->d1b, B, 32, H, W, u->nc16);
    carve(a, total, &u->out, B, u->cout, H, W, u->nc16);
    size_t nb = (size_t)B * hd_nc16_channels(w) * (H / 32) * (W / 32);
    if (a->base) {
        u->bneck = hd_arena_floats(a, nb);
        u->bneck_g = hd_arena_floats(a, nb);
    }
    *total += 2 * ((nb + 15) & ~(size_t)15) * sizeof(float);
}

hd_status hd_unet_create(hd_unet **net, int cin, int cout, int width, int B, int H, int W, hd_conv_path path)
{
    *net = NULL;
    if (cin < 1 || cout < 1 || width < 1 || B < 1 || H < 32 || W < 32 || H % 32 || W % 32)
        return hd_fail(HD_ERR_ARG, "unet: bad shape cin=%d cout=%d width=%d B=%d H=%d W=%d (sizes must be multiples of 32)",
                       cin, cout, width, B, H, W);
    hd_unet *u = hd_calloc(1, sizeof *u);
    if (!u) return HD_ERR_NOMEM;
    u->cin = cin, u->cout = cout, u->width = width, u->B = B, u->H = H, u->W = W;
    hd_status st = HD_OK;
#ifdef HD_HAVE_DNNL
    u->nc16 = path == HD_CONV_AUTO && width % HD_NC16_BLOCK == 0;
#endif
    for (int l = 0; l < HD_UNET_LAYERS && st == HD_OK; l++) {
        int ci, co, lev;
        layer_shape(l, cin, cout, width, &ci, &co, &lev);
        hd_act act = l == DEC1C ? HD_ACT_NONE : HD_ACT_LRELU;
        if (u->nc16) {
            /* the padded lanes as real channels: the input's block in enc0, its tail in dec1a */
            u->cpad[l] = hd_nc16_channels(ci);
            st = hd_conv3x3_plan_nc16(&u->conv[l], B, u->cpad[l], H >> lev, W >> lev, co, 1, act, 0.1f);
            if (st != HD_OK) { /* oneDNN refused a layer (no JIT kernel here): every layer plain */
                hd_clear_error();
                for (int k = 0; k < l; k++) {
                    hd_conv3x3_free(u->conv[k]);
                    u->conv[k] = NULL;
                }
                u->nc16 = 0;
                st = HD_OK;
                l = -1; /* start again */
                continue;
            }
            continue;
        }
        st = hd_conv3x3_plan(&u->conv[l], B, ci, H >> lev, W >> lev, co, 1, act, 0.1f, path);
    }
    /* dec1a: a backward-data primitive onto the upsampled part of cat[1] only, for the backwards
     * that want no input gradient (the input's channels are a quarter of dec1a's at cin 32) */
    if (st == HD_OK && u->nc16 && hd_conv3x3_plan_dinp_head(u->conv[DEC1A], 2 * width) != HD_OK) hd_clear_error();
    for (int l = 0; l < HD_UNET_LAYERS && st == HD_OK && u->nc16; l++) {
        int ci, co, lev;
        layer_shape(l, cin, cout, width, &ci, &co, &lev);
        if (u->cpad[l] == ci) continue;
        size_t n = (size_t)co * u->cpad[l] * 9;
        u->wpad[l] = hd_calloc(n, sizeof(float));
        u->dwpad[l] = hd_calloc(n, sizeof(float));
        if (!u->wpad[l] || !u->dwpad[l]) st = HD_ERR_NOMEM;
    }
    size_t total = 0;
    hd_arena none = {0};
    if (st == HD_OK) carve_all(u, &none, &total);
    if (st == HD_OK) st = hd_arena_init(&u->arena, total + 64);
    if (st == HD_OK) {
        total = 0;
        carve_all(u, &u->arena, &total);
    }
    if (st != HD_OK) {
        hd_unet_free(u);
        return st;
    }
    *net = u;
    return HD_OK;
}

void hd_unet_free(hd_unet *u)
{
    if (!u) return;
    for (int l = 0; l < HD_UNET_LAYERS; l++) hd_conv3x3_free(u->conv[l]);
    for (int l = 0; l < HD_UNET_LAYERS; l++) {
        free(u->wpad[l]);
        free(u->dwpad[l]);
    }
    hd_arena_free(&u->arena);
    free(u);
}

void hd_unet_bind(hd_unet *u, const float *params, float *grads)
{
    size_t off = 0;
    for (int l = 0; l < HD_UNET_LAYERS; l++) {
        int ci, co, lev;
        layer_shape(l, u->cin, u->cout, u->width, &ci, &co, &lev);
        size_t nw = (size_t)co * ci * 9;
        u->wt[l] = params + off;
        u->bias[l] = params + off + nw;
        u->dwt[l] = grads ? grads + off : NULL;
        u->dbias[l] = grads ? grads + off + nw : NULL;
        off += nw + co;
    }
}

size_t hd_unet_memory(const hd_unet *u) { return u->arena.size; }

void hd_unet_profile(hd_unet *u, double *seconds) { u->prof = seconds; }

const float *hd_unet_bottleneck(const hd_unet *u) { return u->nc16 ? u->bneck : u->e[6].x; }

static size_t numel(const tensor *t) { return (size_t)t->cp * t->h * t->w; } /* per image */

/* cat (per image: [up(src), skip]) = upsample2(src) then skip, image by image. */
static void up_concat(const hd_unet *u, tensor *cat, const tensor *src, const tensor *skip, int B)
{
    size_t nc = numel(cat), ns = numel(src), nk = numel(skip), nu = nc - nk;
    for (int n = 0; n < B; n++) {
        if (u->nc16) hd_upsample2_nc16_forward(cat->x + n * nc, src->x + n * ns, 1, src->c, src->h, src->w);
        else hd_upsample2_forward(cat->x + n * nc, src->x + n * ns, 1, src->c, src->h, src->w);
        memcpy(cat->x + n * nc + nu, skip->x + n * nk, nk * sizeof(float));
    }
}

/* Backward of up_concat: src->g += upsample2^T(dcat[:up]), skip->g += dcat[up:] (skip->g may be
 * NULL when the skip is the net's input and no input gradient is wanted). */
static void up_concat_backward(const hd_unet *u, const tensor *cat, tensor *src, float *skip_g, size_t nk, int B)
{
    size_t nc = numel(cat), ns = numel(src), nu = nc - nk;
    for (int n = 0; n < B; n++) {
        if (u->nc16) hd_upsample2_nc16_backward(src->g + n * ns, cat->g + n * nc, 1, src->c, src->h, src->w);
        else hd_upsample2_backward(src->g + n * ns, cat->g + n * nc, 1, src->c, src->h, src->w);
        if (skip_g) {
            const float *g = cat->g + n * nc + nu;
            float *d = skip_g + n * nk;
            for (size_t i = 0; i < nk; i++) d[i] += g[i];
        }
    }
}

/* The weights layer l's plan reads. A padded layer: wpad(o, c, k) = w(o, c, k) for c < ci, copied
 * here (forward), the lanes past ci staying 0 from creation; backward reads the forward's copy. */
static const float *weights_of(hd_unet *u, int l, int refresh)
{
    if (!u->wpad[l]) return u->wt[l];
    int ci, co, lev, cp = u->cpad[l];
    layer_shape(l, u->cin, u->cout, u->width, &ci, &co, &lev);
    if (refresh)
        for (int o = 0; o < co; o++)
            memcpy(u->wpad[l] + (size_t)o * cp * 9, u->wt[l] + (size_t)o * ci * 9, (size_t)ci * 9 * sizeof(float));
    return u->wpad[l];
}

/* Where layer l's weight gradient goes: the bound gradient, or (padded layer) the zeroed scratch
 * that dweights_fold then adds into it, dropping the padded lanes' gradient (those input lanes
 * are 0; the input gradient there, 0 too, is never read). */
static float *dweights_of(hd_unet *u, int l)
{
    if (!u->wpad[l] || !u->dwt[l]) return u->dwt[l];
    int ci, co, lev;
    layer_shape(l, u->cin, u->cout, u->width, &ci, &co, &lev);
    memset(u->dwpad[l], 0, (size_t)co * u->cpad[l] * 9 * sizeof(float));
    return u->dwpad[l];
}

static void dweights_fold(hd_unet *u, int l)
{
    if (!u->wpad[l] || !u->dwt[l]) return;
    int ci, co, lev, cp = u->cpad[l];
    layer_shape(l, u->cin, u->cout, u->width, &ci, &co, &lev);
    for (int o = 0; o < co; o++)
        for (int k = 0; k < ci * 9; k++) u->dwt[l][(size_t)o * ci * 9 + k] += u->dwpad[l][(size_t)o * cp * 9 + k];
}

static void conv_fwd(hd_unet *u, int l, tensor *out, const tensor *in)
{
    double t0 = u->prof ? hd_seconds() : 0.0;
    hd_conv3x3_forward(u->conv[l], out->x, in->x, weights_of(u, l, 1), u->bias[l]);
    if (u->prof) u->prof[l] += hd_seconds() - t0;
}

static void zero_grad(tensor *t, int B) { memset(t->g, 0, (size_t)B * numel(t) * sizeof(float)); }

enum { BWD_ADD, BWD_FRESH, BWD_HEAD };

/* Backward of conv l: out->g (the gradient at its output, turned in place into the gradient
 * before the activation) flows into in_g (added to, overwritten, or only its first channels
 * overwritten: hd_conv3x3_backward_head_into; NULL: no input gradient) and the bound gradients. */
static void conv_bwd_to(hd_unet *u, int l, tensor *out, const tensor *in, float *in_g, int mode)
{
    double t0 = u->prof ? hd_seconds() : 0.0;
    float *dw = dweights_of(u, l);
    const float *w = weights_of(u, l, 0);
    if (mode == BWD_HEAD)
        hd_conv3x3_backward_head_into(u->conv[l], in_g, dw, u->dbias[l], out->g, out->x, in->x, w);
    else if (mode == BWD_FRESH)
        hd_conv3x3_backward_into(u->conv[l], in_g, dw, u->dbias[l], out->g, out->x, in->x, w);
    else
        hd_conv3x3_backward(u->conv[l], in_g, dw, u->dbias[l], out->g, out->x, in->x, w);
    dweights_fold(u, l);
    if (u->prof) u->prof[HD_UNET_LAYERS + l] += hd_seconds() - t0;
}

/* in->g overwritten when `fresh`, else added to */
static void conv_bwd(hd_unet *u, int l, tensor *out, tensor *in, int fresh)
{
    conv_bwd_to(u, l, out, in, in->g, fresh ? BWD_FRESH : BWD_ADD);
}

static void maxpool_fwd(const hd_unet *u, tensor *out, const tensor *in)
{
    if (u->nc16) hd_maxpool2_nc16_forward(out->x, in->x, u->B, in->c, in->h, in->w);
    else hd_maxpool2_forward(out->x, in->x, u->B, in->c, in->h, in->w);
}

/* in->g is overwritten: an encoder output feeds only its pooling */
static void maxpool_bwd(const hd_unet *u, tensor *out, tensor *in)
{
    if (u->nc16) {
        hd_maxpool2_nc16_backward_into(in->g, out->g, in->x, u->B, in->c, in->h, in->w);
        return;
    }
    zero_grad(in, u->B);
    hd_maxpool2_backward(in->g, out->g, in->x, u->B, in->c, in->h, in->w);
}

void hd_unet_forward(hd_unet *u, const float *inp, float *out)
{
    int B = u->B;
    int HW = u->H * u->W;
    if (u->nc16) hd_nc16_from_plain(u->inp.x, inp, B, u->cin, HW);
    else memcpy(u->inp.x, inp, (size_t)B * numel(&u->inp) * sizeof(float));
    conv_fwd(u, ENC0, &u->e[0], &u->inp);
    conv_fwd(u, ENC1, &u->e[1], &u->e[0]);
    maxpool_fwd(u, &u->p[1], &u->e[1]);
    for (int l = 2; l <= 6; l++) {
        conv_fwd(u, ENC0 + l, &u->e[l], &u->p[l - 1]);
        if (l <= 5) maxpool_fwd(u, &u->p[l], &u->e[l]);
    }
    if (u->nc16) hd_nc16_to_plain(u->bneck, u->e[6].x, B, u->width, u->e[6].h * u->e[6].w, 0);
    /* decoder level 5 (size H/16): up(e6) ++ p4; levels 4..2: up(dbk[l+1]) ++ p[l-1] */
    up_concat(u, &u->cat[5], &u->e[6], &u->p[4], B);
    conv_fwd(u, DEC5A, &u->da[5], &u->cat[5]);
    conv_fwd(u, DEC5B, &u->dbk[5], &u->da[5]);
    for (int l = 4; l >= 2; l--) {
        int la = DEC5A + 2 * (5 - l);
        up_concat(u, &u->cat[l], &u->dbk[l + 1], &u->p[l - 1], B);
        conv_fwd(u, la, &u->da[l], &u->cat[l]);
        conv_fwd(u, la + 1, &u->dbk[l], &u->da[l]);
    }
    up_concat(u, &u->cat[1], &u->dbk[2], &u->inp, B);
    conv_fwd(u, DEC1A, &u->d1a, &u->cat[1]);
    conv_fwd(u, DEC1B, &u->d1b, &u->d1a);
    conv_fwd(u, DEC1C, &u->out, &u->d1b);
    if (u->nc16) hd_nc16_to_plain(out, u->out.x, B, u->cout, HW, 0);
    else memcpy(out, u->out.x, (size_t)B * numel(&u->out) * sizeof(float));
}

void hd_unet_backward(hd_unet *u, const float *dout, const float *dbottleneck, float *dinp)
{
    int B = u->B, HW = u->H * u->W;
    if (u->nc16) hd_nc16_from_plain(u->out.g, dout, B, u->cout, HW);
    else memcpy(u->out.g, dout, (size_t)B * numel(&u->out) * sizeof(float));
    /* nc16: the input's gradient is gathered in inp.g and converted at the end */
    float *dinp_net = dinp && u->nc16 ? u->inp.g : dinp;
    if (dinp && u->nc16) zero_grad(&u->inp, B);
    conv_bwd(u, DEC1C, &u->out, &u->d1b, 1);
    conv_bwd(u, DEC1B, &u->d1b, &u->d1a, 1);
    /* without an input gradient, the input's channels of cat[1] need none either */
    conv_bwd_to(u, DEC1A, &u->d1a, &u->cat[1], u->cat[1].g, !dinp_net && u->nc16 ? BWD_HEAD : BWD_FRESH);
    zero_grad(&u->dbk[2], B);
    up_concat_backward(u, &u->cat[1], &u->dbk[2], dinp_net, numel(&u->inp), B);
    for (int l = 2; l <= 4; l++) {
        int la = DEC5A + 2 * (5 - l);
        conv_bwd(u, la + 1, &u->dbk[l], &u->da[l], 1);
        conv_bwd(u, la, &u->da[l], &u->cat[l], 1);
        zero_grad(&u->dbk[l + 1], B);
        zero_grad(&u->p[l - 1], B);
        up_concat_backward(u, &u->cat[l], &u->dbk[l + 1], u->p[l - 1].g, numel(&u->p[l - 1]), B);
    }
    conv_bwd(u, DEC5B, &u->dbk[5], &u->da[5], 1);
    conv_bwd(u, DEC5A, &u->da[5], &u->cat[5], 1);
    zero_grad(&u->e[6], B);
    zero_grad(&u->p[4], B);
    up_concat_backward(u, &u->cat[5], &u->e[6], u->p[4].g, numel(&u->p[4]), B);
    if (dbottleneck) {
        size_t n = (size_t)B * numel(&u->e[6]);
        const float *g = dbottleneck;
        if (u->nc16) {
            hd_nc16_from_plain(u->bneck_g, dbottleneck, B, u->width, u->e[6].h * u->e[6].w);
            g = u->bneck_g;
        }
        for (size_t i = 0; i < n; i++) u->e[6].g[i] += g[i];
    }
    /* encoder: enc l reads p[l-1] (which already holds its skip gradient, except p[5]) */
    conv_bwd(u, ENC6, &u->e[6], &u->p[5], 1);
    for (int l = 5; l >= 2; l--) {
        maxpool_bwd(u, &u->p[l], &u->e[l]);
        conv_bwd(u, ENC0 + l, &u->e[l], &u->p[l - 1], 0);
    }
    maxpool_bwd(u, &u->p[1], &u->e[1]);
    conv_bwd(u, ENC1, &u->e[1], &u->e[0], 1);
    conv_bwd_to(u, ENC0, &u->e[0], &u->inp, dinp_net, BWD_ADD);
    if (dinp && u->nc16) hd_nc16_to_plain(dinp, u->inp.g, B, u->cin, HW, 1);
}
