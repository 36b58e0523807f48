/* losses.c: SPEC section 4's seven terms with their exact definitions and gradients, and the
 * discriminator's loss. Every term is the mean over pairs of its i and j parts, so each image's
 * piece is weighted 1/P; weighted means use nn.h's loss pieces (mean_w). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "train/losses.h"
#include "light/light.h"
#include "mesh/mesh.h"

#define HD_SMOOTH_EPS 0.01f

const char *const hd_loss_names[HD_LOSS_TERMS] = {"rec", "albedo", "smooth", "normal", "light", "srec", "adv", "albedo_gt",
                                                    "shading_mean", "shading_prior", "light_pair",
                                                    "fit_pair"};

hd_status hd_loss_weights_preset(const char *name, hd_loss_weights *w)
{
    static const float gt[HD_LOSS_TERMS] = {0.25f, 0.25f, 0.1f, 0.5f, 0.01f, 0.01f, 0.001f, 0.0f, 1.0f, 1.0f, 0.0f, 0.0f};
    static const float dpr[HD_LOSS_TERMS] = {0.25f, 0.15f, 0.01f, 0.5f, 0.01f, 0.01f, 0.0001f, 0.0f, 1.0f, 1.0f, 0.0f, 0.0f};
    if (strcmp(name, "gt") == 0) memcpy(w->w, gt, sizeof gt);
    else if (strcmp(name, "dpr") == 0) memcpy(w->w, dpr, sizeof dpr);
    else return hd_fail(HD_ERR_ARG, "unknown weight set '%s' (gt or dpr)", name);
    return HD_OK;
}

hd_status hd_losses_create(hd_losses *L, hd_net *net, hd_disc *disc, const hd_net_pass *pass)
{
    memset(L, 0, sizeof *L);
    size_t B = (size_t)net->B, HW = (size_t)net->H * net->W;
    L->net = net;
    L->disc = disc;
    L->pass = pass;
    L->shading_mean = HD_SHADING_MEAN_DEFAULT;
    L->shade = hd_calloc(B * HW, sizeof(float));
    L->d_shade = hd_calloc(B * HW, sizeof(float));
    L->recon = hd_calloc(B * 3 * HW, sizeof(float));
    L->d_recon = hd_calloc(B * 3 * HW, sizeof(float));
    L->render = hd_calloc(B * 3 * HW, sizeof(float));
    L->weight = hd_calloc(HW, sizeof(float));
    L->light_hat = hd_calloc(B * HD_SH_COEFFS, sizeof(float));
    L->prior = hd_calloc(B * HW, sizeof(float));
    if (!L->shade || !L->d_shade || !L->recon || !L->d_recon || !L->render || !L->weight || !L->light_hat || !L->prior) {
        hd_losses_free(L);
        return HD_ERR_NOMEM;
    }
    return HD_OK;
}

void hd_losses_free(hd_losses *L)
{
    free(L->shade);
    free(L->d_shade);
    free(L->recon);
    free(L->d_recon);
    free(L->render);
    free(L->weight);
    free(L->light_hat);
    free(L->prior);
    free(L->skin);
    free(L->fit_weight);
    free(L->fit_layout);
    free(L->fit_light);
    free(L->fit_prior);
    free(L->fit_mask);
    memset(L, 0, sizeof *L);
}

hd_status hd_losses_fit_skin_only(hd_losses *L)
{
    static const int *const PARTS[] = {hd_contour_right_eye, hd_contour_left_eye, hd_contour_inner_lips,
                                       hd_contour_right_brow, hd_contour_left_brow};
    hd_net *net = L->net;
    if (net->H != net->W)
        return hd_fail(HD_ERR_ARG, "the skin-only light fit needs a square network (%d x %d)", net->W, net->H);
    size_t HW = (size_t)net->H * net->W;
    hd_image parts;
    hd_status st = hd_mesh_contours_uv(PARTS, (int)(sizeof PARTS / sizeof PARTS[0]), HD_LOSSES_PARTS_GROW, net->W, &parts);
    if (st != HD_OK) return st;
    float *skin = hd_malloc(HW * sizeof(float)), *fw = hd_malloc(HW * sizeof(float));
    if (!skin || !fw) {
        free(skin), free(fw), hd_image_free(&parts);
        return HD_ERR_NOMEM;
    }
    for (size_t p = 0; p < HW; p++) skin[p] = 1.0f - parts.data[p];
    hd_image_free(&parts);
    free(L->skin), free(L->fit_weight);
    L->skin = skin, L->fit_weight = fw;
    return HD_OK;
}

/* The face's own light fit's texel weights and scratch (L->fit_layout, fit_mask, fit_light, fit_prior). */
static hd_status fit_layout_on(hd_losses *L, const char *who)
{
    hd_net *net = L->net;
    if (net->H != net->W) return hd_fail(HD_ERR_ARG, "%s needs a square network (%d x %d)", who, net->W, net->H);
    if (L->fit_layout) return HD_OK;
    size_t B = (size_t)net->B, HW = (size_t)net->H * net->W;
    hd_image layout = {0};
    hd_status st = hd_face_light_layout(net->W, &layout);
    float *mask = hd_malloc(HW * sizeof(float));
    float *light = hd_calloc(B * HD_SH_COEFFS, sizeof(float)), *prior = hd_calloc(B * HD_SH_COEFFS, sizeof(float));
    if (st == HD_OK && (!mask || !light || !prior)) st = HD_ERR_NOMEM;
    if (st != HD_OK) {
        hd_image_free(&layout);
        free(mask), free(light), free(prior);
        return st;
    }
    L->fit_layout = layout.data, L->fit_mask = mask, L->fit_light = light, L->fit_prior = prior;
    return HD_OK;
}

