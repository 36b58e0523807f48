/* metrics.c: SPEC section 7, the paper's evaluation: normal angular error (mean, std, share under
 * 20/25/30 degrees), albedo MAE/RMSE, reconstruction MAE/RMSE (A*S against the input), shading MAE,
 * pooled over every pixel with mask > 0.5 of a set; the lighting classification (kmeans.c); and a
 * whole run over a SPEC section 5 folder against predictions on disk or from a model, with the
 * baselines: coarse normals, the least-squares light on them, the per-image mean colour. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <cjson/cJSON.h>
#include "core/core.h"
#include "apply/apply.h"
#include "io/dataset.h"
#include "eval/eval_json.h"
#include "eval/metrics.h"
#include "eval/eval.h"
#include "model/model_probe.h"

static const double THRESHOLDS[HD_EVAL_THRESHOLDS] = {20.0, 25.0, 30.0};

static int on(const float *mask, int p) { return !mask || mask[p] > 0.5f; }

void hd_eval_add_normals(hd_eval_sums *s, const float *pred, const float *gt, const float *mask, int npix)
{
    const size_t P = (size_t)npix;
    for (int p = 0; p < npix; p++) {
        if (!on(mask, p)) continue;
        double a[3] = {pred[p], pred[P + p], pred[2 * P + p]}, b[3] = {gt[p], gt[P + p], gt[2 * P + p]};
        /* angle = atan2(|a x b|, a . b): accurate near 0 and 180 degrees, unlike acos */
        double cx = a[1] * b[2] - a[2] * b[1], cy = a[2] * b[0] - a[0] * b[2], cz = a[0] * b[1] - a[1] * b[0];
        double dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        double deg = atan2(sqrt(cx * cx + cy * cy + cz * cz), dot) * (180.0 / M_PI);
        if (!(deg == deg)) deg = 180.0; /* a NaN prediction counts as the worst */
        s->normal_sum += deg;
        s->normal_sum2 += deg * deg;
        s->normal_n++;
        for (int k = 0; k < HD_EVAL_THRESHOLDS; k++) s->normal_under[k] += deg < THRESHOLDS[k];
    }
}

/* Sums |p - t| and (p - t)^2 over masked pixels of a 3-channel map; clamp01 clamps p first. */
static void add_rgb(double *abs_sum, double *sq_sum, long *n, const float *pred, const float *gt, const float *mask,
                    int npix, int clamp01)
{
    const size_t P = (size_t)npix;
    for (int p = 0; p < npix; p++) {
        if (!on(mask, p)) continue;
        for (int c = 0; c < 3; c++) {
            double v = pred[c * P + p];
            if (clamp01) v = v < 0 ? 0 : v > 1 ? 1 : v;
            double e = v - (double)gt[c * P + p];
            if (!(e == e)) e = 1.0; /* NaN: a full miss */
            *abs_sum += fabs(e);
            *sq_sum += e * e;
        }
        *n += 3;
    }
}

typedef struct ratio {
    double r, w;
} ratio;

static int by_ratio(const void *a, const void *b)
{
    double x = ((const ratio *)a)->r, y = ((const ratio *)b)->r;
    return (x > y) - (x < y);
}

/* The k >= 0 minimising sum |k p - t| over the masked channels: sum |p| |k - t / p| is minimal at the
 * weighted median of t / p with weights |p| (terms with p = 0 or not finite do not depend on k).
 * 1 when no pixel decides it or out of memory. */
static double best_scale(const float *pred, const float *gt, const float *mask, int npix)
{
    const size_t P = (size_t)npix;
    ratio *v = malloc(3 * P * sizeof *v);
    if (!v) return 1.0;
    size_t n = 0;
    double total = 0;
    for (int p = 0; p < npix; p++) {
        if (!on(mask, p)) continue;
        for (int c = 0; c < 3; c++) {
            double a = pred[c * P + p], t = gt[c * P + p];
            if (!(a != 0.0 && isfinite(a) && isfinite(t))) continue;
            v[n].r = t / a;
            v[n].w = fabs(a);
            total += v[n++].w;
        }
    }
    double k = 1.0;
    if (n > 0) {
        qsort(v, n, sizeof *v, by_ratio);
        double acc = 0;
        for (size_t i = 0; i < n; i++) {
            acc += v[i].w;
            if (acc >= 0.5 * total) {
                k = v[i].r;
                break;
            }
        }
    }
    free(v);
    return k > 0 ? k : 0.0;
}

