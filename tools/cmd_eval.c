/* cmd_eval.c: `hdnet eval`: the paper's metrics (SPEC section 7) of a model, or of predictions
 * written by any system in `hdnet decompose`'s layout, on a set with ground truth, with the
 * baselines under it; with --photos, relighting measured on folders of real photos (issue 12's
 * chroma, detail, glow, seam, self, light); a table on the terminal and the same in JSON. */
#include <stdio.h>
#include <stdlib.h>
#include <math.h>
#include <string.h>
#include "apply_cli.h"
#include "cli.h"
#include "hdnet_tool.h"

CLI_COMMAND("eval", cmd_eval, "score a model or predictions on a set with ground truth (the paper's metrics)")

static void warn(const char *message) { fprintf(stderr, "hdnet eval: skipped: %s\n", message); }

static void cell(int has, const char *fmt, double v)
{
    if (has) printf(fmt, v);
    else printf("%7s ", "-");
}

static void print_table(const hd_eval_report *r)
{
    printf("%ld images (%ld skipped); lighting classes: k-means, k = %d%s", r->images, r->skipped, r->kmeans_k,
           r->source == HD_SOURCE_FIT ? "; the prediction's light: the fit of S on N (--source-light fit)" : "");
    if (r->repose > 0) printf("; normals turned by %g of the way to the coarse normals' pose (--repose)", (double)r->repose);
    printf("\n\n");
    printf("%-28s %15s %7s %7s %7s | %7s %7s %7s | %7s %7s | %7s | %7s\n", "method", "normal (deg)", "<20%", "<25%",
           "<30%", "alb MAE", "RMSE", "si MAE", "rec MAE", "RMSE", "sh MAE", "light%");
    for (int i = 0; i < r->nrows; i++) {
        const hd_eval_row *w = &r->rows[i];
        printf("%-28s ", w->name);
        if (w->has_normal) printf("%6.2f +- %5.2f ", w->normal_mean, w->normal_std);
        else printf("%15s ", "-");
        for (int k = 0; k < HD_EVAL_THRESHOLDS; k++) cell(w->has_normal, "%7.1f ", w->normal_under[k]);
        printf("| ");
        cell(w->has_albedo, "%7.4f ", w->albedo_mae);
        cell(w->has_albedo, "%7.4f ", w->albedo_rmse);
        cell(w->has_albedo, "%7.4f ", w->albedo_si_mae);
        printf("| ");
        cell(w->has_recon, "%7.4f ", w->recon_mae);
        cell(w->has_recon, "%7.4f ", w->recon_rmse);
        printf("| ");
        cell(w->has_shading, "%7.4f ", w->shading_mae);
        printf("| ");
        cell(w->has_light, "%7.2f", w->light_accuracy);
        printf("\n");
    }
}

/* The targets of issue 12 (docs/usage.md, "Measuring relighting"), as text. */
static const char *const PHOTO_TARGETS[HD_PHOTO_METRICS] = {"<= 10", ">= 0.95", "0.9..1.1", "<= 1.5",
                                                           "<= 0.01", "<= 0.05", "0.97..1.03", ">= 0.7", "<= 4"};

static int print_photo_table(const hd_photo_eval *ev, const hd_photo_rule *how)
{
    int held = 0;
    for (int i = 0; i < ev->count; i++) held += ev->rows[i].heldout;
    printf("%d photos (%d held out, %d skipped), rule %s", ev->count, held, ev->skipped,
           how->rule == HD_RULE_PAPER ? "paper" : "ratio");
    if (how->rule == HD_RULE_RATIO)
        printf(" (source light %s, guard %g)", how->source == HD_SOURCE_LNET ? "lnet" : "fit",
               how->guard > 0 ? how->guard : HD_RATIO_GUARD);
    printf("; medians over photos\n\n");
    printf("%-8s %-10s %9s %9s %9s   %s\n", "metric", "target", "all", "tuning", "held-out", "worst photo (all)");
    for (int m = 0; m < HD_PHOTO_METRICS; m++) {
        double med[3];
        int worst[3];
        for (int g = 0; g < 3; g++)
            if (hd_photo_eval_summary(ev, g, m, &med[g], &worst[g]) != HD_OK) return cli_report("eval");
        printf("%-8s %-10s", hd_photo_metric_name(m), PHOTO_TARGETS[m]);
        for (int g = 0; g < 3; g++) {
            if (isfinite(med[g])) printf(" %9.4f", med[g]);
            else printf(" %9s", "-");
        }
        if (worst[0] >= 0) printf("   %s %.4f", ev->rows[worst[0]].name, ev->rows[worst[0]].v[m]);
        printf("\n");
    }
    return CLI_EXIT_OK;
}

