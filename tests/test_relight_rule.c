/* test_relight_rule.c: issue 12's relighting rule and its measurements on constructed inputs with
 * known answers. The photo metrics: identity scores chroma 0, detail 1, self 0; a colour-shifted
 * copy a known chroma; a pasted step a high seam and a feathered change a low one; blurring a low
 * detail; brightened eyes a known glow; SSIM 1 for equal pictures. The fields: hole filling,
 * blurring and feathering of known shapes. The rule (hd_apply_decomposition): exactly the input
 * under the face's own light, one factor for the three channels under a grey light, the input bit
 * for bit where the mask is 0, the eyes following the skin even when the normals there are wrong,
 * the mean luminance kept, and close to A * s(N, l_target) on an exact decomposition. The face's
 * own light: a change below the nose moves it less than an even fit. The face's
 * region in a photo: grown over the forehead's skin to the hairline and nowhere else. */
#include <stdlib.h>
#include <string.h>
#include "test.h"
#include "core/core.h"
#include "apply/apply.h"
#include "eval/photo_metrics.h"
#include "mesh/mesh.h"
#include "light/light.h"

static hd_image image(int w, int h, int c, float v)
{
    hd_image im = {0};
    if (hd_image_alloc(&im, w, h, c) != HD_OK) exit(1);
    for (size_t i = 0; i < (size_t)w * h * c; i++) im.data[i] = v;
    return im;
}

static hd_image copy(const hd_image *a)
{
    hd_image b = image(a->width, a->height, a->channels, 0);
    memcpy(b.data, a->data, (size_t)a->width * a->height * a->channels * sizeof(float));
    return b;
}

/* A textured grey-ish picture: 0.4 + 0.1 sin pattern, a little colour. */
static hd_image textured(int W, int H)
{
    hd_image im = image(W, H, 3, 0);
    size_t P = (size_t)W * H;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            for (int c = 0; c < 3; c++)
                im.data[c * P + (size_t)y * W + x] =
                    0.4f + 0.05f * c + 0.1f * sinf(0.9f * x + 0.3f * c) * cosf(0.7f * y);
    return im;
}

static int in_disc(int x, int y, float cx, float cy, float r)
{
    float dx = x + 0.5f - cx, dy = y + 0.5f - cy;
    return dx * dx + dy * dy <= r * r;
}

