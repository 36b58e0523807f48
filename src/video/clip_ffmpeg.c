/* clip_ffmpeg.c: reading and writing video files with FFmpeg's libraries (libavformat,
 * libavcodec, libswscale, libavutil). The reader decodes the best video stream to RGB and keeps
 * the packets of the first audio stream as they are demuxed; the writer encodes with the output
 * container's default video codec (H.264 for .mp4 when libavcodec has an encoder for it, else
 * MPEG-4 part 2) at the source's frame rate, and copies those audio packets in, interleaved, as
 * they are (no re-encoding). The file is written through core's atomic file (an unguessable
 * temporary created O_EXCL|O_NOFOLLOW beside it, never through a symlink) by a custom AVIOContext
 * on its descriptor, and renamed into place at the end. */
#if HD_HAVE_FFMPEG
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/imgutils.h>
#include <libavutil/mem.h>
#include <libavutil/opt.h>
#include <libswscale/swscale.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include "core/core.h"
#include "video/clip_ffmpeg.h"

struct hd_av_reader {
    char *path;
    AVFormatContext *fmt;
    AVCodecContext *dec;
    AVFrame *frame;
    AVPacket *pkt;
    struct SwsContext *sws;
    int video, audio; /* stream indices (audio -1: none) */
    int eof, flushed;
    AVRational rate;
    AVPacket **queue; /* audio packets not yet taken by a writer */
    int nqueue, cap;
};

struct hd_av_writer {
    char *path;
    hd_atomic_file af; /* the temporary the muxer writes into (af.f NULL: none open) */
    int fd;            /* af's descriptor */
    hd_av_reader *src;
    AVFormatContext *fmt;
    AVCodecContext *enc;
    AVStream *vst, *ast;
    AVFrame *frame;
    AVPacket *pkt;
    struct SwsContext *sws;
    uint8_t *rgb;
    int width, height; /* the encoded size (even for 4:2:0) and the frames' */
    int in_width, in_height;
    int64_t next_pts;
    int header;
};

static hd_status av_fail(int err, const char *path, const char *what)
{
    char msg[AV_ERROR_MAX_STRING_SIZE] = {0};
    av_strerror(err, msg, sizeof msg);
    return hd_fail(err == AVERROR(ENOMEM) ? HD_ERR_NOMEM : HD_ERR_FORMAT, "%s: %s: %s", path, what, msg);
}

void hd_av_close(hd_av_reader *r)
{
    if (!r) return;
    for (int i = 0; i < r->nqueue; i++) av_packet_free(&r->queue[i]);
    free(r->queue);
    sws_freeContext(r->sws);
    av_packet_free(&r->pkt);
    av_frame_free(&r->frame);
    avcodec_free_context(&r->dec);
    avformat_close_input(&r->fmt);
    free(r->path);
    free(r);
}

/* Library code prints nothing: FFmpeg's own log is silenced; errors come back as statuses. */
static void quiet(void) { av_log_set_level(AV_LOG_QUIET); }

hd_status hd_av_open(const char *path, hd_av_reader **out)
{
    *out = NULL;
    quiet();
    hd_av_reader *r = hd_calloc(1, sizeof *r);
    if (!r) return HD_ERR_NOMEM;
    hd_status st = HD_OK;
    int err;
    r->audio = -1;
    if (!(r->path = strdup(path))) {
        st = HD_ERR_NOMEM;
        goto fail;
    }
    if ((err = avformat_open_input(&r->fmt, path, NULL, NULL)) < 0) {
        st = av_fail(err, path, "cannot open the video");
        if (err == AVERROR(ENOENT)) st = hd_fail(HD_ERR_IO, "%s: no such file", path);
        goto fail;
    }
    if ((err = avformat_find_stream_info(r->fmt, NULL)) < 0) {
        st = av_fail(err, path, "cannot read the streams");
        goto fail;
    }
    const AVCodec *codec = NULL;
    r->video = av_find_best_stream(r->fmt, AVMEDIA_TYPE_VIDEO, -1, -1, &codec, 0);
    if (r->video < 0 || !codec) {
        st = hd_fail(HD_ERR_FORMAT, "%s: no video stream this build can decode", path);
        goto fail;
    }
    r->audio = av_find_best_stream(r->fmt, AVMEDIA_TYPE_AUDIO, -1, r->video, NULL, 0);
    if (r->audio < 0) r->audio = -1;
    /* the frame rate: the stream's base rate (exact for constant-rate video, also where the
     * container's clock is coarse, as Matroska's milliseconds), else the average */
    AVStream *vs = r->fmt->streams[r->video];
    r->rate = vs->r_frame_rate.num > 0 && vs->r_frame_rate.den > 0 ? vs->r_frame_rate : vs->avg_frame_rate;
    if (!(r->rate.num > 0 && r->rate.den > 0) || av_q2d(r->rate) > 1000.0) r->rate = (AVRational){30, 1};
    if (!(r->dec = avcodec_alloc_context3(codec)) || !(r->frame = av_frame_alloc()) || !(r->pkt = av_packet_alloc())) {
        st = HD_ERR_NOMEM;
        goto fail;
    }
    if ((err = avcodec_parameters_to_context(r->dec, vs->codecpar)) < 0 || (err = avcodec_open2(r->dec, codec, NULL)) < 0) {
        st = av_fail(err, path, "cannot open the video decoder");
        goto fail;
    }
    if (r->dec->width < 1 || r->dec->height < 1 || r->dec->width > HD_IMAGE_MAX_SIDE || r->dec->height > HD_IMAGE_MAX_SIDE) {
        st = hd_fail(HD_ERR_RANGE, "%s: frames of %dx%d are out of range (1 to %d a side)", path, r->dec->width,
                     r->dec->height, HD_IMAGE_MAX_SIDE);
        goto fail;
    }
    *out = r;
    return HD_OK;
fail:
    hd_av_close(r);
    return st;
}

