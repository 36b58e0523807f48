/* test_face_detect.c: face detection and landmarks on the bundled photograph (Eileen Collins,
 * examples/astronaut.png, 512 x 512) against points marked by hand on the photo, its mirror image
 * (the person's right and left swap), the same face inside a large photo (the downscaling path),
 * and photos without a face: flat gray, noise, a tiny one; bad arguments give clear errors.
 *
 * Hand marks (photo coordinates, pixel centres at +0.5, read off 8-10x enlargements):
 *   eye centres (pupils) (203.5, 101.3) image-left, (246.7, 102.5) image-right;
 *   outer eye corners (192.0, 101.0) and (259.0, 103.0); nose tip (224.0, 127.0);
 *   mouth corners (203.1, 140.6) and (244.4, 141.3); mouth centre (224, 142); chin (224.0, 178.5).
 * The detector sees the photo at 128 x 128 (4 photo pixels per network pixel) and its keypoints are
 * coarse: every candidate anchor puts the image-right eye 6-8 pixels below the pupil, here and on
 * the mirror image, whatever the resampling; they are held to 10 pixels (the eyes are 43 apart).
 * The landmarks (a 192 x 192 crop of a 141-pixel region) are held to 5. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "test.h"
#include "source_dir.h"
#include "core/core.h"
#include "align/face_detect.h"
#include "align/face_landmarks.h"

#define KP_TOL 10.0
#define LM_TOL 5.0

static const float eye_image_left[2] = {203.5f, 101.3f}, eye_image_right[2] = {246.7f, 102.5f};
static const float nose_tip[2] = {224.0f, 127.0f}, mouth_centre[2] = {224.0f, 142.0f};
static const struct {
    int index;
    float x, y;
} hand_landmarks[] = {
    {33, 192.0f, 101.0f},  /* right eye, outer corner (image left) */
    {263, 259.0f, 103.0f}, /* left eye, outer corner (image right) */
    {1, 224.0f, 127.0f},   /* nose tip */
    {61, 203.1f, 140.6f},  /* mouth corner, image left */
    {291, 244.4f, 141.3f}, /* mouth corner, image right */
    {152, 224.0f, 178.5f}, /* chin */
};

static const char *source_dir; /* test_source_dir() */
static hd_face_detector *detector; /* loaded once; the convenience calls (which load their model
                                    * each time) are exercised on the first photo only */

static double dist(const float *p, const float *q) { return hypot(p[0] - q[0], p[1] - q[1]); }

