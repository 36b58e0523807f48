/* mesh.h: the canonical face mesh (MediaPipe's 468 vertices, UVs with v down, 898 triangles):
 * loading the OBJ, rasterising its UV layout into a texture grid, and vertex normals. The
 * synthetic generator and the photo alignment both stand on this. */
#ifndef HD_MESH_H
#define HD_MESH_H

#include <math.h>
#include "hdnet.h"

typedef struct hd_mesh {
    int nv, nt;
    float *pos; /* (nv, 3): x right, y up, z toward the viewer (cm in the OBJ) */
    float *uv;  /* (nv, 2): u right, v down, in [0, 1] */
    int *tri;   /* (nt, 3): 0-based vertex indices, counter-clockwise seen from the front */
} hd_mesh;

/* Loads an OBJ with v, vt and f lines (vertex i uses vt i). */
hd_status hd_mesh_load_obj(const char *path, hd_mesh *mesh);
/* Loads the canonical mesh shipped with hdnet (found with hd_find_data). */
hd_status hd_mesh_load_canonical(hd_mesh *mesh);
/* The canonical mesh shipped with hdnet, loaded once per process for each file hd_find_data finds
 * (by its real path; a file changed after its first load is not read again) and shared: read-only,
 * never freed, safe to use from any thread. What the calls without an aligner stand on. */
hd_status hd_mesh_canonical(const hd_mesh **mesh);
void hd_mesh_free(hd_mesh *mesh);

/* The closed contours of the face's parts over the 468 landmarks (contours.c; FaceMesh indices, in
 * order around each part, -1 ends each): the eyes' openings, the inner lips, the eyebrows. */
#define HD_CONTOUR_MAX 32
/* Distance from (x, y) to the segment a-b (any 2-D frame: UV, texels). */
static inline float hd_segment_distance(float x, float y, float ax, float ay, float bx, float by)
{
    float dx = bx - ax, dy = by - ay, l2 = dx * dx + dy * dy;
    float t = l2 > 0 ? ((x - ax) * dx + (y - ay) * dy) / l2 : 0;
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    float ex = ax + t * dx - x, ey = ay + t * dy - y;
    return sqrtf(ex * ex + ey * ey);
}
/* Even-odd point-in-polygon test of (x, y) against n vertices (px, py). */
int hd_inside_polygon(const float *px, const float *py, int n, float x, float y);
extern const int hd_contour_right_eye[], hd_contour_left_eye[], hd_contour_inner_lips[], hd_contour_right_brow[],
    hd_contour_left_brow[];
/* The face's outline (FaceMesh's face oval: forehead top 10, round by the right cheek to the chin
 * 152 and back), the edge of the face proper that src/eval's coverage measures outside of. */
extern const int hd_contour_face_oval[];
/* Rasterises contours list[0..count) of the canonical mesh (hd_mesh_canonical) in its UV layout at
 * size x size: 1 at the texel centres inside a contour or within grow_share x size texels of one,
 * 0 elsewhere. */
hd_status hd_mesh_contours_uv(const int *const *list, int count, float grow_share, int size, hd_image *out);

/* The regions a face model does not explain (regions.c), where the relighting change follows the
 * skin around: the eyes (sclera, iris, lids), the inside of the mouth, the eyebrows. Polygons over
 * the 468 landmarks' contours, read in the canonical mesh's UV layout, so one map serves every
 * face. */
/* Rasterises the regions into a size x size texture-space map (1 inside, 0 outside), each
 * polygon grown by HD_REGION_GROW of the texture side. */
#define HD_REGION_GROW 0.012f
hd_status hd_face_regions_uv(int size, hd_image *regions);
/* The weight of each texel in the face's own light fit (hd_face_light), size x size, 1 plane: 1
 * down to the nose tip's row (landmark 1), falling smoothly to lower at the mouth corners' row
 * (landmarks 61 and 291) and lower below. An expression moves the mouth, the cheeks below the
 * nose and the jaw, the light does not: the fit leans on the face above the nose. */