void hd_eval_add_albedo(hd_eval_sums *s, const float *pred, const float *gt, const float *mask, int npix)
{
    add_rgb(&s->albedo_abs, &s->albedo_sq, &s->albedo_n, pred, gt, mask, npix, 0);
    const size_t P = (size_t)npix;
    double k = best_scale(pred, gt, mask, npix);
    for (int p = 0; p < npix; p++) {
        if (!on(mask, p)) continue;
        for (int c = 0; c < 3; c++) {
            double e = fabs(k * pred[c * P + p] - gt[c * P + p]);
            s->albedo_si_abs += e == e ? e : 1.0; /* NaN: a full miss */
        }
    }
}

void hd_eval_add_recon(hd_eval_sums *s, const float *pred, const float *input, const float *mask, int npix)
{
    add_rgb(&s->recon_abs, &s->recon_sq, &s->recon_n, pred, input, mask, npix, 1);
}

void hd_eval_add_shading(hd_eval_sums *s, const float *pred, const float *gt, const float *mask, int npix)
{
    for (int p = 0; p < npix; p++) {
        if (!on(mask, p)) continue;
        double e = fabs((double)pred[p] - gt[p]);
        s->shading_abs += e == e ? e : 1.0;
        s->shading_n++;
    }
}

void hd_eval_row_from_sums(const hd_eval_sums *s, hd_eval_row *row)
{
    if (s->normal_n > 0) {
        double n = (double)s->normal_n, mean = s->normal_sum / n, var = s->normal_sum2 / n - mean * mean;
        row->has_normal = 1;
        row->normal_mean = mean;
        row->normal_std = var > 0 ? sqrt(var) : 0.0;
        for (int k = 0; k < HD_EVAL_THRESHOLDS; k++) row->normal_under[k] = 100.0 * (double)s->normal_under[k] / n;
    }
    if (s->albedo_n > 0) {
        row->has_albedo = 1;
        row->albedo_mae = s->albedo_abs / (double)s->albedo_n;
        row->albedo_rmse = sqrt(s->albedo_sq / (double)s->albedo_n);
        row->albedo_si_mae = s->albedo_si_abs / (double)s->albedo_n;
    }
    if (s->recon_n > 0) {
        row->has_recon = 1;
        row->recon_mae = s->recon_abs / (double)s->recon_n;
        row->recon_rmse = sqrt(s->recon_sq / (double)s->recon_n);
    }
    if (s->shading_n > 0) {
        row->has_shading = 1;
        row->shading_mae = s->shading_abs / (double)s->shading_n;
    }
}

/* ---- a whole run */

/* One image's ground truth and inputs. */
typedef struct gt_image {
    hd_image input, mask, albedo, normal, shading, coarse;
    float light[HD_SH_COEFFS];
    int has_coarse;
} gt_image;

static void gt_free(gt_image *g)
{
    hd_image_free(&g->input);
    hd_image_free(&g->mask);
    hd_image_free(&g->albedo);
    hd_image_free(&g->normal);
    hd_image_free(&g->shading);
    hd_image_free(&g->coarse);
}

/* path with its suffix `from` replaced by `to` (malloc'ed). */
static char *swap_suffix(const char *path, const char *from, const char *to)
{
    size_t n = strlen(path), a = strlen(from), b = strlen(to);
    if (n < a || strcmp(path + n - a, from) != 0) return NULL;
    char *out = hd_malloc(n - a + b + 1);
    if (!out) return NULL;
    memcpy(out, path, n - a);
    memcpy(out + n - a, to, b + 1);
    return out;
}

