/* test_white_balance.c: the camera's colour cast read from the whites of the eyes
 * (src/model/white_balance.c) and divided out by hd_model_decompose. Constructed textures with a
 * known answer: a face of neutral balance reads 1, 1, 1; the same face under a known cast reads
 * that cast whatever its brightness and its iris; a cast past the bounds is clamped; closed or
 * masked-out eyes read 1, 1, 1. With the shipped model on a real aligned face: off by default (bit
 * for bit the same as off); on, the cast is reported, the reconstruction is albedo x shading x tint
 * exactly, and the albedo of a cast copy stays close to the albedo of the original (it does not
 * without the balance). */
#include <stdlib.h>
#include <string.h>
#include "test.h"
#include "source_dir.h"
#include "core/core.h"
#include "model/white_balance.h"

#define S 96

/* Skin everywhere, and inside the eyes a sclera of neutral chroma with an iris on a third of the
 * texels; then every channel multiplied by cast[c] * level. */
static void face_texture(const float *eyes, const float cast[3], float level, float *rgb)
{
    const size_t P = (size_t)S * S;
    const float skin[3] = {0.62f, 0.45f, 0.36f}, iris[3] = {0.16f, 0.09f, 0.05f};
    for (int y = 0; y < S; y++)
        for (int x = 0; x < S; x++) {
            size_t p = (size_t)y * S + x;
            for (int c = 0; c < 3; c++) {
                float v = skin[c];
                if (eyes[p] > 0.5f) v = (x + y) % 3 == 0 ? iris[c] : 0.8f * hd_sclera_chroma[c];
                rgb[c * P + p] = v * cast[c] * level;
            }
        }
}

static void test_known_casts(void)
{
    hd_image eyes = {0};
    CHECK(hd_eyes_uv(S, &eyes) == HD_OK);
    if (!eyes.data) return;
    size_t n = 0;
    for (size_t p = 0; p < (size_t)S * S; p++) n += eyes.data[p] > 0.5f;
    CHECK(n > 60); /* two eyes of a few dozen texels each at 96 */
    float *rgb = malloc((size_t)3 * S * S * sizeof *rgb), t[3];
    if (!rgb) exit(1);
    const float neutral[3] = {1, 1, 1};
    face_texture(eyes.data, neutral, 1.0f, rgb);
    CHECK(hd_eye_tint(rgb, S, eyes.data, t) == HD_OK);
    for (int c = 0; c < 3; c++) CHECK_NEAR(t[c], 1.0, 1e-5);
    /* warm and cool casts, at two brightness levels: the tint is the cast over its mean */
    const float casts[3][3] = {{1.25f, 1.0f, 0.8f}, {0.8f, 1.02f, 1.3f}, {1.1f, 0.9f, 1.0f}};
    for (int k = 0; k < 3; k++)
        for (int l = 0; l < 2; l++) {
            face_texture(eyes.data, casts[k], l ? 0.45f : 1.0f, rgb);
            CHECK(hd_eye_tint(rgb, S, eyes.data, t) == HD_OK);
            float mean = (casts[k][0] + casts[k][1] + casts[k][2]) / 3;
            for (int c = 0; c < 3; c++) CHECK_NEAR(t[c], casts[k][c] / mean, 1e-5);
        }
    /* past the bounds: clamped */
    const float wild[3] = {3.0f, 1.0f, 0.2f};
    face_texture(eyes.data, wild, 0.3f, rgb);
    CHECK(hd_eye_tint(rgb, S, eyes.data, t) == HD_OK);
    CHECK(t[0] == HD_TINT_MAX && t[2] == HD_TINT_MIN && t[1] > HD_TINT_MIN && t[1] < HD_TINT_MAX);
    /* eyes closed or masked out (black there): nothing to go by */
    for (size_t p = 0; p < (size_t)S * S; p++)
        if (eyes.data[p] > 0.5f) rgb[p] = rgb[S * S + p] = rgb[2 * S * S + p] = 0.0f;
    t[0] = t[1] = t[2] = 5.0f;
    CHECK(hd_eye_tint(rgb, S, eyes.data, t) == HD_OK);
    CHECK(t[0] == 1.0f && t[1] == 1.0f && t[2] == 1.0f);
    /* the public call rasterises the eyes itself and agrees */
    hd_image tex = {0};
    CHECK(hd_image_alloc(&tex, S, S, 3) == HD_OK);
    if (tex.data) {
        face_texture(eyes.data, casts[0], 0.9f, tex.data);
        float u[3];
        CHECK(hd_eye_white_balance(&tex, u) == HD_OK);
        CHECK(hd_eye_tint(tex.data, S, eyes.data, t) == HD_OK);
        CHECK(memcmp(t, u, sizeof t) == 0);
    }
    hd_image_free(&tex);
    /* bad input: named, and the tint left neutral */
    hd_image odd = {0};
    CHECK(hd_image_alloc(&odd, S, S / 2, 3) == HD_OK);
    t[0] = 7;
    CHECK(hd_eye_white_balance(&odd, t) == HD_ERR_ARG && strstr(hd_error(), "square") && t[0] == 1.0f);
    CHECK(hd_eye_white_balance(NULL, t) == HD_ERR_ARG);
    hd_image_free(&odd);
    free(rgb);
    hd_image_free(&eyes);
}

