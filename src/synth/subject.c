/* subject.c: one synthetic identity, drawn from the subject's own RNG stream (seed, subject):
 *   shape   the canonical mesh scaled in width, length and depth, plus smooth radial-basis bumps
 *           anchored at landmark vertices (forehead, brow ridge, eye sockets, nose length, width,
 *           bridge and tip, cheeks and cheekbones, lips, chin, jaw), mirrored pairs sharing an
 *           amplitude up to a small asymmetry;
 *   detail  a height field at texel resolution (pores, skin undulation, forehead wrinkles, crow's
 *           feet, nasolabial folds, alar creases, the mentolabial groove, lip volume, the eyeballs)
 *           kept as its gradient, which perturbs the normals;
 *   albedo  a skin tone drawn from measured CIELAB ranges of human skin (docs/synthetic-data.md),
 *           low-frequency blotches, cheek and nose redness, darker skin around the eyes,
 *           freckles and moles at several scales, lips, eyebrows, eyes (sclera, iris, pupil) and
 *           optional stubble.
 * Everything a subject's images share lives here, so the albedo is identical across them. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "synth/synth_internal.h"
#include "synth/synth.h"

/* A bump: vertex displacement amp * exp(-|p - p_anchor|^2 / (2 sigma^2)) * dir (cm). A mirror
 * vertex >= 0 gets the same bump with dir.x negated. */
typedef struct bump {
    int vertex, mirror;
    float dir[3];
    float sigma, amp_std; /* cm */
} bump;

static const bump BUMPS[] = {
    {151, -1, {0, 0.3f, 1}, 3.5f, 0.35f},   /* forehead slope */
    {10, -1, {0, 1, 0}, 3.0f, 0.45f},       /* forehead height */
    {105, 334, {0, 0, 1}, 1.5f, 0.25f},     /* brow ridge */
    {66, 296, {0, 0.5f, 1}, 1.2f, 0.2f},    /* inner brow */
    {159, 386, {0, 0, 1}, 1.0f, 0.22f},     /* upper eye socket */
    {145, 374, {0, 0, 1}, 1.0f, 0.18f},     /* lower lid / socket */
    {1, -1, {0, -1, 0.3f}, 1.3f, 0.3f},     /* nose length */
    {4, -1, {0, 0, 1}, 1.0f, 0.3f},         /* nose tip protrusion */
    {129, 358, {-1, 0, 0}, 0.9f, 0.22f},    /* nose width (wings) */
    {6, -1, {0, 0, 1}, 1.0f, 0.25f},        /* nose bridge, upper */
    {195, -1, {0, 0, 1}, 0.9f, 0.25f},      /* nose bridge, lower (hump) */
    {50, 280, {-0.4f, 0, 1}, 2.0f, 0.35f},  /* cheeks */
    {116, 345, {-1, 0, 0.3f}, 1.8f, 0.3f},  /* cheekbones */
    {0, -1, {0, 0, 1}, 0.8f, 0.18f},        /* upper lip */
    {17, -1, {0, -0.3f, 1}, 0.8f, 0.18f},   /* lower lip */
    {61, 291, {-1, 0, 0}, 0.8f, 0.18f},     /* mouth width */
    {152, -1, {0, -1, 0}, 1.8f, 0.35f},     /* chin length */
    {199, -1, {0, 0, 1}, 1.5f, 0.3f},       /* chin protrusion */
    {172, 397, {-1, 0, 0}, 2.2f, 0.45f},    /* jaw angle */
    {136, 365, {-1, -0.3f, 0}, 2.0f, 0.3f}, /* jaw line */
    {21, 251, {-1, 0, 0.3f}, 2.0f, 0.25f},  /* temples */
};
#define NBUMPS ((int)(sizeof BUMPS / sizeof BUMPS[0]))
/* All bump amplitudes scale with this (1.8 gives faces as varied as adults' are, by eye). */
#define SHAPE_GAIN 1.8f

static float clampf(float x, float lo, float hi) { return x < lo ? lo : x > hi ? hi : x; }

/* Normal draw clipped to +-2.5 standard deviations (no extreme faces). */
static float clipped_normal(hd_rng *r) { return clampf(hd_rng_normal(r), -2.5f, 2.5f); }

