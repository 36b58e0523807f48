/* test_synth.c: the synthetic-face generator: determinism for a seed (and independence of the
 * thread count), image = albedo x shading (in memory exactly, on disk within quantisation),
 * shading = s(normal_gt, light) by the light module's own basis, the least-squares light of the
 * ground truth recovers the ground-truth light, a subject's albedo is the same in all its images,
 * landmarks sit where SPEC section 2 puts them, the coarse normals' modelled fit error (exact at 0,
 * tens of degrees by default, zero-mean, deterministic, touching nothing else), and the FAST PNG
 * effort the set is written with reads back like the default one; the camera effects (each present
 * when enabled, its own signature, deterministic, the ground truth untouched). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include "test.h"
#include "test_models.h"
#include "core/core.h"
#include "io/image_io.h"
#include "synth/synth.h"


static long long file_size_of(const char *path)
{
    struct stat sb;
    return stat(path, &sb) == 0 ? (long long)sb.st_size : -1;
}

static int same_image(const hd_image *a, const hd_image *b)
{
    return a->width == b->width && a->height == b->height && a->channels == b->channels &&
           memcmp(a->data, b->data, (size_t)a->width * a->height * a->channels * sizeof(float)) == 0;
}

static double angle_deg(const float *a, const float *b, size_t P, size_t i)
{
    double d = (double)a[i] * b[i] + (double)a[P + i] * b[P + i] + (double)a[2 * P + i] * b[2 * P + i];
    d = d > 1 ? 1 : d < -1 ? -1 : d;
    return acos(d) * 180.0 / M_PI;
}

/* A generator at size S, or NULL with the failure counted and reported. */
static hd_synth *synth_or_fail(int S)
{
    hd_synth *s = NULL;
    if (hd_synth_create(S, &s) == HD_OK) return s;
    fprintf(stderr, "hd_synth_create: %s\n", hd_error());
    test_failures++;
    return NULL;
}

