/* image_memory.c: PNG and JPEG pictures held in memory, for `hdnet serve`: an upload is never
 * written to disk, and a result is sent from memory. The header probe gives the claimed size
 * before any decoding, so the server's pixel cap is applied before anything is allocated. The
 * decoder makes the same choices as the library's file readers (src/io/image_png.c,
 * image_jpeg.c: palette to RGB, gray expanded, samples / 255 or / 65535, corrupt JPEG data
 * fatal), so a photo uploaded gives the pixels `hdnet relight` reads from the same bytes; the
 * encoder writes an 8-bit PNG as hd_image_write_png does (zlib level 3). */
#include <png.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <jpeglib.h>
#include <jerror.h>
#include "core/core.h"
#include "io/image_io.h"
#include "serve.h"

hd_status hd_blob_append(hd_blob *b, const void *data, size_t n)
{
    if (n == 0) return HD_OK;
    if (b->size + n < b->size) return hd_fail(HD_ERR_NOMEM, "buffer size overflows");
    if (b->size + n > b->cap) {
        size_t cap = b->cap ? b->cap : 4096;
        while (cap < b->size + n) cap = cap > ((size_t)-1) / 2 ? b->size + n : cap * 2;
        unsigned char *grown = realloc(b->data, cap);
        if (!grown) return hd_fail(HD_ERR_NOMEM, "out of memory for %zu bytes", cap);
        b->data = grown;
        b->cap = cap;
    }
    memcpy(b->data + b->size, data, n);
    b->size += n;
    return HD_OK;
}

void hd_blob_free(hd_blob *b)
{
    free(b->data);
    memset(b, 0, sizeof *b);
}

static const unsigned char png_signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};

hd_picture_kind hd_picture_sniff(const unsigned char *data, size_t n)
{
    if (n >= 8 && memcmp(data, png_signature, 8) == 0) return HD_PICTURE_PNG;
    if (n >= 3 && data[0] == 0xFF && data[1] == 0xD8 && data[2] == 0xFF) return HD_PICTURE_JPEG;
    return HD_PICTURE_UNKNOWN;
}

static unsigned long be32(const unsigned char *p)
{
    return ((unsigned long)p[0] << 24) | ((unsigned long)p[1] << 16) | ((unsigned long)p[2] << 8) | p[3];
}

/* JPEG: walks the markers up to the first start-of-frame (SOF0..SOF15 except DHT C4, JPG C8 and
 * DAC CC) and reads its height and width. */
static hd_status probe_jpeg(const unsigned char *d, size_t n, const char *what, long *width, long *height)
{
    size_t i = 2;
    while (i + 4 <= n) {
        if (d[i] != 0xFF) return hd_fail(HD_ERR_FORMAT, "%s: bad JPEG: no marker at byte %zu", what, i);
        unsigned m = d[i + 1];
        if (m == 0xFF) { /* fill byte */
            i++;
            continue;
        }
        if (m == 0xD8 || (m >= 0xD0 && m <= 0xD7) || m == 0x01) { /* markers without a length */
            i += 2;
            continue;
        }
        size_t len = ((size_t)d[i + 2] << 8) | d[i + 3];
        if (len < 2) return hd_fail(HD_ERR_FORMAT, "%s: bad JPEG: marker length %zu", what, len);
        if (m >= 0xC0 && m <= 0xCF && m != 0xC4 && m != 0xC8 && m != 0xCC) {
            if (i + 9 > n) break;
            *height = ((long)d[i + 5] << 8) | d[i + 6];
            *width = ((long)d[i + 7] << 8) | d[i + 8];
            return HD_OK;
        }
        if (m == 0xD9 || m == 0xDA) break; /* end of image or scan before any frame */
        i += 2 + len;
    }
    return hd_fail(HD_ERR_FORMAT, "%s: bad JPEG: no frame header (truncated?)", what);
}

