/* image_io.h: the per-format image readers and writers behind hd_image_read / hd_image_decode and
 * hd_image_write / hd_image_encode (image_codec.c dispatches: on the magic bytes to read, on the
 * format to write), and the size check they share. Every reader and writer works on a stdio
 * stream, so the same code serves files and memory buffers (fmemopen, open_memstream). */
#ifndef HD_IMAGE_IO_H
#define HD_IMAGE_IO_H

#include <stdio.h>
#include "hdnet.h"

/* How hard the PNG writer compresses. COMPACT (what hd_image_write_png does): zlib level 3 with
 * libpng's adaptive per-row filter choice. FAST: the UP filter on every row and zlib's run-length
 * strategy, 2.5-4x faster; files 3 % larger on a synthetic face's maps, 10 % on a picture sheet,
 * 3 % smaller on a photograph. STORE: no filter, zlib's stored blocks (no compression), 6x faster
 * than FAST, files 2.2x larger than FAST on a face's maps. For bulk output such as `hdnet synth`
 * (docs/performance.md, "Synthetic data"). Every effort decodes to the same samples. */
typedef enum hd_png_effort { HD_PNG_COMPACT = 0, HD_PNG_FAST = 1, HD_PNG_STORE = 2 } hd_png_effort;

/* Each reads one image from f (positioned at its first byte; `size` is its length in bytes, or
 * -1 when unknown), fills img (allocated) and info (not NULL); on failure img is left empty and the
 * reason names `name` (the path, or "<memory>"). The stream is not closed. */
hd_status hd_image_read_png(FILE *f, long long size, const char *name, hd_image *img, hd_image_info *info);
hd_status hd_image_read_jpeg(FILE *f, long long size, const char *name, hd_image *img, hd_image_info *info);
hd_status hd_image_read_pfm(FILE *f, long long size, const char *name, hd_image *img, hd_image_info *info);

/* Each writes img to the stream `out`; errors name `name`. */
hd_status hd_image_encode_png(FILE *out, const char *name, const hd_image *img, int bits, hd_png_effort effort);
hd_status hd_image_encode_jpeg(FILE *out, const char *name, const hd_image *img, int quality);
hd_status hd_image_encode_pfm(FILE *out, const char *name, const hd_image *img);

/* HD_OK when width x height x channels floats is a size we accept: sides in 1..HD_IMAGE_MAX_SIDE
 * and the byte count representable; otherwise the reason names path. */
hd_status hd_image_check_dims(const char *path, long width, long height, int channels);

/* EXIF (exif.c): the orientation tag (1..8) of a JPEG APP1 "Exif" segment's payload, 1 when
 * absent or unreadable; and the image turned upright for orientation o (2..8: the mirror and
 * rotations of the EXIF specification; 5-8 swap width and height), in place. */
int hd_exif_orientation(const unsigned char *app1, size_t size);
hd_status hd_image_orient(hd_image *img, int orientation);

/* ---- image calls the library itself, the tool and the tests use (not public) */
long long hd_max_pixels(void);
hd_status hd_image_write_png_effort(const char *path, const hd_image *img, int bits, hd_png_effort effort);
/* The format a path's extension names: .png, .jpg / .jpeg, .pfm (any case); anything else is
 * HD_ERR_ARG naming the path (never a PNG under another name). */
hd_status hd_image_format_of(const char *path, hd_image_format *format);
/* Reads PNG, JPEG or PFM as stored (channels as in the file; palette expands to RGB or RGBA), a
 * JPEG turned upright by its EXIF orientation: hd_image_read_info without the description. */
hd_status hd_image_read(const char *path, hd_image *img);

#endif /* HD_IMAGE_IO_H */
