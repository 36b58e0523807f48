/* test_align.c: photo alignment from synthetic landmarks (the canonical mesh projected with a
 * known pose and scale into a synthetic photo): the similarity fit recovers the pose, unwarp then
 * warp back returns a smooth photo inside the mask, coarse normals point where the face points,
 * hidden texels are masked, the warp file round-trips; Poisson blending reproduces a target from
 * a constant-offset source, reaches its tolerance by an independent residual check, and leaves
 * the target alone when the source is the target; the calls without an aligner read the canonical
 * mesh once and share it. */
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "test.h"
#include "test_pose.h"
#include "core/core.h"
#include "mesh/mesh.h"
#include "test_models.h"
#include "align/photo_raster.h"
#include "io/image_io.h"
#include "align/align.h"
#include "warp/warp.h"

static hd_mesh canonical;


/* Landmarks as a FaceMesh-like model gives them: camera c = s R P, photo (cx + c_x, cy - c_y),
 * z = -c_z (MediaPipe: smaller is closer). */
static void project(double yaw, double pitch, double roll, double s, double cx, double cy, float L[][3], double R[9])
{
    test_pose_rotation(yaw, pitch, roll, R);
    for (int i = 0; i < canonical.nv; i++) {
        const float *p = &canonical.pos[3 * i];
        double c[3];
        for (int k = 0; k < 3; k++) c[k] = s * (R[3 * k] * p[0] + R[3 * k + 1] * p[1] + R[3 * k + 2] * p[2]);
        L[i][0] = (float)(cx + c[0]);
        L[i][1] = (float)(cy - c[1]);
        L[i][2] = (float)(-c[2]);
    }
}

/* A smooth colour photo: low-frequency sines, values in [0.1, 0.9]. */
static void smooth_photo(hd_image *img, int w, int h)
{
    CHECK(hd_image_alloc(img, w, h, 3) == HD_OK);
    for (int c = 0; c < 3; c++)
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++)
                img->data[((size_t)c * h + y) * w + x] =
                    (float)(0.5 + 0.2 * sin(0.045 * x + 1.3 * c) * cos(0.037 * y - 0.7 * c) + 0.2 * sin(0.02 * (x + y) + c));
}

static void test_fit(void)
{
    float (*L)[3] = malloc(sizeof(float[HD_FACE_LANDMARKS][3]));
    double R[9];
    project(20, -10, 5, 11.5, 200, 180, L, R);
    hd_aligned_face face;
    memset(&face, 0, sizeof face);
    memcpy(face.landmarks, L, sizeof face.landmarks);
    CHECK(hd_align_fit(&canonical, &face) == HD_OK);
    CHECK_NEAR(face.scale, 11.5, 1e-3);
    CHECK(face.depth_sign == -1.0f);
    CHECK(face.fit_rms < 1e-3);
    for (int k = 0; k < 9; k++) CHECK_NEAR(face.rotation[k], R[k], 1e-4);
    CHECK_NEAR(face.translation[0], 200, 1e-2);
    CHECK_NEAR(face.translation[1], -180, 1e-2);
    /* z toward the viewer instead: the fit finds the other sign and the same pose */
    for (int i = 0; i < HD_FACE_LANDMARKS; i++) face.landmarks[i][2] = -L[i][2];
    CHECK(hd_align_fit(&canonical, &face) == HD_OK);
    CHECK(face.depth_sign == 1.0f);
    for (int k = 0; k < 9; k++) CHECK_NEAR(face.rotation[k], R[k], 1e-4);
    free(L);
}

/* Texel of vertex v's UV in an S x S map. */
static size_t texel_of(int v, int S)
{
    int x = (int)(canonical.uv[2 * v] * S), y = (int)(canonical.uv[2 * v + 1] * S);
    return (size_t)y * S + x;
}

