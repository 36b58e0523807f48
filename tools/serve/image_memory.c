/* image_memory.c: PNG and JPEG pictures held in memory, for `hdnet serve`: an upload is never
 * written to disk, and a result is sent from memory. The header probe gives the claimed size
 * before any decoding, so the server's pixel cap is applied before anything is allocated; the
 * decoding and encoding themselves are the library's in-memory calls, so a photo uploaded gives
 * the pixels `hdnet relight` reads from the same bytes in a file. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "../hdnet_tool.h"
#include "serve.h"

hd_status serve_blob_append(serve_blob *b, const void *data, size_t n)
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

void serve_blob_free(serve_blob *b)
{
    free(b->data);
    memset(b, 0, sizeof *b);
}

static const unsigned char png_signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};

serve_picture_kind serve_picture_sniff(const unsigned char *data, size_t n)
{
    if (n >= 8 && memcmp(data, png_signature, 8) == 0) return SERVE_PICTURE_PNG;
    if (n >= 3 && data[0] == 0xFF && data[1] == 0xD8 && data[2] == 0xFF) return SERVE_PICTURE_JPEG;
    return SERVE_PICTURE_UNKNOWN;
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

hd_status serve_picture_probe(const unsigned char *data, size_t n, const char *what, long *width, long *height)
{
    *width = *height = 0;
    hd_status st;
    const serve_picture_kind kind = serve_picture_sniff(data, n);
    switch (kind) {
    case SERVE_PICTURE_PNG:
        /* signature, then the IHDR chunk: length 13, "IHDR", width, height */
        if (n < 24 || memcmp(data + 12, "IHDR", 4) != 0)
            return hd_fail(HD_ERR_FORMAT, "%s: bad PNG: no IHDR chunk", what);
        *width = (long)be32(data + 16);
        *height = (long)be32(data + 20);
        st = HD_OK;
        break;
    case SERVE_PICTURE_JPEG: st = probe_jpeg(data, n, what, width, height); break;
    default: return hd_fail(HD_ERR_FORMAT, "%s: not a PNG or JPEG", what);
    }
    /* a side of 0 (JPEG's "height from a DNL marker", or a broken header) is no size to check the
     * pixel cap against: refused here, as the decoder would refuse it (fuzz_serve found it) */
    if (st == HD_OK && (*width <= 0 || *height <= 0)) {
        st = hd_fail(HD_ERR_FORMAT, "%s: bad %s: the header gives a size of %ldx%ld", what,
                     kind == SERVE_PICTURE_PNG ? "PNG" : "JPEG", *width, *height);
        *width = *height = 0;
    }
    return st;
}

/* The decoding and encoding are the library's (hd_image_decode, hd_image_encode): the same
 * samples, EXIF orientation and checks as reading the bytes from a file, the same bytes as
 * writing one. */
hd_status serve_picture_decode(const unsigned char *data, size_t n, const char *what, hd_image *rgb)
{
    memset(rgb, 0, sizeof *rgb);
    if (serve_picture_sniff(data, n) == SERVE_PICTURE_UNKNOWN) return hd_fail(HD_ERR_FORMAT, "%s: not a PNG or JPEG", what);
    hd_image raw = {0};
    hd_status st = hd_image_decode(data, n, &raw, NULL);
    if (st != HD_OK) return st;
    if (raw.channels == 3) {
        *rgb = raw;
        return HD_OK;
    }
    st = hd_image_convert(&raw, 3, rgb);
    hd_image_free(&raw);
    return st;
}

hd_status serve_picture_encode_png(const hd_image *img, serve_blob *png)
{
    memset(png, 0, sizeof *png);
    unsigned char *data = NULL;
    size_t size = 0;
    hd_status st = hd_image_encode(img, HD_FORMAT_PNG, 0, &data, &size);
    if (st == HD_OK) st = serve_blob_append(png, data, size);
    hd_buffer_free(data);
    return st;
}
