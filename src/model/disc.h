/* disc.h: the PatchGAN discriminator of SPEC section 3, training only: its own weights (one flat
 * arena by hd_disc_param_table, with their gradients) and its run state for batches of B images at
 * H x W, beside HD-Net (hdnet_net.h) rather than inside it. The trainer holds one of each.
 *
 * Letters: B images, HW = H * W, Hd[k] x Wd[k] the sides after c(k+1), Hp x Wp the patch logits.
 */
#ifndef HD_DISC_H
#define HD_DISC_H

#include "model/hdnet_net.h"

typedef struct hd_disc {
    int B, H, W;
    hd_param_table table;
    float *params, *grads; /* (table.total) */
    hd_conv3x3 *c1, *c2, *c3, *c4, *out;
    int Hd[4], Wd[4], Hp, Wp;
    float *act_mem;          /* one block holding every activation below */
    size_t act_floats;
    /* activations (d_ a gradient): c1 output; per c2..c4 pre-norm, normed, activated */
    float *in;    /* (B, 3, HW) the input */
    float *h1;    /* (B, 64, Hd0 Wd0) */
    float *pre[3], *norm[3], *act[3], *mean[3], *rstd[3];
    float *logit; /* (B, 1, Hp Wp) */
    float *d_in, *d_h1, *d_pre[3], *d_norm[3], *d_act[3], *d_logit; /* their gradients */
} hd_disc;

/* The discriminator's table: disc.c1 .. disc.c4, disc.out (weight, bias each). */
void hd_disc_param_table(hd_param_table *t);
/* Makes a discriminator for batches of B images of size x size; parameters and gradients are
 * allocated zeroed (load or init them). */
hd_status hd_disc_create(hd_disc *d, int B, int size, hd_conv_path path);
void hd_disc_free(hd_disc *d);
/* Forward of d->in (B, 3, HW) into d->logit (B, 1, Hp, Wp); profile (benchmarks; may be NULL) gets
 * its time under HD_STAGE_DISC, as in hd_disc_backward. */
void hd_disc_forward(hd_disc *d, hd_net_profile *profile);
/* Backward of the last forward from d->d_logit (consumed): accumulates the input gradient into
 * d->d_in when want_input, and parameter gradients into d->grads when want_params. */
void hd_disc_backward(hd_disc *d, int want_input, int want_params, hd_net_profile *profile);
/* Number of patch logits per image. */
int hd_disc_patches(const hd_disc *d);

#endif /* HD_DISC_H */
