/* image_pfm.c: PFM, the exact float32 image format. A header of three white-space separated
 * tokens, "PF" (RGB) or "Pf" (gray), "WIDTH HEIGHT", and a scale whose sign gives the byte order
 * (negative: little-endian); one white-space byte; then width*height*channels float32 samples,
 * rows from the bottom of the image to the top, channels interleaved. The header is parsed
 * strictly (decimal sizes within the limits, a finite nonzero scale) and a short file is an error. */
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include "core/core.h"
#include "io/image_io.h"

#define PFM_TOKEN_MAX 64

static int is_space(int c) { return c == ' ' || c == '\n' || c == '\r' || c == '\t'; }

/* Reads one white-space delimited token into buf; returns its length, or -1 when the file ends
 * before one or it is longer than PFM_TOKEN_MAX - 1. *after gets the byte that ended it. */
static int read_token(FILE *f, char *buf, int *after)
{
    int c;
    while ((c = getc(f)) != EOF && is_space(c)) {}
    int n = 0;
    while (c != EOF && !is_space(c)) {
        if (n == PFM_TOKEN_MAX - 1) return -1;
        buf[n++] = (char)c;
        c = getc(f);
    }
    buf[n] = '\0';
    *after = c;
    return n > 0 ? n : -1;
}

/* A decimal integer of digits only (capped just above 1e9); -1 on anything else. */
static long parse_size(const char *s)
{
    long v = 0;
    if (!*s) return -1;
    for (; *s; s++) {
        if (*s < '0' || *s > '9') return -1;
        v = v * 10 + (*s - '0');
        if (v > 1000000000L) return v;
    }
    return v;
}

static uint32_t bswap32(uint32_t v)
{
    return (v >> 24) | ((v >> 8) & 0xFF00u) | ((v << 8) & 0xFF0000u) | (v << 24);
}

static int host_little_endian(void)
{
    const uint16_t one = 1;
    return *(const unsigned char *)&one == 1;
}

hd_status hd_image_read_pfm(FILE *f, long long file_size, const char *path, hd_image *img, hd_image_info *info)
{
    memset(img, 0, sizeof *img);
    char magic[PFM_TOKEN_MAX], ws[PFM_TOKEN_MAX], hs[PFM_TOKEN_MAX], ss[PFM_TOKEN_MAX];
    int after = 0;
    hd_status st = HD_OK;
    float *buf = NULL;
    if (read_token(f, magic, &after) < 0 || (strcmp(magic, "PF") != 0 && strcmp(magic, "Pf") != 0)) {
        st = hd_fail(HD_ERR_FORMAT, "%s: bad PFM: magic is not PF or Pf", path);
        goto done;
    }
    int channels = magic[1] == 'F' ? 3 : 1;
    if (read_token(f, ws, &after) < 0 || read_token(f, hs, &after) < 0) {
        st = hd_fail(HD_ERR_FORMAT, "%s: bad PFM: header ends before the width and height", path);
        goto done;
    }
    long width = parse_size(ws), height = parse_size(hs);
    if (width < 0 || height < 0) {
        st = hd_fail(HD_ERR_FORMAT, "%s: bad PFM: size '%s %s' is not two decimal integers", path, ws, hs);
        goto done;
    }
    if ((st = hd_image_check_dims(path, width, height, channels)) != HD_OK) goto done;
    if (read_token(f, ss, &after) < 0) {
        st = hd_fail(HD_ERR_FORMAT, "%s: bad PFM: header ends before the scale", path);
        goto done;
    }
    char *end = NULL;
    errno = 0;
    double scale = strtod(ss, &end);
    if (end == ss || *end != '\0' || errno == ERANGE || !isfinite(scale) || scale == 0.0) {
        st = hd_fail(HD_ERR_FORMAT, "%s: bad PFM: scale '%s' is not a finite nonzero number", path, ss);
        goto done;
    }
    if (after == EOF) {
        st = hd_fail(HD_ERR_FORMAT, "%s: bad PFM: file is truncated (no pixel data)", path);
        goto done;
    }
    int file_little = scale < 0;
    size_t count = (size_t)width * (size_t)height * (size_t)channels; /* checked by check_dims */
    /* the samples must be there before anything is allocated for them */
    long here = ftell(f);
    if (file_size >= 0 && here >= 0 && here <= file_size &&
        (unsigned long long)(file_size - here) < (unsigned long long)count * 4u) {
        st = hd_fail(HD_ERR_FORMAT, "%s: bad PFM: file is truncated (the header claims %ldx%ld, %zu bytes of samples, "
                     "the file has %lld bytes after it)", path, width, height, count * 4, file_size - here);
        goto done;
    }
    if ((st = hd_image_alloc(img, (int)width, (int)height, channels)) != HD_OK) {
        st = hd_fail(st, "%s: %s", path, hd_error());
        goto done;
    }
    size_t row_count = (size_t)width * channels;
    buf = hd_malloc(row_count * sizeof(float));
    if (!buf) {
        st = HD_ERR_NOMEM;
        goto done;
    }
    int swap = file_little != host_little_endian();
    size_t plane = (size_t)width * height;
    for (long r = 0; r < height; r++) {
        if (fread(buf, sizeof(float), row_count, f) != row_count) {
            st = hd_fail(HD_ERR_FORMAT, "%s: bad PFM: file is truncated (%zu of %zu samples)", path,
                         (size_t)r * row_count, count);
            goto done;
        }
        long y = height - 1 - r; /* rows are stored bottom to top */
        for (size_t k = 0; k < row_count; k++) {
            float v = buf[k];
            if (swap) {
                uint32_t u;
                memcpy(&u, &v, 4);
                u = bswap32(u);
                memcpy(&v, &u, 4);
            }
            if (!isfinite(v)) {
                st = hd_fail(HD_ERR_NUMERIC, "%s: bad PFM: sample at row %ld is not finite", path, y);
                goto done;
            }
            size_t x = k / channels, c = k % channels;
            img->data[c * plane + (size_t)y * width + x] = v;
        }
    }
    info->format = "PFM";
    info->width = (int)width;
    info->height = (int)height;
    info->channels = channels;
    info->bits = 32;
    info->palette = 0;
done:
    free(buf);
    if (st != HD_OK) hd_image_free(img);
    return st;
}