#define CHECK_POINT(p, want, tol)                                                                     \
    do {                                                                                              \
        double d_ = dist((p), (want));                                                                \
        if (!(d_ <= (tol)))                                                                           \
            fprintf(stderr, "%s:%d: %s = (%.1f, %.1f), expected (%.1f, %.1f): %.1f px off\n", __FILE__, \
                    __LINE__, #p, (p)[0], (p)[1], (want)[0], (want)[1], d_);                          \
        CHECK(d_ <= (tol));                                                                           \
    } while (0)

/* Maps a point of the astronaut photo into a transformed photo: p' = scale p + offset, with the
 * x axis mirrored about the photo width first when mirror is set. */
typedef struct view {
    float scale, ox, oy;
    int mirror;
    float angle; /* then turned by this angle (radians, clockwise on screen) about ROT_CX, ROT_CY */
} view;

#define ROT_CX 225.0f
#define ROT_CY 130.0f

static void map_point(const view *v, const float p[2], float out[2])
{
    float x = v->mirror ? 512.0f - p[0] : p[0];
    out[0] = v->scale * x + v->ox;
    out[1] = v->scale * p[1] + v->oy;
    if (v->angle != 0.0f) {
        float dx = out[0] - ROT_CX, dy = out[1] - ROT_CY, c = cosf(v->angle), s = sinf(v->angle);
        out[0] = ROT_CX + c * dx - s * dy;
        out[1] = ROT_CY + s * dx + c * dy;
    }
}

/* Detection and landmarks on `photo`, which shows the astronaut photo through view v. */
static void check_face(const hd_image *photo, const view *v, hd_face_mesh *mesh)
{
    hd_face_box *faces = NULL;
    int count = -1;
    hd_status st = mesh ? hd_face_detector_run(detector, photo, HD_FACE_MIN_SCORE, &faces, &count)
                        : hd_face_detect(photo, &faces, &count);
    if (st != HD_OK) fprintf(stderr, "detect: %s\n", hd_error());
    CHECK(st == HD_OK);
    CHECK(count == 1);
    if (count < 1) {
        free(faces);
        return;
    }
    const hd_face_box *f = &faces[0];
    float s = v->scale, want[2];
    /* Turned faces are rarer in the detector's training: its keypoints drift further (12 px). */
    double kp_tol = KP_TOL * s * (v->angle != 0.0f ? 1.5 : 1.0);
    CHECK(f->score >= HD_FACE_MIN_SCORE && f->score <= 1.0f);
    /* The person's right eye is on the image's left, unless mirrored. */
    map_point(v, v->mirror ? eye_image_right : eye_image_left, want);
    CHECK_POINT(f->keypoints[HD_FACE_KP_RIGHT_EYE], want, kp_tol);
    map_point(v, v->mirror ? eye_image_left : eye_image_right, want);
    CHECK_POINT(f->keypoints[HD_FACE_KP_LEFT_EYE], want, kp_tol);
    map_point(v, nose_tip, want);
    CHECK_POINT(f->keypoints[HD_FACE_KP_NOSE_TIP], want, kp_tol);
    map_point(v, mouth_centre, want);
    CHECK_POINT(f->keypoints[HD_FACE_KP_MOUTH], want, kp_tol);
    /* The box holds the eyes and the mouth, and is about a face wide (the face is ~90 px). */
    CHECK(f->x0 < f->keypoints[0][0] && f->keypoints[1][0] < f->x1 && f->y0 < f->keypoints[0][1] &&
          f->keypoints[HD_FACE_KP_MOUTH][1] < f->y1);
    CHECK(f->x1 - f->x0 > 70 * s && f->x1 - f->x0 < 130 * s);

    float lm[HD_FACE_MESH_POINTS][3], presence = -1;
    st = mesh ? hd_face_mesh_fit(mesh, photo, f, 2, lm, &presence) : hd_face_landmarks(photo, f, lm, &presence);
    if (st != HD_OK) fprintf(stderr, "landmarks: %s\n", hd_error());
    CHECK(st == HD_OK);
    CHECK(presence > 0.9f);
    for (size_t k = 0; k < sizeof hand_landmarks / sizeof hand_landmarks[0]; k++) {
        float hand[2] = {hand_landmarks[k].x, hand_landmarks[k].y};
        int index = hand_landmarks[k].index;
        if (v->mirror && index == 33) index = 263; /* mirrored, the eye corners swap roles */
        else if (v->mirror && index == 263) index = 33;
        else if (v->mirror && index == 61) index = 291;
        else if (v->mirror && index == 291) index = 61;
        map_point(v, hand, want);
        double d = dist(lm[index], want);
        if (!(d <= LM_TOL * s))
            fprintf(stderr, "landmark %d = (%.1f, %.1f), hand-marked (%.1f, %.1f): %.1f px off\n", index, lm[index][0],
                    lm[index][1], want[0], want[1], d);
        CHECK(d <= LM_TOL * s);
    }
    /* Depth: the nose tip is closer to the camera (smaller z) than the eye corners and the chin. */
    CHECK(lm[1][2] < lm[33][2] - 10 * s && lm[1][2] < lm[263][2] - 10 * s && lm[1][2] < lm[152][2]);
    free(faces);
}

static void test_astronaut(hd_image *photo, hd_face_mesh *mesh)
{
    view plain = {1.0f, 0.0f, 0.0f, 0, 0.0f};
    check_face(photo, &plain, NULL);

    /* The mirror image. */
    hd_image mirrored;
    CHECK(hd_image_alloc(&mirrored, photo->width, photo->height, photo->channels) == HD_OK);
    for (int c = 0; c < photo->channels; c++)
        for (int y = 0; y < photo->height; y++)
            for (int x = 0; x < photo->width; x++)
                mirrored.data[((size_t)c * photo->height + y) * photo->width + x] =
                    photo->data[((size_t)c * photo->height + y) * photo->width + photo->width - 1 - x];
    view mirror = {1.0f, 0.0f, 0.0f, 1, 0.0f};
    check_face(&mirrored, &mirror, mesh);
    hd_image_free(&mirrored);

    /* Turned 25 degrees clockwise about the face (bilinear, gray outside): the crop must turn
     * with the eyes for the landmarks to land. */
    for (int sign = -1; sign <= 1; sign += 2) {
        hd_image turned;
        view v = {1.0f, 0.0f, 0.0f, 0, sign * 25.0f * 3.14159265f / 180.0f};
        CHECK(hd_image_alloc(&turned, photo->width, photo->height, 3) == HD_OK);
        float c = cosf(v.angle), s = sinf(v.angle);
        for (int y = 0; y < photo->height; y++)
            for (int x = 0; x < photo->width; x++) {
                /* the source point: the inverse turn of the pixel centre */
                float dx = (float)x + 0.5f - ROT_CX, dy = (float)y + 0.5f - ROT_CY;
                float sx = ROT_CX + c * dx + s * dy - 0.5f, sy = ROT_CY - s * dx + c * dy - 0.5f;
                int x0 = (int)floorf(sx), y0 = (int)floorf(sy);
                float tx = sx - (float)x0, ty = sy - (float)y0;
                for (int ch = 0; ch < 3; ch++) {
                    float v4[4];
                    for (int k = 0; k < 4; k++) {
                        int xx = x0 + (k & 1), yy = y0 + (k >> 1);
                        v4[k] = xx >= 0 && yy >= 0 && xx < photo->width && yy < photo->height
                                    ? photo->data[((size_t)ch * photo->height + yy) * photo->width + xx]
                                    : 0.5f;
                    }
                    turned.data[((size_t)ch * photo->height + y) * photo->width + x] =
                        (1 - ty) * ((1 - tx) * v4[0] + tx * v4[1]) + ty * ((1 - tx) * v4[2] + tx * v4[3]);
                }
            }
        check_face(&turned, &v, mesh);
        hd_image_free(&turned);
    }
}

/* The photo enlarged 4x (nearest) inside a 2200 x 2100 gray frame: the detector reduces it ~17x.
 * (The short-range model wants the face to fill a good part of the frame: the same face 3x in
 * 2400 x 2000 scores 0.59, under the threshold.) */
static void test_large(const hd_image *photo, hd_face_mesh *mesh)
{
    const int W = 2200, H = 2100, ox = 100, oy = 50, k = 4;
    hd_image big;
    CHECK(hd_image_alloc(&big, W, H, 3) == HD_OK);
    if (!big.data) return;
    for (int c = 0; c < 3; c++)
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                int sx = (x - ox) / k, sy = (y - oy) / k;
                float v = 0.5f;
                if (x >= ox && y >= oy && sx < photo->width && sy < photo->height)
                    v = photo->data[((size_t)c * photo->height + sy) * photo->width + sx];
                big.data[((size_t)c * H + y) * W + x] = v;
            }
    view large = {(float)k, (float)ox, (float)oy, 0, 0.0f};
    check_face(&big, &large, mesh);
    hd_image_free(&big);
}

