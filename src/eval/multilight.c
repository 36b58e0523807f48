/* multilight.c: `hdnet eval --multilight` (docs/evaluation.md, "Real photographs under known
 * lights"). A set of real photographs of each subject under many known point lights (the Extended
 * Yale Face Database B's layout: DIR/lights.csv, one photo a row) scores, on each subject's frontal
 * photo (azimuth 0, elevation 0):
 *   - relighting to a target light's true direction (a distant light, no ambient) against the real
 *     photo under that light;
 *   - light transfer: the frontal photo relit under the light estimated from another subject's
 *     photo under the target light (`hdnet transfer`), against the same real photo;
 *   - the input unchanged, and Lambertian photometric stereo from the subject's other photos (a
 *     bound: it sees the subject, and lacks only cast shadows and what is not Lambertian);
 * all as the scale-invariant MSE x 1000 over the frontal photo's face mask; the model's normals
 * against photometric stereo's in degrees; and the light estimated from every target photo
 * against its true direction. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cjson/cJSON.h>
#include "core/core.h"
#include "eval/eval_json.h"
#include "eval/multilight.h"
#include "eval/eval.h"

#define CSV_MAX_BYTES (16u << 20)
#define CSV_HEADER "file,subject,azimuth_deg,elevation_deg"
/* A photo whose mean is below this is a strobe that did not fire (the set's README): left out. */
#define DARK_MEAN 0.01f
/* Photometric stereo: the lights it takes (in front of the face plane by this much: cos of the
 * angle to the camera's axis) and the pixels it answers (at least PS_MIN_LIT lit photos). */
#define PS_FRONT 0.1f
#define PS_MIN_LIT 5
#define PS_MIN_DET 1e-3

static const char *const ROW_NAMES[HD_ML_ROWS] = {"input unchanged", "hdnet transfer (another subject's photo)",
                                                  "hdnet relight (true direction)", "photometric stereo (bound)"};
static const char *const ROW_KEYS[HD_ML_ROWS] = {"input", "transfer", "relight", "photometric_stereo"};

/* ------------------------------------------------------------------ the set */

void hd_ml_set_free(hd_ml_set *set)
{
    if (!set) return;
    for (int i = 0; i < set->count; i++) free(set->rows[i].file), free(set->rows[i].subject);
    free(set->rows);
    free(set->dir);
    memset(set, 0, sizeof *set);
}

static int parse_float(const char *s, float lo, float hi, float *out)
{
    char *end = NULL;
    const double v = strtod(s, &end);
    if (end == s || *end != '\0' || !isfinite(v) || v < lo || v > hi) return 0;
    *out = (float)v;
    return 1;
}

/* Splits line (modified in place) at commas into at most max fields; returns the count. */
static int split_fields(char *line, char **field, int max)
{
    int n = 0;
    for (char *s = line;; s++) {
        if (n < max) field[n] = s;
        n++;
        s = strchr(s, ',');
        if (!s) break;
        *s = '\0';
    }
    for (int i = 0; i < n && i < max; i++) { /* trim spaces and a trailing CR */
        char *f = field[i];
        while (*f == ' ') f++;
        size_t len = strlen(f);
        while (len > 0 && (f[len - 1] == ' ' || f[len - 1] == '\r')) f[--len] = '\0';
        field[i] = f;
    }
    return n;
}

static hd_status add_row(hd_ml_set *set, int *cap, char **field, const char *path, int line)
{
    hd_ml_row r = {0};
    if (!parse_float(field[2], -180.0f, 180.0f, &r.az))
        return hd_fail(HD_ERR_FORMAT, "%s:%d: azimuth '%s' is not a number in -180..180", path, line, field[2]);
    if (!parse_float(field[3], -90.0f, 90.0f, &r.el))
        return hd_fail(HD_ERR_FORMAT, "%s:%d: elevation '%s' is not a number in -90..90", path, line, field[3]);
    if (!field[0][0] || field[0][0] == '/' || strstr(field[0], ".."))
        return hd_fail(HD_ERR_FORMAT, "%s:%d: file '%s' must be a name inside the set's folder", path, line, field[0]);
    if (!field[1][0]) return hd_fail(HD_ERR_FORMAT, "%s:%d: the subject is empty", path, line);
    if (set->count == *cap) {
        const int next = *cap ? 2 * *cap : 256;
        hd_ml_row *grown = realloc(set->rows, (size_t)next * sizeof *grown);
        if (!grown) return hd_fail(HD_ERR_NOMEM, "%s: out of memory", path);
        set->rows = grown, *cap = next;
    }
    r.file = hd_strdup(field[0]);
    r.subject = hd_strdup(field[1]);
    if (!r.file || !r.subject) {
        free(r.file), free(r.subject);
        return HD_ERR_NOMEM;
    }
    set->rows[set->count++] = r;
    return HD_OK;
}