#define HD_FIT_LOWER_FACE 0.25f
hd_status hd_face_fit_weight_uv(int size, float lower, hd_image *weight);
/* The face's own light (face_light.c). hd_face_light_layout: the weight of each texel of a
 * size x size aligned texture in the fit, 1 plane: hd_face_fit_weight_uv (HD_FIT_LOWER_FACE), 0 in
 * the regions the model does not explain (hd_face_regions_uv). hd_face_light_fit: the light of
 * shading on unit normals (npix texels; normal in 3 planes) weighted by layout where mask > 0.5
 * (mask NULL: everywhere; the weights left in weight, npix floats of scratch), pulled toward the
 * lobe fit of the same weighted shading (hd_sh_fit_lobe, written to lobe; with hold_lobe, lobe is
 * read as given) with HD_SOURCE_PRIOR (hd_sh_fit_toward). The relighting rule's source light
 * (hd_face_light) and the training's --light-target face and fit-pair term are this one fit.
 * hd_face_light_weight: the fit's weights alone (the fit-pair term's backward needs them again). */
hd_status hd_face_light_layout(int size, hd_image *layout);
void hd_face_light_weight(const float *layout, const float *mask, int npix, float *weight);
hd_status hd_face_light_fit(const float *normal, const float *shading, const float *layout, const float *mask,
                            int npix, float *weight, float lobe[HD_SH_COEFFS], int hold_lobe,
                            float light[HD_SH_COEFFS]);
/* The light of a reference face (reference_light.c): the target light transfer takes from it. As
 * hd_face_light_fit, but each texel's weight divided by max(n_z, HD_REF_NZ_FLOOR)^2 and the pull
 * toward the lobe fit (of the same weighted shading) HD_REF_PRIOR; weight: npix floats of scratch. */
#define HD_REF_NZ_FLOOR 0.5f
#define HD_REF_PRIOR 0.03f
hd_status hd_reference_light_fit(const float *normal, const float *shading, const float *layout, const float *mask,
                                 int npix, float *weight, float light[HD_SH_COEFFS]);
/* The centres of the two eyes (the means of their contour landmarks), in the landmarks' frame. */
void hd_face_eye_centres(const float (*landmarks)[3], float centres[2][2]);

/* For each texel centre ((x + 0.5) / size, (y + 0.5) / size) of a size x size UV map: the index
 * of the triangle that covers it in UV space (-1 if none) and its barycentric weights. */
typedef struct hd_uv_raster {
    int size;
    int *tri;    /* (size * size) */
    float *bary; /* (size * size, 3) */
} hd_uv_raster;
hd_status hd_mesh_uv_raster(const hd_mesh *mesh, int size, hd_uv_raster *raster);
void hd_uv_raster_free(hd_uv_raster *raster);

/* Area-weighted, unit vertex normals (nv, 3) of positions pos (nv, 3) with the mesh's triangles
 * (outward for counter-clockwise triangles). */
void hd_mesh_vertex_normals(const hd_mesh *mesh, const float *pos, float *normals);

/* The shadows the face casts on itself (cast_shadow.c): for each texel of a size x size UV map, how
 * much of a distant light from `direction` (camera frame, need not be unit) reaches the canonical
 * mesh turned by `rotation` (row-major, the aligned face's): 1 lit, falling to 0 as the ray toward
 * the light passes `softness` cm under the face (0 deepest in shadow); 1 off the mesh. */
hd_status hd_mesh_cast_shadow_uv(const hd_mesh *mesh, const float rotation[9], const float direction[3], int size,
                                 float softness, hd_image *visibility);
/* The camera-frame depth (toward the camera) of the mesh posed as an aligned face is, scale *
 * (rotation p)_z + offset, at each texel of a size x size UV map (0 off the mesh): what `hdnet
 * serve` warps into the photo for its page to cast the same shadows in. */
hd_status hd_mesh_posed_depth_uv(const hd_mesh *mesh, float scale, const float rotation[9], float offset, int size,
                                 hd_image *depth);
#endif /* HD_MESH_H */
