/* test_apply.c: relighting (src/apply) against analytic cases. A decomposition is built by hand
 * from a hemisphere of normals, a light and a random albedo, with S = s(N, l) and I = A * S, so
 * that relighting under the face's own light must return I, delighting must return A, and a new
 * light must give A * s(N, l_new) computed independently with hd_sh_shade. Also: the brightness
 * rule (masked mean kept, also through the clamp), transfer, soft masks, resized decompositions,
 * mask companions; and, once they are shipped, that the default model reconstructs the bundled
 * example faces (issue 6: reconstruction MAE under 0.03). Contact sheets: test_image.c. */
#include <stdlib.h>
#include <string.h>
#include "test.h"
#include "core/core.h"
#include "io/dataset.h"
#include "apply/apply.h"

#define SIDE 32

/* DPR's rotate_light_00.txt (SPEC section 2). */
static const float light00[HD_SH_COEFFS] = {
    1.084125496282453138f, -0.4642676300617166185f, 0.02837846795150648915f, 0.6765292733937575687f,
    -0.3594067725393816914f, 0.04790996460111427574f, -0.2280054643781863066f, -0.08125983081159608712f,
    0.2881082012687687932f};

static float *alloc_floats(size_t n)
{
    float *p = calloc(n, sizeof *p);
    if (!p) {
        fprintf(stderr, "out of memory\n");
        exit(1);
    }
    return p;
}

static hd_image make_image(int w, int h, int c)
{
    hd_image img = {w, h, c, alloc_floats((size_t)w * h * c)};
    return img;
}

/* A face-like decomposition: normals of a bulge seen from the front (z > 0 everywhere), albedo uniform in [0.1, 0.5] per channel, S = s(N, l), and the
 * matching input I = A * S. */
static void make_face(const float light[HD_SH_COEFFS], uint64_t seed, hd_decomposition *d, hd_image *input)
{
    memset(d, 0, sizeof *d);
    const int n = SIDE * SIDE;
    d->albedo = make_image(SIDE, SIDE, 3);
    d->shading = make_image(SIDE, SIDE, 1);
    d->normal = make_image(SIDE, SIDE, 3);
    d->reconstruction = make_image(SIDE, SIDE, 3);
    *input = make_image(SIDE, SIDE, 3);
    hd_rng rng;
    hd_rng_seed(&rng, seed, 1);
    for (int y = 0; y < SIDE; y++)
        for (int x = 0; x < SIDE; x++) {
            int p = y * SIDE + x;
            float u = (x + 0.5f) / SIDE * 2 - 1, v = 1 - (y + 0.5f) / SIDE * 2; /* v up */
            float nx = 0.8f * u, ny = 0.8f * v, len = sqrtf(nx * nx + ny * ny + 1.0f); /* n ~ (0.8u, 0.8v, 1) */
            d->normal.data[p] = nx / len;
            d->normal.data[n + p] = ny / len;
            d->normal.data[2 * n + p] = 1.0f / len;
            for (int c = 0; c < 3; c++) d->albedo.data[c * n + p] = hd_rng_range(&rng, 0.1f, 0.5f);
        }
    hd_sh_shading_map(d->normal.data, NULL, n, light, d->shading.data);
    for (int c = 0; c < 3; c++)
        for (int p = 0; p < n; p++) {
            float a = d->albedo.data[c * n + p], s = d->shading.data[p];
            input->data[c * n + p] = d->reconstruction.data[c * n + p] = a * (s > 0 ? s : 0);
        }
    memcpy(d->light, light, sizeof d->light);
}

static void free_face(hd_decomposition *d, hd_image *input)
{
    hd_image_free(&d->albedo);
    hd_image_free(&d->shading);
    hd_image_free(&d->normal);
    hd_image_free(&d->reconstruction);
    hd_image_free(input);
}