static void test_render(void)
{
    const int S = 64;
    const size_t P = (size_t)S * S;
    hd_synth *s = synth_or_fail(S);
    if (!s) return;
    CHECK(hd_synth_size(s) == S);
    hd_synth_subject *a = NULL, *a2 = NULL, *b = NULL;
    CHECK(hd_synth_subject_make(s, 7, 3, &a) == HD_OK);
    CHECK(hd_synth_subject_make(s, 7, 3, &a2) == HD_OK);
    CHECK(hd_synth_subject_make(s, 7, 4, &b) == HD_OK);
    hd_synth_face f0 = {0}, f0b = {0}, f1 = {0}, g0 = {0};
    CHECK(hd_synth_render(s, a, 0, 8.0f, 0.0f, &f0) == HD_OK);
    CHECK(hd_synth_render(s, a2, 0, 8.0f, 0.0f, &f0b) == HD_OK);
    CHECK(hd_synth_render(s, a, 1, 8.0f, 0.0f, &f1) == HD_OK);
    CHECK(hd_synth_render(s, b, 0, 8.0f, 0.0f, &g0) == HD_OK);
    /* deterministic */
    CHECK(same_image(&f0.image, &f0b.image) && same_image(&f0.normal_gt, &f0b.normal_gt));
    CHECK(memcmp(f0.light, f0b.light, sizeof f0.light) == 0);
    /* another image of the subject: other light, other pose, same albedo where both are visible */
    CHECK(memcmp(f0.light, f1.light, sizeof f0.light) != 0);
    CHECK(f0.yaw_deg != f1.yaw_deg && fabsf(f0.yaw_deg) <= 8.0f && fabsf(f1.pitch_deg) <= 8.0f);
    int both = 0, albedo_same = 1;
    for (size_t i = 0; i < P; i++)
        if (f0.mask.data[i] > 0.5f && f1.mask.data[i] > 0.5f) {
            both++;
            for (int c = 0; c < 3; c++) albedo_same &= f0.albedo.data[c * P + i] == f1.albedo.data[c * P + i];
        }
    CHECK(both > (int)P / 3 && albedo_same);
    /* another subject: another albedo */
    double diff = 0;
    for (size_t i = 0; i < 3 * P; i++) diff += fabs(f0.albedo.data[i] - g0.albedo.data[i]);
    CHECK(diff > 0.01 * (double)P);
    /* rendering equation and ground truth consistency on every masked texel */
    int bad_eq = 0, bad_sh = 0, bad_unit = 0, bad_out = 0, n = 0;
    double err_sum = 0;
    for (size_t i = 0; i < P; i++) {
        if (f0.mask.data[i] <= 0.5f) {
            float z = 0;
            for (int c = 0; c < 3; c++) z += fabsf(f0.image.data[c * P + i]) + fabsf(f0.normal_gt.data[c * P + i]);
            bad_out += z != 0.0f || f0.shading.data[i] != 0.0f;
            continue;
        }
        n++;
        float ng[3] = {f0.normal_gt.data[i], f0.normal_gt.data[P + i], f0.normal_gt.data[2 * P + i]};
        float nc[3] = {f0.normal.data[i], f0.normal.data[P + i], f0.normal.data[2 * P + i]};
        bad_unit += fabsf(ng[0] * ng[0] + ng[1] * ng[1] + ng[2] * ng[2] - 1) > 1e-4f || ng[2] <= 0;
        bad_unit += fabsf(nc[0] * nc[0] + nc[1] * nc[1] + nc[2] * nc[2] - 1) > 1e-4f;
        float sh = hd_sh_shade(f0.light, ng);
        bad_sh += fabsf(sh - f0.shading.data[i]) > 1e-5f || f0.shading.data[i] < 0;
        for (int c = 0; c < 3; c++) {
            float v = f0.albedo.data[c * P + i] * f0.shading.data[i];
            v = v > 1 ? 1 : v;
            bad_eq += fabsf(v - f0.image.data[c * P + i]) > 1e-6f;
        }
        err_sum += angle_deg(f0.normal.data, f0.normal_gt.data, P, i);
    }
    CHECK(bad_eq == 0);
    CHECK(bad_sh == 0);
    CHECK(bad_unit == 0);
    CHECK(bad_out == 0);
    /* the exact-pose coarse normals (no identity, no detail) are off by about ten degrees */
    double coarse = err_sum / (n ? n : 1);
    fprintf(stderr, "coarse-normal error at %d: %.1f degrees over %d texels\n", S, coarse, n);
    CHECK(coarse > 5.0 && coarse < 45.0);
    /* least squares on the ground truth gives the ground-truth light back */
    float fit[HD_SH_COEFFS];
    CHECK(hd_sh_fit(f0.normal_gt.data, f0.shading.data, f0.mask.data, S * S, fit) == HD_OK);
    for (int k = 0; k < HD_SH_COEFFS; k++) CHECK_NEAR(fit[k], f0.light[k], 2e-3);
    /* SPEC section 2: eyes, nose tip, mouth and chin are face texels in a frontal image; the
     * texture's corner is not */
    hd_synth_face fr = {0};
    CHECK(hd_synth_render(s, a, 2, 0.0f, 0.0f, &fr) == HD_OK);
    CHECK(fr.yaw_deg == 0 && fr.pitch_deg == 0 && fr.roll_deg == 0);
    static const float marks[][2] = {{0.5f, 0.547f}, {0.33f, 0.376f}, {0.67f, 0.376f}, {0.45f, 0.695f}, {0.5f, 0.94f}, {0.5f, 0.12f}};
    for (size_t k = 0; k < sizeof marks / sizeof marks[0]; k++) {
        int x = (int)(marks[k][0] * S), y = (int)(marks[k][1] * S);
        CHECK(fr.mask.data[(size_t)y * S + x] == 1.0f);
    }
    CHECK(fr.mask.data[0] == 0.0f);
    /* the nose tip faces the viewer, the image-left cheek turns left */
    size_t nose = (size_t)(0.547f * S) * S + (size_t)(0.5f * S);
    CHECK(fr.normal.data[2 * P + nose] > 0.7f);
    size_t cheek = (size_t)(0.55f * S) * S + (size_t)(0.12f * S);
    CHECK(fr.mask.data[cheek] == 0.0f || fr.normal.data[cheek] < 0.0f);
    /* reused buffers give the same result as fresh ones */
    CHECK(hd_synth_render(s, a, 0, 8.0f, 0.0f, &fr) == HD_OK);
    CHECK(same_image(&fr.image, &f0.image) && same_image(&fr.mask, &f0.mask));
    /* bad arguments */
    hd_synth_face bad = {0};
    CHECK(hd_synth_render(s, a, -1, 0.0f, 0.0f, &bad) == HD_ERR_ARG);
    CHECK(hd_synth_render(s, a, 0, 90.0f, 0.0f, &bad) == HD_ERR_RANGE);
    hd_synth *t = NULL;
    CHECK(hd_synth_create(8, &t) == HD_ERR_RANGE && t == NULL);
    hd_synth_face_free(&f0);
    hd_synth_face_free(&f0b);
    hd_synth_face_free(&f1);
    hd_synth_face_free(&g0);
    hd_synth_face_free(&fr);
    hd_synth_subject_free(a);
    hd_synth_subject_free(a2);
    hd_synth_subject_free(b);
    hd_synth_free(s);
}

