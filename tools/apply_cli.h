/* apply_cli.h: the per-photo step that relight, delight and transfer share: one input read and
 * changed by hd_apply_photo or hd_apply_texture (src/apply/apply.c, the one home for applying a
 * model), and its pictures written by the naming rule of batch.h. */
#ifndef HD_APPLY_CLI_H
#define HD_APPLY_CLI_H

#include "batch.h"
#include "cli.h"
#include "hdnet_tool.h"
#include "video_cli.h"

/* What every input of a run shares. */
typedef struct cli_apply_run {
    const char *cmd;           /* "relight", for messages */
    hd_apply_request request;
    const char *mask_path;     /* --mask: aligned textures without a companion mask */
    int aligned;               /* --aligned: every input is an aligned texture */
    int noted;                 /* the --mask note of photos is printed once */
    float min_score;           /* --min-score of the aligner */
    hd_model *model;
    hd_aligner *aligner;       /* loaded at the first photo unless given */
} cli_apply_run;

/* Reads `in` into picture (3 channels) and applies run->request to it: a photo through
 * hd_apply_photo (every face), an aligned texture (its mask from hd_face_mask_read) through
 * hd_apply_texture. r->faces gets the faces done. On failure picture and res are freed. */
hd_status cli_apply_input(cli_apply_run *run, const cli_input *in, hd_image *picture, hd_apply_result *res,
                          cli_result *r);

/* Writes pic to the file -o names (single) or to OUT/REL + suffix; the first picture written
 * (index 0) is noted in r->wrote. */
hd_status cli_apply_write(const cli_input *in, const char *out, int single, const char *suffix, int index,
                          const hd_image *pic, cli_result *r);

/* --source-light fit|lnet: the face's own light of the ratio rule (docs/usage.md, "The source light"). */
#define CLI_OPT_SOURCE_LIGHT_ROW(var)                                                                                  \
    {"source-light", 0, CLI_OPT_STRING, &(var), "fit|lnet",                                                            \
     "the face's own light: fit, the least-squares light of the predicted shading on the predicted normals over "      \
     "the skin (the default), or lnet, L-Net's estimate"}
/* The rows every photo-applying command (relight, delight, transfer) ends its option table with:
 * the source light, the clip options of video_cli.h, the detector's minimum score, threads, quiet,
 * and the table's terminator (the file includes video_cli.h for the clip rows). */
#define CLI_OPT_APPLY_TAIL_ROWS(source, scene, clip, min_score, threads, quiet)                                        \
    CLI_OPT_SOURCE_LIGHT_ROW(source), CLI_OPT_SCENE_ROWS(scene), CLI_OPT_CLIP_ROWS(clip),                            \
        CLI_OPT_MIN_SCORE_ROW(min_score),                                                                              \
        CLI_OPT_THREADS_ROW(threads), CLI_OPT_QUIET_ROW(quiet), {NULL, 0, 0, NULL, NULL, NULL}
/* What a photo-applying command makes of the picture around the face's change: --background and
 * --shadows as given (NULL: the default). */
typedef struct cli_scene {
    const char *background, *shadows;
} cli_scene;
#define CLI_OPT_SCENE_ROWS(s)                                                                                           \
    {"background", 0, CLI_OPT_STRING, &(s).background, "keep|relight",                                                 \
     "the background of a photo or clip: keep it bit for bit (default), or relight it as a flat wall under the "      \
     "same light, and the body with the head (docs/usage.md, \"The background\")"},                                   \
    {"shadows", 0, CLI_OPT_STRING, &(s).shadows, "cast|none",                                                          \
     "the shadows the face casts on itself (the nose's, the brows'), under its own light and the new one: cast "       \
     "them (default) or none (docs/usage.md, \"Cast shadows\")"}
/* Reads the scene's values into model's background and shadow modes (model not NULL), or for a
 * clip (clip not NULL) into clip->background and clip->shadows, which cli_video sets on its model;
 * both NULL: checks them only. Returns 0, or the usage error's exit code. */
int cli_scene_set(const cli_cmd_spec *spec, const cli_scene *scene, cli_clip *clip, hd_model *model);
/* Reads a --source-light value; a usage error (nonzero) when it is neither. */
int cli_source_light_parse(const cli_cmd_spec *spec, const char *value, hd_source_light *source);

#endif /* HD_APPLY_CLI_H */
