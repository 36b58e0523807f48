/* warp_back.c: from the aligned texture space back into the photo. Each photo pixel centre gets
 * a landmark triangle and barycentrics from the photo raster (align/photo_raster.c: front-facing
 * only, the front-most kept by depth), hence a UV, where the texture is sampled; then the warped
 * face is Poisson-blended into the photo (hd_warp_back_blend). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "align/photo_raster.h"
#include "warp/warp.h"

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

static hd_status warp_back_on(const hd_mesh *mesh, const hd_aligned_face *face, const hd_image *texture,
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

static hd_status warp_back_blend_on(const hd_mesh *mesh, const hd_aligned_face *face, const hd_image *texture,
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

/* ---------------------------------------------------------------- the canonical mesh: the aligner's, or the shared one (hd_mesh_canonical) */

hd_status hd_warp_back(const hd_aligned_face *face, const hd_image *texture, const hd_image *tex_mask,
                       hd_image *warped, hd_image *coverage)
{
    memset(warped, 0, sizeof *warped);
    memset(coverage, 0, sizeof *coverage);
    const hd_mesh *mesh;
    hd_status st = hd_mesh_canonical(&mesh);
    return st ? st : warp_back_on(mesh, face, texture, tex_mask, warped, coverage);
}

hd_status hd_warp_back_blend(const hd_aligned_face *face, const hd_image *texture, hd_warp_mode mode, double tolerance,
                             hd_image *photo, hd_poisson_report *report)
{
    if (report) memset(report, 0, sizeof *report);
    const hd_mesh *mesh;
    hd_status st = hd_mesh_canonical(&mesh);
    return st ? st : warp_back_blend_on(mesh, face, texture, mode, tolerance, photo, report);
}

hd_status hd_aligner_warp_back(const hd_aligner *aligner, const hd_aligned_face *face, const hd_image *texture,
                               const hd_image *tex_mask, hd_image *warped, hd_image *coverage)
{
    return warp_back_on(hd_aligner_mesh(aligner), face, texture, tex_mask, warped, coverage);
}

hd_status hd_aligner_warp_back_blend(const hd_aligner *aligner, const hd_aligned_face *face, const hd_image *texture,
                                     hd_warp_mode mode, double tolerance, hd_image *photo, hd_poisson_report *report)
{
    return warp_back_blend_on(hd_aligner_mesh(aligner), face, texture, mode, tolerance, photo, report);
}