hd_status hd_losses_fit_pair_on(hd_losses *L)
{
    hd_status st = fit_layout_on(L, "the fit-pair term");
    if (st == HD_OK) L->fit_pair = 1;
    return st;
}

hd_status hd_losses_light_from_face(hd_losses *L)
{
    hd_status st = fit_layout_on(L, "--light-target face");
    if (st == HD_OK) L->light_from_face = 1;
    return st;
}

/* The photo's own light l_img of image b (--light-target image's l_hat, the shading prior's light):
 * the least-squares light of the image's luminance on the normals n (as if the albedo were even).
 * It reads the photo and the normals only, never S: a shading that has collapsed to a constant
 * (which the paper's terms and the anchor accept, with a DC light) is still pulled toward the shape
 * of the light the photo shows. *mean is the mean of s(n, l) over the mask (0 without a face or
 * for a dark fit). Uses image b's part of L->d_shade as scratch (and leaves it zero, as the backward
 * expects). With L->skin the fit weighs the skin alone; the mean still takes the whole mask. */
static hd_status image_light_fit(hd_losses *L, int b, const float *n, float l[HD_SH_COEFFS], double *mean)
{
    hd_net *net = L->net;
    int HW = net->H * net->W;
    const float *I = L->batch->image + (size_t)b * 3 * HW, *m = L->batch->mask + (size_t)b * HW;
    float *Y = L->d_shade + (size_t)b * HW;
    *mean = 0;
    for (int p = 0; p < HW; p++) Y[p] = 0.2126f * I[p] + 0.7152f * I[HW + p] + 0.0722f * I[2 * HW + p];
    const float *fit = m;
    if (L->skin) { /* the skin alone (hd_losses_fit_skin_only) */
        for (int p = 0; p < HW; p++) L->fit_weight[p] = m[p] * L->skin[p];
        fit = L->fit_weight;
    }
    hd_status st = hd_sh_fit(n, Y, fit, HW, l);
    memset(Y, 0, (size_t)HW * sizeof(float)); /* d_shade is the backward's accumulator: leave it clear */
    if (st != HD_OK) return st;
    double ms = 0, mS = 0;
    for (int p = 0; p < HW; p++) {
        float q[3] = {n[p], n[HW + p], n[2 * HW + p]}, g[3];
        ms += m[p];
        mS += (double)m[p] * hd_sh_shade_grad(l, q, g);
    }
    if (ms > 0 && mS > 0) *mean = mS / ms;
    return HD_OK;
}

/* l_img scaled so that the mean of s(n, l) over the mask is the scale anchor's c (a dark fit or no
 * face: kept as it is). */
static hd_status image_light(hd_losses *L, int b, const float *n, float l[HD_SH_COEFFS])
{
    double mean;
    hd_status st = image_light_fit(L, b, n, l, &mean);
    if (st != HD_OK || !(mean > 0)) return st;
    float k = (float)(L->shading_mean / mean);
    for (int c = 0; c < HD_SH_COEFFS; c++) l[c] *= k;
    return HD_OK;
}

/* The shading prior's targets s(N_bar, l_img) (or on N with prior_predicted), detached, for the
 * images with N_bar. Each image's l_img is scaled so that its target's mean over the face is c;
 * with the anchor on the pair (shading_mean_pair), one scale for both images of a pair makes the
 * mean of the two means c, so the two targets keep the ratio of the photos' own lights (one face,
 * one albedo: the ratio of their shadings). */
/* The normals image b's shading prior is rendered on: N_bar, or N with prior_predicted. */
static const float *prior_normals(const hd_losses *L, int b)
{
    const size_t HW3 = (size_t)3 * L->net->H * L->net->W;
    return L->prior_predicted ? L->net->normal + (size_t)b * HW3 : L->batch->coarse_normal + (size_t)b * HW3;
}