static int same_face_but_coarse(const hd_synth_face *a, const hd_synth_face *b)
{
    return same_image(&a->image, &b->image) && same_image(&a->mask, &b->mask) && same_image(&a->albedo, &b->albedo) &&
           same_image(&a->normal_gt, &b->normal_gt) && same_image(&a->shading, &b->shading) &&
           memcmp(a->light, b->light, sizeof a->light) == 0 && a->yaw_deg == b->yaw_deg &&
           a->pitch_deg == b->pitch_deg && a->roll_deg == b->roll_deg;
}

/* The coarse normals' fit error (--coarse-error): 0 is the exact pose and the undeformed mesh; the
 * default lands the mean angular error against the ground truth in the twenties, like the paper's
 * 3DMM baseline; only the coarse normals change; deterministic; zero-mean, so that the average over
 * many images is much closer to the exact-pose normals than one image is. */
static void test_coarse_error(void)
{
    const int S = 64, SUBJECTS = 8, IMAGES = 4;
    const size_t P = (size_t)S * S;
    const float E = HD_SYNTH_COARSE_ERROR_DEFAULT;
    hd_synth *s = synth_or_fail(S);
    if (!s) return;
    double *sum_e = calloc(6 * P, sizeof(double)), *sum_0 = sum_e ? sum_e + 3 * P : NULL; /* sums of normals */
    int *count = calloc(P, sizeof(int));
    double err0 = 0, errE = 0, dev = 0, pose_sum[3] = {0}, pose_sq = 0;
    long n = 0;
    int only_coarse = 1, determ = 1, exact_pose = 1, differs = 0, unit = 1;
    for (int j = 0; j < SUBJECTS && sum_e && count; j++) {
        hd_synth_subject *sub = NULL;
        CHECK(hd_synth_subject_make(s, 5, j, &sub) == HD_OK);
        for (int k = 0; k < IMAGES && sub; k++) {
            hd_synth_face f0 = {0}, fe = {0}, fe2 = {0};
            CHECK(hd_synth_render(s, sub, k, 5.0f, 0.0f, &f0) == HD_OK);
            CHECK(hd_synth_render(s, sub, k, 5.0f, E, &fe) == HD_OK);
            CHECK(hd_synth_render(s, sub, k, 5.0f, E, &fe2) == HD_OK);
            only_coarse &= same_face_but_coarse(&f0, &fe);
            determ &= same_image(&fe.normal, &fe2.normal) && fe.coarse_yaw_deg == fe2.coarse_yaw_deg;
            exact_pose &= f0.coarse_yaw_deg == f0.yaw_deg && f0.coarse_pitch_deg == f0.pitch_deg &&
                          f0.coarse_roll_deg == f0.roll_deg;
            differs += !same_image(&f0.normal, &fe.normal);
            float d[3] = {fe.coarse_yaw_deg - fe.yaw_deg, fe.coarse_pitch_deg - fe.pitch_deg, fe.coarse_roll_deg - fe.roll_deg};
            for (int c = 0; c < 3; c++) pose_sum[c] += d[c], pose_sq += d[c] * d[c];
            for (size_t i = 0; i < P; i++) {
                if (f0.mask.data[i] <= 0.5f) continue;
                n++;
                err0 += angle_deg(f0.normal.data, f0.normal_gt.data, P, i);
                errE += angle_deg(fe.normal.data, fe.normal_gt.data, P, i);
                dev += angle_deg(fe.normal.data, f0.normal.data, P, i);
                float len2 = 0;
                for (int c = 0; c < 3; c++) {
                    float v = fe.normal.data[c * P + i];
                    len2 += v * v;
                    sum_e[c * P + i] += v;
                    sum_0[c * P + i] += f0.normal.data[c * P + i];
                }
                unit &= fabsf(len2 - 1.0f) < 1e-4f;
                count[i]++;
            }
            hd_synth_face_free(&f0);
            hd_synth_face_free(&fe);
            hd_synth_face_free(&fe2);
        }
        hd_synth_subject_free(sub);
    }
    CHECK(only_coarse && determ && exact_pose && unit);
    CHECK(differs == SUBJECTS * IMAGES);
    err0 /= (double)(n ? n : 1), errE /= (double)(n ? n : 1), dev /= (double)(n ? n : 1);
    /* the angle between the mean coarse normal with the error and without: what is left of the
     * error after averaging the images */
    double left = 0;
    int texels = 0;
    for (size_t i = 0; i < P && sum_e && count; i++) {
        if (count[i] < SUBJECTS * IMAGES / 2) continue;
        double dot = 0, ne = 0, n0 = 0;
        for (int c = 0; c < 3; c++) {
            dot += sum_e[c * P + i] * sum_0[c * P + i];
            ne += sum_e[c * P + i] * sum_e[c * P + i];
            n0 += sum_0[c * P + i] * sum_0[c * P + i];
        }
        left += acos(fmax(-1.0, fmin(1.0, dot / sqrt(ne * n0 + 1e-30)))) * 180.0 / M_PI;
        texels++;
    }
    left /= texels ? texels : 1;
    int N = SUBJECTS * IMAGES;
    double pose_std = sqrt(pose_sq / (3.0 * N));
    fprintf(stderr, "coarse error at %d: %.1f degrees exact, %.1f with --coarse-error %g (%.1f from the exact "
            "normals, %.1f after averaging %d images); pose error std %.1f, means %.1f %.1f %.1f\n", S, err0, errE,
            (double)E, dev, left, N, pose_std, pose_sum[0] / N, pose_sum[1] / N, pose_sum[2] / N);
    CHECK(err0 > 5.0 && err0 < 13.0);
    CHECK(errE > 19.0 && errE < 27.0);
    CHECK(left < 0.3 * dev);
    CHECK(pose_std > 0.3 * E && pose_std < 0.7 * E);
    for (int c = 0; c < 3; c++) CHECK(fabs(pose_sum[c] / N) < 3.0 * 0.5 * E / sqrt((double)N));
    /* out of range */
    hd_synth_subject *sub = NULL;
    hd_synth_face bad = {0};
    CHECK(hd_synth_subject_make(s, 5, 0, &sub) == HD_OK);
    CHECK(hd_synth_render(s, sub, 0, 0.0f, -1.0f, &bad) == HD_ERR_RANGE);
    CHECK(hd_synth_render(s, sub, 0, 0.0f, HD_SYNTH_COARSE_ERROR_MAX + 1.0f, &bad) == HD_ERR_RANGE);
    CHECK(hd_synth_render(s, sub, 0, 0.0f, NAN, &bad) == HD_ERR_RANGE);
    hd_synth_face_free(&bad);
    hd_synth_subject_free(sub);
    free(sum_e);
    free(count);
    hd_synth_free(s);
}

