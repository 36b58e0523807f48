/* cmd_estimate_light.c: `hdnet estimate-light`: a face's light as a reference (9 SH coefficients:
 * the fit of the predicted shading on the predicted normals, hd_reference_light, or L-Net's
 * estimate; docs/usage.md "hdnet estimate-light"), the light `hdnet transfer` takes from it: the
 * best-scoring face of a photo (aligned first) or an aligned face texture; written as a light
 * file, optionally drawn on a sphere, or printed as JSON (docs/usage.md). hd_estimate_face_light
 * and hd_estimate_face_light_photo are the cores; estimate_one is the per-photo step the batch
 * loop (batch.c) runs over every input; the rest is file handling. */
#include <stdlib.h>
#include <string.h>
#include "apply_cli.h"
#include "batch.h"
#include "cli.h"

CLI_COMMAND("estimate-light", cmd_estimate_light, "estimate the light of the face in photos or of aligned faces (SH light file)")

typedef struct estimate_run {
    const char *preview;
    int size, aligned;
    float min_score;
    hd_source_light source;
    hd_model *model;
    hd_aligner *aligner;
    cJSON *results; /* --json: one object per input done */
} estimate_run;

static hd_status estimate_one(void *ctx, const cli_input *in, const char *out, int single, cli_result *r)
{
    estimate_run *run = ctx;
    const int photo = !run->aligned && hd_input_kind_of(in->path) == HD_INPUT_PHOTO;
    hd_image tex = {0}, sphere = {0}, mask = {0};
    float light[HD_SH_COEFFS];
    char *path = NULL;
    hd_status st = hd_image_read_as(in->path, 3, &tex);
    if (st == HD_OK && photo && !run->aligner) {
        st = hd_aligner_load(&run->aligner);
        if (st == HD_OK) hd_aligner_set_min_score(run->aligner, run->min_score);
    }
    r->faces = 1;
    /* an aligned texture's light is fitted over its companion mask (none: the whole texture) */
    if (st == HD_OK && !photo) st = hd_face_mask_read(in->path, NULL, tex.width, tex.height, &mask, NULL);
    if (st == HD_OK)
        st = photo ? hd_estimate_face_light_photo(run->model, run->aligner, &tex, run->source, light, &r->faces)
                   : hd_estimate_face_light(run->model, &tex, &mask, run->source, light);
    if (st == HD_OK && photo && r->faces > 1 && !run->results)
        fprintf(stderr, "hdnet estimate-light: note: %s has %d faces; this is the light of face 0 (best score)\n",
                in->path, r->faces);
    if (st == HD_OK && out && !(path = single ? strdup(out) : cli_output_path(out, in, ".light.txt"))) st = HD_ERR_NOMEM;
    if (st == HD_OK && path) st = hd_light_write(path, light);
    if (st == HD_OK && run->preview) {
        st = hd_light_sphere(light, run->size, &sphere);
        if (st == HD_OK) st = hd_image_write_png(run->preview, &sphere, 8);
    }
    if (st == HD_OK) snprintf(r->wrote, sizeof r->wrote, "%s%s%s", path ? path : "stdout", run->preview ? " and " : "",
                              run->preview ? run->preview : "");
    if (st == HD_OK && run->results) {
        cJSON *o = cJSON_CreateObject();
        cJSON *l = cJSON_CreateArray();
        if (o && l) {
            cJSON_AddStringToObject(o, "file", in->path);
            cJSON_AddStringToObject(o, "kind", photo ? "photo" : "aligned");
            cJSON_AddNumberToObject(o, "faces", photo ? r->faces : 1);
            for (int k = 0; k < HD_SH_COEFFS; k++) cJSON_AddItemToArray(l, cJSON_CreateNumber(light[k]));
            cJSON_AddItemToObject(o, "light", l);
            l = NULL;
            if (path) cJSON_AddStringToObject(o, "output", path);
            cJSON_AddItemToArray(run->results, o);
            o = NULL;
        }
        cJSON_Delete(o);
        cJSON_Delete(l);
    }
    free(path);
    hd_image_free(&sphere);
    hd_image_free(&mask);
    hd_image_free(&tex);
    return st;
}

