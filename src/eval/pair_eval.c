/* pair_eval.c: `hdnet eval --pairs`: relighting measured against the truth on paired synthetic
 * sets (`hdnet synth` output, docs/usage.md "Measuring relighting"). Image i of a subject is
 * relit under the true light of the subject's next image j and compared with image j over both
 * masks: MAE, RMSE, PSNR and SSIM, for the input left unchanged, the exact decomposition (true
 * albedo times the true normals' shading under l_j), the exact ratio (the rule with the true
 * normals and lights), and the model under the rule and under the paper's rule. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <cjson/cJSON.h>
#include "core/core.h"
#include "io/dataset.h"
#include "eval/eval_json.h"
#include "eval/photo_metrics.h"
#include "apply/apply.h"
#include "eval/eval.h"

static const char *const ROW_NAMES[HD_PAIR_ROWS] = {"input unchanged", "exact decomposition", "exact ratio (true N, l)",
                                                    "model, ratio rule", "model, paper rule"};

/* SSIM's window: a Gaussian of 1.5 pixels, 11 x 11 (Wang et al. 2004); constants for range 1. */
#define SSIM_SIGMA 1.5f
#define SSIM_C1 (0.01 * 0.01)
#define SSIM_C2 (0.03 * 0.03)

/* One plane blurred by SSIM's window (edges clamped) into out. */
static hd_status window_mean(const float *v, int w, int h, float *out)
{
    memcpy(out, v, (size_t)w * h * sizeof(float));
    return hd_field_blur(out, w, h, SSIM_SIGMA);
}

double hd_ssim_masked(const hd_image *a, const hd_image *b, const float *mask)
{
    const int W = a->width, H = a->height;
    const size_t P = (size_t)W * H;
    float *buf = hd_malloc(7 * (P ? P : 1) * sizeof(float));
    if (!buf) return NAN;
    float *x = buf, *y = x + P, *mx = y + P, *my = mx + P, *t = my + P, *sxy = t + P, *tmp = sxy + P;
    double acc = 0;
    long n = 0;
    for (int c = 0; c < a->channels && c < 3; c++) {
        for (size_t p = 0; p < P; p++) {
            float u = a->data[(size_t)c * P + p], v = b->data[(size_t)c * P + p];
            x[p] = u < 0 ? 0 : u > 1 ? 1 : u;
            y[p] = v < 0 ? 0 : v > 1 ? 1 : v;
        }
        float *sxx = t, *syy = tmp;
        if (window_mean(x, W, H, mx) || window_mean(y, W, H, my)) {
            free(buf);
            return NAN;
        }
        for (size_t p = 0; p < P; p++) sxy[p] = x[p] * y[p];
        hd_field_blur(sxy, W, H, SSIM_SIGMA);
        for (size_t p = 0; p < P; p++) x[p] *= x[p], y[p] *= y[p];
        window_mean(x, W, H, sxx);
        window_mean(y, W, H, syy);
        for (size_t p = 0; p < P; p++) {
            if (mask && mask[p] <= 0.5f) continue;
            double ux = mx[p], uy = my[p];
            double vx = sxx[p] - ux * ux, vy = syy[p] - uy * uy, cxy = sxy[p] - ux * uy;
            acc += ((2 * ux * uy + SSIM_C1) * (2 * cxy + SSIM_C2)) /
                   ((ux * ux + uy * uy + SSIM_C1) * (vx + vy + SSIM_C2));
            n++;
        }
    }
    free(buf);
    return n ? acc / n : 1.0;
}

/* Adds |p - t| and (p - t)^2 over masked pixels (both clamped to [0, 1]) into row sums. */
static void add_errors(hd_pair_row *row, const hd_image *pred, const hd_image *truth, const float *mask)
{
    const size_t P = (size_t)pred->width * pred->height;
    double ae = 0, se = 0;
    long n = 0;
    for (size_t p = 0; p < P; p++) {
        if (mask[p] <= 0.5f) continue;
        for (int c = 0; c < 3; c++) {
            float u = pred->data[c * P + p], v = truth->data[c * P + p];
            u = u < 0 ? 0 : u > 1 ? 1 : u;
            v = v < 0 ? 0 : v > 1 ? 1 : v;
            double e = (double)u - v;
            if (!(e == e)) e = 1.0;
            ae += fabs(e), se += e * e;
        }
        n += 3;
    }
    row->abs_sum += ae, row->sq_sum += se, row->n += n;
    double ssim = hd_ssim_masked(pred, truth, mask);
    if (isfinite(ssim)) row->ssim_sum += ssim, row->pairs++;
}

/* Everything one image of a pair brings: input, mask, truth. */
typedef struct side {
    hd_image input, mask, albedo, normal, nmask;
    float light[HD_SH_COEFFS];
} side;