/* Texel at the UV point (1 - t) uv_a + t uv_b. */
static size_t texel_between(int a, int b, float t, int S)
{
    float u = (1 - t) * canonical.uv[2 * a] + t * canonical.uv[2 * b];
    float v = (1 - t) * canonical.uv[2 * a + 1] + t * canonical.uv[2 * b + 1];
    return (size_t)(int)(v * S) * S + (size_t)(int)(u * S);
}

static double psnr_inside(const hd_image *a, const hd_image *b, const hd_image *mask, long *count)
{
    double se = 0;
    long n = 0;
    size_t plane = (size_t)a->width * a->height;
    for (size_t i = 0; i < plane; i++) {
        if (mask->data[i] <= 0.5f) continue;
        n++;
        for (int c = 0; c < 3; c++) {
            double d = a->data[c * plane + i] - b->data[c * plane + i];
            se += d * d;
        }
    }
    *count = n;
    return n ? 10 * log10(1.0 / (se / (3.0 * n) + 1e-20)) : 0;
}

static void test_round_trip_and_normals(void)
{
    float (*L)[3] = malloc(sizeof(float[HD_FACE_LANDMARKS][3]));
    double R[9];
    hd_image photo = {0}, warped = {0}, coverage = {0};
    smooth_photo(&photo, 320, 300);
    project(0, 0, 0, 12, 160, 150, L, R);
    hd_aligned_face face;
    CHECK(hd_align_face(&photo, (const float (*)[3])L, 256, &face) == HD_OK);
    const int S = face.size;
    const size_t plane = (size_t)S * S;
    long masked = 0;
    for (size_t i = 0; i < plane; i++) masked += face.mask.data[i] > 0.5f;
    CHECK(masked > (long)(0.4 * plane)); /* a frontal face covers most of its UV layout */
    /* frontal: toward the camera at the nose tip, sideways at the face's edges and the cheeks */
    size_t nose = texel_of(1, S);
    CHECK(face.mask.data[nose] == 1.0f);
    CHECK(face.normal.data[2 * plane + nose] > 0.9f);
    CHECK(fabsf(face.normal.data[nose]) < 0.2f);
    for (int side = 0; side < 2; side++) {
        /* the face's contour vertices 234 (image left) and 454 sit on the UV layout's border:
         * look 30 % of the way from them toward the cheek vertices 50 and 280, and at those */
        int edge = side ? 454 : 234, cheek = side ? 280 : 50;
        float sign = side ? 1.0f : -1.0f;
        CHECK(sign * canonical.pos[3 * edge] > 0);
        size_t te = texel_between(edge, cheek, 0.3f, S), tc = texel_of(cheek, S);
        CHECK(face.mask.data[te] == 1.0f && face.mask.data[tc] == 1.0f);
        CHECK(sign * face.normal.data[te] > 0.9f);
        CHECK(sign * face.normal.data[tc] > 0.5f);
        CHECK(face.normal.data[2 * plane + tc] > 0.5f);
        CHECK(fabsf(face.normal.data[plane + te]) < 0.2f);
    }
    /* up is up: the forehead's normals lean up (y > 0), the chin's down */
    CHECK(face.normal.data[plane + texel_of(10, S)] > 0.2f);
    /* unwarp then warp back returns the photo inside the warped mask */
    CHECK(hd_warp_back(&face, &face.texture, NULL, &warped, &coverage) == HD_OK);
    long n;
    double psnr = psnr_inside(&photo, &warped, &coverage, &n);
    printf("round trip (frontal, 256): PSNR %.1f dB over %ld pixels\n", psnr, n);
    CHECK(psnr > 30);
    CHECK(n > 15000);
    /* an aligner warps back on the mesh it loaded once: the same pixels */
    hd_aligner *aligner = NULL;
    CHECK(hd_aligner_load(&aligner) == HD_OK);
    if (aligner) {
        hd_image w2 = {0}, c2 = {0};
        CHECK(hd_aligner_warp_back(aligner, &face, &face.texture, NULL, &w2, &c2) == HD_OK);
        size_t np = (size_t)photo.width * photo.height;
        CHECK(w2.data && c2.data && memcmp(w2.data, warped.data, 3 * np * sizeof(float)) == 0 &&
              memcmp(c2.data, coverage.data, np * sizeof(float)) == 0);
        hd_image_free(&w2);
        hd_image_free(&c2);
        hd_aligner_free(aligner);
    }
    hd_image_free(&warped);
    hd_image_free(&coverage);

    /* turned 35 degrees: the far side is hidden (masked), the near side seen, round trip holds */
    hd_aligned_face turned;
    project(35, 5, 0, 12, 160, 150, L, R);
    CHECK(hd_align_face(&photo, (const float (*)[3])L, 256, &turned) == HD_OK);
    /* positive yaw turns the nose toward image right: the face's side at negative canonical x
     * (234, image left) comes into view, the other side (454) turns away */
    size_t near_cheek = texel_between(234, 50, 0.3f, S), far_cheek = texel_between(454, 280, 0.3f, S);
    CHECK(turned.mask.data[near_cheek] == 1.0f);
    CHECK(turned.mask.data[far_cheek] == 0.0f);
    CHECK(turned.normal.data[near_cheek] < -0.5f);
    CHECK(turned.normal.data[2 * plane + near_cheek] > 0.3f);
    long masked_turned = 0;
    for (size_t i = 0; i < plane; i++) masked_turned += turned.mask.data[i] > 0.5f;
    CHECK(masked_turned < masked);
    CHECK(hd_warp_back(&turned, &turned.texture, NULL, &warped, &coverage) == HD_OK);
    psnr = psnr_inside(&photo, &warped, &coverage, &n);
    printf("round trip (yaw 35, 256): PSNR %.1f dB over %ld pixels\n", psnr, n);
    CHECK(psnr > 30);
    hd_image_free(&warped);
    hd_image_free(&coverage);

    /* without any mask, the texels inside the UV layout are used */
    hd_image saved_mask = face.mask;
    face.mask = (hd_image){0};
    CHECK(hd_warp_back(&face, &face.texture, NULL, &warped, &coverage) == HD_OK);
    face.mask = saved_mask;
    long n_layout;
    psnr = psnr_inside(&photo, &warped, &coverage, &n_layout);
    CHECK(psnr > 30 && n_layout >= n);
    hd_image_free(&warped);
    hd_image_free(&coverage);

    /* a face moved entirely off the photo: nothing to warp, the blend leaves the photo alone */
    hd_aligned_face away = face;
    for (int i = 0; i < HD_FACE_LANDMARKS; i++) away.landmarks[i][0] += 5000;
    CHECK(hd_warp_back(&away, &face.texture, NULL, &warped, &coverage) == HD_OK);
    double covered = 0;
    for (size_t i = 0; i < (size_t)photo.width * photo.height; i++) covered += coverage.data[i];
    CHECK(covered == 0);
    hd_image_free(&warped);
    hd_image_free(&coverage);
    hd_poisson_report away_rep;
    CHECK(hd_warp_back_blend(&away, &face.texture, HD_WARP_REPLACE, 0, &photo, &away_rep) == HD_OK && away_rep.unknowns == 0);
    for (int i = 0; i < HD_FACE_LANDMARKS; i++) away.landmarks[i][1] = 1e20f * (float)(i % 3 - 1);
    CHECK(hd_warp_back_blend(&away, &face.texture, HD_WARP_REPLACE, 0, &photo, &away_rep) == HD_OK);
    hd_aligned_face far_face;
    CHECK(hd_align_face(&photo, (const float (*)[3])away.landmarks, 64, &far_face) == HD_OK);
    hd_aligned_face_free(&far_face);

    /* a texture at another size (a model's output) warps back too */
    hd_image small = {0};
    CHECK(hd_image_resize(&face.texture, 128, 128, &small) == HD_OK);
    hd_image small_mask = {0};
    CHECK(hd_image_resize(&face.mask, 128, 128, &small_mask) == HD_OK);
    for (size_t i = 0; i < 128 * 128; i++) small_mask.data[i] = small_mask.data[i] > 0.999f ? 1.0f : 0.0f;
    CHECK(hd_warp_back(&face, &small, &small_mask, &warped, &coverage) == HD_OK);
    psnr = psnr_inside(&photo, &warped, &coverage, &n);
    printf("round trip (frontal, 128): PSNR %.1f dB over %ld pixels\n", psnr, n);
    CHECK(psnr > 30);
    hd_image_free(&small);
    hd_image_free(&small_mask);
    hd_image_free(&warped);
    hd_image_free(&coverage);

    /* the files of one face and the warp file round trip */
    CHECK(hd_mkdirs("faces") == HD_OK);
    CHECK(hd_aligned_face_write(&turned, "faces", "face0") == HD_OK);
    hd_aligned_face back;
    CHECK(hd_aligned_face_read_warp("faces/face0.warp.txt", &back) == HD_OK);
    CHECK(memcmp(back.landmarks, turned.landmarks, sizeof back.landmarks) == 0);
    CHECK(back.depth_sign == turned.depth_sign && back.size == 256 && back.photo_width == 320 && back.photo_height == 300);
    for (int k = 0; k < 9; k++) CHECK(back.rotation[k] == turned.rotation[k]);
    hd_image m2 = {0}, nrm = {0};
    CHECK(hd_image_read("faces/face0.mask.png", &m2) == HD_OK);
    CHECK(m2.width == 256 && m2.channels == 1 && m2.data[near_cheek] == 1.0f && m2.data[far_cheek] == 0.0f);
    CHECK(hd_image_read("faces/face0.normal.png", &nrm) == HD_OK);
    CHECK(nrm.channels == 3 && fabsf(nrm.data[near_cheek] - (turned.normal.data[near_cheek] + 1) / 2) < 1e-3f);
    hd_image_free(&m2);
    hd_image_free(&nrm);
    FILE *f = fopen("faces/bad.warp.txt", "w");
    fputs("hdnet-warp 1\nphoto 10 10\nsize 256\nscore nan\n", f);
    fclose(f);
    CHECK(hd_aligned_face_read_warp("faces/bad.warp.txt", &back) != HD_OK);
    CHECK(strstr(hd_error(), "bad.warp.txt:4") != NULL);

    /* warping the face's own texture back and blending changes the photo little; a brighter
     * texture brightens the face but keeps the boundary */
    hd_image copy = {0};
    CHECK(hd_image_alloc(&copy, photo.width, photo.height, 3) == HD_OK);
    memcpy(copy.data, photo.data, (size_t)3 * photo.width * photo.height * sizeof(float));
    hd_poisson_report rep;
    CHECK(hd_warp_back_blend(&face, &face.texture, HD_WARP_REPLACE, 0, &copy, &rep) == HD_OK);
    CHECK(rep.unknowns > 10000 && rep.residual[0] <= HD_POISSON_TOLERANCE);
    hd_image all = {0};
    CHECK(hd_image_alloc(&all, photo.width, photo.height, 1) == HD_OK);
    for (size_t i = 0; i < (size_t)photo.width * photo.height; i++) all.data[i] = 1;
    psnr = psnr_inside(&photo, &copy, &all, &n);
    printf("warp back + blend of the unchanged texture: PSNR %.1f dB over the photo, %d unknowns, %d CG iterations\n",
           psnr, rep.unknowns, rep.iterations[0]);
    CHECK(psnr > 35);
    hd_image_free(&copy);
    hd_image_free(&all);

    /* bad input */
    L[7][1] = NAN;
    CHECK(hd_align_face(&photo, (const float (*)[3])L, 256, &back) == HD_ERR_NUMERIC);
    project(0, 0, 0, 12, 160, 150, L, R);
    CHECK(hd_align_face(&photo, (const float (*)[3])L, 8, &back) == HD_ERR_RANGE);
    hd_aligned_face_free(&face);
    hd_aligned_face_free(&turned);
    hd_image_free(&photo);
    free(L);
}