static void test_metrics(void)
{
    const int W = 96, H = 96;
    const size_t P = (size_t)W * H;
    hd_image in = textured(W, H), out = copy(&in);
    unsigned char *ch = NULL;
    long n = -1;
    /* identity: nothing changed */
    CHECK(hd_photo_changed(&in, &out, &ch, &n) == HD_OK);
    CHECK(n == 0);
    CHECK_NEAR(hd_photo_chroma(&in, &out, ch), 0.0, 0);
    CHECK_NEAR(hd_photo_detail(&in, &out, ch), 1.0, 0);
    CHECK_NEAR(hd_photo_mae(&in, &out, NULL), 0.0, 0);
    free(ch);

    /* a flat grey disc whose red goes 0.5 -> 0.6: chroma = 1000 (|0.6/1.6 - 1/3| + 2 |0.5/1.6 - 1/3|) */
    hd_image flat = image(W, H, 3, 0.5f), shifted = copy(&flat);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            if (in_disc(x, y, 48, 48, 30)) shifted.data[(size_t)y * W + x] = 0.6f;
    CHECK(hd_photo_changed(&flat, &shifted, &ch, &n) == HD_OK);
    CHECK(n > 2000);
    CHECK_NEAR(hd_photo_chroma(&flat, &shifted, ch), 1000.0 * (0.6 / 1.6 - 1.0 / 3 + 2 * (1.0 / 3 - 0.5 / 1.6)), 1e-3);
    free(ch);

    /* a grey factor keeps every colour: chroma 0 (to rounding); a smooth one keeps the detail */
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            size_t p = (size_t)y * W + x;
            float dx = x + 0.5f - 48, dy = y + 0.5f - 48, q = 1 - (dx * dx + dy * dy) / 900.0f;
            float f = in_disc(x, y, 48, 48, 30) ? 1.0f + 0.3f * q * q : 1.0f;
            for (int c = 0; c < 3; c++) out.data[c * P + p] = in.data[c * P + p] * f;
        }
    CHECK(hd_photo_changed(&in, &out, &ch, &n) == HD_OK);
    CHECK(hd_photo_chroma(&in, &out, ch) < 1e-3);
    CHECK(hd_photo_detail(&in, &out, ch) > 0.95);
    free(ch);

    /* a pasted step (+0.1 over a disc, a gentle slope inside): a high seam; the same change fading
     * to 0 at the disc's edge: a low one */
    hd_image step = copy(&in), fade = copy(&in);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            if (!in_disc(x, y, 48, 48, 30)) continue;
            float dx = x + 0.5f - 48, dy = y + 0.5f - 48, r2 = (dx * dx + dy * dy) / (30.0f * 30.0f);
            for (int c = 0; c < 3; c++) {
                size_t i = c * P + (size_t)y * W + x;
                step.data[i] += 0.1f + 0.002f * x;
                fade.data[i] += 0.1f * (1 - r2) * (1 - r2) + 1e-4f;
            }
        }
    CHECK(hd_photo_changed(&in, &step, &ch, &n) == HD_OK);
    double seam_step = hd_photo_seam(&in, &step, ch);
    free(ch);
    CHECK(hd_photo_changed(&in, &fade, &ch, &n) == HD_OK);
    double seam_fade = hd_photo_seam(&in, &fade, ch);
    free(ch);
    CHECK(seam_step > 10.0);
    CHECK(seam_fade < 1.0);
    /* a smooth change that crosses zero (darker on the left, lighter on the right, fading to 0 at
     * the disc's edge): the line where it rounds to the input is inside the region, not a seam
     * (1.11 before the region was closed, 0.74 after) */
    hd_image in8 = copy(&in), cross = copy(&in); /* 8-bit pictures: the change rounds to none near zero */
    for (size_t i = 0; i < 3 * P; i++) in8.data[i] = roundf(in.data[i] * 255.0f) / 255.0f;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            for (int c = 0; c < 3; c++) {
                const size_t i = c * P + (size_t)y * W + x;
                float dx = x + 0.5f - 48, dy = y + 0.5f - 48, r2 = (dx * dx + dy * dy) / (30.0f * 30.0f);
                const float ramp = fminf(1.0f, fmaxf(-1.0f, (x - 48) / 6.0f)); /* 0 on the column x = 48 */
                const float change = in_disc(x, y, 48, 48, 30) ? 0.05f * ramp * (1 - r2) * (1 - r2) : 0.0f;
                cross.data[i] = roundf((in8.data[i] + change) * 255.0f) / 255.0f;
            }
    CHECK(hd_photo_changed(&in8, &cross, &ch, &n) == HD_OK);
    double seam_cross = hd_photo_seam(&in8, &cross, ch);
    free(ch);
    printf("seam: a smooth change crossing zero %.3f\n", seam_cross);
    CHECK(seam_cross < 1.0);
    hd_image_free(&cross), hd_image_free(&in8);
    /* the same step where the photo has an edge of its own (a lighter disc: the person's outline
     * against the background, which keeps the photo): no seam */
    hd_image disc = copy(&in), disc_step = copy(&in);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            for (int c = 0; c < 3; c++) {
                const size_t i = c * P + (size_t)y * W + x;
                if (in_disc(x, y, 48, 48, 30)) disc.data[i] = in.data[i] * 0.5f + 0.45f;
                disc_step.data[i] = disc.data[i] + (in_disc(x, y, 48, 48, 30) ? 0.1f * (disc.data[i] < 0.9f) : 0.0f);
            }
    CHECK(hd_photo_changed(&disc, &disc_step, &ch, &n) == HD_OK);
    double seam_outline = hd_photo_seam(&disc, &disc_step, ch);
    free(ch);
    printf("seam: a pasted step %.3f, faded %.3f, at the photo's own edge %.3f\n", seam_step, seam_fade, seam_outline);
    CHECK(seam_outline < 1.5);
    hd_image_free(&disc), hd_image_free(&disc_step);

    /* blurring the disc loses the detail */
    hd_image blurred = copy(&in);
    for (int c = 0; c < 3; c++) hd_field_blur(blurred.data + c * P, W, H, 3.0f);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            if (!in_disc(x, y, 48, 48, 30))
                for (int c = 0; c < 3; c++) blurred.data[c * P + (size_t)y * W + x] = in.data[c * P + (size_t)y * W + x];
    CHECK(hd_photo_changed(&in, &blurred, &ch, &n) == HD_OK);
    CHECK(hd_photo_detail(&in, &blurred, ch) < 0.5);
    free(ch);

    /* glow: the face (a disc) x1.2, the eyes (discs of 0.12 x 40 pixels) x1.8 */
    const float pupils[2][2] = {{28, 40}, {68, 40}};
    hd_image glow = copy(&flat);
    long ne = 0, nf = 0;
    double se = 0, sf = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            if (!in_disc(x, y, 48, 48, 46)) continue;
            int eye = in_disc(x, y, pupils[0][0], pupils[0][1], 4.8f) || in_disc(x, y, pupils[1][0], pupils[1][1], 4.8f);
            float f = eye ? 1.8f : 1.2f;
            for (int c = 0; c < 3; c++) glow.data[c * P + (size_t)y * W + x] *= f;
            ne += eye, se += eye ? f : 0, nf++, sf += f;
        }
    CHECK(hd_photo_changed(&flat, &glow, &ch, &n) == HD_OK);
    CHECK_NEAR(hd_photo_glow(&flat, &glow, ch, pupils), (se / ne) / (sf / nf), 1e-4);
    CHECK_NEAR(hd_photo_glow(&flat, &flat, ch, pupils), 1.0, 1e-9);
    free(ch);

    /* lights; SSIM */
    float a[HD_SH_COEFFS] = {3, 4}, b[HD_SH_COEFFS] = {3, 4, 0, 0, 0, 0, 0, 0, 1};
    CHECK_NEAR(hd_light_difference(a, b), 0.2, 1e-9);
    CHECK_NEAR(hd_light_difference(a, a), 0.0, 0);
    CHECK_NEAR(hd_ssim_masked(&in, &in, NULL), 1.0, 1e-6);
    CHECK(hd_ssim_masked(&in, &blurred, NULL) < 0.95);
    hd_image_free(&in), hd_image_free(&out), hd_image_free(&flat), hd_image_free(&shifted);
    hd_image_free(&step), hd_image_free(&fade), hd_image_free(&blurred), hd_image_free(&glow);
}

