/* apply_cli.h: the per-photo step that relight, delight and transfer share: one input read and
 * changed by hd_apply_photo or hd_apply_texture (src/apply/apply.c, the one home for applying a
 * model), and its pictures written by the naming rule of batch.h. */
#ifndef HD_APPLY_CLI_H
#define HD_APPLY_CLI_H

#include "batch.h"
#include "hdnet_tool.h"

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

#endif /* HD_APPLY_CLI_H */
