/* image_io.h: the per-format image readers behind hd_image_read (image.c dispatches on the
 * file's magic bytes), and the size check they share. */
#ifndef HD_IMAGE_IO_H
#define HD_IMAGE_IO_H

#include "hdnet.h"

/* Each fills img (allocated) and info (not NULL); on failure img is left empty and the reason
 * names the file. */
hd_status hd_image_read_png(const char *path, hd_image *img, hd_image_info *info);
hd_status hd_image_read_jpeg(const char *path, hd_image *img, hd_image_info *info);
hd_status hd_image_read_pfm(const char *path, hd_image *img, hd_image_info *info);

/* HD_OK when width x height x channels floats is a size we accept: sides in 1..HD_IMAGE_MAX_SIDE
 * and the byte count representable; otherwise the reason names path. */
hd_status hd_image_check_dims(const char *path, long width, long height, int channels);

#endif /* HD_IMAGE_IO_H */
