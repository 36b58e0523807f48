/* dataset.h: SPEC section 5 folders: a folder of subjects, each a folder of aligned face images
 * (NAME.png / NAME.jpg) with optional companions (NAME.mask.png, NAME.normal.png, and the ground
 * truth NAME.albedo.png, NAME.normal_gt.png, NAME.shading.png, NAME.light.txt, NAME.camera.txt). */
#ifndef HD_DATASET_H
#define HD_DATASET_H

#include "hdnet.h"

typedef struct hd_sample {
    char *subject;   /* the subject folder's name */
    char *name;      /* NAME */
    char *image;     /* full path of the image */
    /* full paths of the companions, NULL where absent */
    char *mask, *normal, *albedo, *normal_gt, *shading, *light;
    char *camera; /* NAME.camera.txt: the camera effects `hdnet synth --camera` put on the image */
} hd_sample;

typedef struct hd_dataset {
    int count;
    hd_sample *samples;  /* sorted by subject, then name */
    int subject_count;
    int *subject_start;  /* subject s holds samples [subject_start[s], subject_start[s + 1]) */
} hd_dataset;

/* Scans dir. A folder that holds images directly (no subject folders) is one subject. Files that
 * are neither images nor companions are ignored; a companion without its image is reported
 * through `warn` (may be NULL) and skipped. Fails only when dir cannot be read or holds no image. */
hd_status hd_dataset_scan(const char *dir, hd_dataset *ds, void (*warn)(const char *message));
void hd_dataset_free(hd_dataset *ds);
/* Number of unordered pairs of different images within subjects. */
long hd_dataset_pair_count(const hd_dataset *ds);

/* The colour gain g (per channel) that the camera effects of a NAME.camera.txt put on the image
 * (docs/synthetic-data.md, "Camera effects"): the product of its `light_colour r g b` and
 * `white_balance r g b` lines, 1, 1, 1 without them; so image = clamp(g * A * S) before blur, noise
 * and JPEG. The other effects' lines (blur_sigma, noise, jpeg_quality) are checked and skipped. Fails
 * (HD_ERR_FORMAT, naming the file and line) on an unknown effect, a missing or extra number, or a
 * gain that is not a finite number in (0, 10). */
hd_status hd_camera_gain_read(const char *path, float gain[3]);

#endif /* HD_DATASET_H */
