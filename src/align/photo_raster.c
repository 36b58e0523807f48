/* photo_raster.c: the photo-space raster of the landmark triangles (photo_raster.h): which
 * triangles face the camera, and for each photo pixel centre inside the landmarks' box the
 * front-most front-facing triangle and its barycentrics. The unwarp (align_face.c: occlusion) and
 * the warp back (src/warp: texel lookup) both stand on it. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "align/photo_raster.h"

int hd_landmark_tri_front(const hd_mesh *mesh, const float (*landmarks)[3], int t)
{
    const float *a = landmarks[mesh->tri[3 * t]], *b = landmarks[mesh->tri[3 * t + 1]],
                *c = landmarks[mesh->tri[3 * t + 2]];
    /* cross_z in (x, y-down) coordinates; counter-clockwise with y up is negative here */
    float cross = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
    return cross < 0.0f;
}

void hd_photo_raster_free(hd_photo_raster *raster)
{
    free(raster->tri);
    free(raster->bary);
    free(raster->depth);
    memset(raster, 0, sizeof *raster);
}

hd_status hd_photo_raster_build(const hd_mesh *mesh, const float (*landmarks)[3], float depth_sign,
                                int photo_width, int photo_height, hd_photo_raster *raster)
{
    memset(raster, 0, sizeof *raster);
    float lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (int i = 0; i < mesh->nv; i++)
        for (int k = 0; k < 2; k++) {
            if (!isfinite(landmarks[i][k]) || !isfinite(landmarks[i][2]))
                return hd_fail(HD_ERR_NUMERIC, "landmark %d is not finite", i);
            lo[k] = fminf(lo[k], landmarks[i][k]);
            hi[k] = fmaxf(hi[k], landmarks[i][k]);
        }
    /* pixels whose centre (x + 0.5) can lie in [lo, hi] */
    double fx0 = floor(lo[0] - 0.5), fy0 = floor(lo[1] - 0.5), fx1 = ceil(hi[0] - 0.5), fy1 = ceil(hi[1] - 0.5);
    int x0 = fx0 < 0 ? 0 : fx0 > photo_width ? photo_width : (int)fx0;
    int y0 = fy0 < 0 ? 0 : fy0 > photo_height ? photo_height : (int)fy0;
    int x1 = fx1 >= photo_width ? photo_width - 1 : fx1 < -1 ? -1 : (int)fx1;
    int y1 = fy1 >= photo_height ? photo_height - 1 : fy1 < -1 ? -1 : (int)fy1;
    raster->x0 = x0;
    raster->y0 = y0;
    raster->width = x1 >= x0 ? x1 - x0 + 1 : 0;
    raster->height = y1 >= y0 ? y1 - y0 + 1 : 0;
    size_t n = (size_t)raster->width * (size_t)raster->height, n3;
    if (!hd_mul_size(n, 3, &n3)) return hd_fail(HD_ERR_RANGE, "photo raster too large");
    raster->tri = hd_malloc((n ? n : 1) * sizeof *raster->tri);
    raster->bary = hd_malloc((n3 ? n3 : 1) * sizeof *raster->bary);
    raster->depth = hd_malloc((n ? n : 1) * sizeof *raster->depth);
    if (!raster->tri || !raster->bary || !raster->depth) {
        hd_photo_raster_free(raster);
        return HD_ERR_NOMEM;
    }
    for (size_t i = 0; i < n; i++) {
        raster->tri[i] = -1;
        raster->depth[i] = -INFINITY;
    }
    for (int t = 0; t < mesh->nt; t++) {
        if (!hd_landmark_tri_front(mesh, landmarks, t)) continue;
        const float *a = landmarks[mesh->tri[3 * t]], *b = landmarks[mesh->tri[3 * t + 1]],
                    *c = landmarks[mesh->tri[3 * t + 2]];
        /* barycentrics from the edge functions: w_a = cross(b - p, c - p) / cross(b - a, c - a) */
        double area = (double)(b[0] - a[0]) * (c[1] - a[1]) - (double)(b[1] - a[1]) * (c[0] - a[0]);
        if (fabs(area) < 1e-12) continue;
        float tlo_x = fminf(a[0], fminf(b[0], c[0])), thi_x = fmaxf(a[0], fmaxf(b[0], c[0]));
        float tlo_y = fminf(a[1], fminf(b[1], c[1])), thi_y = fmaxf(a[1], fmaxf(b[1], c[1]));
        /* clamped to the window in double before the conversion (landmarks may be far off) */
        int px0 = (int)fmax(floor(tlo_x - 0.5), x0), px1 = (int)fmin(ceil(thi_x - 0.5), x1);
        int py0 = (int)fmax(floor(tlo_y - 0.5), y0), py1 = (int)fmin(ceil(thi_y - 0.5), y1);
        float za = depth_sign * a[2], zb = depth_sign * b[2], zc = depth_sign * c[2];
        for (int y = py0; y <= py1; y++)
            for (int x = px0; x <= px1; x++) {
                double px = x + 0.5, py = y + 0.5;
                double wa = ((b[0] - px) * (c[1] - py) - (b[1] - py) * (c[0] - px)) / area;
                double wb = ((c[0] - px) * (a[1] - py) - (c[1] - py) * (a[0] - px)) / area;
                double wc = 1.0 - wa - wb;
                const double eps = -1e-7; /* shared edges: both sides count, no cracks */
                if (wa < eps || wb < eps || wc < eps) continue;
                float z = (float)(wa * za + wb * zb + wc * zc);
                size_t i = (size_t)(y - y0) * (size_t)raster->width + (size_t)(x - x0);
                if (z <= raster->depth[i]) continue;
                raster->depth[i] = z;
                raster->tri[i] = t;
                raster->bary[3 * i] = (float)wa;
                raster->bary[3 * i + 1] = (float)wb;
                raster->bary[3 * i + 2] = (float)wc;
            }
    }
    return HD_OK;
}