static void expect_no_face(const hd_image *photo, const char *what, int convenience)
{
    hd_face_box *faces = (hd_face_box *)1;
    int count = -1;
    hd_status st = convenience ? hd_face_detect(photo, &faces, &count)
                               : hd_face_detector_run(detector, photo, HD_FACE_MIN_SCORE, &faces, &count);
    if (st != HD_OK || count != 0) fprintf(stderr, "%s: status %d, %d faces (%s)\n", what, (int)st, count, hd_error());
    CHECK(st == HD_OK && count == 0 && faces == NULL);
}

static void test_no_face(hd_face_mesh *mesh)
{
    hd_image img;
    CHECK(hd_image_alloc(&img, 320, 240, 3) == HD_OK);
    for (size_t i = 0; i < (size_t)320 * 240 * 3; i++) img.data[i] = 0.5f;
    expect_no_face(&img, "flat gray", 1);
    /* The face mesh on a crop of flat gray reports no face present. */
    hd_face_roi roi = {160.0f, 120.0f, 150.0f, 0.0f};
    float lm[HD_FACE_MESH_POINTS][3], presence = -1;
    CHECK(hd_face_mesh_run(mesh, &img, &roi, lm, &presence) == HD_OK);
    CHECK(presence >= 0.0f && presence < 0.5f);
    unsigned s = 12345;
    for (size_t i = 0; i < (size_t)320 * 240 * 3; i++) {
        s = s * 1664525u + 1013904223u;
        img.data[i] = (float)(s >> 8) / 16777216.0f;
    }
    expect_no_face(&img, "noise", 0);
    hd_image_free(&img);

    CHECK(hd_image_alloc(&img, 8, 8, 1) == HD_OK);
    expect_no_face(&img, "8x8", 0);
    hd_image_free(&img);
    CHECK(hd_image_alloc(&img, 1, 1, 4) == HD_OK);
    expect_no_face(&img, "1x1", 0);
    hd_image_free(&img);
}

