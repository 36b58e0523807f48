/* cmd_relight.c: `hdnet relight`: a photo (every face in it) or an aligned face texture under a new
 * light (a light file of 9 or 27 numbers, a built-in preset, all seven presets, a direction with
 * an optional colour, or an environment map), by the rule of docs/usage.md. hd_apply_photo and
 * hd_apply_texture (src/apply/apply.c) do the work, through the per-photo step relight, delight and
 * transfer share (apply_cli.c) that the batch loop (batch.c) runs over every input; everything else
 * here is options and files. */
#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "apply_cli.h"
#include "cli.h"
#include "hdnet_tool.h"
#include "light_words.h"
#include "video_cli.h"

CLI_COMMAND("relight", cmd_relight, "relight the faces of a photo (or an aligned face) under a light file, a preset or a direction")

/* Sheet: input | delit | relit under each light. */
static hd_status write_sheet(const char *path, const hd_image *input, const hd_image *delit, const hd_image *relit,
                             int count)
{
    hd_sheet sheet;
    int cell = input->width > 256 ? 256 : input->width;
    hd_status st = hd_sheet_init(&sheet, 1, count + 2, cell, 4);
    if (st != HD_OK) return st;
    st = hd_sheet_put(&sheet, 0, 0, input, HD_SHEET_PICTURE);
    if (st == HD_OK) st = hd_sheet_put(&sheet, 0, 1, delit, HD_SHEET_PICTURE);
    for (int i = 0; i < count && st == HD_OK; i++) st = hd_sheet_put(&sheet, 0, i + 2, &relit[i], HD_SHEET_PICTURE);
    if (st == HD_OK) st = hd_sheet_write(&sheet, path);
    hd_sheet_free(&sheet);
    return st;
}

/* What every photo of one run shares: the request, the model and aligner (loaded once). */
typedef struct relight_run {
    cli_apply_run apply;
    int all; /* --preset all: OUT/REL.preset<i>.png */
    const char *sheet_path;
} relight_run;

static hd_status relight_one(void *ctx, const cli_input *in, const char *out, int single, cli_result *r)
{
    relight_run *run = ctx;
    hd_image tex = {0};
    hd_apply_result res;
    hd_status st = cli_apply_input(&run->apply, in, &tex, &res, r);
    for (int i = 0; i < res.count && st == HD_OK; i++) {
        char what[1200];
        snprintf(what, sizeof what, "%s: the relit result%s (nothing written)", in->path, run->all ? " of a preset" : "");
        st = hd_image_check_finite(&res.relit[i], what);
    }
    if (st == HD_OK) {
        hd_atomic_set_begin(); /* the relit pictures and the sheet appear together or not at all */
        for (int i = 0; i < res.count && st == HD_OK; i++) {
            char suffix[32] = ".relit.png";
            if (run->all) snprintf(suffix, sizeof suffix, ".preset%d.png", i);
            st = cli_apply_write(in, out, single, suffix, i, &res.relit[i], r);
        }
        if (st == HD_OK && run->sheet_path) st = write_sheet(run->sheet_path, &tex, &res.delit, res.relit, res.count);
        hd_status set_end = hd_atomic_set_end(st == HD_OK);
        if (st == HD_OK) st = set_end;
    }
    if (st == HD_OK && run->all && res.count > 1) {
        size_t n = strlen(r->wrote);
        snprintf(r->wrote + n, sizeof r->wrote - n, " .. preset%d.png", res.count - 1);
    }
    hd_apply_result_free(&res);
    hd_image_free(&tex);
    return st;
}

/* The command line of `hdnet relight`: what the option table fills. */
typedef struct relight_args {
    const char *model_path, *light_path, *preset, *out, *mask_path, *sheet_path, *env_path, *source;
    cli_scene scene;
    cli_opt_floats dir, colour;
    float intensity, ambient, rotate, min_score; /* intensity, ambient NAN: the defaults */
    int keep, no_keep, aligned, threads, quiet;
} relight_args;

/* The checks of the command line, and the target lights (one, or the seven presets) into lights
 * and run's request: 0, or the exit code (a usage error, or a light file or map that failed). */
