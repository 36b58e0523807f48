/* rule.c: the relighting rule (docs/usage.md, "The relighting rule"). A face is relit by a change
 * of shading, never by dividing the photo by the network's shading:
 *     out = I * r,   r = (s(N, l_target) + g) / (s(N, l_source) + g)
 * with N the predicted normals, l_source the face's own light (hd_face_light: the least-squares
 * light of the predicted shading on N over the skin, the face below the nose weighted down
 * (hd_face_fit_weight_uv), pulled toward the best ambient + distant light of the same shading;
 * or L-Net's) and g a guard (a share of the
 * face's mean source shading, HD_RATIO_GUARD by default) where the denominator is small. r is exactly 1 when the
 * light does not change, is one factor for all three channels under a grey light, and is smooth
 * because it is a ratio of two low-order renders. Where the model does not explain the face (eyes,
 * the inside of the mouth, brows: src/mesh/regions.c) and outside the face's mask, log r is filled
 * from the skin around, so that the eyes, the mouth and the brows change as the skin around them does; the
 * field is then blurred a little, feathered to nothing at the face's edge and applied with one
 * brightness factor. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "apply/apply.h"
#include "mesh/mesh.h"
#include "light/light.h"

/* the blur of log r, a share of the texture side */
#define RATIO_BLUR 0.012f
/* Cast shadows (cast_shadow.c): how far under the face, in cm, a ray toward the light must pass to
 * be in full shadow, and the least share of a texel's shading a shadow leaves (what the room, the
 * light's size and the skin's own glow bring into a shadow). */
#define SHADOW_SOFTNESS 0.3f
#define SHADOW_FLOOR 0.4f
#define SHADOW_SIDE 128

static const double LUMA[3] = {0.2126, 0.7152, 0.0722};

/* Unit normals of d at size x size (bilinear, renormalised). */
static hd_status normals_at(const hd_decomposition *d, int size, hd_image *out)
{
    hd_status st = hd_image_resize(&d->normal, size, size, out);
    if (st != HD_OK) return st;
    size_t P = (size_t)size * size;
    float *x = out->data, *y = x + P, *z = y + P;
    for (size_t p = 0; p < P; p++) {
        float len = sqrtf(x[p] * x[p] + y[p] * y[p] + z[p] * z[p]);
        float inv = len > 1e-6f ? 1.0f / len : 0.0f;
        x[p] *= inv, y[p] *= inv, z[p] *= inv;
    }
    return HD_OK;
}

/* The skin at size x size: 1 where mask (NULL: everywhere) is > 0.5 outside the face regions. */
static hd_status skin_at(const hd_image *mask, int size, hd_image *skin)
{
    hd_image m = {0};
    hd_status st = mask ? hd_image_resize(mask, size, size, &m) : HD_OK;
    if (st == HD_OK) st = hd_face_regions_uv(size, skin);
    for (size_t p = 0; st == HD_OK && p < (size_t)size * size; p++)
        skin->data[p] = (!m.data || m.data[p] > 0.5f) && skin->data[p] <= 0.5f ? 1.0f : 0.0f;
    hd_image_free(&m);
    if (st != HD_OK) hd_image_free(skin);
    return st;
}

hd_status hd_face_light(const hd_decomposition *d, const hd_image *mask, hd_source_light source,
                        float light[HD_SH_COEFFS])
{
    memset(light, 0, HD_SH_COEFFS * sizeof *light);
    if (!d) return hd_fail(HD_ERR_ARG, "face light: no decomposition");
    if (source == HD_SOURCE_LNET) {
        memcpy(light, d->light, sizeof d->light);
        return HD_OK;
    }
    if (source != HD_SOURCE_FIT) return hd_fail(HD_ERR_ARG, "face light: unknown source %d", (int)source);
    const int size = d->shading.width;
    if (!d->shading.data || d->shading.channels != 1 || d->shading.height != size || !d->normal.data ||
        d->normal.channels != 3 || d->normal.width != size || d->normal.height != size)
        return hd_fail(HD_ERR_ARG,
                       "face light: the decomposition's shading and normals are not square maps of one size");
    if (mask && (!mask->data || mask->channels != 1)) return hd_fail(HD_ERR_ARG, "face light: a mask has 1 channel");
    hd_image m = {0}, layout = {0};
    float *weight = hd_malloc((size_t)size * size * sizeof(float)), lobe[HD_SH_COEFFS];
    hd_status st = weight ? HD_OK : HD_ERR_NOMEM;
    if (st == HD_OK && mask) st = hd_image_resize(mask, size, size, &m);
    if (st == HD_OK) st = hd_face_light_layout(size, &layout);
    if (st == HD_OK)
        st = hd_face_light_fit(d->normal.data, d->shading.data, layout.data, m.data, size * size, weight, lobe, 0, light);
    hd_image_free(&m);
    hd_image_free(&layout);
    free(weight);
    return st;
}