/* Mask-weighted mean over pixels and channels. */
static double masked_mean(const hd_image *img, const hd_image *mask)
{
    const size_t n = (size_t)img->width * img->height;
    double sum = 0, wsum = 0;
    for (size_t p = 0; p < n; p++) {
        double w = mask ? mask->data[p] : 1.0;
        for (int c = 0; c < img->channels; c++) sum += w * img->data[c * n + p];
        wsum += w * img->channels;
    }
    return sum / wsum;
}

/* A disk mask of radius 0.7 (binary). */
static hd_image disk_mask(void)
{
    hd_image m = make_image(SIDE, SIDE, 1);
    for (int y = 0; y < SIDE; y++)
        for (int x = 0; x < SIDE; x++) {
            float u = (x + 0.5f) / SIDE * 2 - 1, v = (y + 0.5f) / SIDE * 2 - 1;
            m.data[y * SIDE + x] = u * u + v * v < 0.49f ? 1.0f : 0.0f;
        }
    return m;
}

static void test_own_light_and_delight(void)
{
    hd_decomposition d;
    hd_image input, out = {0};
    make_face(light00, 1, &d, &input);
    const int n = SIDE * SIDE;
    int checked = 0;
    for (int b = 0; b < 2; b++) {
        CHECK(hd_relight(&input, &d, NULL, light00, b ? HD_BRIGHTNESS_KEEP : HD_BRIGHTNESS_FREE, &out) == HD_OK);
        for (int c = 0; c < 3; c++)
            for (int p = 0; p < n; p++)
                if (d.shading.data[p] > HD_SHADING_FLOOR) {
                    CHECK_NEAR(out.data[c * n + p], input.data[c * n + p], 2e-6);
                    checked++;
                }
        hd_image_free(&out);
    }
    CHECK(checked > n); /* light 00 lights most of the hemisphere */
    CHECK(hd_delight(&input, &d, NULL, &out) == HD_OK);
    for (int c = 0; c < 3; c++)
        for (int p = 0; p < n; p++)
            if (d.shading.data[p] > HD_SHADING_FLOOR) CHECK_NEAR(out.data[c * n + p], d.albedo.data[c * n + p], 2e-6);
    hd_image_free(&out);
    /* hd_relight_albedo is the same ratio, without mask */
    CHECK(hd_relight_albedo(&input, &d, &out) == HD_OK);
    CHECK_NEAR(out.data[n / 2 + SIDE / 2], d.albedo.data[n / 2 + SIDE / 2], 2e-6);
    hd_image_free(&out);
    free_face(&d, &input);
}

static void test_new_light(void)
{
    hd_decomposition d;
    hd_image input, out = {0};
    make_face(light00, 2, &d, &input);
    const int n = SIDE * SIDE;
    float target[HD_SH_COEFFS];
    CHECK(hd_light_preset(2, target) == HD_OK);
    CHECK(hd_relight(&input, &d, NULL, target, HD_BRIGHTNESS_FREE, &out) == HD_OK);
    int checked = 0;
    for (int p = 0; p < n; p += 7) {
        if (d.shading.data[p] <= HD_SHADING_FLOOR) continue;
        float nrm[3] = {d.normal.data[p], d.normal.data[n + p], d.normal.data[2 * n + p]};
        float s = hd_sh_shade(target, nrm);
        for (int c = 0; c < 3; c++) {
            float want = d.albedo.data[c * n + p] * (s > 0 ? s : 0);
            CHECK_NEAR(out.data[c * n + p], want > 1 ? 1 : want, 2e-6);
        }
        checked++;
    }
    CHECK(checked > 50);
    hd_image_free(&out);
    free_face(&d, &input);
}