static hd_status prior_targets(hd_losses *L)
{
    hd_net *net = L->net;
    const hd_pair_batch *batch = L->batch;
    int HW = net->H * net->W;
    for (int p = 0; p < net->B / 2; p++) {
        float li[2][HD_SH_COEFFS];
        double mean[2] = {0, 0};
        for (int k = 0; k < 2; k++) {
            int b = 2 * p + k;
            if (!batch->has_normal[b]) continue;
            hd_status st = image_light_fit(L, b, prior_normals(L, b), li[k], &mean[k]);
            if (st != HD_OK) {
                char why[300];
                snprintf(why, sizeof why, "%s", hd_error());
                return hd_fail(st, "the shading prior's light of image %d: %s", b, why);
            }
        }
        const double both = L->shading_mean_pair && mean[0] > 0 && mean[1] > 0 ? 0.5 * (mean[0] + mean[1]) : 0;
        for (int k = 0; k < 2; k++) {
            int b = 2 * p + k;
            if (!batch->has_normal[b]) continue;
            const double at = both > 0 ? both : mean[k];
            if (at > 0)
                for (int c = 0; c < HD_SH_COEFFS; c++) li[k][c] *= (float)(L->shading_mean / at);
            hd_sh_shading_map(prior_normals(L, b), NULL, HW, li[k], L->prior + (size_t)b * HW);
            for (int q = 0; q < HW; q++)
                if (!isfinite(L->prior[(size_t)b * HW + q]))
                    return hd_fail(HD_ERR_NUMERIC, "the shading prior of image %d is not finite", b);
        }
    }
    return HD_OK;
}

/* Whether pair p's two lights are related (L_lpair's and L_fpair's pairs), and R: 1 or the mirror. */
static int related_pair(const hd_losses *L, int p, float r[HD_SH_COEFFS])
{
    const unsigned char *rel = L->batch->pair_light;
    if (!rel || (rel[p] != HD_PAIR_LIGHT_SAME && rel[p] != HD_PAIR_LIGHT_MIRROR)) return 0;
    for (int k = 0; k < HD_SH_COEFFS; k++) r[k] = 1.0f;
    if (rel[p] == HD_PAIR_LIGHT_MIRROR) hd_light_mirror(r);
    return 1;
}

/* The weight of image b's texels in its own light fit (the rule's skin), in L->fit_mask. */
static const float *face_fit_weight(hd_losses *L, int b)
{
    int HW = L->net->H * L->net->W;
    hd_face_light_weight(L->fit_layout, L->batch->mask + (size_t)b * HW, HW, L->fit_mask);
    return L->fit_mask;
}

/* Image b's own light from shading S on normals N (hd_face_light_fit over the rule's skin: the
 * layout where the mask is > 0.5, weights in L->fit_mask) into f; its lobe into lobe (read with hold). */
static hd_status face_light_of(hd_losses *L, int b, const float *N, const float *S, float *lobe, int hold, float *f)
{
    size_t HW = (size_t)L->net->H * L->net->W;
    return hd_face_light_fit(N, S, L->fit_layout, L->batch->mask + (size_t)b * HW, (int)HW, L->fit_mask, lobe, hold, f);
}

/* f of both images of every related pair (fit_pair on): the lobe of S on N (detached: kept as it
 * is by a gradient check), then the fit of S on N toward it, as hd_face_light computes it. */
static hd_status fit_pair_lights(hd_losses *L)
{
    hd_net *net = L->net;
    int HW = net->H * net->W;
    float r[HD_SH_COEFFS];
    for (int p = 0; L->fit_pair && p < net->B / 2; p++) {
        if (!related_pair(L, p, r)) continue;
        for (int k = 0; k < 2; k++) {
            int b = 2 * p + k;
            const float *N = net->normal + (size_t)b * 3 * HW, *S = net->shading + (size_t)b * HW;
            float *prior = L->fit_prior + (size_t)b * HD_SH_COEFFS, *f = L->fit_light + (size_t)b * HD_SH_COEFFS;
            hd_status st = face_light_of(L, b, N, S, prior, L->hold_light_hat, f);
            if (st != HD_OK) {
                char why[300];
                snprintf(why, sizeof why, "%s", hd_error());
                return hd_fail(st, "the face's own light of image %d: %s", b, why);
            }
        }
    }
    return HD_OK;
}