static void test_fields(void)
{
    const int W = 40, H = 30;
    float v[40 * 30], known[40 * 30], w[40 * 30];
    /* a linear ramp known on the left half only: filled smoothly, the known part untouched */
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            v[y * W + x] = x < 20 ? 2.0f : 99.0f;
            known[y * W + x] = x < 20;
        }
    CHECK(hd_field_fill(v, known, W, H) == HD_OK);
    float lo = 1e9f, hi = -1e9f;
    for (int p = 0; p < W * H; p++) lo = fminf(lo, v[p]), hi = fmaxf(hi, v[p]);
    CHECK_NEAR(lo, 2.0, 1e-5);
    CHECK_NEAR(hi, 2.0, 1e-5);
    /* blurring a constant leaves it */
    CHECK(hd_field_blur(v, W, H, 2.5f) == HD_OK);
    CHECK_NEAR(v[7 * W + 33], 2.0, 1e-5);
    /* feather of a rectangle: 0 outside, 1 from the band inward, rising between */
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) known[y * W + x] = x >= 5 && x < 35 && y >= 5 && y < 25;
    CHECK(hd_field_feather(known, W, H, 6.0f, w) == HD_OK);
    CHECK(w[2 * W + 2] == 0.0f);
    CHECK(w[15 * W + 20] == 1.0f);
    CHECK(w[15 * W + 5] > 0.0f && w[15 * W + 5] < w[15 * W + 7] && w[15 * W + 7] < 1.0f);
    /* the outward feather of the same rectangle: 1 on it, 0 from the band outward, falling between;
     * a region on the picture's edge is not faded there (the edge is not an edge of the region) */
    CHECK(hd_field_feather_out(known, W, H, 3.0f, w) == HD_OK);
    int on = 1;
    for (int p = 0; p < W * H; p++) on &= !known[p] || w[p] == 1.0f;
    CHECK(on);
    CHECK(w[15 * W + 1] == 0.0f && w[1 * W + 20] == 0.0f); /* 4 px outside */
    CHECK(w[15 * W + 4] < 1.0f && w[15 * W + 3] < w[15 * W + 4] && w[15 * W + 3] > 0.0f);
    CHECK_NEAR(w[15 * W + 4], 1.0 - hd_field_smoothstep(1.0f / 3.0f), 1e-6);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) known[y * W + x] = x < 10;
    CHECK(hd_field_feather_out(known, W, H, 3.0f, w) == HD_OK);
    CHECK(w[0] == 1.0f && w[(H - 1) * W + 9] == 1.0f && w[5 * W + 13] == 0.0f);
    for (int p = 0; p < W * H; p++) known[p] = 0;
    CHECK(hd_field_feather_out(known, W, H, 3.0f, w) == HD_OK);
    on = 1;
    for (int p = 0; p < W * H; p++) on &= w[p] == 0.0f;
    CHECK(on); /* no region: no change anywhere */
    /* holes: a ring's inside is filled, a notch open to the picture's edge and the outside are not */
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            const int ring = x >= 5 && x < 35 && y >= 5 && y < 25 && !(x >= 12 && x < 18 && y >= 12 && y < 18);
            const int notch = x >= 25 && x < 30 && y >= 15; /* from inside the ring down to the edge */
            known[y * W + x] = ring && !notch ? 0.8f : 0.2f;
        }
    CHECK(hd_field_fill_holes(known, W, H) == HD_OK);
    CHECK(known[14 * W + 14] == 1.0f && known[12 * W + 17] == 1.0f); /* the hole, set to 1 */
    CHECK(known[10 * W + 10] == 0.8f);                               /* the ring, unchanged */
    CHECK(known[20 * W + 27] == 0.2f && known[2 * W + 2] == 0.2f);   /* the notch, the outside */
    CHECK(hd_field_fill_holes(known, 0, 0) == HD_OK);
}

#define SIDE 64

/* An exact face: normals of a bulge, albedo with a little colour, S = s(N, l), I = A * S. */
static void make_face(const float light[HD_SH_COEFFS], hd_decomposition *d, hd_image *input, hd_image *mask)
{
    memset(d, 0, sizeof *d);
    const size_t P = SIDE * SIDE;
    d->normal = image(SIDE, SIDE, 3, 0);
    d->albedo = image(SIDE, SIDE, 3, 0);
    d->shading = image(SIDE, SIDE, 1, 0);
    *input = image(SIDE, SIDE, 3, 0);
    *mask = image(SIDE, SIDE, 1, 0);
    memcpy(d->light, light, sizeof d->light);
    for (int y = 0; y < SIDE; y++)
        for (int x = 0; x < SIDE; x++) {
            size_t p = (size_t)y * SIDE + x;
            float u = (x + 0.5f) / SIDE * 2 - 1, v = 1 - (y + 0.5f) / SIDE * 2;
            float n[3] = {0.8f * u, 0.8f * v, 1.0f}, len = sqrtf(n[0] * n[0] + n[1] * n[1] + 1.0f);
            for (int k = 0; k < 3; k++) d->normal.data[k * P + p] = n[k] / len;
            float nn[3] = {n[0] / len, n[1] / len, n[2] / len}, s = hd_sh_shade(light, nn);
            d->shading.data[p] = s;
            for (int c = 0; c < 3; c++) {
                float a = 0.35f + 0.05f * c + 0.05f * sinf(0.8f * x + c) * cosf(0.6f * y);
                d->albedo.data[c * P + p] = a;
                input->data[c * P + p] = a * s;
            }
            mask->data[p] = u * u + v * v < 0.85f;
        }
}

static void free_face(hd_decomposition *d, hd_image *input, hd_image *mask)
{
    hd_image_free(&d->normal);
    hd_image_free(&d->albedo);
    hd_image_free(&d->shading);
    hd_image_free(input);
    hd_image_free(mask);
}

