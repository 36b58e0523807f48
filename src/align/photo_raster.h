/* photo_raster.h: internal to src/align (and src/warp, which may use align): the similarity fit of
 * the canonical mesh to the landmarks (align_face.c) and the photo-space raster of the landmark
 * triangles (front-facing only, front-most by depth; photo_raster.c), which both the unwarp
 * (occlusion) and the warp back (texel lookup) stand on. */
#ifndef HD_ALIGN_WARP_H
#define HD_ALIGN_WARP_H

#include "hdnet.h"
#include "mesh/mesh.h"

/* Photo-space raster of the landmark triangles over a window of the photo. */
typedef struct hd_photo_raster {
    int x0, y0, width, height; /* window in photo pixels (clipped to the photo) */
    int *tri;                  /* (height, width): triangle under the pixel centre, -1 if none */
    float *bary;               /* (height, width, 3): its barycentric weights */
    float *depth;              /* (height, width): camera-frame depth (toward the viewer) */
} hd_photo_raster;

/* Camera-frame position of landmark i: (x, -y, depth_sign * z). */
static inline void hd_landmark_camera(const float l[3], float depth_sign, float c[3])
{
    c[0] = l[0];
    c[1] = -l[1];
    c[2] = depth_sign * l[2];
}

/* 1 if triangle t of the landmarks faces the camera: counter-clockwise in the camera's (x, y-up)
 * plane, i.e. clockwise in photo coordinates. */
int hd_landmark_tri_front(const hd_mesh *mesh, const float (*landmarks)[3], int t);

/* Rasterises every front-facing landmark triangle over the landmarks' bounding box clipped to
 * the photo (photo_width x photo_height), keeping the largest camera depth at each pixel centre. */
hd_status hd_photo_raster_build(const hd_mesh *mesh, const float (*landmarks)[3], float depth_sign,
                                int photo_width, int photo_height, hd_photo_raster *raster);
void hd_photo_raster_free(hd_photo_raster *raster);

/* Fits c_i ~ scale * R * P_i + t (Horn's quaternion method, least squares over all vertices) of
 * the canonical positions P to the camera-frame landmarks for both depth signs and keeps the
 * better; fills the fit fields of face (scale, rotation, translation, depth_sign, fit_rms). */
hd_status hd_align_fit(const hd_mesh *mesh, hd_aligned_face *face);

/* hd_align_face on a canonical mesh already loaded (the aligner's, hd_aligner_mesh). */
hd_status hd_align_face_on(const hd_mesh *canonical, const hd_image *photo, const float landmarks[HD_FACE_LANDMARKS][3],
                           int size, hd_aligned_face *face);
/* The canonical mesh the aligner loaded at hd_aligner_load. */
const hd_mesh *hd_aligner_mesh(const hd_aligner *aligner);

#endif /* HD_ALIGN_WARP_H */