double hd_av_fps(const hd_av_reader *r) { return av_q2d(r->rate); }
int hd_av_has_audio(const hd_av_reader *r) { return r->audio >= 0; }

long hd_av_frames(const hd_av_reader *r)
{
    AVStream *vs = r->fmt->streams[r->video];
    if (vs->nb_frames > 0) return (long)vs->nb_frames;
    if (r->fmt->duration > 0) return (long)(r->fmt->duration * av_q2d(r->rate) / AV_TIME_BASE + 0.5);
    return 0;
}

/* Keeps an audio packet for the writer. */
static hd_status queue_audio(hd_av_reader *r, AVPacket *p)
{
    if (r->nqueue == r->cap) {
        int nc = r->cap ? 2 * r->cap : 64;
        AVPacket **q = realloc(r->queue, (size_t)nc * sizeof *q);
        if (!q) return HD_ERR_NOMEM;
        r->queue = q;
        r->cap = nc;
    }
    if (!(r->queue[r->nqueue] = av_packet_clone(p))) return HD_ERR_NOMEM;
    r->nqueue++;
    return HD_OK;
}

/* The decoded frame to RGB floats. */
static hd_status frame_to_image(hd_av_reader *r, hd_image *img)
{
    int W = r->frame->width, H = r->frame->height;
    if (W < 1 || H < 1 || W > HD_IMAGE_MAX_SIDE || H > HD_IMAGE_MAX_SIDE)
        return hd_fail(HD_ERR_RANGE, "%s: a frame of %dx%d is out of range", r->path, W, H);
    r->sws = sws_getCachedContext(r->sws, W, H, (enum AVPixelFormat)r->frame->format, W, H, AV_PIX_FMT_RGB24,
                                  SWS_BICUBIC | SWS_ACCURATE_RND | SWS_FULL_CHR_H_INT, NULL, NULL, NULL);
    if (!r->sws) return hd_fail(HD_ERR_FORMAT, "%s: cannot convert frames of pixel format %d to RGB", r->path, r->frame->format);
    uint8_t *rgb = hd_malloc((size_t)W * H * 3);
    if (!rgb) return HD_ERR_NOMEM;
    uint8_t *dst[4] = {rgb, NULL, NULL, NULL};
    int stride[4] = {3 * W, 0, 0, 0};
    sws_scale(r->sws, (const uint8_t *const *)r->frame->data, r->frame->linesize, 0, H, dst, stride);
    hd_status st = hd_image_alloc(img, W, H, 3);
    if (st == HD_OK) {
        size_t plane = (size_t)W * H;
        for (size_t p = 0; p < plane; p++)
            for (int c = 0; c < 3; c++) img->data[c * plane + p] = (float)rgb[3 * p + c] / 255.0f;
    }
    free(rgb);
    return st;
}