static int readable(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f) return 0;
    fclose(f);
    return 1;
}

/* Reads a shading map: NAME.shading.pfm when it exists beside png_path, else the PNG holding s/2. */
static hd_status read_shading(const char *png_path, const char *pfm_path, hd_image *out)
{
    if (pfm_path && readable(pfm_path)) return hd_image_read_as(pfm_path, 1, out);
    hd_status st = hd_image_read_as(png_path, 1, out);
    if (st != HD_OK) return st;
    size_t n = (size_t)out->width * out->height;
    for (size_t i = 0; i < n; i++) out->data[i] *= 2.0f;
    return HD_OK;
}

static hd_status same_size(const hd_image *a, const hd_image *ref, const char *what, const char *path)
{
    if (a->width != ref->width || a->height != ref->height)
        return hd_fail(HD_ERR_FORMAT, "%s: %s is %dx%d but the image is %dx%d", path, what, a->width, a->height,
                       ref->width, ref->height);
    return HD_OK;
}

static hd_status load_gt(const hd_sample *s, gt_image *g)
{
    memset(g, 0, sizeof *g);
    const char *missing = !s->albedo ? "NAME.albedo.png" : !s->normal_gt ? "NAME.normal_gt.png" : !s->shading ? "NAME.shading.png"
                          : !s->light ? "NAME.light.txt" : NULL;
    if (missing) return hd_fail(HD_ERR_NOTFOUND, "%s: no ground truth %s beside it", s->image, missing);
    hd_status st = hd_image_read_as(s->image, 3, &g->input);
    if (st == HD_OK) st = hd_image_read_as(s->albedo, 3, &g->albedo);
    if (st == HD_OK) st = same_size(&g->albedo, &g->input, "the albedo", s->albedo);
    hd_image rgb = {0}, nmask = {0};
    if (st == HD_OK) st = hd_image_read_as(s->normal_gt, 3, &rgb);
    if (st == HD_OK) st = same_size(&rgb, &g->input, "the normal map", s->normal_gt);
    if (st == HD_OK) st = hd_normal_decode(&rgb, &g->normal, &nmask);
    hd_image_free(&rgb);
    if (st == HD_OK) {
        char *pfm = swap_suffix(s->shading, ".shading.png", ".shading.pfm");
        st = read_shading(s->shading, pfm, &g->shading);
        if (st == HD_OK) st = same_size(&g->shading, &g->input, "the shading", s->shading);
        free(pfm);
    }
    if (st == HD_OK) st = hd_light_read(s->light, g->light);
    if (st == HD_OK && s->mask) {
        st = hd_image_read_as(s->mask, 1, &g->mask);
        if (st == HD_OK) st = same_size(&g->mask, &g->input, "the mask", s->mask);
        /* a texel without a ground-truth normal cannot be scored */
        if (st == HD_OK)
            for (size_t i = 0; i < (size_t)g->mask.width * g->mask.height; i++)
                if (nmask.data[i] <= 0.5f) g->mask.data[i] = 0.0f;
    } else if (st == HD_OK) {
        g->mask = nmask;
        nmask.data = NULL;
    }
    hd_image_free(&nmask);
    if (st == HD_OK && s->normal) {
        hd_image c = {0};
        st = hd_image_read_as(s->normal, 3, &c);
        if (st == HD_OK) st = same_size(&c, &g->input, "the coarse normal map", s->normal);
        if (st == HD_OK) st = hd_normal_decode(&c, &g->coarse, NULL);
        hd_image_free(&c);
        g->has_coarse = st == HD_OK;
    }
    if (st != HD_OK) gt_free(g);
    return st;
}

/* Resizes img in place to w x h (no-op when it already is). */
static hd_status fit_size(hd_image *img, int w, int h)
{
    if (img->width == w && img->height == h) return HD_OK;
    hd_image out = {0};
    hd_status st = hd_image_resize(img, w, h, &out);
    if (st != HD_OK) return st;
    hd_image_free(img);
    *img = out;
    return HD_OK;
}

