/* cmd_transfer.c: `hdnet transfer`: relights the faces of photos, or aligned face textures, under
 * the light the model estimates for a reference face (a photo's best face, or an aligned texture;
 * docs/usage.md). Exactly `hdnet estimate-light REF` followed by `hdnet relight IMG --light`
 * (bit-identical): hd_estimate_light(_photo) for the reference, then hd_apply_photo /
 * hd_apply_texture through the per-photo step relight, delight and transfer share (apply_cli.c),
 * run by the batch loop (batch.c) over every input; the rest is options. */
#include <stdlib.h>
#include <string.h>
#include "apply_cli.h"
#include "cli.h"
#include "video_cli.h"

CLI_COMMAND("transfer", cmd_transfer, "relight the faces of photos (or aligned faces) with the light of a reference face")

static hd_status transfer_one(void *ctx, const cli_input *in, const char *out, int single, cli_result *r)
{
    hd_image tex = {0};
    hd_apply_result res;
    hd_status st = cli_apply_input(ctx, in, &tex, &res, r);
    if (st == HD_OK) st = cli_apply_write(in, out, single, ".transfer.png", 0, &res.relit[0], r);
    hd_apply_result_free(&res);
    hd_image_free(&tex);
    return st;
}

int cmd_transfer(int argc, char **argv)
{
    const char *model_path = NULL, *out = NULL, *mask_path = NULL, *ref_path = NULL, *source = NULL;
    cli_scene scene = {NULL, NULL};
    int keep = 0, no_keep = 0, aligned = 0, threads = 0, quiet = 0;
    cli_clip clip = {0};
    float min_score = cli_min_score_default();
    const cli_opt opts[] = {
        {"ref", 0, CLI_OPT_STRING, &ref_path, "REF", "the photo (its best face) or aligned face whose light is taken"},
        CLI_OPT_MODEL_ROW(model_path),
        {"output", 'o', CLI_OPT_STRING, &out, "OUT",
         "one input: the relit image (8-bit PNG, or .pfm float32; the input's size); many inputs or a "
         "folder: the output folder (OUT/NAME.transfer.png)"},
        CLI_OPT_FACE_MASK_ROW(mask_path),
        {"keep-brightness", 0, CLI_OPT_FLAG, &keep, NULL, "keep the input's mean brightness over the mask (default)"},
        {"no-keep-brightness", 0, CLI_OPT_FLAG, &no_keep, NULL, "use the reference light's own level"},
        {"aligned", 0, CLI_OPT_FLAG, &aligned, NULL,
         "IMG and REF are aligned face textures, not photos (automatic for a file with NAME.mask.png or "
         "NAME.normal.png beside it)"},
        CLI_OPT_APPLY_TAIL_ROWS(source, scene, clip, min_score, threads, quiet),
    };
    const cli_cmd_spec spec = {
        "transfer", "IMG|DIR|@LIST ... --ref REF [-m MODEL] -o OUT [--aligned]",
        "Estimates the light of the reference REF with the model (a photo: its best-scoring face; the\n"
        "face's light of --source-light, as `hdnet estimate-light` writes it) and\n"
        "relights IMG under it by the rule of `hdnet relight`: every face of a photo, or\n"
        "an aligned face texture with --aligned (masked-out pixels keep the input). Many inputs (files,\n"
        "folders walked recursively, @LIST files of paths) share one model load and the reference's\n"
        "light, and write OUT/REL/NAME.transfer.png; a photo that cannot be read or has no face is\n"
        "reported and skipped, and the exit status is then 1.",
        opts, 1, -1};
    char **pos = NULL;
    int npos = 0, code = 0;
    if (cli_opts_parse(&spec, argc, argv, &pos, &npos, &code)) return code;
    if ((code = cli_opts_common(&spec, threads, min_score)) || (!ref_path && (code = cli_usage_error(&spec, "--ref is required"))) ||
        (!out && (code = cli_usage_error(&spec, "-o is required"))) ||
        (keep && no_keep &&
         (code = cli_usage_error(&spec, "--keep-brightness and --no-keep-brightness exclude each other")))) {
        free(pos);
        return code;
    }
    hd_source_light src = HD_SOURCE_FIT;
    if ((source && (code = cli_source_light_parse(&spec, source, &src))) ||
        (code = cli_scene_set(&spec, &scene, npos == 1 && cli_is_clip(pos[0], &clip) ? &clip : NULL, NULL))) {
        free(pos);
        return code;
    }
    if (npos == 1 && cli_is_clip(pos[0], &clip)) { /* a video, or a folder of frames with --fps */
        if (src != HD_SOURCE_FIT) {
            free(pos);
            return cli_usage_error(&spec, "a clip takes the fitted source light (--source-light fit)");
        }
        code = cli_video("transfer", pos[0], out, model_path, NULL, ref_path,
                            no_keep ? HD_BRIGHTNESS_FREE : HD_BRIGHTNESS_KEEP, &clip);
        free(pos);
        return code;
    }
    float light[HD_SH_COEFFS];
    hd_light_rgb rgb;
    /* the mask note of photos is printed once below, before the run */
    cli_apply_run run = {"transfer", {&rgb, 1, 0, 0, HD_RULE_RATIO, no_keep ? HD_BRIGHTNESS_FREE : HD_BRIGHTNESS_KEEP,
                                     src, 0.0f, "transfer"},
                         mask_path, aligned, 1, min_score, NULL, NULL};
    int single = 0;
    if ((code = cli_output_mode(&spec, pos, npos, out, NULL, &single))) {
        free(pos);
        return code;
    }
    const int ref_photo = !aligned && hd_input_kind_of(ref_path) == HD_INPUT_PHOTO;
    cli_inputs in = {0};
    hd_image ref = {0}, ref_mask = {0};
    int rc = CLI_EXIT_FAIL, nfaces = 0;
    /* one model and aligner for the reference and every input */
    int photos = 0;
    hd_status st = cli_inputs_collect(&in, pos, npos);
    for (int i = 0; i < in.count && !aligned; i++) photos += hd_input_kind_of(in.v[i].path) == HD_INPUT_PHOTO;
    if (st != HD_OK || hd_image_read_as(ref_path, 3, &ref) != HD_OK || hd_model_load(model_path, &run.model) != HD_OK ||
        ((ref_photo || photos) && hd_aligner_load(&run.aligner) != HD_OK)) {
        rc = cli_report("transfer");
        goto done;
    }
    if ((code = cli_scene_set(&spec, &scene, NULL, run.model))) {
        rc = code;
        goto done;
    }
    hd_aligner_set_min_score(run.aligner, min_score);
    /* an aligned reference's light is fitted over its companion mask (none: the whole texture) */
    if (!ref_photo) st = hd_face_mask_read(ref_path, NULL, ref.width, ref.height, &ref_mask, NULL);
    if (st == HD_OK)
        st = ref_photo ? hd_estimate_face_light_photo(run.model, run.aligner, &ref, src, light, &nfaces)
                       : hd_estimate_face_light(run.model, &ref, &ref_mask, src, light);
    if (st != HD_OK) {
        rc = ref_photo ? cli_report_photo("transfer", st, ref_path) : cli_report("transfer");
        goto done;
    }
    hd_light_rgb_from_grey(light, &rgb);
    if (ref_photo && nfaces > 1)
        fprintf(stderr, "hdnet transfer: note: %s has %d faces; the light is that of face 0 (best score)\n", ref_path,
                nfaces);
    if (photos) cli_note_mask("transfer", 1, mask_path, NULL);
    rc = cli_batch_run("transfer", "relit", CLI_NO_FACE_ALIGNED, &in, out, single, quiet, transfer_one, &run, NULL);
done:
    hd_image_free(&ref);
    hd_image_free(&ref_mask);
    if (run.model) hd_model_free(run.model);
    hd_aligner_free(run.aligner);
    cli_inputs_free(&in);
    free(pos);
    return rc;
}