hd_status hd_av_read(hd_av_reader *r, hd_image *img, int *got)
{
    *got = 0;
    memset(img, 0, sizeof *img);
    for (;;) {
        int err = avcodec_receive_frame(r->dec, r->frame);
        if (err == 0) {
            hd_status st = frame_to_image(r, img);
            av_frame_unref(r->frame);
            if (st == HD_OK) *got = 1;
            return st;
        }
        if (err == AVERROR_EOF) return HD_OK;
        if (err != AVERROR(EAGAIN)) return av_fail(err, r->path, "cannot decode a frame");
        if (r->eof) {
            if (r->flushed) return HD_OK;
            avcodec_send_packet(r->dec, NULL); /* drain the decoder */
            r->flushed = 1;
            continue;
        }
        err = av_read_frame(r->fmt, r->pkt);
        if (err == AVERROR_EOF) {
            r->eof = 1;
            continue;
        }
        if (err < 0) return av_fail(err, r->path, "cannot read");
        hd_status st = HD_OK;
        if (r->pkt->stream_index == r->video) {
            err = avcodec_send_packet(r->dec, r->pkt);
            if (err < 0 && err != AVERROR(EAGAIN)) st = av_fail(err, r->path, "cannot decode a packet");
        } else if (r->pkt->stream_index == r->audio) {
            st = queue_audio(r, r->pkt);
        }
        av_packet_unref(r->pkt);
        if (st != HD_OK) return st;
    }
}

/* ------------------------------------------------------------------ writing */

static hd_status drain_encoder(hd_av_writer *w)
{
    for (;;) {
        int err = avcodec_receive_packet(w->enc, w->pkt);
        if (err == AVERROR(EAGAIN) || err == AVERROR_EOF) return HD_OK;
        if (err < 0) return av_fail(err, w->path, "cannot encode");
        av_packet_rescale_ts(w->pkt, w->enc->time_base, w->vst->time_base);
        w->pkt->stream_index = w->vst->index;
        err = av_interleaved_write_frame(w->fmt, w->pkt);
        if (err < 0) return av_fail(err, w->path, "cannot write");
    }
}

/* Writes the source's queued audio packets up to video time `until` (seconds; < 0: all). */
static hd_status drain_audio(hd_av_writer *w, double until)
{
    hd_av_reader *r = w->src;
    if (!w->ast || !r || r->nqueue == 0) return HD_OK; /* (an empty queue may have no array yet) */
    AVStream *in = r->fmt->streams[r->audio];
    int k = 0;
    for (; k < r->nqueue; k++) {
        AVPacket *p = r->queue[k];
        if (until >= 0.0 && p->pts != AV_NOPTS_VALUE && p->pts * av_q2d(in->time_base) > until) break;
        av_packet_rescale_ts(p, in->time_base, w->ast->time_base);
        p->stream_index = w->ast->index;
        p->pos = -1;
        int err = av_interleaved_write_frame(w->fmt, p);
        av_packet_free(&r->queue[k]);
        if (err < 0) {
            memmove(r->queue, r->queue + k + 1, (size_t)(r->nqueue - k - 1) * sizeof *r->queue);
            r->nqueue -= k + 1;
            return av_fail(err, w->path, "cannot write the audio");
        }
    }
    memmove(r->queue, r->queue + k, (size_t)(r->nqueue - k) * sizeof *r->queue);
    r->nqueue -= k;
    return HD_OK;
}

/* The muxer's output: plain write() and lseek() on the atomic file's descriptor (the muxers that
 * go back to patch headers need the seek), so errno's text (a full disk) reaches the message. */
static int output_write(void *opaque, uint8_t *buf, int size)
{
    hd_av_writer *w = opaque;
    int done = 0;
    while (done < size) {
        ssize_t n = write(w->fd, buf + done, (size_t)(size - done));
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) return AVERROR(n < 0 ? errno : ENOSPC);
        done += (int)n;
    }
    return done;
}

static int64_t output_seek(void *opaque, int64_t offset, int whence)
{
    hd_av_writer *w = opaque;
    if (whence & AVSEEK_SIZE) {
        struct stat sb;
        return fstat(w->fd, &sb) == 0 ? (int64_t)sb.st_size : AVERROR(errno);
    }
    off_t at = lseek(w->fd, (off_t)offset, whence & ~AVSEEK_FORCE);
    return at < 0 ? AVERROR(errno) : (int64_t)at;
}

/* Frees the custom AVIOContext (and its buffer); the descriptor stays with w->af. */
static void close_output(hd_av_writer *w)
{
    if (!w->fmt->pb) return;
    av_freep(&w->fmt->pb->buffer);
    avio_context_free(&w->fmt->pb);
}

