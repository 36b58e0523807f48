/* cast_shadow.c: the shadows the face casts on itself under a distant light (the nose on the cheek,
 * the brows on the eyes, the upper lip on the lower), in the canonical mesh's UV layout. The mesh,
 * turned into the camera frame by the head's pose, is rasterised into a height field seen from the
 * camera (its z toward the camera, in the mesh's cm); each texel's point on the mesh is marched
 * toward the light over that field, and the deepest the march passes under the surface says how
 * much of the light the texel still sees (docs/usage.md, "Cast shadows"). Orthographic: a face
 * a metre or more from the camera and a light far away. Also the posed mesh's depth in the same
 * layout, which `hdnet serve` warps into the photo for its page to cast the same shadows. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "mesh/mesh.h"

/* The height field's cell, cm (the canonical face is about 15 cm wide). */
#define SHADOW_CELL 0.08f

static float smoothstep01(float t)
{
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    return t * t * (3 - 2 * t);
}

typedef struct height_field {
    int w, h;
    float x0, y0; /* the camera-frame x, y of cell (0, 0)'s centre */
    float *z;     /* (h, w): the highest z of the mesh over the cell, -INFINITY where none */
    float top;    /* the highest z of all */
} height_field;

/* The mesh's points turned into the camera frame: q_i = rotation p_i (row-major). */
static void turn(const hd_mesh *mesh, const float rotation[9], float *q)
{
    for (int i = 0; i < mesh->nv; i++) {
        const float *p = mesh->pos + 3 * i;
        for (int r = 0; r < 3; r++) q[3 * i + r] = rotation[3 * r] * p[0] + rotation[3 * r + 1] * p[1] + rotation[3 * r + 2] * p[2];
    }
}

/* Rasterises every triangle of the turned mesh q (front- or back-facing) into the highest z over
 * each cell centre. */
static hd_status height_field_build(const hd_mesh *mesh, const float *q, height_field *hf)
{
    float lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (int i = 0; i < mesh->nv; i++)
        for (int a = 0; a < 2; a++) lo[a] = fminf(lo[a], q[3 * i + a]), hi[a] = fmaxf(hi[a], q[3 * i + a]);
    if (!(hi[0] - lo[0] < 1e4f && hi[1] - lo[1] < 1e4f)) return hd_fail(HD_ERR_NUMERIC, "cast shadow: the mesh is not finite");
    hf->w = (int)((hi[0] - lo[0]) / SHADOW_CELL) + 3, hf->h = (int)((hi[1] - lo[1]) / SHADOW_CELL) + 3;
    hf->x0 = lo[0] - SHADOW_CELL, hf->y0 = lo[1] - SHADOW_CELL;
    const size_t n = (size_t)hf->w * hf->h;
    if (!(hf->z = hd_malloc(n * sizeof(float)))) return HD_ERR_NOMEM;
    for (size_t i = 0; i < n; i++) hf->z[i] = -INFINITY;
    hf->top = -INFINITY;
    for (int i = 0; i < mesh->nv; i++) hf->top = fmaxf(hf->top, q[3 * i + 2]);
    for (int t = 0; t < mesh->nt; t++) {
        const float *a = q + 3 * mesh->tri[3 * t], *b = q + 3 * mesh->tri[3 * t + 1], *c = q + 3 * mesh->tri[3 * t + 2];
        const float area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        if (fabsf(area) < 1e-12f) continue;
        const int cx0 = (int)ceilf((fminf(a[0], fminf(b[0], c[0])) - hf->x0) / SHADOW_CELL);
        const int cx1 = (int)floorf((fmaxf(a[0], fmaxf(b[0], c[0])) - hf->x0) / SHADOW_CELL);
        const int cy0 = (int)ceilf((fminf(a[1], fminf(b[1], c[1])) - hf->y0) / SHADOW_CELL);
        const int cy1 = (int)floorf((fmaxf(a[1], fmaxf(b[1], c[1])) - hf->y0) / SHADOW_CELL);
        for (int y = cy0 < 0 ? 0 : cy0; y <= cy1 && y < hf->h; y++)
            for (int x = cx0 < 0 ? 0 : cx0; x <= cx1 && x < hf->w; x++) {
                const float px = hf->x0 + x * SHADOW_CELL, py = hf->y0 + y * SHADOW_CELL;
                /* barycentric weights of (px, py) */
                const float wb = ((px - a[0]) * (c[1] - a[1]) - (py - a[1]) * (c[0] - a[0])) / area;
                const float wc = ((b[0] - a[0]) * (py - a[1]) - (b[1] - a[1]) * (px - a[0])) / area;
                const float wa = 1 - wb - wc;
                if (wa < -1e-5f || wb < -1e-5f || wc < -1e-5f) continue;
                const float z = wa * a[2] + wb * b[2] + wc * c[2];
                float *cell = hf->z + (size_t)y * hf->w + x;
                if (z > *cell) *cell = z;
            }
    }
    return HD_OK;
}

/* The height field at camera-frame (x, y), bilinear over the cells that hold the mesh
 * (-INFINITY off it). */