static void side_free(side *s)
{
    hd_image_free(&s->input);
    hd_image_free(&s->mask);
    hd_image_free(&s->albedo);
    hd_image_free(&s->normal);
    hd_image_free(&s->nmask);
}

static hd_status side_load(const hd_sample *s, side *o)
{
    memset(o, 0, sizeof *o);
    if (!s->albedo || !s->normal_gt || !s->light)
        return hd_fail(HD_ERR_NOTFOUND, "%s: no ground truth (NAME.albedo.png, NAME.normal_gt.png, NAME.light.txt) beside it",
                       s->image);
    hd_image rgb = {0};
    hd_status st = hd_image_read_as(s->image, 3, &o->input);
    if (st == HD_OK) st = hd_image_read_as(s->albedo, 3, &o->albedo);
    if (st == HD_OK) st = hd_image_read_as(s->normal_gt, 3, &rgb);
    if (st == HD_OK) st = hd_normal_decode(&rgb, &o->normal, &o->nmask);
    if (st == HD_OK) st = hd_light_read(s->light, o->light);
    if (st == HD_OK && s->mask) st = hd_image_read_as(s->mask, 1, &o->mask);
    if (st == HD_OK && !s->mask) {
        st = hd_image_alloc(&o->mask, o->input.width, o->input.height, 1);
        for (size_t p = 0; st == HD_OK && p < (size_t)o->input.width * o->input.height; p++) o->mask.data[p] = 1.0f;
    }
    hd_image_free(&rgb);
    const hd_image *all[4] = {&o->albedo, &o->normal, &o->mask, &o->nmask};
    for (int k = 0; k < 4 && st == HD_OK; k++)
        if (all[k]->width != o->input.width || all[k]->height != o->input.height)
            st = hd_fail(HD_ERR_FORMAT, "%s: its ground truth is not %d x %d", s->image, o->input.width, o->input.height);
    if (st != HD_OK) side_free(o);
    return st;
}

/* The scored pixels: both masks and both true-normal masks. */
static hd_status pair_mask(const side *a, const side *b, hd_image *m)
{
    hd_status st = hd_image_alloc(m, a->input.width, a->input.height, 1);
    if (st != HD_OK) return st;
    if (b->input.width != a->input.width || b->input.height != a->input.height)
        return hd_fail(HD_ERR_FORMAT, "a pair's images differ in size");
    for (size_t p = 0; p < (size_t)m->width * m->height; p++)
        m->data[p] = a->mask.data[p] > 0.5f && b->mask.data[p] > 0.5f && a->nmask.data[p] > 0.5f && b->nmask.data[p] > 0.5f;
    return HD_OK;
}

/* One pair i -> j: every row's relit picture, scored against j. */
static hd_status score_pair(hd_model *model, const side *a, const side *b, const hd_photo_rule *how, hd_pair_row *rows)
{
    hd_image m = {0}, exact = {0}, out = {0};
    hd_decomposition d, truth;
    memset(&d, 0, sizeof d);
    memset(&truth, 0, sizeof truth);
    hd_status st = pair_mask(a, b, &m);
    const size_t P = (size_t)a->input.width * a->input.height;
    hd_light_rgb target;
    hd_light_rgb_from_grey(b->light, &target);
    hd_apply_request q = {&target, 1, 0, 0, HD_RULE_RATIO, HD_BRIGHTNESS_FREE, HD_SOURCE_LNET, how->guard, "eval"};
    hd_apply_result r;
    if (st == HD_OK) add_errors(&rows[HD_PAIR_INPUT], &a->input, &b->input, m.data);
    /* exact decomposition: A_i s(N_i, l_j) */
    if (st == HD_OK) st = hd_image_alloc(&exact, a->input.width, a->input.height, 3);
    float *s = st == HD_OK ? hd_malloc(P * sizeof(float)) : NULL;
    if (st == HD_OK && !s) st = HD_ERR_NOMEM;
    if (st == HD_OK) {
        hd_sh_shading_map(a->normal.data, NULL, (int)P, b->light, s);
        for (int c = 0; c < 3; c++)
            for (size_t p = 0; p < P; p++) exact.data[c * P + p] = a->albedo.data[c * P + p] * (s[p] > 0 ? s[p] : 0);
        add_errors(&rows[HD_PAIR_EXACT], &exact, &b->input, m.data);
    }
    free(s);
    /* the rule with the true normals and light */
    if (st == HD_OK) {
        truth.normal = a->normal;
        memcpy(truth.light, a->light, sizeof truth.light);
        st = hd_apply_decomposition(&a->input, &truth, &a->mask, &q, &r);
        truth.normal.data = NULL;
        if (st == HD_OK) {
            add_errors(&rows[HD_PAIR_EXACT_RATIO], &r.relit[0], &b->input, m.data);
            hd_apply_result_free(&r);
        }
    }
    q.source = how->source; /* the model's rows: the face's own light as the tool takes it */
    if (st == HD_OK) st = hd_model_decompose(model, &a->input, 1, &d);
    if (st == HD_OK) st = hd_apply_decomposition(&a->input, &d, &a->mask, &q, &r);
    if (st == HD_OK) {
        add_errors(&rows[HD_PAIR_MODEL], &r.relit[0], &b->input, m.data);
        hd_apply_result_free(&r);
    }
    if (st == HD_OK) st = hd_relight_paper(&a->input, &d, &a->mask, b->light, HD_BRIGHTNESS_FREE, &out);
    if (st == HD_OK) add_errors(&rows[HD_PAIR_PAPER], &out, &b->input, m.data);
    hd_image_free(&out);
    hd_image_free(&exact);
    hd_image_free(&m);
    hd_decomposition_free(&d);
    return st;
}

