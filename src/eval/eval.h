/* eval.h: measuring a model, a job of the hdnet command (`hdnet eval`) and of the tests, not of the
 * public API (docs/library.md, "What is public"): the SPEC section 7 metrics over a synthetic set
 * (metrics.c), relighting measured on real photos (photo_eval.c) and against the truth on paired
 * synthetic faces (pair_eval.c). */
#ifndef HD_EVAL_H
#define HD_EVAL_H

#include "hdnet.h"

/* SPEC section 7 metrics, pooled over every pixel with mask > 0.5 of a set (the accumulators:
 * src/eval/metrics.h). */
#define HD_EVAL_THRESHOLDS 3 /* normal error thresholds: 20, 25, 30 degrees */
typedef struct hd_eval_row {
    char name[64];
    int has_normal, has_albedo, has_recon, has_shading, has_light; /* columns this row fills */
    double normal_mean, normal_std, normal_under[HD_EVAL_THRESHOLDS]; /* degrees; percent */
    double albedo_mae, albedo_rmse, recon_mae, recon_rmse, shading_mae;
    double albedo_si_mae; /* scale-invariant albedo MAE: each image's albedo times its best scale */
    double light_accuracy; /* percent */
} hd_eval_row;

/* A whole evaluation: the set's ground truth (SPEC section 5 folders with NAME.albedo.png,
 * NAME.normal_gt.png, NAME.shading.pfm or .png, NAME.light.txt, NAME.mask.png) scored against
 * predictions, read from pred_dir in `hdnet decompose`'s layout (PRED/SUBJECT/NAME.albedo.png,
 * .shading.pfm or .shading.png (s/2), .normal.png, .light.txt, .recon.png) or made by `model`
 * (exactly one of the two). Row 0 is the prediction; then the baselines: the coarse normals
 * (NAME.normal.png) as normals; the least-squares light of the true shading on the coarse normals
 * (its light and shading); the per-image mean colour of the input as albedo; with
 * hd_eval_options.true_shading, N-Net on the true shading (below). An image whose files
 * are missing or broken is reported through warn (may be NULL) and skipped. */
#define HD_EVAL_MAX_ROWS 5
typedef struct hd_eval_report {
    int nrows;
    hd_eval_row rows[HD_EVAL_MAX_ROWS];
    long images, skipped;
    int kmeans_k;
    hd_source_light source; /* the prediction's light that the lighting classification scored */
    float repose;           /* the share of the turn to the coarse normals' pose the normals took (0: none) */
    int true_shading;       /* row 4 is N-Net on the true shading (hd_eval_options.true_shading) */
} hd_eval_report;
hd_status hd_eval_run(const char *data_dir, const char *pred_dir, hd_model *model, hd_eval_report *report,
                      void (*warn)(const char *message));
/* hd_eval_run with the prediction's light taken from `source`: HD_SOURCE_LNET (hd_eval_run's) the
 * prediction's own light (L-Net's, or PRED/.../NAME.light.txt); HD_SOURCE_FIT the face's light
 * fitted to the predicted shading on the predicted normals (hd_face_light, over the set's mask),
 * the light the relighting rule takes as the face's own. Only the light column changes. */
hd_status hd_eval_run_light(const char *data_dir, const char *pred_dir, hd_model *model, hd_source_light source,
                            hd_eval_report *report, void (*warn)(const char *message));
/* Everything an evaluation can be told beyond its data: the prediction's light (`source`, as
 * hd_eval_run_light); `repose` (0..1): the predicted normals first turned by that share of the
 * rotation that carries them onto the image's coarse normals (hd_face_repose, what the photo paths
 * do with HD_REPOSE_SHARE; images without coarse normals are scored as they are): where the coarse
 * normals' pose is a landmark fit's, how much the model gains from it (docs/evaluation.md, "The
 * head's pose"); and, with a model,
 * `true_shading`: a fifth row, "N-Net on true shading", whose normals are the model's N-Net run on
 * the set's true shading (hd_model_normals_from_shading; scaled to S-Net's level, then turned as the
 * prediction's) instead of S-Net's: how much of the normals' error is N-Net's own and how much the
 * shading it reads (docs/synthetic-data.md). */
typedef struct hd_eval_options {
    hd_source_light source;
    float repose;
    int true_shading;
} hd_eval_options;
hd_status hd_eval_run_options(const char *data_dir, const char *pred_dir, hd_model *model, const hd_eval_options *o,
                              hd_eval_report *report, void (*warn)(const char *message));
/* The report as JSON: the text (malloc'ed; NULL with the reason set when out of memory), or
 * written to path atomically. */
char *hd_eval_report_json(const hd_eval_report *report);
hd_status hd_eval_report_write_json(const char *path, const hd_eval_report *report);

/* Relighting measured on real photos without ground truth (src/eval/photo_metrics.c, docs/usage.md
 * "Measuring relighting"; the metrics themselves: src/eval/photo_metrics.h). */
