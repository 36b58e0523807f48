/* sheet.c: the sheets of a model's outputs, on the contact sheets of io/sheet.c: a decomposition's
 * row (input | albedo | shading | normal | reconstruction, for `hdnet decompose`) and the before /
 * after relighting sheet of a photo (`hdnet relight --sheet`). */
#include <math.h>
#include <string.h>
#include "core/core.h"
#include "apply/apply.h"

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
        hd_apply_request q = {presets, HD_LIGHT_PRESETS, 1, 0, rules[row], HD_BRIGHTNESS_KEEP, HD_SOURCE_FIT, 0.0f, NULL};
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
