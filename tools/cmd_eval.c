/* cmd_eval.c: `hdnet eval`: the paper's metrics (SPEC section 7) of a model, or of predictions
 * written by any system in `hdnet decompose`'s layout, on a set with ground truth, with the
 * baselines under it; a table on the terminal and the same in JSON. */
#include <stdio.h>
#include <stdlib.h>
#include "cli.h"

CLI_COMMAND("eval", cmd_eval, "score a model or predictions on a set with ground truth (the paper's metrics)")

static void warn(const char *message) { fprintf(stderr, "hdnet eval: skipped: %s\n", message); }

static void cell(int has, const char *fmt, double v)
{
    if (has) printf(fmt, v);
    else printf("%7s ", "-");
}

static void print_table(const hd_eval_report *r)
{
    printf("%ld images (%ld skipped); lighting classes: k-means, k = %d\n\n", r->images, r->skipped, r->kmeans_k);
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

int cmd_eval(int argc, char **argv)
{
    const char *model_path = NULL, *pred = NULL, *json = NULL;
    int threads = 0, quiet = 0;
    const cli_opt opts[] = {
        {"model", 'm', CLI_OPT_STRING, &model_path, "MODEL",
         "score this model (safetensors) on the set's images (default: the shipped hdnet-synth model)"},
        {"pred", 0, CLI_OPT_STRING, &pred, "DIR", "score predictions in hdnet decompose's layout: DIR/SUBJECT/NAME.*"},
        {"json", 0, CLI_OPT_STRING, &json, "OUT", "also write the table as JSON to OUT"},
        CLI_OPT_THREADS_ROW(threads),
        CLI_OPT_QUIET_ROW(quiet),
        {NULL, 0, 0, NULL, NULL, NULL},
    };
    const cli_cmd_spec spec = {
        "eval", "DATA [-m MODEL | --pred DIR] [--json OUT]",
        "Scores albedo, shading, normals, light and reconstruction against the ground truth of DATA\n"
        "(SPEC section 5 folders with NAME.albedo.png, NAME.normal_gt.png, NAME.shading.pfm or .png,\n"
        "NAME.light.txt, NAME.mask.png) over pixels with mask > 0.5: normal angular error (mean, std,\n"
        "% under 20/25/30 degrees), albedo MAE/RMSE, reconstruction MAE/RMSE (A*S against the input),\n"
        "shading MAE, and lighting classification accuracy (k-means, k = 10, on the set's true lights).\n"
        "Baselines under it: the coarse normals (NAME.normal.png); the least-squares light of the true\n"
        "shading on the coarse normals; the per-image mean colour as albedo. Without -m or --pred the\n"
        "shipped model is scored.",
        opts, 1, 1};
    char **pos = NULL;
    int npos = 0, code = 0;
    if (cli_opts_parse(&spec, argc, argv, &pos, &npos, &code)) return code;
    const char *data = pos[0];
    free(pos);
    if (model_path && pred) return cli_usage_error(&spec, "-m MODEL and --pred DIR exclude each other");
    if ((code = cli_opts_common(&spec, threads, 1.0f))) return code;
    hd_model *model = NULL;
    if (!pred && hd_model_load(model_path, &model) != HD_OK) return cli_report("eval");
    hd_eval_report rep;
    hd_status st = hd_eval_run(data, pred, model, &rep, warn);
    hd_model_free(model);
    if (st != HD_OK) return cli_report("eval");
    snprintf(rep.rows[0].name, sizeof rep.rows[0].name, "%s", pred ? "predictions" : "hdnet model");
    if (!quiet) print_table(&rep);
    if (json && hd_eval_report_write_json(json, &rep) != HD_OK) return cli_report("eval");
    if (json && !quiet) printf("wrote %s\n", json);
    return CLI_EXIT_OK;
}