/* A face larger than its texture: HD_WARP_REPLACE redraws it at the texture's resolution and
 * loses the photo's fine detail; HD_WARP_CHANGE keeps it (an unchanged texture returns the photo
 * exactly), and a change made in the texture shows in the photo. */
static void test_change_mode(void)
{
    float (*L)[3] = malloc(sizeof(float[HD_FACE_LANDMARKS][3]));
    double R[9];
    hd_image photo = {0}, work = {0}, all = {0}, brighter = {0};
    smooth_photo(&photo, 320, 300);
    for (int c = 0; c < 3; c++) /* fine detail: a 3-pixel checker */
        for (int y = 0; y < 300; y++)
            for (int x = 0; x < 320; x++) photo.data[((size_t)c * 300 + y) * 320 + x] += ((x / 3 + y / 3) % 2) ? 0.05f : -0.05f;
    project(0, 0, 0, 12, 160, 150, L, R);
    hd_aligned_face face;
    CHECK(hd_align_face(&photo, (const float (*)[3])L, 64, &face) == HD_OK);
    CHECK(hd_image_alloc(&work, 320, 300, 3) == HD_OK && hd_image_alloc(&all, 320, 300, 1) == HD_OK);
    for (size_t i = 0; i < (size_t)320 * 300; i++) all.data[i] = 1;
    long n;
    memcpy(work.data, photo.data, (size_t)3 * 320 * 300 * sizeof(float));
    CHECK(hd_warp_back_blend(&face, &face.texture, HD_WARP_REPLACE, 0, &work, NULL) == HD_OK);
    double psnr_replace = psnr_inside(&photo, &work, &all, &n);
    memcpy(work.data, photo.data, (size_t)3 * 320 * 300 * sizeof(float));
    CHECK(hd_warp_back_blend(&face, &face.texture, HD_WARP_CHANGE, 0, &work, NULL) == HD_OK);
    double psnr_change = psnr_inside(&photo, &work, &all, &n);
    printf("face of 180 px through a 64 texture: replace %.1f dB, change %.1f dB\n", psnr_replace, psnr_change);
    CHECK(psnr_replace < 40);
    CHECK(psnr_change > 80);
    /* brighten a spot around the nose in the texture: the photo's face gets brighter there by
     * about as much, not elsewhere, and the checker is still there */
    CHECK(hd_image_alloc(&brighter, 64, 64, 3) == HD_OK);
    float nu = canonical.uv[2] * 64, nv = canonical.uv[3] * 64; /* vertex 1, the nose tip */
    for (int c = 0; c < 3; c++)
        for (int y = 0; y < 64; y++)
            for (int x = 0; x < 64; x++) {
                size_t i = ((size_t)c * 64 + y) * 64 + x;
                float d2 = (x + 0.5f - nu) * (x + 0.5f - nu) + (y + 0.5f - nv) * (y + 0.5f - nv);
                brighter.data[i] = face.texture.data[i] + 0.2f * expf(-d2 / (2 * 5.0f * 5.0f));
            }
    memcpy(work.data, photo.data, (size_t)3 * 320 * 300 * sizeof(float));
    CHECK(hd_warp_back_blend(&face, &brighter, HD_WARP_CHANGE, 0, &work, NULL) == HD_OK);
    int nx = (int)L[1][0], ny = (int)L[1][1];
    int cx = (int)(0.7f * L[234][0] + 0.3f * L[50][0]), cy = (int)(0.7f * L[234][1] + 0.3f * L[50][1]);
    double at_nose = 0, at_cheek = 0, detail = 0;
    for (int dy = -2; dy <= 2; dy++)
        for (int dx = -2; dx <= 2; dx++) {
            size_t in = (size_t)(ny + dy) * 320 + nx + dx, ic = (size_t)(cy + dy) * 320 + cx + dx;
            at_nose += (work.data[in] - photo.data[in]) / 25;
            at_cheek += (work.data[ic] - photo.data[ic]) / 25;
            detail = fmax(detail, fabs((work.data[in] - photo.data[in]) - (work.data[in + 1] - photo.data[in + 1])));
        }
    printf("bright spot at the nose: change %+.3f at the nose, %+.3f at the cheek, largest step %.4f\n", at_nose,
           at_cheek, detail);
    CHECK(at_nose > 0.15 && at_nose < 0.22);
    CHECK(fabs(at_cheek) < 0.02);
    CHECK(detail < 0.01); /* the difference is smooth: the checker is untouched */
    hd_aligned_face_free(&face);
    hd_image_free(&photo);
    hd_image_free(&work);
    hd_image_free(&all);
    hd_image_free(&brighter);
    free(L);
}