/* The fit's pose error set on its own (hd_synth_render_fit): the image and its ground truth are the
 * default render's, the pose error's spread is the one asked for (over 64 images, each angle), and
 * the shape and tilt errors stay E's: with a pose error of 0.01 degrees the coarse normals are off
 * from the exact-pose ones by about as much as the default's, less its pose part. A negative pose
 * error is the default (E / 2) exactly. */
static void test_coarse_pose(void)
{
    const int S = 48, SUBJECTS = 16, IMAGES = 4;
    const float E = HD_SYNTH_COARSE_ERROR_DEFAULT, SD = 3.0f;
    const size_t P = (size_t)S * S;
    hd_synth *s = synth_or_fail(S);
    if (!s) return;
    int same = 1, as_default = 1, n = 0;
    double sq = 0, dev_default = 0, dev_tiny = 0;
    long texels = 0;
    for (int j = 0; j < SUBJECTS; j++) {
        hd_synth_subject *sub = NULL;
        CHECK(hd_synth_subject_make(s, 9, j, &sub) == HD_OK);
        for (int k = 0; k < IMAGES && sub; k++) {
            hd_synth_face f0 = {0}, fd = {0}, fp = {0}, ft = {0}, fneg = {0};
            CHECK(hd_synth_render(s, sub, k, 20.0f, 0.0f, &f0) == HD_OK);
            CHECK(hd_synth_render(s, sub, k, 20.0f, E, &fd) == HD_OK);
            CHECK(hd_synth_render_fit(s, sub, k, 20.0f, E, SD, &fp) == HD_OK);
            CHECK(hd_synth_render_fit(s, sub, k, 20.0f, E, 0.01f, &ft) == HD_OK);
            CHECK(hd_synth_render_fit(s, sub, k, 20.0f, E, -1.0f, &fneg) == HD_OK);
            same &= same_face_but_coarse(&fd, &fp) && same_face_but_coarse(&fd, &ft);
            as_default &= same_image(&fd.normal, &fneg.normal) && fd.coarse_pitch_deg == fneg.coarse_pitch_deg;
            const float d[3] = {fp.coarse_yaw_deg - fp.yaw_deg, fp.coarse_pitch_deg - fp.pitch_deg,
                                fp.coarse_roll_deg - fp.roll_deg};
            for (int c = 0; c < 3; c++) sq += d[c] * d[c];
            n += 3;
            for (size_t i = 0; i < P; i++)
                if (f0.mask.data[i] > 0.5f && fd.mask.data[i] > 0.5f) {
                    dev_default += angle_deg(fd.normal.data, f0.normal.data, P, i);
                    dev_tiny += angle_deg(ft.normal.data, f0.normal.data, P, i);
                    texels++;
                }
            hd_synth_face_free(&f0), hd_synth_face_free(&fd), hd_synth_face_free(&fp);
            hd_synth_face_free(&ft), hd_synth_face_free(&fneg);
        }
        hd_synth_subject_free(sub);
    }
    const double sd = sqrt(sq / (n ? n : 1));
    dev_default /= (double)(texels ? texels : 1), dev_tiny /= (double)(texels ? texels : 1);
    fprintf(stderr, "coarse pose error: asked %.1f, measured %.2f over %d angles; coarse normals off the exact "
            "pose's by %.1f degrees (default) and %.1f (pose error 0.01)\n", (double)SD, sd, n, dev_default, dev_tiny);
    CHECK(same && as_default);
    CHECK(sd > 0.8 * SD && sd < 1.2 * SD);
    CHECK(dev_tiny > 5.0 && dev_tiny < dev_default - 2.0);
    hd_synth_subject *sub = NULL;
    hd_synth_face bad = {0};
    CHECK(hd_synth_subject_make(s, 9, 0, &sub) == HD_OK);
    CHECK(hd_synth_render_fit(s, sub, 0, 0.0f, E, HD_SYNTH_COARSE_ERROR_MAX + 1.0f, &bad) == HD_ERR_RANGE);
    CHECK(hd_synth_render_fit(s, sub, 0, 0.0f, E, NAN, &bad) == HD_ERR_RANGE);
    hd_synth_face_free(&bad);
    hd_synth_subject_free(sub);
    hd_synth_free(s);
}

