/* train_log.c: the training log (train_log.h): loss.csv (one row per iteration, kept up to the
 * checkpoint's iteration on resume), the history of every row, the loss curves as a PNG line plot,
 * and the sample sheet of the last forward (through the contact sheets of apply/sheet.c). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "model/train_log.h"
#include "light/light.h"

static hd_status history_push(hd_train_log *h, const float *row)
{
    if (h->n == h->cap) {
        long cap = h->cap ? 2 * h->cap : 1024;
        float *v = realloc(h->v, (size_t)cap * HD_TRAIN_LOG_COLS * sizeof(float));
        if (!v) return hd_fail(HD_ERR_NOMEM, "out of memory keeping the loss history");
        h->v = v;
        h->cap = cap;
    }
    memcpy(h->v + (size_t)h->n * HD_TRAIN_LOG_COLS, row, HD_TRAIN_LOG_COLS * sizeof(float));
    h->n++;
    return HD_OK;
}

static void csv_header(FILE *f)
{
    fprintf(f, "iteration,total");
    for (int k = 0; k < HD_LOSS_TERMS; k++) fprintf(f, ",%s", hd_loss_names[k]);
    fprintf(f, ",disc,seconds\n");
}

/* Rewrites loss.csv keeping rows up to `iteration` (a resumed run continues from its checkpoint)
 * and loads them into the history. */
static hd_status csv_restore(const char *path, long iteration, hd_train_log *h)
{
    char *data = NULL;
    size_t size;
    h->n = 0;
    if (hd_read_file(path, (size_t)1 << 31, &data, &size) != HD_OK) data = NULL;
    hd_atomic_file af;
    hd_status s = hd_atomic_open(&af, path);
    if (s != HD_OK) {
        free(data);
        return s;
    }
    csv_header(af.f);
    char *line = data ? strchr(data, '\n') : NULL; /* skip the header */
    while (line && *++line) {
        char *next = strchr(line, '\n');
        if (next) *next = '\0';
        char *end;
        long it = strtol(line, &end, 10);
        if (end != line && it >= 1 && it <= iteration) {
            float row[HD_TRAIN_LOG_COLS] = {0};
            const char *p = end;
            /* columns: total, terms..., disc */
            for (int c = 0; c < HD_TRAIN_LOG_COLS && *p == ','; c++) {
                float v = strtof(p + 1, &end);
                p = end;
                if (c == 0) row[HD_LOSS_TERMS] = v;
                else if (c <= HD_LOSS_TERMS) row[c - 1] = v;
                else row[HD_LOSS_TERMS + 1] = v;
            }
            fprintf(af.f, "%s\n", line);
            if ((s = history_push(h, row)) != HD_OK) break;
        }
        line = next;
    }
    free(data);
    if (s != HD_OK) {
        hd_atomic_abort(&af);
        return s;
    }
    return hd_atomic_commit(&af);
}

static void plot_line(hd_image *img, int x0, int y0, int x1, int y1, const float rgb[3])
{
    int dx = abs(x1 - x0), dy = -abs(y1 - y0), sx = x0 < x1 ? 1 : -1, sy = y0 < y1 ? 1 : -1, err = dx + dy;
    size_t HW = (size_t)img->width * img->height;
    for (;;) {
        if (x0 >= 0 && x0 < img->width && y0 >= 0 && y0 < img->height)
            for (int c = 0; c < 3; c++) img->data[c * HW + (size_t)y0 * img->width + x0] = rgb[c];
        if (x0 == x1 && y0 == y1) break;
        int e2 = 2 * err;
        if (e2 >= dy) {
            err += dy;
            x0 += sx;
        }
        if (e2 <= dx) {
            err += dx;
            y0 += sy;
        }
    }
}

/* The loss curves: log10 of the weighted total (black) and of each unweighted term (colours),
 * averaged over buckets of iterations, on a white 800 x 400 canvas with a grid per decade. */
hd_status hd_train_log_plot(const hd_train_log *h, const char *path)
{
    static const float colours[HD_TRAIN_LOG_COLS][3] = {
        {0.85f, 0.1f, 0.1f}, {0.1f, 0.6f, 0.1f}, {0.1f, 0.3f, 0.9f}, {0.9f, 0.6f, 0.0f}, {0.6f, 0.1f, 0.7f},
        {0.0f, 0.7f, 0.7f},  {0.5f, 0.5f, 0.5f}, {0.9f, 0.4f, 0.7f}, {0.55f, 0.55f, 0.0f},
        {0.0f, 0.0f, 0.0f},  {0.7f, 0.4f, 0.2f}};
    const int Wd = 800, Ht = 400, margin = 10;
    hd_image img = {0};
    hd_status s = hd_image_alloc(&img, Wd, Ht, 3);
    if (s != HD_OK) return s;
    for (size_t i = 0; i < (size_t)3 * Wd * Ht; i++) img.data[i] = 1.0f;
    double lo = 1e30, hi = -1e30;
    for (long i = 0; i < h->n * HD_TRAIN_LOG_COLS; i++) {
        float v = h->v[i];
        if (v > 0 && isfinite(v)) {
            double l = log10(v);
            lo = l < lo ? l : lo;
            hi = l > hi ? l : hi;
        }
    }
    if (h->n >= 1 && lo < hi + 1) {
        lo = floor(lo);
        hi = ceil(hi);
        if (hi <= lo) hi = lo + 1;
        const float grid[3] = {0.85f, 0.85f, 0.85f};
        for (double d = lo; d <= hi; d += 1) {
            int y = margin + (int)((hi - d) / (hi - lo) * (Ht - 2 * margin));
            plot_line(&img, margin, y, Wd - margin, y, grid);
        }
        int cols = Wd - 2 * margin;
        long bucket = h->n / cols + 1;
        for (int c = 0; c < HD_TRAIN_LOG_COLS; c++) {
            int px = -1, py = 0;
            for (long start = 0; start < h->n; start += bucket) {
                double sum = 0;
                long cnt = 0;
                for (long i = start; i < start + bucket && i < h->n; i++) {
                    float v = h->v[(size_t)i * HD_TRAIN_LOG_COLS + c];
                    if (v > 0 && isfinite(v)) {
                        sum += v;
                        cnt++;
                    }
                }
                if (!cnt) continue;
                int x = margin + (int)((double)start / (h->n > 1 ? h->n - 1 : 1) * cols);
                int y = margin + (int)((hi - log10(sum / cnt)) / (hi - lo) * (Ht - 2 * margin));
                if (px >= 0) plot_line(&img, px, py, x, y, colours[c]);
                else plot_line(&img, x, y, x, y, colours[c]);
                px = x;
                py = y;
            }
        }
    }
    s = hd_image_write_png(path, &img, 8);
    hd_image_free(&img);
    return s;
}