/* CIELAB (D65) -> stored RGB: XYZ, linear sRGB, then the sRGB transfer curve, because the images
 * store display values and the model works on stored values (SPEC section 2). */
static void lab_to_rgb(float L, float a, float b, float rgb[3])
{
    double fy = (L + 16.0) / 116.0, fx = fy + a / 500.0, fz = fy - b / 200.0;
    double d = 6.0 / 29.0;
    double xr = fx > d ? fx * fx * fx : 3 * d * d * (fx - 4.0 / 29.0);
    double yr = fy > d ? fy * fy * fy : 3 * d * d * (fy - 4.0 / 29.0);
    double zr = fz > d ? fz * fz * fz : 3 * d * d * (fz - 4.0 / 29.0);
    double X = 0.95047 * xr, Y = yr, Z = 1.08883 * zr;
    double lin[3] = {3.2404542 * X - 1.5371385 * Y - 0.4985314 * Z, -0.9692660 * X + 1.8760108 * Y + 0.0415560 * Z,
                     0.0556434 * X - 0.2040259 * Y + 1.0572252 * Z};
    for (int c = 0; c < 3; c++) {
        double v = lin[c] < 0 ? 0 : lin[c] > 1 ? 1 : lin[c];
        rgb[c] = (float)(v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1.0 / 2.4) - 0.055);
    }
}

void syn_shape_make(const hd_mesh *m, hd_rng *r, float gain, float *pos)
{
    float sx = 1.0f + gain * 0.05f * clipped_normal(r), sy = 1.0f + gain * 0.05f * clipped_normal(r),
          sz = 1.0f + gain * 0.1f * clipped_normal(r);
    for (int v = 0; v < m->nv; v++) {
        pos[3 * v] = m->pos[3 * v] * sx;
        pos[3 * v + 1] = m->pos[3 * v + 1] * sy;
        pos[3 * v + 2] = m->pos[3 * v + 2] * sz;
    }
    for (int k = 0; k < NBUMPS; k++) {
        const bump *b = &BUMPS[k];
        float amp = gain * SHAPE_GAIN * b->amp_std * clipped_normal(r);
        float len = sqrtf(b->dir[0] * b->dir[0] + b->dir[1] * b->dir[1] + b->dir[2] * b->dir[2]);
        for (int side = 0; side < 2; side++) {
            int anchor = side ? b->mirror : b->vertex;
            if (anchor < 0) continue;
            float a = amp * (1.0f + 0.1f * clipped_normal(r)); /* slight asymmetry */
            float dx = (side ? -b->dir[0] : b->dir[0]) / len, dy = b->dir[1] / len, dz = b->dir[2] / len;
            const float *c = m->pos + 3 * anchor;
            float inv2s2 = 1.0f / (2.0f * b->sigma * b->sigma);
            for (int v = 0; v < m->nv; v++) {
                const float *p = m->pos + 3 * v;
                float d2 = (p[0] - c[0]) * (p[0] - c[0]) + (p[1] - c[1]) * (p[1] - c[1]) + (p[2] - c[2]) * (p[2] - c[2]);
                float w = a * expf(-d2 * inv2s2); /* exp(-|p - c|^2 / (2 sigma^2)) */
                pos[3 * v] += w * dx;
                pos[3 * v + 1] += w * dy;
                pos[3 * v + 2] += w * dz;
            }
        }
    }
}

