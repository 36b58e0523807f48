/* cmd_delight.c: `hdnet delight`: an aligned face texture under flat light, i.e. the paper's final
 * albedo I / S (clamped) where the mask is set, the input elsewhere (docs/usage.md).
 * hd_delight_face is the texture-in, texture-out core; this file is the file handling. */
#include <stdlib.h>
#include <string.h>
#include "cli.h"

HD_COMMAND("delight", cmd_delight, "remove the lighting of an aligned face (albedo under flat light)")

int cmd_delight(int argc, char **argv)
{
    const char *model_path = NULL, *out = NULL, *mask_path = NULL;
    const hd_opt opts[] = {
        {"model", 'm', HD_OPT_STRING, &model_path, "MODEL", "model file (default: the shipped hdnet-synth model)"},
        {"output", 'o', HD_OPT_STRING, &out, "OUT.png", "the delit image (PNG, 8 bit, the input's size)"},
        {"mask", 0, HD_OPT_STRING, &mask_path, "M.png", "face mask when IMG has no NAME.mask.png beside it (default: all ones)"},
        {NULL, 0, 0, NULL, NULL, NULL},
    };
    const hd_cmd_spec spec = {
        "delight", "IMG [-m MODEL] -o OUT.png [--mask M.png]",
        "Removes the lighting of an aligned face texture (SPEC section 2): writes the final albedo\n"
        "I / S (S the predicted shading, floored at 1e-3, the ratio clamped to [0, 1]) where the mask\n"
        "is set and the input where it is not.",
        opts, 1, 1};
    char **pos = NULL;
    int npos = 0, code = 0;
    if (hd_opts_parse(&spec, argc, argv, &pos, &npos, &code)) return code;
    const char *image_path = pos[0];
    free(pos);
    if (!out) return hd_usage_error(&spec, "-o is required");

    hd_model *model = NULL;
    hd_image tex = {0}, mask = {0}, delit = {0};
    char *mask_source = NULL;
    int rc = HD_EXIT_OK;
    if (hd_image_read_as(image_path, 3, &tex) != HD_OK ||
        hd_face_mask_read(image_path, mask_path, tex.width, tex.height, &mask, &mask_source) != HD_OK ||
        hd_model_load(model_path, &model) != HD_OK || hd_delight_face(model, &tex, &mask, &delit) != HD_OK ||
        hd_image_write_png(out, &delit, 8) != HD_OK)
        rc = hd_report("delight");
    else if (mask_path && mask_source && strcmp(mask_source, mask_path) != 0)
        fprintf(stderr, "hdnet delight: note: used %s beside the image, not --mask %s\n", mask_source, mask_path);
    hd_image_free(&delit);
    hd_image_free(&tex);
    hd_image_free(&mask);
    if (model) hd_model_free(model);
    free(mask_source);
    return rc;
}
