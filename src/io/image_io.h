/* image_io.h: the per-format image readers and writers behind hd_image_read / hd_image_decode and
 * hd_image_write / hd_image_encode (image_codec.c dispatches: on the magic bytes to read, on the
 * format to write), and the size check they share. Every reader and writer works on a stdio
 * stream, so the same code serves files and memory buffers (fmemopen, open_memstream). */
#ifndef HD_IMAGE_IO_H
#define HD_IMAGE_IO_H

#include <stdio.h>
#include "hdnet.h"

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

#endif /* HD_IMAGE_IO_H */
