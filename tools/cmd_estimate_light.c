/* cmd_estimate_light.c: `hdnet estimate-light`: the light the model estimates for an aligned face
 * (L-Net's 9 SH coefficients), as a light file, optionally drawn on a sphere (docs/usage.md).
 * hd_estimate_light is the texture-in core; this file is the file handling. */
#include <stdlib.h>
#include "cli.h"

HD_COMMAND("estimate-light", cmd_estimate_light, "estimate the light of an aligned face (SH light file)")

int cmd_estimate_light(int argc, char **argv)
{
    const char *model_path = NULL, *out = NULL, *preview = NULL;
    int size = 256;
    const hd_opt opts[] = {
        {"model", 'm', HD_OPT_STRING, &model_path, "MODEL", "model file (default: the shipped hdnet-synth model)"},
        {"output", 'o', HD_OPT_STRING, &out, "L.txt", "the light file (9 numbers, DPR order)"},
        {"preview", 0, HD_OPT_STRING, &preview, "SPHERE.png", "also draw the light on a sphere"},
        {"size", 0, HD_OPT_INT, &size, "N", "side of the sphere picture in pixels (default 256)"},
        {NULL, 0, 0, NULL, NULL, NULL},
    };
    const hd_cmd_spec spec = {
        "estimate-light", "IMG [-m MODEL] -o L.txt [--preview SPHERE.png]",
        "Writes the light the model estimates for an aligned face texture (SPEC section 2): 9\n"
        "spherical-harmonics coefficients in DPR's order and scale, loadable by `hdnet relight --light`.",
        opts, 1, 1};
    char **pos = NULL;
    int npos = 0, code = 0;
    if (hd_opts_parse(&spec, argc, argv, &pos, &npos, &code)) return code;
    const char *image_path = pos[0];
    free(pos);
    if (!out) return hd_usage_error(&spec, "-o is required");
    if (size < 8 || size > 4096) return hd_usage_error(&spec, "--size wants 8..4096, got %d", size);

    hd_model *model = NULL;
    hd_image tex = {0}, sphere = {0};
    float light[HD_SH_COEFFS];
    int rc = HD_EXIT_OK;
    if (hd_image_read_as(image_path, 3, &tex) != HD_OK || hd_model_load(model_path, &model) != HD_OK ||
        hd_estimate_light(model, &tex, light) != HD_OK || hd_light_write(out, light) != HD_OK ||
        (preview && (hd_light_sphere(light, size, &sphere) != HD_OK || hd_image_write_png(preview, &sphere, 8) != HD_OK)))
        rc = hd_report("estimate-light");
    hd_image_free(&sphere);
    hd_image_free(&tex);
    if (model) hd_model_free(model);
    return rc;
}
