/* conv3x3_dnnl.c: the oneDNN path of the 3x3 convolution. Per plan, once: forward (bias and the
 * leaky ReLU fused as an eltwise post-op), backward-data and backward-weights primitives with the
 * memory formats oneDNN picks ("any": its blocked channel layouts), the reorders between those
 * and our NCHW / OIHW buffers, plan-owned buffers in the blocked formats, and one user-managed
 * scratchpad. Nothing is allocated in forward or backward.
 *
 * Algorithm: in the blocked layout (nc16 plans), stride 1, channels in whole blocks of 16 and at
 * least WINO_MIN pixels a side, the three primitives use oneDNN's Winograd F(4x4, 3x3) kernels
 * (jit_wino_4x3): on this machine's AVX-512 they run the Common-Net's layers 1.5-2x faster than
 * the direct ones forward and 1.2-2.3x backward (one thread, docs/performance.md), and the naive
 * loops hold them to the same 1e-5 relative difference as the direct ones (tests/test_conv.c). The Winograd forward takes no leaky ReLU
 * post-op, so that plan applies the activation in a pass of its own. Smaller layers, other
 * shapes, a CPU without the kernels, or HD_CONV_DIRECT=1 in the environment (for comparisons)
 * take the direct kernels. The choice depends on the shape only: runs stay bit-reproducible.
 *
 * Accumulation: oneDNN's backward primitives overwrite, so they write into plan-owned buffers
 * which are then reordered into the caller's dinp / dw with a sum post-op (dst = dst + src); the
 * bias gradient (OC floats) is added by hand.
 *
 * Threads: the engine is one per process (made once, under pthread_once); each plan has its own
 * stream, primitives and buffers, so plans (one per network run state) run in different threads
 * at once. */
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include "nn/conv3x3_impl.h"

#ifdef HD_HAVE_DNNL
#include <dnnl.h>

/* Winograd below this many pixels a side loses to the direct kernels (16 x 16: 0.09 against
 * 0.06 ms for 48 -> 48, one thread). */
#define WINO_MIN 32

/* A tensor seen two ways: the caller's plain buffer (user) and the primitive's format (prim,
 * with a plan-owned buffer when the formats differ), and the reorder between them. */
typedef struct view {
    dnnl_memory_t user, prim; /* prim == user when the formats agree */
    dnnl_primitive_t reorder; /* user -> prim (inputs) or prim -> user (outputs), or NULL */
} view;

typedef struct dn {
    dnnl_primitive_t fwd, bwd_data, bwd_weights;
    view src, w, dst;                 /* forward */
    view bd_ddst, bd_w, bd_dsrc;      /* backward data: dsrc reorders with a sum into dinp */
    view bw_src, bw_ddst, bw_dw;      /* backward weights: dw reorders with a sum into dw */
    dnnl_memory_t bias, dbias, scratch;
    dnnl_memory_t dsrc_tmp; /* nc16: backward data's output before it is added into dinp */
    float *zero_bias, *dbias_buf;
    const float *last_src; /* the input of the last forward, held by src.prim */
    int share_src;         /* backward weights reads src in the forward's (reordered) format */
    int share_ddst;        /* backward weights reads diff_dst in backward data's (reordered) format */
    int act_pass;          /* the forward has no post-op: the leaky ReLU is a pass of our own */
    int fwd_wino;          /* the forward took the Winograd kernels */
    int bf16;              /* inputs and weights in bf16 (FP32 outputs and accumulation) */
    dnnl_alg_kind_t bd_alg; /* the algorithm backward data took */
    /* backward data onto the first c_head input channels only (hd_conv3x3_plan_dinp_head), one
     * image per call: weights w(:, :c_head) seen through a strided view */
    dnnl_primitive_t bwd_head;
    view bh_w;
    dnnl_memory_t bh_ddst, bh_dsrc;
    int c_head;
    dnnl_stream_t stream; /* this plan's own */
} dn;

static dnnl_engine_t engine;
static pthread_once_t engine_once = PTHREAD_ONCE_INIT;

static void engine_make(void)
{
    if (dnnl_engine_create(&engine, dnnl_cpu, 0) != dnnl_success) engine = NULL;
}