hd_status hd_ml_set_read(const char *dir, hd_ml_set *set)
{
    memset(set, 0, sizeof *set);
    char *path = hd_path_join(dir, "lights.csv"), *text = NULL;
    if (!path) return HD_ERR_NOMEM;
    size_t size = 0;
    hd_status st = hd_read_file(path, CSV_MAX_BYTES, &text, &size);
    if (st == HD_OK && !(set->dir = hd_strdup(dir))) st = HD_ERR_NOMEM;
    int cap = 0, line = 0;
    for (char *s = text, *next; st == HD_OK && s && *s; s = next) {
        next = strchr(s, '\n');
        if (next) *next++ = '\0';
        line++;
        char *field[4];
        const int n = split_fields(s, field, 4);
        if (line == 1) {
            if (n != 4 || strcmp(field[0], "file") || strcmp(field[1], "subject") || strcmp(field[2], "azimuth_deg") ||
                strcmp(field[3], "elevation_deg"))
                st = hd_fail(HD_ERR_FORMAT, "%s:1: the header must be '%s'", path, CSV_HEADER);
            continue;
        }
        if (n == 1 && !field[0][0]) continue; /* a blank line */
        if (n != 4) st = hd_fail(HD_ERR_FORMAT, "%s:%d: %d columns, want 4 (%s)", path, line, n, CSV_HEADER);
        else st = add_row(set, &cap, field, path, line);
    }
    if (st == HD_OK && set->count == 0) st = hd_fail(HD_ERR_FORMAT, "%s: no photos listed", path);
    free(text);
    free(path);
    if (st != HD_OK) hd_ml_set_free(set);
    return st;
}

void hd_ml_direction(float az, float el, float d[3])
{
    const double a = az * M_PI / 180.0, e = el * M_PI / 180.0;
    d[0] = (float)(-sin(a) * cos(e));
    d[1] = (float)sin(e);
    d[2] = (float)(cos(a) * cos(e));
}

int hd_ml_default_lights(float *az, float *el, int max)
{
    static const float A[] = {25, -25, 50, -50, 70, -70, 0, 0, 35, -35, 60, -60};
    static const float E[] = {0, 0, 0, 0, 0, 0, -35, 45, 40, 40, -20, -20};
    const int n = (int)(sizeof A / sizeof A[0]) < max ? (int)(sizeof A / sizeof A[0]) : max;
    for (int i = 0; i < n; i++) az[i] = A[i], el[i] = E[i];
    return n;
}

/* ------------------------------------------------------------------ photometric stereo */

void hd_ps_free(hd_ps *ps)
{
    if (!ps) return;
    free(ps->sums);
    memset(ps, 0, sizeof *ps);
}

static int lit(float v) { return v > HD_PS_DARK && v < HD_PS_BRIGHT; }

hd_status hd_ps_build(const hd_image *photos, const float (*dirs)[3], int n, hd_ps *ps)
{
    memset(ps, 0, sizeof *ps);
    if (n < 1 || !photos || !dirs) return hd_fail(HD_ERR_ARG, "photometric stereo: no photos");
    const int W = photos[0].width, H = photos[0].height;
    for (int i = 0; i < n; i++)
        if (!photos[i].data || photos[i].width != W || photos[i].height != H || photos[i].channels != 1)
            return hd_fail(HD_ERR_ARG, "photometric stereo: photo %d is not a %d x %d grey picture", i, W, H);
    const size_t P = (size_t)W * H;
    size_t bytes;
    if (!hd_mul3_size(P, 9, sizeof(float), &bytes)) return hd_fail(HD_ERR_ARG, "photometric stereo: too large");
    if (!(ps->sums = hd_calloc(P ? P * 9 : 1, sizeof(float)))) return HD_ERR_NOMEM;
    ps->width = W, ps->height = H;
    for (int i = 0; i < n; i++) {
        const float *l = dirs[i];
        for (size_t p = 0; p < P; p++) {
            const float v = photos[i].data[p];
            if (!lit(v)) continue;
            float *s = ps->sums + 9 * p;
            s[0] += l[0] * l[0], s[1] += l[0] * l[1], s[2] += l[0] * l[2];
            s[3] += l[1] * l[1], s[4] += l[1] * l[2], s[5] += l[2] * l[2];
            s[6] += v * l[0], s[7] += v * l[1], s[8] += v * l[2];
        }
    }
    return HD_OK;
}

int hd_ps_solve(const hd_ps *ps, size_t p, const float *leave_value, const float leave_dir[3], float b[3])
{
    double s[9];
    for (int k = 0; k < 9; k++) s[k] = ps->sums[9 * p + k];
    if (leave_value && leave_dir && lit(*leave_value)) {
        const float *l = leave_dir, v = *leave_value;
        s[0] -= l[0] * l[0], s[1] -= l[0] * l[1], s[2] -= l[0] * l[2];
        s[3] -= l[1] * l[1], s[4] -= l[1] * l[2], s[5] -= l[2] * l[2];
        s[6] -= v * l[0], s[7] -= v * l[1], s[8] -= v * l[2];
    }
    /* the trace counts the lit photos (unit lights): fewer than PS_MIN_LIT give no answer */
    if (s[0] + s[3] + s[5] < PS_MIN_LIT - 0.5) return 0;
    const double a = s[0], bb = s[1], c = s[2], d = s[3], e = s[4], f = s[5];
    const double c00 = d * f - e * e, c01 = c * e - bb * f, c02 = bb * e - c * d;
    const double det = a * c00 + bb * c01 + c * c02;
    if (!(det > PS_MIN_DET)) return 0;
    const double c11 = a * f - c * c, c12 = bb * c - a * e, c22 = a * d - bb * bb;
    const double r0 = s[6], r1 = s[7], r2 = s[8];
    b[0] = (float)((c00 * r0 + c01 * r1 + c02 * r2) / det);
    b[1] = (float)((c01 * r0 + c11 * r1 + c12 * r2) / det);
    b[2] = (float)((c02 * r0 + c12 * r1 + c22 * r2) / det);
    return isfinite(b[0]) && isfinite(b[1]) && isfinite(b[2]);
}