hd_status hd_picture_probe(const unsigned char *data, size_t n, const char *what, long *width, long *height)
{
    *width = *height = 0;
    switch (hd_picture_sniff(data, n)) {
    case HD_PICTURE_PNG:
        /* signature, then the IHDR chunk: length 13, "IHDR", width, height */
        if (n < 24 || memcmp(data + 12, "IHDR", 4) != 0)
            return hd_fail(HD_ERR_FORMAT, "%s: bad PNG: no IHDR chunk", what);
        *width = (long)be32(data + 16);
        *height = (long)be32(data + 20);
        return HD_OK;
    case HD_PICTURE_JPEG:
        return probe_jpeg(data, n, what, width, height);
    default:
        return hd_fail(HD_ERR_FORMAT, "%s: not a PNG or JPEG", what);
    }
}

/* ---------------------------------------------------------------- PNG */

typedef struct png_memory {
    const unsigned char *data;
    size_t size, pos;
    hd_blob *out;
    int out_failed;
    char reason[256];
} png_memory;

static void png_on_error(png_structp png, png_const_charp message)
{
    png_memory *m = png_get_error_ptr(png);
    snprintf(m->reason, sizeof m->reason, "%s", message);
    png_longjmp(png, 1);
}

static void png_on_warning(png_structp png, png_const_charp message)
{
    (void)png;
    (void)message;
}

static void png_on_read(png_structp png, png_bytep data, size_t length)
{
    png_memory *m = png_get_io_ptr(png);
    if (length > m->size - m->pos) png_error(png, "data is truncated");
    memcpy(data, m->data + m->pos, length);
    m->pos += length;
}

static void png_on_write(png_structp png, png_bytep data, size_t length)
{
    png_memory *m = png_get_io_ptr(png);
    if (hd_blob_append(m->out, data, length) != HD_OK) {
        m->out_failed = 1;
        png_error(png, "out of memory");
    }
}

static void png_on_flush(png_structp png) { (void)png; }

static hd_status decode_png(const unsigned char *data, size_t n, const char *what, hd_image *img)
{
    memset(img, 0, sizeof *img);
    png_memory m = {.data = data, .size = n};
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &m, png_on_error, png_on_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!png || !info) {
        png_destroy_read_struct(&png, NULL, NULL);
        return hd_fail(HD_ERR_NOMEM, "%s: out of memory starting libpng", what);
    }
    png_bytep volatile rows = NULL;
    png_bytepp volatile row_ptrs = NULL;
    hd_status volatile st = HD_OK;
    if (setjmp(png_jmpbuf(png))) {
        free(rows);
        free(row_ptrs);
        hd_image_free(img);
        png_destroy_read_struct(&png, &info, NULL);
        return st != HD_OK ? st : hd_fail(HD_ERR_FORMAT, "%s: bad PNG: %s", what, m.reason);
    }
    png_set_read_fn(png, &m, png_on_read);
    png_read_info(png, info);
    png_uint_32 width, height;
    int bit_depth, color_type, interlace;
    png_get_IHDR(png, info, &width, &height, &bit_depth, &color_type, &interlace, NULL, NULL);
    if ((st = hd_image_check_dims(what, (long)width, (long)height, 4)) != HD_OK) png_longjmp(png, 1);
    /* a deflate stream compresses at most about 1032:1: a body far smaller than its image lies */
    double raw = (double)height * (1.0 + ((double)width * png_get_channels(png, info) * bit_depth + 7) / 8);
    if (raw > 1100.0 * (double)n + 65536.0) {
        st = hd_fail(HD_ERR_FORMAT, "%s: bad PNG: header claims %ux%u pixels in only %zu bytes", what,
                     (unsigned)width, (unsigned)height, n);
        png_longjmp(png, 1);
    }
    if (color_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
    if (color_type == PNG_COLOR_TYPE_GRAY && bit_depth < 8) png_set_expand_gray_1_2_4_to_8(png);
    if (png_get_valid(png, info, PNG_INFO_tRNS)) png_set_tRNS_to_alpha(png);
    png_set_interlace_handling(png);
    png_read_update_info(png, info);
    const int channels = png_get_channels(png, info), bits = png_get_bit_depth(png, info);
    const size_t rowbytes = png_get_rowbytes(png, info);
    if (channels < 1 || channels > 4 || (bits != 8 && bits != 16) ||
        rowbytes != (size_t)width * channels * (bits / 8)) {
        st = hd_fail(HD_ERR_FORMAT, "%s: unsupported PNG layout (%d channels of %d bits)", what, channels, bits);
        png_longjmp(png, 1);
    }
    size_t total;
    if (!hd_mul_size(rowbytes, height, &total) || hd_image_alloc(img, (int)width, (int)height, channels) != HD_OK ||
        !(rows = malloc(total)) || !(row_ptrs = malloc(height * sizeof *row_ptrs))) {
        st = hd_fail(HD_ERR_NOMEM, "%s: out of memory for a %ux%u image", what, (unsigned)width, (unsigned)height);
        png_longjmp(png, 1);
    }
    for (png_uint_32 y = 0; y < height; y++) row_ptrs[y] = rows + y * rowbytes;
    png_read_image(png, row_ptrs);
    png_read_end(png, NULL);
    const size_t plane = (size_t)width * height;
    for (png_uint_32 y = 0; y < height; y++) {
        const png_byte *row = row_ptrs[y];
        for (png_uint_32 x = 0; x < width; x++)
            for (int c = 0; c < channels; c++) {
                size_t k = (size_t)x * channels + c;
                img->data[c * plane + (size_t)y * width + x] =
                    bits == 16 ? (float)((row[2 * k] << 8) | row[2 * k + 1]) / 65535.0f : (float)row[k] / 255.0f;
            }
    }
    free(rows);
    free(row_ptrs);
    png_destroy_read_struct(&png, &info, NULL);
    return HD_OK;
}