hd_status hd_losses_prepare(hd_losses *L, const hd_pair_batch *batch, hd_light_target target)
{
    hd_net *net = L->net;
    int B = net->B, HW = net->H * net->W;
    L->batch = batch;
    L->target = target;
    hd_prof_mark pm = hd_prof_now(); /* the benchmarks' profile (core.h): laps */
    for (int b = 0; b < B; b++) {
        const float *N = net->normal + (size_t)b * 3 * HW, *A = net->albedo + (size_t)b * 3 * HW;
        const float *m = batch->mask + (size_t)b * HW, *l = net->light + (size_t)b * HD_SH_COEFFS;
        float *s = L->shade + (size_t)b * HW, *r = L->render + (size_t)b * 3 * HW;
        /* s(N, l) over every pixel; render = m * A * s(N, l) */
        hd_sh_shading_map(N, NULL, HW, l, s);
        for (int c = 0; c < 3; c++)
            for (int p = 0; p < HW; p++) r[(size_t)c * HW + p] = m[p] * A[(size_t)c * HW + p] * s[p];
        hd_prof_lap("shade and render", &pm);
        /* l_hat = argmin sum_p m_p (b(n_p).l - S_p)^2 with n = N_bar (stage 1) or N (stage 2), detached */
        if (L->hold_light_hat) continue;
        if (batch->has_light && batch->has_light[b]) { /* --light-target gt */
            memcpy(L->light_hat + (size_t)b * HD_SH_COEFFS, batch->light_gt + (size_t)b * HD_SH_COEFFS,
                   HD_SH_COEFFS * sizeof(float));
            continue;
        }
        const float *src = target == HD_LIGHT_FROM_COARSE && batch->has_normal[b]
                               ? batch->coarse_normal + (size_t)b * 3 * HW : N;
        float *lh = L->light_hat + (size_t)b * HD_SH_COEFFS;
        const float *S = net->shading + (size_t)b * HW;
        float lobe[HD_SH_COEFFS];
        hd_status st = L->light_from_image  ? image_light(L, b, src, lh)
                       : L->light_from_face ? face_light_of(L, b, src, S, lobe, 0, lh)
                                            : hd_sh_fit(src, S, m, HW, lh);
        if (st != HD_OK) return st;
        for (int k = 0; k < HD_SH_COEFFS; k++)
            if (!isfinite(L->light_hat[b * HD_SH_COEFFS + k]))
                return hd_fail(HD_ERR_NUMERIC, "the least-squares light target of image %d is not finite", b);
        hd_prof_lap("l_hat fit", &pm);
    }
    hd_status st = fit_pair_lights(L);
    hd_prof_lap("fit-pair lights", &pm);
    if (st != HD_OK) return st;
    /* the shading prior's targets, on N_bar or (prior_predicted) on N, detached; a gradient check
     * holds them with light_hat */
    if (!(L->hold_light_hat && L->prior_predicted)) {
        st = prior_targets(L);
        hd_prof_lap("shading prior targets", &pm);
    }
    return st;
}

/* Propagates L->d_shade (dL/ds(N, l)) into d_normal and d_light, then clears it.
 * forward: s_p = sum_k l_k b_k(N_p) */
static void shade_backward(hd_losses *L)
{
    hd_net *net = L->net;
    int B = net->B, HW = net->H * net->W;
    for (int b = 0; b < B; b++) {
        const float *N = net->normal + (size_t)b * 3 * HW, *l = net->light + (size_t)b * HD_SH_COEFFS;
        float *dN = net->d_normal + (size_t)b * 3 * HW, *dl = net->d_light + (size_t)b * HD_SH_COEFFS;
        float *ds = L->d_shade + (size_t)b * HW;
        double dlk[HD_SH_COEFFS] = {0};
        for (int p = 0; p < HW; p++) {
            if (ds[p] == 0.0f) continue;
            float n[3] = {N[p], N[HW + p], N[2 * HW + p]}, g[3], basis[HD_SH_COEFFS];
            hd_sh_shade_grad(l, n, g);
            hd_sh_basis(n, basis);
            dN[p] += ds[p] * g[0];
            dN[HW + p] += ds[p] * g[1];
            dN[2 * HW + p] += ds[p] * g[2];
            for (int k = 0; k < HD_SH_COEFFS; k++) dlk[k] += (double)ds[p] * basis[k];
            ds[p] = 0.0f;
        }
        for (int k = 0; k < HD_SH_COEFFS; k++) dl[k] += (float)dlk[k];
    }
}

/* The domain weight of image b (1 without weights). */
static float wgt(const hd_losses *L, int b) { return L->batch->weight ? L->batch->weight[b] : 1.0f; }

/* L_Irec = mean_m(|I - A*S*g|), S broadcast over colour; g the camera's colour gain of the image
 * (batch->camera_gain; 1, the paper's, where none is recorded or read). */
