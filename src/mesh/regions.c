/* regions.c: the parts of a face a face model does not explain (eyes, the inside of the mouth,
 * eyebrows), as polygons over the 468 landmarks' contours (MediaPipe's FaceMesh indices). The
 * landmarks are the canonical mesh's vertices, so each polygon has fixed UVs: the regions are
 * rasterised once in the aligned texture space, the same for every face. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "mesh/mesh.h"

static const int *const REGIONS[] = {hd_contour_right_eye, hd_contour_left_eye, hd_contour_inner_lips,
                                     hd_contour_right_brow, hd_contour_left_brow};
#define NREGIONS ((int)(sizeof REGIONS / sizeof REGIONS[0]))

/* 0 below 0, 1 above 1, a cubic between with zero slope at both ends. */
static float smoothstep(float t) { return t <= 0 ? 0 : t >= 1 ? 1 : t * t * (3 - 2 * t); }

static const int *const EYES[2] = {hd_contour_right_eye, hd_contour_left_eye};

/* The mean of a contour's points, each at pts + stride * index (x, y first). */
static void contour_centre(const int *contour, const float *pts, int stride, float centre[2])
{
    double x = 0, y = 0;
    int n = 0;
    for (; contour[n] >= 0; n++) x += pts[(size_t)stride * contour[n]], y += pts[(size_t)stride * contour[n] + 1];
    centre[0] = n ? (float)(x / n) : 0.0f;
    centre[1] = n ? (float)(y / n) : 0.0f;
}

hd_status hd_face_regions_uv(int size, hd_image *regions)
{
    return hd_mesh_contours_uv(REGIONS, NREGIONS, HD_REGION_GROW, size, regions);
}

hd_status hd_face_fit_weight_uv(int size, float lower, hd_image *weight)
{
    enum { NOSE_TIP = 1, MOUTH_RIGHT = 61, MOUTH_LEFT = 291 };
    memset(weight, 0, sizeof *weight);
    if (size < 1 || size > HD_IMAGE_MAX_SIDE || !(lower >= 0.0f && lower <= 1.0f))
        return hd_fail(HD_ERR_ARG, "fit weight: size %d or lower-face weight %g out of range", size, lower);
    const hd_mesh *mesh;
    hd_status st = hd_mesh_canonical(&mesh);
    if (st != HD_OK) return st;
    if (mesh->nv <= MOUTH_LEFT)
        return hd_fail(HD_ERR_FORMAT, "fit weight: the mesh has %d vertices, landmark %d needed", mesh->nv, MOUTH_LEFT);
    const float top = mesh->uv[2 * NOSE_TIP + 1] * size,
                bottom = 0.5f * (mesh->uv[2 * MOUTH_RIGHT + 1] + mesh->uv[2 * MOUTH_LEFT + 1]) * size;
    if (!(bottom > top)) return hd_fail(HD_ERR_FORMAT, "fit weight: the mouth corners are not below the nose tip");
    if ((st = hd_image_alloc(weight, size, size, 1)) != HD_OK) return st;
    for (int y = 0; y < size; y++) {
        const float t = smoothstep((y + 0.5f - top) / (bottom - top)), w = 1.0f - t + t * lower;
        for (int x = 0; x < size; x++) weight->data[(size_t)y * size + x] = w;
    }
    return HD_OK;
}

void hd_face_eye_centres(const float (*landmarks)[3], float centres[2][2])
{
    for (int e = 0; e < 2; e++) contour_centre(EYES[e], &landmarks[0][0], 3, centres[e]);
}
