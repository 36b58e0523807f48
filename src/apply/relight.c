/* relight.c: what a user does with a decomposition (the paper's relighting, section "Using a
 * model" of docs/usage.md). The final albedo is the input over the predicted shading,
 *     A_final = clamp(I / max(S, HD_SHADING_FLOOR), 0, 1)        per colour channel,
 * which keeps every detail of the input that the network's own albedo smooths away; the relit face
 * is A_final * max(s(N, l_target), 0), optionally scaled to keep the input's mean brightness over
 * the mask, and blended with the input by the mask. Delighting is relighting under flat light
 * (s = 1); transfer relights under the light estimated for another face. */
#include <math.h>
#include <string.h>
#include "core/core.h"
#include "apply/apply.h"

static float clamp01(float v) { return v < 0.0f ? 0.0f : v > 1.0f ? 1.0f : v; }

/* The decomposition's maps brought to the image's size: pointers into d where the sizes agree,
 * resized copies (owned here) where they do not. */
typedef struct face_maps {
    const float *shading; /* (HW) */
    const float *normal;  /* (3, HW) unit */
    const float *mask;    /* (HW) in [0, 1], NULL = all ones */
    hd_image own_shading, own_normal, own_mask;
} face_maps;

static void face_maps_free(face_maps *m)
{
    hd_image_free(&m->own_shading);
    hd_image_free(&m->own_normal);
    hd_image_free(&m->own_mask);
}

/* Checks the inputs and fills m at the image's size. */
static hd_status face_maps_get(const hd_image *image, const hd_decomposition *d, const hd_image *mask, face_maps *m)
{
    memset(m, 0, sizeof *m);
    if (!image || !image->data || image->channels != 3)
        return hd_fail(HD_ERR_ARG, "relight: the image must have 3 channels (has %d)", image ? image->channels : 0);
    const hd_image *s = &d->shading, *n = &d->normal;
    if (!s->data || !n->data || s->channels != 1 || n->channels != 3 || s->width != n->width ||
        s->height != n->height)
        return hd_fail(HD_ERR_ARG, "relight: the decomposition's shading (1 channel) and normals (3) disagree");
    if (mask && (!mask->data || mask->channels != 1))
        return hd_fail(HD_ERR_ARG, "relight: a mask has 1 channel (has %d)", mask->channels);
    const int W = image->width, H = image->height;
    const size_t HW = (size_t)W * (size_t)H;
    hd_status st = HD_OK;
    if (s->width == W && s->height == H) {
        m->shading = s->data;
        m->normal = n->data;
    } else {
        st = hd_image_resize(s, W, H, &m->own_shading);
        if (st == HD_OK) st = hd_image_resize(n, W, H, &m->own_normal);
        if (st != HD_OK) goto fail;
        /* bilinear blends of unit vectors are shorter: n / |n| */
        float *x = m->own_normal.data, *y = x + HW, *z = y + HW;
        for (size_t p = 0; p < HW; p++) {
            float len = sqrtf(x[p] * x[p] + y[p] * y[p] + z[p] * z[p]);
            float inv = len > 1e-6f ? 1.0f / len : 0.0f;
            x[p] *= inv;
            y[p] *= inv;
            z[p] *= inv;
        }
        m->shading = m->own_shading.data;
        m->normal = m->own_normal.data;
    }
    if (mask) {
        if (mask->width == W && mask->height == H) {
            m->mask = mask->data;
        } else {
            st = hd_image_resize(mask, W, H, &m->own_mask);
            if (st != HD_OK) goto fail;
            m->mask = m->own_mask.data;
        }
    }
    return HD_OK;
fail:
    face_maps_free(m);
    return st;
}

static float mask_at(const face_maps *m, size_t p) { return m->mask ? clamp01(m->mask[p]) : 1.0f; }

/* sum_p m_p sum_c min(k R_cp, 1) for R >= 0. */
static double clamped_sum(const float *relit, size_t HW, const face_maps *m, double k)
{
    double acc = 0.0;
    for (int c = 0; c < 3; c++)
        for (size_t p = 0; p < HW; p++) {
            double v = k * relit[(size_t)c * HW + p];
            acc += mask_at(m, p) * (v > 1.0 ? 1.0 : v);
        }
    return acc;
}

/* The brightness factor k >= 0 with sum_p m_p sum_c clamp(k R_cp, 0, 1) = sum_p m_p sum_c I_cp
 * (R >= 0). The left side is continuous and nondecreasing in k: start from the unclamped solution
 * k0 = target / sum m R (exact unless some k0 R > 1), then bisect above it. When the target cannot
 * be reached (too few lit pixels) the largest factor tried is returned; with nothing lit, 1. */