double hd_ml_si_mse(const float *out, const float *truth, const float *mask, size_t P)
{
    double oo = 0, ot = 0, tt = 0;
    long n = 0;
    for (size_t p = 0; p < P; p++) {
        if (mask && !(mask[p] > 0.5f)) continue;
        oo += (double)out[p] * out[p], ot += (double)out[p] * truth[p], tt += (double)truth[p] * truth[p];
        n++;
    }
    if (n == 0) return NAN;
    const double gain = oo > 0 ? ot / oo : 0.0;
    /* sum (g o - t)^2 = g^2 oo - 2 g ot + tt, with g = ot / oo: tt - ot^2 / oo */
    const double sse = tt - gain * ot;
    return 1000.0 * (sse > 0 ? sse : 0.0) / (double)n;
}

/* ------------------------------------------------------------------ statistics */

/* A growing list of values, summarised as mean and median. */
typedef struct values {
    double *v;
    long n, cap;
} values;

static hd_status push(values *s, double v)
{
    if (!isfinite(v)) return HD_OK;
    if (s->n == s->cap) {
        const long next = s->cap ? 2 * s->cap : 64;
        double *grown = realloc(s->v, (size_t)next * sizeof *grown);
        if (!grown) return HD_ERR_NOMEM;
        s->v = grown, s->cap = next;
    }
    s->v[s->n++] = v;
    return HD_OK;
}

