/* multilight.h: `hdnet eval --multilight` (multilight.c, docs/evaluation.md): relighting, light
 * transfer, the light estimate and the normals measured against real photographs of one face
 * under many known point lights (the layout of the Extended Yale Face Database B: a lights.csv
 * and one folder per subject), with photometric stereo computed here as the real normals and as a
 * bound. Internal to the tool (hdnet_tool.h). */
#ifndef HD_MULTILIGHT_H
#define HD_MULTILIGHT_H

#include "hdnet.h"

/* ---- the set */
typedef struct hd_ml_row {
    char *file;    /* relative to the set's folder */
    char *subject;
    float az, el;  /* degrees, the set's convention: az > 0 lights the image's LEFT side */
} hd_ml_row;
typedef struct hd_ml_set {
    char *dir;
    hd_ml_row *rows;
    int count;
} hd_ml_set;
/* Reads DIR/lights.csv (header "file,subject,azimuth_deg,elevation_deg", then one row a photo).
 * Errors name the file and line: a wrong header or column count, a number that is not one or out of
 * range (|az| <= 180, |el| <= 90), an absolute file name or one with "..", an empty subject. */
hd_status hd_ml_set_read(const char *dir, hd_ml_set *set);
void hd_ml_set_free(hd_ml_set *set);

/* The set's light direction in hdnet's camera frame (x image right, y up, z toward the camera):
 * (-sin az cos el, sin el, cos az cos el). */
void hd_ml_direction(float az, float el, float d[3]);

/* ---- photometric stereo (Lambertian, one distant light per photo, no ambient) */
/* Per pixel, the normal equations of b = albedo * n over the photos where the pixel is lit and
 * not clipped (HD_PS_DARK < I < HD_PS_BRIGHT): A = sum l l^T (6 numbers), r = sum I l (3). */
#define HD_PS_DARK 0.03f
#define HD_PS_BRIGHT 0.97f
typedef struct hd_ps {
    int width, height;
    float *sums; /* 9 per pixel: A00 A01 A02 A11 A12 A22 r0 r1 r2 */
} hd_ps;
/* n photos (1 channel each, width x height, values 0..1) under lights from dirs (unit, camera frame). */
hd_status hd_ps_build(const hd_image *photos, const float (*dirs)[3], int n, hd_ps *ps);
void hd_ps_free(hd_ps *ps);
/* b at pixel p, solved from the sums less one photo's share (leave: that photo's value at p and its
 * light; NULL: all photos). Returns 0 when the pixel has too few lit photos for a stable answer. */
int hd_ps_solve(const hd_ps *ps, size_t p, const float *leave_value, const float leave_dir[3], float b[3]);

/* The scale-invariant mean squared error x 1000 of out against truth (1 channel each, P values)
 * over mask > 0.5: the best gain of out against truth applied first. NAN with no pixel. */
double hd_ml_si_mse(const float *out, const float *truth, const float *mask, size_t P);

/* ---- the evaluation */
#define HD_ML_MAX_LIGHTS 64
#define HD_ML_MAX_MISSED 32
enum { HD_ML_INPUT, HD_ML_TRANSFER, HD_ML_RELIGHT, HD_ML_PS, HD_ML_ROWS };
typedef struct hd_ml_options {
    int nlights;                     /* the target lights (set convention); 0: the default twelve */
    float az[HD_ML_MAX_LIGHTS], el[HD_ML_MAX_LIGHTS];
    int refs;                        /* references per light for the transfer (0: 3) */
    int limit;                       /* the first N subjects (0: all) */
    const char *sheets;              /* a folder for one sheet per subject, or NULL */
    hd_relight_rule rule;
    hd_source_light source;
    float guard;
    hd_brightness brightness;        /* of the relight and transfer rows (HD_BRIGHTNESS_KEEP: `hdnet relight`'s) */
} hd_ml_options;
typedef struct hd_ml_stat {
    double mean, median;
    long n;
} hd_ml_stat;
/* One subject's means: each row over its lights (and references), its normals' mean angle, the
 * light estimated from its target photos against the truth; n 0 where it has none. */
typedef struct hd_ml_subject {
    char name[64];
    hd_ml_stat rows[HD_ML_ROWS];
    hd_ml_stat normals, light_error;
} hd_ml_subject;
typedef struct hd_ml_report {
    int nlights;
    float az[HD_ML_MAX_LIGHTS], el[HD_ML_MAX_LIGHTS];
    hd_ml_stat rows[HD_ML_ROWS];                    /* over every (subject, light[, reference]) */
    hd_ml_stat per_light[HD_ML_ROWS][HD_ML_MAX_LIGHTS];
    hd_ml_stat normals, normals_flat, normals_coarse; /* degrees, a subject's mean over its face */
    hd_ml_stat light_error;                         /* degrees, estimate-light against the truth */
    int subjects, sources_missed, refs_missed, photos_absent, photos_dark;
    char missed[HD_ML_MAX_MISSED][64];              /* the first photos whose face was not found */
    int nmissed;
    hd_ml_subject *per_subject;                     /* each subject's means (allocated; hd_ml_report_free) */
    int nper_subject;
} hd_ml_report;
void hd_ml_report_free(hd_ml_report *report);
/* Scores model on the set in dir (the report freed with hd_ml_report_free, also on failure). warn
 * (may be NULL) hears what is skipped, progress (may be NULL) each step done (done of total: the
 * lights of a subject's target photos estimated, then a subject scored). */
hd_status hd_ml_run(const char *dir, hd_model *model, hd_aligner *aligner, const hd_ml_options *options,
                    hd_ml_report *report, void (*warn)(const char *message),
                    void (*progress)(int done, int total, const char *subject));
/* A row's name in the table ("input unchanged", ...). */
const char *hd_ml_row_name(int row);
/* The default target lights: twelve within 70 degrees of the camera (docs/evaluation.md). */
int hd_ml_default_lights(float *az, float *el, int max);
/* As JSON (malloc'ed; NULL with the reason set) or written to path atomically. */
char *hd_ml_report_json(const hd_ml_report *report);
hd_status hd_ml_report_write_json(const char *path, const hd_ml_report *report);

#endif /* HD_MULTILIGHT_H */