static int files_equal(const char *p, const char *q)
{
    char *a = NULL, *b = NULL;
    size_t na = 0, nb = 0;
    int eq = hd_read_file(p, 1 << 24, &a, &na) == HD_OK && hd_read_file(q, 1 << 24, &b, &nb) == HD_OK && na == nb &&
             memcmp(a, b, na) == 0;
    free(a);
    free(b);
    return eq;
}

/* A whole set on disk, written with 1 and with 2 threads: byte-identical; the files read back
 * satisfy image = albedo x shading within quantisation. */
static void test_write_set(void)
{
    hd_synth_options o = {3, 3, 32, 11, 5.0f, HD_SYNTH_COARSE_ERROR_DEFAULT, 0, {0.0f, 0}, 0.0f};
    hd_set_threads(1);
    CHECK(hd_synth_write_set("set1", &o, NULL, NULL) == HD_OK);
    hd_set_threads(2);
    CHECK(hd_synth_write_set("set2", &o, NULL, NULL) == HD_OK);
    static const char *const suffix[] = {".png", ".mask.png", ".normal.png", ".albedo.png", ".normal_gt.png",
                                         ".shading.png", ".shading.pfm", ".light.txt"};
    for (int sub = 0; sub < 3; sub++)
        for (int im = 0; im < 3; im++)
            for (int k = 0; k < 8; k++) {
                char p[256], q[256];
                snprintf(p, sizeof p, "set1/subject_%04d/%04d%s", sub, im, suffix[k]);
                snprintf(q, sizeof q, "set2/subject_%04d/%04d%s", sub, im, suffix[k]);
                if (!files_equal(p, q)) {
                    fprintf(stderr, "%s and %s differ (or are missing)\n", p, q);
                    test_failures++;
                }
            }
    CHECK(files_equal("set1/preview.sheet.png", "set2/preview.sheet.png"));
    hd_image img = {0}, alb = {0}, sh = {0}, shp = {0}, mask = {0};
    float light[HD_SH_COEFFS];
    CHECK(hd_image_read("set1/subject_0001/0002.png", &img) == HD_OK);
    CHECK(hd_image_read("set1/subject_0001/0002.albedo.png", &alb) == HD_OK);
    CHECK(hd_image_read("set1/subject_0001/0002.shading.pfm", &sh) == HD_OK);
    CHECK(hd_image_read("set1/subject_0001/0002.shading.png", &shp) == HD_OK);
    CHECK(hd_image_read("set1/subject_0001/0002.mask.png", &mask) == HD_OK);
    CHECK(hd_light_read("set1/subject_0001/0002.light.txt", light) == HD_OK);
    if (img.data && alb.data && sh.data && shp.data && mask.data && img.channels == 3 && alb.channels == 3) {
        size_t P = 32 * 32;
        int bad = 0, masked = 0;
        for (size_t i = 0; i < P; i++) {
            if (mask.data[i] <= 0.5f) continue;
            masked++;
            bad += fabsf(2.0f * shp.data[i] - sh.data[i]) > 2.0f / 65535.0f;
            for (int c = 0; c < 3; c++) {
                float v = alb.data[c * P + i] * sh.data[i];
                v = v > 1 ? 1 : v;
                /* both PNGs are 8 bit: half a step each, the albedo's scaled by the shading */
                bad += fabsf(v - img.data[c * P + i]) > (0.5f + 0.5f * sh.data[i]) / 255.0f + 1e-6f;
            }
        }
        CHECK(masked > 200);
        CHECK(bad == 0);
    }
    hd_image_free(&img);
    hd_image_free(&alb);
    hd_image_free(&sh);
    hd_image_free(&shp);
    hd_image_free(&mask);
    /* png_store: uncompressed PNGs that decode to the same samples, the other files byte-identical */
    hd_synth_options st = o;
    st.png_store = 1;
    CHECK(hd_synth_write_set("set_store", &st, NULL, NULL) == HD_OK);
    for (int sub = 0; sub < 3; sub++)
        for (int im = 0; im < 3; im++)
            for (int k = 0; k < 8; k++) {
                char p[256], q[256];
                snprintf(p, sizeof p, "set1/subject_%04d/%04d%s", sub, im, suffix[k]);
                snprintf(q, sizeof q, "set_store/subject_%04d/%04d%s", sub, im, suffix[k]);
                if (k >= 6) {
                    CHECK(files_equal(p, q));
                    continue;
                }
                hd_image a = {0}, b = {0};
                CHECK(hd_image_read(p, &a) == HD_OK);
                CHECK(hd_image_read(q, &b) == HD_OK);
                CHECK(a.data && b.data && same_image(&a, &b));
                CHECK(file_size_of(q) > file_size_of(p));
                hd_image_free(&a);
                hd_image_free(&b);
            }
    st.png_store = 2;
    CHECK(hd_synth_write_set("set3", &st, NULL, NULL) == HD_ERR_RANGE);
    CHECK(strstr(hd_error(), "png_store") != NULL);
    /* bad options are refused with a reason */
    hd_synth_options z = {0, 1, 32, 1, 0, 0, 0, {0.0f, 0}, 0.0f};
    CHECK(hd_synth_write_set("set3", &z, NULL, NULL) == HD_ERR_RANGE);
    CHECK(strstr(hd_error(), "subjects") != NULL);
    hd_synth_options ce = {1, 1, 32, 1, 0, -2.0f, 0, {0.0f, 0}, 0.0f};
    CHECK(hd_synth_write_set("set3", &ce, NULL, NULL) == HD_ERR_RANGE);
    CHECK(strstr(hd_error(), "coarse-error") != NULL);
    hd_synth_options cp = {1, 1, 32, 1, 0, 20.0f, 0, {0.0f, 0}, -3.0f};
    CHECK(hd_synth_write_set("set3", &cp, NULL, NULL) == HD_ERR_RANGE);
    CHECK(strstr(hd_error(), "coarse-pose-error") != NULL);
}