static void test_keep_brightness(void)
{
    hd_decomposition d;
    hd_image input, out = {0}, free_out = {0};
    make_face(light00, 3, &d, &input);
    hd_image mask = disk_mask();
    const int n = SIDE * SIDE;
    const double want = masked_mean(&input, &mask);
    /* a dim light (no clamping) and a bright one from the side (clamping at 1 on the lit side
     * once scaled, since the input is brighter on average than the dim relit face) */
    float lights[3][HD_SH_COEFFS];
    hd_light_from_direction(30, 10, 0.2f, 0.05f, lights[0]);
    hd_light_from_direction(-80, 0, 3.0f, 0.0f, lights[1]);
    hd_light_preset(5, lights[2]);
    int saturated = 0;
    for (int i = 0; i < 3; i++) {
        CHECK(hd_relight(&input, &d, &mask, lights[i], HD_BRIGHTNESS_KEEP, &out) == HD_OK);
        CHECK(hd_relight(&input, &d, &mask, lights[i], HD_BRIGHTNESS_FREE, &free_out) == HD_OK);
        CHECK_NEAR(masked_mean(&out, &mask), want, 1e-5);
        CHECK(fabs(masked_mean(&free_out, &mask) - want) > 1e-3); /* the rule did something */
        for (int c = 0; c < 3; c++)
            for (int p = 0; p < n; p++) {
                if (mask.data[p] == 0.0f) CHECK(out.data[c * n + p] == input.data[c * n + p]);
                saturated += out.data[c * n + p] == 1.0f;
                CHECK(out.data[c * n + p] >= 0.0f && out.data[c * n + p] <= 1.0f);
            }
        hd_image_free(&out);
        hd_image_free(&free_out);
    }
    CHECK(saturated > 0); /* the bright case went through the clamp */
    hd_image_free(&mask);
    free_face(&d, &input);
}

static void test_transfer_and_soft_mask(void)
{
    hd_decomposition d, ref;
    hd_image input, ref_input, a = {0}, b = {0}, m = make_image(SIDE, SIDE, 1);
    make_face(light00, 4, &d, &input);
    float other[HD_SH_COEFFS];
    hd_light_from_direction(-40, 20, 1.2f, 0.6f, other);
    make_face(other, 5, &ref, &ref_input);
    const int n = SIDE * SIDE;
    for (int p = 0; p < n; p++) m.data[p] = 0.25f;
    CHECK(hd_transfer(&input, &d, &m, &ref, HD_BRIGHTNESS_KEEP, &a) == HD_OK);
    CHECK(hd_relight(&input, &d, &m, other, HD_BRIGHTNESS_KEEP, &b) == HD_OK);
    CHECK(memcmp(a.data, b.data, sizeof(float) * 3 * n) == 0);
    hd_image_free(&a);
    hd_image_free(&b);
    /* soft mask: out = m relit + (1 - m) I */
    CHECK(hd_relight(&input, &d, &m, other, HD_BRIGHTNESS_FREE, &a) == HD_OK);
    CHECK(hd_relight(&input, &d, NULL, other, HD_BRIGHTNESS_FREE, &b) == HD_OK);
    for (int i = 0; i < 3 * n; i += 5) CHECK_NEAR(a.data[i], 0.25f * b.data[i] + 0.75f * input.data[i], 1e-6);
    hd_image_free(&a);
    hd_image_free(&b);
    hd_image_free(&m);
    free_face(&ref, &ref_input);
    free_face(&d, &input);
}

/* A decomposition at 16 x 16 applied to a 48 x 40 image: constant maps survive resizing, so the
 * result is I / S * s(n, l) exactly. */
