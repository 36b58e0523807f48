/* mask.c: finding the mask of a face image: its companion NAME.mask.png (SPEC section 5), else a
 * mask the user gave, else all ones. */
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "core/core.h"

hd_status hd_face_mask_read(const char *image_path, const char *fallback, int width, int height,
                            hd_image *mask, char **source)
{
    memset(mask, 0, sizeof *mask);
    if (source) *source = NULL;
    if (width < 1 || height < 1 || width > HD_IMAGE_MAX_SIDE || height > HD_IMAGE_MAX_SIDE)
        return hd_fail(HD_ERR_ARG, "mask of %d x %d pixels is out of range", width, height);
    char *path = image_path ? hd_path_companion(image_path, ".mask.png") : NULL;
    if (image_path && !path) return HD_ERR_NOMEM;
    if (path && access(path, F_OK) != 0) {
        free(path);
        path = NULL;
    }
    if (!path && fallback) {
        size_t n = strlen(fallback) + 1;
        path = hd_malloc(n);
        if (!path) return HD_ERR_NOMEM;
        memcpy(path, fallback, n);
    }
    hd_status st;
    if (!path) {
        st = hd_image_alloc(mask, width, height, 1);
        if (st != HD_OK) return st;
        for (size_t p = 0; p < (size_t)width * (size_t)height; p++) mask->data[p] = 1.0f;
        return HD_OK;
    }
    hd_image raw = {0};
    st = hd_image_read_as(path, 1, &raw);
    if (st == HD_OK) {
        if (raw.width == width && raw.height == height) {
            *mask = raw;
            raw.data = NULL;
        } else {
            st = hd_image_resize(&raw, width, height, mask);
        }
    }
    hd_image_free(&raw);
    if (st == HD_OK && source) *source = path;
    else free(path);
    return st;
}