static void test_bad_arguments(const hd_image *photo, hd_face_mesh *mesh)
{
    hd_face_box *faces;
    int count;
    hd_image empty = {0};
    CHECK(hd_face_detect(&empty, &faces, &count) == HD_ERR_ARG && strstr(hd_error(), "empty"));
    hd_image five = *photo;
    five.channels = 5;
    CHECK(hd_face_detect(&five, &faces, &count) == HD_ERR_ARG && strstr(hd_error(), "channel"));
    hd_face_detector *det;
    CHECK(hd_face_detector_run(detector, photo, 0.0f, &faces, &count) == HD_ERR_ARG && strstr(hd_error(), "threshold"));
    CHECK(hd_face_detector_run(detector, photo, NAN, &faces, &count) == HD_ERR_ARG);
    /* A degenerate face region. */
    hd_face_roi roi = {100.0f, 100.0f, 0.0f, 0.0f};
    float lm[HD_FACE_MESH_POINTS][3];
    CHECK(hd_face_mesh_run(mesh, photo, &roi, lm, NULL) == HD_ERR_ARG && strstr(hd_error(), "degenerate"));
    roi.size = 100.0f;
    roi.angle = NAN;
    CHECK(hd_face_mesh_run(mesh, photo, &roi, lm, NULL) == HD_ERR_ARG);
    /* A model file that is not there: the error names it. */
    CHECK(hd_face_detector_load("no/such/model.json", &det) == HD_ERR_IO && strstr(hd_error(), "no/such/model.json"));
    /* The face mesh is not a detector. */
    char path[4400];
    snprintf(path, sizeof path, "%s/models/face-models/facemesh.json", source_dir);
    CHECK(hd_face_detector_load(path, &det) == HD_ERR_FORMAT && strstr(hd_error(), "not a BlazeFace model"));
}

/* A tight crop, the face filling the photo (as the Yale B and Multi-PIE crops): no pyramid window
 * sees the context the detector needs, so it is found by the zoom-out on grey. */
