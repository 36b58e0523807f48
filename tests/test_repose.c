/* test_repose.c: the model's normals turned toward the landmark fit's pose (src/apply/repose.c) on
 * constructed faces with known answers: a sphere cap as the face, its coarse normals turned by a
 * known pose; the model's normals the cap unturned (the pose missed), with and without a local
 * shape of their own. The whole turn gives the coarse normals back (the pose found to 1e-4
 * degrees), a share of it that share of the angle about the same axis, the local shape is kept,
 * and nothing changes without a mask, with share 0, or on bad arguments; a texture finer than the
 * model's normals is sampled where they lie. hd_best_rotation on its own: a known rotation out of
 * noiseless pairs. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "test.h"
#include "test_pose.h"
#include "core/core.h"
#include "apply/apply.h"
#include "align/align.h"

static void turn(const double R[9], const float p[3], float q[3])
{
    for (int k = 0; k < 3; k++) q[k] = (float)(R[3 * k] * p[0] + R[3 * k + 1] * p[1] + R[3 * k + 2] * p[2]);
}

/* The cap's normal at texel (x, y) of an S x S texture, with a local bump of size `bump` (a
 * ripple, zero-mean over the cap); 0 outside the disc. */
static int cap_normal(int x, int y, int S, float bump, float n[3])
{
    const float u = 2.0f * (x + 0.5f) / S - 1.0f, v = 1.0f - 2.0f * (y + 0.5f) / S, r2 = u * u + v * v;
    if (r2 > 0.8f) return 0;
    n[0] = u + bump * sinf(9.0f * u) * cosf(7.0f * v), n[1] = v + bump * cosf(8.0f * u) * sinf(9.0f * v);
    n[2] = sqrtf(1.0f - r2);
    const float len = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (int k = 0; k < 3; k++) n[k] /= len;
    return 1;
}

/* A face of side S whose coarse normals are the cap turned by R, and its model normals at side s:
 * the cap with the bump, unturned. */
static void make(int S, int s, const double R[9], float bump, hd_aligned_face *f, hd_decomposition *d)
{
    memset(f, 0, sizeof *f), memset(d, 0, sizeof *d);
    if (hd_image_alloc(&f->normal, S, S, 3) != HD_OK || hd_image_alloc(&f->mask, S, S, 1) != HD_OK ||
        hd_image_alloc(&d->normal, s, s, 3) != HD_OK)
        exit(1);
    const size_t P = (size_t)S * S, p = (size_t)s * s;
    for (int y = 0; y < S; y++)
        for (int x = 0; x < S; x++) {
            float n[3] = {0, 0, 0}, c[3] = {0, 0, 0};
            const size_t i = (size_t)y * S + x;
            f->mask.data[i] = (float)cap_normal(x, y, S, 0.0f, n);
            if (f->mask.data[i] > 0) turn(R, n, c);
            for (int k = 0; k < 3; k++) f->normal.data[k * P + i] = c[k];
        }
    for (int y = 0; y < s; y++)
        for (int x = 0; x < s; x++) {
            float n[3] = {0, 0, 0};
            cap_normal(x, y, s, bump, n);
            for (int k = 0; k < 3; k++) d->normal.data[k * p + (size_t)y * s + x] = n[k];
        }
}

static void release(hd_aligned_face *f, hd_decomposition *d)
{
    hd_image_free(&f->normal), hd_image_free(&f->mask), hd_image_free(&d->normal);
}

/* The largest angle, in degrees, between d's normals and the cap (with `bump`) turned by R. */
static double worst(const hd_decomposition *d, const double R[9], float bump)
{
    const int s = d->normal.width;
    const size_t p = (size_t)s * s;
    double w = 0;
    for (int y = 0; y < s; y++)
        for (int x = 0; x < s; x++) {
            float n[3], t[3];
            if (!cap_normal(x, y, s, bump, n)) continue;
            turn(R, n, t);
            const size_t i = (size_t)y * s + x;
            double dot = 0;
            for (int k = 0; k < 3; k++) dot += t[k] * d->normal.data[k * p + i];
            const double a = acos(dot > 1 ? 1 : dot < -1 ? -1 : dot) * 180 / M_PI;
            w = a > w ? a : w;
        }
    return w;
}

