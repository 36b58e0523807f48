/* sheet.c: contact sheets, and the before / after relighting sheet of a photo. A grid of square cells on a border-coloured canvas; each picture is
 * resized into its cell and mapped to display colours by its kind (a picture as stored, a normal
 * map as (n + 1) / 2, a shading map as s / 2). Used by `hdnet decompose`, `hdnet relight --sheet`
 * and the trainer's sample sheets. */
#include <math.h>
#include <string.h>
#include "core/core.h"
#include "apply/apply.h"

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

hd_status hd_sheet_put_decomposition(hd_sheet *sheet, int row, const hd_image *input, const hd_decomposition *d)
{
    if (sheet->columns < 5)
        return hd_fail(HD_ERR_ARG, "contact sheet: a decomposition needs 5 columns, the sheet has %d", sheet->columns);
    hd_status st = hd_sheet_put(sheet, row, 0, input, HD_SHEET_PICTURE);
    if (st == HD_OK) st = hd_sheet_put(sheet, row, 1, &d->albedo, HD_SHEET_PICTURE);
    if (st == HD_OK) st = hd_sheet_put(sheet, row, 2, &d->shading, HD_SHEET_SHADING);
    if (st == HD_OK) st = hd_sheet_put(sheet, row, 3, &d->normal, HD_SHEET_NORMAL);
    if (st == HD_OK) st = hd_sheet_put(sheet, row, 4, &d->reconstruction, HD_SHEET_PICTURE);
    return st;
}

hd_status hd_sheet_write(const hd_sheet *sheet, const char *path)
{
    if (!sheet->canvas.data) return hd_fail(HD_ERR_ARG, "%s: contact sheet was not initialised", path);
    return hd_image_write_png(path, &sheet->canvas, 8);
}

/* The square around face f's landmarks, 1.3 x their larger extent, inside the photo. */
static void face_box(const hd_aligned_face *f, int W, int H, int *x0, int *y0, int *side)
{
    float lo[2] = {1e30f, 1e30f}, hi[2] = {-1e30f, -1e30f};
    for (int i = 0; i < HD_FACE_LANDMARKS; i++)
        for (int k = 0; k < 2; k++) lo[k] = fminf(lo[k], f->landmarks[i][k]), hi[k] = fmaxf(hi[k], f->landmarks[i][k]);
    float s = 1.3f * fmaxf(hi[0] - lo[0], hi[1] - lo[1]);
    int n = (int)s;
    if (n > W) n = W;
    if (n > H) n = H;
    if (n < 1) n = 1;
    int x = (int)(0.5f * (lo[0] + hi[0]) - 0.5f * n), y = (int)(0.5f * (lo[1] + hi[1]) - 0.5f * n);
    *x0 = x < 0 ? 0 : x + n > W ? W - n : x;
    *y0 = y < 0 ? 0 : y + n > H ? H - n : y;
    *side = n;
}

static hd_status crop(const hd_image *im, int x0, int y0, int side, hd_image *out)
{
    hd_status st = hd_image_alloc(out, side, side, im->channels);
    for (int c = 0; st == HD_OK && c < im->channels; c++)
        for (int y = 0; y < side; y++)
            memcpy(out->data + ((size_t)c * side + y) * side,
                   im->data + ((size_t)c * im->height + (size_t)(y0 + y)) * im->width + x0, (size_t)side * sizeof(float));
    return st;
}

hd_status hd_relight_sheet(hd_model *model, hd_aligner *aligner, const hd_image *photo, hd_image *canvas)
{
    memset(canvas, 0, sizeof *canvas);
    hd_light_rgb presets[HD_LIGHT_PRESETS];
    for (int k = 0; k < HD_LIGHT_PRESETS; k++) {
        float l[HD_SH_COEFFS];
        hd_light_preset(k, l);
        hd_light_rgb_from_grey(l, &presets[k]);
    }
    hd_sheet sheet;
    memset(&sheet, 0, sizeof sheet);
    hd_status st = HD_OK;
    int x0 = 0, y0 = 0, side = 0;
    const hd_relight_rule rules[2] = {HD_RULE_PAPER, HD_RULE_RATIO};
    for (int row = 0; row < 2 && st == HD_OK; row++) {
        hd_apply_request q = {presets, HD_LIGHT_PRESETS, 1, 0, rules[row], HD_BRIGHTNESS_KEEP};
        hd_apply_result r;
        if ((st = hd_apply_photo(model, aligner, photo, &q, &r)) != HD_OK) break;
        if (row == 0) {
            face_box(&r.faces[0], photo->width, photo->height, &x0, &y0, &side);
            st = hd_sheet_init(&sheet, 2, HD_LIGHT_PRESETS + 2, side, 4);
        }
        for (int col = 0; col < HD_LIGHT_PRESETS + 2 && st == HD_OK; col++) {
            const hd_image *src = col == 0 ? photo : col == HD_LIGHT_PRESETS + 1 ? &r.delit : &r.relit[col - 1];
            hd_image cut = {0};
            st = crop(src, x0, y0, side, &cut);
            if (st == HD_OK) st = hd_sheet_put(&sheet, row, col, &cut, HD_SHEET_PICTURE);
            hd_image_free(&cut);
        }
        hd_apply_result_free(&r);
    }
    if (st == HD_OK) {
        *canvas = sheet.canvas;
        memset(&sheet.canvas, 0, sizeof sheet.canvas);
    }
    hd_sheet_free(&sheet);
    return st;
}