/* round(clamp(v, 0, 1) * 255), NaN -> 0, as the library's writer quantises */
static unsigned char quantise8(float v)
{
    v = v > 0.0f ? v : 0.0f;
    v = v < 1.0f ? v : 1.0f;
    return (unsigned char)(v * 255.0f + 0.5f);
}

hd_status hd_picture_encode_png(const hd_image *img, hd_blob *out)
{
    memset(out, 0, sizeof *out);
    if (!img || !img->data || img->channels < 1 || img->channels > 4 || img->width <= 0 || img->height <= 0)
        return hd_fail(HD_ERR_ARG, "cannot encode an image of %d channels as PNG", img ? img->channels : 0);
    static const int color_types[5] = {0, PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA, PNG_COLOR_TYPE_RGB,
                                       PNG_COLOR_TYPE_RGB_ALPHA};
    const int channels = img->channels, width = img->width, height = img->height;
    png_bytep row = hd_malloc((size_t)width * channels);
    if (!row) return HD_ERR_NOMEM;
    png_memory m = {.out = out};
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &m, png_on_error, png_on_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!png || !info) {
        png_destroy_write_struct(&png, NULL);
        free(row);
        return hd_fail(HD_ERR_NOMEM, "out of memory starting libpng");
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        free(row);
        hd_blob_free(out);
        return hd_fail(m.out_failed ? HD_ERR_NOMEM : HD_ERR_IO, "PNG encoding failed: %s", m.reason);
    }
    png_set_write_fn(png, &m, png_on_write, png_on_flush);
    png_set_IHDR(png, info, (png_uint_32)width, (png_uint_32)height, 8, color_types[channels], PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_compression_level(png, 3);
    png_write_info(png, info);
    const size_t plane = (size_t)width * height;
    for (int y = 0; y < height; y++) {
        for (int c = 0; c < channels; c++) {
            const float *src = img->data + c * plane + (size_t)y * width;
            for (int x = 0; x < width; x++) row[(size_t)x * channels + c] = quantise8(src[x]);
        }
        png_write_row(png, row);
    }
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    free(row);
    return HD_OK;
}

/* ---------------------------------------------------------------- JPEG */

typedef struct jpeg_memory {
    struct jpeg_error_mgr mgr; /* first: the error manager pointer is the context */
    jmp_buf jump;
    char reason[JMSG_LENGTH_MAX + 32];
} jpeg_memory;

static void jpeg_on_error_exit(j_common_ptr cinfo)
{
    jpeg_memory *m = (jpeg_memory *)cinfo->err;
    (*cinfo->err->format_message)(cinfo, m->reason);
    longjmp(m->jump, 1);
}

