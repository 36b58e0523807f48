/* losses.h: the seven loss terms of SPEC section 4, each a named function that returns its value
 * (the mean over the batch's pairs of the i and j parts) and accumulates `scale` times its
 * gradient into the network's activation gradients (d_albedo, d_shading, d_normal, d_light);
 * scale 0 computes the value only. Plus the discriminator's own loss, the weight presets, and one
 * call that evaluates every term of a training step.
 *
 * Letters: P pairs, B = 2P images (image 2p is I_i, 2p+1 is I_j), HW pixels per image.
 */
#ifndef HD_LOSSES_H
#define HD_LOSSES_H

#include "model/disc.h"
#include "model/hdnet_net.h"
#include "train/train_data.h"

/* The scale anchor's target mean shading over the face: the median of the synthetic set's
 * (0.79 over 200 held-out images; docs/training.md). */
#define HD_SHADING_MEAN_DEFAULT 0.8f

typedef enum hd_loss_term {
    HD_LOSS_REC = 0, /* L_Irec: mean_m |I - A*S| (A*S*g with the batch's camera gain g: --rec-gain camera) */
    HD_LOSS_ALBEDO,  /* L_a: mean_{m_i m_j} |A_i - A_j| */
    HD_LOSS_SMOOTH,  /* L_s: shading smoothness */
    HD_LOSS_NORMAL,  /* L_n: ||N_bar - N||^2 */
    HD_LOSS_LIGHT,   /* L_l: mean |l - l_hat| */
    HD_LOSS_SREC,    /* L_Srec: mean_m |S - s(N, l)| */
    HD_LOSS_ADV,     /* L_adv: softplus(-D(m A s(N, l))) */
    HD_LOSS_ALBEDO_GT, /* not the paper's: mean_m |A - A_gt| where ground truth exists (weight 0 in
                        * both presets; anchors the scale A and S share, see docs/training.md) */
    HD_LOSS_SHADING_MEAN, /* not the paper's: the scale anchor, |mean_m S - c| per image (weight 1 in
                           * both presets; docs/training.md) */
    HD_LOSS_SHADING_PRIOR, /* not the paper's: mean_m |S - s(N_bar, l_img)|, the shading of the photo's own
                            * light on the coarse normals (weight 1 in both presets; docs/training.md) */
    HD_LOSS_LIGHT_PAIR, /* not the paper's: L_lpair, mean_k |l_j - R l_i| over the pairs whose lights the
                         * data relates (R = 1 or the mirror; weight 0 in both presets; docs/training.md) */
    HD_LOSS_FIT_PAIR, /* not the paper's: L_fpair, mean_k |f_j - R f_i| with f the face's own light that
                       * relighting uses (the fit of S on N, hd_face_light) over the same pairs (weight 0 in
                       * both presets; docs/training.md) */
    HD_LOSS_TERMS
} hd_loss_term;

/* Short names ("rec", "albedo", "smooth", "normal", "light", "srec", "adv", "albedo_gt", "shading_mean",
 * "shading_prior", "light_pair", "fit_pair"): CSV columns, the --w-NAME options and the dump's loss.NAME tensors. */
extern const char *const hd_loss_names[HD_LOSS_TERMS];

typedef struct hd_loss_weights {
    float w[HD_LOSS_TERMS];
} hd_loss_weights;

/* The weight sets of SPEC section 4: "gt" or "dpr". */
hd_status hd_loss_weights_preset(const char *name, hd_loss_weights *w);

/* Where l_hat's normals come from: the coarse normals N_bar (stage 1) or the predicted N (stage 2). */
typedef enum hd_light_target {
    HD_LIGHT_FROM_COARSE = 0,
    HD_LIGHT_FROM_PREDICTED
} hd_light_target;

/* Scratch of the losses of one training step, made once per network. */
typedef struct hd_losses {
    hd_net *net;
    hd_disc *disc; /* the adversarial terms' discriminator */
    const hd_net_pass *pass; /* the trainer's: its profile times the discriminator (may be NULL) */
    const hd_pair_batch *batch;
    hd_light_target target;
    float *shade, *d_shade, *recon, *d_recon, *render, *weight;
    float *light_hat; /* (B, 9) l_hat, detached */
    float *prior;     /* (B, HW) the shading prior's target s(N_bar, l_img), detached (images with N_bar) */
    int hold_light_hat; /* gradient checks only: keep light_hat as it is (detached for real) */
    float shading_mean; /* c of the scale anchor (HD_SHADING_MEAN_DEFAULT unless changed) */
    int shading_mean_pair; /* the anchor on the mean of the pair's two mean shadings, not on each image */
    int light_from_image; /* l_hat fitted to the image's luminance instead of to S, scaled so that its
                           * shading's mean over the mask is shading_mean (not the paper's) */
    int light_from_face; /* l_hat = the face's own light of S on N, as the relighting rule fits it
                          * (hd_losses_light_from_face; not the paper's) */
    int prior_predicted; /* the shading prior's target on the predicted normals N (detached) instead of
                          * the coarse N_bar (stage 2; --shading-prior-normals predicted) */
    float *skin;       /* (HW) or NULL: 1 on skin, 0 on the eyes, brows and inner lips, where the photo's
                        * own light is fitted without them (hd_losses_fit_skin_only) */
    float *fit_weight; /* (HW) scratch: mask times skin */
    int fit_pair;      /* the term fit_pair is on (hd_losses_fit_pair_on) */
    float *fit_layout; /* (HW) or NULL (neither fit_pair nor light_from_face): the weight of each texel
                        * in the face's own light fit, the skin times the lower face's weight */
    float *fit_light;  /* (B, 9) f: the face's own light of each image of a related pair */
    float *fit_prior;  /* (B, 9) the lobe each f is pulled toward, detached (held by gradient checks) */
    float *fit_mask;   /* (HW) scratch: the fit's weight for one image, fit_layout on its mask */
} hd_losses;

