/* image_png.c: PNG through libpng. Reads 1-16 bit gray, gray+alpha, RGB, RGBA and palette images
 * (palette expands to RGB, or RGBA when the file has transparency); writes 8 or 16 bits with 1-4
 * channels, atomically, at one of three compression efforts (hd_png_effort). libpng reports errors by
 * calling our error function, which records the reason and longjmps back to the setjmp in the
 * reader or writer. */
#include <errno.h>
#include <png.h>
#include <setjmp.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>
#include "core/core.h"
#include "io/image_io.h"

typedef struct png_context {
    FILE *f;
    FILE *out; /* writing: the stream (a failed write's errno gives the reason) */
    char reason[256];
    int truncated;
} png_context;

static void png_on_error(png_structp png, png_const_charp message)
{
    png_context *ctx = png_get_error_ptr(png);
    snprintf(ctx->reason, sizeof ctx->reason, "%s", message);
    png_longjmp(png, 1);
}

static void png_on_warning(png_structp png, png_const_charp message)
{
    (void)png;
    (void)message;
}

/* The read callback: short reads are errors that say the file is truncated. */
static void png_on_read(png_structp png, png_bytep data, size_t length)
{
    png_context *ctx = png_get_io_ptr(png);
    if (fread(data, 1, length, ctx->f) != length) {
        ctx->truncated = 1;
        png_error(png, ferror(ctx->f) ? "read error" : "file is truncated");
    }
}

/* The write callbacks: a failed write says why (the errno's text), not libpng's "Write Error". */
static void png_on_write(png_structp png, png_bytep data, size_t length)
{
    png_context *ctx = png_get_io_ptr(png);
    errno = 0;
    if (fwrite(data, 1, length, ctx->out) != length) png_error(png, strerror(errno ? errno : EIO));
}

static void png_on_flush(png_structp png)
{
    png_context *ctx = png_get_io_ptr(png);
    errno = 0;
    if (fflush(ctx->out) != 0) png_error(png, strerror(errno ? errno : EIO));
}

static float png_sample(const png_byte *row, size_t k, int bits)
{
    if (bits == 16) return (float)((row[2 * k] << 8) | row[2 * k + 1]) / 65535.0f;
    return (float)row[k] / 255.0f;
}

/* Reads path into img. All resources touched after setjmp live in `volatile` locals or in img,
 * so the longjmp path can release them. */