hd_status hd_reference_light(const hd_decomposition *d, const hd_image *mask, hd_source_light source,
                             float light[HD_SH_COEFFS])
{
    memset(light, 0, HD_SH_COEFFS * sizeof *light);
    if (!d || source != HD_SOURCE_FIT) return hd_face_light(d, mask, source, light);
    const int size = d->shading.width;
    if (!d->shading.data || d->shading.channels != 1 || d->shading.height != size || !d->normal.data ||
        d->normal.channels != 3 || d->normal.width != size || d->normal.height != size)
        return hd_fail(HD_ERR_ARG,
                       "reference light: the decomposition's shading and normals are not square maps of one size");
    if (mask && (!mask->data || mask->channels != 1))
        return hd_fail(HD_ERR_ARG, "reference light: a mask has 1 channel");
    hd_image m = {0}, layout = {0};
    float *weight = hd_malloc((size_t)size * size * sizeof(float));
    hd_status st = weight ? HD_OK : HD_ERR_NOMEM;
    if (st == HD_OK && mask) st = hd_image_resize(mask, size, size, &m);
    if (st == HD_OK) st = hd_face_light_layout(size, &layout);
    if (st == HD_OK)
        st = hd_reference_light_fit(d->normal.data, d->shading.data, layout.data, m.data, size * size, weight, light);
    hd_image_free(&m);
    hd_image_free(&layout);
    free(weight);
    return st;
}

/* The shadows the face casts under light (cast_shadow.c), at size x size: s'(n) = max(s(n) - (1 - V)
 * max(s_d(n), 0), SHADOW_FLOOR s(n)), s_d the distant part of the light (hd_light_distant_part) and V
 * the texel's share of it; shading (P floats, s) is changed in place. vis: the visibility map of the
 * light's direction, computed here when vis->data is NULL (kept for the caller to free); scratch:
 * P floats. */
static hd_status cast_shadows(const float *normal, size_t P, int size, const float *rotation,
                              const float light[HD_SH_COEFFS], const float direction[3], hd_image *vis, float *shading,
                              float *scratch)
{
    float own_direction[3], part[HD_SH_COEFFS]; /* light's own: a channel's may differ from direction */
    hd_light_distant_part(light, own_direction, part);
    if (!vis->data) {
        const hd_mesh *mesh = NULL;
        hd_status st = hd_mesh_canonical(&mesh);
        /* at half the side past SHADOW_SIDE texels: the field is blurred by more than a texel */
        const int side = size > SHADOW_SIDE ? size / 2 : size;
        hd_image half = {0};
        if (st == HD_OK) st = hd_mesh_cast_shadow_uv(mesh, rotation, direction, side, SHADOW_SOFTNESS, side == size ? vis : &half);
        if (st == HD_OK && side != size) st = hd_image_resize(&half, size, size, vis);
        hd_image_free(&half);
        if (st != HD_OK) return st;
    }
    hd_sh_shading_map(normal, NULL, (int)P, part, scratch);
    for (size_t p = 0; p < P; p++) {
        const float s = shading[p], direct = scratch[p] > 0 ? scratch[p] : 0.0f;
        const float lit = s - (1 - vis->data[p]) * direct;
        shading[p] = lit > SHADOW_FLOOR * s ? lit : SHADOW_FLOOR * s;
    }
    return HD_OK;
}

