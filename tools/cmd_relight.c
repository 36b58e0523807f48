/* cmd_relight.c: `hdnet relight`: a photo (every face in it) or an aligned face texture under a new
 * light (a light file, a built-in preset, all seven presets, or a direction), by the paper's rule
 * relit = (I / S) x s(N, l) (docs/usage.md). relight_texture is the texture-in, texture-out core;
 * hd_relight_photo wraps the same steps for photos (align, relight each face, warp back, Poisson
 * blend); everything else here is file handling. */
#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "cli.h"
#include "hdnet_tool.h"
#include "video_cli.h"

CLI_COMMAND("relight", cmd_relight, "relight the faces of a photo (or an aligned face) under a light file, a preset or a direction")

/* The core: decomposes tex once and relights it under each of count lights (relit[count]); delit
 * (may be NULL) receives the albedo under flat light. */
static hd_status relight_texture(hd_model *model, const hd_image *tex, const hd_image *mask,
                                 const float (*lights)[HD_SH_COEFFS], int count, hd_brightness brightness,
                                 hd_image *relit, hd_image *delit)
{
    hd_decomposition d;
    memset(&d, 0, sizeof d);
    for (int i = 0; i < count; i++) memset(&relit[i], 0, sizeof relit[i]);
    if (delit) memset(delit, 0, sizeof *delit);
    hd_status st = hd_model_decompose(model, tex, 1, &d);
    for (int i = 0; i < count && st == HD_OK; i++) st = hd_relight(tex, &d, mask, lights[i], brightness, &relit[i]);
    if (st == HD_OK && delit) st = hd_delight(tex, &d, mask, delit);
    hd_decomposition_free(&d);
    if (st != HD_OK) {
        for (int i = 0; i < count; i++) hd_image_free(&relit[i]);
        if (delit) hd_image_free(delit);
    }
    return st;
}

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