/* Brings a decomposition to the ground truth's size (normals renormalised after resampling). */
/* Normals n resized to w x h and made unit again where they were resized. */
static hd_status fit_normals(hd_image *n, int w, int h)
{
    const int resized = n->width != w || n->height != h;
    hd_status st = fit_size(n, w, h);
    if (st == HD_OK && resized) {
        size_t P = (size_t)w * h;
        float *v = n->data;
        for (size_t i = 0; i < P; i++) {
            float l = sqrtf(v[i] * v[i] + v[P + i] * v[P + i] + v[2 * P + i] * v[2 * P + i]);
            if (l > 1e-12f) v[i] /= l, v[P + i] /= l, v[2 * P + i] /= l;
        }
    }
    return st;
}

static hd_status fit_decomposition(hd_decomposition *d, int w, int h)
{
    hd_status st = fit_size(&d->albedo, w, h);
    if (st == HD_OK) st = fit_size(&d->shading, w, h);
    if (st == HD_OK) st = fit_normals(&d->normal, w, h);
    if (st == HD_OK && d->reconstruction.data) st = fit_size(&d->reconstruction, w, h);
    return st;
}

/* Reads the prediction for sample s into d: by the batch commands' naming rule (docs/usage.md),
 * pred_dir/SUBJECT/NAME.* for an image data_dir/SUBJECT/NAME.png, and pred_dir/NAME.* for one
 * directly in data_dir (a flat set, whose subject is the folder's own name). */
static hd_status load_pred(const char *data_dir, const char *pred_dir, const hd_sample *s, hd_decomposition *d)
{
    memset(d, 0, sizeof *d);
    char *subject_dir = hd_path_join(data_dir, s->subject);
    if (!subject_dir) return hd_fail(HD_ERR_NOMEM, "out of memory");
    size_t k = strlen(subject_dir);
    const int in_subject = strncmp(s->image, subject_dir, k) == 0 && s->image[k] == '/';
    free(subject_dir);
    char base[4096];
    if (snprintf(base, sizeof base, "%s/%s%s%s", pred_dir, in_subject ? s->subject : "", in_subject ? "/" : "",
                 s->name) >= (int)sizeof base)
        return hd_fail(HD_ERR_RANGE, "%s/%s: path too long", pred_dir, s->name);
    char path[4200], pfm[4200];
    hd_status st;
    snprintf(path, sizeof path, "%s.albedo.png", base);
    st = hd_image_read_as(path, 3, &d->albedo);
    if (st == HD_OK) {
        snprintf(path, sizeof path, "%s.shading.png", base);
        snprintf(pfm, sizeof pfm, "%s.shading.pfm", base);
        st = read_shading(path, pfm, &d->shading);
    }
    if (st == HD_OK) {
        hd_image rgb = {0};
        snprintf(path, sizeof path, "%s.normal.png", base);
        st = hd_image_read_as(path, 3, &rgb);
        if (st == HD_OK) st = hd_normal_decode(&rgb, &d->normal, NULL);
        hd_image_free(&rgb);
    }
    if (st == HD_OK) {
        snprintf(path, sizeof path, "%s.light.txt", base);
        st = hd_light_read(path, d->light);
    }
    if (st == HD_OK) {
        snprintf(path, sizeof path, "%s.recon.png", base);
        if (readable(path)) st = hd_image_read_as(path, 3, &d->reconstruction);
    }
    if (st == HD_OK && (d->albedo.width != d->shading.width || d->albedo.height != d->shading.height ||
                        d->albedo.width != d->normal.width || d->albedo.height != d->normal.height))
        st = hd_fail(HD_ERR_FORMAT, "%s.*: the predicted maps differ in size", base);
    if (st != HD_OK) hd_decomposition_free(d);
    return st;
}

/* Fills d->reconstruction with albedo * shading when the prediction has none. */
static hd_status ensure_recon(hd_decomposition *d)
{
    if (d->reconstruction.data) return HD_OK;
    hd_status st = hd_image_alloc(&d->reconstruction, d->albedo.width, d->albedo.height, 3);
    if (st != HD_OK) return st;
    size_t P = (size_t)d->albedo.width * d->albedo.height;
    for (int c = 0; c < 3; c++)
        for (size_t i = 0; i < P; i++) d->reconstruction.data[c * P + i] = d->albedo.data[c * P + i] * d->shading.data[i];
    return HD_OK;
}