hd_status hd_ratio_field(const hd_decomposition *d, const hd_image *mask, int size, const float source[HD_SH_COEFFS],
                         float guard, const hd_light_rgb *target, const float *rotation, hd_image *log_ratio)
{
    memset(log_ratio, 0, sizeof *log_ratio);
    if (!d || !d->normal.data || d->normal.channels != 3)
        return hd_fail(HD_ERR_ARG, "relight: the decomposition has no normals");
    if (mask && (!mask->data || mask->channels != 1)) return hd_fail(HD_ERR_ARG, "relight: a mask has 1 channel");
    for (int k = 0; k < HD_SH_COEFFS; k++)
        if (!isfinite(source[k])) return hd_fail(HD_ERR_NUMERIC, "relight: the face's light coefficient %d is not finite", k);
    const int channels = target && !hd_light_rgb_is_grey(target) ? 3 : 1;
    if (target)
        for (int c = 0; c < 3; c++)
            for (int k = 0; k < HD_SH_COEFFS; k++)
                if (!isfinite(target->sh[c][k]))
                    return hd_fail(HD_ERR_NUMERIC, "relight: light coefficient %d of channel %d is not finite", k, c);
    const size_t P = (size_t)size * size;
    hd_image n = {0}, skin = {0}, src = {0}, vis_src = {0}, vis_target = {0};
    hd_status st = normals_at(d, size, &n);
    if (st == HD_OK) st = skin_at(mask, size, &skin);
    if (st == HD_OK) st = hd_image_alloc(&src, size, size, 1);
    if (st == HD_OK) st = hd_image_alloc(log_ratio, size, size, channels);
    float *scratch = st == HD_OK ? hd_malloc(P * sizeof(float)) : NULL;
    if (st == HD_OK && !scratch) st = HD_ERR_NOMEM;
    const float *known = skin.data; /* 1 where log r is the model's, 0 where it is filled */
    if (st == HD_OK) {
        hd_sh_shading_map(n.data, NULL, (int)P, source, src.data);
        double mean = 0, count = 0;
        for (size_t p = 0; p < P; p++) {
            if (src.data[p] < 0) src.data[p] = 0;
            if (known[p] > 0) mean += src.data[p], count++;
        }
        const float share = guard > 0 && isfinite(guard) ? guard : HD_RATIO_GUARD;
        const float g = share * (count > 0 && mean > 0 ? (float)(mean / count) : 1.0f);
        /* with the head's pose, both lights cast the face's shadows: the source's are in the photo
         * already, and a light that does not change still changes nothing */
        float dir_src[3], dir_target[3], part[HD_SH_COEFFS];
        if (rotation) {
            hd_light_distant_part(source, dir_src, part);
            st = cast_shadows(n.data, P, size, rotation, source, dir_src, &vis_src, src.data, scratch);
        }
        if (st == HD_OK && rotation && target) {
            float grey[HD_SH_COEFFS];
            for (int k = 0; k < HD_SH_COEFFS; k++) grey[k] = (target->sh[0][k] + target->sh[1][k] + target->sh[2][k]) / 3;
            hd_light_distant_part(grey, dir_target, part);
            /* the same direction as the source's: the same shadows */
            if (memcmp(dir_target, dir_src, sizeof dir_src) == 0) vis_target = vis_src, vis_src.data = NULL;
        }
        for (int c = 0; c < channels && st == HD_OK; c++) {
            float *lr = log_ratio->data + (size_t)c * P;
            if (target) hd_sh_shading_map(n.data, NULL, (int)P, target->sh[c], lr);
            else for (size_t p = 0; p < P; p++) lr[p] = 1.0f; /* flat light: the albedo's level */
            for (size_t p = 0; p < P; p++) lr[p] = lr[p] > 0 ? lr[p] : 0.0f;
            if (rotation && target)
                st = cast_shadows(n.data, P, size, rotation, target->sh[c], dir_target, &vis_target, lr, scratch);
            for (size_t p = 0; st == HD_OK && p < P; p++) {
                const float t = lr[p];
                lr[p] = t == src.data[p] ? 0.0f : logf((t + g) / (src.data[p] + g));
            }
            if (st == HD_OK) st = hd_field_fill(lr, known, size, size);
            if (st == HD_OK) st = hd_field_blur(lr, size, size, RATIO_BLUR * size);
        }
    }
    free(scratch);
    hd_image_free(&n);
    hd_image_free(&skin);
    hd_image_free(&src);
    hd_image_free(&vis_src);
    hd_image_free(&vis_target);
    if (st != HD_OK) hd_image_free(log_ratio);
    return st;
}