static void test_resized_decomposition(void)
{
    hd_decomposition d;
    memset(&d, 0, sizeof d);
    d.shading = make_image(16, 16, 1);
    d.normal = make_image(16, 16, 3);
    const float nrm[3] = {0.6f, 0.0f, 0.8f};
    for (int p = 0; p < 256; p++) {
        d.shading.data[p] = 1.25f;
        for (int c = 0; c < 3; c++) d.normal.data[c * 256 + p] = nrm[c];
    }
    hd_image input = make_image(48, 40, 3), out = {0};
    for (int i = 0; i < 48 * 40 * 3; i++) input.data[i] = (float)(i % 97) / 97.0f;
    float target[HD_SH_COEFFS];
    hd_light_preset(0, target);
    CHECK(hd_relight(&input, &d, NULL, target, HD_BRIGHTNESS_FREE, &out) == HD_OK);
    CHECK(out.width == 48 && out.height == 40 && out.channels == 3);
    const float s = hd_sh_shade(target, nrm);
    for (int i = 0; i < 48 * 40 * 3; i += 11) {
        float want = input.data[i] / 1.25f * s;
        CHECK_NEAR(out.data[i], want > 1 ? 1 : want, 2e-6);
    }
    hd_image_free(&out);
    /* errors: a gray image, a non-finite light */
    hd_image gray = make_image(16, 16, 1);
    CHECK(hd_relight(&gray, &d, NULL, target, HD_BRIGHTNESS_KEEP, &out) == HD_ERR_ARG);
    CHECK(out.data == NULL);
    target[4] = NAN;
    CHECK(hd_relight(&input, &d, NULL, target, HD_BRIGHTNESS_KEEP, &out) == HD_ERR_NUMERIC);
    CHECK(strstr(hd_error(), "coefficient 4") != NULL);
    hd_image_free(&gray);
    hd_image_free(&input);
    hd_image_free(&d.shading);
    hd_image_free(&d.normal);
}

static void test_mask_companion(void)
{
    hd_image m = make_image(8, 8, 1), got = {0};
    for (int p = 0; p < 64; p++) m.data[p] = p < 32 ? 1.0f : 0.0f;
    CHECK(hd_image_write_png("face.mask.png", &m, 8) == HD_OK);
    char *source = NULL;
    /* the companion beside face.png, resized to 16 x 16 */
    CHECK(hd_face_mask_read("face.png", "other.png", 16, 16, &got, &source) == HD_OK);
    CHECK(source && strcmp(source, "face.mask.png") == 0);
    CHECK(got.width == 16 && got.height == 16 && got.channels == 1);
    if (got.data) CHECK(got.data[0] == 1.0f && got.data[255] == 0.0f);
    free(source);
    hd_image_free(&got);
    /* no companion: the fallback; none: all ones */
    CHECK(hd_face_mask_read("nobody.png", "face.mask.png", 8, 8, &got, &source) == HD_OK);
    CHECK(source && strcmp(source, "face.mask.png") == 0);
    free(source);
    hd_image_free(&got);
    CHECK(hd_face_mask_read("nobody.png", NULL, 4, 4, &got, &source) == HD_OK);
    CHECK(source == NULL && got.data && got.data[5] == 1.0f);
    hd_image_free(&got);
    /* a broken companion is an error naming it */
    FILE *f = fopen("broken.mask.png", "wb");
    if (f) {
        fputs("not a png", f);
        fclose(f);
    }
    CHECK(hd_face_mask_read("broken.jpg", NULL, 4, 4, &got, &source) != HD_OK);
    CHECK(strstr(hd_error(), "broken.mask.png") != NULL);
    CHECK(hd_face_mask_read("nobody.png", "missing.png", 4, 4, &got, NULL) != HD_OK);
    CHECK(strstr(hd_error(), "missing.png") != NULL);
    hd_image_free(&m);
}

/* The shipped model (models/hdnet-synth.safetensors) on the first bundled example face
 * (examples/faces/): A * S against the input, over the mask, at the model's size. Both ship with
 * the repository, found from $HDNET_TESTDATA (tests/data): either missing is a failure. */
