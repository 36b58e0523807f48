/* cmd_delight.c: `hdnet delight`: the faces of a photo, or an aligned face texture, under flat
 * light, i.e. the paper's final albedo I / S (clamped) where the face's mask is set, the input
 * elsewhere (docs/usage.md). hd_delight_face is the texture-in, texture-out core and
 * hd_relight_photo its photo wrapper (align, delight each face, warp back, Poisson blend); this
 * file is the file handling. */
#include <stdlib.h>
#include <string.h>
#include "cli.h"
#include "video_cli.h"

CLI_COMMAND("delight", cmd_delight, "remove the lighting of the faces of a photo or of an aligned face (albedo under flat light)")

int cmd_delight(int argc, char **argv)
{
    const char *model_path = NULL, *out = NULL, *mask_path = NULL;
    int aligned = 0;
    hd_cli_clip clip = {0};
    const cli_opt opts[] = {
        CLI_OPT_MODEL_ROW(model_path),
        {"output", 'o', CLI_OPT_STRING, &out, "OUT.png", "the delit image (8-bit PNG, or .pfm float32; the input's size)"},
        CLI_OPT_FACE_MASK_ROW(mask_path),
        CLI_OPT_ALIGNED_ROW(aligned),
        HD_OPT_CLIP_ROWS(clip),
        {NULL, 0, 0, NULL, NULL, NULL},
    };
    const cli_cmd_spec spec = {
        "delight", "IMG [-m MODEL] -o OUT.png [--aligned [--mask M.png]]",
        "Removes the lighting of every face of a photo: each face is aligned, replaced by its final albedo\n"
        "I / S (S the predicted shading, floored at 1e-3, the ratio clamped to [0, 1]) in the aligned\n"
        "texture space, warped back and Poisson-blended into the photo. With --aligned (or a companion\n"
        "NAME.mask.png / NAME.normal.png) IMG is an aligned face texture: the final albedo where the mask\n"
        "is set, the input where it is not.",
        opts, 1, 1};
    char **pos = NULL;
    int npos = 0, code = 0;
    if (cli_opts_parse(&spec, argc, argv, &pos, &npos, &code)) return code;
    const char *image_path = pos[0];
    free(pos);
    if (!out) return cli_usage_error(&spec, "-o is required");
    if (hd_cli_is_clip(image_path, &clip)) /* a video, or a folder of frames with --fps */
        return hd_cli_video("delight", image_path, out, model_path, NULL, NULL, HD_BRIGHTNESS_KEEP, &clip);

    const int photo = !aligned && hd_input_kind_of(image_path) == HD_INPUT_PHOTO;
    hd_model *model = NULL;
    hd_aligner *aligner = NULL;
    hd_image tex = {0}, mask = {0}, delit = {0};
    char *mask_source = NULL;
    int rc = CLI_EXIT_OK;
    if (photo) {
        int nfaces = 0;
        hd_status st = HD_OK;
        if (hd_image_read_as(image_path, 3, &tex) != HD_OK || hd_model_load(model_path, &model) != HD_OK ||
            hd_aligner_load(&aligner) != HD_OK) {
            rc = cli_report("delight");
        } else if ((st = hd_relight_photo(model, aligner, &tex, NULL, 0, HD_BRIGHTNESS_KEEP, NULL, &delit, &nfaces)) !=
                   HD_OK) {
            rc = cli_report_photo("delight", st, image_path);
        } else if (hd_image_write_picture(out, &delit) != HD_OK) {
            rc = cli_report("delight");
        } else {
            cli_note_mask("delight", 1, mask_path, NULL);
            printf("%s: delit %d face%s\n", image_path, nfaces, nfaces == 1 ? "" : "s");
        }
    } else if (hd_image_read_as(image_path, 3, &tex) != HD_OK ||
               hd_face_mask_read(image_path, mask_path, tex.width, tex.height, &mask, &mask_source) != HD_OK ||
               hd_model_load(model_path, &model) != HD_OK || hd_delight_face(model, &tex, &mask, &delit) != HD_OK ||
               hd_image_write_picture(out, &delit) != HD_OK) {
        rc = cli_report("delight");
    } else {
        cli_note_mask("delight", 0, mask_path, mask_source);
    }
    hd_image_free(&delit);
    hd_image_free(&tex);
    hd_image_free(&mask);
    if (model) hd_model_free(model);
    hd_aligner_free(aligner);
    free(mask_source);
    return rc;
}