/* |b - A f| / |b| of the blend equation over Omega, computed here independently in double. */
static double blend_residual(const hd_image *src, const hd_image *mask, int ox, int oy, const hd_image *before,
                             const hd_image *after, int c)
{
    int sw = src->width, sh = src->height, tw = before->width, th = before->height;
    const float *S = &src->data[(size_t)c * sw * sh], *T0 = &before->data[(size_t)c * tw * th],
                *F = &after->data[(size_t)c * tw * th];
#define OMEGA(x, y) \
    ((x) >= 1 && (y) >= 1 && (x) < sw - 1 && (y) < sh - 1 && (x) + ox >= 1 && (y) + oy >= 1 && (x) + ox < tw - 1 && \
     (y) + oy < th - 1 && mask->data[(size_t)(y) * sw + (x)] > 0.5f)
    double rr = 0, bb = 0;
    const int dx[4] = {-1, 1, 0, 0}, dy[4] = {0, 0, -1, 1};
    for (int y = 0; y < sh; y++)
        for (int x = 0; x < sw; x++) {
            if (!OMEGA(x, y)) continue;
            double b = 4.0 * S[y * sw + x], af = 4.0 * F[(y + oy) * tw + x + ox];
            for (int k = 0; k < 4; k++) {
                int qx = x + dx[k], qy = y + dy[k];
                b -= S[qy * sw + qx];
                if (OMEGA(qx, qy)) af -= F[(qy + oy) * tw + qx + ox];
                else b += T0[(qy + oy) * tw + qx + ox];
            }
            rr += (b - af) * (b - af);
            bb += b * b;
        }
#undef OMEGA
    return sqrt(rr / bb);
}