static double brightness_factor(const float *relit, const hd_image *image, const face_maps *m)
{
    const size_t HW = (size_t)image->width * (size_t)image->height;
    double target = 0.0, lit = 0.0;
    for (int c = 0; c < 3; c++)
        for (size_t p = 0; p < HW; p++) {
            double w = mask_at(m, p);
            target += w * image->data[(size_t)c * HW + p];
            lit += w * relit[(size_t)c * HW + p];
        }
    if (!(lit > 0.0) || !(target > 0.0)) return 1.0;
    const double k0 = target / lit;
    double f = clamped_sum(relit, HW, m, k0);
    if (f >= target * (1.0 - 1e-9)) return k0;
    double lo = k0, hi = k0;
    for (int i = 0; i < 40; i++) { /* up to 2^40 k0 */
        hi *= 2.0;
        f = clamped_sum(relit, HW, m, hi);
        if (f >= target) break;
        lo = hi;
    }
    if (f < target) return hi;
    for (int i = 0; i < 60 && hi - lo > 1e-9 * hi; i++) {
        double mid = 0.5 * (lo + hi);
        if (clamped_sum(relit, HW, m, mid) < target) lo = mid;
        else hi = mid;
    }
    return hi;
}

/* The shared path: light NULL means flat light (s = 1) without brightness matching. */
hd_status hd_relight_paper(const hd_image *image, const hd_decomposition *d, const hd_image *mask, const float *light,
                           hd_brightness brightness, hd_image *out)
{
    memset(out, 0, sizeof *out);
    face_maps m;
    hd_status st = face_maps_get(image, d, mask, &m);
    if (st != HD_OK) return st;
    if (light)
        for (int k = 0; k < HD_SH_COEFFS; k++)
            if (!isfinite(light[k])) {
                face_maps_free(&m);
                return hd_fail(HD_ERR_NUMERIC, "relight: light coefficient %d is not finite", k);
            }
    const int W = image->width, H = image->height;
    const size_t HW = (size_t)W * (size_t)H;
    hd_image target = {0};
    st = hd_image_alloc(out, W, H, 3);
    if (st == HD_OK) st = hd_image_alloc(&target, W, H, 1);
    if (st != HD_OK) goto done;
    if (light) {
        hd_sh_shading_map(m.normal, NULL, (int)HW, light, target.data); /* s(N, l) */
        for (size_t p = 0; p < HW; p++) target.data[p] = target.data[p] > 0.0f ? target.data[p] : 0.0f;
    } else {
        for (size_t p = 0; p < HW; p++) target.data[p] = 1.0f;
    }
    /* relit = A_final * s, A_final = clamp(I / max(S, floor), 0, 1) */
    for (int c = 0; c < 3; c++)
        for (size_t p = 0; p < HW; p++) {
            float s = m.shading[p] > HD_SHADING_FLOOR ? m.shading[p] : HD_SHADING_FLOOR;
            out->data[(size_t)c * HW + p] = clamp01(image->data[(size_t)c * HW + p] / s) * target.data[p];
        }
    double k = light && brightness == HD_BRIGHTNESS_KEEP ? brightness_factor(out->data, image, &m) : 1.0;
    /* out = m * clamp(k relit) + (1 - m) * I */
    for (int c = 0; c < 3; c++)
        for (size_t p = 0; p < HW; p++) {
            size_t i = (size_t)c * HW + p;
            float w = mask_at(&m, p);
            out->data[i] = w * clamp01((float)(k * out->data[i])) + (1.0f - w) * image->data[i];
        }
done:
    hd_image_free(&target);
    face_maps_free(&m);
    if (st != HD_OK) hd_image_free(out);
    return st;
}

hd_status hd_relight_albedo(const hd_image *image, const hd_decomposition *d, hd_image *albedo)
{
    return hd_relight_paper(image, d, NULL, NULL, HD_BRIGHTNESS_FREE, albedo);
}

hd_status hd_relight(const hd_image *image, const hd_decomposition *d, const hd_image *mask,
                     const float light[HD_SH_COEFFS], hd_brightness brightness, hd_image *out)
{
    if (!light) return hd_fail(HD_ERR_ARG, "relight: no target light");
    return hd_relight_paper(image, d, mask, light, brightness, out);
}

hd_status hd_delight(const hd_image *image, const hd_decomposition *d, const hd_image *mask, hd_image *out)
{
    return hd_relight_paper(image, d, mask, NULL, HD_BRIGHTNESS_FREE, out);
}

hd_status hd_transfer(const hd_image *image, const hd_decomposition *d, const hd_image *mask,
                      const hd_decomposition *ref, hd_brightness brightness, hd_image *out)
{
    return hd_relight_paper(image, d, mask, ref->light, brightness, out);
}