/* The fine-detail height field h (cm) of a subject, and its gradient by central differences. */
static hd_status make_detail(const hd_synth *s, hd_rng *r, float *grad)
{
    const int S = s->size;
    const size_t P = (size_t)S * S;
    float *h = hd_calloc(P, sizeof(float));
    if (!h) return HD_ERR_NOMEM;
    syn_noise_view fine, texel, mid, wob;
    syn_noise_view_pick(&fine, s->noise[SYN_NOISE_FINE], S, r);
    syn_noise_view_pick(&texel, s->noise[SYN_NOISE_TEXEL], S, r);
    syn_noise_view_pick(&mid, s->noise[SYN_NOISE_MID], S, r);
    syn_noise_view_pick(&wob, s->noise[SYN_NOISE_MID], S, r);
    float age = powf(hd_rng_uniform(r), 1.3f);                 /* 0 young .. 1 old */
    float pore = hd_rng_range(r, 0.008f, 0.02f);               /* cm */
    float undulation = hd_rng_range(r, 0.03f, 0.07f);          /* cm */
    float fore_depth = age * hd_rng_range(r, 0.01f, 0.04f);    /* cm */
    int fore_lines = 2 + (int)hd_rng_below(r, 3);
    float fore_phase = hd_rng_uniform(r);
    float crow_depth = age * hd_rng_range(r, 0.01f, 0.03f);
    float crow_rays = hd_rng_range(r, 5.0f, 9.0f);
    float fold_depth = (0.25f + age) * hd_rng_range(r, 0.04f, 0.12f);
    float fold_width = hd_rng_range(r, 0.15f, 0.3f); /* cm */
    float eyeball = hd_rng_range(r, 0.15f, 0.3f);     /* cm the eyeball stands out of the lid plane */
    float lip_volume = hd_rng_range(r, 0.06f, 0.16f); /* cm */
    float sulcus = hd_rng_range(r, 0.05f, 0.2f), alar = hd_rng_range(r, 0.05f, 0.15f);
    const float *fore = s->region[SYN_REGION_FOREHEAD], *nose = s->region[SYN_REGION_NOSE], *cheek = s->region[SYN_REGION_CHEEKS];
    const float *eyes = s->region[SYN_REGION_EYES], *ex = s->region[SYN_REGION_EYE_X], *ey = s->region[SYN_REGION_EYE_Y];
    const float *lips = s->region[SYN_REGION_LIPS];
    for (int ci = 0; ci < s->ncovered; ci++) {
        int i = s->covered[ci], x = i % S, y = i / S;
        float v = ((float)y + 0.5f) / (float)S;
        float pw = 0.6f + 0.8f * fminf(1.0f, nose[i] + cheek[i]);
        float hv = pore * pw * (0.7f * syn_noise_at(&fine, S, x, y) + 0.5f * syn_noise_at(&texel, S, x, y));
        hv += undulation * syn_noise_at(&mid, S, x, y);
        if (fore[i] > 0 && fore_depth > 0) {
            /* horizontal lines, wobbling: cos^8 of a phase running down the forehead */
            float ph = (v * 22.0f * (float)fore_lines / 3.0f + fore_phase + 0.15f * syn_noise_at(&wob, S, x, y)) * (float)M_PI;
            float c = cosf(ph), c2 = c * c, c8 = c2 * c2 * c2 * c2;
            hv -= fore_depth * fore[i] * c8;
        }
        float rc = s->region[SYN_REGION_CROW][i];
        if (rc < 2.0f && crow_depth > 0) {
            float c = cosf(s->region[SYN_REGION_CROW_ANGLE][i] * crow_rays), c2 = c * c, c8 = c2 * c2 * c2 * c2;
            float fall = expf(-(rc - 0.8f) * (rc - 0.8f) / 0.3f);
            hv -= crow_depth * fall * c8;
        }
        /* the eyeball bulging in the eye opening: a cap of a sphere of radius 1.2 cm */
        if (eyes[i] > 0) {
            float r2 = (ex[i] * ex[i] + ey[i] * ey[i]) / (1.2f * 1.2f);
            hv += eyes[i] * eyeball * (r2 < 1.0f ? 1.0f - r2 : 0.0f);
        }
        hv += lip_volume * lips[i];
        float ds = s->region[SYN_REGION_SULCUS][i] / 0.3f;
        if (ds < 4.0f) hv -= sulcus * expf(-ds * ds);
        float da = s->region[SYN_REGION_ALAR][i] / 0.12f;
        if (da < 4.0f) hv -= alar * expf(-da * da);
        float dn = s->region[SYN_REGION_NASOLABIAL][i] / fold_width;
        if (dn < 4.0f) hv -= fold_depth * expf(-dn * dn);
        h[i] = hv;
    }
    /* gradient: central differences where both neighbours are on the mesh, else one-sided */
    const float inv_step = (float)S / SYN_CM_PER_UV; /* texels per cm */
    memset(grad, 0, 2 * P * sizeof(float));
    const int *tri = s->raster.tri;
    for (int ci = 0; ci < s->ncovered; ci++) {
        int i = s->covered[ci], x = i % S, y = i / S;
        int xl = x > 0 && tri[i - 1] >= 0, xr = x < S - 1 && tri[i + 1] >= 0;
        int yu = y > 0 && tri[i - S] >= 0, yd = y < S - 1 && tri[i + S] >= 0;
        float gx = xl && xr ? 0.5f * (h[i + 1] - h[i - 1]) : xr ? h[i + 1] - h[i] : xl ? h[i] - h[i - 1] : 0;
        float gy = yu && yd ? 0.5f * (h[i + S] - h[i - S]) : yd ? h[i + S] - h[i] : yu ? h[i] - h[i - S] : 0;
        grad[i] = gx * inv_step;
        grad[P + i] = gy * inv_step;
    }
    free(h);
    return HD_OK;
}

