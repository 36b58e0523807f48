/* sheet.c: contact sheets (hdnet.h's hd_sheet_*): a grid of square cells on a border-coloured
 * canvas; each picture is resized into its cell and mapped to display colours by its kind (a
 * picture as stored, a normal map as (n + 1) / 2, a shading map as s / 2), and the canvas is
 * written as an 8-bit PNG. Only images: used by apply's sheets (a decomposition's row, the before /
 * after sheet of a photo), `hdnet decompose`, `hdnet relight --sheet` and the trainer's sample
 * sheets (train/train_log.c). */
#include <string.h>
#include "core/core.h"

#define SHEET_BORDER_GRAY 0.12f
#define SHEET_MAX_CELLS 4096

hd_status hd_sheet_init(hd_sheet *sheet, int rows, int columns, int cell, int border)
{
    memset(sheet, 0, sizeof *sheet);
    if (rows < 1 || columns < 1 || cell < 1 || border < 0 || rows > SHEET_MAX_CELLS ||
        columns > SHEET_MAX_CELLS || cell > HD_IMAGE_MAX_SIDE || border > 256)
        return hd_fail(HD_ERR_ARG, "contact sheet of %d x %d cells of %d pixels (border %d) is out of range",
                       rows, columns, cell, border);
    /* side = n * (cell + border) + border */
    long width = (long)columns * (cell + border) + border, height = (long)rows * (cell + border) + border;
    if (width > HD_IMAGE_MAX_SIDE * 4L || height > HD_IMAGE_MAX_SIDE * 4L)
        return hd_fail(HD_ERR_RANGE, "contact sheet of %ld x %ld pixels is too large", width, height);
    hd_status st = hd_image_alloc(&sheet->canvas, (int)width, (int)height, 3);
    if (st != HD_OK) return st;
    size_t n = (size_t)width * (size_t)height * 3;
    for (size_t i = 0; i < n; i++) sheet->canvas.data[i] = SHEET_BORDER_GRAY;
    sheet->rows = rows;
    sheet->columns = columns;
    sheet->cell = cell;
    sheet->border = border;
    return HD_OK;
}

void hd_sheet_free(hd_sheet *sheet)
{
    hd_image_free(&sheet->canvas);
    memset(sheet, 0, sizeof *sheet);
}

static float clamp01(float v) { return v < 0.0f ? 0.0f : v > 1.0f ? 1.0f : v; }

/* The display value of channel c (0..2) at pixel p of a picture of the given kind. */
static float display(const hd_image *img, hd_sheet_kind kind, int c, size_t p)
{
    size_t plane = (size_t)img->width * (size_t)img->height;
    const float *d = img->data;
    switch (kind) {
    case HD_SHEET_NORMAL: {
        if (img->channels < 3) break;
        float x = d[p], y = d[plane + p], z = d[2 * plane + p];
        if (x * x + y * y + z * z < 0.25f) return 0.0f; /* masked out: written as 0, as in files */
        return clamp01((d[(size_t)c * plane + p] + 1.0f) * 0.5f);
    }
    case HD_SHEET_SHADING:
        return clamp01(d[p] * 0.5f); /* s / 2, as in NAME.shading.png */
    case HD_SHEET_PICTURE:
        break;
    }
    int ch = img->channels >= 3 ? c : 0; /* gray (and gray + alpha) shown gray; alpha dropped */
    return clamp01(d[(size_t)ch * plane + p]);
}

hd_status hd_sheet_put(hd_sheet *sheet, int row, int column, const hd_image *picture, hd_sheet_kind kind)
{
    if (row < 0 || row >= sheet->rows || column < 0 || column >= sheet->columns)
        return hd_fail(HD_ERR_ARG, "contact sheet cell (%d, %d) outside %d x %d", row, column, sheet->rows,
                       sheet->columns);
    if (!picture || !picture->data || picture->channels < 1 || picture->channels > 4)
        return hd_fail(HD_ERR_ARG, "contact sheet: picture for cell (%d, %d) is empty or has %d channels", row,
                       column, picture ? picture->channels : 0);
    if (kind == HD_SHEET_NORMAL && picture->channels != 3)
        return hd_fail(HD_ERR_ARG, "contact sheet: a normal map has 3 channels, not %d", picture->channels);
    const hd_image *src = picture;
    hd_image resized = {0};
    const int cell = sheet->cell;
    if (picture->width != cell || picture->height != cell) {
        hd_status st = hd_image_resize(picture, cell, cell, &resized);
        if (st != HD_OK) return st;
        src = &resized;
    }
    const int W = sheet->canvas.width, H = sheet->canvas.height;
    const int x0 = sheet->border + column * (cell + sheet->border);
    const int y0 = sheet->border + row * (cell + sheet->border);
    for (int c = 0; c < 3; c++)
        for (int y = 0; y < cell; y++)
            for (int x = 0; x < cell; x++)
                sheet->canvas.data[((size_t)c * H + (size_t)(y0 + y)) * W + (size_t)(x0 + x)] =
                    display(src, kind, c, (size_t)y * cell + (size_t)x);
    hd_image_free(&resized);
    return HD_OK;
}

hd_status hd_sheet_write(const hd_sheet *sheet, const char *path)
{
    if (!sheet->canvas.data) return hd_fail(HD_ERR_ARG, "%s: contact sheet was not initialised", path);
    return hd_image_write_png(path, &sheet->canvas, 8);
}
