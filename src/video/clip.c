/* clip.c: a clip is a video file (clip_ffmpeg.c, when the build has FFmpeg) or a folder of frames
 * (clip_frames.c); this file picks one by the path and hides which. */
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include "core/core.h"
#include "video/clip_ffmpeg.h"
#include "video/clip_frames.h"
#include "video/video.h"

int hd_path_is_video(const char *path)
{
    static const char *const ext[] = {".mp4", ".mov", ".mkv", ".avi", ".webm", ".m4v", ".mpg", ".mpeg"};
    const char *dot = path ? strrchr(path, '.') : NULL;
    if (!dot || strchr(dot, '/')) return 0;
    for (size_t i = 0; i < sizeof ext / sizeof ext[0]; i++)
        if (!strcasecmp(dot, ext[i])) return 1;
    return 0;
}

int hd_video_supported(void) { return HD_HAVE_FFMPEG; }

struct hd_clip_reader {
    double fps;
    hd_frame_list frames; /* a folder */
    hd_av_reader *av;     /* a video file */
};

struct hd_clip_writer {
    hd_frame_folder folder;
    hd_av_writer *av;
};

hd_status hd_clip_open(const char *path, double folder_fps, hd_clip_reader **out)
{
    *out = NULL;
    struct stat sb;
    int dir = stat(path, &sb) == 0 && S_ISDIR(sb.st_mode);
    if (!dir && !hd_path_is_video(path)) return hd_fail(HD_ERR_ARG, "%s: neither a video file nor a folder of frames", path);
    if (!dir && !HD_HAVE_FFMPEG) return hd_fail(HD_ERR_ARG, "%s: %s", path, HD_VIDEO_HOW_TO);
    if (dir && !(folder_fps > 0.0 && folder_fps <= 1000.0))
        return hd_fail(HD_ERR_ARG, "%s: a frame rate in (0, 1000] is needed for a folder of frames", path);
    hd_clip_reader *r = hd_calloc(1, sizeof *r);
    if (!r) return HD_ERR_NOMEM;
    hd_status st;
    if (dir) {
        st = hd_frame_list_open(path, &r->frames);
        r->fps = folder_fps;
    } else {
#if HD_HAVE_FFMPEG
        st = hd_av_open(path, &r->av);
        if (st == HD_OK) r->fps = hd_av_fps(r->av);
#else
        st = HD_ERR_ARG;
#endif
    }
    if (st != HD_OK) {
        hd_clip_close(r);
        return st;
    }
    *out = r;
    return HD_OK;
}

hd_status hd_clip_read(hd_clip_reader *r, hd_image *frame, int *got)
{
#if HD_HAVE_FFMPEG
    if (r->av) return hd_av_read(r->av, frame, got);
#endif
    return hd_frame_list_read(&r->frames, frame, got);
}

double hd_clip_fps(const hd_clip_reader *r) { return r->fps; }

long hd_clip_frames(const hd_clip_reader *r)
{
#if HD_HAVE_FFMPEG
    if (r->av) return hd_av_frames(r->av);
#endif
    return r->frames.count;
}

void hd_clip_close(hd_clip_reader *r)
{
    if (!r) return;
#if HD_HAVE_FFMPEG
    hd_av_close(r->av);
#endif
    hd_frame_list_free(&r->frames);
    free(r);
}

hd_status hd_clip_create(const char *path, const hd_clip_reader *source, int width, int height, hd_clip_writer **out)
{
    *out = NULL;
    if (hd_path_is_video(path) && !HD_HAVE_FFMPEG) return hd_fail(HD_ERR_ARG, "%s: %s", path, HD_VIDEO_HOW_TO);
    hd_clip_writer *w = hd_calloc(1, sizeof *w);
    if (!w) return HD_ERR_NOMEM;
    hd_status st;
    if (hd_path_is_video(path)) {
#if HD_HAVE_FFMPEG
        st = hd_av_create(path, source ? source->av : NULL, width, height, &w->av);
#else
        (void)source, (void)width, (void)height;
        st = HD_ERR_ARG;
#endif
    } else {
        st = hd_frame_folder_create(path, &w->folder);
    }
    if (st != HD_OK) {
        free(w->folder.dir);
        free(w);
        return st;
    }
    *out = w;
    return HD_OK;
}

hd_status hd_clip_write(hd_clip_writer *w, const hd_image *frame)
{
#if HD_HAVE_FFMPEG
    if (w->av) return hd_av_write(w->av, frame);
#endif
    return hd_frame_folder_write(&w->folder, frame);
}

hd_status hd_clip_finish(hd_clip_writer *w, int ok)
{
    if (!w) return HD_OK;
    hd_status st = HD_OK;
#if HD_HAVE_FFMPEG
    if (w->av) st = hd_av_finish(w->av, ok);
    else
#endif
        hd_frame_folder_finish(&w->folder, ok);
    free(w);
    return st;
}