static void test_tight_crop(const hd_image *photo, hd_face_mesh *mesh)
{
    const int x0 = 186, y0 = 72, W = 76, H = 90;
    hd_image crop;
    CHECK(hd_image_alloc(&crop, W, H, 3) == HD_OK);
    if (!crop.data) return;
    for (int c = 0; c < 3; c++)
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++)
                crop.data[((size_t)c * H + y) * W + x] = /* grey, as those crops are */
                    (photo->data[((size_t)y0 + y) * photo->width + x0 + x] +
                     photo->data[((size_t)photo->height + y0 + y) * photo->width + x0 + x] +
                     photo->data[((size_t)2 * photo->height + y0 + y) * photo->width + x0 + x]) / 3.0f;
    (void)mesh;
    hd_face_box *faces = NULL;
    int count = 0;
    CHECK(hd_face_detector_run(detector, &crop, HD_FACE_MIN_SCORE, &faces, &count) == HD_OK && count == 1);
    if (count == 1) { /* the box round the nose (hand-marked) */
        float centre[2] = {0.5f * (faces[0].x0 + faces[0].x1) + (float)x0, 0.5f * (faces[0].y0 + faces[0].y1) + (float)y0};
        CHECK_POINT(centre, nose_tip, 15.0);
    }
    free(faces);
    /* a face under hard side light scores under the threshold on grey: the zoom-out is tried again
     * at a share of it (with a threshold of 1, which no face reaches, only that round finds it) */
    faces = NULL, count = 0;
    CHECK(hd_face_detector_run(detector, &crop, 1.0f, &faces, &count) == HD_OK && count == 1);
    if (count == 1) {
        float centre[2] = {0.5f * (faces[0].x0 + faces[0].x1) + (float)x0, 0.5f * (faces[0].y0 + faces[0].y1) + (float)y0};
        CHECK(faces[0].score < 1.0f);
        CHECK_POINT(centre, nose_tip, 15.0);
    }
    free(faces);
    /* the zoom-out alone (what the aligner tries when the landmark model doubts every box the
     * pyramid found in a crop) */
    faces = NULL, count = 0;
    CHECK(hd_face_detector_find_zoomed(detector, &crop, HD_FACE_MIN_SCORE, &faces, &count) == HD_OK && count == 1);
    if (count == 1) {
        float centre[2] = {0.5f * (faces[0].x0 + faces[0].x1) + (float)x0, 0.5f * (faces[0].y0 + faces[0].y1) + (float)y0};
        CHECK_POINT(centre, nose_tip, 15.0);
    }
    free(faces);
    hd_image_free(&crop);
}

/* A face under hard side light (a London face darkened, its right side near black, as the Yale B
 * photos under a strobe from 70 degrees): the landmark model doubts it on the photo itself, and
 * the aligner finds it on the photo with its shadows lifted; the landmarks stand where they stand
 * on the photo in plain light, and the texture is cut from the dark photo itself. */
