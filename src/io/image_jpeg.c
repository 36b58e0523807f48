/* image_jpeg.c: JPEG reading and writing through libjpeg(-turbo): gray and RGB (YCbCr decoded to
 * RGB), turned upright by the EXIF orientation (exif.c); CMYK and other colour spaces are refused. libjpeg's fatal errors come to our error_exit, which
 * records the message and longjmps back. Its warnings that mean lost image data (a truncated file
 * or a corrupt scan, which libjpeg would otherwise paper over with gray) are errors too, raised at
 * once so that a truncated file claiming a huge size is not decoded to the end; harmless warnings
 * (extraneous bytes before a marker, an unknown JFIF revision, a bad ICC marker) are ignored. */
#include <errno.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <jpeglib.h>
#include <jerror.h>
#include "core/core.h"
#include "io/image_io.h"

typedef struct jpeg_context {
    struct jpeg_error_mgr mgr; /* first, so the error manager pointer is the context */
    jmp_buf jump;
    char reason[JMSG_LENGTH_MAX + 32];
} jpeg_context;

static void jpeg_on_error_exit(j_common_ptr cinfo)
{
    jpeg_context *ctx = (jpeg_context *)cinfo->err;
    (*cinfo->err->format_message)(cinfo, ctx->reason);
    longjmp(ctx->jump, 1);
}

/* level < 0: a warning, fatal when it means lost pixels (libjpeg's jerror.c invites overriding
 * this method to abort on warnings); level >= 0: trace messages, ignored. */
static void jpeg_on_message(j_common_ptr cinfo, int level)
{
    jpeg_context *ctx = (jpeg_context *)cinfo->err;
    if (level >= 0) return;
    switch (cinfo->err->msg_code) {
    case JWRN_JPEG_EOF:
    case JWRN_HIT_MARKER:
    case JWRN_HUFF_BAD_CODE:
    case JWRN_ARITH_BAD_CODE:
    case JWRN_MUST_RESYNC:
    case JWRN_NOT_SEQUENTIAL:
    case JWRN_BOGUS_PROGRESSION: {
        char message[JMSG_LENGTH_MAX];
        (*cinfo->err->format_message)(cinfo, message);
        snprintf(ctx->reason, sizeof ctx->reason, "corrupt data: %s", message);
        longjmp(ctx->jump, 1);
    }
    default:
        return;
    }
}

hd_status hd_image_read_jpeg(FILE *f, long long file_size, const char *path, hd_image *img, hd_image_info *info)
{
    (void)file_size;
    memset(img, 0, sizeof *img);
    struct jpeg_decompress_struct cinfo;
    jpeg_context ctx;
    memset(&ctx, 0, sizeof ctx);
    cinfo.err = jpeg_std_error(&ctx.mgr);
    ctx.mgr.error_exit = jpeg_on_error_exit;
    ctx.mgr.emit_message = jpeg_on_message;
    JSAMPLE *volatile row = NULL;
    hd_status volatile st = HD_OK;
    if (setjmp(ctx.jump)) {
        free(row);
        hd_image_free(img);
        jpeg_destroy_decompress(&cinfo);
        if (st != HD_OK) return st;
        return hd_fail(HD_ERR_FORMAT, "%s: bad JPEG: %s", path, ctx.reason);
    }
    jpeg_create_decompress(&cinfo);
    jpeg_stdio_src(&cinfo, f);
    jpeg_save_markers(&cinfo, JPEG_APP0 + 1, 0xFFFF);
    jpeg_read_header(&cinfo, TRUE);
    int orientation = 1;
    for (jpeg_saved_marker_ptr m = cinfo.marker_list; m && orientation == 1; m = m->next)
        if (m->marker == JPEG_APP0 + 1) orientation = hd_exif_orientation(m->data, m->data_length);
    if (cinfo.jpeg_color_space == JCS_CMYK || cinfo.jpeg_color_space == JCS_YCCK) {
        st = hd_fail(HD_ERR_FORMAT, "%s: unsupported JPEG: CMYK colour (only gray and RGB are read)", path);
        longjmp(ctx.jump, 1);
    }
    if (cinfo.num_components != 1 && cinfo.num_components != 3) {
        st = hd_fail(HD_ERR_FORMAT, "%s: unsupported JPEG: %d colour components (only gray and RGB "
                     "are read)", path, cinfo.num_components);
        longjmp(ctx.jump, 1);
    }
    cinfo.out_color_space = cinfo.num_components == 1 ? JCS_GRAYSCALE : JCS_RGB;
    if (hd_image_check_dims(path, (long)cinfo.image_width, (long)cinfo.image_height, 3) != HD_OK) {
        st = HD_ERR_RANGE;
        longjmp(ctx.jump, 1);
    }
    jpeg_start_decompress(&cinfo);
    int width = (int)cinfo.output_width, height = (int)cinfo.output_height;
    int channels = cinfo.output_components;
    if (hd_image_alloc(img, width, height, channels) != HD_OK ||
        !(row = malloc((size_t)width * channels * sizeof(JSAMPLE)))) {
        st = hd_fail(HD_ERR_NOMEM, "%s: out of memory for a %dx%d image", path, width, height);
        longjmp(ctx.jump, 1);
    }
    size_t plane = (size_t)width * height;
    while (cinfo.output_scanline < cinfo.output_height) {
        int y = (int)cinfo.output_scanline;
        JSAMPROW rows[1] = {row};
        if (jpeg_read_scanlines(&cinfo, rows, 1) != 1) {
            snprintf(ctx.reason, sizeof ctx.reason, "no scanline %d", y);
            longjmp(ctx.jump, 1);
        }
        for (int x = 0; x < width; x++)
            for (int c = 0; c < channels; c++)
                img->data[c * plane + (size_t)y * width + x] = (float)row[x * channels + c] / 255.0f;
    }
    jpeg_finish_decompress(&cinfo);
    free(row);
    row = NULL;
    jpeg_destroy_decompress(&cinfo);
    /* Upright, as the EXIF orientation says it is to be shown. */
    hd_status ost = hd_image_orient(img, orientation);
    if (ost != HD_OK) {
        hd_image_free(img);
        return ost;
    }
    info->format = "JPEG";
    info->width = img->width;
    info->height = img->height;
    info->orientation = orientation;
    info->channels = channels;
    info->bits = 8;
    info->palette = 0;
    return HD_OK;
}