static void test_rule(void)
{
    float src[HD_SH_COEFFS], tgt[HD_SH_COEFFS];
    hd_light_from_direction(0, 0, 1.0f, 0.6f, src);
    hd_light_from_direction(40, 20, 1.0f, 0.6f, tgt);
    hd_decomposition d;
    hd_image in, mask;
    make_face(src, &d, &in, &mask);
    const size_t P = SIDE * SIDE;
    hd_light_rgb t;
    hd_light_rgb_from_grey(tgt, &t);
    hd_apply_request q = {&t, 1, 1, 1, HD_RULE_RATIO, HD_BRIGHTNESS_FREE, HD_SOURCE_FIT, 0.0f, NULL};
    hd_apply_result r;
    if (hd_apply_decomposition(&in, &d, &mask, &q, &r) != HD_OK) {
        fprintf(stderr, "test_relight_rule: %s\n", hd_error());
        test_failures++;
        return;
    }
    /* the face's own light: the input exactly */
    CHECK(memcmp(r.self.data, in.data, 3 * P * sizeof(float)) == 0);
    int grey = 1, outside = 1;
    double err = 0;
    long n = 0;
    hd_image w = image(SIDE, SIDE, 1, 0);
    CHECK(hd_field_feather(mask.data, SIDE, SIDE, 0.04f * SIDE, w.data) == HD_OK);
    for (size_t p = 0; p < P; p++) {
        float f0 = r.relit[0].data[p] / in.data[p];
        for (int c = 1; c < 3; c++) grey &= fabsf(r.relit[0].data[c * P + p] / in.data[c * P + p] - f0) < 1e-5f * f0;
        if (mask.data[p] <= 0.5f)
            for (int c = 0; c < 3; c++) outside &= r.relit[0].data[c * P + p] == in.data[c * P + p];
        /* fully inside and away from the eye regions: close to A * s(N, l_target) */
        if (w.data[p] >= 1.0f) {
            float nn[3] = {d.normal.data[p], d.normal.data[P + p], d.normal.data[2 * P + p]};
            for (int c = 0; c < 3; c++)
                err += fabs(r.relit[0].data[c * P + p] - d.albedo.data[c * P + p] * hd_sh_shade(tgt, nn)), n++;
        }
    }
    CHECK(grey);
    CHECK(outside);
    CHECK(n > 500);
    /* the guard and the blur cost a little against the exact answer; the change itself is larger */
    CHECK(err / n < 0.02);
    CHECK(hd_photo_mae(&in, &r.relit[0], NULL) > 0.03);
    hd_apply_result_free(&r);

    /* wrong normals inside the eye regions do not show: the ratio there follows the skin */
    hd_image regions;
    CHECK(hd_face_regions_uv(SIDE, &regions) == HD_OK);
    long in_regions = 0;
    hd_decomposition bad = d;
    bad.normal = copy(&d.normal);
    for (size_t p = 0; p < P; p++)
        if (regions.data[p] > 0.5f) {
            in_regions++;
            bad.normal.data[p] = 1, bad.normal.data[P + p] = 0, bad.normal.data[2 * P + p] = 0;
        }
    CHECK(in_regions > 20);
    hd_apply_request q1 = {&t, 1, 0, 0, HD_RULE_RATIO, HD_BRIGHTNESS_FREE, HD_SOURCE_FIT, 0.0f, NULL};
    hd_apply_result good, worse;
    CHECK(hd_apply_decomposition(&in, &d, &mask, &q1, &good) == HD_OK);
    CHECK(hd_apply_decomposition(&in, &bad, &mask, &q1, &worse) == HD_OK);
    CHECK(memcmp(good.relit[0].data, worse.relit[0].data, 3 * P * sizeof(float)) == 0);
    hd_apply_result_free(&good);
    hd_apply_result_free(&worse);
    hd_image_free(&bad.normal);
    hd_image_free(&regions);

    /* brightness kept: the feather-weighted mean luminance of the face is the input's */
    hd_apply_request qk = {&t, 1, 0, 0, HD_RULE_RATIO, HD_BRIGHTNESS_KEEP, HD_SOURCE_FIT, 0.0f, NULL};
    CHECK(hd_apply_decomposition(&in, &d, &mask, &qk, &r) == HD_OK);
    double li = 0, lo = 0;
    for (size_t p = 0; p < P; p++) {
        li += w.data[p] * (0.2126 * in.data[p] + 0.7152 * in.data[P + p] + 0.0722 * in.data[2 * P + p]);
        lo += w.data[p] * (0.2126 * r.relit[0].data[p] + 0.7152 * r.relit[0].data[P + p] +
                           0.0722 * r.relit[0].data[2 * P + p]);
    }
    CHECK_NEAR(lo / li, 1.0, 2e-3);
    hd_apply_result_free(&r);

    /* a coloured light changes the channels apart; the paper's rule refuses it */
    hd_light_rgb warm = t;
    for (int k = 0; k < HD_SH_COEFFS; k++) warm.sh[2][k] *= 0.5f;
    hd_apply_request qc = {&warm, 1, 0, 0, HD_RULE_RATIO, HD_BRIGHTNESS_FREE, HD_SOURCE_FIT, 0.0f, NULL};
    CHECK(hd_apply_decomposition(&in, &d, &mask, &qc, &r) == HD_OK);
    size_t mid = (SIDE / 2) * SIDE + SIDE / 2;
    CHECK(r.relit[0].data[2 * P + mid] / in.data[2 * P + mid] < 0.8f * r.relit[0].data[mid] / in.data[mid]);
    hd_apply_result_free(&r);
    qc.rule = HD_RULE_PAPER;
    CHECK(hd_apply_decomposition(&in, &d, &mask, &qc, &r) == HD_ERR_ARG);
    hd_image_free(&w);
    free_face(&d, &in, &mask);
}

/* The face's own light: S rendered exactly from a known light on known normals fits back to that
 * light; L-Net's (d->light) is taken as it is; a wrong L-Net light is mostly corrected by the fit
 * (its shading lands far nearer S); the rule stays the identity under the face's own light, and
 * face_light reports the light the rule used. */
