/* test_photo_coverage.c: issue 36's head measures (src/eval/photo_coverage.c) on constructed faces
 * whose answer is known: the canonical mesh's landmarks laid on a picture of skin; a change
 * confined to the face's outline scores coverage 0, a change of the whole picture 1; a step of the
 * change across the forehead scores a high band, a smooth ramp about 1; the band stops at the
 * hairline (a step in the hair is not the forehead's) and is not measured under a fringe; the skin
 * model keeps a blue background and dark hair out. */
#include <stdlib.h>
#include <string.h>
#include "test.h"
#include "core/core.h"
#include "mesh/mesh.h"
#include "eval/photo_coverage.h"

enum { W = 256, H = 256 };
#define SCALE 7.0f /* pixels per cm of the canonical mesh */

static float lm[HD_FACE_LANDMARKS][3];
static float eye_mid[2], eye_dist, up[2];

/* The canonical mesh's vertices as a frontal face in the middle of the picture. */
static int landmarks(void)
{
    const hd_mesh *mesh = NULL;
    if (hd_mesh_canonical(&mesh) != HD_OK) return 0;
    for (int i = 0; i < HD_FACE_LANDMARKS; i++) {
        lm[i][0] = 128 + SCALE * mesh->pos[3 * i];
        lm[i][1] = 120 - SCALE * mesh->pos[3 * i + 1];
        lm[i][2] = SCALE * mesh->pos[3 * i + 2];
    }
    float eyes[2][2];
    hd_face_eye_centres((const float (*)[3])lm, eyes);
    eye_mid[0] = 0.5f * (eyes[0][0] + eyes[1][0]), eye_mid[1] = 0.5f * (eyes[0][1] + eyes[1][1]);
    eye_dist = hypotf(eyes[1][0] - eyes[0][0], eyes[1][1] - eyes[0][1]);
    float ux = lm[10][0] - lm[152][0], uy = lm[10][1] - lm[152][1], ul = hypotf(ux, uy);
    up[0] = ux / ul, up[1] = uy / ul;
    return 1;
}

/* Height of pixel (x, y) above the eye line, in eye distances. */
static float height(int x, int y) { return ((x + 0.5f - eye_mid[0]) * up[0] + (y + 0.5f - eye_mid[1]) * up[1]) / eye_dist; }

/* Skin with a grain everywhere, hair (dark brown) above height `hair` (> 5: none), a fringe
 * between heights 0.4 and 1.6 when asked, and a blue background beyond `radius` pixels from the
 * face's middle (0: none). */
static hd_image picture(float hair, int fringe, float radius)
{
    hd_image im = {0};
    if (hd_image_alloc(&im, W, H, 3) != HD_OK) exit(1);
    const size_t P = (size_t)W * H;
    static const float skin[3] = {0.62f, 0.45f, 0.36f}, brown[3] = {0.12f, 0.08f, 0.05f}, blue[3] = {0.2f, 0.3f, 0.7f};
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            const float h = height(x, y), dx = x + 0.5f - 128, dy = y + 0.5f - 128;
            const float *rgb = h > hair || (fringe && h > 0.4f && h < 1.6f) ? brown : skin;
            if (radius > 0 && dx * dx + dy * dy > radius * radius) rgb = blue;
            for (int c = 0; c < 3; c++)
                im.data[c * P + (size_t)y * W + x] = rgb[c] * (1.0f + 0.04f * sinf(1.3f * x + 2.1f * y));
        }
    return im;
}

/* in times exp(f(x, y)), f given as a kind of change. */
enum { MASK, GLOBAL, STEP, RAMP, STEP_HIGH };
static hd_image changed(const hd_image *in, int kind)
{
    hd_image out = {0};
    if (hd_image_alloc(&out, W, H, 3) != HD_OK) exit(1);
    const size_t P = (size_t)W * H;
    float ox[64], oy[64];
    int n = 0;
    for (const int *i = hd_contour_face_oval; *i >= 0; i++) ox[n] = lm[*i][0], oy[n++] = lm[*i][1];
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            const float h = height(x, y);
            float f = 0;
            if (kind == MASK) f = hd_inside_polygon(ox, oy, n, x + 0.5f, y + 0.5f) ? 0.3f : 0.0f;
            else if (kind == GLOBAL) f = 0.3f;
            else if (kind == STEP) f = h > 1.0f ? 0.15f : 0.0f;
            else if (kind == RAMP) f = 0.15f * h;
            else f = h > 1.5f ? 0.15f : 0.0f;
            for (int c = 0; c < 3; c++) out.data[c * P + (size_t)y * W + x] = in->data[c * P + (size_t)y * W + x] * expf(f);
        }
    return out;
}

static double coverage_of(const hd_image *in, int kind, const unsigned char *skin)
{
    hd_image out = changed(in, kind);
    double ring = NAN, face = NAN;
    CHECK(hd_photo_coverage_parts(in, &out, (const float (*)[3])lm, skin, &ring, &face) == HD_OK);
    hd_image_free(&out);
    return ring / face;
}

