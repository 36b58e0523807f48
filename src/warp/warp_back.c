/* warp.c: from the aligned texture space back into the photo. The landmark triangles are
 * rasterised in photo space (front-facing only, the front-most kept by depth), each photo pixel
 * centre gets a triangle and barycentrics, hence a UV, where the texture is sampled; then the
 * warped face is Poisson-blended into the photo (hd_warp_back_blend). */
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

/* Nearest-texel value of a 1-channel mask (any side) at texture coordinate (u, v) in [0, 1]. */
static float mask_at(const hd_image *mask, float u, float v)
{
    int x = (int)(u * mask->width), y = (int)(v * mask->height);
    if (x < 0) x = 0;
    if (y < 0) y = 0;
    if (x >= mask->width) x = mask->width - 1;
    if (y >= mask->height) y = mask->height - 1;
    return mask->data[(size_t)y * mask->width + x];
}

/* Warps `texture` into the window (x0, y0, w, h) of the raster: warped (C, h, w) and coverage
 * (1, h, w) allocated here; pixels outside the face are 0 in both. */
static hd_status warp_window(const hd_aligned_face *face, const hd_mesh *mesh, const hd_photo_raster *r,
                             const hd_image *texture, const hd_image *tex_mask, hd_image *warped,
                             hd_image *coverage)
{
    int tw = texture->width, th = texture->height, nc = texture->channels;
    const hd_image *m = tex_mask;
    if (!m && face->mask.data && face->mask.width > 0) m = &face->mask;
    hd_image layout = {0};
    hd_status st = HD_OK;
    if (!m) {
        /* no mask at all: every texel inside the mesh's UV layout counts */
        hd_uv_raster uvr;
        int side = tw > th ? tw : th;
        if (side > 1024) side = 1024; /* read by UV: a finer layout would change nothing */
        if ((st = hd_mesh_uv_raster(mesh, side, &uvr))) return st;
        st = hd_image_alloc(&layout, side, side, 1);
        for (size_t i = 0; !st && i < (size_t)side * side; i++) layout.data[i] = uvr.tri[i] >= 0 ? 1.0f : 0.0f;
        hd_uv_raster_free(&uvr);
        if (st) return st;
        m = &layout;
    }
    if ((st = hd_image_alloc(warped, r->width, r->height, texture->channels))) {
        hd_image_free(&layout);
        return st;
    }
    if ((st = hd_image_alloc(coverage, r->width, r->height, 1))) {
        hd_image_free(warped);
        hd_image_free(&layout);
        return st;
    }
    size_t plane = (size_t)r->width * r->height, tplane = (size_t)tw * th;
#pragma omp parallel for schedule(static)
    for (int y = 0; y < r->height; y++)
        for (int x = 0; x < r->width; x++) {
            size_t i = (size_t)y * r->width + x;
            int t = r->tri[i];
            if (t < 0) continue;
            const float *b = &r->bary[3 * i];
            float u = 0, v = 0;
            for (int k = 0; k < 3; k++) {
                int vi = mesh->tri[3 * t + k];
                u += b[k] * mesh->uv[2 * vi];
                v += b[k] * mesh->uv[2 * vi + 1];
            }
            /* bilinear taps around (u * tw - 0.5, v * th - 0.5), each weighted by its mask */
            float fx = u * tw - 0.5f, fy = v * th - 0.5f;
            int ix = (int)floorf(fx), iy = (int)floorf(fy);
            float ax = fx - ix, ay = fy - iy;
            float wsum = 0, acc[4] = {0, 0, 0, 0};
            for (int dy = 0; dy < 2; dy++)
                for (int dx = 0; dx < 2; dx++) {
                    int sx = ix + dx, sy = iy + dy;
                    if (sx < 0 || sy < 0 || sx >= tw || sy >= th) continue;
                    float w = (dx ? ax : 1 - ax) * (dy ? ay : 1 - ay);
                    if (mask_at(m, (sx + 0.5f) / tw, (sy + 0.5f) / th) <= 0.5f) w = 0;
                    if (w <= 0) continue;
                    wsum += w;
                    for (int c = 0; c < nc && c < 4; c++) acc[c] += w * texture->data[c * tplane + (size_t)sy * tw + sx];
                }
            if (wsum < 0.5f) continue;
            for (int c = 0; c < nc && c < 4; c++) warped->data[c * plane + i] = acc[c] / wsum;
            coverage->data[i] = 1.0f;
        }
    hd_image_free(&layout);
    return HD_OK;
}