hd_status hd_pair_eval_run(const char *dir, hd_model *model, const hd_photo_rule *how, hd_pair_report *rep,
                           void (*warn)(const char *message))
{
    memset(rep, 0, sizeof *rep);
    for (int k = 0; k < HD_PAIR_ROWS; k++) snprintf(rep->rows[k].name, sizeof rep->rows[k].name, "%s", ROW_NAMES[k]);
    hd_dataset ds;
    hd_status st = hd_dataset_scan(dir, &ds, warn);
    if (st != HD_OK) return st;
    for (int sub = 0; sub < ds.subject_count && st == HD_OK; sub++) {
        int lo = ds.subject_start[sub], hi = ds.subject_start[sub + 1];
        for (int i = lo; hi - lo >= 2 && i < hi && st == HD_OK; i++) {
            int j = i + 1 < hi ? i + 1 : lo;
            side a, b;
            hd_status e = side_load(&ds.samples[i], &a);
            if (e == HD_OK) {
                e = side_load(&ds.samples[j], &b);
                if (e == HD_OK) {
                    e = score_pair(model, &a, &b, how, rep->rows);
                    side_free(&b);
                }
                side_free(&a);
            }
            if (e == HD_ERR_NOMEM) st = e;
            if (e != HD_OK) {
                rep->skipped++;
                if (warn) warn(hd_error());
            } else {
                rep->pairs++;
            }
        }
    }
    hd_dataset_free(&ds);
    if (st == HD_OK && rep->pairs == 0) st = hd_fail(HD_ERR_NOTFOUND, "%s: no pair could be scored", dir);
    for (int k = 0; st == HD_OK && k < HD_PAIR_ROWS; k++) {
        hd_pair_row *r = &rep->rows[k];
        r->mae = r->n ? r->abs_sum / r->n : NAN;
        r->rmse = r->n ? sqrt(r->sq_sum / r->n) : NAN;
        r->psnr = r->n ? (r->sq_sum > 0 ? 10.0 * log10((double)r->n / r->sq_sum) : INFINITY) : NAN;
        r->ssim = r->pairs ? r->ssim_sum / r->pairs : NAN;
    }
    return st;
}

char *hd_pair_report_json(const hd_pair_report *rep)
{
    cJSON *root = cJSON_CreateObject();
    if (!root) return hd_fail(HD_ERR_NOMEM, "out of memory building the JSON report"), NULL;
    cJSON_AddNumberToObject(root, "pairs", rep->pairs);
    cJSON_AddNumberToObject(root, "skipped", rep->skipped);
    cJSON *rows = cJSON_AddArrayToObject(root, "rows");
    for (int k = 0; k < HD_PAIR_ROWS; k++) {
        const hd_pair_row *r = &rep->rows[k];
        cJSON *o = cJSON_CreateObject();
        cJSON_AddItemToArray(rows, o);
        cJSON_AddStringToObject(o, "name", r->name);
        const double v[4] = {r->mae, r->rmse, r->psnr, r->ssim};
        const char *keys[4] = {"mae", "rmse", "psnr_db", "ssim"};
        for (int i = 0; i < 4; i++)
            if (isfinite(v[i])) cJSON_AddNumberToObject(o, keys[i], v[i]);
            else cJSON_AddNullToObject(o, keys[i]);
    }
    char *text = cJSON_Print(root);
    cJSON_Delete(root);
    if (!text) hd_fail(HD_ERR_NOMEM, "out of memory printing the JSON report");
    return text;
}

hd_status hd_pair_report_write_json(const char *path, const hd_pair_report *rep)
{
    return hd_eval_json_write(path, hd_pair_report_json(rep));
}