/* --sheets: the before / after sheet of every photo of DATA as OUT/PERSON-NAME.png. */
static int photo_sheets(const char *data, const char *model_path, hd_shadows shadows, const char *out)
{
    hd_model *model = NULL;
    hd_aligner *aligner = NULL;
    hd_dataset ds;
    memset(&ds, 0, sizeof ds);
    int rc = CLI_EXIT_OK;
    if (hd_model_load(model_path, &model) != HD_OK || hd_model_set_shadows(model, shadows) != HD_OK ||
        hd_aligner_load(&aligner) != HD_OK || hd_dataset_scan(data, &ds, warn) != HD_OK || hd_mkdirs(out) != HD_OK) {
        rc = cli_report("eval");
        goto done;
    }
    for (int i = 0; i < ds.count && rc == CLI_EXIT_OK; i++) {
        hd_image photo = {0}, sheet = {0};
        char path[4096];
        snprintf(path, sizeof path, "%s/%s-%s.png", out, ds.samples[i].subject, ds.samples[i].name);
        if (hd_image_read_as(ds.samples[i].image, 3, &photo) != HD_OK ||
            hd_relight_sheet(model, aligner, &photo, &sheet) != HD_OK || hd_image_write_png(path, &sheet, 8) != HD_OK)
            rc = cli_report("eval");
        else
            printf("%s\n", path);
        hd_image_free(&photo);
        hd_image_free(&sheet);
    }
done:
    hd_dataset_free(&ds);
    hd_model_free(model);
    hd_aligner_free(aligner);
    return rc;
}

/* --json prints the report's JSON on stdout (instead of the table), -o FILE writes it (atomically):
 * text is the JSON (taken; NULL: out of memory, the reason set), write its writer's status. */
typedef struct json_out {
    int print;       /* --json */
    const char *out; /* -o FILE */
    int quiet;
} json_out;

static int emit_json(const json_out *j, char *text, hd_status written)
{
    int rc = text ? CLI_EXIT_OK : cli_report("eval");
    if (text && j->out && written != HD_OK) rc = cli_report("eval");
    else if (text && j->out && !j->quiet && !j->print) printf("wrote %s\n", j->out);
    if (text && j->print) printf("%s\n", text);
    free(text);
    return rc;
}

/* The model (model_path, NULL: the shipped one; casting shadows or not) and the aligner the photo
 * evaluations run; 0 when both loaded, else the exit code (the reason reported). */
static int load_model_aligner(const char *model_path, hd_shadows shadows, hd_model **model, hd_aligner **aligner)
{
    *model = NULL, *aligner = NULL;
    if (hd_model_load(model_path, model) == HD_OK && hd_model_set_shadows(*model, shadows) == HD_OK &&
        hd_aligner_load(aligner) == HD_OK)
        return 0;
    hd_model_free(*model);
    *model = NULL;
    return cli_report("eval");
}

static int photo_eval(const char *data, const char *model_path, hd_shadows shadows, const hd_photo_rule *how,
                      const char *heldout, int limit, const json_out *json)
{
    hd_model *model = NULL;
    hd_aligner *aligner = NULL;
    int code = load_model_aligner(model_path, shadows, &model, &aligner);
    if (code) return code;
    hd_photo_eval ev;
    hd_status st = hd_photo_eval_run(data, model, aligner, how, heldout, limit, &ev, warn);
    hd_model_free(model);
    hd_aligner_free(aligner);
    if (st != HD_OK) return cli_report("eval");
    int rc = json->print ? CLI_EXIT_OK : print_photo_table(&ev, how);
    if (rc == CLI_EXIT_OK && (json->print || json->out))
        rc = emit_json(json, hd_photo_eval_json(&ev, how), json->out ? hd_photo_eval_write_json(json->out, &ev, how) : HD_OK);
    hd_photo_eval_free(&ev);
    return rc;
}

