/* exif.c: the EXIF orientation of a JPEG (tag 0x0112 in the first IFD of its APP1 "Exif" segment)
 * and turning a decoded image upright by it. Every offset in the TIFF structure is checked against
 * the segment's length; anything unreadable counts as orientation 1 (as stored). */
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "io/image_io.h"

static unsigned get16(const unsigned char *p, int little) { return little ? p[0] | p[1] << 8 : p[0] << 8 | p[1]; }

static unsigned long get32(const unsigned char *p, int little)
{
    return little ? (unsigned long)p[0] | (unsigned long)p[1] << 8 | (unsigned long)p[2] << 16 | (unsigned long)p[3] << 24
                  : (unsigned long)p[0] << 24 | (unsigned long)p[1] << 16 | (unsigned long)p[2] << 8 | p[3];
}

int hd_exif_orientation(const unsigned char *app1, size_t size)
{
    /* "Exif\0\0", then a TIFF header: byte order "II" / "MM", 42, the first IFD's offset. */
    if (size < 6 + 8 || memcmp(app1, "Exif\0\0", 6) != 0) return 1;
    const unsigned char *t = app1 + 6;
    size_t n = size - 6;
    int little;
    if (t[0] == 'I' && t[1] == 'I') little = 1;
    else if (t[0] == 'M' && t[1] == 'M') little = 0;
    else return 1;
    if (get16(t + 2, little) != 42) return 1;
    unsigned long ifd = get32(t + 4, little);
    if (ifd > n || n - ifd < 2) return 1;
    unsigned entries = get16(t + ifd, little);
    for (unsigned i = 0; i < entries; i++) {
        size_t e = ifd + 2 + (size_t)12 * i;
        if (e > n || n - e < 12) return 1;
        if (get16(t + e, little) != 0x0112) continue;
        /* type SHORT (3), count 1: the value sits in the first two bytes of the value field */
        if (get16(t + e + 2, little) != 3 || get32(t + e + 4, little) != 1) return 1;
        unsigned v = get16(t + e + 8, little);
        return v >= 1 && v <= 8 ? (int)v : 1;
    }
    return 1;
}

hd_status hd_image_orient(hd_image *img, int orientation)
{
    if (orientation <= 1 || orientation > 8) return HD_OK;
    int W = img->width, H = img->height, C = img->channels, swap = orientation >= 5;
    hd_image out = {0};
    hd_status st = hd_image_alloc(&out, swap ? H : W, swap ? W : H, C);
    if (st != HD_OK) return st;
    int Wo = out.width, Ho = out.height;
    for (int c = 0; c < C; c++) {
        const float *src = img->data + (size_t)c * W * H;
        float *dst = out.data + (size_t)c * Wo * Ho;
        for (int y = 0; y < Ho; y++)
            for (int x = 0; x < Wo; x++) {
                int sx, sy; /* the stored pixel shown at (x, y) */
                switch (orientation) {
                case 2: sx = W - 1 - x, sy = y; break;          /* mirrored left-right */
                case 3: sx = W - 1 - x, sy = H - 1 - y; break;  /* turned 180 degrees */
                case 4: sx = x, sy = H - 1 - y; break;          /* mirrored top-bottom */
                case 5: sx = y, sy = x; break;                  /* transposed */
                case 6: sx = y, sy = H - 1 - x; break;          /* to be turned 90 degrees clockwise */
                case 7: sx = W - 1 - y, sy = H - 1 - x; break;  /* transversed */
                default: sx = W - 1 - y, sy = x; break;         /* 8: to be turned 90 degrees anticlockwise */
                }
                dst[(size_t)y * Wo + x] = src[(size_t)sy * W + sx];
            }
    }
    hd_image_free(img);
    *img = out;
    return HD_OK;
}