/* The lw-weighted mean luminance of the pixels idx relit with weights lw (the picture whose
 * brightness is kept: with the body relit, the one with the body near the neck alone) for brightness
 * offset t, unclamped. */
static double relit_lum(const hd_image *lr, const float *lw, const hd_image *im, const size_t *idx, size_t n, double t)
{
    const size_t P = (size_t)im->width * (size_t)im->height;
    double acc = 0;
    for (size_t i = 0; i < n; i++) {
        size_t p = idx[i];
        for (int c = 0; c < 3; c++) {
            const float *l = lr->data + (size_t)(lr->channels == 3 ? c : 0) * P;
            acc += lw[p] * LUMA[c] * im->data[c * P + p] * exp(lw[p] * (l[p] + t));
        }
    }
    return acc;
}

hd_status hd_ratio_apply(const hd_image *log_ratio, const float *weight, const float *level, hd_brightness brightness,
                         hd_image *image, double *offset)
{
    if (offset) *offset = 0.0;
    if (!image || !image->data || image->channels != 3 || !log_ratio || !log_ratio->data ||
        (log_ratio->channels != 1 && log_ratio->channels != 3) || log_ratio->width != image->width ||
        log_ratio->height != image->height)
        return hd_fail(HD_ERR_ARG, "relight: the ratio field (%d channels, %d x %d) does not fit the %d x %d picture",
                       log_ratio ? log_ratio->channels : 0, log_ratio ? log_ratio->width : 0,
                       log_ratio ? log_ratio->height : 0, image ? image->width : 0, image ? image->height : 0);
    const size_t P = (size_t)image->width * (size_t)image->height;
    const int C = log_ratio->channels;
    float *ones = NULL;
    if (!weight) {
        if (!(ones = hd_malloc((P ? P : 1) * sizeof(float)))) return HD_ERR_NOMEM;
        for (size_t p = 0; p < P; p++) ones[p] = 1.0f;
        weight = ones;
    }
    if (!level) level = weight;
    size_t *idx = hd_malloc((P ? P : 1) * sizeof *idx), n = 0;
    if (!idx) {
        free(ones);
        return HD_ERR_NOMEM;
    }
    int changes = 0;
    for (size_t p = 0; p < P; p++)
        if (weight[p] > 0) {
            idx[n++] = p;
            for (int c = 0; c < C; c++) changes |= log_ratio->data[(size_t)c * P + p] != 0.0f;
        }
    double t = 0.0;
    if (changes && brightness == HD_BRIGHTNESS_KEEP) {
        /* the mean luminance grows with t: bisection for the input's */
        double goal = 0;
        for (size_t i = 0; i < n; i++)
            for (int c = 0; c < 3; c++) goal += level[idx[i]] * LUMA[c] * image->data[c * P + idx[i]];
        double lo = -4.0, hi = 4.0;
        for (int it = 0; it < 50 && goal > 0; it++) {
            double mid = 0.5 * (lo + hi);
            if (relit_lum(log_ratio, level, image, idx, n, mid) < goal) lo = mid;
            else hi = mid;
        }
        t = goal > 0 ? 0.5 * (lo + hi) : 0.0;
    }
    if (offset) *offset = t;
    for (size_t i = 0; changes && i < n; i++) {
        size_t p = idx[i];
        float w = weight[p];
        if (C == 1) {
            /* one factor for the pixel, limited so that no channel passes 1: the colour is kept */
            float f = (float)exp(w * (log_ratio->data[p] + t)), top = 0;
            for (int c = 0; c < 3; c++) top = fmaxf(top, image->data[c * P + p]);
            if (top > 0 && f * top > 1.0f) f = 1.0f / top;
            for (int c = 0; c < 3; c++) image->data[c * P + p] *= f;
        } else {
            for (int c = 0; c < 3; c++) {
                float v = image->data[c * P + p] * (float)exp(w * (log_ratio->data[(size_t)c * P + p] + t));
                image->data[c * P + p] = v > 1.0f ? 1.0f : v;
            }
        }
    }
    free(idx);
    free(ones);
    return HD_OK;
}