static int pair_eval(const char *data, const char *model_path, const hd_photo_rule *how, const json_out *json)
{
    hd_model *model = NULL;
    if (hd_model_load(model_path, &model) != HD_OK) return cli_report("eval");
    hd_pair_report rep;
    hd_status st = hd_pair_eval_run(data, model, how, &rep, warn);
    hd_model_free(model);
    if (st != HD_OK) return cli_report("eval");
    if (!json->print) {
        printf("%ld pairs (%ld skipped): image i relit under the true light of image j, against image j\n"
               "(the model's ratio rule from source light %s; guard %g)\n\n",
               rep.pairs, rep.skipped, how->source == HD_SOURCE_LNET ? "lnet" : "fit",
               how->guard > 0 ? how->guard : HD_RATIO_GUARD);
        printf("%-28s %8s %8s %8s %8s\n", "method", "MAE", "RMSE", "PSNR dB", "SSIM");
        for (int k = 0; k < HD_PAIR_ROWS; k++)
            printf("%-28s %8.4f %8.4f %8.2f %8.4f\n", rep.rows[k].name, rep.rows[k].mae, rep.rows[k].rmse,
                   rep.rows[k].psnr, rep.rows[k].ssim);
    }
    if (json->print || json->out)
        return emit_json(json, hd_pair_report_json(&rep), json->out ? hd_pair_report_write_json(json->out, &rep) : HD_OK);
    return CLI_EXIT_OK;
}

static cli_progress ml_bar;
static void ml_progress(int done, int total, const char *subject)
{
    ml_bar.total = total;
    cli_progress_update(&ml_bar, done, subject);
}

/* "A+025E+00,A-050E+00" (the set's own names) or "25,0;-50,0" into the options' lights. */
static int parse_ml_lights(const cli_cmd_spec *spec, const char *text, hd_ml_options *o)
{
    o->nlights = 0;
    for (const char *s = text; *s;) {
        float az, el;
        int used = 0, a, e;
        if (o->nlights == HD_ML_MAX_LIGHTS) return cli_usage_error(spec, "--lights: at most %d lights", HD_ML_MAX_LIGHTS);
        if (sscanf(s, "A%dE%d%n", &a, &e, &used) == 2) az = (float)a, el = (float)e; /* %f would read 025E+00 */
        else if (sscanf(s, "%f:%f%n", &az, &el, &used) != 2) used = 0;
        if (!used ||
            !(fabsf(az) <= 180.0f && fabsf(el) <= 90.0f))
            return cli_usage_error(spec, "--lights wants names like A+025E+00 or AZ:EL, comma-separated, got '%s'", s);
        o->az[o->nlights] = az, o->el[o->nlights++] = el;
        s += used;
        if (*s == ',') s++;
        else if (*s) return cli_usage_error(spec, "--lights: '%s' is not a light", s);
    }
    return 0;
}

/* The short names of the rows, as the heads of the per-light and per-subject tables' columns. */
static void ml_row_heads(void)
{
    for (int k = 0; k < HD_ML_ROWS; k++)
        printf(" %9s", k == HD_ML_INPUT ? "input" : k == HD_ML_TRANSFER ? "transfer" : k == HD_ML_RELIGHT ? "relight" : "PS bound");
}