/* A spot of radius rad (UV) at (cx, cy): albedo *= 1 - strength * g * tint, g a Gaussian. */
static void spot(const hd_synth *s, float *albedo, float cx, float cy, float rad, float strength, const float tint[3])
{
    const int S = s->size;
    const size_t P = (size_t)S * S;
    int x0 = (int)floorf((cx - 2.5f * rad) * S), x1 = (int)ceilf((cx + 2.5f * rad) * S);
    int y0 = (int)floorf((cy - 2.5f * rad) * S), y1 = (int)ceilf((cy + 2.5f * rad) * S);
    x0 = x0 < 0 ? 0 : x0, y0 = y0 < 0 ? 0 : y0, x1 = x1 > S - 1 ? S - 1 : x1, y1 = y1 > S - 1 ? S - 1 : y1;
    /* a spot smaller than a texel still darkens its texel by its area share */
    float r_eff = fmaxf(rad, 0.5f / (float)S), k = strength * (rad * rad) / (r_eff * r_eff);
    for (int y = y0; y <= y1; y++)
        for (int x = x0; x <= x1; x++) {
            float dx = ((float)x + 0.5f) / (float)S - cx, dy = ((float)y + 0.5f) / (float)S - cy;
            float g = k * expf(-(dx * dx + dy * dy) / (2.0f * r_eff * r_eff));
            size_t i = (size_t)y * S + x;
            for (int c = 0; c < 3; c++) albedo[c * P + i] *= 1.0f - g * tint[c];
        }
}

