/* cmd_estimate_light.c: `hdnet estimate-light`: the light the model estimates for a face (L-Net's 9
 * SH coefficients): the best-scoring face of a photo (aligned first) or an aligned face texture;
 * written as a light file, optionally drawn on a sphere (docs/usage.md). hd_estimate_light and
 * hd_estimate_light_photo are the cores; this file is the file handling. */
#include <stdlib.h>
#include "cli.h"

CLI_COMMAND("estimate-light", cmd_estimate_light, "estimate the light of the face in a photo or of an aligned face (SH light file)")

int cmd_estimate_light(int argc, char **argv)
{
    const char *model_path = NULL, *out = NULL, *preview = NULL;
    int size = 256, aligned = 0;
    const cli_opt opts[] = {
        CLI_OPT_MODEL_ROW(model_path),
        {"output", 'o', CLI_OPT_STRING, &out, "L.txt", "the light file (9 numbers, DPR order)"},
        {"preview", 0, CLI_OPT_STRING, &preview, "SPHERE.png", "also draw the light on a sphere"},
        {"size", 0, CLI_OPT_INT, &size, "N", "side of the sphere picture in pixels (default 256)"},
        CLI_OPT_ALIGNED_ROW(aligned),
        {NULL, 0, 0, NULL, NULL, NULL},
    };
    const cli_cmd_spec spec = {
        "estimate-light", "IMG [-m MODEL] -o L.txt [--preview SPHERE.png] [--aligned]",
        "Writes the light the model estimates for the face in a photo (the best-scoring face, aligned\n"
        "first) or, with --aligned, for an aligned face texture (docs/spec.md section 2): 9 spherical-harmonics\n"
        "coefficients in DPR's order and scale, loadable by `hdnet relight --light`.",
        opts, 1, 1};
    char **pos = NULL;
    int npos = 0, code = 0;
    if (cli_opts_parse(&spec, argc, argv, &pos, &npos, &code)) return code;
    const char *image_path = pos[0];
    free(pos);
    if (!out) return cli_usage_error(&spec, "-o is required");
    if (size < 8 || size > 4096) return cli_usage_error(&spec, "--size wants 8..4096, got %d", size);

    const int photo = !aligned && hd_input_kind_of(image_path) == HD_INPUT_PHOTO;
    hd_model *model = NULL;
    hd_aligner *aligner = NULL;
    hd_image tex = {0}, sphere = {0};
    float light[HD_SH_COEFFS];
    int rc = CLI_EXIT_FAIL, nfaces = 1;
    if (hd_image_read_as(image_path, 3, &tex) != HD_OK || hd_model_load(model_path, &model) != HD_OK ||
        (photo && hd_aligner_load(&aligner) != HD_OK)) {
        rc = cli_report("estimate-light");
        goto done;
    }
    hd_status st = photo ? hd_estimate_light_photo(model, aligner, &tex, light, &nfaces)
                         : hd_estimate_light(model, &tex, light);
    if (st != HD_OK) {
        if (photo) cli_report_photo("estimate-light", st, image_path);
        else cli_report("estimate-light");
        goto done;
    }
    if (nfaces > 1)
        fprintf(stderr, "hdnet estimate-light: note: %s has %d faces; this is the light of face 0 (best score)\n",
                image_path, nfaces);
    if (hd_light_write(out, light) != HD_OK ||
        (preview && (hd_light_sphere(light, size, &sphere) != HD_OK || hd_image_write_png(preview, &sphere, 8) != HD_OK))) {
        rc = cli_report("estimate-light");
        goto done;
    }
    rc = CLI_EXIT_OK;
done:
    hd_image_free(&sphere);
    hd_image_free(&tex);
    if (model) hd_model_free(model);
    hd_aligner_free(aligner);
    return rc;
}