static int multilight_eval(const char *data, const char *model_path, hd_shadows shadows, const hd_ml_options *o,
                           const json_out *json)
{
    hd_model *model = NULL;
    hd_aligner *aligner = NULL;
    int code = load_model_aligner(model_path, shadows, &model, &aligner);
    if (code) return code;
    hd_ml_report r;
    cli_progress_start(&ml_bar, "eval --multilight: steps", 0);
    hd_status st = hd_ml_run(data, model, aligner, o, &r, warn, json->quiet ? NULL : ml_progress);
    if (!json->quiet) cli_progress_finish(&ml_bar, ml_bar.total, NULL);
    hd_model_free(model);
    hd_aligner_free(aligner);
    if (st != HD_OK) {
        hd_ml_report_free(&r);
        return cli_report("eval");
    }
    if (!json->print) {
        printf("%d subjects, %d target lights: each subject's frontal photo against its real photo under each light\n"
               "scale-invariant MSE x 1000 over the face (lower is better; docs/evaluation.md)\n\n",
               r.subjects, r.nlights);
        printf("%-42s %8s %8s %6s\n", "method", "median", "mean", "n");
        for (int k = 0; k < HD_ML_ROWS; k++)
            printf("%-42s %8.2f %8.2f %6ld\n", hd_ml_row_name(k), r.rows[k].median, r.rows[k].mean, r.rows[k].n);
        printf("\nper light (mean; the set's convention: azimuth > 0 lights the image's left)\n%-12s", "light");
        ml_row_heads();
        printf("\n");
        for (int j = 0; j < r.nlights; j++) {
            printf("A%+04.0fE%+03.0f  ", r.az[j], r.el[j]);
            for (int k = 0; k < HD_ML_ROWS; k++) printf(" %9.2f", r.per_light[k][j].mean);
            printf("\n");
        }
        printf("\nper subject (mean; normals and the light's direction in degrees)\n%-12s", "subject");
        ml_row_heads();
        printf(" %9s %9s\n", "normals", "light");
        for (int i = 0; i < r.nper_subject; i++) {
            const hd_ml_subject *o = &r.per_subject[i];
            printf("%-12.12s", o->name);
            for (int k = 0; k < HD_ML_ROWS; k++) printf(" %9.2f", o->rows[k].n ? o->rows[k].mean : NAN);
            printf(" %9.2f %9.2f\n", o->normals.n ? o->normals.mean : NAN, o->light_error.n ? o->light_error.mean : NAN);
        }
        printf("\nnormals against photometric stereo: %.2f degrees mean, %.2f median over %ld subjects\n"
               "(a flat front-facing map: %.2f; the coarse normals, the canonical mesh posed on the landmarks: %.2f)\n",
               r.normals.mean, r.normals.median, r.normals.n, r.normals_flat.mean, r.normals_coarse.mean);
        printf("light estimated from each target photo against its true direction: %.2f degrees mean, %.2f median (%ld photos)\n",
               r.light_error.mean, r.light_error.median, r.light_error.n);
        printf("faces missed: %d frontal photos, %d target photos (%d references left out of the transfer)",
               r.sources_missed, r.nmissed - r.sources_missed, r.refs_missed);
        for (int i = 0; i < r.nmissed; i++) printf("%s%s", i ? ", " : ": ", r.missed[i]);
        printf("\nphotos absent from the set: %d; dark, left out: %d\n", r.photos_absent, r.photos_dark);
    }
    int code_out = CLI_EXIT_OK;
    if (json->print || json->out)
        code_out = emit_json(json, hd_ml_report_json(&r), json->out ? hd_ml_report_write_json(json->out, &r) : HD_OK);
    hd_ml_report_free(&r);
    return code_out;
}

/* What `hdnet eval` was asked: its options, DATA, and the relighting they describe. */
typedef struct eval_args {
    const char *model_path, *pred, *out, *rule, *heldout, *sheets, *source, *white_balance, *ml_lights, *shadows;
    int threads, quiet, photos, pairs, limit, json, multilight, refs, free_level, true_shading;
    float guard, repose;
    const char *data;
    hd_photo_rule how; /* from rule, source and guard (eval_check) */
    hd_shadows shadow_mode; /* from shadows (eval_check) */
} eval_args;

/* The checks every kind of evaluation shares, in the order the messages were always given; 0 or
 * the exit code. */