#define DN(call)                                                                   \
    do {                                                                           \
        dnnl_status_t s_ = (call);                                                 \
        if (s_ != dnnl_success) {                                                  \
            hd_fail(HD_ERR_ARG, "conv3x3: oneDNN: %s failed (status %d)", #call, (int)s_); \
            goto fail;                                                             \
        }                                                                          \
    } while (0)

/* oneDNN's reference kernels (impl "ref:...") are what it runs where it has no JIT kernel for a
 * layout on this CPU (nChw16c on a CPU without AVX-512, for one): correct, but a hundred times
 * slower than the portable path. A plan that would get one fails, so that the caller takes the
 * plain layout or the portable path instead. HD_DNNL_REFERENCE=1 in the environment lets them
 * through (the tests of the nc16 plans' numerics, on such a CPU). */
static int reference_allowed(void)
{
    const char *e = getenv("HD_DNNL_REFERENCE");
    return e && strcmp(e, "1") == 0;
}

#define NOT_REFERENCE(pd, what)                                                                      \
    do {                                                                                             \
        const char *impl_ = NULL;                                                                    \
        if (!reference_allowed() &&                                                                  \
            dnnl_primitive_desc_query(pd, dnnl_query_impl_info_str, 0, &impl_) == dnnl_success && impl_ && \
            strncmp(impl_, "ref", 3) == 0) {                                                         \
            hd_fail(HD_ERR_ARG, "conv3x3: oneDNN has only its reference kernel (%s) for this %s on this CPU", impl_, what); \
            goto fail;                                                                               \
        }                                                                                            \
    } while (0)

static hd_status dn_init(void)
{
    pthread_once(&engine_once, engine_make);
    return engine ? HD_OK : hd_fail(HD_ERR_ARG, "conv3x3: oneDNN: no CPU engine");
}

/* oneDNN runs bf16 convolutions with JIT kernels from avx512_core_bf16 (the ISA values nest:
 * each includes the bits of those it extends). */
static int bf16_isa(void)
{
    unsigned isa = (unsigned)dnnl_get_effective_cpu_isa(), need = (unsigned)dnnl_cpu_isa_avx512_core_bf16;
    return (isa & need) == need;
}

static dnnl_status_t attr_user_scratch(dnnl_primitive_attr_t *attr)
{
    dnnl_status_t s = dnnl_primitive_attr_create(attr);
    if (s == dnnl_success) s = dnnl_primitive_attr_set_scratchpad_mode(*attr, dnnl_scratchpad_mode_user);
    return s;
}

static size_t scratch_size(const_dnnl_primitive_desc_t pd)
{
    const dnnl_memory_desc_t *md = dnnl_primitive_desc_query_md(pd, dnnl_query_scratchpad_md, 0);
    return md ? dnnl_memory_desc_get_size(md) : 0;
}

/* Builds view v for a user format `user_md` and the primitive's `prim_md`. to_prim: the reorder
 * goes user -> prim (an input); otherwise prim -> user, with a sum when `accumulate`. Grows
 * *scratch to the reorder's scratchpad. */
static dnnl_status_t make_view(view *v, const dnnl_memory_desc_t *user_md, const dnnl_memory_desc_t *prim_md,
                               int to_prim, int accumulate, size_t *scratch)
{
    dnnl_status_t s = dnnl_memory_create(&v->user, user_md, engine, DNNL_MEMORY_NONE);
    if (s != dnnl_success) return s;
    if (dnnl_memory_desc_equal(user_md, prim_md) && !accumulate) {
        v->prim = v->user;
        return dnnl_success;
    }
    s = dnnl_memory_create(&v->prim, prim_md, engine, DNNL_MEMORY_ALLOCATE);
    if (s != dnnl_success) return s;
    dnnl_primitive_attr_t attr = NULL;
    dnnl_post_ops_t po = NULL;
    dnnl_primitive_desc_t pd = NULL;
    s = attr_user_scratch(&attr);
    if (s == dnnl_success && accumulate) {
        s = dnnl_post_ops_create(&po);
        if (s == dnnl_success) s = dnnl_post_ops_append_sum(po, 1.0f);
        if (s == dnnl_success) s = dnnl_primitive_attr_set_post_ops(attr, po);
    }
    if (s == dnnl_success)
        s = to_prim ? dnnl_reorder_primitive_desc_create(&pd, user_md, engine, prim_md, engine, attr)
                    : dnnl_reorder_primitive_desc_create(&pd, prim_md, engine, user_md, engine, attr);
    if (s == dnnl_success) {
        size_t n = scratch_size(pd);
        if (n > *scratch) *scratch = n;
        s = dnnl_primitive_create(&v->reorder, pd);
    }
    if (pd) dnnl_primitive_desc_destroy(pd);
    if (po) dnnl_post_ops_destroy(po);
    if (attr) dnnl_primitive_attr_destroy(attr);
    return s;
}

static void free_view(view *v)
{
    if (v->reorder) dnnl_primitive_destroy(v->reorder);
    if (v->prim && v->prim != v->user) dnnl_memory_destroy(v->prim);
    if (v->user) dnnl_memory_destroy(v->user);
    memset(v, 0, sizeof *v);
}

static const dnnl_memory_desc_t *qmd(const_dnnl_primitive_desc_t pd, dnnl_query_t what)
{
    return dnnl_primitive_desc_query_md(pd, what, 0);
}

/* The memory descriptors and geometry of a plan's primitives: inputs (src, weights, diff_dst: *_lp)
 * in lp, outputs (dst, diff_src: *_any; diff_weights: dw_any) and the bias in f32 (in FP32 both
 * are the same); *_user the caller's layouts. */
typedef struct conv_descs {
    dnnl_memory_desc_t s_any, d_any, s_lp, w_lp, d_lp, dw_any, b_md, s_user, w_user, d_user;
    dnnl_dims_t strides, pad_l, pad_r;
} conv_descs;

static hd_status conv_descs_init(const hd_conv3x3 *p, dnnl_data_type_t lp, conv_descs *m)
{
    dnnl_dims_t sdims = {p->B, p->C, p->H, p->W}, wdims = {p->OC, p->C, 3, 3}, bdims = {p->OC},
                ddims = {p->B, p->OC, p->Ho, p->Wo};
    m->strides[0] = m->strides[1] = p->stride;
    m->pad_l[0] = m->pad_l[1] = 1;
    /* right padding so that Ho = (H + 1 + pad_r - 3) / stride + 1 exactly */
    m->pad_r[0] = (p->Ho - 1) * p->stride + 3 - p->H - 1;
    m->pad_r[1] = (p->Wo - 1) * p->stride + 3 - p->W - 1;
    dnnl_format_tag_t act_tag = p->nc16 ? dnnl_nChw16c : dnnl_nchw;
    dnnl_format_tag_t act_any = p->nc16 ? dnnl_nChw16c : dnnl_format_tag_any; /* nc16: no reorders of layout */
    DN(dnnl_memory_desc_init_by_tag(&m->s_any, 4, sdims, dnnl_f32, act_any));
    DN(dnnl_memory_desc_init_by_tag(&m->d_any, 4, ddims, dnnl_f32, act_any));
    DN(dnnl_memory_desc_init_by_tag(&m->s_lp, 4, sdims, lp, act_any));
    DN(dnnl_memory_desc_init_by_tag(&m->d_lp, 4, ddims, lp, act_any));
    DN(dnnl_memory_desc_init_by_tag(&m->w_lp, 4, wdims, lp, dnnl_format_tag_any));
    DN(dnnl_memory_desc_init_by_tag(&m->dw_any, 4, wdims, dnnl_f32, dnnl_format_tag_any));
    DN(dnnl_memory_desc_init_by_tag(&m->b_md, 1, bdims, dnnl_f32, dnnl_x));
    DN(dnnl_memory_desc_init_by_tag(&m->s_user, 4, sdims, dnnl_f32, act_tag));
    DN(dnnl_memory_desc_init_by_tag(&m->w_user, 4, wdims, dnnl_f32, dnnl_oihw));
    DN(dnnl_memory_desc_init_by_tag(&m->d_user, 4, ddims, dnnl_f32, act_tag));
    return HD_OK;
fail:
    return HD_ERR_ARG;
}

/* Whether a plan's shape takes Winograd (FP32, stride 1, channels in blocks of 16, at least
 * WINO_MIN a side), unless HD_CONV_DIRECT is set to anything but 0. */
static int winograd_shape(const hd_conv3x3 *p)
{
    const char *direct_env = getenv("HD_CONV_DIRECT");
    return p->nc16 && p->stride == 1 && p->C % 16 == 0 && p->OC % 16 == 0 && p->H >= WINO_MIN && p->W >= WINO_MIN &&
           !(direct_env && *direct_env && strcmp(direct_env, "0"));
}

/* Backward weights in bf16 lost to FP32 (Winograd or direct) on this machine's Zen 5 (1.7x slower
 * per step, docs/performance.md) where forward and backward data gained (2x, 1.25x): a bf16 plan
 * computes its weight gradients in FP32 unless HD_BF16_WEIGHT_GRAD=1. */
static int weight_grad_f32(dnnl_data_type_t lp)
{
    const char *wg_env = getenv("HD_BF16_WEIGHT_GRAD");
    return lp != dnnl_f32 && !(wg_env && strcmp(wg_env, "1") == 0);
}

/* The FP32 forward that backward weights in FP32 takes as its hint: Winograd when wino and oneDNN
 * has it (*used_wino 1), else direct. */
static hd_status fp32_hint(const conv_descs *m, dnnl_primitive_attr_t attr, int wino, dnnl_primitive_desc_t *hint,
                           int *used_wino)
{
    dnnl_convolution_desc_t hdesc;
    dnnl_alg_kind_t halg = wino ? dnnl_convolution_winograd : dnnl_convolution_direct;
    *used_wino = wino;
    if (dnnl_convolution_forward_desc_init(&hdesc, dnnl_forward_training, halg, &m->s_any, &m->dw_any, &m->b_md,
                                           &m->d_any, m->strides, m->pad_l, m->pad_r) == dnnl_success &&
        dnnl_primitive_desc_create(hint, &hdesc, attr, engine, NULL) == dnnl_success)
        return HD_OK;
    *hint = NULL, *used_wino = 0;
    DN(dnnl_convolution_forward_desc_init(&hdesc, dnnl_forward_training, dnnl_convolution_direct, &m->s_any,
                                          &m->dw_any, &m->b_md, &m->d_any, m->strides, m->pad_l, m->pad_r));
    DN(dnnl_primitive_desc_create(hint, &hdesc, attr, engine, NULL));
    return HD_OK;
fail:
    return HD_ERR_ARG;
}

/* A plan's bias buffers (zero_bias, dbias and their memories) and its scratchpad of `scratch`
 * bytes. */
static hd_status plan_buffers(hd_conv3x3 *p, const dnnl_memory_desc_t *b_md, size_t scratch)
{
    dn *d = p->dnnl;
    d->zero_bias = hd_calloc((size_t)p->OC, sizeof(float));
    d->dbias_buf = hd_calloc((size_t)p->OC, sizeof(float));
    if (!d->zero_bias || !d->dbias_buf) return HD_ERR_NOMEM;
    DN(dnnl_memory_create(&d->bias, b_md, engine, DNNL_MEMORY_NONE));
    DN(dnnl_memory_create(&d->dbias, b_md, engine, d->dbias_buf));
    dnnl_memory_desc_t sp_md;
    dnnl_dims_t spdims = {(dnnl_dim_t)(scratch ? scratch : 1)};
    DN(dnnl_memory_desc_init_by_tag(&sp_md, 1, spdims, dnnl_u8, dnnl_x));
    DN(dnnl_memory_create(&d->scratch, &sp_md, engine, DNNL_MEMORY_ALLOCATE));
    return HD_OK;
fail:
    return HD_ERR_ARG;
}

/* Builds the plan with the primitives' inputs (src, weights, diff_dst) in data type lp (f32, or
 * bf16: oneDNN's bf16 kernels, which take FP32 for every output and accumulate in FP32). */
static hd_status plan_typed(hd_conv3x3 *p, dnnl_data_type_t lp)
{
    dn *d = hd_calloc(1, sizeof *d);
    if (!d) return HD_ERR_NOMEM;
    p->dnnl = d;
    d->bf16 = lp == dnnl_bf16;
    if (dnnl_stream_create(&d->stream, engine, dnnl_stream_default_flags) != dnnl_success) {
        d->stream = NULL;
        hd_conv3x3_dnnl_free(p);
        return hd_fail(HD_ERR_ARG, "conv3x3: oneDNN: no stream");
    }
    dnnl_primitive_desc_t fpd = NULL, dpd = NULL, wpd = NULL;
    dnnl_primitive_desc_t hint32 = NULL; /* the FP32 forward backward weights then takes as its hint */
    dnnl_primitive_attr_t fattr = NULL, dattr = NULL, wattr = NULL;
    dnnl_post_ops_t po = NULL;
    size_t scratch = 0;
    hd_status st;

    conv_descs m;
    if (conv_descs_init(p, lp, &m) != HD_OK) goto fail;
    dnnl_memory_desc_t *s_any = &m.s_any, *d_any = &m.d_any, *s_lp = &m.s_lp, *w_lp = &m.w_lp, *d_lp = &m.d_lp,
                       *dw_any = &m.dw_any, *b_md = &m.b_md, *s_user = &m.s_user, *w_user = &m.w_user,
                       *d_user = &m.d_user;
    dnnl_dim_t *strides = m.strides, *pad_l = m.pad_l, *pad_r = m.pad_r;

    const int wino_shape = winograd_shape(p), wino = lp == dnnl_f32 && wino_shape;
    const int bw_f32 = weight_grad_f32(lp);

    /* forward: dst = act(conv(src, w) + b); Winograd without the post-op, else direct with it */
    dnnl_convolution_desc_t fdesc, ddesc, wdesc;
    DN(attr_user_scratch(&fattr));
    if (wino && dnnl_convolution_forward_desc_init(&fdesc, dnnl_forward_training, dnnl_convolution_winograd, s_lp,
                                                   w_lp, b_md, d_any, strides, pad_l, pad_r) == dnnl_success &&
        dnnl_primitive_desc_create(&fpd, &fdesc, fattr, engine, NULL) == dnnl_success) {
        d->act_pass = p->act == HD_ACT_LRELU;
        d->fwd_wino = 1;
    } else {
        fpd = NULL;
        DN(dnnl_convolution_forward_desc_init(&fdesc, dnnl_forward_training, dnnl_convolution_direct, s_lp,
                                              w_lp, b_md, d_any, strides, pad_l, pad_r));
        if (p->act == HD_ACT_LRELU) {
            DN(dnnl_post_ops_create(&po));
            DN(dnnl_post_ops_append_eltwise(po, 1.0f, dnnl_eltwise_relu, p->slope, 0.0f)); /* x > 0 ? x : alpha x */
            DN(dnnl_primitive_attr_set_post_ops(fattr, po));
        }
        DN(dnnl_primitive_desc_create(&fpd, &fdesc, fattr, engine, NULL));
    }
    NOT_REFERENCE(fpd, "forward");
    DN(dnnl_primitive_create(&d->fwd, fpd));
    if (scratch_size(fpd) > scratch) scratch = scratch_size(fpd);
    DN(make_view(&d->src, s_user, qmd(fpd, dnnl_query_src_md), 1, 0, &scratch));
    DN(make_view(&d->w, w_user, qmd(fpd, dnnl_query_weights_md), 1, 0, &scratch));
    DN(make_view(&d->dst, d_user, qmd(fpd, dnnl_query_dst_md), 0, 0, &scratch));

    /* backward data: dsrc = conv^T(ddst, w) */
    DN(attr_user_scratch(&dattr));
    if (!wino || dnnl_convolution_backward_data_desc_init(&ddesc, dnnl_convolution_winograd, s_any, w_lp, d_lp,
                                                          strides, pad_l, pad_r) != dnnl_success ||
        dnnl_primitive_desc_create(&dpd, &ddesc, dattr, engine, fpd) != dnnl_success) {
        dpd = NULL;
        DN(dnnl_convolution_backward_data_desc_init(&ddesc, dnnl_convolution_direct, s_any, w_lp, d_lp,
                                                    strides, pad_l, pad_r));
        DN(dnnl_primitive_desc_create(&dpd, &ddesc, dattr, engine, fpd));
        d->bd_alg = dnnl_convolution_direct;
    } else {
        d->bd_alg = dnnl_convolution_winograd;
    }
    NOT_REFERENCE(dpd, "backward data");
    DN(dnnl_primitive_create(&d->bwd_data, dpd));
    if (scratch_size(dpd) > scratch) scratch = scratch_size(dpd);
    DN(make_view(&d->bd_ddst, d_user, qmd(dpd, dnnl_query_diff_dst_md), 1, 0, &scratch));
    DN(make_view(&d->bd_w, w_user, qmd(dpd, dnnl_query_weights_md), 1, 0, &scratch));
    DN(make_view(&d->bd_dsrc, s_user, qmd(dpd, dnnl_query_diff_src_md), 0, !p->nc16, &scratch));
    if (p->nc16) DN(dnnl_memory_create(&d->dsrc_tmp, s_user, engine, DNNL_MEMORY_ALLOCATE));

    /* backward weights: dw = ddst x src, db = sum ddst */
    DN(attr_user_scratch(&wattr));
    const dnnl_memory_desc_t *ws = s_lp, *wd = d_lp;
    const_dnnl_primitive_desc_t whint = fpd;
    int wwino = wino;
    if (bw_f32) {
        ws = s_any, wd = d_any;
        if (fp32_hint(&m, wattr, wino_shape, &hint32, &wwino) != HD_OK) goto fail;
        whint = hint32;
    }
    if (!wwino || dnnl_convolution_backward_weights_desc_init(&wdesc, dnnl_convolution_winograd, ws, dw_any, b_md,
                                                              wd, strides, pad_l, pad_r) != dnnl_success ||
        dnnl_primitive_desc_create(&wpd, &wdesc, wattr, engine, whint) != dnnl_success) {
        wpd = NULL;
        DN(dnnl_convolution_backward_weights_desc_init(&wdesc, dnnl_convolution_direct, ws, dw_any, b_md, wd, strides,
                                                       pad_l, pad_r));
        DN(dnnl_primitive_desc_create(&wpd, &wdesc, wattr, engine, whint));
    }
    NOT_REFERENCE(wpd, "backward weights");
    DN(dnnl_primitive_create(&d->bwd_weights, wpd));
    if (scratch_size(wpd) > scratch) scratch = scratch_size(wpd);
    DN(make_view(&d->bw_src, s_user, qmd(wpd, dnnl_query_src_md), 1, 0, &scratch));
    DN(make_view(&d->bw_ddst, d_user, qmd(wpd, dnnl_query_diff_dst_md), 1, 0, &scratch));
    DN(make_view(&d->bw_dw, w_user, qmd(wpd, dnnl_query_diff_weights_md), 0, 1, &scratch));
    d->share_src = d->src.reorder && dnnl_memory_desc_equal(qmd(fpd, dnnl_query_src_md), qmd(wpd, dnnl_query_src_md));
    d->share_ddst = d->bd_ddst.reorder &&
                    dnnl_memory_desc_equal(qmd(dpd, dnnl_query_diff_dst_md), qmd(wpd, dnnl_query_diff_dst_md));

    if (plan_buffers(p, b_md, scratch) != HD_OK) goto fail;

    st = HD_OK;
    goto done;
fail:
    st = HD_ERR_ARG;
done:
    if (fpd) dnnl_primitive_desc_destroy(fpd);
    if (dpd) dnnl_primitive_desc_destroy(dpd);
    if (wpd) dnnl_primitive_desc_destroy(wpd);
    if (hint32) dnnl_primitive_desc_destroy(hint32);
    if (fattr) dnnl_primitive_attr_destroy(fattr);
    if (dattr) dnnl_primitive_attr_destroy(dattr);
    if (wattr) dnnl_primitive_attr_destroy(wattr);
    if (po) dnnl_post_ops_destroy(po);
    if (st != HD_OK) hd_conv3x3_dnnl_free(p);
    return st;
}

hd_status hd_conv3x3_dnnl_plan(hd_conv3x3 *p)
{
    hd_status st = dn_init();
    if (st != HD_OK) return st;
    if (p->bf16) {
        /* bf16 where oneDNN has JIT kernels for it (avx512_core_bf16 and up), else FP32 */
        if (bf16_isa() && plan_typed(p, dnnl_bf16) == HD_OK) return HD_OK;
        hd_clear_error();
        p->bf16 = 0;
    }
    return plan_typed(p, dnnl_f32);
}

int hd_conv3x3_dnnl_bf16_available(void) { return dn_init() == HD_OK && bf16_isa(); }

const char *hd_conv3x3_dnnl_isa(void)
{
    if (dn_init() != HD_OK) return "none";
    switch (dnnl_get_effective_cpu_isa()) {
    case dnnl_cpu_isa_sse41: return "sse41";
    case dnnl_cpu_isa_avx: return "avx";
    case dnnl_cpu_isa_avx2: return "avx2";
    case dnnl_cpu_isa_avx512_mic: return "avx512_mic";
    case dnnl_cpu_isa_avx512_mic_4ops: return "avx512_mic_4ops";
    case dnnl_cpu_isa_avx512_core: return "avx512_core";
    case dnnl_cpu_isa_avx512_core_vnni: return "avx512_core_vnni";
    case dnnl_cpu_isa_avx512_core_bf16: return "avx512_core_bf16";
    case dnnl_cpu_isa_avx512_core_amx: return "avx512_core_amx";
    case dnnl_cpu_isa_avx2_vnni: return "avx2_vnni";
    default: return "other";
    }
}

hd_status hd_conv3x3_dnnl_plan_head(hd_conv3x3 *p, int c_head)
{
    dn *d = p->dnnl;
    if (!d || !p->nc16 || c_head < 1 || c_head % HD_NC16_BLOCK || c_head > p->C || d->bwd_head)
        return hd_fail(HD_ERR_ARG, "conv3x3: a head of %d input channels needs a fresh nc16 plan of more", c_head);
    dnnl_primitive_desc_t fpd = NULL, dpd = NULL;
    dnnl_primitive_attr_t attr = NULL;
    size_t scratch = 0;
    dnnl_dims_t sdims = {1, c_head, p->H, p->W}, wdims = {p->OC, c_head, 3, 3}, bdims = {p->OC},
                ddims = {1, p->OC, p->Ho, p->Wo}, wstrides = {(dnnl_dim_t)p->C * 9, 9, 3, 1};
    dnnl_dims_t strides = {p->stride, p->stride}, pad_l = {1, 1};
    dnnl_dims_t pad_r = {(p->Ho - 1) * p->stride + 3 - p->H - 1, (p->Wo - 1) * p->stride + 3 - p->W - 1};
    dnnl_memory_desc_t s_md, d_md, w_any, w_user, b_md;
    dnnl_convolution_desc_t fdesc, ddesc;
    DN(dnnl_memory_desc_init_by_tag(&s_md, 4, sdims, dnnl_f32, dnnl_nChw16c));
    DN(dnnl_memory_desc_init_by_tag(&d_md, 4, ddims, dnnl_f32, dnnl_nChw16c));
    DN(dnnl_memory_desc_init_by_tag(&w_any, 4, wdims, dnnl_f32, dnnl_format_tag_any));
    DN(dnnl_memory_desc_init_by_strides(&w_user, 4, wdims, dnnl_f32, wstrides));
    DN(dnnl_memory_desc_init_by_tag(&b_md, 1, bdims, dnnl_f32, dnnl_x));
    DN(attr_user_scratch(&attr));
    /* the forward of the same shape, as the hint backward data needs */
    DN(dnnl_convolution_forward_desc_init(&fdesc, dnnl_forward_training, d->bd_alg, &s_md, &w_any, &b_md, &d_md,
                                          strides, pad_l, pad_r));
    DN(dnnl_primitive_desc_create(&fpd, &fdesc, attr, engine, NULL));
    DN(dnnl_convolution_backward_data_desc_init(&ddesc, d->bd_alg, &s_md, &w_any, &d_md, strides, pad_l, pad_r));
    DN(dnnl_primitive_desc_create(&dpd, &ddesc, attr, engine, fpd));
    NOT_REFERENCE(dpd, "backward data head");
    DN(dnnl_primitive_create(&d->bwd_head, dpd));
    scratch = scratch_size(dpd);
    DN(make_view(&d->bh_w, &w_user, qmd(dpd, dnnl_query_weights_md), 1, 0, &scratch));
    DN(dnnl_memory_create(&d->bh_ddst, &d_md, engine, DNNL_MEMORY_NONE));
    DN(dnnl_memory_create(&d->bh_dsrc, &s_md, engine, DNNL_MEMORY_NONE));
    const dnnl_memory_desc_t *sp = NULL;
    DN(dnnl_memory_get_memory_desc(d->scratch, &sp));
    if (scratch > dnnl_memory_desc_get_size(sp)) { /* a larger scratchpad, once */
        dnnl_memory_desc_t sp_md;
        dnnl_dims_t spdims = {(dnnl_dim_t)scratch};
        DN(dnnl_memory_desc_init_by_tag(&sp_md, 1, spdims, dnnl_u8, dnnl_x));
        dnnl_memory_t bigger;
        DN(dnnl_memory_create(&bigger, &sp_md, engine, DNNL_MEMORY_ALLOCATE));
        dnnl_memory_destroy(d->scratch);
        d->scratch = bigger;
    }
    d->c_head = c_head;
    dnnl_primitive_desc_destroy(fpd);
    dnnl_primitive_desc_destroy(dpd);
    dnnl_primitive_attr_destroy(attr);
    return HD_OK;
fail:
    if (fpd) dnnl_primitive_desc_destroy(fpd);
    if (dpd) dnnl_primitive_desc_destroy(dpd);
    if (attr) dnnl_primitive_attr_destroy(attr);
    if (d->bwd_head) dnnl_primitive_destroy(d->bwd_head);
    d->bwd_head = NULL;
    free_view(&d->bh_w);
    if (d->bh_ddst) dnnl_memory_destroy(d->bh_ddst);
    if (d->bh_dsrc) dnnl_memory_destroy(d->bh_dsrc);
    d->bh_ddst = d->bh_dsrc = NULL;
    return HD_ERR_ARG;
}

int hd_conv3x3_dnnl_winograd(const hd_conv3x3 *p) { return p->dnnl && ((const dn *)p->dnnl)->fwd_wino; }

int hd_conv3x3_dnnl_is_bf16(const hd_conv3x3 *p) { return p->dnnl && ((const dn *)p->dnnl)->bf16; }

int hd_conv3x3_dnnl_head(const hd_conv3x3 *p) { return p->dnnl ? ((const dn *)p->dnnl)->c_head : 0; }


void hd_conv3x3_dnnl_free(hd_conv3x3 *p)
{
    dn *d = p->dnnl;
    if (!d) return;
    if (d->bwd_head) dnnl_primitive_destroy(d->bwd_head);
    free_view(&d->bh_w);
    if (d->bh_ddst) dnnl_memory_destroy(d->bh_ddst);
    if (d->bh_dsrc) dnnl_memory_destroy(d->bh_dsrc);
    if (d->fwd) dnnl_primitive_destroy(d->fwd);
    if (d->bwd_data) dnnl_primitive_destroy(d->bwd_data);
    if (d->bwd_weights) dnnl_primitive_destroy(d->bwd_weights);
    view *views[] = {&d->src, &d->w, &d->dst, &d->bd_ddst, &d->bd_w, &d->bd_dsrc, &d->bw_src, &d->bw_ddst, &d->bw_dw};
    for (size_t i = 0; i < sizeof views / sizeof views[0]; i++) free_view(views[i]);
    if (d->bias) dnnl_memory_destroy(d->bias);
    if (d->dbias) dnnl_memory_destroy(d->dbias);
    if (d->scratch) dnnl_memory_destroy(d->scratch);
    if (d->dsrc_tmp) dnnl_memory_destroy(d->dsrc_tmp);
    if (d->stream) dnnl_stream_destroy(d->stream);
    free(d->zero_bias);
    free(d->dbias_buf);
    free(d);
    p->dnnl = NULL;
}

/* Runs a reorder from `from` to `to`. */
static void run_reorder(dn *d, dnnl_primitive_t r, dnnl_memory_t from, dnnl_memory_t to)
{
    dnnl_exec_arg_t args[3] = {{DNNL_ARG_FROM, from}, {DNNL_ARG_TO, to}, {DNNL_ARG_SCRATCHPAD, d->scratch}};
    dnnl_primitive_execute(r, d->stream, 3, args);
}

/* Points an input view at ptr and brings it into the primitive's format. */
static dnnl_memory_t view_in(dn *d, view *v, const float *ptr)
{
    dnnl_memory_set_data_handle(v->user, (void *)ptr);
    if (v->reorder) run_reorder(d, v->reorder, v->user, v->prim);
    return v->prim;
}

void hd_conv3x3_dnnl_forward(hd_conv3x3 *p, float *out, const float *inp, const float *w, const float *b)
{
    dn *d = p->dnnl;
    dnnl_memory_t src = view_in(d, &d->src, inp), wt = view_in(d, &d->w, w);
    dnnl_memory_set_data_handle(d->bias, (void *)(b ? b : d->zero_bias));
    dnnl_memory_set_data_handle(d->dst.user, out);
    dnnl_exec_arg_t args[5] = {{DNNL_ARG_SRC, src}, {DNNL_ARG_WEIGHTS, wt}, {DNNL_ARG_BIAS, d->bias},
                               {DNNL_ARG_DST, d->dst.prim}, {DNNL_ARG_SCRATCHPAD, d->scratch}};
    dnnl_primitive_execute(d->fwd, d->stream, 5, args);
    if (d->dst.reorder) run_reorder(d, d->dst.reorder, d->dst.prim, d->dst.user);
    dnnl_stream_wait(d->stream);
    d->last_src = inp;
    if (d->act_pass) hd_conv3x3_lrelu(out, p->out_n, p->slope);
}

void hd_conv3x3_dnnl_backward(hd_conv3x3 *p, float *dinp, float *dw, float *db, const float *dout,
                              const float *inp, const float *w, int overwrite)
{
    dn *d = p->dnnl;
    dnnl_memory_t ddst_done = NULL; /* diff_dst already reordered by backward data, in this call */
    if (dinp) {
        /* dsrc = conv^T(ddst, w); then dinp = dsrc or dinp += dsrc */
        dnnl_memory_t ddst = view_in(d, &d->bd_ddst, dout), wt = view_in(d, &d->bd_w, w), dsrc;
        if (p->nc16) {
            dsrc = overwrite ? d->bd_dsrc.user : d->dsrc_tmp;
            if (overwrite) dnnl_memory_set_data_handle(d->bd_dsrc.user, dinp);
        } else {
            dsrc = d->bd_dsrc.prim;
            if (overwrite) memset(dinp, 0, p->in_n * sizeof(float));
        }
        dnnl_exec_arg_t args[4] = {{DNNL_ARG_DIFF_DST, ddst}, {DNNL_ARG_WEIGHTS, wt},
                                   {DNNL_ARG_DIFF_SRC, dsrc}, {DNNL_ARG_SCRATCHPAD, d->scratch}};
        dnnl_primitive_execute(d->bwd_data, d->stream, 4, args);
        if (d->share_ddst) ddst_done = ddst;
        if (!p->nc16) {
            /* a reorder with a sum post-op: dinp += dsrc */
            dnnl_memory_set_data_handle(d->bd_dsrc.user, dinp);
            run_reorder(d, d->bd_dsrc.reorder, d->bd_dsrc.prim, d->bd_dsrc.user);
        } else if (!overwrite) {
            dnnl_stream_wait(d->stream);
            void *h = NULL;
            dnnl_memory_get_data_handle(d->dsrc_tmp, &h);
            const float *t = h;
            size_t n = p->in_n;
#pragma omp parallel for schedule(static) if (n > 262144)
            for (size_t i = 0; i < n; i++) dinp[i] += t[i];
        }
    }
    if (dw || db) {
        /* dw = sum ddst x src, db = sum ddst; both accumulate */
        dnnl_memory_t src;
        if (d->share_src && d->last_src == inp) src = d->src.prim; /* the forward's copy */
        else src = view_in(d, &d->bw_src, inp);
        dnnl_memory_t ddst = ddst_done ? ddst_done : view_in(d, &d->bw_ddst, dout);
        dnnl_exec_arg_t args[5] = {{DNNL_ARG_SRC, src}, {DNNL_ARG_DIFF_DST, ddst},
                                   {DNNL_ARG_DIFF_WEIGHTS, d->bw_dw.prim}, {DNNL_ARG_DIFF_BIAS, d->dbias},
                                   {DNNL_ARG_SCRATCHPAD, d->scratch}};
        dnnl_primitive_execute(d->bwd_weights, d->stream, 5, args);
        if (dw) {
            dnnl_memory_set_data_handle(d->bw_dw.user, dw);
            run_reorder(d, d->bw_dw.reorder, d->bw_dw.prim, d->bw_dw.user);
        }
        dnnl_stream_wait(d->stream);
        if (db)
            for (int o = 0; o < p->OC; o++) db[o] += d->dbias_buf[o];
    }
    dnnl_stream_wait(d->stream);
}

void hd_conv3x3_dnnl_backward_head(hd_conv3x3 *p, float *dinp, const float *dout, const float *w)
{
    dn *d = p->dnnl;
    dnnl_memory_t wt = view_in(d, &d->bh_w, w);
    size_t in_img = p->in_n / (size_t)p->B, out_img = p->out_n / (size_t)p->B;
    for (int n = 0; n < p->B; n++) {
        dnnl_memory_set_data_handle(d->bh_ddst, (void *)(dout + n * out_img));
        dnnl_memory_set_data_handle(d->bh_dsrc, dinp + n * in_img);
        dnnl_exec_arg_t args[4] = {{DNNL_ARG_DIFF_DST, d->bh_ddst}, {DNNL_ARG_WEIGHTS, wt},
                                   {DNNL_ARG_DIFF_SRC, d->bh_dsrc}, {DNNL_ARG_SCRATCHPAD, d->scratch}};
        dnnl_primitive_execute(d->bwd_head, d->stream, 4, args);
    }
    dnnl_stream_wait(d->stream);
}
#endif