static void test_source_light(void)
{
    float src[HD_SH_COEFFS], other[HD_SH_COEFFS], got[HD_SH_COEFFS];
    hd_light_from_direction(-30, 15, 1.0f, 0.6f, src);
    hd_light_from_direction(35, -10, 0.7f, 0.8f, other);
    hd_decomposition d;
    hd_image in, mask;
    make_face(src, &d, &in, &mask);
    const size_t P = SIDE * SIDE;
    CHECK(hd_face_light(&d, &mask, HD_SOURCE_FIT, got) == HD_OK);
    double e = 0;
    for (int k = 0; k < HD_SH_COEFFS; k++) e = fmax(e, fabs(got[k] - src[k]));
    CHECK(e < 1e-4);
    /* L-Net's wrong: the fit (pulled toward it a little) still follows S */
    memcpy(d.light, other, sizeof other);
    CHECK(hd_face_light(&d, &mask, HD_SOURCE_LNET, got) == HD_OK);
    CHECK(memcmp(got, other, sizeof got) == 0);
    CHECK(hd_face_light(&d, &mask, HD_SOURCE_FIT, got) == HD_OK);
    double fit_err = 0, lnet_err = 0;
    long n = 0;
    for (size_t p = 0; p < P; p++) {
        if (mask.data[p] <= 0.5f) continue;
        float nn[3] = {d.normal.data[p], d.normal.data[P + p], d.normal.data[2 * P + p]};
        fit_err += fabs(hd_sh_shade(got, nn) - d.shading.data[p]);
        lnet_err += fabs(hd_sh_shade(other, nn) - d.shading.data[p]);
        n++;
    }
    printf("source light: shading MAE over the mask, fit %.4f, the wrong L-Net light %.4f\n", fit_err / n, lnet_err / n);
    CHECK(fit_err < 0.5 * lnet_err);
    /* the rule from the fitted light: the identity under it, and face_light is it */
    hd_light_rgb t;
    hd_light_rgb_from_grey(src, &t);
    hd_apply_request q = {&t, 1, 0, 1, HD_RULE_RATIO, HD_BRIGHTNESS_KEEP, HD_SOURCE_FIT, 0.0f, NULL};
    hd_apply_result r;
    CHECK(hd_apply_decomposition(&in, &d, &mask, &q, &r) == HD_OK);
    CHECK(memcmp(r.self.data, in.data, 3 * P * sizeof(float)) == 0);
    CHECK(memcmp(r.face_light[0], got, sizeof got) == 0);
    /* the fitted light is near the true one, so relighting under the true light hardly moves it;
     * from L-Net's wrong light it moves it much more */
    double near_fit = hd_photo_mae(&in, &r.relit[0], NULL);
    hd_apply_result_free(&r);
    q.source = HD_SOURCE_LNET;
    CHECK(hd_apply_decomposition(&in, &d, &mask, &q, &r) == HD_OK);
    CHECK(memcmp(r.self.data, in.data, 3 * P * sizeof(float)) == 0);
    CHECK(memcmp(r.face_light[0], other, sizeof other) == 0);
    double near_lnet = hd_photo_mae(&in, &r.relit[0], NULL);
    hd_apply_result_free(&r);
    printf("relit under its true light: MAE %.4f from the fitted source, %.4f from L-Net's wrong one\n", near_fit,
           near_lnet);
    CHECK(near_fit < 0.5 * near_lnet);
    /* no shading to fit: refused, naming it */
    hd_image_free(&d.shading);
    CHECK(hd_face_light(&d, &mask, HD_SOURCE_FIT, got) == HD_ERR_ARG);
    CHECK(hd_face_light(&d, &mask, (hd_source_light)7, got) == HD_ERR_ARG);
    free_face(&d, &in, &mask);
}

/* The fit's weight: 1 down to the nose tip's row, `lower` from the mouth corners' row, falling in
 * between; with it, a change of the shading below the nose (a smile's, not the light's) moves the
 * face's own light less than an even fit lets it, and an exact shading still fits back exactly. */
static void test_fit_weight(void)
{
    const hd_mesh *mesh;
    CHECK(hd_mesh_canonical(&mesh) == HD_OK);
    const int S = 128;
    hd_image w = {0};
    CHECK(hd_face_fit_weight_uv(S, 0.25f, &w) == HD_OK);
    const float top = mesh->uv[2 * 1 + 1] * S, bottom = 0.5f * (mesh->uv[2 * 61 + 1] + mesh->uv[2 * 291 + 1]) * S;
    CHECK(top > 0.4f * S && bottom < 0.8f * S && bottom > top + 8);
    int ok = 1;
    for (int y = 0; y < S; y++) {
        float v = w.data[(size_t)y * S], c = y + 0.5f;
        for (int x = 1; x < S; x++) ok &= w.data[(size_t)y * S + x] == v; /* rows are flat */
        if (c <= top) ok &= v == 1.0f;
        if (c >= bottom) ok &= v == 0.25f;
        if (c > top && c < bottom) ok &= v < 1.0f && v > 0.25f;
        if (y > 0) ok &= v <= w.data[(size_t)(y - 1) * S];
    }
    CHECK(ok);
    hd_image_free(&w);
    CHECK(hd_face_fit_weight_uv(S, 1.5f, &w) == HD_ERR_ARG);
    CHECK(hd_face_fit_weight_uv(0, 0.25f, &w) == HD_ERR_ARG);

    float src[HD_SH_COEFFS], got[HD_SH_COEFFS], even[HD_SH_COEFFS];
    hd_light_from_direction(-30, 15, 1.0f, 0.6f, src);
    hd_decomposition d;
    hd_image in, mask;
    make_face(src, &d, &in, &mask);
    const size_t P = SIDE * SIDE;
    /* a third more shading over the lower face's cheeks (below the mouth corners' row, off the mouth) */
    hd_image weight = {0}, skin = {0};
    CHECK(hd_face_fit_weight_uv(SIDE, HD_FIT_LOWER_FACE, &weight) == HD_OK);
    CHECK(hd_face_regions_uv(SIDE, &skin) == HD_OK);
    for (size_t p = 0; p < P; p++) {
        if (weight.data[p] == HD_FIT_LOWER_FACE && (p % SIDE < SIDE / 3 || p % SIDE >= 2 * SIDE / 3))
            d.shading.data[p] *= 1.3f;
        skin.data[p] = mask.data[p] > 0.5f && skin.data[p] <= 0.5f; /* the even fit's mask: hd_face_light's skin */
    }
    CHECK(hd_face_light(&d, &mask, HD_SOURCE_FIT, got) == HD_OK);
    CHECK(hd_sh_fit_toward_lobe(d.normal.data, d.shading.data, skin.data, (int)P, HD_SOURCE_PRIOR, even) == HD_OK);
    double eg = 0, ee = 0, n = 0;
    for (int k = 0; k < HD_SH_COEFFS; k++) {
        eg += (got[k] - src[k]) * (got[k] - src[k]);
        ee += (even[k] - src[k]) * (even[k] - src[k]);
        n += src[k] * src[k];
    }
    eg = sqrt(eg / n), ee = sqrt(ee / n);
    printf("a lower-face change: the light's relative error %.4f weighted, %.4f even\n", eg, ee);
    CHECK(eg < 0.6 * ee && ee > 0.02);
    /* the exact shading: the weighted fit gives the light back */
    free_face(&d, &in, &mask);
    make_face(src, &d, &in, &mask);
    CHECK(hd_face_light(&d, &mask, HD_SOURCE_FIT, got) == HD_OK);
    double e = 0;
    for (int k = 0; k < HD_SH_COEFFS; k++) e = fmax(e, fabs(got[k] - src[k]));
    CHECK(e < 1e-4);
    hd_image_free(&weight);
    hd_image_free(&skin);
    free_face(&d, &in, &mask);
}