/* The albedo texture of a subject. */
static void make_albedo(const hd_synth *s, hd_rng *r, float *albedo)
{
    const int S = s->size;
    const size_t P = (size_t)S * S;
    /* skin tone: pigmentation t in [0, 1] from very light to very dark; CIELAB after the
     * measured ranges (docs/synthetic-data.md): L* 74 -> 28, b* peaking for intermediate skin */
    float t = hd_rng_uniform(r);
    float L = 74.0f - 46.0f * t + 2.0f * clipped_normal(r);
    float bb = 13.0f + 7.0f * sinf((float)M_PI * t) + 1.8f * clipped_normal(r);
    float aa = 9.0f + 3.0f * t + 1.5f * clipped_normal(r);
    float skin[3], lip[3], hair[3];
    lab_to_rgb(clampf(L, 22, 80), clampf(aa, 3, 18), clampf(bb, 5, 28), skin);
    lab_to_rgb(clampf(L - 8.0f - 3.0f * hd_rng_uniform(r), 15, 75), clampf(aa + 9.0f + 5.0f * hd_rng_uniform(r), 8, 35),
               clampf(bb - 2.0f, 2, 25), lip);
    float hairL = fminf(L - 15.0f, hd_rng_range(r, 12.0f, 55.0f) - 20.0f * t);
    lab_to_rgb(clampf(hairL, 6, 60), hd_rng_range(r, 1, 8), hd_rng_range(r, 2, 18), hair);
    /* low-frequency variation */
    float blotch = hd_rng_range(r, 0.02f, 0.07f);
    float red_cheek = hd_rng_range(r, 0.0f, 0.5f) * (1.0f - 0.6f * t);
    float red_nose = hd_rng_range(r, 0.0f, 0.4f) * (1.0f - 0.6f * t);
    float dark_eyes = hd_rng_range(r, 0.05f, 0.3f);
    float brow_density = hd_rng_range(r, 0.45f, 1.0f);
    float stubble = hd_rng_uniform(r) < 0.3f ? hd_rng_range(r, 0.2f, 0.9f) : 0.0f;
    /* eyes: iris colour (darker skin -> mostly brown), sizes in cm */
    static const float IRIS[6][3] = {{0.18f, 0.10f, 0.05f}, {0.33f, 0.20f, 0.10f}, {0.42f, 0.34f, 0.18f},
                                     {0.30f, 0.40f, 0.25f}, {0.30f, 0.44f, 0.58f}, {0.44f, 0.47f, 0.50f}};
    int iris_kind = hd_rng_uniform(r) < 0.45f + 0.5f * t ? (int)hd_rng_below(r, 2) : (int)hd_rng_below(r, 6);
    float iris_r = hd_rng_range(r, 0.52f, 0.62f), pupil_r = hd_rng_range(r, 0.14f, 0.24f);
    float gaze_x = hd_rng_range(r, -0.08f, 0.08f), gaze_y = hd_rng_range(r, -0.05f, 0.05f);
    float sclera = hd_rng_range(r, 0.78f, 0.92f);
    syn_noise_view low, mid, fine, texel;
    syn_noise_view_pick(&low, s->noise[SYN_NOISE_LOW], S, r);
    syn_noise_view_pick(&mid, s->noise[SYN_NOISE_MID], S, r);
    syn_noise_view_pick(&fine, s->noise[SYN_NOISE_FINE], S, r);
    syn_noise_view_pick(&texel, s->noise[SYN_NOISE_TEXEL], S, r);
    memset(albedo, 0, 3 * P * sizeof(float));
    const float **reg = (const float **)s->region;
    for (int ci = 0; ci < s->ncovered; ci++) {
        int i = s->covered[ci], x = i % S, y = i / S;
        float c[3] = {skin[0], skin[1], skin[2]};
        float lf = 1.0f + blotch * (syn_noise_at(&low, S, x, y) + 0.5f * syn_noise_at(&mid, S, x, y));
        float red = red_cheek * reg[SYN_REGION_CHEEKS][i] + red_nose * reg[SYN_REGION_NOSE][i];
        float dark = dark_eyes * reg[SYN_REGION_UNDER_EYE][i];
        c[0] *= lf * (1.0f - 0.03f * red) * (1.0f - 0.9f * dark);
        c[1] *= lf * (1.0f - 0.16f * red) * (1.0f - dark);
        c[2] *= lf * (1.0f - 0.12f * red) * (1.0f - 0.85f * dark);
        float wl = reg[SYN_REGION_LIPS][i];
        if (wl > 0) {
            float lv = 1.0f + 0.05f * syn_noise_at(&fine, S, x, y);
            for (int k = 0; k < 3; k++) c[k] += wl * (lip[k] * lv - c[k]);
        }
        float wb = reg[SYN_REGION_BROWS][i];
        if (wb > 0) {
            /* hair strokes: fine noise thresholded by the density */
            float strand = clampf(0.5f + 0.6f * syn_noise_at(&fine, S, x, y) + 0.4f * syn_noise_at(&texel, S, x, y), 0, 1);
            float w = wb * brow_density * (0.55f + 0.45f * strand);
            for (int k = 0; k < 3; k++) c[k] += w * (hair[k] - c[k]);
        }
        float wbeard = reg[SYN_REGION_BEARD][i] * stubble;
        if (wbeard > 0) {
            float dots = syn_noise_at(&texel, S, x, y) > 0.3f ? 1.0f : 0.35f;
            float w = 0.6f * wbeard * dots;
            for (int k = 0; k < 3; k++) c[k] += w * (hair[k] - c[k]);
        }
        float we = reg[SYN_REGION_EYES][i];
        if (we > 0) {
            float ex = reg[SYN_REGION_EYE_X][i] - gaze_x, ey = reg[SYN_REGION_EYE_Y][i] - gaze_y;
            float rr = sqrtf(ex * ex + ey * ey);
            float e[3];
            if (rr < pupil_r) {
                e[0] = e[1] = e[2] = 0.03f;
            } else if (rr < iris_r) {
                float streak = 0.8f + 0.2f * syn_noise_at(&fine, S, x, y);
                float limbal = rr > 0.85f * iris_r ? 0.6f : 1.0f; /* the darker ring at its rim */
                for (int k = 0; k < 3; k++) e[k] = IRIS[iris_kind][k] * streak * limbal;
            } else {
                for (int k = 0; k < 3; k++) e[k] = sclera * (k == 0 ? 1.0f : k == 1 ? 0.96f : 0.93f);
            }
            for (int k = 0; k < 3; k++) c[k] += we * (e[k] - c[k]);
        }
        for (int k = 0; k < 3; k++) albedo[k * P + i] = clampf(c[k], 0.0f, 1.0f);
    }
    /* freckles (many, small, on cheeks and nose for most), and moles (few, larger, darker) */
    static const float FRECKLE[3] = {0.35f, 0.5f, 0.6f}, MOLE[3] = {0.55f, 0.7f, 0.75f};
    int nfreckles = hd_rng_uniform(r) < 0.35f ? (int)hd_rng_range(r, 20, 400) : (int)hd_rng_below(r, 15);
    float freckle_strength = hd_rng_range(r, 0.08f, 0.3f);
    for (int k = 0; k < nfreckles; k++) {
        float cx, cy;
        if (hd_rng_uniform(r) < 0.7f) { /* cheeks and nose */
            float side = hd_rng_uniform(r) < 0.5f ? -1.0f : 1.0f;
            cx = 0.5f + side * hd_rng_range(r, 0.0f, 0.25f) + 0.03f * hd_rng_normal(r);
            cy = 0.52f + 0.06f * hd_rng_normal(r);
        } else {
            cx = hd_rng_range(r, 0.1f, 0.9f);
            cy = hd_rng_range(r, 0.12f, 0.9f);
        }
        float rad = hd_rng_range(r, 0.0015f, 0.005f);
        spot(s, albedo, cx, cy, rad, freckle_strength * hd_rng_range(r, 0.5f, 1.0f), FRECKLE);
    }
    int nmoles = (int)hd_rng_below(r, 5);
    for (int k = 0; k < nmoles; k++) {
        float cx = hd_rng_range(r, 0.15f, 0.85f), cy = hd_rng_range(r, 0.2f, 0.9f);
        spot(s, albedo, cx, cy, hd_rng_range(r, 0.003f, 0.008f), hd_rng_range(r, 0.3f, 0.6f), MOLE);
    }
    /* nothing outside the mesh */
    const int *tri = s->raster.tri;
    for (size_t i = 0; i < P; i++)
        if (tri[i] < 0) albedo[i] = albedo[P + i] = albedo[2 * P + i] = 0.0f;
}