enum { ROW_PRED, ROW_COARSE, ROW_LSLIGHT, ROW_MEANCOLOR, ROW_TRUE_SHADING, ROWS };

/* Scores one image against prediction d (already at the ground truth's size) and adds the
 * baselines; appends the lights. */
static hd_status score(const gt_image *g, const hd_decomposition *d, hd_eval_sums sums[ROWS], float *gt_light,
                       float *pred_light, float *ls_light, int *has_ls)
{
    const int npix = g->input.width * g->input.height;
    const size_t P = (size_t)npix;
    const float *m = g->mask.data;
    hd_eval_add_normals(&sums[ROW_PRED], d->normal.data, g->normal.data, m, npix);
    hd_eval_add_albedo(&sums[ROW_PRED], d->albedo.data, g->albedo.data, m, npix);
    hd_eval_add_recon(&sums[ROW_PRED], d->reconstruction.data, g->input.data, m, npix);
    hd_eval_add_shading(&sums[ROW_PRED], d->shading.data, g->shading.data, m, npix);
    memcpy(gt_light, g->light, sizeof g->light);
    memcpy(pred_light, d->light, sizeof d->light);
    /* baseline: per-image mean colour of the input over the mask, as albedo */
    double mean[3] = {0, 0, 0}, count = 0;
    for (size_t i = 0; i < P; i++)
        if (m[i] > 0.5f) {
            for (int c = 0; c < 3; c++) mean[c] += g->input.data[c * P + i];
            count++;
        }
    float *buf = hd_malloc(3 * P * sizeof(float));
    if (!buf) return HD_ERR_NOMEM;
    for (int c = 0; c < 3; c++)
        for (size_t i = 0; i < P; i++) buf[c * P + i] = count > 0 ? (float)(mean[c] / count) : 0.0f;
    hd_eval_add_albedo(&sums[ROW_MEANCOLOR], buf, g->albedo.data, m, npix);
    *has_ls = 0;
    if (g->has_coarse) {
        hd_eval_add_normals(&sums[ROW_COARSE], g->coarse.data, g->normal.data, m, npix);
        /* baseline: the least-squares light of the true shading on the coarse normals, and the
         * shading it gives on them */
        hd_status st = hd_sh_fit(g->coarse.data, g->shading.data, m, npix, ls_light);
        if (st != HD_OK) {
            free(buf);
            return st;
        }
        hd_sh_shading_map(g->coarse.data, m, npix, ls_light, buf);
        hd_eval_add_shading(&sums[ROW_LSLIGHT], buf, g->shading.data, m, npix);
        *has_ls = 1;
    }
    free(buf);
    return HD_OK;
}

/* What one image contributes, kept apart until the in-order merge. */
typedef struct image_result {
    hd_status status;
    char *message; /* the reason, when status != HD_OK */
    hd_eval_sums sums[ROWS];
    float gt_light[HD_SH_COEFFS], pred_light[HD_SH_COEFFS], ls_light[HD_SH_COEFFS];
    int has_ls;
} image_result;

static void sums_add(hd_eval_sums *a, const hd_eval_sums *b)
{
    a->normal_sum += b->normal_sum;
    a->normal_sum2 += b->normal_sum2;
    a->normal_n += b->normal_n;
    for (int k = 0; k < HD_EVAL_THRESHOLDS; k++) a->normal_under[k] += b->normal_under[k];
    a->albedo_abs += b->albedo_abs;
    a->albedo_sq += b->albedo_sq;
    a->albedo_si_abs += b->albedo_si_abs;
    a->albedo_n += b->albedo_n;
    a->recon_abs += b->recon_abs;
    a->recon_sq += b->recon_sq;
    a->recon_n += b->recon_n;
    a->shading_abs += b->shading_abs;
    a->shading_n += b->shading_n;
}