static void test_poisson(void)
{
    hd_image target = {0}, orig = {0}, src = {0}, mask = {0};
    const int tw = 240, th = 200, sw = 150, sh = 130, ox = 50, oy = 40;
    smooth_photo(&target, tw, th);
    hd_rng rng;
    hd_rng_seed(&rng, 7, 1);
    CHECK(hd_image_alloc(&orig, tw, th, 3) == HD_OK);
    memcpy(orig.data, target.data, (size_t)3 * tw * th * sizeof(float));
    CHECK(hd_image_alloc(&src, sw, sh, 3) == HD_OK);
    CHECK(hd_image_alloc(&mask, sw, sh, 1) == HD_OK);
    /* an irregular mask: an ellipse with a hole and a separate blob */
    for (int y = 0; y < sh; y++)
        for (int x = 0; x < sw; x++) {
            double ex = (x - 70.0) / 60, ey = (y - 65.0) / 55, hx = (x - 80.0) / 10, hy = (y - 60.0) / 12;
            int in = (ex * ex + ey * ey < 1 && hx * hx + hy * hy > 1) || ((x - 135) * (x - 135) + (y - 20) * (y - 20) < 64);
            mask.data[y * sw + x] = in ? 1.0f : 0.0f;
        }
    /* 1. a constant offset of the target: the solution is the target itself */
    for (int c = 0; c < 3; c++)
        for (int y = 0; y < sh; y++)
            for (int x = 0; x < sw; x++)
                src.data[((size_t)c * sh + y) * sw + x] = target.data[((size_t)c * th + y + oy) * tw + x + ox] + 0.25f;
    hd_poisson_report rep;
    CHECK(hd_poisson_blend(&src, &mask, ox, oy, 1e-5, &target, &rep) == HD_OK);
    double maxerr = 0;
    for (size_t i = 0; i < (size_t)3 * tw * th; i++) maxerr = fmax(maxerr, fabs(target.data[i] - orig.data[i]));
    printf("poisson, constant offset: %d unknowns, iterations %d %d %d, residual %.2g, max error %.2g, %.3f s\n",
           rep.unknowns, rep.iterations[0], rep.iterations[1], rep.iterations[2], rep.residual[0], maxerr, rep.seconds);
    CHECK(maxerr < 1e-3);
    CHECK(rep.unknowns > 10000 && rep.channels == 3);
    for (int c = 0; c < 3; c++) CHECK(rep.residual[c] <= 1e-5 && rep.iterations[c] < 100);
    /* 2. the source is the target: the target comes back */
    memcpy(target.data, orig.data, (size_t)3 * tw * th * sizeof(float));
    for (int c = 0; c < 3; c++)
        for (int y = 0; y < sh; y++)
            for (int x = 0; x < sw; x++)
                src.data[((size_t)c * sh + y) * sw + x] = target.data[((size_t)c * th + y + oy) * tw + x + ox];
    CHECK(hd_poisson_blend(&src, &mask, ox, oy, 0, &target, &rep) == HD_OK);
    maxerr = 0;
    for (size_t i = 0; i < (size_t)3 * tw * th; i++) maxerr = fmax(maxerr, fabs(target.data[i] - orig.data[i]));
    CHECK(maxerr < 1e-3);
    /* 3. an unrelated noisy source: the output satisfies the equation to the tolerance reported */
    memcpy(target.data, orig.data, (size_t)3 * tw * th * sizeof(float));
    for (size_t i = 0; i < (size_t)3 * sw * sh; i++) src.data[i] = hd_rng_uniform(&rng);
    CHECK(hd_poisson_blend(&src, &mask, ox, oy, 1e-4, &target, &rep) == HD_OK);
    for (int c = 0; c < 3; c++) {
        double r = blend_residual(&src, &mask, ox, oy, &orig, &target, c);
        CHECK(r <= 1.05e-4);
        CHECK_NEAR(r, rep.residual[c], 1e-5);
    }
    printf("poisson, noise source: iterations %d, reported residual %.3g\n", rep.iterations[0], rep.residual[0]);
    /* outside Omega the target is untouched */
    CHECK(target.data[0] == orig.data[0] && target.data[(size_t)th * tw - 1] == orig.data[(size_t)th * tw - 1]);
    /* 4. partly outside the target: clipped, still solved */
    memcpy(target.data, orig.data, (size_t)3 * tw * th * sizeof(float));
    CHECK(hd_poisson_blend(&src, &mask, 150, -30, 1e-4, &target, &rep) == HD_OK);
    CHECK(rep.unknowns > 0 && rep.residual[0] <= 1e-4);
    CHECK(blend_residual(&src, &mask, 150, -30, &orig, &target, 1) <= 1.05e-4);
    /* errors: a NaN in the source is reported, not blended */
    src.data[sw * 60 + 70] = NAN;
    CHECK(hd_poisson_blend(&src, &mask, ox, oy, 1e-4, &target, &rep) == HD_ERR_NUMERIC);
    hd_image wrong = {0};
    CHECK(hd_image_alloc(&wrong, 10, 10, 1) == HD_OK);
    CHECK(hd_poisson_blend(&src, &wrong, 0, 0, 0, &target, NULL) == HD_ERR_ARG);
    CHECK(strstr(hd_error(), "mask") != NULL);
    hd_image_free(&wrong);
    hd_image_free(&target);
    hd_image_free(&orig);
    hd_image_free(&src);
    hd_image_free(&mask);
}