/* mean |a - b| over the texels where mask > 0.5 */
static double masked_mae(const hd_image *a, const hd_image *b, const hd_image *mask)
{
    const size_t P = (size_t)a->width * a->height;
    double sum = 0;
    size_t n = 0;
    for (size_t p = 0; p < P; p++)
        if (mask->data[p] > 0.5f)
            for (int c = 0; c < 3; c++) sum += fabsf(a->data[c * P + p] - b->data[c * P + p]), n++;
    return n ? sum / n : 1e9;
}

static void test_model_balances(const char *source_dir)
{
    char path[4400];
    snprintf(path, sizeof path, "%s/tests/data/faces/london-001.jpg", source_dir);
    hd_image photo = {0};
    hd_model *model = NULL;
    hd_aligned_face *faces = NULL;
    int count = 0;
    CHECK(hd_image_read_as(path, 3, &photo) == HD_OK);
    CHECK(hd_model_load(NULL, &model) == HD_OK);
    if (!model || !photo.data) goto done;
    CHECK(hd_align_photo(&photo, hd_model_size(model), &faces, &count) == HD_OK && count >= 1);
    if (count < 1) goto done;
    const hd_image *tex = &faces[0].texture, *mask = &faces[0].mask;
    const size_t P = (size_t)tex->width * tex->height;
    /* a warm cast (and a little darker, so nothing clips) */
    const float warm[3] = {1.16f, 1.0f, 0.84f};
    hd_image cast = {0};
    CHECK(hd_image_alloc(&cast, tex->width, tex->height, 3) == HD_OK);
    if (!cast.data) goto done;
    for (int c = 0; c < 3; c++)
        for (size_t p = 0; p < P; p++) cast.data[c * P + p] = tex->data[c * P + p] * warm[c] * 0.8f;
    hd_decomposition d0 = {0}, d1 = {0}, off = {0}, dflt = {0};
    CHECK(hd_model_decompose(model, &cast, 1, &dflt) == HD_OK); /* the default: off */
    CHECK(hd_model_set_white_balance(model, HD_WHITE_BALANCE_EYES) == HD_OK);
    CHECK(hd_model_decompose(model, tex, 1, &d0) == HD_OK);
    CHECK(hd_model_decompose(model, &cast, 1, &d1) == HD_OK);
    CHECK(hd_model_set_white_balance(model, HD_WHITE_BALANCE_OFF) == HD_OK);
    CHECK(hd_model_decompose(model, &cast, 1, &off) == HD_OK);
    CHECK(hd_model_set_white_balance(model, (hd_white_balance)7) == HD_ERR_ARG);
    CHECK(hd_model_set_white_balance(NULL, HD_WHITE_BALANCE_OFF) == HD_ERR_ARG);
    if (!d0.albedo.data || !d1.albedo.data || !off.albedo.data || !dflt.albedo.data) goto free_d;
    CHECK(memcmp(dflt.albedo.data, off.albedo.data, P * 3 * sizeof(float)) == 0 &&
          memcmp(dflt.reconstruction.data, off.reconstruction.data, P * 3 * sizeof(float)) == 0);
    /* a studio photo reads close to neutral; the cast copy reads the cast on top of it */
    fprintf(stderr, "tint: photo %.3f %.3f %.3f, warm copy %.3f %.3f %.3f\n", d0.camera_tint[0], d0.camera_tint[1],
            d0.camera_tint[2], d1.camera_tint[0], d1.camera_tint[1], d1.camera_tint[2]);
    double m = 0;
    for (int c = 0; c < 3; c++) m += d0.camera_tint[c] * warm[c] / 3;
    for (int c = 0; c < 3; c++) {
        CHECK(fabsf(d0.camera_tint[c] - 1.0f) < 0.08f);
        CHECK_NEAR(d1.camera_tint[c], d0.camera_tint[c] * warm[c] / m, 0.01);
        CHECK(off.camera_tint[c] == 1.0f);
    }
    /* the reconstruction is the input as explained: albedo x shading x tint */
    int exact = 1;
    for (int c = 0; c < 3; c++)
        for (size_t p = 0; p < P; p++)
            exact &= d1.reconstruction.data[c * P + p] ==
                     d1.albedo.data[c * P + p] * d1.shading.data[p] * d1.camera_tint[c];
    CHECK(exact);
    /* the albedo's colour survives the cast with the balance (up to the 0.8 level, which the
     * shading takes), and does not without it */
    double with = masked_mae(&d0.albedo, &d1.albedo, mask), without = masked_mae(&d0.albedo, &off.albedo, mask);
    fprintf(stderr, "albedo change under the warm cast: %.4f balanced, %.4f not\n", with, without);
    CHECK(with < 0.5 * without);
free_d:
    hd_decomposition_free(&d0);
    hd_decomposition_free(&d1);
    hd_decomposition_free(&off);
    hd_decomposition_free(&dflt);
    hd_image_free(&cast);
done:
    hd_aligned_faces_free(faces, count);
    hd_model_free(model);
    hd_image_free(&photo);
}

int main(void)
{
    const char *source_dir = test_source_dir();
    char path[4400];
    snprintf(path, sizeof path, "%s/models", source_dir);
    setenv("HDNET_DATA", path, 1);
    test_known_casts();
    test_model_balances(source_dir);
    return test_summary("white_balance");
}