/* The prediction's light, as the lighting classification scores it: L-Net's (d->light, kept) or
 * the face's least-squares light of S on N over the set's mask without the face regions
 * (hd_face_light, what the relighting rule uses as the face's own light). */
static hd_status source_light(hd_decomposition *d, const gt_image *g, hd_source_light source)
{
    if (source == HD_SOURCE_LNET) return HD_OK;
    float l[HD_SH_COEFFS];
    hd_status st = hd_face_light(d, &g->mask, source, l);
    if (st == HD_OK) memcpy(d->light, l, sizeof l);
    return st;
}

hd_status hd_eval_run(const char *data_dir, const char *pred_dir, hd_model *model, hd_eval_report *rep,
                      void (*warn)(const char *message))
{
    return hd_eval_run_light(data_dir, pred_dir, model, HD_SOURCE_LNET, rep, warn);
}

hd_status hd_eval_run_light(const char *data_dir, const char *pred_dir, hd_model *model, hd_source_light source,
                            hd_eval_report *rep, void (*warn)(const char *message))
{
    const hd_eval_options o = {source, 0.0f, 0};
    return hd_eval_run_options(data_dir, pred_dir, model, &o, rep, warn);
}

/* The prediction's normals turned toward the coarse normals' pose by `share` (none without them). */
static hd_status repose(hd_decomposition *d, const gt_image *g, float share)
{
    if (!(share > 0.0f) || !g->has_coarse) return HD_OK;
    hd_aligned_face f;
    memset(&f, 0, sizeof f);
    f.normal = g->coarse, f.mask = g->mask; /* borrowed */
    return hd_face_repose(&f, d, share, NULL);
}

/* Row ROW_TRUE_SHADING: the model's N-Net on the true shading, turned as the prediction is. */
static hd_status score_true_shading(hd_model *model, const gt_image *g, float share, hd_eval_sums *sums)
{
    hd_decomposition t;
    memset(&t, 0, sizeof t);
    hd_status st = hd_model_normals_from_shading(model, &g->input, &g->shading, &g->mask, &t.normal, NULL);
    if (st == HD_OK) st = fit_normals(&t.normal, g->input.width, g->input.height);
    if (st == HD_OK) st = repose(&t, g, share);
    if (st == HD_OK) hd_eval_add_normals(sums, t.normal.data, g->normal.data, g->mask.data, g->input.width * g->input.height);
    hd_image_free(&t.normal);
    return st;
}