static void test_hard_side_light(void)
{
    char path[4400];
    snprintf(path, sizeof path, "%s/tests/data/faces/london-001.jpg", source_dir);
    hd_image plain = {0}, dark = {0};
    CHECK(hd_image_read_as(path, 3, &plain) == HD_OK);
    if (!plain.data) return;
    const int W = plain.width, H = plain.height;
    CHECK(hd_image_alloc(&dark, W, H, 3) == HD_OK);
    if (!dark.data) return;
    for (int c = 0; c < 3; c++)
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                /* lit from the image's left: 1 up to 40 % of the width, 0.01 from 50 %, a ramp between */
                float u = (float)x / (float)(W - 1), side = u < 0.4f ? 1.0f : u > 0.5f ? 0.01f : 1.0f - (u - 0.4f) / 0.1f * 0.99f;
                size_t i = ((size_t)c * H + y) * W + x;
                dark.data[i] = 0.35f * side * powf(plain.data[i], 2.2f);
            }
    hd_aligner *aligner = NULL;
    CHECK(hd_aligner_load(&aligner) == HD_OK);
    hd_aligned_face *a = NULL, *b = NULL;
    int na = 0, nb = 0;
    CHECK(aligner && hd_aligner_run(aligner, &plain, 64, &a, &na) == HD_OK && na == 1);
    hd_status st = aligner ? hd_aligner_run(aligner, &dark, 64, &b, &nb) : HD_ERR_ARG;
    if (st != HD_OK) fprintf(stderr, "hard side light: %s\n", hd_error());
    CHECK(st == HD_OK && nb == 1);
    if (na == 1 && nb == 1) {
        double d = 0, side = a[0].box[2] - a[0].box[0];
        for (int i = 0; i < HD_FACE_LANDMARKS; i++)
            d += hypot(a[0].landmarks[i][0] - b[0].landmarks[i][0], a[0].landmarks[i][1] - b[0].landmarks[i][1]);
        d /= HD_FACE_LANDMARKS;
        if (!(d < 0.05 * side)) fprintf(stderr, "hard side light: landmarks %.2f px from plain light's (face %.0f px)\n", d, side);
        CHECK(d < 0.05 * side);
        /* the texture is the dark photo's, not the lifted copy's: against plain light's it keeps
         * the darkening (0.35 x^2.2, half of it at 1 %: under a third), where sqrt would not */
        double sa = 0, sb = 0;
        size_t n = (size_t)b[0].texture.width * (size_t)b[0].texture.height * 3;
        for (size_t i = 0; i < n; i++) sa += a[0].texture.data[i], sb += b[0].texture.data[i];
        if (!(sb < 0.3 * sa)) fprintf(stderr, "hard side light: texture mean %.4f against plain light's %.4f\n", sb / (double)n, sa / (double)n);
        CHECK(sb < 0.3 * sa);
    }
    hd_aligned_faces_free(a, na);
    hd_aligned_faces_free(b, nb);
    hd_aligner_free(aligner);
    hd_image_free(&plain);
    hd_image_free(&dark);
}

/* A tight crop (the face's width, from the forehead to the chin, as the Yale B crops; each pixel
 * doubled) lit hard from the image's right, its left third near black: the pyramid finds the lit
 * half as a face of its own, cut by the photo's edge, and the landmark model fitted in that box
 * follows it (10 % of the face's width off before the aligner looked again zoomed out). The aligner
 * takes the whole face the zoom-out finds: one face, its landmarks where they stand in plain light.
 * The same crop in plain light (a close-up the aligner also looks at zoomed out) keeps its face. */