hd_status hd_image_read_png(FILE *f, long long file_size, const char *path, hd_image *img, hd_image_info *info)
{
    memset(img, 0, sizeof *img);
    png_context ctx = {0};
    ctx.f = f;
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &ctx, png_on_error, png_on_warning);
    png_infop pinfo = png ? png_create_info_struct(png) : NULL;
    if (!png || !pinfo) {
        png_destroy_read_struct(&png, NULL, NULL);
        return hd_fail(HD_ERR_NOMEM, "%s: out of memory starting libpng", path);
    }
    png_bytep volatile rows_buf = NULL;
    png_bytepp volatile row_ptrs = NULL;
    hd_status volatile st = HD_OK;
    if (setjmp(png_jmpbuf(png))) {
        free(rows_buf);
        free(row_ptrs);
        hd_image_free(img);
        png_destroy_read_struct(&png, &pinfo, NULL);
        if (st != HD_OK) return st;
        return hd_fail(HD_ERR_FORMAT, "%s: bad PNG: %s", path, ctx.reason);
    }
    png_set_read_fn(png, &ctx, png_on_read);
    png_read_info(png, pinfo);
    png_uint_32 width, height;
    int bit_depth, color_type, interlace;
    png_get_IHDR(png, pinfo, &width, &height, &bit_depth, &color_type, &interlace, NULL, NULL);
    int file_channels = png_get_channels(png, pinfo);
    if (hd_image_check_dims(path, (long)width, (long)height, 4) != HD_OK) {
        st = HD_ERR_RANGE;
        png_longjmp(png, 1);
    }
    /* A deflate stream compresses at most about 1032:1, so a file far smaller than its filtered
     * image data is lying about its size: refuse before allocating for it. */
    double raw = (double)height * (1.0 + ((double)width * file_channels * bit_depth + 7) / 8);
    if (file_size >= 0 && raw > 1100.0 * (double)file_size + 65536.0) {
        st = hd_fail(HD_ERR_FORMAT, "%s: bad PNG: header claims %ux%u pixels but the file has only "
                     "%lld bytes", path, (unsigned)width, (unsigned)height, file_size);
        png_longjmp(png, 1);
    }
    if (color_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
    if (color_type == PNG_COLOR_TYPE_GRAY && bit_depth < 8) png_set_expand_gray_1_2_4_to_8(png);
    if (png_get_valid(png, pinfo, PNG_INFO_tRNS)) png_set_tRNS_to_alpha(png);
    int passes = png_set_interlace_handling(png);
    png_read_update_info(png, pinfo);
    int channels = png_get_channels(png, pinfo);
    int bits = png_get_bit_depth(png, pinfo);
    size_t rowbytes = png_get_rowbytes(png, pinfo);
    if (channels < 1 || channels > 4 || (bits != 8 && bits != 16) ||
        rowbytes != (size_t)width * channels * (bits / 8)) {
        st = hd_fail(HD_ERR_FORMAT, "%s: unsupported PNG layout (%d channels of %d bits)", path,
                     channels, bits);
        png_longjmp(png, 1);
    }
    if (hd_image_alloc(img, (int)width, (int)height, channels) != HD_OK) {
        st = hd_fail(HD_ERR_NOMEM, "%s: out of memory for a %ux%u image", path, (unsigned)width,
                     (unsigned)height);
        png_longjmp(png, 1);
    }
    /* Interlaced images need every row at once (passes > 1); others are converted row by row. */
    size_t nrows = passes > 1 ? height : 1, total;
    if (!hd_mul_size(rowbytes, nrows, &total) || !(rows_buf = malloc(total)) ||
        !(row_ptrs = malloc(nrows * sizeof *row_ptrs))) {
        st = hd_fail(HD_ERR_NOMEM, "%s: out of memory for PNG rows", path);
        png_longjmp(png, 1);
    }
    for (size_t r = 0; r < nrows; r++) row_ptrs[r] = rows_buf + r * rowbytes;
    size_t plane = (size_t)width * height;
    if (passes > 1) png_read_image(png, row_ptrs);
    for (png_uint_32 y = 0; y < height; y++) {
        png_bytep row = row_ptrs[passes > 1 ? y : 0];
        if (passes <= 1) png_read_row(png, row, NULL);
        for (png_uint_32 x = 0; x < width; x++)
            for (int c = 0; c < channels; c++)
                img->data[c * plane + (size_t)y * width + x] = png_sample(row, (size_t)x * channels + c, bits);
    }
    png_read_end(png, NULL);
    info->format = "PNG";
    info->width = (int)width;
    info->height = (int)height;
    info->channels = channels;
    info->bits = bit_depth;
    info->palette = color_type == PNG_COLOR_TYPE_PALETTE;
    free(rows_buf);
    free(row_ptrs);
    png_destroy_read_struct(&png, &pinfo, NULL);
    return HD_OK;
}

/* round(clamp(v, 0, 1) * maxval), NaN -> 0; written without branches so the row loops vectorise. */
static inline unsigned quantise(float v, unsigned maxval)
{
    v = v > 0.0f ? v : 0.0f; /* also NaN */
    v = v < 1.0f ? v : 1.0f;
    return (unsigned)(v * (float)maxval + 0.5f);
}

hd_status hd_image_write_png(const char *path, const hd_image *img, int bits)
{
    return hd_image_write_png_effort(path, img, bits, HD_PNG_COMPACT);
}

