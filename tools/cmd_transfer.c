/* cmd_transfer.c: `hdnet transfer`: relights an aligned face under the light the model estimates
 * for a reference face (docs/usage.md). hd_transfer_face is the texture-in, texture-out core
 * (bit-identical to `hdnet estimate-light REF` followed by `hdnet relight IMG --light`); this
 * file is the file handling. */
#include <stdlib.h>
#include <string.h>
#include "cli.h"

HD_COMMAND("transfer", cmd_transfer, "relight an aligned face with the light of a reference face")

int cmd_transfer(int argc, char **argv)
{
    const char *model_path = NULL, *out = NULL, *mask_path = NULL, *ref_path = NULL;
    int keep = 0, no_keep = 0;
    const hd_opt opts[] = {
        {"ref", 0, HD_OPT_STRING, &ref_path, "REF", "the aligned face whose light is taken"},
        {"model", 'm', HD_OPT_STRING, &model_path, "MODEL", "model file (default: the shipped hdnet-synth model)"},
        {"output", 'o', HD_OPT_STRING, &out, "OUT.png", "the relit image (PNG, 8 bit, the input's size)"},
        {"mask", 0, HD_OPT_STRING, &mask_path, "M.png", "face mask when IMG has no NAME.mask.png beside it (default: all ones)"},
        {"keep-brightness", 0, HD_OPT_FLAG, &keep, NULL, "keep the input's mean brightness over the mask (default)"},
        {"no-keep-brightness", 0, HD_OPT_FLAG, &no_keep, NULL, "use the reference light's own level"},
        {NULL, 0, 0, NULL, NULL, NULL},
    };
    const hd_cmd_spec spec = {
        "transfer", "IMG --ref REF [-m MODEL] -o OUT.png",
        "Estimates the light of the reference face REF with the model and relights IMG under it\n"
        "(both aligned face textures, SPEC section 2). Masked-out pixels keep the input.",
        opts, 1, 1};
    char **pos = NULL;
    int npos = 0, code = 0;
    if (hd_opts_parse(&spec, argc, argv, &pos, &npos, &code)) return code;
    const char *image_path = pos[0];
    free(pos);
    if (!ref_path) return hd_usage_error(&spec, "--ref is required");
    if (!out) return hd_usage_error(&spec, "-o is required");
    if (keep && no_keep) return hd_usage_error(&spec, "--keep-brightness and --no-keep-brightness exclude each other");
    const hd_brightness brightness = no_keep ? HD_BRIGHTNESS_FREE : HD_BRIGHTNESS_KEEP;

    hd_model *model = NULL;
    hd_image tex = {0}, ref = {0}, mask = {0}, relit = {0};
    char *mask_source = NULL;
    int rc = HD_EXIT_OK;
    if (hd_image_read_as(image_path, 3, &tex) != HD_OK || hd_image_read_as(ref_path, 3, &ref) != HD_OK ||
        hd_face_mask_read(image_path, mask_path, tex.width, tex.height, &mask, &mask_source) != HD_OK ||
        hd_model_load(model_path, &model) != HD_OK ||
        hd_transfer_face(model, &tex, &mask, &ref, brightness, &relit) != HD_OK ||
        hd_image_write_png(out, &relit, 8) != HD_OK)
        rc = hd_report("transfer");
    else if (mask_path && mask_source && strcmp(mask_source, mask_path) != 0)
        fprintf(stderr, "hdnet transfer: note: used %s beside the image, not --mask %s\n", mask_source, mask_path);
    hd_image_free(&relit);
    hd_image_free(&tex);
    hd_image_free(&ref);
    hd_image_free(&mask);
    if (model) hd_model_free(model);
    free(mask_source);
    return rc;
}