/* The PNG writer's FAST and STORE efforts (what the set's files use) read back exactly like
 * COMPACT, for 1-4 channels at 8 and 16 bits, odd sizes and out-of-range values (a NaN is refused);
 * the large size needs several of zlib's stored blocks (at most 64 KB each). */
static void test_png_fast(void)
{
    hd_rng r;
    hd_rng_seed(&r, 3, 4);
    static const int sizes[2][2] = {{37, 21}, {301, 117}};
    for (int sz = 0; sz < 2; sz++)
        for (int channels = 1; channels <= 4; channels++)
            for (int bits = 8; bits <= 16; bits += 8) {
                hd_image img = {0}, a = {0}, b = {0}, c = {0};
                int w = sizes[sz][0], h = sizes[sz][1];
                CHECK(hd_image_alloc(&img, w, h, channels) == HD_OK);
                size_t n = (size_t)w * h * channels;
                for (size_t i = 0; i < n; i++) img.data[i] = i % 5 == 0 ? 0.25f : hd_rng_range(&r, -0.2f, 1.2f);
                img.data[3] = NAN;
                CHECK(hd_image_write_png_effort("nan.png", &img, bits, HD_PNG_FAST) == HD_ERR_NUMERIC);
                img.data[3] = -0.2f;
                CHECK(hd_image_write_png_effort("compact.png", &img, bits, HD_PNG_COMPACT) == HD_OK);
                CHECK(hd_image_write_png_effort("fast.png", &img, bits, HD_PNG_FAST) == HD_OK);
                CHECK(hd_image_write_png_effort("store.png", &img, bits, HD_PNG_STORE) == HD_OK);
                CHECK(hd_image_read("compact.png", &a) == HD_OK);
                CHECK(hd_image_read("fast.png", &b) == HD_OK);
                CHECK(hd_image_read("store.png", &c) == HD_OK);
                CHECK(a.data && b.data && same_image(&a, &b) && a.channels == channels);
                CHECK(a.data && c.data && same_image(&a, &c));
                if (a.data) CHECK(a.data[3] == 0.0f);
                /* stored: the samples, one filter byte a row, and a few bytes per block and chunk */
                long long raw = (long long)h * (1 + (long long)w * channels * (bits / 8));
                CHECK(file_size_of("store.png") >= raw && file_size_of("store.png") < raw + raw / 50 + 200);
                hd_image_free(&img);
                hd_image_free(&a);
                hd_image_free(&b);
                hd_image_free(&c);
            }
    hd_image one = {0};
    CHECK(hd_image_alloc(&one, 2, 2, 1) == HD_OK);
    CHECK(hd_image_write_png_effort("bad.png", &one, 8, (hd_png_effort)7) == HD_ERR_ARG);
    hd_image_free(&one);
}