hd_status hd_image_encode_png(FILE *out, const char *path, const hd_image *img, int bits, hd_png_effort effort)
{
    if (!img || !img->data || img->channels < 1 || img->channels > 4 || img->width <= 0 ||
        img->height <= 0)
        return hd_fail(HD_ERR_ARG, "%s: cannot write an image of %d channels as PNG", path,
                       img ? img->channels : 0);
    if (bits != 8 && bits != 16)
        return hd_fail(HD_ERR_ARG, "%s: PNG bit depth must be 8 or 16, not %d", path, bits);
    if (effort != HD_PNG_COMPACT && effort != HD_PNG_FAST && effort != HD_PNG_STORE)
        return hd_fail(HD_ERR_ARG, "%s: unknown PNG effort %d", path, (int)effort);
    hd_status fin = hd_image_check_finite(img, path);
    if (fin != HD_OK) return hd_fail(fin, "%s (not written)", hd_error());
    static const int color_types[5] = {0, PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA,
                                       PNG_COLOR_TYPE_RGB, PNG_COLOR_TYPE_RGB_ALPHA};
    int channels = img->channels, width = img->width, height = img->height;
    size_t rowbytes = (size_t)width * channels * (bits / 8);
    png_bytep row = hd_malloc(rowbytes);
    if (!row) return HD_ERR_NOMEM;
    png_context ctx = {0};
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &ctx, png_on_error, png_on_warning);
    png_infop pinfo = png ? png_create_info_struct(png) : NULL;
    if (!png || !pinfo) {
        png_destroy_write_struct(&png, NULL);
        free(row);
        return hd_fail(HD_ERR_NOMEM, "%s: out of memory starting libpng", path);
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &pinfo);
        free(row);
        return hd_fail(HD_ERR_IO, "%s: PNG write failed: %s", path, ctx.reason);
    }
    ctx.out = out;
    png_set_write_fn(png, &ctx, png_on_write, png_on_flush);
    png_set_IHDR(png, pinfo, (png_uint_32)width, (png_uint_32)height, bits, color_types[channels],
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    if (effort == HD_PNG_FAST) {
        /* One filter for every row (UP: no per-row trial of the five) and zlib's run-length
         * strategy (matches at distance 1 only, no hash chains): on a synthetic face's maps 3.8x
         * faster than COMPACT, files 2.6 % larger (docs/performance.md). */
        png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_UP);
        png_set_compression_level(png, 1);
        png_set_compression_strategy(png, Z_RLE);
    } else if (effort == HD_PNG_STORE) {
        /* No filter and zlib's stored blocks: no compression at all, the samples copied (plus
         * zlib's Adler-32 and libpng's CRC). 6x faster than FAST on a synthetic face's maps, files
         * 2.2x larger (docs/performance.md). */
        png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_NONE);
        png_set_compression_level(png, 0);
    } else {
        /* zlib level 3: about twice as fast as the default 6 on our 16-bit maps, files < 1% larger. */
        png_set_compression_level(png, 3);
    }
    png_write_info(png, pinfo);
    size_t plane = (size_t)width * height;
    unsigned maxval = bits == 16 ? 65535u : 255u;
    for (int y = 0; y < height; y++) {
        /* one plane at a time, so that the reads are contiguous */
        for (int c = 0; c < channels; c++) {
            const float *src = img->data + c * plane + (size_t)y * width;
            if (bits == 16) {
                for (int x = 0; x < width; x++) {
                    unsigned q = quantise(src[x], maxval);
                    size_t k = (size_t)x * channels + c;
                    row[2 * k] = (png_byte)(q >> 8);
                    row[2 * k + 1] = (png_byte)(q & 0xFF);
                }
            } else {
                for (int x = 0; x < width; x++) row[(size_t)x * channels + c] = (png_byte)quantise(src[x], maxval);
            }
        }
        png_write_row(png, row);
    }
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &pinfo);
    free(row);
    return HD_OK;
}

hd_status hd_image_write_png_effort(const char *path, const hd_image *img, int bits, hd_png_effort effort)
{
    hd_atomic_file af;
    hd_status st = hd_atomic_open(&af, path);
    if (st != HD_OK) return st;
    if ((st = hd_image_encode_png(af.f, path, img, bits, effort)) != HD_OK) {
        hd_atomic_abort(&af);
        return st;
    }
    return hd_atomic_commit(&af);
}