hd_status hd_train_log_open(hd_train_log *log, const char *csv_path, int resume, long iteration)
{
    memset(log, 0, sizeof *log);
    hd_status s;
    if (resume) {
        if ((s = csv_restore(csv_path, iteration, log)) != HD_OK) return s;
    } else {
        hd_atomic_file af;
        if ((s = hd_atomic_open(&af, csv_path)) != HD_OK) return s;
        csv_header(af.f);
        if ((s = hd_atomic_commit(&af)) != HD_OK) return s;
    }
    log->csv = hd_open_append(csv_path); /* never through a symlink */
    return log->csv ? HD_OK : HD_ERR_IO;
}

hd_status hd_train_log_add(hd_train_log *log, long iteration, const hd_step_result *r, double seconds)
{
    float row[HD_TRAIN_LOG_COLS];
    for (int k = 0; k < HD_LOSS_TERMS; k++) row[k] = (float)r->terms[k];
    row[HD_LOSS_TERMS] = (float)r->total;
    row[HD_LOSS_TERMS + 1] = (float)r->disc;
    hd_status s = history_push(log, row);
    if (s != HD_OK) return s;
    fprintf(log->csv, "%ld,%.9g", iteration, r->total);
    for (int k = 0; k < HD_LOSS_TERMS; k++) fprintf(log->csv, ",%.9g", r->terms[k]);
    fprintf(log->csv, ",%.9g,%.3f\n", r->disc, seconds);
    fflush(log->csv);
    return HD_OK;
}

void hd_train_log_close(hd_train_log *log)
{
    if (log->csv) fclose(log->csv);
    free(log->v);
    memset(log, 0, sizeof *log);
}

/* A picture of the network's memory (no copy). */
static hd_image view(int size, int channels, const float *data)
{
    hd_image img = {size, size, channels, (float *)data};
    return img;
}

hd_status hd_train_write_samples(const hd_trainer *t, const char *path)
{
    const hd_net *net = &t->net;
    int S = net->H, rows = net->B < 4 ? net->B : 4;
    size_t HW = (size_t)S * S;
    hd_sheet sheet = {0};
    hd_image normal = {0}, recon = {0}, relit = {0};
    float *relit_s = hd_malloc(HW * sizeof(float));
    hd_status s = relit_s ? HD_OK : HD_ERR_NOMEM;
    if (s == HD_OK) s = hd_sheet_init(&sheet, rows, 6, S, 0);
    if (s == HD_OK) s = hd_image_alloc(&normal, S, S, 3);
    if (s == HD_OK) s = hd_image_alloc(&recon, S, S, 3);
    if (s == HD_OK) s = hd_image_alloc(&relit, S, S, 3);
    for (int r = 0; r < rows && s == HD_OK; r++) {
        const float *A = net->albedo + (size_t)r * 3 * HW, *Sh = net->shading + (size_t)r * HW;
        const float *N = net->normal + (size_t)r * 3 * HW, *m = t->chunk.mask + (size_t)r * HW;
        /* relit under the light of its pair partner */
        hd_sh_shading_map(N, NULL, (int)HW, net->light + (size_t)(r ^ 1) * HD_SH_COEFFS, relit_s);
        for (int c = 0; c < 3; c++)
            for (size_t p = 0; p < HW; p++) {
                normal.data[c * HW + p] = m[p] > 0 ? N[c * HW + p] : 0.0f; /* black outside the mask */
                recon.data[c * HW + p] = A[c * HW + p] * Sh[p];
                relit.data[c * HW + p] = A[c * HW + p] * relit_s[p];
            }
        hd_image input = view(S, 3, t->chunk.image + (size_t)r * 3 * HW), albedo = view(S, 3, A), shading = view(S, 1, Sh);
        if (s == HD_OK) s = hd_sheet_put(&sheet, r, 0, &input, HD_SHEET_PICTURE);
        if (s == HD_OK) s = hd_sheet_put(&sheet, r, 1, &albedo, HD_SHEET_PICTURE);
        if (s == HD_OK) s = hd_sheet_put(&sheet, r, 2, &shading, HD_SHEET_SHADING);
        if (s == HD_OK) s = hd_sheet_put(&sheet, r, 3, &normal, HD_SHEET_NORMAL);
        if (s == HD_OK) s = hd_sheet_put(&sheet, r, 4, &recon, HD_SHEET_PICTURE);
        if (s == HD_OK) s = hd_sheet_put(&sheet, r, 5, &relit, HD_SHEET_PICTURE);
    }
    if (s == HD_OK) s = hd_sheet_write(&sheet, path);
    hd_sheet_free(&sheet);
    hd_image_free(&normal);
    hd_image_free(&recon);
    hd_image_free(&relit);
    free(relit_s);
    return s;
}