hd_status hd_losses_create(hd_losses *L, hd_net *net, hd_disc *disc, const hd_net_pass *pass);
void hd_losses_free(hd_losses *L);

/* The photo's own light (the shading prior's, and --light-target image's) fitted to the skin alone:
 * the eyes, brows and inner lips of the canonical layout, grown by HD_LOSSES_PARTS_GROW of the
 * side, weigh 0 in the least-squares fit (their albedo is far from the skin's, so an even-albedo
 * fit reads them as shading). The scale to c still takes the whole face. Needs a square network
 * (the aligned texture space); --light-fit skin. */
#define HD_LOSSES_PARTS_GROW 0.02f
hd_status hd_losses_fit_skin_only(hd_losses *L);

/* Turns the term fit_pair on (its weight alone does not): the texel weights of the face's own
 * light fit, the layout hd_face_light uses (the face regions out, the face below the nose at
 * HD_FIT_LOWER_FACE). Needs a square network (the aligned texture space). */
hd_status hd_losses_fit_pair_on(hd_losses *L);

/* l_hat of L_l becomes the face's own light the relighting rule uses (hd_face_light: the fit of S
 * on the stage's normals over the skin, the face below the nose at HD_FIT_LOWER_FACE, pulled toward
 * the lobe with HD_SOURCE_PRIOR) instead of the plain least-squares fit over the mask: L-Net then
 * learns the light the tool applies. Detached like the paper's l_hat. Needs a square network. */
hd_status hd_losses_light_from_face(hd_losses *L);

/* After hd_net_forward: computes s(N, l), the render m*A*s(N, l) and l_hat (from the coarse or the
 * predicted normals; the batch's ground-truth light where it has one) that the terms below share. Fails (HD_ERR_NUMERIC) if l_hat is not finite. */
hd_status hd_losses_prepare(hd_losses *L, const hd_pair_batch *batch, hd_light_target target);

double hd_loss_reconstruction(hd_losses *L, float scale);
double hd_loss_albedo_consistency(hd_losses *L, float scale);
double hd_loss_shading_smoothness(hd_losses *L, float scale);
double hd_loss_normal_prior(hd_losses *L, float scale);
double hd_loss_light(hd_losses *L, float scale);
double hd_loss_shading_reconstruction(hd_losses *L, float scale);
/* Not the paper's: mean_m |A - A_gt| over the images that have a ground-truth albedo. */
double hd_loss_albedo_supervised(hd_losses *L, float scale);
/* Not the paper's, the scale anchor: mean over images of |mean_m S - c|, c = L->shading_mean; with
 * L->shading_mean_pair, |(mean_m S_i + mean_m S_j) / 2 - c| for both images of a pair instead. */
double hd_loss_shading_mean(hd_losses *L, float scale);
/* Not the paper's, the shading prior: mean_m |S - s(N_bar, l_img)| over the images that have coarse
 * normals, l_img the least-squares light of the photo's luminance on N_bar scaled so that the
 * target's mean over the face is the anchor's c. A constant S cannot satisfy it. With
 * L->prior_predicted, N_bar is replaced by the predicted N (detached) in both places. */
double hd_loss_shading_prior(hd_losses *L, float scale);
/* Not the paper's, L_lpair: mean over pairs of mean_k |l_j,k - (R l_i)_k|, R the identity for
 * HD_PAIR_LIGHT_SAME pairs and hd_light_mirror for HD_PAIR_LIGHT_MIRROR ones, 0 for the others;
 * reaches both images' L-Net outputs, weighted by image i's domain weight. */
double hd_loss_light_pair(hd_losses *L, float scale);
/* Not the paper's, L_fpair: mean over the pairs L_lpair takes of mean_k |f_j,k - (R f_i)_k|, f the
 * face's own light the relighting rule uses (hd_face_light's fit of S on N over the skin, pulled
 * toward the lobe with HD_SOURCE_PRIOR, the lobe detached); reaches S and N of both images by the
 * fit's adjoint (hd_sh_fit_adjoint), weighted by image i's domain weight. 0 unless
 * hd_losses_fit_pair_on. */
double hd_loss_fit_pair(hd_losses *L, float scale);
/* Generator side: runs the discriminator on the render (its parameters get no gradient). */
double hd_loss_adversarial(hd_losses *L, float scale);
/* The discriminator's own loss, mean softplus(-D(m I)) + mean softplus(D(render)) (render
 * detached), for i and j, averaged over pairs; accumulates scale times its gradient into
 * disc->grads. */
double hd_loss_discriminator(hd_losses *L, float scale);

/* Every generator term (prepare first): terms[k] = L_k, returns sum_k w_k L_k, and accumulates
 * its gradient into the activation gradients when grad is nonzero. */
double hd_losses_generator(hd_losses *L, const hd_loss_weights *w, double terms[HD_LOSS_TERMS], int grad);

#endif /* HD_LOSSES_H */