/* The calls without an aligner share one canonical mesh per file, read once: hd_mesh_canonical
 * gives the same mesh twice, equal to the one loaded here; a copy in a folder of its own (through
 * HDNET_DATA) is a mesh of its own; and once it is read, spoiling that file changes nothing for
 * hd_align_face and hd_warp_back (while the file itself no longer loads). */
static void test_shared_mesh(void)
{
    const hd_mesh *a = NULL, *b = NULL, *c = NULL, *d = NULL;
    CHECK(hd_mesh_canonical(&a) == HD_OK && hd_mesh_canonical(&b) == HD_OK && a && a == b);
    if (!a) return;
    CHECK(a->nv == canonical.nv && a->nt == canonical.nt &&
          memcmp(a->pos, canonical.pos, (size_t)canonical.nv * 3 * sizeof(float)) == 0 &&
          memcmp(a->uv, canonical.uv, (size_t)canonical.nv * 2 * sizeof(float)) == 0 &&
          memcmp(a->tri, canonical.tri, (size_t)canonical.nt * 3 * sizeof(int)) == 0);
    char *found = hd_find_data("canonical_face_model.obj"), *text = NULL, *old = NULL, dir[4200];
    size_t n = 0;
    CHECK(found && hd_read_file(found, 1 << 24, &text, &n) == HD_OK);
    CHECK(hd_mkdirs("own_models") == HD_OK && getcwd(dir, 4096) != NULL);
    FILE *f = fopen("own_models/canonical_face_model.obj", "wb");
    CHECK(f && text && fwrite(text, 1, n, f) == n);
    if (f) fclose(f);
    if (getenv("HDNET_DATA")) old = strdup(getenv("HDNET_DATA"));
    strcat(dir, "/own_models");
    setenv("HDNET_DATA", dir, 1);
    CHECK(hd_mesh_canonical(&c) == HD_OK && c && c != a && c->nv == a->nv);
    float (*L)[3] = malloc(sizeof(float[HD_FACE_LANDMARKS][3]));
    double R[9];
    hd_image photo = {0}, w1 = {0}, c1 = {0}, w2 = {0}, c2 = {0};
    smooth_photo(&photo, 160, 150);
    project(10, 0, 0, 6, 80, 75, L, R);
    hd_aligned_face face, again;
    CHECK(hd_align_face(&photo, (const float (*)[3])L, 64, &face) == HD_OK);
    CHECK(hd_warp_back(&face, &face.texture, NULL, &w1, &c1) == HD_OK);
    f = fopen("own_models/canonical_face_model.obj", "wb"); /* spoiled: one vertex of two numbers */
    if (f) fputs("v 1 2\n", f), fclose(f);
    hd_mesh spoiled;
    CHECK(hd_mesh_load_canonical(&spoiled) == HD_ERR_FORMAT);
    CHECK(hd_mesh_canonical(&d) == HD_OK && d == c);
    CHECK(hd_align_face(&photo, (const float (*)[3])L, 64, &again) == HD_OK);
    CHECK(again.texture.data && memcmp(again.texture.data, face.texture.data, (size_t)64 * 64 * 3 * sizeof(float)) == 0);
    CHECK(hd_warp_back(&face, &face.texture, NULL, &w2, &c2) == HD_OK);
    CHECK(w1.data && w2.data && memcmp(w1.data, w2.data, (size_t)160 * 150 * 3 * sizeof(float)) == 0);
    if (old) setenv("HDNET_DATA", old, 1);
    else unsetenv("HDNET_DATA");
    free(old);
    free(found);
    free(text);
    free(L);
    hd_aligned_face_free(&face);
    hd_aligned_face_free(&again);
    hd_image_free(&photo);
    hd_image_free(&w1);
    hd_image_free(&c1);
    hd_image_free(&w2);
    hd_image_free(&c2);
}

int main(void)
{
    if (!test_load_canonical(&canonical)) return 1;
    test_fit();
    test_round_trip_and_normals();
    test_change_mode();
    test_shared_mesh();
    test_poisson();
    hd_mesh_free(&canonical);
    return test_summary("align");
}
