/* contours.c: the closed contours of the face's parts over the 468 landmarks (MediaPipe's FaceMesh
 * indices: the eyes, the inner lips, the eyebrows, the face's outline) and their rasterisation in the canonical mesh's
 * UV layout, the same for every aligned face. What src/apply's face regions and src/model's white
 * balance from the eyes stand on. */
#include <math.h>
#include <string.h>
#include "core/core.h"
#include "mesh/mesh.h"

/* Closed contours, in order around each region (FaceMesh's eye, inner-lip and eyebrow lines). */
const int hd_contour_right_eye[] = {33, 7, 163, 144, 145, 153, 154, 155, 133, 173, 157, 158, 159, 160, 161, 246, -1};
const int hd_contour_left_eye[] = {263, 249, 390, 373, 374, 380, 381, 382, 362, 398, 384, 385, 386, 387, 388, 466, -1};
const int hd_contour_inner_lips[] = {78,  95,  88,  178, 87,  14,  317, 402, 318, 324,
                                     308, 415, 310, 311, 312, 13,  82,  81,  80,  191, -1};
const int hd_contour_right_brow[] = {46, 53, 52, 65, 55, 107, 66, 105, 63, 70, -1};
const int hd_contour_left_brow[] = {276, 283, 282, 295, 285, 336, 296, 334, 293, 300, -1};
const int hd_contour_face_oval[] = {10,  338, 297, 332, 284, 251, 389, 356, 454, 323, 361, 288,
                                    397, 365, 379, 378, 400, 377, 152, 148, 176, 149, 150, 136,
                                    172, 58,  132, 93,  234, 127, 162, 21,  54,  103, 67,  109, -1};

/* (mesh.h) */
int hd_inside_polygon(const float *px, const float *py, int n, float x, float y)
{
    int in = 0;
    for (int i = 0, j = n - 1; i < n; j = i++)
        if ((py[i] > y) != (py[j] > y) && x < (px[j] - px[i]) * (y - py[i]) / (py[j] - py[i]) + px[i]) in = !in;
    return in;
}

/* (mesh.h) */
hd_status hd_mesh_contours_uv(const int *const *list, int count, float grow_share, int size, hd_image *regions)
{
    memset(regions, 0, sizeof *regions);
    if (size < 1 || size > HD_IMAGE_MAX_SIDE) return hd_fail(HD_ERR_ARG, "face regions: size %d out of range", size);
    const hd_mesh *mesh;
    hd_status st = hd_mesh_canonical(&mesh);
    if (st != HD_OK) return st;
    st = hd_image_alloc(regions, size, size, 1);
    const float grow = grow_share * size;
    for (int r = 0; r < count && st == HD_OK; r++) {
        float px[HD_CONTOUR_MAX], py[HD_CONTOUR_MAX], lo[2] = {1e30f, 1e30f}, hi[2] = {-1e30f, -1e30f};
        int n = 0;
        for (; list[r][n] >= 0 && n < HD_CONTOUR_MAX; n++) {
            int v = list[r][n];
            if (v >= mesh->nv) {
                st = hd_fail(HD_ERR_FORMAT, "face regions: the mesh has %d vertices, landmark %d needed", mesh->nv, v);
                break;
            }
            px[n] = mesh->uv[2 * v] * size; /* texel units; texel (x, y) centred at x + 0.5 */
            py[n] = mesh->uv[2 * v + 1] * size;
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
                int in = hd_inside_polygon(px, py, n, cx, cy);
                for (int i = 0, j = n - 1; !in && i < n; j = i++)
                    in = hd_segment_distance(cx, cy, px[j], py[j], px[i], py[i]) <= grow;
                if (in) regions->data[(size_t)y * size + x] = 1.0f;
            }
    }
    if (st != HD_OK) hd_image_free(regions);
    return st;
}

