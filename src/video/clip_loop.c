/* clip_loop.c: a whole clip through a relighter (video.h): read a frame, relight it, write it,
 * and keep the light's frame-to-frame change for the report. */
#include <math.h>
#include <string.h>
#include "core/core.h"
#include "video/video.h"

hd_status hd_video_relight_clip(hd_video_relighter *v, const char *in, const char *out, double folder_fps,
                                hd_video_report *report)
{
    memset(report, 0, sizeof *report);
    double t0 = hd_seconds();
    hd_clip_reader *r = NULL;
    hd_clip_writer *w = NULL;
    hd_status st = hd_clip_open(in, folder_fps, &r);
    if (st != HD_OK) return st;
    hd_video_relighter_set_fps(v, hd_clip_fps(r));
    hd_image frame = {0}, relit = {0};
    float prev[HD_SH_COEFFS];
    int have_prev = 0, width = 0, height = 0;
    double change = 0.0;
    long changes = 0;
    for (;;) {
        int got = 0;
        if ((st = hd_clip_read(r, &frame, &got)) != HD_OK || !got) break;
        if (!w) {
            width = frame.width, height = frame.height;
            if ((st = hd_clip_create(out, r, width, height, &w)) != HD_OK) break;
        } else if (frame.width != width || frame.height != height) {
            st = hd_fail(HD_ERR_FORMAT, "%s: frame %ld is %dx%d, the first was %dx%d", in, report->frames + 1, frame.width,
                         frame.height, width, height);
            break;
        }
        hd_video_frame_info info;
        if ((st = hd_video_relight_frame(v, &frame, &relit, &info)) != HD_OK) break;
        if ((st = hd_clip_write(w, &relit)) != HD_OK) break;
        report->frames++;
        if (info.faces > 0) report->frames_with_face++;
        if (info.wall == HD_VIDEO_WALL_HELD) report->frames_wall_held++;
        if (info.has_light && have_prev) {
            double s = 0.0;
            for (int k = 0; k < HD_SH_COEFFS; k++) s += (double)(info.light[k] - prev[k]) * (info.light[k] - prev[k]);
            change += sqrt(s);
            changes++;
        }
        have_prev = info.has_light;
        if (info.has_light) memcpy(prev, info.light, sizeof prev);
        hd_image_free(&frame);
        hd_image_free(&relit);
    }
    hd_image_free(&frame);
    hd_image_free(&relit);
    if (st == HD_OK && report->frames == 0) st = hd_fail(HD_ERR_FORMAT, "%s: no frames", in);
    hd_status fs = hd_clip_finish(w, st == HD_OK);
    if (st == HD_OK) st = fs;
    hd_clip_close(r);
    report->light_change = changes ? change / (double)changes : 0.0;
    report->seconds = hd_seconds() - t0;
    return st;
}