static void writer_free(hd_av_writer *w)
{
    sws_freeContext(w->sws);
    free(w->rgb);
    av_packet_free(&w->pkt);
    av_frame_free(&w->frame);
    avcodec_free_context(&w->enc);
    if (w->fmt) {
        close_output(w);
        avformat_free_context(w->fmt);
    }
    if (w->af.f) hd_atomic_abort(&w->af);
    free(w->path);
    free(w);
}

hd_status hd_av_create(const char *path, hd_av_reader *src, int width, int height, hd_av_writer **out)
{
    *out = NULL;
    quiet();
    if (width < 2 || height < 2) return hd_fail(HD_ERR_RANGE, "%s: frames of %dx%d are too small to encode", path, width, height);
    hd_av_writer *w = hd_calloc(1, sizeof *w);
    if (!w) return HD_ERR_NOMEM;
    hd_status st = HD_OK;
    int err;
    w->path = strdup(path);
    if (!w->path) {
        st = HD_ERR_NOMEM;
        goto fail;
    }
    w->src = src;
    w->in_width = width;
    w->in_height = height;
    w->width = width & ~1;
    w->height = height & ~1;
    if ((err = avformat_alloc_output_context2(&w->fmt, NULL, NULL, path)) < 0 || !w->fmt) {
        st = hd_fail(HD_ERR_ARG, "%s: no video format for this file name", path);
        goto fail;
    }
    const AVCodec *codec = avcodec_find_encoder(w->fmt->oformat->video_codec);
    if (!codec || avformat_query_codec(w->fmt->oformat, codec->id, FF_COMPLIANCE_NORMAL) != 1)
        codec = avcodec_find_encoder(AV_CODEC_ID_MPEG4);
    if (!codec) {
        st = hd_fail(HD_ERR_FORMAT, "%s: this FFmpeg has no video encoder for the format", path);
        goto fail;
    }
    AVRational rate = src ? src->rate : (AVRational){30, 1};
    if (!(w->vst = avformat_new_stream(w->fmt, NULL)) || !(w->enc = avcodec_alloc_context3(codec)) ||
        !(w->frame = av_frame_alloc()) || !(w->pkt = av_packet_alloc())) {
        st = HD_ERR_NOMEM;
        goto fail;
    }
    w->enc->width = w->width;
    w->enc->height = w->height;
    w->enc->time_base = av_inv_q(rate);
    w->enc->framerate = rate;
    w->enc->pix_fmt = AV_PIX_FMT_YUV420P;
    w->enc->gop_size = 12;
    if (codec->id == AV_CODEC_ID_H264) {
        av_opt_set(w->enc->priv_data, "crf", "18", 0);
        av_opt_set(w->enc->priv_data, "preset", "medium", 0);
    } else {
        w->enc->flags |= AV_CODEC_FLAG_QSCALE;
        w->enc->global_quality = FF_QP2LAMBDA * 2;
    }
    if (w->fmt->oformat->flags & AVFMT_GLOBALHEADER) w->enc->flags |= AV_CODEC_FLAG_GLOBAL_HEADER;
    w->enc->thread_count = 1;
    if ((err = avcodec_open2(w->enc, codec, NULL)) < 0) {
        st = av_fail(err, path, "cannot open the video encoder");
        goto fail;
    }
    if ((err = avcodec_parameters_from_context(w->vst->codecpar, w->enc)) < 0) {
        st = av_fail(err, path, "cannot set up the video stream");
        goto fail;
    }
    w->vst->time_base = w->enc->time_base;
    w->vst->avg_frame_rate = rate;
    if (src && src->audio >= 0) {
        AVStream *in = src->fmt->streams[src->audio];
        if (avformat_query_codec(w->fmt->oformat, in->codecpar->codec_id, FF_COMPLIANCE_NORMAL) == 1) {
            if (!(w->ast = avformat_new_stream(w->fmt, NULL))) {
                st = HD_ERR_NOMEM;
                goto fail;
            }
            if ((err = avcodec_parameters_copy(w->ast->codecpar, in->codecpar)) < 0) {
                st = av_fail(err, path, "cannot copy the audio stream");
                goto fail;
            }
            w->ast->codecpar->codec_tag = 0;
            w->ast->time_base = in->time_base;
        } else {
            st = hd_fail(HD_ERR_FORMAT, "%s: the format cannot hold the source's audio (%s) as it is; choose another "
                         "container (.mkv holds most)", path, avcodec_get_name(in->codecpar->codec_id));
            goto fail;
        }
    }
    w->frame->format = w->enc->pix_fmt;
    w->frame->width = w->width;
    w->frame->height = w->height;
    if ((err = av_frame_get_buffer(w->frame, 0)) < 0) {
        st = av_fail(err, path, "cannot allocate a frame");
        goto fail;
    }
    w->sws = sws_getContext(w->width, w->height, AV_PIX_FMT_RGB24, w->width, w->height, w->enc->pix_fmt,
                            SWS_BICUBIC | SWS_ACCURATE_RND, NULL, NULL, NULL);
    w->rgb = hd_malloc((size_t)width * height * 3);
    if (!w->sws || !w->rgb) {
        st = HD_ERR_NOMEM;
        goto fail;
    }
    if ((st = hd_atomic_open(&w->af, path)) != HD_OK) goto fail;
    w->fd = hd_atomic_fd(&w->af);
    enum { AVIO_BUFFER = 1 << 16 };
    unsigned char *buf = av_malloc(AVIO_BUFFER);
    if (buf) w->fmt->pb = avio_alloc_context(buf, AVIO_BUFFER, 1, w, NULL, output_write, output_seek);
    if (!w->fmt->pb) {
        av_free(buf);
        st = HD_ERR_NOMEM;
        goto fail;
    }
    w->fmt->flags |= AVFMT_FLAG_CUSTOM_IO;
    if ((err = avformat_write_header(w->fmt, NULL)) < 0) {
        st = av_fail(err, path, "cannot write the header");
        goto fail;
    }
    w->header = 1;
    *out = w;
    return HD_OK;
fail:
    writer_free(w); /* removes the temporary */
    return st;
}

