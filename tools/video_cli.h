/* video_cli.h: what relight, delight and transfer do with a clip (a video file, or a folder of
 * frames given with --fps) instead of a photo: the option rows and the one call. */
#ifndef HD_VIDEO_CLI_H
#define HD_VIDEO_CLI_H

#include "hdnet.h"

typedef struct cli_clip {
    float fps;     /* --fps: a folder input is a clip at this frame rate (0: not given) */
    int no_smooth; /* --no-smooth */
    hd_background background; /* --background (cli_scene_set) */
    hd_shadows shadows;       /* --shadows (cli_scene_set) */
} cli_clip;

#define CLI_OPT_CLIP_ROWS(c)                                                                                            \
    {"fps", 0, CLI_OPT_FLOAT, &(c).fps, "N",                                                                            \
     "IMG is a folder of frames (in name order) of a clip at N frames per second, smoothed as a video; -o names "      \
     "a video file or a folder of PNG frames"},                                                                        \
    {"no-smooth", 0, CLI_OPT_FLAG, &(c).no_smooth, NULL,                                                               \
     "with a clip: no smoothing of the estimated light, shading and normals across frames"}

/* Whether the input is a clip: a video file (by extension), or a folder with --fps. */
int cli_is_clip(const char *input, const cli_clip *clip);
/* Relights the clip `in` into `out`: under `light`; or (light NULL) under the light estimated for
 * the reference `ref` (a photo's best face or an aligned texture); or (both NULL) delights. Prints
 * what it wrote; returns the exit code. */
int cli_video(const char *cmd, const char *in, const char *out, const char *model_path, const float *light,
                 const char *ref, hd_brightness brightness, const cli_clip *clip);

#endif /* HD_VIDEO_CLI_H */
