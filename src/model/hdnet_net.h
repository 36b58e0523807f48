/* hdnet_net.h: HD-Net of SPEC section 3 wired together: conv_in, ASD-Net (a_net, s_net),
 * NLD-Net (n_net, l_net); the PatchGAN discriminator is its own network beside it (disc.h). One
 * flat parameter arena per network described by a parameter table in a fixed order; forward and
 * backward over activations allocated once per (batch, size).
 *
 * Letters: B images in a forward (a batch of P pairs is B = 2P, image 2p is i and 2p+1 is j),
 * H = W = size, HW = H * W, w the Common-Net width, Hb = H / 32 the bottleneck side.
 */
#ifndef HD_HDNET_NET_H
#define HD_HDNET_NET_H

#include "core/core.h"
#include "nn/nn.h"
#include "model/unet.h"

#define HD_NET_FORMAT_VERSION 1
#define HD_NET_MAX_PARAMS 128
#define HD_FEAT 32      /* conv_in output channels */
#define HD_LNET_HIDDEN 64

typedef struct hd_net_config {
    int width; /* Common-Net width w (paper: 48) */
    int size;  /* input side, a multiple of 32 (paper: 256) */
} hd_net_config;

/* What a network's parameter arena holds: the table (names, shapes, offsets) and its total size. */
typedef struct hd_param_table {
    hd_param p[HD_NET_MAX_PARAMS];
    int count;
    size_t total; /* floats */
} hd_param_table;

/* The parameter table of HD-Net: conv_in.weight/bias, a_net.*, s_net.*, n_net.*,
 * l_net.conv1/conv2/fc, in that order. Offsets of the sub-nets are returned for binding. */
void hd_net_param_table(const hd_net_config *cfg, hd_param_table *t);
/* Index of a named parameter in a table, or -1. */
int hd_param_find(const hd_param_table *t, const char *name);
/* The named parameter's first float in an arena laid out by t (params or grads), or NULL. */
float *hd_param_of(const hd_param_table *t, float *base, const char *name);
/* Adds a 3x3 convolution's PREFIX.weight (cout, cin, 3, 3) and PREFIX.bias (cout) to t. */
void hd_param_table_conv(hd_param_table *t, const char *prefix, int cin, int cout);
/* Fills a flat arena with PyTorch's default init (uniform +-1/sqrt(fan_in)), in table order,
 * from rng. */
void hd_params_init(const hd_param_table *t, float *params, hd_rng *rng);
/* Checks that a configuration is usable (width 1..1024, size a positive multiple of 32). */
hd_status hd_net_config_check(const hd_net_config *cfg);

typedef enum hd_net_mode {
    HD_NET_INFER = 0, /* forward only, no gradients */
    HD_NET_TRAIN      /* gradients */
} hd_net_mode;

/* Which parameters receive gradients in hd_net_backward. */
typedef enum hd_net_train_set {
    HD_TRAIN_ALL = 0, /* everything (stage 1, stage 2b) */
    HD_TRAIN_LNET     /* only l_net (stage 2a: A-, S-, N-Net frozen) */
} hd_net_train_set;

/* Parts of the networks a profile splits its time into (hd_net_pass.profile). */
typedef enum hd_net_stage {
    HD_STAGE_CONV_IN = 0,
    HD_STAGE_A_NET,
    HD_STAGE_S_NET,
    HD_STAGE_N_NET,
    HD_STAGE_L_NET,
    HD_STAGE_HEADS, /* sigmoid, softplus, tanh, normalisation and their gradients */
    HD_STAGE_DISC,  /* the discriminator (disc.h), every call */
    HD_NET_STAGES
} hd_net_stage;

/* Stage names for tables ("conv_in", "a_net", "s_net", "n_net", "l_net", "heads", "disc"). */
extern const char *const hd_net_stage_names[HD_NET_STAGES];

/* Seconds (wall clock) spent per stage, forward and backward, accumulated over every pass given
 * it (hd_net_pass.profile). */
typedef struct hd_net_profile {
    double fwd[HD_NET_STAGES], bwd[HD_NET_STAGES];
} hd_net_profile;

/* A stage's clock (the networks' own files): hd_net_stage_start at a pass's start, then
 * hd_net_stage_lap adds the time since to stage k of profile's forward (bwd 0) or backward table
 * (nothing without a profile) and to the benchmarks' profiler (core.h, hd_prof_*) as a phase of
 * the stage's name, and restarts the clock. */
typedef struct hd_net_stage_clock {
    double t;
    hd_prof_mark m;
} hd_net_stage_clock;
hd_net_stage_clock hd_net_stage_start(const hd_net_profile *profile);
void hd_net_stage_lap(hd_net_profile *profile, int bwd, hd_net_stage k, hd_net_stage_clock *c);

/* Carves a network's activations out of one block: a first pass with base NULL only counts
 * (used), a second over the allocated block hands out the pointers, 64-byte aligned. */