hd_status hd_eval_run_options(const char *data_dir, const char *pred_dir, hd_model *model, const hd_eval_options *o,
                              hd_eval_report *rep, void (*warn)(const char *message))
{
    memset(rep, 0, sizeof *rep);
    if (!o) return hd_fail(HD_ERR_ARG, "eval: no options");
    const hd_source_light source = o->source;
    const float share = o->repose;
    rep->source = source;
    rep->repose = share;
    rep->true_shading = o->true_shading != 0;
    if (!(share >= 0.0f && share <= 1.0f)) return hd_fail(HD_ERR_ARG, "eval: the repose share %g is not in 0..1", share);
    if ((pred_dir == NULL) == (model == NULL))
        return hd_fail(HD_ERR_ARG, "eval: give exactly one of a prediction folder and a model");
    if (o->true_shading && !model)
        return hd_fail(HD_ERR_ARG, "eval: N-Net on the true shading needs a model, not a prediction folder");
    if (source != HD_SOURCE_LNET && source != HD_SOURCE_FIT)
        return hd_fail(HD_ERR_ARG, "eval: unknown source light %d", (int)source);
    hd_dataset ds;
    hd_status st = hd_dataset_scan(data_dir, &ds, warn);
    if (st != HD_OK) return st;
    size_t n = (size_t)ds.count;
    float *gt_l = hd_malloc(n * HD_SH_COEFFS * sizeof(float)), *pred_l = hd_malloc(n * HD_SH_COEFFS * sizeof(float));
    float *ls_gt = hd_malloc(n * HD_SH_COEFFS * sizeof(float)), *ls_l = hd_malloc(n * HD_SH_COEFFS * sizeof(float));
    if (!gt_l || !pred_l || !ls_gt || !ls_l) {
        free(gt_l), free(pred_l), free(ls_gt), free(ls_l);
        hd_dataset_free(&ds);
        return HD_ERR_NOMEM;
    }
    hd_eval_sums sums[ROWS];
    memset(sums, 0, sizeof sums);
    long scored = 0, nls = 0;
    /* Each image is scored into its own slot (in parallel when reading predictions from disk; a
     * model runs its own threads), then the slots are merged in the set's order, so the result
     * does not depend on the thread count. */
    image_result *res = hd_calloc(n ? n : 1, sizeof *res);
    const int count = res ? ds.count : 0;
    if (!res) st = HD_ERR_NOMEM;
#pragma omp parallel for schedule(dynamic, 1) if (pred_dir != NULL)
    for (int i = 0; i < count; i++) {
        const hd_sample *s = &ds.samples[i];
        image_result *ir = &res[i];
        gt_image g;
        hd_decomposition d;
        memset(&d, 0, sizeof d);
        hd_status e = load_gt(s, &g);
        if (e == HD_OK) {
            e = pred_dir ? load_pred(data_dir, pred_dir, s, &d) : hd_model_decompose(model, &g.input, 1, &d);
            if (e == HD_OK) e = repose(&d, &g, share);
            if (e == HD_OK) e = fit_decomposition(&d, g.input.width, g.input.height);
            if (e == HD_OK) e = ensure_recon(&d);
            if (e == HD_OK) e = source_light(&d, &g, source);
            if (e == HD_OK) e = score(&g, &d, ir->sums, ir->gt_light, ir->pred_light, ir->ls_light, &ir->has_ls);
            if (e == HD_OK && rep->true_shading) e = score_true_shading(model, &g, share, &ir->sums[ROW_TRUE_SHADING]);
            hd_decomposition_free(&d);
            gt_free(&g);
        }
        ir->status = e;
        if (e != HD_OK) ir->message = strdup(hd_error());
    }
    for (int i = 0; res && i < ds.count; i++) {
        image_result *ir = &res[i];
        if (ir->status != HD_OK) {
            if (ir->status == HD_ERR_NOMEM && st == HD_OK) st = hd_fail(HD_ERR_NOMEM, "%s", ir->message ? ir->message : "out of memory");
            rep->skipped++;
            if (warn) warn(ir->message ? ir->message : "out of memory");
            free(ir->message);
            continue;
        }
        for (int r = 0; r < ROWS; r++) sums_add(&sums[r], &ir->sums[r]);
        memcpy(gt_l + (size_t)scored * HD_SH_COEFFS, ir->gt_light, sizeof ir->gt_light);
        memcpy(pred_l + (size_t)scored * HD_SH_COEFFS, ir->pred_light, sizeof ir->pred_light);
        scored++;
        if (ir->has_ls) {
            memcpy(ls_gt + (size_t)nls * HD_SH_COEFFS, ir->gt_light, sizeof ir->gt_light);
            memcpy(ls_l + (size_t)nls * HD_SH_COEFFS, ir->ls_light, sizeof ir->ls_light);
            nls++;
        }
    }
    free(res);
    if (st == HD_OK && scored == 0) st = hd_fail(HD_ERR_NOTFOUND, "%s: no image could be scored", data_dir);
    if (st == HD_OK) {
        rep->images = scored;
        rep->kmeans_k = scored < HD_EVAL_KMEANS_K ? (int)scored : HD_EVAL_KMEANS_K;
        static const char *const names[ROWS] = {"prediction", "coarse normals", "LS light on coarse normals",
                                                "mean colour albedo", "N-Net on true shading"};
        const int nrows = rep->true_shading ? ROWS : ROW_TRUE_SHADING;
        for (int r = 0; r < nrows; r++) {
            snprintf(rep->rows[r].name, sizeof rep->rows[r].name, "%s", names[r]);
            hd_eval_row_from_sums(&sums[r], &rep->rows[r]);
        }
        st = hd_eval_light_accuracy(gt_l, pred_l, (int)scored, HD_EVAL_KMEANS_K, HD_EVAL_KMEANS_SEED,
                                    &rep->rows[ROW_PRED].light_accuracy);
        rep->rows[ROW_PRED].has_light = st == HD_OK;
        if (st == HD_OK && nls > 0) {
            st = hd_eval_light_accuracy(ls_gt, ls_l, (int)nls, HD_EVAL_KMEANS_K, HD_EVAL_KMEANS_SEED,
                                        &rep->rows[ROW_LSLIGHT].light_accuracy);
            rep->rows[ROW_LSLIGHT].has_light = st == HD_OK;
        }
        rep->nrows = nrows;
    }
    free(gt_l), free(pred_l), free(ls_gt), free(ls_l);
    hd_dataset_free(&ds);
    return st;
}