static void test_shipped_model(void)
{
    const char *testdata = getenv("HDNET_TESTDATA");
    char model_path[4096], faces[4096];
    CHECK(testdata != NULL);
    if (!testdata || snprintf(model_path, sizeof model_path, "%s/../../models/hdnet-synth.safetensors", testdata) >=
                         (int)sizeof model_path)
        return;
    snprintf(faces, sizeof faces, "%s/../../examples/faces", testdata);
    FILE *f = fopen(model_path, "rb");
    CHECK(f != NULL && hd_is_dir(faces));
    if (!f || !hd_is_dir(faces)) {
        if (f) fclose(f);
        return;
    }
    fclose(f);
    hd_model *model = NULL;
    hd_dataset ds;
    CHECK(hd_model_load(model_path, &model) == HD_OK);
    CHECK(hd_dataset_scan(faces, &ds, NULL) == HD_OK);
    if (!model || ds.count == 0) {
        fprintf(stderr, "shipped model: %s\n", hd_error());
        if (model) hd_model_free(model);
        return;
    }
    const int size = hd_model_size(model);
    hd_image img = {0}, sized = {0}, mask = {0};
    hd_decomposition d;
    memset(&d, 0, sizeof d);
    CHECK(hd_image_read_as(ds.samples[0].image, 3, &img) == HD_OK);
    CHECK(hd_image_resize(&img, size, size, &sized) == HD_OK);
    CHECK(hd_face_mask_read(ds.samples[0].image, NULL, size, size, &mask, NULL) == HD_OK);
    CHECK(hd_model_decompose(model, &img, 1, &d) == HD_OK);
    if (d.reconstruction.data && sized.data && mask.data) {
        const size_t n = (size_t)size * size;
        double err = 0, wsum = 0;
        for (size_t p = 0; p < n; p++)
            for (int c = 0; c < 3; c++) {
                float r = d.reconstruction.data[c * n + p];
                err += mask.data[p] * fabs((r > 1 ? 1 : r) - sized.data[c * n + p]);
                wsum += mask.data[p];
            }
        printf("test_apply: shipped model on %s: reconstruction MAE %.4f\n", ds.samples[0].image, err / wsum);
        CHECK(err / wsum < 0.03);
    }
    hd_decomposition_free(&d);
    hd_image_free(&img);
    hd_image_free(&sized);
    hd_image_free(&mask);
    hd_dataset_free(&ds);
    hd_model_free(model);
}

/* ---- the reasons name the operation the caller asked for, not always "relight" */

static void test_reason_names_operation(void)
{
    hd_image grey = {0};
    CHECK(hd_image_alloc(&grey, 8, 8, 1) == HD_OK); /* one channel: refused before any work */
    hd_decomposition d = {0};
    hd_apply_result r;
    const char *ops[] = {"delight", "transfer", NULL};
    for (int i = 0; i < 3; i++) {
        hd_apply_request q = {NULL, 0, 1, 0, HD_RULE_RATIO, HD_BRIGHTNESS_KEEP, HD_SOURCE_FIT, 0.0f, ops[i]};
        CHECK(hd_apply_decomposition(&grey, &d, NULL, &q, &r) == HD_ERR_ARG);
        char want[32];
        snprintf(want, sizeof want, "%s:", ops[i] ? ops[i] : "relight");
        CHECK(strncmp(hd_error(), want, strlen(want)) == 0);
    }
    hd_image_free(&grey);
    /* a refusal from a piece of the rule (rule.c: no normals) names the operation too */
    hd_image tex = {0};
    CHECK(hd_image_alloc(&tex, 8, 8, 3) == HD_OK);
    for (int i = 0; i < 3; i++) {
        hd_apply_request q = {NULL, 0, 1, 0, HD_RULE_RATIO, HD_BRIGHTNESS_KEEP, HD_SOURCE_LNET, 0.0f, ops[i]};
        CHECK(hd_apply_decomposition(&tex, &d, NULL, &q, &r) == HD_ERR_ARG);
        char want[64];
        snprintf(want, sizeof want, "%s: the decomposition has no normals", ops[i] ? ops[i] : "relight");
        if (strcmp(hd_error(), want) != 0) fprintf(stderr, "test_apply: reason '%s', want '%s'\n", hd_error(), want);
        CHECK(strcmp(hd_error(), want) == 0);
    }
    hd_image_free(&tex);
}

int main(void)
{
    test_own_light_and_delight();
    test_reason_names_operation();
    test_new_light();
    test_keep_brightness();
    test_transfer_and_soft_mask();
    test_resized_decomposition();
    test_mask_companion();
    test_shipped_model();
    return test_summary("apply");
}