static hd_status check_face(const hd_aligned_face *face)
{
    if (face->photo_width <= 0 || face->photo_height <= 0 || face->photo_width > HD_IMAGE_MAX_SIDE ||
        face->photo_height > HD_IMAGE_MAX_SIDE)
        return hd_fail(HD_ERR_ARG, "aligned face: photo size %dx%d out of range", face->photo_width, face->photo_height);
    if (face->depth_sign != 1.0f && face->depth_sign != -1.0f)
        return hd_fail(HD_ERR_ARG, "aligned face: depth_sign must be +1 or -1");
    return HD_OK;
}

static hd_status check_texture(const hd_image *texture, const hd_image *tex_mask)
{
    if (!texture || !texture->data || texture->width < 1 || texture->height < 1 || texture->channels < 1 ||
        texture->channels > 4)
        return hd_fail(HD_ERR_ARG, "warp back: the texture is empty or has more than 4 channels");
    if (tex_mask && (!tex_mask->data || tex_mask->channels != 1 || tex_mask->width < 1 || tex_mask->height < 1))
        return hd_fail(HD_ERR_ARG, "warp back: the texture mask must have 1 channel");
    return HD_OK;
}

hd_status hd_warp_back_on(const hd_mesh *mesh, const hd_aligned_face *face, const hd_image *texture,
                          const hd_image *tex_mask, hd_image *warped, hd_image *coverage)
{
    memset(warped, 0, sizeof *warped);
    memset(coverage, 0, sizeof *coverage);
    hd_status st = check_face(face);
    if (!st) st = check_texture(texture, tex_mask);
    if (st) return st;
    hd_photo_raster r;
    hd_image ww = {0}, cw = {0};
    st = hd_photo_raster_build(mesh, (const float (*)[3])face->landmarks, face->depth_sign,
                               face->photo_width, face->photo_height, &r);
    if (!st && r.width > 0 && r.height > 0) st = warp_window(face, mesh, &r, texture, tex_mask, &ww, &cw);
    if (!st) st = hd_image_alloc(warped, face->photo_width, face->photo_height, texture->channels);
    if (!st) st = hd_image_alloc(coverage, face->photo_width, face->photo_height, 1);
    if (!st && ww.data) {
        size_t plane = (size_t)face->photo_width * face->photo_height, wplane = (size_t)r.width * r.height;
        for (int c = 0; c < texture->channels; c++)
            for (int y = 0; y < r.height; y++)
                memcpy(&warped->data[c * plane + (size_t)(y + r.y0) * face->photo_width + r.x0],
                       &ww.data[c * wplane + (size_t)y * r.width], (size_t)r.width * sizeof(float));
        for (int y = 0; y < r.height; y++)
            memcpy(&coverage->data[(size_t)(y + r.y0) * face->photo_width + r.x0], &cw.data[(size_t)y * r.width],
                   (size_t)r.width * sizeof(float));
    } else if (st) {
        hd_image_free(warped);
        hd_image_free(coverage);
    }
    hd_image_free(&ww);
    hd_image_free(&cw);
    hd_photo_raster_free(&r);
    return st;
}

/* The change a result makes to the face: texture - face->texture, the latter resampled to the
 * texture's size. */
static hd_status texture_change(const hd_aligned_face *face, const hd_image *texture, hd_image *change)
{
    if (!face->texture.data || face->texture.channels != texture->channels)
        return hd_fail(HD_ERR_ARG, "warp back: HD_WARP_CHANGE needs the face's own texture with %d channels",
                       texture->channels);
    hd_status st = hd_image_resize(&face->texture, texture->width, texture->height, change);
    if (st) return st;
    size_t n = (size_t)texture->width * texture->height * texture->channels;
    for (size_t i = 0; i < n; i++) change->data[i] = texture->data[i] - change->data[i];
    return HD_OK;
}