static int relight_check(const cli_cmd_spec *spec, const relight_args *a, relight_run *run,
                         hd_light_rgb lights[HD_LIGHT_PRESETS])
{
    int code;
    float l[HD_SH_COEFFS];
    const int modes = (a->light_path != NULL) + (a->preset != NULL) + (a->dir.count > 0) + (a->env_path != NULL);
    if ((code = cli_opts_common(spec, a->threads, a->min_score))) return code;
    if (modes != 1) return cli_usage_error(spec, "give exactly one of --light, --preset, --dir and --env");
    int preset_k = INT_MIN;
    if (a->preset && strcmp(a->preset, "all") != 0) {
        char *end = NULL;
        long k = strtol(a->preset, &end, 10);
        if (end == a->preset || *end) return cli_usage_error(spec, "--preset wants 0..%d or 'all', got '%s'", HD_LIGHT_PRESETS - 1, a->preset);
        preset_k = k < -1 ? -1 : k > HD_LIGHT_PRESETS ? HD_LIGHT_PRESETS : (int)k;
    }
    const cli_light_words words = cli_light_words_of(&a->dir, a->intensity, a->ambient, &a->colour, preset_k, a->env_path, a->rotate);
    char why[200];
    if (cli_light_words_check(&words, why, sizeof why) != HD_OK) return cli_usage_error(spec, "%s", why);
    if (!a->out) return cli_usage_error(spec, "-o is required");
    if (a->keep && a->no_keep) return cli_usage_error(spec, "--keep-brightness and --no-keep-brightness exclude each other");
    run->apply.request.count = 1;
    if (a->preset && preset_k == INT_MIN) { /* --preset all */
        run->all = 1;
        run->apply.request.count = HD_LIGHT_PRESETS;
        for (int i = 0; i < HD_LIGHT_PRESETS; i++) hd_light_preset(i, l), hd_light_rgb_from_grey(l, &lights[i]);
    } else if (a->light_path ? hd_light_read_rgb(a->light_path, &lights[0]) != HD_OK
                          : cli_light_from_words(&words, &lights[0], why, sizeof why) != HD_OK) {
        return a->light_path || !why[0] ? cli_report("relight") : cli_usage_error(spec, "%s", why);
    }
    for (int c = 0; c < 3; c++)
        for (int k = 0; k < HD_SH_COEFFS; k++)
            if (!(fabsf(lights[0].sh[c][k]) <= HD_LIGHT_MAX_COEFF)) return cli_usage_error(spec, "the light's coefficient %d (%g) is beyond %g: its shading could overflow", k,
                                (double)lights[0].sh[c][k], (double)HD_LIGHT_MAX_COEFF);
    if (a->source && cli_source_light_parse(spec, a->source, &run->apply.request.source)) return CLI_EXIT_USAGE;
    return cli_scene_set(spec, &a->scene, NULL, NULL);
}

