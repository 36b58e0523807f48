/* clip_ffmpeg.h: video files through FFmpeg's libraries (clip_ffmpeg.c); built only when the
 * build found them (HD_HAVE_FFMPEG). */
#ifndef HD_CLIP_FFMPEG_H
#define HD_CLIP_FFMPEG_H

#include "hdnet.h"

typedef struct hd_av_reader hd_av_reader;
typedef struct hd_av_writer hd_av_writer;

hd_status hd_av_open(const char *path, hd_av_reader **reader);
hd_status hd_av_read(hd_av_reader *reader, hd_image *frame, int *got);
double hd_av_fps(const hd_av_reader *reader);
long hd_av_frames(const hd_av_reader *reader);
int hd_av_has_audio(const hd_av_reader *reader);
void hd_av_close(hd_av_reader *reader);

/* The source's frame rate and audio (the writer drains the reader's audio packets as it goes). */
hd_status hd_av_create(const char *path, hd_av_reader *source, int width, int height, hd_av_writer **writer);
hd_status hd_av_write(hd_av_writer *writer, const hd_image *frame);
hd_status hd_av_finish(hd_av_writer *writer, int ok);

#endif /* HD_CLIP_FFMPEG_H */