hd_status hd_warp_back_blend_on(const hd_mesh *mesh, const hd_aligned_face *face, const hd_image *texture,
                                hd_warp_mode mode, double tolerance, hd_image *photo, hd_poisson_report *report)
{
    if (report) memset(report, 0, sizeof *report);
    hd_status st = check_face(face);
    if (!st) st = check_texture(texture, NULL);
    if (st) return st;
    if (mode != HD_WARP_REPLACE && mode != HD_WARP_CHANGE) return hd_fail(HD_ERR_ARG, "warp back: unknown mode %d", (int)mode);
    if (!photo || !photo->data || photo->width != face->photo_width || photo->height != face->photo_height)
        return hd_fail(HD_ERR_ARG, "warp back: the photo is %dx%d, the face was found in a %dx%d photo",
                       photo ? photo->width : 0, photo ? photo->height : 0, face->photo_width, face->photo_height);
    if (photo->channels != texture->channels)
        return hd_fail(HD_ERR_ARG, "warp back: the photo has %d channels, the texture %d", photo->channels,
                       texture->channels);
    hd_image change = {0};
    if (mode == HD_WARP_CHANGE) {
        if ((st = texture_change(face, texture, &change))) return st;
        texture = &change;
    }
    hd_photo_raster r;
    hd_image warped = {0}, coverage = {0}, region = {0};
    st = hd_photo_raster_build(mesh, (const float (*)[3])face->landmarks, face->depth_sign,
                               face->photo_width, face->photo_height, &r);
    int empty = !st && (r.width < 3 || r.height < 3); /* the face is (almost) outside the photo */
    if (!st && !empty) st = warp_window(face, mesh, &r, texture, NULL, &warped, &coverage);
    if (!st && !empty) st = hd_image_alloc(&region, r.width, r.height, 1);
    if (!st && !empty) {
        size_t wplane = (size_t)r.width * r.height, pplane = (size_t)photo->width * photo->height;
        if (mode == HD_WARP_CHANGE) /* source = photo + the warped change, where the face is */
            for (int c = 0; c < photo->channels; c++)
                for (int y = 0; y < r.height; y++)
                    for (int x = 0; x < r.width; x++) {
                        size_t i = (size_t)y * r.width + x;
                        if (coverage.data[i] > 0.5f)
                            warped.data[c * wplane + i] +=
                                photo->data[c * pplane + (size_t)(y + r.y0) * photo->width + x + r.x0];
                    }
        /* the region shrunk by one pixel (4-neighbourhood), so that every neighbour of a solved
         * pixel has a warped face value for the guidance field */
        for (int y = 1; y + 1 < r.height; y++)
            for (int x = 1; x + 1 < r.width; x++) {
                size_t i = (size_t)y * r.width + x;
                const float *c = coverage.data;
                region.data[i] = c[i] > 0.5f && c[i - 1] > 0.5f && c[i + 1] > 0.5f && c[i - r.width] > 0.5f &&
                                         c[i + r.width] > 0.5f
                                     ? 1.0f
                                     : 0.0f;
            }
        st = hd_poisson_blend(&warped, &region, r.x0, r.y0, tolerance, photo, report);
    }
    hd_image_free(&change);
    hd_image_free(&warped);
    hd_image_free(&coverage);
    hd_image_free(&region);
    hd_photo_raster_free(&r);
    return st;
}

/* ---------------------------------------------------------------- the canonical mesh: the aligner's, or loaded per call */

hd_status hd_warp_back(const hd_aligned_face *face, const hd_image *texture, const hd_image *tex_mask,
                       hd_image *warped, hd_image *coverage)
{
    memset(warped, 0, sizeof *warped);
    memset(coverage, 0, sizeof *coverage);
    hd_mesh mesh;
    hd_status st = hd_mesh_load_canonical(&mesh);
    if (st) return st;
    st = hd_warp_back_on(&mesh, face, texture, tex_mask, warped, coverage);
    hd_mesh_free(&mesh);
    return st;
}

hd_status hd_warp_back_blend(const hd_aligned_face *face, const hd_image *texture, hd_warp_mode mode, double tolerance,
                             hd_image *photo, hd_poisson_report *report)
{
    if (report) memset(report, 0, sizeof *report);
    hd_mesh mesh;
    hd_status st = hd_mesh_load_canonical(&mesh);
    if (st) return st;
    st = hd_warp_back_blend_on(&mesh, face, texture, mode, tolerance, photo, report);
    hd_mesh_free(&mesh);
    return st;
}

hd_status hd_aligner_warp_back(const hd_aligner *aligner, const hd_aligned_face *face, const hd_image *texture,
                               const hd_image *tex_mask, hd_image *warped, hd_image *coverage)
{
    return hd_warp_back_on(hd_aligner_mesh(aligner), face, texture, tex_mask, warped, coverage);
}

hd_status hd_aligner_warp_back_blend(const hd_aligner *aligner, const hd_aligned_face *face, const hd_image *texture,
                                     hd_warp_mode mode, double tolerance, hd_image *photo, hd_poisson_report *report)
{
    return hd_warp_back_blend_on(hd_aligner_mesh(aligner), face, texture, mode, tolerance, photo, report);
}