hd_status hd_image_encode_pfm(FILE *out, const char *path, const hd_image *img)
{
    if (!img || !img->data || (img->channels != 1 && img->channels != 3) || img->width <= 0 ||
        img->height <= 0)
        return hd_fail(HD_ERR_ARG, "%s: PFM holds 1 or 3 channels, not %d", path, img ? img->channels : 0);
    hd_status fin = hd_image_check_finite(img, path);
    if (fin != HD_OK) return hd_fail(fin, "%s (not written)", hd_error());
    int width = img->width, height = img->height, channels = img->channels;
    size_t row_count = (size_t)width * channels, plane = (size_t)width * height;
    uint32_t *row = hd_malloc(row_count * sizeof(uint32_t));
    if (!row) return HD_ERR_NOMEM;
    /* Little-endian, written byte by byte through the integer representation. */
    fprintf(out, "%s\n%d %d\n-1.0\n", channels == 3 ? "PF" : "Pf", width, height);
    for (int r = 0; r < height; r++) {
        int y = height - 1 - r;
        unsigned char *bytes = (unsigned char *)row;
        for (size_t k = 0; k < row_count; k++) {
            size_t x = k / channels, c = k % channels;
            uint32_t u;
            memcpy(&u, &img->data[c * plane + (size_t)y * width + x], 4);
            bytes[4 * k] = (unsigned char)u;
            bytes[4 * k + 1] = (unsigned char)(u >> 8);
            bytes[4 * k + 2] = (unsigned char)(u >> 16);
            bytes[4 * k + 3] = (unsigned char)(u >> 24);
        }
        fwrite(row, 4, row_count, out);
    }
    free(row);
    return ferror(out) ? hd_fail(HD_ERR_IO, "%s: PFM write failed", path) : HD_OK;
}

hd_status hd_image_write_pfm(const char *path, const hd_image *img)
{
    hd_atomic_file af;
    hd_status st = hd_atomic_open(&af, path);
    if (st != HD_OK) return st;
    if ((st = hd_image_encode_pfm(af.f, path, img)) != HD_OK) {
        hd_atomic_abort(&af);
        return st;
    }
    return hd_atomic_commit(&af);
}