/* Warnings that mean lost pixels (a truncated or corrupt scan) are errors, as in image_jpeg.c. */
static void jpeg_on_message(j_common_ptr cinfo, int level)
{
    jpeg_memory *m = (jpeg_memory *)cinfo->err;
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
        snprintf(m->reason, sizeof m->reason, "corrupt data: %s", message);
        longjmp(m->jump, 1);
    }
    default:
        return;
    }
}

static hd_status decode_jpeg(const unsigned char *data, size_t n, const char *what, hd_image *img)
{
    memset(img, 0, sizeof *img);
    struct jpeg_decompress_struct cinfo;
    jpeg_memory m;
    memset(&m, 0, sizeof m);
    cinfo.err = jpeg_std_error(&m.mgr);
    m.mgr.error_exit = jpeg_on_error_exit;
    m.mgr.emit_message = jpeg_on_message;
    JSAMPLE *volatile row = NULL;
    hd_status volatile st = HD_OK;
    if (setjmp(m.jump)) {
        free(row);
        hd_image_free(img);
        jpeg_destroy_decompress(&cinfo);
        return st != HD_OK ? st : hd_fail(HD_ERR_FORMAT, "%s: bad JPEG: %s", what, m.reason);
    }
    jpeg_create_decompress(&cinfo);
    jpeg_mem_src(&cinfo, data, (unsigned long)n);
    jpeg_read_header(&cinfo, TRUE);
    if (cinfo.num_components != 1 && cinfo.num_components != 3) {
        st = hd_fail(HD_ERR_FORMAT, "%s: unsupported JPEG: %d colour components (only gray and RGB)", what,
                     cinfo.num_components);
        longjmp(m.jump, 1);
    }
    cinfo.out_color_space = cinfo.num_components == 1 ? JCS_GRAYSCALE : JCS_RGB;
    if ((st = hd_image_check_dims(what, (long)cinfo.image_width, (long)cinfo.image_height, 3)) != HD_OK)
        longjmp(m.jump, 1);
    jpeg_start_decompress(&cinfo);
    const int width = (int)cinfo.output_width, height = (int)cinfo.output_height, channels = cinfo.output_components;
    if (hd_image_alloc(img, width, height, channels) != HD_OK || !(row = malloc((size_t)width * channels))) {
        st = hd_fail(HD_ERR_NOMEM, "%s: out of memory for a %dx%d image", what, width, height);
        longjmp(m.jump, 1);
    }
    const size_t plane = (size_t)width * height;
    while (cinfo.output_scanline < cinfo.output_height) {
        const int y = (int)cinfo.output_scanline;
        JSAMPROW rows[1] = {row};
        if (jpeg_read_scanlines(&cinfo, rows, 1) != 1) {
            snprintf(m.reason, sizeof m.reason, "no scanline %d", y);
            longjmp(m.jump, 1);
        }
        for (int x = 0; x < width; x++)
            for (int c = 0; c < channels; c++)
                img->data[c * plane + (size_t)y * width + x] = (float)row[x * channels + c] / 255.0f;
    }
    jpeg_finish_decompress(&cinfo);
    free(row);
    jpeg_destroy_decompress(&cinfo);
    return HD_OK;
}

hd_status hd_picture_decode(const unsigned char *data, size_t n, const char *what, hd_image *rgb)
{
    memset(rgb, 0, sizeof *rgb);
    hd_image raw = {0};
    hd_status st;
    switch (hd_picture_sniff(data, n)) {
    case HD_PICTURE_PNG: st = decode_png(data, n, what, &raw); break;
    case HD_PICTURE_JPEG: st = decode_jpeg(data, n, what, &raw); break;
    default: return hd_fail(HD_ERR_FORMAT, "%s: not a PNG or JPEG", what);
    }
    if (st != HD_OK) return st;
    if (raw.channels == 3) {
        *rgb = raw;
        return HD_OK;
    }
    st = hd_image_convert(&raw, 3, rgb);
    hd_image_free(&raw);
    return st;
}