/* The guard: g = share x the mean source shading; a smaller guard brings the rule on an exact
 * decomposition nearer A * s(N, l_target) where the source shading is low. */
static void test_guard(void)
{
    float src[HD_SH_COEFFS], tgt[HD_SH_COEFFS];
    hd_light_from_direction(60, 0, 1.2f, 0.15f, src); /* one side of the bulge dark */
    hd_light_from_direction(-60, 0, 1.2f, 0.15f, tgt);
    hd_decomposition d;
    hd_image in, mask;
    make_face(src, &d, &in, &mask);
    const size_t P = SIDE * SIDE;
    hd_light_rgb t;
    hd_light_rgb_from_grey(tgt, &t);
    hd_image w = image(SIDE, SIDE, 1, 0), regions;
    CHECK(hd_field_feather(mask.data, SIDE, SIDE, 0.04f * SIDE, w.data) == HD_OK);
    CHECK(hd_face_regions_uv(SIDE, &regions) == HD_OK);
    const float guards[3] = {0.3f, 0.1f, 0.02f};
    double errs[3];
    for (int i = 0; i < 3; i++) {
        hd_apply_request q = {&t, 1, 0, 0, HD_RULE_RATIO, HD_BRIGHTNESS_FREE, HD_SOURCE_FIT, guards[i], NULL};
        hd_apply_result r;
        errs[i] = 1;
        if (hd_apply_decomposition(&in, &d, &mask, &q, &r) != HD_OK) {
            CHECK(0);
            continue;
        }
        double err = 0;
        long n = 0;
        for (size_t p = 0; p < P; p++) {
            if (w.data[p] < 1.0f || regions.data[p] > 0.5f) continue;
            float nn[3] = {d.normal.data[p], d.normal.data[P + p], d.normal.data[2 * P + p]};
            float s = hd_sh_shade(tgt, nn);
            for (int c = 0; c < 3; c++) err += fabs(r.relit[0].data[c * P + p] - d.albedo.data[c * P + p] * (s > 0 ? s : 0));
            n += 3;
        }
        errs[i] = err / n;
        hd_apply_result_free(&r);
    }
    printf("guard 0.3 / 0.1 / 0.02: MAE against A s(N, l_target) %.4f / %.4f / %.4f\n", errs[0], errs[1], errs[2]);
    CHECK(errs[1] < errs[0] && errs[2] < errs[1]);
    hd_image_free(&w);
    hd_image_free(&regions);
    free_face(&d, &in, &mask);
}

/* The eyes follow the skin around them (no cap toward the face's mean): under a light from one
 * side, log r at each eye's centre (the eyes are regions, filled from the skin) is within a little
 * of the mean over the skin ring around that eye (0.3 .. 0.5 eye distances), and the lit eye's
 * change is well above the shadowed one's, as their rings' are. A cap toward the face's mean
 * ratio held both eyes within a factor 1.08 of it: a dark disc round the lit eye, a light one
 * round the shadowed eye. */
static void test_eyes_follow_skin(void)
{
    float src[HD_SH_COEFFS], tgt[HD_SH_COEFFS];
    hd_light_from_direction(0, 0, 1.0f, 0.6f, src);
    hd_light_from_direction(70, 0, 1.5f, 0.3f, tgt);
    hd_decomposition d;
    hd_image in, mask, lr = {0};
    make_face(src, &d, &in, &mask);
    hd_light_rgb t;
    hd_light_rgb_from_grey(tgt, &t);
    const hd_mesh *mesh = NULL;
    CHECK(hd_mesh_canonical(&mesh) == HD_OK);
    CHECK(hd_ratio_field(&d, &mask, SIDE, src, 0.0f, &t, NULL, &lr) == HD_OK);
    if (mesh && lr.data) {
        const int *eyes[2] = {hd_contour_right_eye, hd_contour_left_eye};
        float c[2][2] = {{0}};
        for (int e = 0; e < 2; e++) {
            int n = 0;
            for (; eyes[e][n] >= 0; n++)
                c[e][0] += mesh->uv[2 * eyes[e][n]] * SIDE, c[e][1] += mesh->uv[2 * eyes[e][n] + 1] * SIDE;
            c[e][0] /= n, c[e][1] /= n;
        }
        const float dist = hypotf(c[1][0] - c[0][0], c[1][1] - c[0][1]);
        float at[2], ring[2];
        for (int e = 0; e < 2; e++) {
            at[e] = lr.data[(size_t)c[e][1] * SIDE + (size_t)c[e][0]];
            double sum = 0;
            int n = 0;
            for (int y = 0; y < SIDE; y++)
                for (int x = 0; x < SIDE; x++) {
                    const float r = hypotf(x + 0.5f - c[e][0], y + 0.5f - c[e][1]) / dist;
                    if (r >= 0.3f && r <= 0.5f && mask.data[(size_t)y * SIDE + x] > 0.5f)
                        sum += lr.data[(size_t)y * SIDE + x], n++;
                }
            ring[e] = n ? (float)(sum / n) : 0.0f;
        }
        printf("eyes' log r %.3f / %.3f, their skin rings' %.3f / %.3f\n", at[0], at[1], ring[0], ring[1]);
        CHECK(fabsf(ring[0] - ring[1]) > 0.3f); /* the light from one side does reach them differently */
        CHECK(fabsf(at[0] - ring[0]) < 0.1f && fabsf(at[1] - ring[1]) < 0.1f);
        CHECK(fabsf(at[0] - at[1]) > 0.2f);
    }
    hd_image_free(&lr);
    free_face(&d, &in, &mask);
}