hd_status hd_synth_subject_make(const hd_synth *s, uint64_t seed, int subject, hd_synth_subject **out)
{
    *out = NULL;
    if (subject < 0) return hd_fail(HD_ERR_ARG, "synth: negative subject index %d", subject);
    const size_t P = (size_t)s->size * s->size;
    hd_synth_subject *sub = hd_calloc(1, sizeof *sub);
    if (!sub) return HD_ERR_NOMEM;
    sub->seed = seed;
    sub->subject = subject;
    sub->pos = hd_malloc((size_t)s->mesh.nv * 3 * sizeof(float));
    sub->albedo = hd_malloc(3 * P * sizeof(float));
    sub->grad = hd_malloc(2 * P * sizeof(float));
    if (!sub->pos || !sub->albedo || !sub->grad) {
        hd_synth_subject_free(sub);
        return HD_ERR_NOMEM;
    }
    hd_rng r;
    syn_rng(&r, seed, subject, -1);
    syn_shape_make(&s->mesh, &r, 1.0f, sub->pos);
    hd_status st = make_detail(s, &r, sub->grad);
    if (st != HD_OK) {
        hd_synth_subject_free(sub);
        return st;
    }
    make_albedo(s, &r, sub->albedo);
    *out = sub;
    return HD_OK;
}

void hd_synth_subject_free(hd_synth_subject *sub)
{
    if (!sub) return;
    free(sub->pos);
    free(sub->albedo);
    free(sub->grad);
    free(sub);
}