double hd_loss_reconstruction(hd_losses *L, float scale)
{
    hd_net *net = L->net;
    int B = net->B, HW = net->H * net->W, P = B / 2;
    double sum = 0;
    for (int b = 0; b < B; b++) {
        const float *A = net->albedo + (size_t)b * 3 * HW, *S = net->shading + (size_t)b * HW;
        const float one[3] = {1.0f, 1.0f, 1.0f}, *g = L->batch->camera_gain ? L->batch->camera_gain + (size_t)b * 3 : one;
        float *rec = L->recon + (size_t)b * 3 * HW, *drec = L->d_recon + (size_t)b * 3 * HW;
        for (int c = 0; c < 3; c++)
            for (int p = 0; p < HW; p++) rec[(size_t)c * HW + p] = A[(size_t)c * HW + p] * S[p] * g[c];
        if (scale != 0.0f) memset(drec, 0, (size_t)3 * HW * sizeof(float));
        sum += wgt(L, b) * hd_loss_l1(scale != 0.0f ? drec : NULL, NULL, rec, L->batch->image + (size_t)b * 3 * HW,
                                      L->batch->mask + (size_t)b * HW, 3, HW, scale * wgt(L, b) / P);
        if (scale == 0.0f) continue;
        /* rec = A * S * g: dA += drec * S * g, dS += sum_c drec * A * g */
        float *dA = net->d_albedo + (size_t)b * 3 * HW, *dS = net->d_shading + (size_t)b * HW;
        for (int c = 0; c < 3; c++)
            for (int p = 0; p < HW; p++) {
                dA[(size_t)c * HW + p] += drec[(size_t)c * HW + p] * S[p] * g[c];
                dS[p] += drec[(size_t)c * HW + p] * A[(size_t)c * HW + p] * g[c];
            }
    }
    return sum / P;
}

/* L_a = mean_{m_i m_j}(|A_i - A_j|), once per pair. */
double hd_loss_albedo_consistency(hd_losses *L, float scale)
{
    hd_net *net = L->net;
    int HW = net->H * net->W, P = net->B / 2;
    double sum = 0;
    for (int p = 0; p < P; p++) {
        int i = 2 * p, j = 2 * p + 1;
        const float *mi = L->batch->mask + (size_t)i * HW, *mj = L->batch->mask + (size_t)j * HW;
        for (int q = 0; q < HW; q++) L->weight[q] = mi[q] * mj[q];
        sum += wgt(L, i) * hd_loss_l1(scale != 0.0f ? net->d_albedo + (size_t)i * 3 * HW : NULL,
                                      scale != 0.0f ? net->d_albedo + (size_t)j * 3 * HW : NULL,
                                      net->albedo + (size_t)i * 3 * HW, net->albedo + (size_t)j * 3 * HW, L->weight, 3,
                                      HW, scale * wgt(L, i) / P);
    }
    return sum / P;
}

/* mean_m |x - target| per image b with has[b] (C channels, the domain weight), summed over i and
 * j, mean over pairs; scale times its gradient into dx. The target is detached. */
static double l1_to_target(hd_losses *L, const float *x, float *dx, const float *target, int C,
                           const unsigned char *has, float scale)
{
    hd_net *net = L->net;
    int B = net->B, HW = net->H * net->W, P = B / 2;
    size_t n = (size_t)C * HW;
    double sum = 0;
    for (int b = 0; b < B; b++) {
        if (!has[b]) continue;
        sum += wgt(L, b) * hd_loss_l1(scale != 0.0f ? dx + (size_t)b * n : NULL, NULL, x + (size_t)b * n,
                                      target + (size_t)b * n, L->batch->mask + (size_t)b * HW, C, HW,
                                      scale * wgt(L, b) / P);
    }
    return sum / P;
}

/* mean_m(|A - A_gt|) per image with a ground-truth albedo, summed over i and j, mean over pairs. */
double hd_loss_albedo_supervised(hd_losses *L, float scale)
{
    return l1_to_target(L, L->net->albedo, L->net->d_albedo, L->batch->albedo_gt, 3, L->batch->has_albedo, scale);
}

/* The scale anchor: (A k, S / k) scores the same on every paper term but L_a, which prefers k -> 0;
 * this prior pins the mean shading over the mask, |mean_m S - c| per image, summed over i and j,
 * mean over pairs. L1, so that its pull is bounded: a squared form turned one spike of the shading
 * (mean 20) into a gradient 4,000 times its usual size, and the run's softplus saturated for good.
 * Gradient: dS_p = sign(mean - c) m_p / sum m. On the pair (L->shading_mean_pair) the deviation
 * d = (mean_i + mean_j) / 2 - c is shared by both images (each counted, as above, so the term has
 * the same size): only the subject's scale is pinned, and images of one subject under a brighter
 * and a darker light no longer pull their shading toward one mean against L_a. */
static double mean_over_mask(const float *S, const float *m, int HW, double *ms_out)
{
    double ms = 0, mS = 0;
    for (int p = 0; p < HW; p++) {
        ms += m[p];
        mS += (double)m[p] * S[p];
    }
    *ms_out = ms;
    return ms > 0 ? mS / ms : 0;
}