/* The face's region in a photo grows from the mesh's upper edge over the forehead's skin to the
 * hairline (forehead.c), and nowhere else: not into hair, the background, the neck below the
 * mesh, nor past its reach. A constructed face: eyes at (80, 100) and (120, 100) (eye distance 40),
 * forehead up (landmark 10 above, 152 below), skin in a disc of radius 70 with hair above y = 45
 * (or, bald, a disc of radius 90 and no hair; or a fringe of hair across the mesh's top, with skin
 * above it), the mesh's coverage a disc of radius 50 about (100, 110), so its top is at y = 60. */
static void test_forehead_region(void)
{
    static const int right_eye[] = {33, 7, 163, 144, 145, 153, 154, 155, 133, 173, 157, 158, 159, 160, 161, 246};
    static const int left_eye[] = {263, 249, 390, 373, 374, 380, 381, 382, 362, 398, 384, 385, 386, 387, 388, 466};
    const int W = 200, H = 200;
    const size_t P = (size_t)W * H;
    hd_aligned_face f;
    memset(&f, 0, sizeof f);
    for (int i = 0; i < HD_FACE_LANDMARKS; i++) f.landmarks[i][0] = 100, f.landmarks[i][1] = 100;
    for (int i = 0; i < 16; i++) {
        f.landmarks[right_eye[i]][0] = 80, f.landmarks[right_eye[i]][1] = 100;
        f.landmarks[left_eye[i]][0] = 120, f.landmarks[left_eye[i]][1] = 100;
    }
    f.landmarks[10][1] = 40, f.landmarks[152][1] = 190;
    for (int kind = 0; kind < 3; kind++) {
        const int bald = kind == 1, fringe = kind == 2;
        hd_image photo = image(W, H, 3, 0.8f); /* a light grey background */
        float *cov = calloc(P, sizeof *cov), *region = calloc(P, sizeof *region);
        if (!cov || !region) exit(1);
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                size_t p = (size_t)y * W + x;
                float dx = x + 0.5f - 100, dy = y + 0.5f - 100, dc = y + 0.5f - 110;
                const float *rgb = NULL;
                static const float skin[3] = {0.70f, 0.50f, 0.40f}, hair[3] = {0.10f, 0.07f, 0.05f};
                const float r = bald ? 90.0f : 70.0f; /* bald: skin up to the picture's top */
                if (dx * dx + dy * dy < r * r) rgb = (!bald && y < 45) || (fringe && y >= 55 && y < 75) ? hair : skin;
                if (x >= 85 && x < 115 && y > 165) rgb = skin; /* the neck */
                /* the skin's grain, so that its deviations are not 0 */
                for (int c = 0; rgb && c < 3; c++) photo.data[c * P + p] = rgb[c] * (1 + 0.02f * sinf(1.3f * x + 2.1f * y));
                cov[p] = dx * dx + dc * dc < 50 * 50 ? 1.0f : 0.0f;
            }
        CHECK(hd_photo_face_region(&f, &photo, cov, 0.0f, region) == HD_OK);
        int same = 1;
        for (size_t p = 0; p < P; p++) same &= region[p] == cov[p];
        CHECK(same); /* no growth: the coverage */
        CHECK(hd_photo_face_region(&f, &photo, cov, 0.7f, region) == HD_OK);
#define AT(x, y) region[(size_t)(y) * W + (x)]
        CHECK(AT(100, 50) == !fringe); /* forehead skin above the mesh */
        CHECK(AT(75, 55) == !fringe);
        CHECK(AT(100, 100) == 1.0f); /* the mesh itself */
        CHECK(AT(20, 100) == 0.0f);  /* background beside the face */
        CHECK(AT(100, 190) == 0.0f); /* the neck, below the mesh */
        CHECK(AT(100, 166) == 0.0f);
        if (fringe) {
            CHECK(AT(100, 50) == 0.0f); /* skin above a fringe across the mesh: not reached */
        } else if (!bald) {
            CHECK(AT(40, 60) == 0.0f); /* background at forehead height */
            CHECK(AT(100, 40) == 0.0f); /* hair */
            CHECK(AT(100, 44) == 0.0f);
        } else {
            CHECK(AT(100, 36) == 1.0f); /* 24 px above the mesh: within reach (0.7 x 40 = 28) */
            CHECK(AT(100, 29) == 0.0f); /* 31 px: beyond */
        }
#undef AT
        if (!bald && !fringe) {
            /* the feather: above the brows the whole change up to the grown region's top edge (the
             * growth stops a few pixels under the hair, y = 45, where the skin test's blur sees
             * it: y = 49 here) and a band of 0.12 x 40 = 4.8 px beyond it, over the skin left and
             * into the hair; inside the region's edge it used to fade to 0. On the cheeks it fades
             * inside the mesh's edge as before (0.3 x 40 = 12 px) */
            float *w = calloc(P, sizeof *w);
            if (!w) exit(1);
            CHECK(hd_photo_face_feather(&f, &photo, cov, w) == HD_OK);
            CHECK(hd_photo_face_region(&f, &photo, cov, HD_FOREHEAD_GROW, region) == HD_OK);
#define WT(x, y) w[(size_t)(y) * W + (x)]
            CHECK(region[(size_t)49 * W + 100] == 1.0f && region[(size_t)48 * W + 100] == 0.0f);
            CHECK(WT(100, 49) == 1.0f && WT(100, 55) == 1.0f); /* the region's edge: all of it */
            CHECK(WT(100, 46) > 0.3f && WT(100, 46) < WT(100, 48) && WT(100, 48) < 1.0f); /* beyond it */
            CHECK(WT(100, 44) == 0.0f && WT(100, 20) == 0.0f); /* the hair beyond the band: the photo */
            CHECK(WT(20, 100) == 0.0f);                          /* the background */
            CHECK(WT(145, 110) > 0.0f && WT(145, 110) < 0.5f);   /* 4.5 px inside the mesh's side */
            CHECK(WT(100, 110) == 1.0f);
#undef WT
            free(w);
        }
        size_t grown = 0;
        for (size_t p = 0; p < P; p++) grown += region[p] > 0.5f && cov[p] <= 0.5f;
        CHECK(fringe || grown > 200);
        hd_image_free(&photo);
        free(cov), free(region);
    }
}