static int by_value(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static hd_ml_stat summary(values *s)
{
    hd_ml_stat r = {NAN, NAN, s->n};
    if (s->n == 0) return r;
    double sum = 0;
    for (long i = 0; i < s->n; i++) sum += s->v[i];
    qsort(s->v, (size_t)s->n, sizeof *s->v, by_value);
    r.mean = sum / (double)s->n;
    r.median = s->n % 2 ? s->v[s->n / 2] : 0.5 * (s->v[s->n / 2 - 1] + s->v[s->n / 2]);
    return r;
}

/* ------------------------------------------------------------------ the evaluation */

/* What is kept of one subject: its rows' photos (grey) and, for the target lights, the light
 * estimated from its photo. */
typedef struct subject {
    const char *name;
    int frontal;                 /* index into the set's rows, -1 if none */
    int target[HD_ML_MAX_LIGHTS]; /* the row of each target light, -1 if absent or dark */
    int est_found[HD_ML_MAX_LIGHTS];
    float est[HD_ML_MAX_LIGHTS][HD_SH_COEFFS];
    values rows[HD_ML_ROWS], normals, light_error; /* its own share of the run's lists */
} subject;

typedef struct run {
    const hd_ml_set *set;
    hd_model *model;
    hd_aligner *aligner;
    const hd_ml_options *o;
    hd_ml_report *r;
    void (*warn)(const char *message);
    subject *subj;
    int nsubj, nsubj0;
    values rows[HD_ML_ROWS], per_light[HD_ML_ROWS][HD_ML_MAX_LIGHTS];
    values normals, normals_flat, normals_coarse, light_error;
} run;

static void say(const run *R, const char *what, const char *reason)
{
    if (!R->warn) return;
    char msg[512];
    snprintf(msg, sizeof msg, "%s: %s", what, reason);
    R->warn(msg);
}

static void note_missed(hd_ml_report *r, const char *file)
{
    if (r->nmissed < HD_ML_MAX_MISSED) snprintf(r->missed[r->nmissed++], sizeof r->missed[0], "%s", file);
}

static int same_angle(float a, float b) { return fabsf(a - b) < 0.5f; }

/* The subjects in order of first appearance, each with its frontal row and target rows. */
static hd_status group_subjects(run *R)
{
    const hd_ml_set *set = R->set;
    R->subj = hd_calloc((size_t)set->count, sizeof *R->subj);
    if (!R->subj) return HD_ERR_NOMEM;
    for (int i = 0; i < set->count; i++) {
        int k = 0;
        while (k < R->nsubj && strcmp(R->subj[k].name, set->rows[i].subject)) k++;
        if (k == R->nsubj) {
            subject *s = &R->subj[R->nsubj++];
            s->name = set->rows[i].subject;
            s->frontal = -1;
            for (int j = 0; j < HD_ML_MAX_LIGHTS; j++) s->target[j] = -1;
        }
        subject *s = &R->subj[k];
        if (same_angle(set->rows[i].az, 0) && same_angle(set->rows[i].el, 0)) s->frontal = i;
        for (int j = 0; j < R->r->nlights; j++)
            if (same_angle(set->rows[i].az, R->r->az[j]) && same_angle(set->rows[i].el, R->r->el[j])) s->target[j] = i;
    }
    return HD_OK;
}

/* A picture's grey (the mean of its 3 channels). */
static void grey_of(const hd_image *rgb, float *out)
{
    const size_t P = (size_t)rgb->width * rgb->height;
    for (size_t p = 0; p < P; p++)
        out[p] = (rgb->data[p] + rgb->data[P + p] + rgb->data[2 * P + p]) / 3.0f;
}

/* Row i's photo as the model takes it (3 channels; a grey photo's value in each) into rgb (may be
 * NULL), and as grey (the mean of its channels, as the relit pictures are scored) into grey. */
static hd_status load(const run *R, int i, hd_image *grey, hd_image *rgb)
{
    char *path = hd_path_join(R->set->dir, R->set->rows[i].file);
    if (!path) return HD_ERR_NOMEM;
    hd_image colour = {0};
    hd_status st = hd_image_read_as(path, 3, &colour);
    if (st == HD_OK) st = hd_image_alloc(grey, colour.width, colour.height, 1);
    if (st == HD_OK) grey_of(&colour, grey->data);
    if (st == HD_OK && rgb) *rgb = colour;
    else hd_image_free(&colour);
    free(path);
    return st;
}

static float mean_of(const hd_image *im)
{
    double s = 0;
    const size_t n = (size_t)im->width * im->height * im->channels;
    for (size_t i = 0; i < n; i++) s += im->data[i];
    return n ? (float)(s / (double)n) : 0.0f;
}

/* The light direction an SH light's first band points to, in the camera frame (docs/conventions.md:
 * the band's shading is c1 (l3 x + l2 y - l1 z)); 0 when it has none. */
static int sh_direction(const float l[HD_SH_COEFFS], float d[3])
{
    const float v[3] = {l[3], l[2], -l[1]};
    const float len = sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (!(len > 1e-9f)) return 0;
    for (int k = 0; k < 3; k++) d[k] = v[k] / len;
    return 1;
}

static double angle_deg(const float a[3], const float b[3])
{
    double c = (double)a[0] * b[0] + (double)a[1] * b[1] + (double)a[2] * b[2];
    c = c > 1 ? 1 : c < -1 ? -1 : c;
    return acos(c) * 180.0 / M_PI;
}

/* Pass 1: the light estimated from every target photo, and its error against the truth. Also
 * marks dark photos absent. */
static hd_status estimate_lights(run *R, void (*progress)(int done, int total, const char *subject))
{
    hd_status st = HD_OK;
    for (int s = 0; s < R->nsubj && st == HD_OK; s++) {
        if (s > 0 && progress) progress(s, 2 * R->nsubj, R->subj[s - 1].name);
        for (int j = 0; j < R->r->nlights && st == HD_OK; j++) {
            subject *S = &R->subj[s];
            const int i = S->target[j];
            if (i < 0) continue;
            hd_image grey = {0}, rgb = {0};
            st = load(R, i, &grey, &rgb);
            if (st == HD_OK && mean_of(&grey) < DARK_MEAN) {
                say(R, R->set->rows[i].file, "dark (the strobe did not fire?): left out");
                R->r->photos_dark++;
                S->target[j] = -1;
            } else if (st == HD_OK) {
                int nf = 0;
                st = hd_estimate_face_light_photo(R->model, R->aligner, &rgb, R->o->source, S->est[j], &nf);
                if (st == HD_ERR_NOTFOUND) {
                    hd_clear_error();
                    st = HD_OK;
                    note_missed(R->r, R->set->rows[i].file);
                } else if (st == HD_OK) {
                    S->est_found[j] = 1;
                    float truth[3], got[3];
                    hd_ml_direction(R->set->rows[i].az, R->set->rows[i].el, truth);
                    if (sh_direction(S->est[j], got)) {
                        const double e = angle_deg(truth, got);
                        st = push(&R->light_error, e);
                        if (st == HD_OK) st = push(&S->light_error, e);
                    }
                }
            }
            hd_image_free(&grey), hd_image_free(&rgb);
        }
    }
    return st;
}


typedef struct sheet_row {
    hd_image truth, relit, transfer, ps;
} sheet_row;

/* One subject's model rows: relit under every target light's true direction and under the lights
 * of the references, scored against the real photos; the sheet's pictures kept when asked. */
static hd_status model_rows(run *R, int s, const hd_image *frontal, const float *mask, const hd_image *truths,
                            sheet_row *sheet)
{
    const subject *S = &R->subj[s];
    const int L = R->r->nlights, refs = R->o->refs > 0 ? R->o->refs : 3;
    const int nref = refs < R->nsubj - 1 ? refs : R->nsubj - 1;
    const size_t P = (size_t)frontal->width * frontal->height;
    hd_light_rgb *lights = hd_malloc((size_t)L * (1 + (nref > 0 ? nref : 0)) * sizeof *lights);
    int *light_of = hd_malloc((size_t)L * (1 + (nref > 0 ? nref : 0)) * sizeof *light_of);
    float *g = hd_malloc((P ? P : 1) * sizeof(float));
    if (!lights || !light_of || !g) {
        free(lights), free(light_of), free(g);
        return HD_ERR_NOMEM;
    }
    int count = 0, nrelight = 0;
    for (int j = 0; j < L; j++) { /* the true directions, no ambient (hdnet's azimuth is the set's negated) */
        if (S->target[j] < 0) continue;
        float sh[HD_SH_COEFFS];
        hd_light_from_direction(-R->r->az[j], R->r->el[j], 1.0f, 0.0f, sh);
        hd_light_rgb_from_grey(sh, &lights[count]);
        light_of[count++] = j;
    }
    nrelight = count;
    for (int j = 0; j < L; j++) { /* the references: dealt round-robin over the other subjects */
        if (S->target[j] < 0) continue;
        for (int k = 0; k < nref; k++) {
            const int q = (s + 1 + (j * nref + k) % (R->nsubj - 1)) % R->nsubj;
            if (R->subj[q].target[j] < 0) continue;
            if (!R->subj[q].est_found[j]) {
                R->r->refs_missed++;
                continue;
            }
            hd_light_rgb_from_grey(R->subj[q].est[j], &lights[count]);
            light_of[count++] = j;
        }
    }
    hd_apply_request q = {lights, count, 0, 0, R->o->rule, R->o->brightness, R->o->source, R->o->guard, "eval"};
    hd_apply_result res;
    hd_status st = hd_apply_photo(R->model, R->aligner, frontal, &q, &res);
    const int applied = st == HD_OK;
    for (int c = 0; c < count && st == HD_OK; c++) {
        const int j = light_of[c], row = c < nrelight ? HD_ML_RELIGHT : HD_ML_TRANSFER;
        grey_of(&res.relit[c], g);
        const double e = hd_ml_si_mse(g, truths[j].data, mask, P);
        st = push(&R->rows[row], e);
        if (st == HD_OK) st = push(&R->per_light[row][j], e);
        if (st == HD_OK) st = push(&R->subj[s].rows[row], e);
        if (st == HD_OK && sheet) {
            hd_image *keep = row == HD_ML_RELIGHT ? &sheet[j].relit : &sheet[j].transfer;
            if (!keep->data) st = hd_image_convert(&res.relit[c], 3, keep);
        }
    }
    if (applied) hd_apply_result_free(&res);
    free(lights), free(light_of), free(g);
    return st;
}

static hd_status write_sheet(const run *R, const subject *S, const hd_image *frontal, sheet_row *rows,
                             const hd_photo_maps *maps, const hd_image *ps_normal)
{
    const int L = R->r->nlights;
    hd_sheet sh;
    hd_status st = hd_sheet_init(&sh, L + 1, 4, 128, 4);
    if (st != HD_OK) return st;
    /* row 0: the frontal photo, the model's normals, photometric stereo's, the face mask */
    st = hd_sheet_put(&sh, 0, 0, frontal, HD_SHEET_PICTURE);
    if (st == HD_OK) st = hd_sheet_put(&sh, 0, 1, &maps->normal, HD_SHEET_NORMAL);
    if (st == HD_OK) st = hd_sheet_put(&sh, 0, 2, ps_normal, HD_SHEET_NORMAL);
    if (st == HD_OK) st = hd_sheet_put(&sh, 0, 3, &maps->mask, HD_SHEET_PICTURE);
    /* then per light: the truth, the relit, the transfer, the bound */
    for (int j = 0; j < L && st == HD_OK; j++) {
        const hd_image *col[4] = {&rows[j].truth, &rows[j].relit, &rows[j].transfer, &rows[j].ps};
        for (int c = 0; c < 4 && st == HD_OK; c++)
            if (col[c]->data) st = hd_sheet_put(&sh, j + 1, c, col[c], HD_SHEET_PICTURE);
    }
    char name[300];
    snprintf(name, sizeof name, "%s.png", S->name);
    for (char *c = name; *c; c++)
        if (*c == '/') *c = '_';
    char *path = st == HD_OK ? hd_path_join(R->o->sheets, name) : NULL;
    if (st == HD_OK && !path) st = HD_ERR_NOMEM;
    if (st == HD_OK) st = hd_sheet_write(&sh, path);
    free(path);
    hd_sheet_free(&sh);
    return st;
}

/* The model's normals (maps->normal, the first face's) against photometric stereo's over the face
 * (maps->mask), with a flat map's and the coarse normals' (the canonical mesh posed on the
 * landmarks, what the model starts from): subject s's mean angle into R's three lists, and the
 * model's also into the subject's own.
 * ps_normal, when allocated, receives photometric stereo's normals for the sheet. */
static hd_status score_normals(run *R, int s, const hd_ps *ps, const hd_photo_maps *maps, size_t P, hd_image *ps_normal)
{
    const float *mask = maps->mask.data;
    hd_image coarse = {0}, coarse_cover = {0};
    hd_status st = hd_warp_back(&maps->faces[0], &maps->faces[0].normal, NULL, &coarse, &coarse_cover);
    double sum = 0, flat = 0, crs = 0;
    long cnt = 0;
    for (size_t p = 0; st == HD_OK && p < P; p++) {
        float b[3];
        if (!(mask[p] > 0.5f) || !hd_ps_solve(ps, p, NULL, NULL, b)) continue;
        const float len = sqrtf(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
        if (!(len > 1e-6f)) continue;
        const float t[3] = {b[0] / len, b[1] / len, b[2] / len}, z[3] = {0, 0, 1};
        const float mn[3] = {maps->normal.data[p], maps->normal.data[P + p], maps->normal.data[2 * P + p]};
        float cn[3] = {coarse.data[p], coarse.data[P + p], coarse.data[2 * P + p]};
        if (ps_normal->data)
            for (int k = 0; k < 3; k++) ps_normal->data[(size_t)k * P + p] = t[k];
        if (mn[0] == 0 && mn[1] == 0 && mn[2] == 0) continue;
        const float cl = sqrtf(cn[0] * cn[0] + cn[1] * cn[1] + cn[2] * cn[2]);
        if (!(coarse_cover.data[p] > 0.5f) || !(cl > 1e-6f)) cn[0] = mn[0], cn[1] = mn[1], cn[2] = mn[2];
        else cn[0] /= cl, cn[1] /= cl, cn[2] /= cl;
        sum += angle_deg(mn, t), flat += angle_deg(z, t), crs += angle_deg(cn, t), cnt++;
    }
    if (st == HD_OK && cnt > 0) st = push(&R->normals, sum / (double)cnt);
    if (st == HD_OK && cnt > 0) st = push(&R->subj[s].normals, sum / (double)cnt);
    if (st == HD_OK && cnt > 0) st = push(&R->normals_flat, flat / (double)cnt);
    if (st == HD_OK && cnt > 0) st = push(&R->normals_coarse, crs / (double)cnt);
    hd_image_free(&coarse), hd_image_free(&coarse_cover);
    return st;
}

/* Pass 2 for subject s: photometric stereo from its photos, the model's normals against it, the
 * four rows against the real photos. */
static hd_status score_subject(run *R, int s, int *scored)
{
    *scored = 1;
    const subject *S = &R->subj[s];
    const hd_ml_set *set = R->set;
    const int L = R->r->nlights;
    /* the subject's photos that are not dark; those with the light in front of the face plane
     * make the photometric stereo */
    int n = 0;
    for (int i = 0; i < set->count; i++) n += !strcmp(set->rows[i].subject, S->name);
    hd_image *ph = hd_calloc((size_t)n, sizeof *ph), *front = hd_calloc((size_t)n, sizeof *front);
    hd_image truths[HD_ML_MAX_LIGHTS], frontal = {0}, ps_normal = {0};
    float (*dirs)[3] = hd_malloc((size_t)n * sizeof *dirs);
    int in_ps[HD_ML_MAX_LIGHTS] = {0};
    sheet_row *sheet = R->o->sheets ? hd_calloc((size_t)L, sizeof *sheet) : NULL;
    memset(truths, 0, sizeof truths);
    hd_status st = ph && front && dirs && (sheet || !R->o->sheets) ? HD_OK : HD_ERR_NOMEM;
    int m = 0, nf = 0, fm = -1;
    for (int i = 0; i < set->count && st == HD_OK; i++) {
        if (strcmp(set->rows[i].subject, S->name)) continue;
        st = load(R, i, &ph[m], i == S->frontal ? &frontal : NULL);
        if (st == HD_OK && mean_of(&ph[m]) < DARK_MEAN) {
            hd_image_free(&ph[m]);
            continue;
        }
        float d[3];
        hd_ml_direction(set->rows[i].az, set->rows[i].el, d);
        const int use = d[2] >= PS_FRONT;
        for (int j = 0; j < L && st == HD_OK; j++)
            if (S->target[j] == i) st = hd_image_convert(&ph[m], 1, &truths[j]), in_ps[j] = use;
        if (st == HD_OK && m > 0 && (ph[m].width != ph[0].width || ph[m].height != ph[0].height))
            st = hd_fail(HD_ERR_FORMAT, "%s/%s: %d x %d, the subject's other photos are %d x %d", set->dir,
                         set->rows[i].file, ph[m].width, ph[m].height, ph[0].width, ph[0].height);
        if (st == HD_OK && i == S->frontal) fm = m;
        if (st == HD_OK && use) front[nf] = ph[m], memcpy(dirs[nf++], d, sizeof d);
        if (st == HD_OK) m++;
    }
    if (st == HD_OK && fm < 0) { /* the frontal photo is dark: nothing to relight */
        say(R, set->rows[S->frontal].file, "the frontal photo is dark: the subject is left out");
        *scored = 0;
    }
    hd_ps ps = {0};
    if (st == HD_OK && fm >= 0) st = hd_ps_build(front, (const float (*)[3])dirs, nf, &ps);
    const size_t P = st == HD_OK ? (size_t)frontal.width * frontal.height : 0;
    hd_photo_maps maps;
    memset(&maps, 0, sizeof maps);
    if (st == HD_OK && *scored) st = hd_decompose_photo_maps(R->model, R->aligner, &frontal, &maps);
    int found = st == HD_OK && *scored;
    if (st == HD_ERR_NOTFOUND && *scored) {
        hd_clear_error();
        st = HD_OK;
        R->r->sources_missed++;
        note_missed(R->r, set->rows[S->frontal].file);
    }
    float *mask = found ? maps.mask.data : NULL, *pred = hd_malloc((P ? P : 1) * sizeof(float));
    if (st == HD_OK && !pred) st = HD_ERR_NOMEM;
    if (st == HD_OK && found && R->o->sheets) st = hd_image_alloc(&ps_normal, frontal.width, frontal.height, 3);
    if (st == HD_OK && found) st = score_normals(R, s, &ps, &maps, P, &ps_normal);
    /* the input unchanged and the bound, per target light */
    for (int j = 0; j < L && st == HD_OK && found; j++) {
        if (S->target[j] < 0 || !truths[j].data) continue;
        float l[3];
        hd_ml_direction(set->rows[S->target[j]].az, set->rows[S->target[j]].el, l);
        for (size_t p = 0; p < P; p++) {
            float b[3];
            const float v = truths[j].data[p];
            pred[p] = hd_ps_solve(&ps, p, in_ps[j] ? &v : NULL, l, b) ? fmaxf(0.0f, b[0] * l[0] + b[1] * l[1] + b[2] * l[2]) : 0.0f;
        }
        double e = hd_ml_si_mse(pred, truths[j].data, mask, P);
        st = push(&R->rows[HD_ML_PS], e);
        if (st == HD_OK) st = push(&R->per_light[HD_ML_PS][j], e);
        if (st == HD_OK) st = push(&R->subj[s].rows[HD_ML_PS], e);
        e = hd_ml_si_mse(ph[fm].data, truths[j].data, mask, P);
        if (st == HD_OK) st = push(&R->rows[HD_ML_INPUT], e);
        if (st == HD_OK) st = push(&R->per_light[HD_ML_INPUT][j], e);
        if (st == HD_OK) st = push(&R->subj[s].rows[HD_ML_INPUT], e);
        if (st == HD_OK && sheet) {
            st = hd_image_convert(&truths[j], 1, &sheet[j].truth);
            if (st == HD_OK) st = hd_image_alloc(&sheet[j].ps, frontal.width, frontal.height, 1);
            for (size_t p = 0; st == HD_OK && p < P; p++) sheet[j].ps.data[p] = fminf(1.0f, pred[p]); /* the bound as shown */
        }
    }
    if (st == HD_OK && found) st = model_rows(R, s, &frontal, mask, truths, sheet);
    if (st == HD_OK && found && sheet) st = write_sheet(R, S, &frontal, sheet, &maps, &ps_normal);
    for (int i = 0; ph && i < n; i++) hd_image_free(&ph[i]); /* front[] shares their pixels */
    for (int j = 0; j < L; j++) {
        hd_image_free(&truths[j]);
        if (sheet) hd_image_free(&sheet[j].truth), hd_image_free(&sheet[j].relit), hd_image_free(&sheet[j].transfer),
            hd_image_free(&sheet[j].ps);
    }
    hd_photo_maps_free(&maps);
    hd_ps_free(&ps);
    hd_image_free(&frontal), hd_image_free(&ps_normal);
    free(ph), free(front), free(dirs), free(pred), free(sheet);
    return st;
}

hd_status hd_ml_run(const char *dir, hd_model *model, hd_aligner *aligner, const hd_ml_options *o, hd_ml_report *r,
                    void (*warn)(const char *message), void (*progress)(int done, int total, const char *subject))
{
    memset(r, 0, sizeof *r);
    if (!dir || !model || !aligner || !o) return hd_fail(HD_ERR_ARG, "eval --multilight: a set, a model and an aligner are needed");
    if (o->nlights < 0 || o->nlights > HD_ML_MAX_LIGHTS)
        return hd_fail(HD_ERR_ARG, "eval --multilight: %d target lights (at most %d)", o->nlights, HD_ML_MAX_LIGHTS);
    if (o->nlights == 0) r->nlights = hd_ml_default_lights(r->az, r->el, HD_ML_MAX_LIGHTS);
    else {
        r->nlights = o->nlights;
        memcpy(r->az, o->az, sizeof r->az), memcpy(r->el, o->el, sizeof r->el);
    }
    hd_ml_set set;
    hd_status st = hd_ml_set_read(dir, &set);
    if (st != HD_OK) return st;
    run R;
    memset(&R, 0, sizeof R);
    R.set = &set, R.model = model, R.aligner = aligner, R.o = o, R.r = r, R.warn = warn;
    st = group_subjects(&R);
    R.nsubj0 = R.nsubj; /* every subject's lists are freed, also those past --limit */
    if (st == HD_OK && o->limit > 0 && o->limit < R.nsubj) R.nsubj = o->limit;
    if (st == HD_OK && o->sheets) st = hd_mkdirs(o->sheets);
    for (int s = 0; s < R.nsubj && st == HD_OK; s++) {
        if (R.subj[s].frontal < 0) say(&R, R.subj[s].name, "no frontal photo (azimuth 0, elevation 0): left out");
        for (int j = 0; j < r->nlights; j++) r->photos_absent += R.subj[s].target[j] < 0;
    }
    if (st == HD_OK) st = estimate_lights(&R, progress);
    for (int s = 0; s < R.nsubj && st == HD_OK; s++) {
        if (R.subj[s].frontal < 0) continue;
        int scored = 0;
        st = score_subject(&R, s, &scored);
        if (st != HD_OK) break;
        r->subjects += scored;
        if (progress) progress(R.nsubj + s + 1, 2 * R.nsubj, R.subj[s].name);
    }
    for (int k = 0; k < HD_ML_ROWS; k++) {
        r->rows[k] = summary(&R.rows[k]);
        for (int j = 0; j < r->nlights; j++) r->per_light[k][j] = summary(&R.per_light[k][j]);
    }
    r->normals = summary(&R.normals), r->normals_flat = summary(&R.normals_flat), r->light_error = summary(&R.light_error);
    r->normals_coarse = summary(&R.normals_coarse);
    r->per_subject = R.nsubj > 0 ? hd_calloc((size_t)R.nsubj, sizeof *r->per_subject) : NULL;
    if (st == HD_OK && R.nsubj > 0 && !r->per_subject) st = HD_ERR_NOMEM;
    for (int s = 0; r->per_subject && s < R.nsubj; s++) {
        hd_ml_subject *o = &r->per_subject[r->nper_subject];
        subject *S = &R.subj[s];
        if (S->frontal < 0) continue;
        snprintf(o->name, sizeof o->name, "%s", S->name);
        for (int k = 0; k < HD_ML_ROWS; k++) o->rows[k] = summary(&S->rows[k]);
        o->normals = summary(&S->normals), o->light_error = summary(&S->light_error);
        r->nper_subject++;
    }
    for (int k = 0; k < HD_ML_ROWS; k++) {
        free(R.rows[k].v);
        for (int j = 0; j < HD_ML_MAX_LIGHTS; j++) free(R.per_light[k][j].v);
    }
    free(R.normals.v), free(R.normals_flat.v), free(R.normals_coarse.v), free(R.light_error.v);
    for (int s = 0; R.subj && s < R.nsubj0; s++) {
        for (int k = 0; k < HD_ML_ROWS; k++) free(R.subj[s].rows[k].v);
        free(R.subj[s].normals.v), free(R.subj[s].light_error.v);
    }
    free(R.subj);
    hd_ml_set_free(&set);
    return st;
}

/* ------------------------------------------------------------------ the report as JSON */

static cJSON *stat_json(const hd_ml_stat *s)
{
    cJSON *o = cJSON_CreateObject();
    if (!o) return NULL;
    if (s->n > 0) {
        cJSON_AddNumberToObject(o, "mean", s->mean);
        cJSON_AddNumberToObject(o, "median", s->median);
    } else {
        cJSON_AddNullToObject(o, "mean");
        cJSON_AddNullToObject(o, "median");
    }
    cJSON_AddNumberToObject(o, "n", (double)s->n);
    return o;
}

char *hd_ml_report_json(const hd_ml_report *r)
{
    cJSON *root = cJSON_CreateObject(), *rows = cJSON_AddObjectToObject(root, "si_mse_x1000");
    cJSON *lights = cJSON_AddArrayToObject(root, "lights"), *missed = cJSON_AddArrayToObject(root, "missed");
    if (!root || !rows || !lights || !missed) {
        cJSON_Delete(root);
        hd_fail(HD_ERR_NOMEM, "eval: out of memory for the report");
        return NULL;
    }
    cJSON_AddStringToObject(root, "metric", "scale-invariant MSE x 1000 over the frontal photo's face mask");
    for (int k = 0; k < HD_ML_ROWS; k++) cJSON_AddItemToObject(rows, ROW_KEYS[k], stat_json(&r->rows[k]));
    for (int j = 0; j < r->nlights; j++) {
        cJSON *l = cJSON_CreateObject();
        cJSON_AddNumberToObject(l, "azimuth_deg", r->az[j]);
        cJSON_AddNumberToObject(l, "elevation_deg", r->el[j]);
        for (int k = 0; k < HD_ML_ROWS; k++) cJSON_AddItemToObject(l, ROW_KEYS[k], stat_json(&r->per_light[k][j]));
        cJSON_AddItemToArray(lights, l);
    }
    cJSON_AddItemToObject(root, "normals_deg", stat_json(&r->normals));
    cJSON_AddItemToObject(root, "normals_flat_deg", stat_json(&r->normals_flat));
    cJSON_AddItemToObject(root, "normals_coarse_deg", stat_json(&r->normals_coarse));
    cJSON_AddItemToObject(root, "light_error_deg", stat_json(&r->light_error));
    cJSON_AddNumberToObject(root, "subjects", r->subjects);
    cJSON_AddNumberToObject(root, "sources_missed", r->sources_missed);
    cJSON_AddNumberToObject(root, "references_missed", r->refs_missed);
    cJSON_AddNumberToObject(root, "photos_absent", r->photos_absent);
    cJSON_AddNumberToObject(root, "photos_dark", r->photos_dark);
    for (int i = 0; i < r->nmissed; i++) cJSON_AddItemToArray(missed, cJSON_CreateString(r->missed[i]));
    cJSON *subjects = cJSON_AddArrayToObject(root, "per_subject");
    for (int i = 0; subjects && i < r->nper_subject; i++) {
        const hd_ml_subject *o = &r->per_subject[i];
        cJSON *e = cJSON_CreateObject();
        cJSON_AddStringToObject(e, "subject", o->name);
        for (int k = 0; k < HD_ML_ROWS; k++) cJSON_AddItemToObject(e, ROW_KEYS[k], stat_json(&o->rows[k]));
        cJSON_AddItemToObject(e, "normals_deg", stat_json(&o->normals));
        cJSON_AddItemToObject(e, "light_error_deg", stat_json(&o->light_error));
        cJSON_AddItemToArray(subjects, e);
    }
    char *text = cJSON_Print(root);
    cJSON_Delete(root);
    if (!text) hd_fail(HD_ERR_NOMEM, "eval: out of memory for the report");
    return text;
}

hd_status hd_ml_report_write_json(const char *path, const hd_ml_report *r)
{
    return hd_eval_json_write(path, hd_ml_report_json(r));
}

void hd_ml_report_free(hd_ml_report *r)
{
    if (!r) return;
    free(r->per_subject);
    r->per_subject = NULL;
    r->nper_subject = 0;
}

const char *hd_ml_row_name(int row) { return row >= 0 && row < HD_ML_ROWS ? ROW_NAMES[row] : "?"; }
