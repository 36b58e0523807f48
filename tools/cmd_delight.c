/* cmd_delight.c: `hdnet delight`: the faces of photos, or aligned face textures, under flat light by
 * the relighting rule (docs/usage.md: I * (1 + g) / (s(N, l_face) + g), feathered, brightness kept),
 * the input outside the faces. The work is hd_apply_photo / hd_apply_texture through the per-photo
 * step relight, delight and transfer share (apply_cli.c), run by the batch loop (batch.c) over
 * every input; the rest is options. */
#include <stdlib.h>
#include <string.h>
#include "apply_cli.h"
#include "cli.h"
#include "video_cli.h"

CLI_COMMAND("delight", cmd_delight, "remove the lighting of the faces of photos or of aligned faces (albedo under flat light)")

static hd_status delight_one(void *ctx, const cli_input *in, const char *out, int single, cli_result *r)
{
    hd_image tex = {0};
    hd_apply_result res;
    hd_status st = cli_apply_input(ctx, in, &tex, &res, r);
    if (st == HD_OK) st = cli_apply_write(in, out, single, ".delit.png", 0, &res.delit, r);
    hd_apply_result_free(&res);
    hd_image_free(&tex);
    return st;
}

int cmd_delight(int argc, char **argv)
{
    const char *model_path = NULL, *out = NULL, *mask_path = NULL, *source = NULL;
    cli_scene scene = {NULL, NULL};
    int aligned = 0, threads = 0, quiet = 0;
    cli_clip clip = {0};
    float min_score = cli_min_score_default();
    const cli_opt opts[] = {
        CLI_OPT_MODEL_ROW(model_path),
        {"output", 'o', CLI_OPT_STRING, &out, "OUT",
         "one input: the delit image (8-bit PNG, or .pfm float32; the input's size); many inputs or a "
         "folder: the output folder (OUT/NAME.delit.png)"},
        CLI_OPT_FACE_MASK_ROW(mask_path),
        CLI_OPT_ALIGNED_ROW(aligned),
        CLI_OPT_APPLY_TAIL_ROWS(source, scene, clip, min_score, threads, quiet),
    };
    const cli_cmd_spec spec = {
        "delight", "IMG|DIR|@LIST ... [-m MODEL] -o OUT [--aligned [--mask M.png]]",
        "Removes the lighting of every face of a photo: each face is aligned and decomposed, and the photo\n"
        "is multiplied by (1 + g) / (s(N, l_face) + g), the change from the face's own light to a\n"
        "flat one on the predicted normals (docs/usage.md), faded to nothing at the face's edge, with the\n"
        "face's mean brightness kept. With --aligned (or a companion NAME.mask.png / NAME.normal.png) IMG\n"
        "is an aligned face texture: changed inside the mask, the input where it is not. Many inputs\n"
        "(files, folders walked recursively, @LIST files of paths) share one model load and write\n"
        "OUT/REL/NAME.delit.png; a photo that cannot be read or has no face is reported and skipped, and\n"
        "the exit status is then 1.",
        opts, 1, -1};
    char **pos = NULL;
    int npos = 0, code = 0;
    if (cli_opts_parse(&spec, argc, argv, &pos, &npos, &code)) return code;
    cli_inputs in = {0};
    cli_apply_run run = {"delight", {NULL, 0, 1, 0, HD_RULE_RATIO, HD_BRIGHTNESS_KEEP, HD_SOURCE_FIT, 0.0f, "delight"}, mask_path, aligned, 0,
                         min_score, NULL, NULL};
    int rc = CLI_EXIT_FAIL;
    if ((code = cli_opts_common(&spec, threads, min_score)) || (!out && (code = cli_usage_error(&spec, "-o is required"))) ||
        (source && (code = cli_source_light_parse(&spec, source, &run.request.source))) ||
        (code = cli_scene_set(&spec, &scene, npos == 1 && cli_is_clip(pos[0], &clip) ? &clip : NULL, NULL))) {
        free(pos);
        return code;
    }
    if (npos == 1 && cli_is_clip(pos[0], &clip)) { /* a video, or a folder of frames with --fps */
        if (run.request.source != HD_SOURCE_FIT) {
            free(pos);
            return cli_usage_error(&spec, "a clip takes the fitted source light (--source-light fit)");
        }
        rc = cli_video("delight", pos[0], out, model_path, NULL, NULL, HD_BRIGHTNESS_KEEP, &clip);
        free(pos);
        return rc;
    }
    int single = 0;
    if ((code = cli_output_mode(&spec, pos, npos, out, NULL, &single))) {
        free(pos);
        return code;
    }
    if (cli_inputs_collect(&in, pos, npos) != HD_OK || hd_model_load(model_path, &run.model) != HD_OK)
        rc = cli_report("delight");
    else if ((code = cli_scene_set(&spec, &scene, NULL, run.model)))
        rc = code;
    else
        rc = cli_batch_run("delight", "delit", CLI_NO_FACE_ALIGNED, &in, out, single, quiet, delight_one, &run, NULL);
    if (run.model) hd_model_free(run.model);
    hd_aligner_free(run.aligner);
    cli_inputs_free(&in);
    free(pos);
    return rc;
}
