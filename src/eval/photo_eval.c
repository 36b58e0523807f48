/* photo_eval.c: `hdnet eval --photos`: relighting measured on folders of real photographs without
 * ground truth (one folder per person, SPEC section 5 layout; docs/usage.md, "Measuring
 * relighting"). Every photo is relit under the seven presets and under its own estimated light
 * with the chosen rule; photo_metrics.c scores each against the input; the light of a person's
 * first two photos is compared. Medians over photos, split into a tuning and a held-out group by a
 * list of held-out person IDs, and the worst photos by name. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <cjson/cJSON.h>
#include "core/core.h"
#include "io/dataset.h"
#include "eval/eval_json.h"
#include "eval/photo_coverage.h"
#include "eval/photo_metrics.h"
#include "apply/apply.h"
#include "mesh/mesh.h"
#include "eval/eval.h"

static const char *const METRIC_NAMES[HD_PHOTO_METRICS] = {"chroma", "detail", "glow", "seam", "self", "light", "lum",
                                                                "coverage", "band"};

const char *hd_photo_metric_name(int k) { return k >= 0 && k < HD_PHOTO_METRICS ? METRIC_NAMES[k] : "?"; }

/* How bad a value is, larger worse: detail and coverage fall, glow and lum stray from 1 either way. */
static double badness(int k, double v)
{
    if (k == HD_PM_DETAIL || k == HD_PM_COVERAGE) return -v;
    if (k == HD_PM_GLOW || k == HD_PM_LUM) return fabs(log(v > 1e-9 ? v : 1e-9));
    return v;
}

/* The pupils from NAME.tem beside the photo (points 0 and 1); 0 when there is none. */
static int read_tem_pupils(const char *image, float pupils[2][2])
{
    char *path = hd_path_companion(image, ".tem");
    if (!path) return 0;
    FILE *f = fopen(path, "r");
    free(path);
    if (!f) return 0;
    int count = 0, ok = fscanf(f, "%d", &count) == 1 && count >= 2;
    for (int e = 0; ok && e < 2; e++) ok = fscanf(f, "%f %f", &pupils[e][0], &pupils[e][1]) == 2;
    fclose(f);
    return ok && isfinite(pupils[0][0]) && isfinite(pupils[0][1]) && isfinite(pupils[1][0]) && isfinite(pupils[1][1]);
}

/* The held-out IDs of a file: words separated by blanks or lines ('#' starts a comment). */
static hd_status read_ids(const char *path, char ***ids, int *count)
{
    *ids = NULL;
    *count = 0;
    char *text = NULL;
    size_t size = 0;
    hd_status st = hd_read_file(path, 1 << 20, &text, &size);
    if (st != HD_OK) return st;
    int cap = 0;
    for (char *line = strtok(text, "\n"); line && st == HD_OK; line = strtok(NULL, "\n")) {
        char *hash = strchr(line, '#');
        if (hash) *hash = '\0';
        for (char *w = line; *w && st == HD_OK;) {
            while (*w == ' ' || *w == '\t' || *w == '\r') w++;
            size_t n = strcspn(w, " \t\r");
            if (!n) break;
            if (*count == cap) {
                cap = cap ? cap * 2 : 32;
                char **v = realloc(*ids, (size_t)cap * sizeof *v);
                if (!v) {
                    st = hd_fail(HD_ERR_NOMEM, "%s: out of memory", path);
                    break;
                }
                *ids = v;
            }
            if (!((*ids)[*count] = strndup(w, n))) st = hd_fail(HD_ERR_NOMEM, "%s: out of memory", path);
            else (*count)++;
            w += n;
        }
    }
    free(text);
    return st;
}

static int listed(char **ids, int n, const char *id)
{
    for (int i = 0; i < n; i++)
        if (strcmp(ids[i], id) == 0) return 1;
    return 0;
}

/* What the head measures take of a photo: its face's landmarks and skin; sums of the coverage's
 * parts and of the band over the presets (photo_coverage.c). */
typedef struct head_sums {
    const float (*landmarks)[3];
    const unsigned char *skin;
    double ring, face, band;
    int rings, bands;
} head_sums;

/* Scores one relit picture against the input into sums (chroma, detail, glow, seam, lum) and
 * head (coverage, band), and marks its changed pixels in `any`. */
static hd_status score_relit(const hd_image *input, const hd_image *relit, const float pupils[2][2], double *sums,
                             head_sums *head, unsigned char *any)
{
    unsigned char *changed = NULL;
    hd_status st = hd_photo_changed(input, relit, &changed, NULL);
    if (st != HD_OK) return st;
    sums[HD_PM_CHROMA] += hd_photo_chroma(input, relit, changed);
    sums[HD_PM_DETAIL] += hd_photo_detail(input, relit, changed);
    sums[HD_PM_GLOW] += hd_photo_glow(input, relit, changed, pupils);
    double seam = hd_photo_seam(input, relit, changed);
    if (!isfinite(seam)) st = hd_fail(HD_ERR_NOMEM, "photo metrics: out of memory");
    sums[HD_PM_SEAM] += seam;
    sums[HD_PM_LUM] += hd_photo_mean_lum_ratio(input, relit, changed);
    double ring, face;
    if (st == HD_OK) st = hd_photo_coverage_parts(input, relit, head->landmarks, head->skin, &ring, &face);
    if (st == HD_OK && isfinite(ring) && isfinite(face)) head->ring += ring, head->face += face, head->rings++;
    double band = st == HD_OK ? hd_photo_band(input, relit, head->landmarks, head->skin) : NAN;
    if (isfinite(band)) head->band += band, head->bands++;
    size_t P = (size_t)input->width * (size_t)input->height;
    for (size_t p = 0; p < P; p++) any[p] |= changed[p];
    free(changed);
    return st;
}