static int eval_check(const cli_cmd_spec *spec, eval_args *a, const char *surplus)
{
    if (surplus && a->json) /* the old --json OUT */
        return cli_usage_error(spec, "--json prints the report on stdout; write it to a file with -o %s", surplus);
    if (surplus) return cli_usage_error(spec, "one DATA folder, not also '%s'", surplus);
    if (a->model_path && a->pred) return cli_usage_error(spec, "-m MODEL and --pred DIR exclude each other");
    int code = cli_opts_common(spec, a->threads, 1.0f);
    if (code) return code;
    if (a->photos + a->pairs + a->multilight > 1)
        return cli_usage_error(spec, "--photos, --pairs and --multilight exclude each other");
    if ((a->ml_lights || a->refs || a->free_level) && !a->multilight)
        return cli_usage_error(spec, "--lights, --refs and --no-keep-brightness go with --multilight");
    a->how = (hd_photo_rule){strcmp(a->rule, "paper") == 0 ? HD_RULE_PAPER : HD_RULE_RATIO, HD_SOURCE_FIT, a->guard};
    if (a->source && cli_source_light_parse(spec, a->source, &a->how.source)) return CLI_EXIT_USAGE;
    if (!(a->guard >= 0.0f && a->guard <= 10.0f)) return cli_usage_error(spec, "--guard wants 0..10, got %g", a->guard);
    if (a->guard > 0 && !a->photos && !a->pairs && !a->multilight)
        return cli_usage_error(spec, "--guard goes with --photos, --pairs or --multilight");
    if (!(a->repose >= 0.0f && a->repose <= 1.0f)) return cli_usage_error(spec, "--repose wants 0..1, got %g", a->repose);
    if (a->repose > 0 && (a->pairs || a->photos || a->multilight))
        return cli_usage_error(spec, "--repose goes with the ground-truth evaluation (photos always take half the turn)");
    if (a->true_shading && (a->pairs || a->photos || a->multilight || a->pred))
        return cli_usage_error(spec, "--true-shading goes with a model's ground-truth evaluation, not --pred, --photos, "
                                     "--pairs or --multilight");
    if (a->white_balance && (a->pairs || a->photos || a->multilight))
        return cli_usage_error(spec, "--white-balance goes with the ground-truth evaluation, not --photos or --pairs");
    if (a->shadows && !a->photos && !a->multilight) return cli_usage_error(spec, "--shadows goes with --photos or --multilight");
    if (a->shadows && strcmp(a->shadows, "cast") != 0 && strcmp(a->shadows, "none") != 0)
        return cli_usage_error(spec, "--shadows wants cast or none, got '%s'", a->shadows);
    a->shadow_mode = a->shadows && strcmp(a->shadows, "none") == 0 ? HD_SHADOWS_NONE : HD_SHADOWS_CAST;
    return 0;
}

/* --rule and --limit as --photos and --multilight take them; 0 or the exit code. */
static int rule_limit_check(const cli_cmd_spec *spec, const eval_args *a)
{
    if (strcmp(a->rule, "ratio") != 0 && strcmp(a->rule, "paper") != 0)
        return cli_usage_error(spec, "--rule wants ratio or paper, got '%s'", a->rule);
    if (a->limit < 0) return cli_usage_error(spec, "--limit %d must be >= 0", a->limit);
    return 0;
}

/* --multilight: its own checks, then the run. */
static int run_multilight(const cli_cmd_spec *spec, const eval_args *a, const json_out *jo)
{
    if (a->pred) return cli_usage_error(spec, "--multilight relights with a model: --pred does not go with it");
    int code = rule_limit_check(spec, a);
    if (code) return code;
    if (a->refs < 0 || a->refs > 16) return cli_usage_error(spec, "--refs wants 1..16, got %d", a->refs);
    hd_ml_options o;
    memset(&o, 0, sizeof o);
    o.refs = a->refs, o.limit = a->limit, o.sheets = a->sheets, o.rule = a->how.rule, o.source = a->how.source;
    o.guard = a->guard;
    o.brightness = a->free_level ? HD_BRIGHTNESS_FREE : HD_BRIGHTNESS_KEEP;
    if (a->ml_lights && parse_ml_lights(spec, a->ml_lights, &o)) return CLI_EXIT_USAGE;
    return multilight_eval(a->data, a->model_path, a->shadow_mode, &o, jo);
}

/* --photos: its own checks, then the sheets or the scores. */
static int run_photos(const cli_cmd_spec *spec, const eval_args *a, const json_out *jo)
{
    if (a->pred) return cli_usage_error(spec, "--photos relights with a model: --pred does not go with it");
    int code = rule_limit_check(spec, a);
    if (code) return code;
    if (a->sheets) return photo_sheets(a->data, a->model_path, a->shadow_mode, a->sheets);
    return photo_eval(a->data, a->model_path, a->shadow_mode, &a->how, a->heldout, a->limit, jo);
}