int cmd_relight(int argc, char **argv)
{
    relight_args a = {.dir = {.max = 2}, .colour = {.max = 3}, .intensity = NAN, .ambient = NAN,
                      .min_score = cli_min_score_default()};
    cli_clip clip = {0};
    static char intensity_help[96], ambient_help[96];
    snprintf(intensity_help, sizeof intensity_help, "with --dir: strength of the directional light (default %g)",
             (double)HD_LIGHT_DEFAULT_INTENSITY);
    snprintf(ambient_help, sizeof ambient_help, "with --dir: constant shading added everywhere (default %g)",
             (double)HD_LIGHT_DEFAULT_AMBIENT);
    const cli_opt opts[] = {
        CLI_OPT_MODEL_ROW(a.model_path),
        {"light", 0, CLI_OPT_STRING, &a.light_path, "L.txt",
         "target light file (9 SH coefficients, DPR order; 27 for a coloured light, docs/formats.md)"},
        {"preset", 0, CLI_OPT_STRING, &a.preset, "K|all",
         "built-in light K in 0..6; 'all' writes all seven, -o is then a folder"},
        {"dir", 0, CLI_OPT_FLOATS, &a.dir, "AZ,EL",
         "a light from azimuth AZ and elevation EL in degrees (0,0 = from the viewer; AZ > 0 right, EL > 0 up)"},
        {"intensity", 0, CLI_OPT_FLOAT, &a.intensity, "I", intensity_help},
        {"ambient", 0, CLI_OPT_FLOAT, &a.ambient, "A", ambient_help},
        {"colour", 0, CLI_OPT_FLOATS, &a.colour, "R,G,B", "with --dir: the light's colour (linear factors, default 1,1,1)"},
        {"env", 0, CLI_OPT_STRING, &a.env_path, "MAP.pfm", "the light of an equirectangular environment map (PFM, PNG)"},
        {"rotate", 0, CLI_OPT_FLOAT, &a.rotate, "DEG", "with --env: turn the map about the vertical axis (default 0)"},
        {"output", 'o', CLI_OPT_STRING, &a.out, "OUT",
         "one input: the relit image (8-bit PNG, or .pfm float32); many inputs, a folder or --preset all: "
         "the output folder (OUT/NAME.relit.png, OUT/NAME.preset<K>.png)"},
        CLI_OPT_FACE_MASK_ROW(a.mask_path),
        {"keep-brightness", 0, CLI_OPT_FLAG, &a.keep, NULL, "keep the input's mean brightness over the mask (default)"},
        {"no-keep-brightness", 0, CLI_OPT_FLAG, &a.no_keep, NULL, "use the target light's own level"},
        {"sheet", 0, CLI_OPT_STRING, &a.sheet_path, "FILE.png",
         "also write a contact sheet: input | delit | relit ... (one input only)"},
        CLI_OPT_ALIGNED_ROW(a.aligned),
        CLI_OPT_APPLY_TAIL_ROWS(a.source, a.scene, clip, a.min_score, a.threads, a.quiet),
    };
    const cli_cmd_spec spec = {
        "relight",
        "IMG|DIR|@LIST ... [-m MODEL] (--light L.txt | --preset K|all | --dir AZ,EL [--intensity I] [--ambient A] "
        "[--colour R,G,B] | --env MAP [--rotate DEG]) -o OUT [--aligned]",
        "Relights every face of a photo: each face is found and decomposed in the aligned texture space,\n"
        "and the photo is multiplied by the change of shading s(N, l_target) / s(N, l_face) on the\n"
        "predicted normals (the eyes, mouth and brows following the skin around them), faded to nothing\n"
        "at the face's edge, so everything outside the faces stays as it was (docs/usage.md). With --aligned (or a NAME.mask.png / NAME.normal.png beside\n"
        "IMG) IMG is an aligned face texture (docs/spec.md section 2), relit directly; masked-out pixels keep the\n"
        "input. The output has the input's size; an OUT ending in .pfm is written as exact float32 PFM.\n"
        "Many inputs (files, folders walked recursively, @LIST files of paths) share one model load: OUT\n"
        "is then a folder receiving OUT/REL/NAME.relit.png (REL the path below a folder given), and with\n"
        "--preset all (always a folder) OUT/REL/NAME.preset0.png .. preset6.png. A photo that cannot be\n"
        "read or has no face is reported and skipped; the exit status is 1 if any was.",
        opts, 1, -1};
    char **pos = NULL;
    int npos = 0, code = 0;
    if (cli_opts_parse(&spec, argc, argv, &pos, &npos, &code)) return code;
    cli_inputs in = {0};
    relight_run run = {0};
    hd_light_rgb lights[HD_LIGHT_PRESETS];
    int rc = CLI_EXIT_USAGE;

    if ((code = relight_check(&spec, &a, &run, lights))) goto done;
    if (npos == 1 && cli_is_clip(pos[0], &clip)) { /* a video, or a folder of frames with --fps */
        if ((code = cli_scene_set(&spec, &a.scene, &clip, NULL))) goto done;
        if (run.apply.request.source != HD_SOURCE_FIT)
            cli_usage_error(&spec, "a clip takes the fitted source light (--source-light fit)");
        else if (run.all || a.sheet_path || !hd_light_rgb_is_grey(&lights[0]))
            cli_usage_error(&spec, "a clip takes one light, grey (no --preset all, no --sheet, no colour)");
        else rc = cli_video("relight", pos[0], a.out, a.model_path, lights[0].sh[0], NULL,
                               a.no_keep ? HD_BRIGHTNESS_FREE : HD_BRIGHTNESS_KEEP, &clip);
        goto done;
    }
    int single = 0;
    if ((code = cli_output_mode(&spec, pos, npos, a.out, run.all ? "--preset all writes seven images into a folder" : NULL, &single))) goto done;
    if (cli_inputs_collect(&in, pos, npos) != HD_OK) {
        rc = cli_report("relight");
        goto done;
    }
    if (a.sheet_path && in.total != 1) {
        cli_usage_error(&spec, "--sheet goes with one input (%d given)", in.total);
        goto done;
    }
    rc = CLI_EXIT_FAIL;
    run.apply.request.lights = lights;
    run.apply.request.delight = a.sheet_path != NULL;
    run.apply.request.rule = HD_RULE_RATIO;
    run.apply.cmd = "relight";
    run.apply.request.brightness = a.no_keep ? HD_BRIGHTNESS_FREE : HD_BRIGHTNESS_KEEP;
    run.apply.aligned = a.aligned;
    run.apply.mask_path = a.mask_path;
    run.sheet_path = a.sheet_path;
    run.apply.min_score = a.min_score;
    if (hd_model_load(a.model_path, &run.apply.model) != HD_OK) {
        rc = cli_report("relight");
        goto done;
    }
    if ((code = cli_scene_set(&spec, &a.scene, NULL, run.apply.model))) goto done;
    rc = cli_batch_run("relight", "relit", CLI_NO_FACE_ALIGNED, &in, a.out, single, a.quiet, relight_one, &run, NULL);
done:
    if (code) rc = code;
    if (run.apply.model) hd_model_free(run.apply.model);
    hd_aligner_free(run.apply.aligner);
    cli_inputs_free(&in);
    free(pos);
    return rc;
}