/* One photo: relit under the presets and its own light; scores into row; its light into light. */
static hd_status score_photo(hd_model *model, hd_aligner *aligner, const hd_sample *s, const hd_photo_rule *how,
                             hd_photo_row *row, float light[HD_SH_COEFFS])
{
    hd_image photo = {0};
    hd_status st = hd_image_read_as(s->image, 3, &photo);
    if (st != HD_OK) return st;
    hd_light_rgb presets[HD_LIGHT_PRESETS];
    for (int k = 0; k < HD_LIGHT_PRESETS; k++) {
        float l[HD_SH_COEFFS];
        hd_light_preset(k, l);
        hd_light_rgb_from_grey(l, &presets[k]);
    }
    hd_apply_request q = {presets, HD_LIGHT_PRESETS, 0, 1, how->rule, HD_BRIGHTNESS_KEEP, how->source, how->guard, "eval"};
    hd_apply_result r;
    st = hd_apply_photo(model, aligner, &photo, &q, &r);
    if (st != HD_OK) {
        hd_image_free(&photo);
        return hd_fail(st, "%s: %s", s->image, hd_error());
    }
    float pupils[2][2];
    row->pupils_from_tem = read_tem_pupils(s->image, pupils);
    if (!row->pupils_from_tem) hd_face_eye_centres((const float (*)[3])r.faces[0].landmarks, pupils);
    memcpy(light, r.face_light[0], sizeof r.face_light[0]);
    const size_t P = (size_t)photo.width * (size_t)photo.height;
    unsigned char *any = hd_calloc(P ? P : 1, 1), *skin = NULL;
    double sums[HD_PHOTO_METRICS] = {0};
    if (!any) st = HD_ERR_NOMEM;
    head_sums head = {(const float (*)[3])r.faces[0].landmarks, NULL, 0, 0, 0, 0, 0};
    if (st == HD_OK) st = hd_photo_skin(&photo, head.landmarks, &skin);
    head.skin = skin;
    for (int k = 0; k < HD_LIGHT_PRESETS && st == HD_OK; k++)
        st = score_relit(&photo, &r.relit[k], pupils, sums, &head, any);
    if (st == HD_OK) {
        for (int m = 0; m < HD_PHOTO_METRICS; m++) row->v[m] = sums[m] / HD_LIGHT_PRESETS;
        row->v[HD_PM_SELF] = hd_photo_mae(&photo, &r.self, any);
        row->v[HD_PM_LIGHT] = NAN; /* per person, filled by the caller */
        row->v[HD_PM_COVERAGE] = head.rings && head.face > 0 ? head.ring / head.face : NAN;
        row->v[HD_PM_BAND] = head.bands ? head.band / head.bands : NAN;
    }
    free(any);
    free(skin);
    hd_apply_result_free(&r);
    hd_image_free(&photo);
    return st;
}

hd_status hd_photo_eval_run(const char *dir, hd_model *model, hd_aligner *aligner, const hd_photo_rule *how,
                            const char *heldout_path, int limit, hd_photo_eval *ev, void (*warn)(const char *message))
{
    memset(ev, 0, sizeof *ev);
    char **ids = NULL;
    int nids = 0;
    hd_status st = heldout_path ? read_ids(heldout_path, &ids, &nids) : HD_OK;
    hd_dataset ds;
    memset(&ds, 0, sizeof ds);
    if (st == HD_OK) st = hd_dataset_scan(dir, &ds, warn);
    if (st == HD_OK && !(ev->rows = hd_calloc((size_t)ds.count, sizeof *ev->rows))) st = HD_ERR_NOMEM;
    int people = limit > 0 && limit < ds.subject_count ? limit : ds.subject_count;
    for (int p = 0; p < people && st == HD_OK; p++) {
        float first[HD_SH_COEFFS];
        int first_row = -1;
        for (int i = ds.subject_start[p]; i < ds.subject_start[p + 1] && st == HD_OK; i++) {
            const hd_sample *s = &ds.samples[i];
            hd_photo_row *row = &ev->rows[ev->count];
            memset(row, 0, sizeof *row);
            snprintf(row->name, sizeof row->name, "%s/%s", s->subject, s->name);
            row->heldout = listed(ids, nids, s->subject);
            float light[HD_SH_COEFFS];
            hd_status e = score_photo(model, aligner, s, how, row, light);
            if (e == HD_ERR_NOMEM) st = e;
            if (e != HD_OK) {
                ev->skipped++;
                if (warn) warn(hd_error());
                continue;
            }
            if (first_row < 0) {
                first_row = ev->count;
                memcpy(first, light, sizeof first);
            } else if (isnan(ev->rows[first_row].v[HD_PM_LIGHT])) {
                ev->rows[first_row].v[HD_PM_LIGHT] = hd_light_difference(first, light);
            }
            ev->count++;
        }
    }
    if (st == HD_OK && ev->count == 0) st = hd_fail(HD_ERR_NOTFOUND, "%s: no photo could be scored", dir);
    for (int i = 0; i < nids; i++) free(ids[i]);
    free(ids);
    hd_dataset_free(&ds);
    if (st != HD_OK) hd_photo_eval_free(ev);
    return st;
}