/* Sum of squared differences between horizontal neighbours inside the mask: blur lowers it, noise
 * raises it. */
static double roughness(const hd_image *img, const hd_image *mask)
{
    int S = img->width;
    size_t P = (size_t)S * S;
    double e = 0;
    for (int c = 0; c < 3; c++)
        for (int y = 0; y < S; y++)
            for (int x = 0; x + 1 < S; x++) {
                size_t q = (size_t)y * S + x;
                if (mask->data[q] <= 0.5f || mask->data[q + 1] <= 0.5f) continue;
                double d = img->data[c * P + q + 1] - img->data[c * P + q];
                e += d * d;
            }
    return e;
}

/* Mean red over mean blue inside the mask. */
static double red_blue(const hd_image *img, const hd_image *mask)
{
    size_t P = (size_t)img->width * img->height;
    double r = 0, b = 0;
    for (size_t q = 0; q < P; q++)
        if (mask->data[q] > 0.5f) {
            r += img->data[q];
            b += img->data[2 * P + q];
        }
    return r / b;
}

static void test_camera(void)
{
    const int S = 64;
    hd_synth *s = NULL;
    hd_synth_subject *sub = NULL;
    if (hd_synth_create(S, &s) != HD_OK || hd_synth_subject_make(s, 5, 2, &sub) != HD_OK) {
        fprintf(stderr, "synth: %s\n", hd_error());
        test_failures++;
        return;
    }
    hd_synth_face plain = {0}, f = {0}, g = {0};
    CHECK(hd_synth_render(s, sub, 1, 10.0f, 20.0f, &plain) == HD_OK);
    /* probability 0: nothing changes */
    hd_synth_camera off = {0.0f, HD_SYNTH_CAMERA_ALL};
    CHECK(hd_synth_render(s, sub, 1, 10.0f, 20.0f, &f) == HD_OK);
    CHECK(hd_synth_camera_apply(&f, &off, 5, 2, 1, NULL) == HD_OK);
    CHECK(same_image(&f.image, &plain.image));
    double rough0 = roughness(&plain.image, &plain.mask), rb0 = red_blue(&plain.image, &plain.mask);
    static const unsigned each[] = {HD_SYNTH_CAMERA_LIGHT_COLOUR, HD_SYNTH_CAMERA_BLUR, HD_SYNTH_CAMERA_NOISE,
                                    HD_SYNTH_CAMERA_WHITE_BALANCE, HD_SYNTH_CAMERA_JPEG, HD_SYNTH_CAMERA_ALL};
    for (size_t k = 0; k < sizeof each / sizeof each[0]; k++) {
        hd_synth_camera cam = {1.0f, each[k]};
        hd_synth_camera_record rec, rec2;
        CHECK(hd_synth_render(s, sub, 1, 10.0f, 20.0f, &f) == HD_OK);
        CHECK(hd_synth_camera_apply(&f, &cam, 5, 2, 1, &rec) == HD_OK);
        CHECK(rec.applied == each[k]);
        CHECK(!same_image(&f.image, &plain.image));
        /* the ground truth is the scene's */
        CHECK(same_image(&f.albedo, &plain.albedo) && same_image(&f.shading, &plain.shading) &&
              same_image(&f.normal_gt, &plain.normal_gt) && same_image(&f.mask, &plain.mask));
        /* deterministic: the same (seed, subject, image) gives the same bytes */
        CHECK(hd_synth_render(s, sub, 1, 10.0f, 20.0f, &g) == HD_OK);
        CHECK(hd_synth_camera_apply(&g, &cam, 5, 2, 1, &rec2) == HD_OK);
        CHECK(same_image(&f.image, &g.image));
        /* another image of the subject draws other parameters */
        hd_synth_camera_record rec3;
        CHECK(hd_synth_render(s, sub, 2, 10.0f, 20.0f, &g) == HD_OK);
        CHECK(hd_synth_camera_apply(&g, &cam, 5, 2, 2, &rec3) == HD_OK);
        CHECK(memcmp(&rec, &rec3, sizeof rec) != 0);
        double rough = roughness(&f.image, &f.mask), rb = red_blue(&f.image, &f.mask);
        if (each[k] == HD_SYNTH_CAMERA_BLUR) CHECK(rough < 0.8 * rough0 && rec.blur_sigma >= 0.3f);
        if (each[k] == HD_SYNTH_CAMERA_NOISE) CHECK(rough > rough0);
        if (each[k] == HD_SYNTH_CAMERA_LIGHT_COLOUR)
            CHECK(fabs(rb / rb0 - rec.light_gain[0] / rec.light_gain[2]) < 0.05 * rb / rb0);
        if (each[k] == HD_SYNTH_CAMERA_WHITE_BALANCE) CHECK(fabs(rb / rb0 - 1.0) > 0.005);
        if (each[k] == HD_SYNTH_CAMERA_JPEG) CHECK(rec.jpeg_quality >= 40 && rec.jpeg_quality <= 95);
        /* outside the mask the image stays black */
        size_t P = (size_t)S * S;
        int dark = 1;
        for (size_t q = 0; q < P; q++)
            if (f.mask.data[q] <= 0.0f && (f.image.data[q] != 0 || f.image.data[P + q] != 0 || f.image.data[2 * P + q] != 0))
                dark = 0;
        CHECK(dark);
    }
    /* the draws of one effect do not depend on which others are enabled */
    hd_synth_camera one = {1.0f, HD_SYNTH_CAMERA_BLUR}, all = {1.0f, HD_SYNTH_CAMERA_ALL};
    hd_synth_camera_record r1, r2;
    CHECK(hd_synth_render(s, sub, 1, 10.0f, 20.0f, &f) == HD_OK && hd_synth_camera_apply(&f, &one, 5, 2, 1, &r1) == HD_OK);
    CHECK(hd_synth_render(s, sub, 1, 10.0f, 20.0f, &f) == HD_OK && hd_synth_camera_apply(&f, &all, 5, 2, 1, &r2) == HD_OK);
    CHECK(r1.blur_sigma == r2.blur_sigma);
    hd_synth_camera bad = {1.5f, HD_SYNTH_CAMERA_ALL};
    CHECK(hd_synth_camera_apply(&f, &bad, 5, 2, 1, NULL) == HD_ERR_RANGE);
    hd_synth_face_free(&plain);
    hd_synth_face_free(&f);
    hd_synth_face_free(&g);
    hd_synth_subject_free(sub);
    hd_synth_free(s);
}

int main(void)
{
    test_use_source_models(0);
    test_render();
    test_coarse_error();
    test_coarse_pose();
    test_write_set();
    test_png_fast();
    test_camera();
    return test_summary("test_synth");
}