int cmd_estimate_light(int argc, char **argv)
{
    const char *model_path = NULL, *out = NULL, *preview = NULL, *source = NULL;
    int size = 256, aligned = 0, threads = 0, quiet = 0, json = 0;
    float min_score = cli_min_score_default();
    const cli_opt opts[] = {
        CLI_OPT_MODEL_ROW(model_path),
        {"output", 'o', CLI_OPT_STRING, &out, "OUT",
         "one input: the light file (9 numbers, DPR order); many inputs or a folder: the output folder "
         "(OUT/NAME.light.txt); optional with --json"},
        {"preview", 0, CLI_OPT_STRING, &preview, "SPHERE.png", "also draw the light on a sphere (one input only)"},
        {"size", 0, CLI_OPT_INT, &size, "N", "side of the sphere picture in pixels (default 256)"},
        CLI_OPT_ALIGNED_ROW(aligned),
        CLI_OPT_SOURCE_LIGHT_ROW(source),
        CLI_OPT_MIN_SCORE_ROW(min_score),
        CLI_OPT_THREADS_ROW(threads),
        CLI_OPT_QUIET_ROW(quiet),
        CLI_OPT_JSON_ROW(json),
        {NULL, 0, 0, NULL, NULL, NULL},
    };
    const cli_cmd_spec spec = {
        "estimate-light", "IMG|DIR|@LIST ... [-m MODEL] (-o OUT | --json) [--preview SPHERE.png] [--aligned]",
        "Writes the face's light, as `hdnet transfer --ref` takes it, for the face in a photo (the\n"
        "best-scoring face, aligned first) or, with --aligned, for an aligned face texture (docs/spec.md\n"
        "section 2): 9 spherical-harmonics coefficients in DPR's order and scale, loadable by `hdnet\n"
        "relight --light`. By default (--source-light fit) the least-squares light of the predicted shading\n"
        "on the predicted normals over the face's skin (the face below the nose weighted a quarter, each\n"
        "texel by 1 / max(n_z, 0.5)^2), pulled a little toward the best ambient + distant light of that\n"
        "shading (not quite the relighting rule's own light of the face; docs/usage.md); with\n"
        "--source-light lnet L-Net's estimate itself (what decompose writes). Many inputs (files,\n"
        "folders walked recursively, @LIST files of paths) share one model load and write\n"
        "OUT/REL/NAME.light.txt; a photo that cannot be read or has no face is reported and skipped, and\n"
        "the exit status is then 1. --json prints every light and the summary on stdout.",
        opts, 1, -1};
    char **pos = NULL;
    int npos = 0, code = 0;
    if (cli_opts_parse(&spec, argc, argv, &pos, &npos, &code)) return code;
    cli_inputs in = {0};
    estimate_run run = {preview, size, aligned, min_score, HD_SOURCE_FIT, NULL, NULL, NULL};
    int rc = CLI_EXIT_USAGE;
    if ((code = cli_opts_common(&spec, threads, min_score))) goto done;
    if (source && (code = cli_source_light_parse(&spec, source, &run.source))) goto done;
    if (!out && !json) {
        cli_usage_error(&spec, "-o is required (or --json)");
        goto done;
    }
    if (size < 8 || size > 4096) {
        cli_usage_error(&spec, "--size wants 8..4096, got %d", size);
        goto done;
    }
    int single = 0;
    if ((code = cli_output_mode(&spec, pos, npos, out, NULL, &single))) goto done;
    rc = CLI_EXIT_FAIL;
    if (cli_inputs_collect(&in, pos, npos) != HD_OK) {
        rc = cli_report("estimate-light");
        goto done;
    }
    if (preview && in.total != 1) {
        rc = cli_usage_error(&spec, "--preview goes with one input (%d given)", in.total);
        goto done;
    }
    if (json && !(run.results = cJSON_CreateArray())) {
        fprintf(stderr, "hdnet estimate-light: out of memory\n");
        goto done;
    }
    if (hd_model_load(model_path, &run.model) != HD_OK) {
        rc = cli_report("estimate-light");
        goto done;
    }
    cli_summary sum;
    rc = cli_batch_run("estimate-light", "estimated the light of", CLI_NO_FACE_ALIGNED, &in, out, single, quiet || json,
                       estimate_one, &run, &sum);
    if (json) rc = cli_json_print_run("estimate-light", &run.results, &in, &sum, out, rc);
done:
    if (code) rc = code;
    cJSON_Delete(run.results);
    if (run.model) hd_model_free(run.model);
    hd_aligner_free(run.aligner);
    cli_inputs_free(&in);
    free(pos);
    return rc;
}