/* ---- JSON */

static void add_num(cJSON *o, const char *key, int has, double v)
{
    if (has) cJSON_AddNumberToObject(o, key, v);
    else cJSON_AddNullToObject(o, key);
}

char *hd_eval_report_json(const hd_eval_report *r)
{
    cJSON *root = cJSON_CreateObject();
    if (!root) return hd_fail(HD_ERR_NOMEM, "out of memory building the JSON report"), NULL;
    cJSON_AddNumberToObject(root, "images", (double)r->images);
    cJSON_AddNumberToObject(root, "skipped", (double)r->skipped);
    cJSON_AddNumberToObject(root, "kmeans_k", r->kmeans_k);
    cJSON_AddStringToObject(root, "source_light", r->source == HD_SOURCE_FIT ? "fit" : "lnet");
    cJSON_AddNumberToObject(root, "repose", r->repose);
    cJSON *rows = cJSON_AddArrayToObject(root, "rows");
    for (int i = 0; i < r->nrows; i++) {
        const hd_eval_row *w = &r->rows[i];
        cJSON *o = cJSON_CreateObject();
        cJSON_AddItemToArray(rows, o);
        cJSON_AddStringToObject(o, "name", w->name);
        add_num(o, "normal_mean_deg", w->has_normal, w->normal_mean);
        add_num(o, "normal_std_deg", w->has_normal, w->normal_std);
        add_num(o, "normal_under_20_pct", w->has_normal, w->normal_under[0]);
        add_num(o, "normal_under_25_pct", w->has_normal, w->normal_under[1]);
        add_num(o, "normal_under_30_pct", w->has_normal, w->normal_under[2]);
        add_num(o, "albedo_mae", w->has_albedo, w->albedo_mae);
        add_num(o, "albedo_rmse", w->has_albedo, w->albedo_rmse);
        add_num(o, "albedo_si_mae", w->has_albedo, w->albedo_si_mae);
        add_num(o, "recon_mae", w->has_recon, w->recon_mae);
        add_num(o, "recon_rmse", w->has_recon, w->recon_rmse);
        add_num(o, "shading_mae", w->has_shading, w->shading_mae);
        add_num(o, "light_accuracy_pct", w->has_light, w->light_accuracy);
    }
    char *text = cJSON_Print(root);
    cJSON_Delete(root);
    if (!text) hd_fail(HD_ERR_NOMEM, "out of memory printing the JSON report");
    return text;
}

hd_status hd_eval_report_write_json(const char *path, const hd_eval_report *r)
{
    return hd_eval_json_write(path, hd_eval_report_json(r));
}

hd_status hd_eval_json_write(const char *path, char *text)
{
    if (!text) return hd_fail(HD_ERR_NOMEM, "%s: %s", path, hd_error());
    hd_atomic_file af;
    hd_status st = hd_atomic_open(&af, path);
    if (st == HD_OK) {
        fputs(text, af.f);
        fputc('\n', af.f);
        st = hd_atomic_commit(&af);
    }
    free(text);
    return st;
}
