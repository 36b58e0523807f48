/* regions.c: the parts of a face a face model does not explain (eyes, the inside of the mouth,
 * eyebrows), as polygons over the 468 landmarks' contours (MediaPipe's FaceMesh indices). The
 * landmarks are the canonical mesh's vertices, so each polygon has fixed UVs: the regions are
 * rasterised once in the aligned texture space, the same for every face. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "mesh/mesh.h"
#include "apply/apply.h"

/* Closed contours, in order around each region (FaceMesh's eye, inner-lip and eyebrow lines). */
static const int RIGHT_EYE[] = {33, 7, 163, 144, 145, 153, 154, 155, 133, 173, 157, 158, 159, 160, 161, 246, -1};
static const int LEFT_EYE[] = {263, 249, 390, 373, 374, 380, 381, 382, 362, 398, 384, 385, 386, 387, 388, 466, -1};
static const int INNER_LIPS[] = {78,  95,  88,  178, 87,  14,  317, 402, 318, 324,
                                 308, 415, 310, 311, 312, 13,  82,  81,  80,  191, -1};
static const int RIGHT_BROW[] = {46, 53, 52, 65, 55, 107, 66, 105, 63, 70, -1};
static const int LEFT_BROW[] = {276, 283, 282, 295, 285, 336, 296, 334, 293, 300, -1};
static const int *const REGIONS[] = {RIGHT_EYE, LEFT_EYE, INNER_LIPS, RIGHT_BROW, LEFT_BROW};
#define NREGIONS ((int)(sizeof REGIONS / sizeof REGIONS[0]))

static const int *const EYES[2] = {RIGHT_EYE, LEFT_EYE};

/* The mean of a contour's points, each at pts + stride * index (x, y first). */
static void contour_centre(const int *contour, const float *pts, int stride, float centre[2])
{
    double x = 0, y = 0;
    int n = 0;
    for (; contour[n] >= 0; n++) x += pts[(size_t)stride * contour[n]], y += pts[(size_t)stride * contour[n] + 1];
    centre[0] = n ? (float)(x / n) : 0.0f;
    centre[1] = n ? (float)(y / n) : 0.0f;
}

/* Even-odd point-in-polygon test of (x, y) against n vertices (px, py). */
static int inside_polygon(const float *px, const float *py, int n, float x, float y)
{
    int in = 0;
    for (int i = 0, j = n - 1; i < n; j = i++)
        if ((py[i] > y) != (py[j] > y) && x < (px[j] - px[i]) * (y - py[i]) / (py[j] - py[i]) + px[i]) in = !in;
    return in;
}

/* Distance from (x, y) to the segment a-b. */
static float segment_distance(float x, float y, float ax, float ay, float bx, float by)
{
    float dx = bx - ax, dy = by - ay, l2 = dx * dx + dy * dy;
    float t = l2 > 0 ? ((x - ax) * dx + (y - ay) * dy) / l2 : 0;
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    float ex = ax + t * dx - x, ey = ay + t * dy - y;
    return sqrtf(ex * ex + ey * ey);
}

hd_status hd_face_regions_uv(int size, hd_image *regions)
{
    memset(regions, 0, sizeof *regions);
    if (size < 1 || size > HD_IMAGE_MAX_SIDE) return hd_fail(HD_ERR_ARG, "face regions: size %d out of range", size);
    hd_mesh mesh;
    hd_status st = hd_mesh_load_canonical(&mesh);
    if (st != HD_OK) return st;
    st = hd_image_alloc(regions, size, size, 1);
    const float grow = HD_REGION_GROW * size;
    for (int r = 0; r < NREGIONS && st == HD_OK; r++) {
        float px[32], py[32], lo[2] = {1e30f, 1e30f}, hi[2] = {-1e30f, -1e30f};
        int n = 0;
        for (; REGIONS[r][n] >= 0; n++) {
            int v = REGIONS[r][n];
            if (v >= mesh.nv) {
                st = hd_fail(HD_ERR_FORMAT, "face regions: the mesh has %d vertices, landmark %d needed", mesh.nv, v);
                break;
            }
            px[n] = mesh.uv[2 * v] * size; /* texel units; texel (x, y) centred at x + 0.5 */
            py[n] = mesh.uv[2 * v + 1] * size;
            lo[0] = fminf(lo[0], px[n]), hi[0] = fmaxf(hi[0], px[n]);
            lo[1] = fminf(lo[1], py[n]), hi[1] = fmaxf(hi[1], py[n]);
        }
        if (st != HD_OK) break;
        int x0 = (int)floorf(lo[0] - grow), x1 = (int)ceilf(hi[0] + grow);
        int y0 = (int)floorf(lo[1] - grow), y1 = (int)ceilf(hi[1] + grow);
        x0 = x0 < 0 ? 0 : x0, y0 = y0 < 0 ? 0 : y0;
        x1 = x1 >= size ? size - 1 : x1, y1 = y1 >= size ? size - 1 : y1;
        for (int y = y0; y <= y1; y++)
            for (int x = x0; x <= x1; x++) {
                float cx = x + 0.5f, cy = y + 0.5f;
                int in = inside_polygon(px, py, n, cx, cy);
                for (int i = 0, j = n - 1; !in && i < n; j = i++)
                    in = segment_distance(cx, cy, px[j], py[j], px[i], py[i]) <= grow;
                if (in) regions->data[(size_t)y * size + x] = 1.0f;
            }
    }
    hd_mesh_free(&mesh);
    if (st != HD_OK) hd_image_free(regions);
    return st;
}

hd_status hd_face_eye_discs_uv(int size, float inner, float outer, hd_image *weight)
{
    memset(weight, 0, sizeof *weight);
    if (size < 1 || size > HD_IMAGE_MAX_SIDE || !(inner >= 0.0f) || !(outer > inner))
        return hd_fail(HD_ERR_ARG, "eye discs: size %d or radii %g, %g out of range", size, inner, outer);
    hd_mesh mesh;
    hd_status st = hd_mesh_load_canonical(&mesh);
    if (st != HD_OK) return st;
    float c[2][2];
    for (int e = 0; e < 2 && st == HD_OK; e++) {
        for (int n = 0; EYES[e][n] >= 0; n++)
            if (EYES[e][n] >= mesh.nv)
                st = hd_fail(HD_ERR_FORMAT, "eye discs: the mesh has %d vertices, landmark %d needed", mesh.nv, EYES[e][n]);
        if (st != HD_OK) break;
        contour_centre(EYES[e], mesh.uv, 2, c[e]);
        c[e][0] *= size, c[e][1] *= size; /* texel units */
    }
    hd_mesh_free(&mesh);
    if (st == HD_OK) st = hd_image_alloc(weight, size, size, 1);
    if (st != HD_OK) return st;
    const float dist = hypotf(c[1][0] - c[0][0], c[1][1] - c[0][1]), r0 = inner * dist, r1 = outer * dist;
    for (int y = 0; y < size; y++)
        for (int x = 0; x < size; x++) {
            float w = 0;
            for (int e = 0; e < 2; e++) {
                float d = hypotf(x + 0.5f - c[e][0], y + 0.5f - c[e][1]);
                w = fmaxf(w, 1.0f - hd_field_smoothstep((d - r0) / (r1 - r0)));
            }
            weight->data[(size_t)y * size + x] = w;
        }
    return HD_OK;
}

void hd_face_eye_centres(const float (*landmarks)[3], float centres[2][2])
{
    for (int e = 0; e < 2; e++) contour_centre(EYES[e], &landmarks[0][0], 3, centres[e]);
}