/* A whole run over a folder of people (one subfolder each, photos inside; NAME.tem beside a photo
 * gives its pupils as points 0 and 1, else the eye contours' centres): every photo relit under the
 * seven presets (brightness kept) and under its own estimated light, by `rule`. Per photo, the
 * means over the presets of chroma, detail, glow, seam and lum (the face's mean luminance ratio),
 * self (the MAE of the own-light result against the input over the pixels any preset changed),
 * and, on a person's first photo, light (hd_light_difference of the first two photos' lights). */
/* coverage: the sum over the presets of the change on the skin in a ring outside the face's outline
 * over the sum of the change on its cheeks (0: a mask, about 1: the whole head); band: the mean
 * over the presets of the forehead's largest jump of the change over its median step (issue 36;
 * src/eval/photo_coverage.c). */
enum { HD_PM_CHROMA, HD_PM_DETAIL, HD_PM_GLOW, HD_PM_SEAM, HD_PM_SELF, HD_PM_LIGHT, HD_PM_LUM, HD_PM_COVERAGE,
       HD_PM_BAND, HD_PHOTO_METRICS };
enum { HD_PG_ALL, HD_PG_TUNING, HD_PG_HELDOUT };
typedef struct hd_photo_row {
    char name[128];              /* PERSON/NAME */
    int heldout;                 /* the person is in the held-out list */
    int pupils_from_tem;
    double v[HD_PHOTO_METRICS];  /* NAN where not measured */
} hd_photo_row;
typedef struct hd_photo_eval {
    int count, skipped;
    hd_photo_row *rows;
} hd_photo_eval;
const char *hd_photo_metric_name(int metric);
/* heldout_path (may be NULL): a file of held-out person IDs (blank- or line-separated, '#'
 * comments). limit > 0: only the first `limit` people. A photo that fails (unreadable, no face)
 * is reported through warn and skipped. */
/* How the photos are relit: the rule, the face's own light, the guard (<= 0: HD_RATIO_GUARD). */
typedef struct hd_photo_rule {
    hd_relight_rule rule;
    hd_source_light source;
    float guard;
} hd_photo_rule;
hd_status hd_photo_eval_run(const char *dir, hd_model *model, hd_aligner *aligner, const hd_photo_rule *how,
                            const char *heldout_path, int limit, hd_photo_eval *eval, void (*warn)(const char *message));
void hd_photo_eval_free(hd_photo_eval *eval);
/* The median of a metric over a group (HD_PG_*) and the row of its worst photo (-1 if none). */
hd_status hd_photo_eval_summary(const hd_photo_eval *eval, int group, int metric, double *median, int *worst);
/* As JSON, as text (malloc'ed, NULL with the reason set on failure) or written to path atomically. */
char *hd_photo_eval_json(const hd_photo_eval *eval, const hd_photo_rule *how);
hd_status hd_photo_eval_write_json(const char *path, const hd_photo_eval *eval, const hd_photo_rule *how);

/* Relighting against the truth on a paired synthetic set (src/eval/pair_eval.c): image i of each
 * subject relit under the true light of the subject's next image j (cyclically) and compared with
 * image j over both masks (and both true-normal masks), colours clamped to [0, 1]. Rows: the input
 * unchanged; the exact decomposition (true albedo x s(true N, l_j)); the rule with the true
 * normals and light; the model under the ratio rule; the model under the paper's rule (all at
 * the true light's level: HD_BRIGHTNESS_FREE). MAE and RMSE over pixels x channels, PSNR from the
 * pooled MSE, SSIM (Gaussian window of 1.5 pixels, per channel, the mean over masked pixels) as
 * the mean over pairs. */
enum { HD_PAIR_INPUT, HD_PAIR_EXACT, HD_PAIR_EXACT_RATIO, HD_PAIR_MODEL, HD_PAIR_PAPER, HD_PAIR_ROWS };
typedef struct hd_pair_row {
    char name[64];
    double abs_sum, sq_sum, ssim_sum;
    long n, pairs;
    double mae, rmse, psnr, ssim;
} hd_pair_row;
typedef struct hd_pair_report {
    hd_pair_row rows[HD_PAIR_ROWS];
    long pairs, skipped;
} hd_pair_report;
/* how: the model rows' source light and the guard of every ratio row (rule ignored; the exact
 * ratio takes the true light as the source). */
hd_status hd_pair_eval_run(const char *dir, hd_model *model, const hd_photo_rule *how, hd_pair_report *report,
                           void (*warn)(const char *message));
/* As JSON, as text (malloc'ed, NULL with the reason set on failure) or written to path atomically. */
char *hd_pair_report_json(const hd_pair_report *report);
hd_status hd_pair_report_write_json(const char *path, const hd_pair_report *report);

#endif /* HD_EVAL_H */