static float height_at(const height_field *hf, float x, float y)
{
    const float fx = (x - hf->x0) / SHADOW_CELL, fy = (y - hf->y0) / SHADOW_CELL;
    const int ix = (int)floorf(fx), iy = (int)floorf(fy);
    if (ix < 0 || iy < 0 || ix + 1 >= hf->w || iy + 1 >= hf->h) return -INFINITY;
    const float ax = fx - ix, ay = fy - iy;
    const float *z = hf->z + (size_t)iy * hf->w + ix;
    float sum = 0, wsum = 0, top = -INFINITY;
    const float v[4] = {z[0], z[1], z[hf->w], z[hf->w + 1]};
    const float w[4] = {(1 - ax) * (1 - ay), ax * (1 - ay), (1 - ax) * ay, ax * ay};
    for (int k = 0; k < 4; k++)
        if (v[k] > -INFINITY) sum += w[k] * v[k], wsum += w[k], top = fmaxf(top, v[k]);
    return wsum > 0.25f ? sum / wsum : top;
}

/* How much of the light from unit direction d point p (on the mesh) sees: 1 - smoothstep(depth /
 * softness), depth the deepest the ray toward the light passes under the height field. */
static float visible(const height_field *hf, const float p[3], const float d[3], float softness)
{
    const float dxy = sqrtf(d[0] * d[0] + d[1] * d[1]);
    if (dxy < 1e-4f) return 1.0f; /* a light along the camera's axis: the camera's own view */
    /* the point must be the surface the camera sees (not under another part of the face) */
    if (height_at(hf, p[0], p[1]) > p[2] + softness) return 1.0f;
    /* march one cell at a time toward the light, from two cells out (the point's own triangles) */
    const float step = SHADOW_CELL / dxy;
    float depth = 0;
    for (float s = 2 * step;; s += step) {
        const float x = p[0] + s * d[0], y = p[1] + s * d[1], zr = p[2] + s * d[2];
        if (zr > hf->top && d[2] >= 0) break; /* above the whole face, and rising */
        if (x < hf->x0 || y < hf->y0 || x > hf->x0 + hf->w * SHADOW_CELL || y > hf->y0 + hf->h * SHADOW_CELL) break;
        const float zs = height_at(hf, x, y);
        if (zs - zr > depth) depth = zs - zr;
    }
    return 1.0f - smoothstep01(depth / softness);
}

hd_status hd_mesh_cast_shadow_uv(const hd_mesh *mesh, const float rotation[9], const float direction[3], int size,
                                 float softness, hd_image *visibility)
{
    memset(visibility, 0, sizeof *visibility);
    if (!mesh || !mesh->pos || !rotation || !direction) return hd_fail(HD_ERR_ARG, "cast shadow: no mesh, pose or light");
    const float len = sqrtf(direction[0] * direction[0] + direction[1] * direction[1] + direction[2] * direction[2]);
    if (!(len > 1e-6f) || !isfinite(len)) return hd_fail(HD_ERR_ARG, "cast shadow: the light's direction is not a direction");
    for (int k = 0; k < 9; k++)
        if (!isfinite(rotation[k])) return hd_fail(HD_ERR_ARG, "cast shadow: the pose is not finite");
    if (!(softness > 0)) return hd_fail(HD_ERR_ARG, "cast shadow: the softness must be positive");
    const float d[3] = {direction[0] / len, direction[1] / len, direction[2] / len};
    hd_uv_raster raster = {0};
    height_field hf = {0};
    float *q = hd_malloc((size_t)mesh->nv * 3 * sizeof(float));
    hd_status st = q ? HD_OK : HD_ERR_NOMEM;
    if (st == HD_OK) turn(mesh, rotation, q), st = height_field_build(mesh, q, &hf);
    if (st == HD_OK) st = hd_mesh_uv_raster(mesh, size, &raster);
    if (st == HD_OK) st = hd_image_alloc(visibility, size, size, 1);
    const size_t P = (size_t)size * size;
    if (st == HD_OK) {
#pragma omp parallel for schedule(dynamic, 256)
        for (size_t i = 0; i < P; i++) {
            const int t = raster.tri[i];
            float p[3] = {0, 0, 0};
            for (int k = 0; t >= 0 && k < 3; k++)
                for (int a = 0; a < 3; a++) p[a] += raster.bary[3 * i + k] * q[3 * mesh->tri[3 * t + k] + a];
            visibility->data[i] = t < 0 ? 1.0f : visible(&hf, p, d, softness);
        }
    }
    free(q), free(hf.z);
    hd_uv_raster_free(&raster);
    if (st != HD_OK) hd_image_free(visibility);
    return st;
}

hd_status hd_mesh_posed_depth_uv(const hd_mesh *mesh, float scale, const float rotation[9], float offset, int size,
                                 hd_image *depth)
{
    memset(depth, 0, sizeof *depth);
    if (!mesh || !mesh->pos || !rotation || !isfinite(scale) || !isfinite(offset))
        return hd_fail(HD_ERR_ARG, "posed depth: no mesh, or a pose that is not finite");
    hd_uv_raster raster = {0};
    hd_status st = hd_mesh_uv_raster(mesh, size, &raster);
    if (st == HD_OK) st = hd_image_alloc(depth, size, size, 1);
    for (size_t i = 0; st == HD_OK && i < (size_t)size * size; i++) {
        const int t = raster.tri[i];
        float z = 0;
        for (int k = 0; t >= 0 && k < 3; k++) {
            const float *p = mesh->pos + 3 * mesh->tri[3 * t + k];
            z += raster.bary[3 * i + k] * (rotation[6] * p[0] + rotation[7] * p[1] + rotation[8] * p[2]);
        }
        depth->data[i] = t >= 0 ? scale * z + offset : 0.0f;
    }
    hd_uv_raster_free(&raster);
    return st;
}