void hd_photo_eval_free(hd_photo_eval *ev)
{
    free(ev->rows);
    memset(ev, 0, sizeof *ev);
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

hd_status hd_photo_eval_summary(const hd_photo_eval *ev, int group, int metric, double *median, int *worst)
{
    *median = NAN;
    *worst = -1;
    double *v = hd_malloc((size_t)(ev->count ? ev->count : 1) * sizeof *v);
    if (!v) return HD_ERR_NOMEM;
    int n = 0;
    for (int i = 0; i < ev->count; i++) {
        const hd_photo_row *r = &ev->rows[i];
        if ((group == HD_PG_TUNING && r->heldout) || (group == HD_PG_HELDOUT && !r->heldout)) continue;
        if (isnan(r->v[metric])) continue;
        v[n++] = r->v[metric];
        if (*worst < 0 || badness(metric, r->v[metric]) > badness(metric, ev->rows[*worst].v[metric])) *worst = i;
    }
    if (n) {
        qsort(v, (size_t)n, sizeof *v, cmp_double);
        *median = n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
    }
    free(v);
    return HD_OK;
}

static const char *const GROUP_NAMES[3] = {"all", "tuning", "heldout"};

char *hd_photo_eval_json(const hd_photo_eval *ev, const hd_photo_rule *how)
{
    cJSON *root = cJSON_CreateObject();
    if (!root) return hd_fail(HD_ERR_NOMEM, "out of memory building the JSON report"), NULL;
    cJSON_AddStringToObject(root, "rule", how->rule == HD_RULE_PAPER ? "paper" : "ratio");
    cJSON_AddStringToObject(root, "source_light", how->source == HD_SOURCE_LNET ? "lnet" : "fit");
    cJSON_AddNumberToObject(root, "guard", how->guard > 0 ? how->guard : HD_RATIO_GUARD);
    cJSON_AddNumberToObject(root, "photos", ev->count);
    cJSON_AddNumberToObject(root, "skipped", ev->skipped);
    hd_status st = HD_OK;
    cJSON *groups = cJSON_AddObjectToObject(root, "medians");
    cJSON *worst = cJSON_AddObjectToObject(root, "worst");
    for (int g = 0; g < 3 && st == HD_OK; g++) {
        cJSON *o = cJSON_AddObjectToObject(groups, GROUP_NAMES[g]);
        cJSON *w = cJSON_AddObjectToObject(worst, GROUP_NAMES[g]);
        for (int m = 0; m < HD_PHOTO_METRICS && st == HD_OK; m++) {
            double med;
            int at;
            st = hd_photo_eval_summary(ev, g, m, &med, &at);
            if (isfinite(med)) cJSON_AddNumberToObject(o, METRIC_NAMES[m], med);
            else cJSON_AddNullToObject(o, METRIC_NAMES[m]);
            if (at >= 0) {
                cJSON *x = cJSON_AddObjectToObject(w, METRIC_NAMES[m]);
                cJSON_AddStringToObject(x, "photo", ev->rows[at].name);
                cJSON_AddNumberToObject(x, "value", ev->rows[at].v[m]);
            }
        }
    }
    cJSON *rows = cJSON_AddArrayToObject(root, "photos_scored");
    for (int i = 0; i < ev->count; i++) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddItemToArray(rows, o);
        cJSON_AddStringToObject(o, "photo", ev->rows[i].name);
        cJSON_AddBoolToObject(o, "heldout", ev->rows[i].heldout);
        for (int m = 0; m < HD_PHOTO_METRICS; m++)
            if (isfinite(ev->rows[i].v[m])) cJSON_AddNumberToObject(o, METRIC_NAMES[m], ev->rows[i].v[m]);
    }
    char *text = st == HD_OK ? cJSON_Print(root) : NULL;
    cJSON_Delete(root);
    if (st == HD_OK && !text) hd_fail(HD_ERR_NOMEM, "out of memory printing the JSON report");
    return text;
}

hd_status hd_photo_eval_write_json(const char *path, const hd_photo_eval *ev, const hd_photo_rule *how)
{
    return hd_eval_json_write(path, hd_photo_eval_json(ev, how));
}