hd_status hd_av_write(hd_av_writer *w, const hd_image *img)
{
    if (img->width != w->in_width || img->height != w->in_height || img->channels != 3)
        return hd_fail(HD_ERR_ARG, "%s: a %dx%dx%d frame in a %dx%d clip", w->path, img->width, img->height,
                       img->channels, w->in_width, w->in_height);
    size_t plane = (size_t)img->width * img->height;
    for (size_t p = 0; p < plane; p++)
        for (int c = 0; c < 3; c++) {
            float v = img->data[c * plane + p];
            v = v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f; /* also maps NaN to 0 */
            w->rgb[3 * p + c] = (uint8_t)(v * 255.0f + 0.5f);
        }
    int err = av_frame_make_writable(w->frame);
    if (err < 0) return av_fail(err, w->path, "cannot write a frame");
    const uint8_t *src[4] = {w->rgb, NULL, NULL, NULL};
    int stride[4] = {3 * img->width, 0, 0, 0}; /* an odd last column or row is left out */
    sws_scale(w->sws, src, stride, 0, w->height, w->frame->data, w->frame->linesize);
    w->frame->pts = w->next_pts++;
    if ((err = avcodec_send_frame(w->enc, w->frame)) < 0) return av_fail(err, w->path, "cannot encode a frame");
    hd_status st = drain_encoder(w);
    if (st == HD_OK) st = drain_audio(w, (double)w->next_pts * av_q2d(w->enc->time_base));
    return st;
}

hd_status hd_av_finish(hd_av_writer *w, int ok)
{
    hd_status st = HD_OK;
    if (ok) {
        avcodec_send_frame(w->enc, NULL);
        st = drain_encoder(w);
        /* the rest of the source's audio */
        if (st == HD_OK && w->src && w->ast) {
            while (!w->src->eof && st == HD_OK) {
                int err = av_read_frame(w->src->fmt, w->src->pkt);
                if (err < 0) break;
                if (w->src->pkt->stream_index == w->src->audio) st = queue_audio(w->src, w->src->pkt);
                av_packet_unref(w->src->pkt);
            }
            if (st == HD_OK) st = drain_audio(w, -1.0);
        }
        if (st == HD_OK) {
            int err = av_write_trailer(w->fmt);
            if (err < 0) st = av_fail(err, w->path, "cannot finish the file");
        }
        if (st == HD_OK) {
            avio_flush(w->fmt->pb);
            if (w->fmt->pb->error < 0) st = av_fail(w->fmt->pb->error, w->path, "cannot write");
        }
        close_output(w);
        if (st == HD_OK) st = hd_atomic_commit(&w->af); /* fsync (if durable) and rename */
    }
    writer_free(w); /* removes the temporary unless it was committed */
    return st;
}
#else
typedef int hd_clip_ffmpeg_unused; /* ISO C wants something in a translation unit */
#endif