/* round(clamp(v, 0, 1) * 255), NaN -> 0. */
static JSAMPLE to_sample(float v)
{
    v = v > 0.0f ? v : 0.0f;
    v = v < 1.0f ? v : 1.0f;
    return (JSAMPLE)(v * 255.0f + 0.5f);
}

hd_status hd_image_encode_jpeg(FILE *out, const char *path, const hd_image *img, int quality)
{
    if (!img || !img->data || img->channels < 1 || img->channels > 4 || img->width <= 0 || img->height <= 0)
        return hd_fail(HD_ERR_ARG, "%s: cannot write an image of %d channels as JPEG", path, img ? img->channels : 0);
    if (quality < 1 || quality > 100) return hd_fail(HD_ERR_ARG, "%s: JPEG quality %d is not in 1..100", path, quality);
    /* JPEG has no alpha: gray+alpha is written gray, RGBA as RGB. */
    hd_image conv = {0};
    const hd_image *volatile src = img; /* read again after a longjmp */
    if (img->channels == 2 || img->channels == 4) {
        hd_status st = hd_image_convert(img, img->channels - 1, &conv);
        if (st != HD_OK) return st;
        src = &conv;
    }
    int W = src->width, H = src->height, C = src->channels;
    struct jpeg_compress_struct cinfo;
    jpeg_context ctx;
    memset(&ctx, 0, sizeof ctx);
    cinfo.err = jpeg_std_error(&ctx.mgr);
    ctx.mgr.error_exit = jpeg_on_error_exit;
    JSAMPLE *volatile row = NULL;
    if (setjmp(ctx.jump)) {
        free(row);
        jpeg_destroy_compress(&cinfo);
        hd_image_free(&conv);
        return hd_fail(HD_ERR_IO, "%s: JPEG write failed: %s", path, ctx.reason);
    }
    jpeg_create_compress(&cinfo);
    jpeg_stdio_dest(&cinfo, out);
    cinfo.image_width = (JDIMENSION)W;
    cinfo.image_height = (JDIMENSION)H;
    cinfo.input_components = C;
    cinfo.in_color_space = C == 1 ? JCS_GRAYSCALE : JCS_RGB;
    jpeg_set_defaults(&cinfo);
    jpeg_set_quality(&cinfo, quality, TRUE);
    if (!(row = malloc((size_t)W * C))) {
        snprintf(ctx.reason, sizeof ctx.reason, "out of memory");
        longjmp(ctx.jump, 1);
    }
    jpeg_start_compress(&cinfo, TRUE);
    size_t plane = (size_t)W * H;
    while (cinfo.next_scanline < cinfo.image_height) {
        size_t y = cinfo.next_scanline;
        for (int x = 0; x < W; x++)
            for (int c = 0; c < C; c++) row[(size_t)x * C + c] = to_sample(src->data[c * plane + y * W + x]);
        JSAMPROW rows[1] = {row};
        jpeg_write_scanlines(&cinfo, rows, 1);
    }
    jpeg_finish_compress(&cinfo);
    jpeg_destroy_compress(&cinfo);
    free(row);
    hd_image_free(&conv);
    return ferror(out) ? hd_fail(HD_ERR_IO, "%s: JPEG write failed", path) : HD_OK;
}
