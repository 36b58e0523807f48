/* apply_cli.c: the per-photo step of relight, delight and transfer (apply_cli.h): read, align on
 * demand, apply the request through src/apply/apply.c, write by the naming rule. */
#include <stdlib.h>
#include <string.h>
#include "apply_cli.h"
#include "cli.h"

hd_status cli_apply_input(cli_apply_run *run, const cli_input *in, hd_image *picture, hd_apply_result *res,
                          cli_result *r)
{
    memset(res, 0, sizeof *res);
    const int photo = !run->aligned && hd_input_kind_of(in->path) == HD_INPUT_PHOTO;
    hd_image mask = {0};
    char *mask_source = NULL;
    hd_status st = hd_image_read_as(in->path, 3, picture);
    if (st == HD_OK && photo && !run->aligner) {
        st = hd_aligner_load(&run->aligner);
        if (st == HD_OK) hd_aligner_set_min_score(run->aligner, run->min_score);
    }
    run->request.operation = run->cmd; /* the reasons name the command's operation */
    if (st == HD_OK && photo) {
        if (run->mask_path && !run->noted++) cli_note_mask(run->cmd, 1, run->mask_path, NULL);
        st = hd_apply_photo(run->model, run->aligner, picture, &run->request, res);
        r->faces = res->nfaces;
    } else if (st == HD_OK) {
        st = hd_face_mask_read(in->path, run->mask_path, picture->width, picture->height, &mask, &mask_source);
        if (st == HD_OK) cli_note_mask(run->cmd, 0, run->mask_path, mask_source);
        if (st == HD_OK) st = hd_apply_texture(run->model, picture, &mask, &run->request, res);
        r->faces = 1;
    }
    hd_image_free(&mask);
    free(mask_source);
    if (st != HD_OK) hd_image_free(picture);
    return st;
}

hd_status cli_apply_write(const cli_input *in, const char *out, int single, const char *suffix, int index,
                          const hd_image *pic, cli_result *r)
{
    char *path = single ? strdup(out) : cli_output_path(out, in, suffix);
    if (!path) return HD_ERR_NOMEM;
    hd_status st = hd_image_write_picture(path, pic);
    if (st == HD_OK && index == 0) snprintf(r->wrote, sizeof r->wrote, "%s", path);
    free(path);
    return st;
}

int cli_white_balance_set(const cli_cmd_spec *spec, const char *value, hd_model *model)
{
    if (!value) return 0;
    hd_white_balance mode;
    if (strcmp(value, "off") == 0) mode = HD_WHITE_BALANCE_OFF;
    else if (strcmp(value, "eyes") == 0) mode = HD_WHITE_BALANCE_EYES;
    else return cli_usage_error(spec, "--white-balance wants off or eyes, got '%s'", value);
    return model && hd_model_set_white_balance(model, mode) != HD_OK ? cli_report(spec->name) : 0;
}

int cli_scene_set(const cli_cmd_spec *spec, const cli_scene *scene, cli_clip *clip, hd_model *model)
{
    hd_background background = HD_BACKGROUND_KEEP;
    hd_shadows shadows = HD_SHADOWS_CAST;
    const char *b = scene->background, *s = scene->shadows;
    if (b && strcmp(b, "relight") == 0) background = HD_BACKGROUND_RELIGHT;
    else if (b && strcmp(b, "keep") != 0) return cli_usage_error(spec, "--background wants keep or relight, got '%s'", b);
    if (s && strcmp(s, "none") == 0) shadows = HD_SHADOWS_NONE;
    else if (s && strcmp(s, "cast") != 0) return cli_usage_error(spec, "--shadows wants cast or none, got '%s'", s);
    if (clip) clip->background = background, clip->shadows = shadows;
    if (model && (hd_model_set_background(model, background) != HD_OK || hd_model_set_shadows(model, shadows) != HD_OK))
        return cli_report(spec->name);
    return 0;
}

int cli_source_light_parse(const cli_cmd_spec *spec, const char *value, hd_source_light *source)
{
    if (strcmp(value, "fit") == 0) *source = HD_SOURCE_FIT;
    else if (strcmp(value, "lnet") == 0) *source = HD_SOURCE_LNET;
    else return cli_usage_error(spec, "--source-light wants fit or lnet, got '%s'", value);
    return 0;
}