static void test_half_face_crop(void)
{
    char path[4400];
    snprintf(path, sizeof path, "%s/tests/data/faces/london-101.jpg", source_dir);
    hd_image plain = {0}, big = {0};
    CHECK(hd_image_read_as(path, 3, &plain) == HD_OK);
    hd_aligner *aligner = NULL;
    CHECK(hd_aligner_load(&aligner) == HD_OK);
    hd_aligned_face *a = NULL, *b = NULL;
    int na = 0, nb = 0;
    CHECK(aligner && plain.data && hd_aligner_run(aligner, &plain, 64, &a, &na) == HD_OK && na == 1);
    if (na == 1) {
        float lo[2] = {1e9f, 1e9f}, hi[2] = {-1e9f, -1e9f};
        for (int i = 0; i < HD_FACE_LANDMARKS; i++)
            for (int k = 0; k < 2; k++) lo[k] = fminf(lo[k], a[0].landmarks[i][k]), hi[k] = fmaxf(hi[k], a[0].landmarks[i][k]);
        const float w = hi[0] - lo[0], h = hi[1] - lo[1];
        const int x0 = (int)lroundf(lo[0] + 0.02f * w), x1 = (int)lroundf(hi[0] - 0.02f * w);
        const int y0 = (int)lroundf(lo[1] + 0.12f * h), y1 = (int)fminf((float)plain.height, lroundf(hi[1] + 0.02f * h));
        const int W = x1 - x0, H = y1 - y0, P = plain.width * plain.height;
        CHECK(x0 >= 0 && y0 >= 0 && x1 <= plain.width && W > 40 && H > 40);
        CHECK(hd_image_alloc(&big, 2 * W, 2 * H, 3) == HD_OK); /* each pixel doubled */
        for (int side_lit = 1; side_lit >= 0 && big.data; side_lit--) { /* then in plain light: kept */
            for (int y = 0; y < 2 * H; y++)
                for (int x = 0; x < 2 * W; x++) {
                    const size_t i = (size_t)(y0 + y / 2) * plain.width + x0 + x / 2;
                    const float grey = (plain.data[i] + plain.data[P + i] + plain.data[2 * (size_t)P + i]) / 3.0f;
                    const float u = (float)(x / 2) / (float)(W - 1);
                    const float lit = side_lit ? fminf(fmaxf((u - 0.35f) / 0.15f, 0.0f), 1.0f) * 0.99f + 0.01f : 1.0f;
                    const float v = powf(0.9f * lit * powf(grey, 2.2f), 1.0f / 2.2f);
                    for (int c = 0; c < 3; c++) big.data[((size_t)c * 2 * H + y) * 2 * W + x] = v;
                }
            hd_aligned_faces_free(b, nb);
            b = NULL, nb = 0;
            hd_status st = hd_aligner_run(aligner, &big, 64, &b, &nb);
            if (st != HD_OK) fprintf(stderr, "half-face crop: %s\n", hd_error());
            CHECK(st == HD_OK && nb == 1);
            if (nb >= 1) {
                double d = 0;
                for (int i = 0; i < HD_FACE_LANDMARKS; i++)
                    d += hypot(2.0 * (a[0].landmarks[i][0] - (float)x0) - b[0].landmarks[i][0],
                               2.0 * (a[0].landmarks[i][1] - (float)y0) - b[0].landmarks[i][1]);
                d /= HD_FACE_LANDMARKS * 2.0 * w;
                if (!(d < 0.04))
                    fprintf(stderr, "half-face crop (%s): landmarks %.3f of the face's width from the photo's\n",
                            side_lit ? "side light" : "plain light", d);
                CHECK(d < 0.04);
            }
        }
    }
    hd_aligned_faces_free(a, na);
    hd_aligned_faces_free(b, nb);
    hd_aligner_free(aligner);
    hd_image_free(&plain), hd_image_free(&big);
}

int main(void)
{
    source_dir = test_source_dir();
    char path[4400];
    snprintf(path, sizeof path, "%s/models", source_dir);
    setenv("HDNET_DATA", path, 1);
    snprintf(path, sizeof path, "%s/examples/astronaut.png", source_dir);
    hd_image photo = {0};
    hd_status st = hd_image_read_as(path, 3, &photo);
    if (st != HD_OK) fprintf(stderr, "%s\n", hd_error());
    CHECK(st == HD_OK && photo.width == 512 && photo.height == 512);
    hd_face_mesh *mesh = NULL;
    st = hd_face_mesh_load(NULL, &mesh);
    if (st == HD_OK) st = hd_face_detector_load(NULL, &detector);
    if (st != HD_OK) fprintf(stderr, "%s\n", hd_error());
    CHECK(st == HD_OK);
    if (photo.data && mesh && detector) {
        test_astronaut(&photo, mesh);
        test_large(&photo, mesh);
        test_tight_crop(&photo, mesh);
        test_hard_side_light();
        test_half_face_crop();
        test_no_face(mesh);
        test_bad_arguments(&photo, mesh);
    }
    hd_face_mesh_free(mesh);
    hd_face_detector_free(detector);
    hd_image_free(&photo);
    return test_summary("face_detect");
}
