/* synth.h: the synthetic-face generator (docs/synthetic-data.md), a job of the hdnet command
 * (`hdnet synth`) and of the tests, not of the public API (docs/library.md, "What is public").
 * Its files share synth_internal.h beyond this. */
#ifndef HD_SYNTH_H
#define HD_SYNTH_H

#include "hdnet.h"
#include "io/image_io.h" /* hd_png_effort */

/* A generator of faces with full ground truth, rendered straight into the aligned texture space
 * (docs/synthetic-data.md). Everything is a pure function of (seed, subject, image): the same
 * set comes out whatever the thread count. */
typedef struct hd_synth hd_synth;                 /* per texture size: mesh, UV raster, region maps */
typedef struct hd_synth_subject hd_synth_subject; /* one identity: shape, fine detail, albedo */

typedef struct hd_synth_face {
    hd_image image;     /* 3: albedo * shading, clamped to [0, 1]; 0 outside the mask */
    hd_image mask;      /* 1: 1 on visible face texels, else 0 */
    hd_image normal;    /* 3: coarse normals (the canonical mesh in the image's pose, with the fit error) */
    hd_image albedo;    /* 3: ground-truth albedo in [0, 1] */
    hd_image normal_gt; /* 3: ground-truth unit normals (identity shape + fine detail, posed) */
    hd_image shading;   /* 1: ground-truth shading s(normal_gt, light), not clamped */
    float light[HD_SH_COEFFS];
    float yaw_deg, pitch_deg, roll_deg; /* the head's pose */
    float coarse_yaw_deg, coarse_pitch_deg, coarse_roll_deg; /* the pose of the coarse normals' fit */
} hd_synth_face;

hd_status hd_synth_create(int size, hd_synth **synth);
void hd_synth_free(hd_synth *synth);
int hd_synth_size(const hd_synth *synth);
/* The identity of subject `subject` for this seed (deterministic). */
hd_status hd_synth_subject_make(const hd_synth *synth, uint64_t seed, int subject, hd_synth_subject **out);
void hd_synth_subject_free(hd_synth_subject *subject);
/* Image `image` of a subject: its own light and (with pose_jitter_deg > 0) pose, drawn from the
 * stream (seed, subject, image). The coarse normals model a 3DMM fit: the canonical mesh in the
 * image's pose (coarse_error_deg 0), or with a random zero-mean fit error of size E =
 * coarse_error_deg: yaw, pitch and roll off by E/2 (standard deviation), the mesh deformed like a
 * random identity, and a smooth tilt field of E RMS (docs/synthetic-data.md).
 * `out` must be zero-initialised ({0}) or hold the images of an earlier call, whose buffers are
 * then reused; free it with hd_synth_face_free. */
#define HD_SYNTH_COARSE_ERROR_DEFAULT 20.0f /* hdnet synth's default: about 23 degrees of error */
#define HD_SYNTH_COARSE_ERROR_MAX 40.0f
hd_status hd_synth_render(const hd_synth *synth, const hd_synth_subject *subject, int image,
                          float pose_jitter_deg, float coarse_error_deg, hd_synth_face *out);
/* The same with the fit's pose error given on its own: yaw, pitch and roll off by coarse_pose_deg
 * (standard deviation; a landmark fit's pose is better than E/2), or by E/2 where it is <= 0;
 * the shape and tilt errors stay E's. hd_synth_render is this with 0. */
hd_status hd_synth_render_fit(const hd_synth *synth, const hd_synth_subject *subject, int image,
                              float pose_jitter_deg, float coarse_error_deg, float coarse_pose_deg,
                              hd_synth_face *out);
void hd_synth_face_free(hd_synth_face *face);
/* Writes the SPEC section 5 files of one face as dir/NAME.png, NAME.mask.png, NAME.normal.png,
 * NAME.albedo.png, NAME.normal_gt.png, NAME.shading.png (16 bit, s/2), NAME.shading.pfm and
 * NAME.light.txt (each atomically). */
hd_status hd_synth_face_write(const char *dir, const char *name, const hd_synth_face *face);
/* The same with the PNGs at a chosen effort (hd_synth_face_write: HD_PNG_FAST). */
hd_status hd_synth_face_write_effort(const char *dir, const char *name, const hd_synth_face *face,
                                     hd_png_effort effort);

/* Camera effects on a rendered face's image (docs/synthetic-data.md), the ground truth untouched:
 * a coloured light (image = clamp(A s gain), a warm or cool tint of up to 30 %), defocus blur
 * (Gaussian, sigma 0.3-1.5 texels, normalised inside the mask), sensor noise (read noise
 * 0.003-0.02 plus shot noise), the camera's white balance (another tint of up to 30 %) and JPEG
 * at quality 40-95, in that order; each enabled effect applies with `probability`, its draws from
 * the image's stream (seed, subject, image), the same whichever effects are enabled. */
enum {
    HD_SYNTH_CAMERA_LIGHT_COLOUR = 1,
    HD_SYNTH_CAMERA_BLUR = 2,
    HD_SYNTH_CAMERA_NOISE = 4,
    HD_SYNTH_CAMERA_WHITE_BALANCE = 8,
    HD_SYNTH_CAMERA_JPEG = 16,
    HD_SYNTH_CAMERA_ALL = 31
};
typedef struct hd_synth_camera {
    float probability; /* of each enabled effect, [0, 1]; 0: none */
    unsigned effects;  /* HD_SYNTH_CAMERA_* flags */
} hd_synth_camera;
/* What was applied to one image (applied: flags; the parameters of those applied). */
typedef struct hd_synth_camera_record {
    unsigned applied;
    float light_gain[3], blur_sigma, noise_read, noise_shot, wb_gain[3];
    int jpeg_quality;
} hd_synth_camera_record;
/* Applies the effects to face->image after hd_synth_render of the same (subject, image); rec may be NULL. */
hd_status hd_synth_camera_apply(hd_synth_face *face, const hd_synth_camera *camera, uint64_t seed, int subject,
                                int image, hd_synth_camera_record *rec);

typedef struct hd_synth_options {
    int subjects, per_subject, size;
    uint64_t seed;
    float pose_jitter_deg;  /* maximum yaw, pitch and roll, degrees (0: frontal) */
    float coarse_error_deg; /* the coarse normals' fit error (hd_synth_render); 0: exact pose, no shape error */
    int png_store;          /* 0: the PNGs at HD_PNG_FAST; 1: HD_PNG_STORE (uncompressed: faster, larger) */
    hd_synth_camera camera; /* camera effects on the images (probability 0: none) */
    float coarse_pose_deg;  /* the fit's pose error, degrees (hd_synth_render_fit); 0: coarse_error_deg / 2 */
} hd_synth_options;
/* Called now and then with the number of images written (may be NULL). */
typedef void (*hd_synth_progress_fn)(void *ctx, long done, long total);
/* Writes a whole set: out/subject_XXXX/YYYY.* for every subject and image, plus out/preview.sheet.png
 * (a sheet of the first subjects). Parallel over images with OpenMP (hd_set_threads). */
hd_status hd_synth_write_set(const char *out, const hd_synth_options *options,
                             hd_synth_progress_fn progress, void *ctx);

#endif /* HD_SYNTH_H */