static double band_of(const hd_image *in, int kind, const unsigned char *skin)
{
    hd_image out = changed(in, kind);
    double b = hd_photo_band(in, &out, (const float (*)[3])lm, skin);
    hd_image_free(&out);
    return b;
}

static void test_coverage(void)
{
    hd_image in = picture(10.0f, 0, 0.0f);
    unsigned char *skin = NULL;
    CHECK(hd_photo_skin(&in, (const float (*)[3])lm, &skin) == HD_OK);
    size_t P = (size_t)W * H, n = 0;
    for (size_t p = 0; skin && p < P; p++) n += skin[p];
    CHECK(n == P); /* all of it is skin */
    const double mask = coverage_of(&in, MASK, skin), global = coverage_of(&in, GLOBAL, skin);
    printf("coverage: a change inside the face's outline %.4f, of the whole picture %.4f\n", mask, global);
    CHECK_NEAR(mask, 0.0, 1e-9);
    CHECK_NEAR(global, 1.0, 0.02);
    free(skin);
    hd_image_free(&in);

    /* a blue background close around the face and dark hair above it: not skin, so not in the ring */
    in = picture(1.4f, 0, 0.9f * 128);
    CHECK(hd_photo_skin(&in, (const float (*)[3])lm, &skin) == HD_OK);
    if (skin) {
        CHECK(skin[5 * W + 5] == 0);                                /* the background */
        CHECK(skin[(size_t)(int)(eye_mid[1] - 1.7f * eye_dist) * W + 128] == 0); /* the hair */
        CHECK(skin[(size_t)(int)(eye_mid[1] + 0.5f * eye_dist) * W + 128] == 1); /* the nose */
    }
    CHECK_NEAR(coverage_of(&in, GLOBAL, skin), 1.0, 0.02);
    free(skin);
    hd_image_free(&in);
}

static void test_band(void)
{
    hd_image in = picture(10.0f, 0, 0.0f);
    unsigned char *skin = NULL;
    CHECK(hd_photo_skin(&in, (const float (*)[3])lm, &skin) == HD_OK);
    const double step = band_of(&in, STEP, skin), ramp = band_of(&in, RAMP, skin), flat = band_of(&in, GLOBAL, skin);
    printf("band: a step across the forehead %.2f, a ramp %.2f, a uniform change %.2f\n", step, ramp, flat);
    CHECK(step > 20);
    CHECK(ramp >= 1.0 && ramp < 1.5);
    CHECK(flat >= 1.0 && flat < 1.5);
    free(skin);
    hd_image_free(&in);

    /* hair from 1.2 eye distances up: a step at 1.5 lies in the hair, not on the forehead */
    in = picture(1.2f, 0, 0.0f);
    CHECK(hd_photo_skin(&in, (const float (*)[3])lm, &skin) == HD_OK);
    const double in_hair = band_of(&in, STEP_HIGH, skin), on_skin = band_of(&in, STEP, skin);
    printf("band with a hairline at 1.2: a step at 1.5 %.2f, at 1.0 %.2f\n", in_hair, on_skin);
    CHECK(in_hair >= 1.0 && in_hair < 1.5);
    CHECK(on_skin > 20);
    free(skin);
    hd_image_free(&in);

    /* a fringe over the forehead: nothing to measure */
    in = picture(10.0f, 1, 0.0f);
    CHECK(hd_photo_skin(&in, (const float (*)[3])lm, &skin) == HD_OK);
    CHECK(isnan(band_of(&in, STEP, skin)));
    free(skin);
    hd_image_free(&in);
}

static void test_bad_input(void)
{
    hd_image in = picture(10.0f, 0, 0.0f), small = {0};
    CHECK(hd_image_alloc(&small, 10, 10, 3) == HD_OK);
    unsigned char skin[1] = {1};
    double ring, face;
    CHECK(hd_photo_coverage_parts(&in, &small, (const float (*)[3])lm, skin, &ring, &face) == HD_ERR_ARG);
    CHECK(isnan(ring) && isnan(face));
    float flat[HD_FACE_LANDMARKS][3] = {{0}};
    unsigned char *s = NULL;
    CHECK(hd_photo_skin(&in, (const float (*)[3])flat, &s) == HD_ERR_ARG && s == NULL);
    hd_image_free(&in), hd_image_free(&small);
}

int main(void)
{
    const char *td = getenv("HDNET_TESTDATA");
    if (!getenv("HDNET_DATA") && td) {
        char dir[4096];
        snprintf(dir, sizeof dir, "%s/../../models", td); /* HDNET_TESTDATA is <source>/tests/data */
        setenv("HDNET_DATA", dir, 1);
    }
    if (!landmarks()) {
        fprintf(stderr, "test_photo_coverage: the canonical mesh is not found (HDNET_DATA)\n");
        return 1;
    }
    test_coverage();
    test_band();
    test_bad_input();
    return test_summary("test_photo_coverage");
}