double hd_loss_shading_mean(hd_losses *L, float scale)
{
    hd_net *net = L->net;
    int B = net->B, HW = net->H * net->W, P = B / 2;
    double sum = 0;
    for (int p = 0; p < P; p++) {
        double mean[2], ms[2], d[2], pull[2];
        for (int k = 0; k < 2; k++) {
            int b = 2 * p + k;
            mean[k] = mean_over_mask(net->shading + (size_t)b * HW, L->batch->mask + (size_t)b * HW, HW, &ms[k]);
            d[k] = mean[k] - L->shading_mean;
            pull[k] = wgt(L, b); /* the weight of the terms that d[k] enters */
        }
        if (L->shading_mean_pair && ms[0] > 0 && ms[1] > 0) {
            /* one d for both images, so each image's pixels get half the pull of both terms */
            d[0] = d[1] = 0.5 * (mean[0] + mean[1]) - L->shading_mean;
            pull[0] = pull[1] = 0.5 * (wgt(L, 2 * p) + wgt(L, 2 * p + 1));
        }
        for (int k = 0; k < 2; k++) {
            int b = 2 * p + k;
            if (ms[k] <= 0) continue;
            sum += wgt(L, b) * fabs(d[k]);
            if (scale == 0.0f) continue;
            float g = (float)(scale * pull[k] / P * (double)((d[k] > 0) - (d[k] < 0)) / ms[k]);
            float *dS = net->d_shading + (size_t)b * HW;
            const float *m = L->batch->mask + (size_t)b * HW;
            for (int q = 0; q < HW; q++) dS[q] += g * m[q];
        }
    }
    return sum / P;
}

double hd_loss_shading_prior(hd_losses *L, float scale)
{
    return l1_to_target(L, L->net->shading, L->net->d_shading, L->prior, 1, L->batch->has_normal, scale);
}

/* L_s = mean_wx(|dx S| / max(|dx S|, 0.01)) + mean_wy(|dy S| / max(|dy S|, 0.01)). */
double hd_loss_shading_smoothness(hd_losses *L, float scale)
{
    hd_net *net = L->net;
    int B = net->B, HW = net->H * net->W, P = B / 2;
    double sum = 0;
    for (int b = 0; b < B; b++)
        sum += wgt(L, b) * hd_loss_smooth(scale != 0.0f ? net->d_shading + (size_t)b * HW : NULL,
                                          net->shading + (size_t)b * HW, L->batch->mask + (size_t)b * HW, net->H, net->W,
                                          HD_SMOOTH_EPS, scale * wgt(L, b) / P);
    return sum / P;
}

/* L_n = sum_p m_p ||N_bar_p - N_p||^2 / sum_p m_p (images without coarse normals contribute 0). */
double hd_loss_normal_prior(hd_losses *L, float scale)
{
    hd_net *net = L->net;
    int B = net->B, HW = net->H * net->W, P = B / 2;
    double sum = 0;
    for (int b = 0; b < B; b++) {
        if (!L->batch->has_normal[b]) continue;
        sum += wgt(L, b) * hd_loss_sqdist(scale != 0.0f ? net->d_normal + (size_t)b * 3 * HW : NULL, NULL,
                                          net->normal + (size_t)b * 3 * HW, L->batch->coarse_normal + (size_t)b * 3 * HW,
                                          L->batch->mask + (size_t)b * HW, 3, HW, scale * wgt(L, b) / P);
    }
    return sum / P;
}

/* L_l = mean_k |l_k - l_hat_k|, l_hat detached. */
double hd_loss_light(hd_losses *L, float scale)
{
    hd_net *net = L->net;
    int B = net->B, P = B / 2;
    double sum = 0;
    for (int b = 0; b < B; b++) {
        const float *l = net->light + (size_t)b * HD_SH_COEFFS, *t = L->light_hat + (size_t)b * HD_SH_COEFFS;
        float *dl = net->d_light + (size_t)b * HD_SH_COEFFS;
        double s = 0;
        for (int k = 0; k < HD_SH_COEFFS; k++) {
            float d = l[k] - t[k];
            s += fabsf(d);
            if (scale != 0.0f) dl[k] += scale * wgt(L, b) / P / HD_SH_COEFFS * (float)((d > 0) - (d < 0));
        }
        sum += wgt(L, b) * s / HD_SH_COEFFS;
    }
    return sum / P;
}

