/* video.h: relighting video clips (docs/usage.md, "Video"). A clip is a video file, read and
 * written through FFmpeg's libraries when the build has them (HD_HAVE_FFMPEG), or a folder of
 * frames (PNG, JPEG or PFM, in name order), which needs nothing more. Each frame goes through the
 * photo pipeline (detect, landmarks, align, decompose, relight, warp back, blend) with the state
 * that makes it temporally stable: faces are tracked from frame to frame, and the decomposition's
 * estimated light and its shading and normal maps (in the aligned texture space, where a face
 * keeps its place whatever the head does) are smoothed by a low-pass of fixed cutoff; the
 * landmarks can be smoothed too, by a one-euro filter, before the face is unwarped. */
#ifndef HD_VIDEO_H
#define HD_VIDEO_H

#include "hdnet.h"

#ifndef HD_HAVE_FFMPEG
#define HD_HAVE_FFMPEG 0 /* the Makefile sets 1 when pkg-config finds FFmpeg's libraries */
#endif

/* ------------------------------------------------------------------ clips */

/* Whether a path names a video file (by extension: .mp4 .mov .mkv .avi .webm .m4v .mpg .mpeg). */
int hd_path_is_video(const char *path);
/* Whether this build reads and writes video files (FFmpeg's libraries were found at build time). */
int hd_video_supported(void);
/* What to do when it does not. */
#define HD_VIDEO_HOW_TO                                                                              \
    "this build has no video support: install FFmpeg's libraries (Debian: apt-get install "         \
    "libavformat-dev libavcodec-dev libswscale-dev libavutil-dev) and rebuild (make clean; make), " \
    "or give a folder of frames"

typedef struct hd_clip_reader hd_clip_reader;
/* Opens a video file or a folder of frames. fps: the file's frame rate (a folder: `fps`, the
 * caller's choice, > 0). */
hd_status hd_clip_open(const char *path, double folder_fps, hd_clip_reader **reader);
/* The next frame as a 3-channel image (allocated); *got 0 at the end. */
hd_status hd_clip_read(hd_clip_reader *reader, hd_image *frame, int *got);
double hd_clip_fps(const hd_clip_reader *reader);
/* Frames in the clip if known (a folder; a file's container estimate, 0 if unknown). */
long hd_clip_frames(const hd_clip_reader *reader);
void hd_clip_close(hd_clip_reader *reader);

typedef struct hd_clip_writer hd_clip_writer;
/* Creates a video file (by its extension; the container's default video codec, the source's frame
 * rate, the source's audio stream copied as it is) or, for any other path, a folder of PNG frames
 * (NAME/frame000000.png ...). `source` is the clip the frames come from (its frame rate and audio). */
hd_status hd_clip_create(const char *path, const hd_clip_reader *source, int width, int height,
                         hd_clip_writer **writer);
hd_status hd_clip_write(hd_clip_writer *writer, const hd_image *frame);
/* Finishes the file (the audio is copied here for video files). On failure, or when called with
 * ok 0, the partial output is removed. */
hd_status hd_clip_finish(hd_clip_writer *writer, int ok);

/* ------------------------------------------------------------------ the frame loop */

typedef struct hd_video_options {
    int smooth;                /* 1 (default): smooth the decomposition (light, shading, normals) */
    int smooth_landmarks;      /* 1: also the landmarks (default 0: it lowers the flicker of a still
                                * camera's clip and raises a shaking one's, docs/video.md) */
    float landmark_min_cutoff; /* one-euro filter of the landmarks: Hz when still (default 3) */
    float landmark_beta;       /* cutoff rise per face width per second of speed (default 60) */
    float light_cutoff;        /* Hz: low-pass of the light, shading and normals (default 1.5) */
} hd_video_options;
void hd_video_options_default(hd_video_options *o);

/* What a frame's background took with the background relit (HD_BACKGROUND_RELIGHT). */
typedef enum hd_video_wall {
    HD_VIDEO_WALL_KEPT = 0, /* none: the background kept (the model's setting, or no earlier frame had a
                             * change to hold, or it was held long enough: docs/video.md, "Limits") */
    HD_VIDEO_WALL_OWN,      /* the change of this frame's first face's light */
    HD_VIDEO_WALL_HELD      /* the last such frame's change (no face, or a face without its person) */
} hd_video_wall;

/* What one frame gave. */
typedef struct hd_video_frame_info {
    int faces;                      /* faces relit in this frame */
    hd_video_wall wall;             /* its background */
    int has_light;                  /* 1 when light[] holds the first face's (smoothed) light */
    float light[HD_SH_COEFFS];
} hd_video_frame_info;

typedef struct hd_video_relighter hd_video_relighter;
/* light NULL: delight (flat light); else relight under `light` (a preset, a file, or for transfer
 * the light estimated for a reference face). The model and aligner stay the caller's. */
hd_status hd_video_relighter_new(hd_model *model, hd_aligner *aligner, const float *light, hd_brightness brightness,
                                 const hd_video_options *options, hd_video_relighter **out);
/* The clip's frame rate (default 30): the filters' time step. */
void hd_video_relighter_set_fps(hd_video_relighter *v, double fps);
/* Relights one frame (3 channels) into *out (allocated; the frame itself where no face is found,
 * but for a held wall: with the background relit, a frame without a face, or with a face whose
 * person the segmentation does not find, takes the wall's change of the last frame that had one,
 * over that frame's people for up to a second, then fading them out over another: docs/video.md). */
hd_status hd_video_relight_frame(hd_video_relighter *v, const hd_image *frame, hd_image *out,
                                 hd_video_frame_info *info);
void hd_video_relighter_free(hd_video_relighter *v);

/* What a whole clip gave. */
typedef struct hd_video_report {
    long frames, frames_with_face;
    long frames_wall_held; /* frames whose wall took an earlier frame's change (HD_VIDEO_WALL_HELD) */
    double light_change;  /* mean over consecutive frames with a face of |light_t - light_t-1| (L2
                           * over the 9 coefficients of the first face): the light's flicker */
    double seconds;
} hd_video_report;
/* Reads `in`, relights every frame with v, writes `out` (hd_clip_create). folder_fps for a folder
 * of frames. Prints nothing; the report says what happened. */
hd_status hd_video_relight_clip(hd_video_relighter *v, const char *in, const char *out, double folder_fps,
                                hd_video_report *report);

#endif /* HD_VIDEO_H */