static void test_best_rotation(void)
{
    double R[9], F[9], S[3][3] = {{0}};
    test_pose_rotation(25, -12, 7, R);
    for (int i = 0; i < 50; i++) {
        const float p[3] = {sinf(i * 1.3f), cosf(i * 0.7f), sinf(i * 0.3f + 1)};
        float c[3];
        turn(R, p, c);
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++) S[a][b] += p[a] * c[b];
    }
    hd_best_rotation(S, F);
    double err = 0;
    for (int k = 0; k < 9; k++) err = fmax(err, fabs(F[k] - R[k]));
    fprintf(stderr, "best rotation: largest element off by %.2g\n", err);
    CHECK(err < 1e-6);
}

static void test_repose(void)
{
    const int S = 48;
    const double yaw = 18, pitch = -11, roll = 6;
    double R[9];
    test_pose_rotation(yaw, pitch, roll, R);
    const double full = acos(0.5 * (R[0] + R[4] + R[8] - 1)) * 180 / M_PI;
    hd_aligned_face f;
    hd_decomposition d;
    float angle = 0;

    /* the whole turn: the coarse normals back, the angle the pose's */
    make(S, S, R, 0.0f, &f, &d);
    CHECK(hd_face_repose(&f, &d, 1.0f, &angle) == HD_OK);
    fprintf(stderr, "repose: turned %.4f degrees (the pose's %.4f); off the coarse by at most %.2g\n", angle, full,
            worst(&d, R, 0.0f));
    CHECK(fabs(angle - full) < 1e-3);
    CHECK(worst(&d, R, 0.0f) < 0.05); /* float normals: acos near 1 resolves about 0.02 degrees */
    release(&f, &d);

    /* half the turn: half the angle, about the same axis (twice gives the whole) */
    make(S, S, R, 0.0f, &f, &d);
    CHECK(hd_face_repose(&f, &d, 0.5f, &angle) == HD_OK);
    CHECK(fabs(angle - 0.5 * full) < 1e-3);
    CHECK(hd_face_repose(&f, &d, 1.0f, &angle) == HD_OK); /* the rest: what is left is the other half */
    CHECK(fabs(angle - 0.5 * full) < 1e-2);
    CHECK(worst(&d, R, 0.0f) < 0.05);
    release(&f, &d);

    /* the model's own local shape is kept: the pose is found through it, and the bump turned */
    make(S, S, R, 0.08f, &f, &d);
    CHECK(hd_face_repose(&f, &d, 1.0f, &angle) == HD_OK);
    fprintf(stderr, "repose with a local shape: turned %.3f degrees (pose %.3f), shape kept within %.3f\n", angle,
            full, worst(&d, R, 0.08f));
    CHECK(fabs(angle - full) < 0.5);
    CHECK(worst(&d, R, 0.08f) < 0.5);
    release(&f, &d);

    /* a texture twice as fine as the model's normals: sampled where they lie */
    make(2 * S, S, R, 0.0f, &f, &d);
    CHECK(hd_face_repose(&f, &d, 1.0f, &angle) == HD_OK);
    fprintf(stderr, "repose at two sizes: turned %.3f degrees (pose %.3f)\n", angle, full);
    CHECK(fabs(angle - full) < 0.5);
    release(&f, &d);

    /* nothing changes (bit for bit): share 0, no mask, bad arguments */
    make(S, S, R, 0.05f, &f, &d);
    hd_image before = {0};
    if (hd_image_alloc(&before, S, S, 3) != HD_OK) exit(1);
    memcpy(before.data, d.normal.data, (size_t)S * S * 3 * sizeof(float));
    CHECK(hd_face_repose(&f, &d, 0.0f, &angle) == HD_OK && angle == 0.0f);
    CHECK(memcmp(before.data, d.normal.data, (size_t)S * S * 3 * sizeof(float)) == 0);
    memset(f.mask.data, 0, (size_t)S * S * sizeof(float));
    CHECK(hd_face_repose(&f, &d, 1.0f, &angle) == HD_OK && angle == 0.0f);
    CHECK(memcmp(before.data, d.normal.data, (size_t)S * S * 3 * sizeof(float)) == 0);
    hd_image_free(&before);
    hd_image_free(&f.mask);
    CHECK(hd_face_repose(&f, &d, 1.0f, NULL) == HD_ERR_ARG);
    CHECK(hd_face_repose(NULL, &d, 1.0f, NULL) == HD_ERR_ARG);
    release(&f, &d);
}

int main(void)
{
    test_best_rotation();
    test_repose();
    return test_summary("test_repose");
}