/* L_lpair = mean over pairs of mean_k |d_k|, d = l_j - R l_i (R diagonal, +-1, so R^T = R). */
double hd_loss_light_pair(hd_losses *L, float scale)
{
    hd_net *net = L->net;
    int P = net->B / 2;
    double sum = 0;
    float r[HD_SH_COEFFS];
    for (int p = 0; p < P; p++) {
        if (!related_pair(L, p, r)) continue;
        const float *li = net->light + (size_t)2 * p * HD_SH_COEFFS, *lj = li + HD_SH_COEFFS;
        float *dli = net->d_light + (size_t)2 * p * HD_SH_COEFFS, *dlj = dli + HD_SH_COEFFS;
        double s = 0;
        const float g = scale * wgt(L, 2 * p) / P / HD_SH_COEFFS;
        for (int k = 0; k < HD_SH_COEFFS; k++) {
            float d = lj[k] - r[k] * li[k], sg = (float)((d > 0) - (d < 0));
            s += fabsf(d);
            if (scale != 0.0f) {
                dlj[k] += g * sg;
                dli[k] -= g * sg * r[k];
            }
        }
        sum += wgt(L, 2 * p) * s / HD_SH_COEFFS;
    }
    return sum / P;
}

/* L_fpair = mean over pairs of mean_k |d_k|, d = f_j - R f_i. With g = dL/df of one image and y =
 * M^-1 g (the fit's adjoint), f = M^-1 r, r = sum_p w_p S_p b(n_p) + lambda prior, M = sum_p w_p
 * b b^T + (ridge + lambda) I:  dS_p = w_p s(n_p, y),
 * dN_p = w_p [(S_p - s(n_p, f)) grad_n s(n_p, y) - s(n_p, y) grad_n s(n_p, f)]
 * (the ridge's own change with N, 1e-6 of the trace, is left out). */
double hd_loss_fit_pair(hd_losses *L, float scale)
{
    hd_net *net = L->net;
    int P = net->B / 2, HW = net->H * net->W;
    double sum = 0;
    float r[HD_SH_COEFFS];
    for (int p = 0; L->fit_pair && p < P; p++) {
        if (!related_pair(L, p, r)) continue;
        const float *fi = L->fit_light + (size_t)2 * p * HD_SH_COEFFS, *fj = fi + HD_SH_COEFFS;
        float g[2][HD_SH_COEFFS];
        const float gs = scale * wgt(L, 2 * p) / P / HD_SH_COEFFS;
        double s = 0;
        for (int k = 0; k < HD_SH_COEFFS; k++) {
            float d = fj[k] - r[k] * fi[k], sg = (float)((d > 0) - (d < 0));
            s += fabsf(d);
            g[1][k] = gs * sg;
            g[0][k] = -gs * sg * r[k];
        }
        sum += wgt(L, 2 * p) * s / HD_SH_COEFFS;
        if (scale == 0.0f) continue;
        for (int k = 0; k < 2; k++) {
            int b = 2 * p + k;
            const float *N = net->normal + (size_t)b * 3 * HW, *S = net->shading + (size_t)b * HW, *w = face_fit_weight(L, b);
            const float *f = L->fit_light + (size_t)b * HD_SH_COEFFS;
            float *dN = net->d_normal + (size_t)b * 3 * HW, *dS = net->d_shading + (size_t)b * HW, y[HD_SH_COEFFS];
            if (hd_sh_fit_adjoint(N, w, HW, HD_SOURCE_PRIOR, g[k], y) != HD_OK) continue; /* prepare solved it */
            for (int q = 0; q < HW; q++) {
                if (!(w[q] > 0.0f)) continue;
                float n[3] = {N[q], N[HW + q], N[2 * HW + q]}, gy[3], gf[3];
                float sy = hd_sh_shade_grad(y, n, gy), res = S[q] - hd_sh_shade_grad(f, n, gf);
                dS[q] += w[q] * sy;
                for (int c = 0; c < 3; c++) dN[(size_t)c * HW + q] += w[q] * (res * gy[c] - sy * gf[c]);
            }
        }
    }
    return sum / P;
}

/* L_Srec = mean_m(|S - s(N, l)|): reaches S, N and l. */
double hd_loss_shading_reconstruction(hd_losses *L, float scale)
{
    hd_net *net = L->net;
    int B = net->B, HW = net->H * net->W, P = B / 2;
    double sum = 0;
    for (int b = 0; b < B; b++)
        sum += wgt(L, b) * hd_loss_l1(scale != 0.0f ? net->d_shading + (size_t)b * HW : NULL,
                                      scale != 0.0f ? L->d_shade + (size_t)b * HW : NULL, net->shading + (size_t)b * HW,
                                      L->shade + (size_t)b * HW, L->batch->mask + (size_t)b * HW, 1, HW,
                                      scale * wgt(L, b) / P);
    if (scale != 0.0f) shade_backward(L);
    return sum / P;
}

/* The profile the discriminator's passes add their time to (the benchmarks'), or NULL. */
static hd_net_profile *disc_profile(const hd_losses *L)
{
    return L->pass ? L->pass->profile : NULL;
}

/* L_adv = mean over patch logits of softplus(-D(m A s(N, l))) for i and j: with B = 2P images,
 * the mean over pairs of the two per-image means is 2 * (the mean over all B * patches logits). */
