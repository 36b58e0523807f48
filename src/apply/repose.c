/* repose.c: the model's normals of a face in a photo turned to the landmark fit's pose (issue 35;
 * docs/usage.md, "The head's pose"). The network sees the face unwarped into the texture space,
 * where the head's pose is gone but for what the shading shows of it: on real photos its normals
 * carry about 40 % of the pitch the landmark fit finds (docs/evaluation.md). The coarse normals are
 * the canonical mesh in the fit's pose; the rotation that best carries the model's normals onto
 * them over the face's mask (hd_best_rotation, Horn's quaternions) is the pose the model missed.
 * Turning its normals by a share of it keeps their local shape and moves their pose toward the
 * fit's: the whole of it where the fit's pose is exact (synthetic faces turned up to 20 degrees,
 * the fit's pose 3 degrees off: 13.42 -> 9.64 degrees from the truth), HD_REPOSE_SHARE of it on
 * real photos, where the fit's pose is no better than the model's (docs/evaluation.md). */
#include <math.h>
#include <stdlib.h>
#include "core/core.h"
#include "apply/apply.h"
#include "align/align.h"

/* R's angle of rotation in degrees. */
static double rotation_angle(const double R[9])
{
    const double c = 0.5 * (R[0] + R[4] + R[8] - 1.0);
    return acos(c < -1 ? -1 : c > 1 ? 1 : c) * 180.0 / M_PI;
}

/* R scaled to `share` of its angle about the same axis (Rodrigues). */
static void rotation_share(double R[9], double share)
{
    const double angle = rotation_angle(R) * M_PI / 180.0;
    double axis[3] = {R[7] - R[5], R[2] - R[6], R[3] - R[1]};
    const double len = sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
    if (!(len > 1e-12)) return; /* no turn (or a half turn, which no face needs): left as it is */
    for (int k = 0; k < 3; k++) axis[k] /= len;
    const double a = share * angle, c = cos(a), s = sin(a), t = 1 - c;
    const double x = axis[0], y = axis[1], z = axis[2];
    const double M[9] = {t * x * x + c,     t * x * y - s * z, t * x * z + s * y,
                         t * x * y + s * z, t * y * y + c,     t * y * z - s * x,
                         t * x * z - s * y, t * y * z + s * x, t * z * z + c};
    for (int k = 0; k < 9; k++) R[k] = M[k];
}

hd_status hd_face_repose(const hd_aligned_face *f, hd_decomposition *d, float share, float *angle_deg)
{
    if (angle_deg) *angle_deg = 0.0f;
    if (!f || !d || !d->normal.data || d->normal.channels != 3 || !f->normal.data || f->normal.channels != 3 ||
        !f->mask.data || f->mask.width != f->normal.width || f->mask.height != f->normal.height)
        return hd_fail(HD_ERR_ARG, "repose: the face's coarse normals and mask and the model's normals are needed");
    if (!(share > 0.0f)) return HD_OK;
    const int w = d->normal.width, h = d->normal.height, W = f->normal.width, H = f->normal.height;
    const size_t n = (size_t)w * h, N = (size_t)W * H;
    const float *nd = d->normal.data, *nc = f->normal.data;
    double S[3][3] = {{0}};
    size_t used = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            /* the coarse texel under the model's (the texture may be finer than the model's input) */
            const int X = (int)((x + 0.5) * W / w), Y = (int)((y + 0.5) * H / h);
            const size_t i = (size_t)y * w + x, I = (size_t)(Y < H ? Y : H - 1) * W + (size_t)(X < W ? X : W - 1);
            if (!(f->mask.data[I] > 0.5f)) continue;
            const float p[3] = {nd[i], nd[n + i], nd[2 * n + i]}, c[3] = {nc[I], nc[N + I], nc[2 * N + I]};
            if (!isfinite(p[0] + p[1] + p[2] + c[0] + c[1] + c[2])) continue;
            for (int a = 0; a < 3; a++)
                for (int b = 0; b < 3; b++) S[a][b] += (double)p[a] * c[b];
            used++;
        }
    if (used < 3) return HD_OK; /* nothing to fit on: the normals stay */
    double R[9];
    hd_best_rotation(S, R);
    rotation_share(R, share);
    if (angle_deg) *angle_deg = (float)rotation_angle(R);
    for (size_t i = 0; i < n; i++) {
        const float p[3] = {nd[i], nd[n + i], nd[2 * n + i]};
        for (int k = 0; k < 3; k++)
            d->normal.data[(size_t)k * n + i] = (float)(R[3 * k] * p[0] + R[3 * k + 1] * p[1] + R[3 * k + 2] * p[2]);
    }
    return HD_OK;
}

hd_status hd_face_decompose(hd_model *model, const hd_aligned_face *f, hd_decomposition *d)
{
    hd_status st = hd_model_decompose(model, &f->texture, 1, d);
    if (st == HD_OK && (st = hd_face_repose(f, d, HD_REPOSE_SHARE, NULL)) != HD_OK) hd_decomposition_free(d);
    return st;
}
