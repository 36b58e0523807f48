/* cmd_delight.c: `hdnet delight`: the faces of photos, or aligned face textures, under flat light,
 * i.e. the paper's final albedo I / S (clamped) where the face's mask is set, the input elsewhere
 * (docs/usage.md). hd_delight_face is the texture-in, texture-out core and hd_relight_photo its
 * photo wrapper (align, delight each face, warp back, Poisson blend); delight_one is the per-photo
 * step the batch loop (batch.c) runs over every input; the rest is file handling. */
#include <stdlib.h>
#include <string.h>
#include "batch.h"
#include "cli.h"
#include "video_cli.h"

CLI_COMMAND("delight", cmd_delight, "remove the lighting of the faces of photos or of aligned faces (albedo under flat light)")

typedef struct delight_run {
    const char *mask_path;
    int aligned, noted;
    float min_score;
    hd_model *model;
    hd_aligner *aligner;
} delight_run;

static hd_status delight_one(void *ctx, const cli_input *in, const char *out, int single, cli_result *r)
{
    delight_run *run = ctx;
    const int photo = !run->aligned && hd_input_kind_of(in->path) == HD_INPUT_PHOTO;
    hd_image tex = {0}, mask = {0}, delit = {0};
    char *mask_source = NULL, *path = NULL;
    hd_status st = hd_image_read_as(in->path, 3, &tex);
    if (st == HD_OK && photo && !run->aligner) {
        st = hd_aligner_load(&run->aligner);
        if (st == HD_OK) hd_aligner_set_min_score(run->aligner, run->min_score);
    }
    if (st == HD_OK && photo) {
        if (run->mask_path && !run->noted++) cli_note_mask("delight", 1, run->mask_path, NULL);
        st = hd_relight_photo(run->model, run->aligner, &tex, NULL, 0, HD_BRIGHTNESS_KEEP, NULL, &delit, &r->faces);
    } else if (st == HD_OK) {
        st = hd_face_mask_read(in->path, run->mask_path, tex.width, tex.height, &mask, &mask_source);
        if (st == HD_OK) cli_note_mask("delight", 0, run->mask_path, mask_source);
        if (st == HD_OK) st = hd_delight_face(run->model, &tex, &mask, &delit);
        r->faces = 1;
    }
    if (st == HD_OK && !(path = single ? strdup(out) : cli_output_path(out, in, ".delit.png"))) st = HD_ERR_NOMEM;
    if (st == HD_OK) st = hd_image_write_picture(path, &delit);
    if (st == HD_OK) snprintf(r->wrote, sizeof r->wrote, "%s", path);
    free(path);
    hd_image_free(&delit);
    hd_image_free(&tex);
    hd_image_free(&mask);
    free(mask_source);
    return st;
}

int cmd_delight(int argc, char **argv)
{
    const char *model_path = NULL, *out = NULL, *mask_path = NULL;
    int aligned = 0, threads = 0, quiet = 0;
    hd_cli_clip clip = {0};
    float min_score = cli_min_score_default();
    const cli_opt opts[] = {
        CLI_OPT_MODEL_ROW(model_path),
        {"output", 'o', CLI_OPT_STRING, &out, "OUT",
         "one input: the delit image (8-bit PNG, or .pfm float32; the input's size); many inputs or a "
         "folder: the output folder (OUT/NAME.delit.png)"},
        CLI_OPT_FACE_MASK_ROW(mask_path),
        CLI_OPT_ALIGNED_ROW(aligned),
        HD_OPT_CLIP_ROWS(clip),
        CLI_OPT_MIN_SCORE_ROW(min_score),
        CLI_OPT_THREADS_ROW(threads),
        CLI_OPT_QUIET_ROW(quiet),
        {NULL, 0, 0, NULL, NULL, NULL},
    };
    const cli_cmd_spec spec = {
        "delight", "IMG|DIR|@LIST ... [-m MODEL] -o OUT [--aligned [--mask M.png]]",
        "Removes the lighting of every face of a photo: each face is aligned, replaced by its final albedo\n"
        "I / S (S the predicted shading, floored at 1e-3, the ratio clamped to [0, 1]) in the aligned\n"
        "texture space, warped back and Poisson-blended into the photo. With --aligned (or a companion\n"
        "NAME.mask.png / NAME.normal.png) IMG is an aligned face texture: the final albedo where the mask\n"
        "is set, the input where it is not. Many inputs (files, folders walked recursively, @LIST files of\n"
        "paths) share one model load and write OUT/REL/NAME.delit.png; a photo that cannot be read or has\n"
        "no face is reported and skipped, and the exit status is then 1.",
        opts, 1, -1};
    char **pos = NULL;
    int npos = 0, code = 0;
    if (cli_opts_parse(&spec, argc, argv, &pos, &npos, &code)) return code;
    cli_inputs in = {0};
    delight_run run = {mask_path, aligned, 0, min_score, NULL, NULL};
    int rc = CLI_EXIT_FAIL;
    if ((code = cli_opts_common(&spec, threads, min_score)) || (!out && (code = cli_usage_error(&spec, "-o is required")))) {
        free(pos);
        return code;
    }
    if (npos == 1 && hd_cli_is_clip(pos[0], &clip)) { /* a video, or a folder of frames with --fps */
        rc = hd_cli_video("delight", pos[0], out, model_path, NULL, NULL, HD_BRIGHTNESS_KEEP, &clip);
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
    else
        rc = cli_batch_run("delight", "delit", &in, out, single, quiet, delight_one, &run, NULL);
    if (run.model) hd_model_free(run.model);
    hd_aligner_free(run.aligner);
    cli_inputs_free(&in);
    free(pos);
    return rc;
}
