/* image_codec.c: images to and from files and memory buffers. Reading sniffs the magic bytes
 * (PNG, JPEG, PFM) and hands the stream to that format's reader; a file is read through fopen, a
 * buffer through fmemopen, so both take exactly the same path. Writing picks the format from the
 * file's extension (or the caller's hd_image_format), encodes to the atomic file's stream or to an
 * open_memstream buffer. */
#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include "core/core.h"
#include "io/image_io.h"

#define HD_JPEG_DEFAULT_QUALITY 95

/* Reads one image from f (size bytes, -1 unknown) by its magic bytes. */
static hd_status decode_stream(FILE *f, long long size, const char *name, hd_image *img, hd_image_info *info)
{
    hd_image_info local;
    if (!info) info = &local;
    memset(info, 0, sizeof *info);
    info->orientation = 1;
    memset(img, 0, sizeof *img);
    unsigned char magic[8];
    size_t got = fread(magic, 1, sizeof magic, f);
    if (ferror(f)) return hd_fail(HD_ERR_IO, "%s: cannot read: %s", name, strerror(errno));
    if (got == 0) return hd_fail(HD_ERR_FORMAT, "%s: empty file, not an image", name);
    if (fseek(f, 0, SEEK_SET) != 0) return hd_fail(HD_ERR_IO, "%s: cannot seek: %s", name, strerror(errno));
    static const unsigned char png_sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    if (got >= 8 && memcmp(magic, png_sig, 8) == 0) return hd_image_read_png(f, size, name, img, info);
    if (got >= 3 && magic[0] == 0xFF && magic[1] == 0xD8 && magic[2] == 0xFF)
        return hd_image_read_jpeg(f, size, name, img, info);
    if (got >= 3 && magic[0] == 'P' && (magic[1] == 'F' || magic[1] == 'f') &&
        (magic[2] == '\n' || magic[2] == ' ' || magic[2] == '\r' || magic[2] == '\t'))
        return hd_image_read_pfm(f, size, name, img, info);
    return hd_fail(HD_ERR_FORMAT, "%s: unknown image format (not PNG, JPEG or PFM)", name);
}

hd_status hd_image_read_info(const char *path, hd_image *img, hd_image_info *info)
{
    if (info) memset(info, 0, sizeof *info);
    memset(img, 0, sizeof *img);
    FILE *f = fopen(path, "rb");
    if (!f) return hd_fail(HD_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    struct stat sb;
    long long size = fstat(fileno(f), &sb) == 0 && S_ISREG(sb.st_mode) ? (long long)sb.st_size : -1;
    hd_status st = decode_stream(f, size, path, img, info);
    fclose(f);
    return st;
}

hd_status hd_image_read(const char *path, hd_image *img) { return hd_image_read_info(path, img, NULL); }

hd_status hd_image_decode(const void *data, size_t size, hd_image *img, hd_image_info *info)
{
    if (info) memset(info, 0, sizeof *info);
    if (img) memset(img, 0, sizeof *img);
    if (!img || (!data && size > 0)) return hd_fail(HD_ERR_ARG, "hd_image_decode: missing argument");
    if (size == 0) return hd_fail(HD_ERR_FORMAT, "<memory>: empty buffer, not an image");
    FILE *f = fmemopen((void *)data, size, "rb");
    if (!f) return hd_fail(HD_ERR_NOMEM, "<memory>: cannot open a stream over the buffer: %s", strerror(errno));
    hd_status st = decode_stream(f, (long long)size, "<memory>", img, info);
    fclose(f);
    return st;
}

hd_status hd_image_format_of(const char *path, hd_image_format *format)
{
    const char *slash = strrchr(path, '/'), *base = slash ? slash + 1 : path, *dot = strrchr(base, '.');
    const char *ext = dot && dot != base ? dot + 1 : "";
    if (strcasecmp(ext, "png") == 0) *format = HD_FORMAT_PNG;
    else if (strcasecmp(ext, "jpg") == 0 || strcasecmp(ext, "jpeg") == 0) *format = HD_FORMAT_JPEG;
    else if (strcasecmp(ext, "pfm") == 0) *format = HD_FORMAT_PFM;
    else
        return hd_fail(HD_ERR_ARG, "%s: cannot write images as '%s%s' (the extension chooses the format: .png, .jpg or "
                       ".jpeg, .pfm)", path, *ext ? "." : "no extension", ext);
    return HD_OK;
}

static hd_status encode_stream(FILE *out, const char *name, const hd_image *img, hd_image_format format, int quality)
{
    switch (format) {
    case HD_FORMAT_PNG: return hd_image_encode_png(out, name, img, 8, HD_PNG_COMPACT);
    case HD_FORMAT_JPEG: return hd_image_encode_jpeg(out, name, img, quality ? quality : HD_JPEG_DEFAULT_QUALITY);
    case HD_FORMAT_PFM: return hd_image_encode_pfm(out, name, img);
    }
    return hd_fail(HD_ERR_ARG, "%s: unknown image format %d", name, (int)format);
}

hd_status hd_image_encode(const hd_image *img, hd_image_format format, int quality, unsigned char **data, size_t *size)
{
    *data = NULL;
    *size = 0;
    char *buf = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&buf, &len);
    if (!f) return hd_fail(HD_ERR_NOMEM, "<memory>: cannot open a memory stream: %s", strerror(errno));
    hd_status st = encode_stream(f, "<memory>", img, format, quality);
    if (fclose(f) != 0 && st == HD_OK) st = hd_fail(HD_ERR_NOMEM, "<memory>: out of memory encoding an image");
    if (st != HD_OK) {
        free(buf);
        return st;
    }
    *data = (unsigned char *)buf;
    *size = len;
    return HD_OK;
}

void hd_buffer_free(void *data) { free(data); }

hd_status hd_image_write(const char *path, const hd_image *img, int quality)
{
    hd_image_format format;
    hd_status st = hd_image_format_of(path, &format);
    if (st != HD_OK) return st;
    hd_atomic_file af;
    if ((st = hd_atomic_open(&af, path)) != HD_OK) return st;
    if ((st = encode_stream(af.f, path, img, format, quality)) != HD_OK) {
        hd_atomic_abort(&af);
        return st;
    }
    return hd_atomic_commit(&af);
}

hd_status hd_image_write_picture(const char *path, const hd_image *img) { return hd_image_write(path, img, 0); }