/* The ground-truth evaluation (SPEC section 7) of a model or of predictions. */
static int run_ground_truth(const cli_cmd_spec *spec, const eval_args *a, const json_out *jo)
{
    if (a->heldout || a->limit || a->sheets || strcmp(a->rule, "ratio") != 0)
        return cli_usage_error(spec, "--rule, --heldout, --limit and --sheets go with --photos");
    if (a->white_balance && a->pred) return cli_usage_error(spec, "--white-balance goes with a model, not --pred");
    int code = cli_white_balance_set(spec, a->white_balance, NULL);
    if (code) return code;
    hd_model *model = NULL;
    if (!a->pred && hd_model_load(a->model_path, &model) != HD_OK) return cli_report("eval");
    if ((code = cli_white_balance_set(spec, a->white_balance, model))) {
        hd_model_free(model);
        return code;
    }
    /* the ground-truth evaluation scores L-Net's light unless told otherwise (SPEC section 7) */
    hd_eval_report rep;
    const hd_eval_options o = {a->source ? a->how.source : HD_SOURCE_LNET, a->repose, a->true_shading};
    hd_status st = hd_eval_run_options(a->data, a->pred, model, &o, &rep, warn);
    hd_model_free(model);
    if (st != HD_OK) return cli_report("eval");
    snprintf(rep.rows[0].name, sizeof rep.rows[0].name, "%s", a->pred ? "predictions" : "hdnet model");
    if (!a->quiet && !a->json) print_table(&rep);
    if (a->json || a->out)
        return emit_json(jo, hd_eval_report_json(&rep), a->out ? hd_eval_report_write_json(a->out, &rep) : HD_OK);
    return CLI_EXIT_OK;
}