int cmd_relight(int argc, char **argv)
{
    const char *model_path = NULL, *light_path = NULL, *preset = NULL, *out = NULL, *mask_path = NULL;
    const char *sheet_path = NULL;
    cli_opt_floats dir = {.max = 2};
    float intensity = NAN, ambient = NAN;
    int keep = 0, no_keep = 0, aligned = 0;
    hd_cli_clip clip = {0};
    static char intensity_help[96], ambient_help[96];
    snprintf(intensity_help, sizeof intensity_help, "with --dir: strength of the directional light (default %g)",
             (double)HD_LIGHT_DEFAULT_INTENSITY);
    snprintf(ambient_help, sizeof ambient_help, "with --dir: constant shading added everywhere (default %g)",
             (double)HD_LIGHT_DEFAULT_AMBIENT);
    const cli_opt opts[] = {
        CLI_OPT_MODEL_ROW(model_path),
        {"light", 0, CLI_OPT_STRING, &light_path, "L.txt", "target light file (9 SH coefficients, DPR order)"},
        {"preset", 0, CLI_OPT_STRING, &preset, "K|all",
         "built-in light K in 0..6; 'all' writes all seven, -o is then a folder"},
        {"dir", 0, CLI_OPT_FLOATS, &dir, "AZ,EL",
         "a light from azimuth AZ and elevation EL in degrees (0,0 = from the viewer; AZ > 0 right, EL > 0 up)"},
        {"intensity", 0, CLI_OPT_FLOAT, &intensity, "I", intensity_help},
        {"ambient", 0, CLI_OPT_FLOAT, &ambient, "A", ambient_help},
        {"output", 'o', CLI_OPT_STRING, &out, "OUT", "relit image (8-bit PNG, or .pfm float32); with --preset all a folder"},
        CLI_OPT_FACE_MASK_ROW(mask_path),
        {"keep-brightness", 0, CLI_OPT_FLAG, &keep, NULL, "keep the input's mean brightness over the mask (default)"},
        {"no-keep-brightness", 0, CLI_OPT_FLAG, &no_keep, NULL, "use the target light's own level"},
        {"sheet", 0, CLI_OPT_STRING, &sheet_path, "FILE.png", "also write a contact sheet: input | delit | relit ..."},
        CLI_OPT_ALIGNED_ROW(aligned),
        HD_OPT_CLIP_ROWS(clip),
        {NULL, 0, 0, NULL, NULL, NULL},
    };
    const cli_cmd_spec spec = {
        "relight",
        "IMG [-m MODEL] (--light L.txt | --preset K|all | --dir AZ,EL [--intensity I] [--ambient A]) -o OUT "
        "[--aligned]",
        "Relights every face of a photo: each face is found, unwarped into the aligned texture space,\n"
        "relit there (the final albedo I / S, S the predicted shading, times the shading of the target\n"
        "light on the predicted normals), warped back and Poisson-blended into the photo, so everything\n"
        "outside the faces stays as it was. With --aligned (or a NAME.mask.png / NAME.normal.png beside\n"
        "IMG) IMG is an aligned face texture (docs/spec.md section 2), relit directly; masked-out pixels keep the\n"
        "input. With --preset all, OUT is a folder that receives NAME.preset0.png .. NAME.preset6.png.\n"
        "The output has the input's size; an OUT ending in .pfm is written as exact float32 PFM.",
        opts, 1, 1};
    char **pos = NULL;
    int npos = 0, code = 0;
    if (cli_opts_parse(&spec, argc, argv, &pos, &npos, &code)) return code;
    const char *image_path = pos[0];
    free(pos);

    const int modes = (light_path != NULL) + (preset != NULL) + (dir.count > 0);
    if (modes != 1) return cli_usage_error(&spec, "give exactly one of --light, --preset and --dir");
    if (dir.count == 1) return cli_usage_error(&spec, "--dir wants two numbers AZ,EL");
    if ((!isnan(intensity) || !isnan(ambient)) && dir.count == 0)
        return cli_usage_error(&spec, "--intensity and --ambient go with --dir");
    if (!out) return cli_usage_error(&spec, "-o is required");
    if (keep && no_keep) return cli_usage_error(&spec, "--keep-brightness and --no-keep-brightness exclude each other");
    const hd_brightness brightness = no_keep ? HD_BRIGHTNESS_FREE : HD_BRIGHTNESS_KEEP;

    float lights[HD_LIGHT_PRESETS][HD_SH_COEFFS];
    int count = 1, all = 0;
    if (preset) {
        char *end = NULL;
        long k = strtol(preset, &end, 10);
        if (strcmp(preset, "all") == 0) {
            all = 1;
            count = HD_LIGHT_PRESETS;
            for (int i = 0; i < HD_LIGHT_PRESETS; i++) hd_light_preset(i, lights[i]);
        } else if (end == preset || *end || k < 0 || k >= HD_LIGHT_PRESETS) {
            return cli_usage_error(&spec, "--preset wants 0..%d or 'all', got '%s'", HD_LIGHT_PRESETS - 1, preset);
        } else {
            hd_light_preset((int)k, lights[0]);
        }
    } else if (dir.count) {
        hd_light_from_direction(dir.v[0], dir.v[1], isnan(intensity) ? HD_LIGHT_DEFAULT_INTENSITY : intensity,
                                isnan(ambient) ? HD_LIGHT_DEFAULT_AMBIENT : ambient, lights[0]);
    } else if (hd_light_read(light_path, lights[0]) != HD_OK) {
        return cli_report("relight");
    }
    if (hd_cli_is_clip(image_path, &clip)) /* a video, or a folder of frames with --fps */
        return all || sheet_path ? cli_usage_error(&spec, "a clip takes one light (no --preset all, no --sheet)")
                                 : hd_cli_video("relight", image_path, out, model_path, lights[0], NULL, brightness, &clip);

    const int photo = !aligned && hd_input_kind_of(image_path) == HD_INPUT_PHOTO;
    hd_model *model = NULL;
    hd_aligner *aligner = NULL;
    hd_image tex = {0}, mask = {0}, delit = {0};
    hd_image relit[HD_LIGHT_PRESETS];
    memset(relit, 0, sizeof relit);
    char *mask_source = NULL, *stem = NULL;
    int rc = CLI_EXIT_FAIL;
    if (photo) {
        int nfaces = 0;
        if (hd_image_read_as(image_path, 3, &tex) != HD_OK || hd_model_load(model_path, &model) != HD_OK ||
            hd_aligner_load(&aligner) != HD_OK) {
            rc = cli_report("relight");
            goto done;
        }
        cli_note_mask("relight", 1, mask_path, NULL);
        hd_status st = hd_relight_photo(model, aligner, &tex, (const float (*)[HD_SH_COEFFS])lights, count, brightness,
                                        relit, sheet_path ? &delit : NULL, &nfaces);
        if (st != HD_OK) {
            cli_report_photo("relight", st, image_path);
            goto done;
        }
        printf("%s: relit %d face%s\n", image_path, nfaces, nfaces == 1 ? "" : "s");
    } else {
        if (hd_image_read_as(image_path, 3, &tex) != HD_OK ||
            hd_face_mask_read(image_path, mask_path, tex.width, tex.height, &mask, &mask_source) != HD_OK ||
            hd_model_load(model_path, &model) != HD_OK) {
            rc = cli_report("relight");
            goto done;
        }
        cli_note_mask("relight", 0, mask_path, mask_source);
        if (relight_texture(model, &tex, &mask, (const float (*)[HD_SH_COEFFS])lights, count, brightness, relit,
                            sheet_path ? &delit : NULL) != HD_OK) {
            rc = cli_report("relight");
            goto done;
        }
    }
    if (all) {
        stem = hd_path_stem(image_path);
        if (!stem || hd_mkdirs(out) != HD_OK) {
            rc = cli_report("relight");
            goto done;
        }
        for (int i = 0; i < count; i++) {
            char file[4096];
            if (snprintf(file, sizeof file, "%s/%s.preset%d.png", out, stem, i) >= (int)sizeof file) {
                fprintf(stderr, "hdnet relight: %s: output path too long\n", out);
                goto done;
            }
            if (hd_image_write_picture(file, &relit[i]) != HD_OK) {
                rc = cli_report("relight");
                goto done;
            }
        }
        printf("%s/%s.preset0.png .. preset%d.png\n", out, stem, count - 1);
    } else if (hd_image_write_picture(out, &relit[0]) != HD_OK) {
        rc = cli_report("relight");
        goto done;
    }
    if (sheet_path && write_sheet(sheet_path, &tex, &delit, relit, count) != HD_OK) {
        rc = cli_report("relight");
        goto done;
    }
    rc = CLI_EXIT_OK;
done:
    for (int i = 0; i < HD_LIGHT_PRESETS; i++) hd_image_free(&relit[i]);
    hd_image_free(&delit);
    hd_image_free(&tex);
    hd_image_free(&mask);
    if (model) hd_model_free(model);
    hd_aligner_free(aligner);
    free(mask_source);
    free(stem);
    return rc;
}
