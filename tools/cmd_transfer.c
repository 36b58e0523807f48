/* cmd_transfer.c: `hdnet transfer`: relights the faces of a photo, or an aligned face texture, under
 * the light the model estimates for a reference face (a photo's best face, or an aligned texture;
 * docs/usage.md). Exactly `hdnet estimate-light REF` followed by `hdnet relight IMG --light`
 * (bit-identical); hd_estimate_light(_photo), hd_relight_face and hd_relight_photo are the cores,
 * this file is the file handling. */
#include <stdlib.h>
#include <string.h>
#include "cli.h"
#include "video_cli.h"

CLI_COMMAND("transfer", cmd_transfer, "relight the faces of a photo (or an aligned face) with the light of a reference face")

int cmd_transfer(int argc, char **argv)
{
    const char *model_path = NULL, *out = NULL, *mask_path = NULL, *ref_path = NULL;
    int keep = 0, no_keep = 0, aligned = 0;
    hd_cli_clip clip = {0};
    const cli_opt opts[] = {
        {"ref", 0, CLI_OPT_STRING, &ref_path, "REF", "the photo (its best face) or aligned face whose light is taken"},
        CLI_OPT_MODEL_ROW(model_path),
        {"output", 'o', CLI_OPT_STRING, &out, "OUT.png", "the relit image (8-bit PNG, or .pfm float32; the input's size)"},
        CLI_OPT_FACE_MASK_ROW(mask_path),
        {"keep-brightness", 0, CLI_OPT_FLAG, &keep, NULL, "keep the input's mean brightness over the mask (default)"},
        {"no-keep-brightness", 0, CLI_OPT_FLAG, &no_keep, NULL, "use the reference light's own level"},
        {"aligned", 0, CLI_OPT_FLAG, &aligned, NULL,
         "IMG and REF are aligned face textures, not photos (automatic for a file with NAME.mask.png or "
         "NAME.normal.png beside it)"},
        HD_OPT_CLIP_ROWS(clip),
        {NULL, 0, 0, NULL, NULL, NULL},
    };
    const cli_cmd_spec spec = {
        "transfer", "IMG --ref REF [-m MODEL] -o OUT.png [--aligned]",
        "Estimates the light of the reference REF with the model (a photo: its best-scoring face) and\n"
        "relights IMG under it: every face of a photo (aligned, relit, warped back, Poisson-blended), or\n"
        "an aligned face texture with --aligned (masked-out pixels keep the input).",
        opts, 1, 1};
    char **pos = NULL;
    int npos = 0, code = 0;
    if (cli_opts_parse(&spec, argc, argv, &pos, &npos, &code)) return code;
    const char *image_path = pos[0];
    free(pos);
    if (!ref_path) return cli_usage_error(&spec, "--ref is required");
    if (!out) return cli_usage_error(&spec, "-o is required");
    if (keep && no_keep) return cli_usage_error(&spec, "--keep-brightness and --no-keep-brightness exclude each other");
    const hd_brightness brightness = no_keep ? HD_BRIGHTNESS_FREE : HD_BRIGHTNESS_KEEP;
    if (hd_cli_is_clip(image_path, &clip)) /* a video, or a folder of frames with --fps */
        return hd_cli_video("transfer", image_path, out, model_path, NULL, ref_path, brightness, &clip);

    const int photo = !aligned && hd_input_kind_of(image_path) == HD_INPUT_PHOTO;
    const int ref_photo = !aligned && hd_input_kind_of(ref_path) == HD_INPUT_PHOTO;
    hd_model *model = NULL;
    hd_aligner *aligner = NULL;
    hd_image tex = {0}, ref = {0}, mask = {0}, relit = {0};
    char *mask_source = NULL;
    float light[HD_SH_COEFFS];
    int rc = CLI_EXIT_FAIL, nfaces = 0;
    if (hd_image_read_as(image_path, 3, &tex) != HD_OK || hd_image_read_as(ref_path, 3, &ref) != HD_OK ||
        (!photo && hd_face_mask_read(image_path, mask_path, tex.width, tex.height, &mask, &mask_source) != HD_OK) ||
        hd_model_load(model_path, &model) != HD_OK || ((photo || ref_photo) && hd_aligner_load(&aligner) != HD_OK)) {
        rc = cli_report("transfer");
        goto done;
    }
    /* the reference's light, then IMG relit under it (as estimate-light + relight --light) */
    hd_status st = ref_photo ? hd_estimate_light_photo(model, aligner, &ref, light, &nfaces)
                             : hd_estimate_light(model, &ref, light);
    if (st != HD_OK) {
        rc = ref_photo ? cli_report_photo("transfer", st, ref_path) : cli_report("transfer");
        goto done;
    }
    if (ref_photo && nfaces > 1)
        fprintf(stderr, "hdnet transfer: note: %s has %d faces; the light is that of face 0 (best score)\n", ref_path,
                nfaces);
    if (photo) {
        st = hd_relight_photo(model, aligner, &tex, (const float (*)[HD_SH_COEFFS])&light, 1, brightness, &relit, NULL,
                              &nfaces);
        if (st != HD_OK) {
            rc = cli_report_photo("transfer", st, image_path);
            goto done;
        }
    } else if (hd_relight_face(model, &tex, &mask, light, brightness, &relit) != HD_OK) {
        rc = cli_report("transfer");
        goto done;
    }
    if (hd_image_write_picture(out, &relit) != HD_OK) {
        rc = cli_report("transfer");
        goto done;
    }
    cli_note_mask("transfer", photo, mask_path, mask_source);
    rc = CLI_EXIT_OK;
done:
    hd_image_free(&relit);
    hd_image_free(&tex);
    hd_image_free(&ref);
    hd_image_free(&mask);
    if (model) hd_model_free(model);
    hd_aligner_free(aligner);
    free(mask_source);
    return rc;
}