int cmd_eval(int argc, char **argv)
{
    eval_args a = {.rule = "ratio"};
    const cli_opt opts[] = {
        {"model", 'm', CLI_OPT_STRING, &a.model_path, "MODEL",
         "score this model (safetensors) on the set's images (default: the shipped hdnet-synth model)"},
        {"pred", 0, CLI_OPT_STRING, &a.pred, "DIR", "score predictions in hdnet decompose's layout: DIR/SUBJECT/NAME.*"},
        {"json", 0, CLI_OPT_FLAG, &a.json, NULL, "print the report as JSON on stdout instead of the table"},
        {"output", 'o', CLI_OPT_STRING, &a.out, "FILE.json", "also write the report as JSON to FILE.json"},
        {"photos", 0, CLI_OPT_FLAG, &a.photos, NULL,
         "DATA is a folder of people (one folder each) of real photos: measure relighting (docs/usage.md)"},
        {"pairs", 0, CLI_OPT_FLAG, &a.pairs, NULL,
         "DATA is a paired synthetic set: relight image i under the true light of image j, against j"},
        {"multilight", 0, CLI_OPT_FLAG, &a.multilight, NULL,
         "DATA holds photos of faces under known point lights (lights.csv; docs/evaluation.md): measure relighting, "
         "light transfer, the light estimate and the normals against them"},
        {"lights", 0, CLI_OPT_STRING, &a.ml_lights, "LIST",
         "with --multilight: the target lights, e.g. A+025E+00,A-050E+00 (default: twelve within 70 degrees)"},
        {"refs", 0, CLI_OPT_INT, &a.refs, "N", "with --multilight: references per light for the transfer (default 3)"},
        {"no-keep-brightness", 0, CLI_OPT_FLAG, &a.free_level, NULL,
         "with --multilight: relight at the target light's own level instead of keeping the face's mean "
         "(what `hdnet relight --no-keep-brightness` does; the score ignores the level, not what clips)"},
        {"rule", 0, CLI_OPT_STRING, &a.rule, "ratio|paper", "with --photos: the relighting rule (default ratio)"},
        {"heldout", 0, CLI_OPT_STRING, &a.heldout, "IDS.txt", "with --photos: the held-out people, reported apart"},
        {"limit", 0, CLI_OPT_INT, &a.limit, "N", "with --photos: only the first N people"},
        {"sheets", 0, CLI_OPT_STRING, &a.sheets, "OUT",
         "with --photos: instead of scores, a before / after sheet per photo into folder OUT; with --multilight: "
         "also a sheet per subject (the truth, relit, transfer and bound per light) into OUT"},
        CLI_OPT_SOURCE_LIGHT_ROW(a.source),
        {"repose", 0, CLI_OPT_FLOAT, &a.repose, "S",
         "the ground-truth evaluation: first turn the model's normals by S (0..1) of the rotation onto each image's "
         "coarse normals' pose, as photos are (docs/evaluation.md; default 0)"},
        {"true-shading", 0, CLI_OPT_FLAG, &a.true_shading, NULL,
         "the ground-truth evaluation of a model: add a row of the normals N-Net gives when it reads the set's true "
         "shading instead of S-Net's (docs/synthetic-data.md)"},
        CLI_OPT_WHITE_BALANCE_ROW(a.white_balance),
        {"shadows", 0, CLI_OPT_STRING, &a.shadows, "cast|none",
         "with --photos or --multilight: the shadows the face casts on itself, cast (default) or none "
         "(docs/usage.md, \"Cast shadows\")"},
        {"guard", 0, CLI_OPT_FLOAT, &a.guard, "G",
         "with --photos or --pairs: the ratio rule's guard g as a share of the face's mean source shading "
         "(default 0: the built-in value, docs/usage.md)"},
        CLI_OPT_THREADS_ROW(a.threads),
        CLI_OPT_QUIET_ROW(a.quiet),
        {NULL, 0, 0, NULL, NULL, NULL},
    };
    const cli_cmd_spec spec = {
        "eval",
        "DATA [-m MODEL | --pred DIR] [--json] [-o FILE.json] | DATA --photos [-m MODEL] [--rule R] [--heldout IDS.txt] "
        "| DATA --pairs [-m MODEL] | DATA --multilight [-m MODEL] [--lights LIST] [--sheets OUT]",
        "Scores albedo, shading, normals, light and reconstruction against the ground truth of DATA\n"
        "(SPEC section 5 folders with NAME.albedo.png, NAME.normal_gt.png, NAME.shading.pfm or .png,\n"
        "NAME.light.txt, NAME.mask.png) over pixels with mask > 0.5: normal angular error (mean, std,\n"
        "% under 20/25/30 degrees), albedo MAE/RMSE, reconstruction MAE/RMSE (A*S against the input),\n"
        "shading MAE, and lighting classification accuracy (k-means, k = 10, on the set's true lights)\n"
        "of L-Net's light, or with --source-light fit of the least-squares light of the predicted\n"
        "shading on the predicted normals over the skin (the relighting rule's face light).\n"
        "Baselines under it: the coarse normals (NAME.normal.png); the least-squares light of the true\n"
        "shading on the coarse normals; the per-image mean colour as albedo. Without -m or --pred the\n"
        "shipped model is scored.\n"
        "With --photos, DATA holds one folder per person of real photographs: each is relit under the\n"
        "seven presets and its own light, and scored without ground truth (chroma, detail, glow, seam,\n"
        "self, light, lum; docs/usage.md, \"Measuring relighting\"): medians, tuning and held-out\n"
        "apart, and the worst photo of each. With --pairs, DATA is an `hdnet synth` set: image i of a\n"
        "subject relit under the true light of its next image j, against j (MAE, RMSE, PSNR, SSIM),\n"
        "beside the input unchanged, the exact decomposition and the paper's rule. With --multilight,\n"
        "DATA holds real photos of faces under known point lights (DATA/lights.csv: file, subject,\n"
        "azimuth_deg, elevation_deg; azimuth > 0 lights the image's LEFT, as the Extended Yale Face\n"
        "Database B): each subject's frontal photo relit to each target light's true direction and\n"
        "under the light estimated from another subject's photo (transfer), against the real photo\n"
        "(scale-invariant MSE x 1000 over the face), with the input unchanged and photometric stereo\n"
        "from the subject's other photos as rows; the model's normals against photometric stereo's;\n"
        "the light estimated from each target photo against its true direction; means per light and\n"
        "per subject (docs/evaluation.md).",
        opts, 1, 2};
    char **pos = NULL;
    int npos = 0, code = 0;
    if (cli_opts_parse(&spec, argc, argv, &pos, &npos, &code)) return code;
    a.data = pos[0];
    const char *surplus = npos > 1 ? pos[1] : NULL;
    free(pos);
    if ((code = eval_check(&spec, &a, surplus))) return code;
    const json_out jo = {a.json, a.out, a.quiet};
    if (a.pairs) {
        if (a.pred) return cli_usage_error(&spec, "--pairs relights with a model: --pred does not go with it");
        return pair_eval(a.data, a.model_path, &a.how, &jo);
    }
    if (a.multilight) return run_multilight(&spec, &a, &jo);
    if (a.photos) return run_photos(&spec, &a, &jo);
    return run_ground_truth(&spec, &a, &jo);
}