typedef struct hd_carver {
    float *base;
    size_t used;
} hd_carver;
static inline float *hd_carve(hd_carver *c, size_t n)
{
    float *p = c->base ? c->base + c->used : NULL;
    c->used += (n + 15) & ~(size_t)15;
    return p;
}

/* A network is its configuration and weights (cfg, table, params) and its run state (the conv
 * plans with their scratch, the activations and gradients). The weights are owned (hd_net_create:
 * training, one net per trainer) or borrowed read-only (hd_net_create_run: inference, many run
 * states over one model's weights, one per concurrent call). A forward only writes the run state,
 * so nets sharing weights may run in different threads at once. */
typedef struct hd_net {
    hd_net_config cfg;
    hd_net_mode mode;
    int B, H, W;
    hd_param_table table;
    size_t off_a, off_s, off_n; /* float offsets of the sub-nets in params */
    float *params, *grads;      /* (table.total); params not written when weights_borrowed */
    int weights_borrowed;       /* params belong to the caller (hd_net_create_run) */

    hd_unet *a_net, *s_net, *n_net;
    hd_conv3x3 *conv_in, *l_conv1, *l_conv2;
    int Hb, Wb, H1, W1, H2, W2; /* bottleneck, l_net conv1 and conv2 output sides */

    float *act_mem; /* one block holding every activation below */
    size_t act_floats;
    /* activations */
    float *input;   /* (B, 3, HW) */
    float *feat;    /* (B, 32, HW) conv_in output */
    float *a_logit; /* (B, 3, HW) */
    float *albedo;  /* (B, 3, HW) A = sigmoid(a_logit) */
    float *s_logit; /* (B, 1, HW) */
    float *shading; /* (B, 1, HW) S = softplus(s_logit) */
    float *n_logit; /* (B, 3, HW) */
    float *n_tanh;  /* (B, 3, HW) */
    float *normal;  /* (B, 3, HW) N = normalize(tanh(n_logit)) */
    float *l_h1;    /* (B, 64, H1 * W1) */
    float *l_h2;    /* (B, 64, H2 * W2) */
    float *l_pool;  /* (B, 64) */
    float *light;   /* (B, 9) */
    /* gradients of activations (TRAIN only) */
    float *d_feat, *d_a_logit, *d_albedo, *d_s_logit, *d_shading, *d_n_logit, *d_n_tanh, *d_normal;
    float *d_bottleneck, *d_l_h1, *d_l_h2, *d_l_pool, *d_light;
} hd_net;

/* Makes a network for batches of B images at cfg->size; parameters are allocated (zeroed: load or
 * init them). */
hd_status hd_net_create(hd_net *net, const hd_net_config *cfg, int B, hd_net_mode mode, hd_conv_path path);
/* An inference run state (HD_NET_INFER) for batches of B over `weights` (table.total floats in the
 * order of hd_net_param_table), which the net reads but neither copies, writes nor frees: they
 * must outlive it. */
hd_status hd_net_create_run(hd_net *net, const hd_net_config *cfg, int B, hd_conv_path path, const float *weights);
void hd_net_free(hd_net *net);

/* How one pass runs beyond the network's own state, for the benchmarks, the gradient checks and the
 * probes of model_probe.h;
 * a NULL pass (inference, training) is a plain one. The trainer owns one (hd_trainer.pass). */
typedef struct hd_net_pass {
    hd_net_profile *profile;   /* benchmarks: when not NULL, the pass adds its stage times here */
    const float *n_input_hold; /* gradient checks: when not NULL, N-Net reads this (B, 1, HW) instead of
                                * S, so that a finite difference sees S detached from N-Net as the
                                * analytic gradient does; probes: N-Net on a shading from outside */
} hd_net_pass;

/* Forward of net->input: albedo, shading, normal, light (and everything backward needs). */
void hd_net_forward(hd_net *net, const hd_net_pass *pass);
/* Zeroes the HD-Net parameter gradients and the activation gradients d_albedo, d_shading,
 * d_normal, d_light (which the losses then accumulate into). */
void hd_net_zero_grad(hd_net *net);
/* Zeroes only the activation gradients (between micro-batches whose parameter gradients add up). */
void hd_net_zero_act_grad(hd_net *net);
/* Backward from d_albedo, d_shading, d_normal, d_light into net->grads, with SPEC section 4's
 * paths: the N-Net input S is detached; with HD_TRAIN_LNET only l_net receives gradients.
 * The activation gradients are consumed (overwritten). */
void hd_net_backward(hd_net *net, hd_net_train_set set, const hd_net_pass *pass);

/* Multiply-accumulates of one HD-Net forward of one image at cfg (for GFLOP/s). */
double hd_net_macs(const hd_net_config *cfg);

#endif /* HD_HDNET_NET_H */