double hd_loss_adversarial(hd_losses *L, float scale)
{
    hd_net *net = L->net;
    hd_disc *D = L->disc;
    size_t B = (size_t)net->B, HW = (size_t)net->H * net->W, n = B * (size_t)hd_disc_patches(D);
    memcpy(D->in, L->render, B * 3 * HW * sizeof(float));
    hd_disc_forward(D, disc_profile(L));
    memset(D->d_logit, 0, n * sizeof(float));
    double loss = 2.0 * hd_loss_bce_logits(scale != 0.0f ? D->d_logit : NULL, D->logit, n, 1, 2.0f * scale);
    if (scale == 0.0f) return loss;
    memset(D->d_in, 0, B * 3 * HW * sizeof(float));
    hd_disc_backward(D, 1, 0, disc_profile(L));
    /* render = m * A * s: dA += g * m * s, ds += sum_c g * m * A */
    for (size_t b = 0; b < B; b++) {
        const float *m = L->batch->mask + b * HW, *s = L->shade + b * HW, *A = net->albedo + b * 3 * HW;
        const float *g = D->d_in + b * 3 * HW;
        float *dA = net->d_albedo + b * 3 * HW, *ds = L->d_shade + b * HW;
        for (size_t c = 0; c < 3; c++)
            for (size_t p = 0; p < HW; p++) {
                dA[c * HW + p] += g[c * HW + p] * m[p] * s[p];
                ds[p] += g[c * HW + p] * m[p] * A[c * HW + p];
            }
    }
    shade_backward(L);
    return loss;
}

/* L_D = mean softplus(-D(m I)) + mean softplus(D(render)), i and j, mean over pairs. */
double hd_loss_discriminator(hd_losses *L, float scale)
{
    hd_disc *D = L->disc;
    size_t B = (size_t)D->B, HW = (size_t)D->H * D->W, n = B * (size_t)hd_disc_patches(D);
    int grad = scale != 0.0f;
    for (size_t b = 0; b < B; b++) {
        const float *m = L->batch->mask + b * HW, *I = L->batch->image + b * 3 * HW;
        float *x = D->in + b * 3 * HW;
        for (size_t c = 0; c < 3; c++)
            for (size_t p = 0; p < HW; p++) x[c * HW + p] = m[p] * I[c * HW + p];
    }
    hd_disc_forward(D, disc_profile(L));
    memset(D->d_logit, 0, n * sizeof(float));
    double real = 2.0 * hd_loss_bce_logits(grad ? D->d_logit : NULL, D->logit, n, 1, 2.0f * scale);
    if (grad) hd_disc_backward(D, 0, 1, disc_profile(L));
    memcpy(D->in, L->render, B * 3 * HW * sizeof(float));
    hd_disc_forward(D, disc_profile(L));
    memset(D->d_logit, 0, n * sizeof(float));
    double fake = 2.0 * hd_loss_bce_logits(grad ? D->d_logit : NULL, D->logit, n, 0, 2.0f * scale);
    if (grad) hd_disc_backward(D, 0, 1, disc_profile(L));
    return real + fake;
}

double hd_losses_generator(hd_losses *L, const hd_loss_weights *w, double terms[HD_LOSS_TERMS], int grad)
{
    float s[HD_LOSS_TERMS];
    for (int k = 0; k < HD_LOSS_TERMS; k++) s[k] = grad ? w->w[k] : 0.0f;
    /* each term a phase of the benchmarks' profile (core.h) */
#define TERM(k, fn)                      \
    do {                                 \
        hd_prof_begin(hd_loss_names[k]); \
        terms[k] = fn(L, s[k]);          \
        hd_prof_end();                   \
    } while (0)
    TERM(HD_LOSS_REC, hd_loss_reconstruction);
    TERM(HD_LOSS_ALBEDO, hd_loss_albedo_consistency);
    TERM(HD_LOSS_SMOOTH, hd_loss_shading_smoothness);
    TERM(HD_LOSS_NORMAL, hd_loss_normal_prior);
    TERM(HD_LOSS_LIGHT, hd_loss_light);
    TERM(HD_LOSS_SREC, hd_loss_shading_reconstruction);
    TERM(HD_LOSS_ADV, hd_loss_adversarial);
    TERM(HD_LOSS_ALBEDO_GT, hd_loss_albedo_supervised);
    TERM(HD_LOSS_SHADING_MEAN, hd_loss_shading_mean);
    TERM(HD_LOSS_SHADING_PRIOR, hd_loss_shading_prior);
    TERM(HD_LOSS_LIGHT_PAIR, hd_loss_light_pair);
    TERM(HD_LOSS_FIT_PAIR, hd_loss_fit_pair);
#undef TERM
    double total = 0;
    for (int k = 0; k < HD_LOSS_TERMS; k++) total += (double)w->w[k] * terms[k];
    return total;
}