/* A real face (tests/data/faces-london/001/smiling.jpg): the face mesh's coverage has holes (the
 * nostrils, the line between the lips), and the weight the change applies with is whole over them
 * rather than fading to 0 around each. */
static void test_photo_weight_holes(void)
{
    const char *td = getenv("HDNET_TESTDATA");
    char path[4200];
    snprintf(path, sizeof path, "%s/faces-london/001/smiling.jpg", td ? td : "tests/data");
    hd_image photo = {0}, warped = {0}, cover = {0};
    hd_aligned_face *faces = NULL;
    int n = 0;
    CHECK(hd_image_read_as(path, 3, &photo) == HD_OK);
    CHECK(photo.data && hd_align_photo(&photo, 128, &faces, &n) == HD_OK && n >= 1);
    if (n < 1) {
        hd_image_free(&photo);
        return;
    }
    const size_t P = (size_t)photo.width * photo.height;
    float *filled = malloc(P * sizeof *filled), *w = malloc(P * sizeof *w);
    CHECK(filled && w && hd_warp_back(&faces[0], &faces[0].mask, NULL, &warped, &cover) == HD_OK);
    if (filled && w && cover.data) {
        memcpy(filled, cover.data, P * sizeof *filled);
        CHECK(hd_field_fill_holes(filled, photo.width, photo.height) == HD_OK);
        CHECK(hd_photo_face_weight(&faces[0], &photo, w) == HD_OK);
        size_t holes = 0;
        double in_holes = 0;
        for (size_t p = 0; p < P; p++)
            if (cover.data[p] <= 0.5f && filled[p] > 0.5f) holes++, in_holes += w[p];
        /* between the inner lips (FaceMesh 13 and 14) */
        const float *a = faces[0].landmarks[13], *b = faces[0].landmarks[14];
        const int mx = (int)(0.5f * (a[0] + b[0])), my = (int)(0.5f * (a[1] + b[1]));
        printf("mesh holes: %zu pixels, mean weight over them %.4f; between the lips %.4f\n", holes,
               holes ? in_holes / (double)holes : 0.0, w[(size_t)my * photo.width + mx]);
        CHECK(holes > 20);
        CHECK(holes && in_holes / (double)holes > 0.99);
        CHECK(w[(size_t)my * photo.width + mx] == 1.0f);
    }
    free(filled), free(w);
    hd_image_free(&warped), hd_image_free(&cover), hd_image_free(&photo);
    hd_aligned_faces_free(faces, n);
}


/* Cast shadows in the rule (rule.c, cast_shadow.c): with the head's pose, a light from the image's
 * left darkens the change on the right half (the nose's shadow on the cheek) and never brightens
 * it anywhere, for a grey light and each channel of a coloured one; a light that does not change
 * changes nothing, shadows or not. The source light is along the camera's axis: it casts none. */
static void test_cast_shadows(void)
{
    float src[HD_SH_COEFFS], tgt[HD_SH_COEFFS];
    hd_light_from_direction(0, 0, 1.0f, 0.6f, src);
    hd_light_from_direction(-60, 0, 1.5f, 0.3f, tgt);
    hd_decomposition d;
    hd_image in, mask, on = {0}, off = {0}, same = {0};
    make_face(src, &d, &in, &mask);
    const float I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    hd_light_rgb t, s, c;
    hd_light_rgb_from_grey(tgt, &t);
    hd_light_rgb_from_grey(src, &s);
    const float colour[3] = {1.0f, 0.8f, 0.6f};
    hd_light_rgb_from_direction(-60, 0, 1.5f, 0.3f, colour, &c);
    CHECK(hd_ratio_field(&d, &mask, SIDE, src, 0.0f, &s, I, &same) == HD_OK);
    int zero = 1;
    for (size_t p = 0; same.data && p < (size_t)SIDE * SIDE; p++) zero &= same.data[p] == 0.0f;
    CHECK(same.data && zero);
    for (int coloured = 0; coloured < 2; coloured++) {
        const hd_light_rgb *L = coloured ? &c : &t;
        CHECK(hd_ratio_field(&d, &mask, SIDE, src, 0.0f, L, I, &on) == HD_OK);
        CHECK(hd_ratio_field(&d, &mask, SIDE, src, 0.0f, L, NULL, &off) == HD_OK);
        if (!on.data || !off.data) break;
        double half[2] = {0, 0}, most = 0;
        int darker = 1;
        for (int ch = 0; ch < on.channels; ch++)
            for (int y = 0; y < SIDE; y++)
                for (int x = 0; x < SIDE; x++) {
                    const size_t p = (size_t)ch * SIDE * SIDE + (size_t)y * SIDE + x;
                    const double drop = off.data[p] - on.data[p];
                    darker &= drop >= -1e-5;
                    half[x >= SIDE / 2] += drop, most = fmax(most, drop);
                }
        printf("cast shadows (%s light): log r lower by %.3f at most, summed %.1f on the right half, %.1f on the left\n",
               coloured ? "coloured" : "grey", most, half[1], half[0]);
        CHECK(darker && most > 0.5 && half[1] > 10 * half[0]);
        hd_image_free(&on), hd_image_free(&off);
    }
    hd_image_free(&same);
    free_face(&d, &in, &mask);
}

int main(void)
{
    /* the canonical mesh (for the face regions): from the build tree, the source tree's models/ */
    const char *td = getenv("HDNET_TESTDATA");
    if (!getenv("HDNET_DATA") && td) {
        char dir[4096];
        snprintf(dir, sizeof dir, "%s/../../models", td); /* HDNET_TESTDATA is <source>/tests/data */
        setenv("HDNET_DATA", dir, 1);
    }
    test_metrics();
    test_fields();
    test_rule();
    test_source_light();
    test_fit_weight();
    test_guard();
    test_eyes_follow_skin();
    test_forehead_region();
    test_photo_weight_holes();
    test_cast_shadows();
    return test_summary("test_relight_rule");
}
