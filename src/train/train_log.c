/* train_log.c: the training log (train_log.h): loss.csv (one row per iteration, kept up to the
 * checkpoint's iteration on resume), the history of every row, the loss curves as a PNG line plot,
 * and the sample sheet of the last forward (on the contact sheets of io/sheet.c). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "train/train_log.h"
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

/* The columns of loss.csv: iteration, total, the terms, disc, seconds. */
#define CSV_COLS (HD_LOSS_TERMS + 4)

/* The column named name in today's loss.csv, or -1. */
static int csv_column(const char *name)
{
    if (strcmp(name, "iteration") == 0) return 0;
    if (strcmp(name, "total") == 0) return 1;
    for (int k = 0; k < HD_LOSS_TERMS; k++)
        if (strcmp(name, hd_loss_names[k]) == 0) return 2 + k;
    if (strcmp(name, "disc") == 0) return HD_LOSS_TERMS + 2;
    if (strcmp(name, "seconds") == 0) return HD_LOSS_TERMS + 3;
    return -1;
}

/* Splits line at its commas in place into at most max fields; returns how many. */
static int csv_fields(char *line, char **field, int max)
{
    int n = 0;
    while (line && n < max) {
        char *comma = strchr(line, ',');
        if (comma) *comma = '\0';
        field[n++] = line;
        line = comma ? comma + 1 : NULL;
    }
    return n;
}

/* Rewrites loss.csv keeping rows up to `iteration` (a resumed run continues from its checkpoint)
 * and loads them into the history. The columns are matched by the old file's header, so a run
 * from before a term was added resumes into today's columns (the new term's old rows read 0). */
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
    int map[4 * CSV_COLS], nmap = 0; /* old column -> today's (-1: dropped) */
    char *field[4 * CSV_COLS];
    char *line = data;
    if (line) { /* the header */
        char *next = strchr(line, '\n');
        if (next) *next = '\0';
        nmap = csv_fields(line, field, 4 * CSV_COLS);
        for (int c = 0; c < nmap; c++) map[c] = csv_column(field[c]);
        line = next ? next + 1 : NULL;
    }
    while (line && *line) {
        char *next = strchr(line, '\n');
        if (next) *next = '\0';
        const char *tok[CSV_COLS] = {0};
        int n = csv_fields(line, field, nmap);
        for (int c = 0; c < n; c++)
            if (map[c] >= 0) tok[map[c]] = field[c];
        char *end = NULL;
        long it = tok[0] ? strtol(tok[0], &end, 10) : 0;
        if (tok[0] && end != tok[0] && it >= 1 && it <= iteration) {
            float row[HD_TRAIN_LOG_COLS] = {0};
            fprintf(af.f, "%ld", it);
            for (int c = 1; c < CSV_COLS; c++) {
                const char *v = tok[c] && *tok[c] ? tok[c] : "0";
                fprintf(af.f, ",%s", v);
                float x = strtof(v, NULL);
                if (c == 1) row[HD_LOSS_TERMS] = x; /* total */
                else if (c < HD_LOSS_TERMS + 2) row[c - 2] = x;
                else if (c == HD_LOSS_TERMS + 2) row[HD_LOSS_TERMS + 1] = x; /* disc */
            }
            fprintf(af.f, "\n");
            if ((s = history_push(h, row)) != HD_OK) break;
        }
        line = next ? next + 1 : NULL;
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

/* A 3 x 5 pixel font (drawn at 2x) for the plot's labels: digits, a few signs, capitals. Each
 * glyph is five rows of three bits, the left pixel in bit 2. */
static const unsigned char *glyph(char ch)
{
    static const struct { char c; unsigned char rows[5]; } font[] = {
        {'0', {7, 5, 5, 5, 7}}, {'1', {2, 6, 2, 2, 7}}, {'2', {7, 1, 7, 4, 7}}, {'3', {7, 1, 7, 1, 7}},
        {'4', {5, 5, 7, 1, 1}}, {'5', {7, 4, 7, 1, 7}}, {'6', {7, 4, 7, 5, 7}}, {'7', {7, 1, 1, 1, 1}},
        {'8', {7, 5, 7, 5, 7}}, {'9', {7, 5, 7, 1, 7}}, {'-', {0, 0, 7, 0, 0}}, {'.', {0, 0, 0, 0, 2}},
        {'_', {0, 0, 0, 0, 7}}, {'(', {1, 2, 2, 2, 1}}, {')', {4, 2, 2, 2, 4}}, {'A', {2, 5, 7, 5, 5}},
        {'B', {6, 5, 6, 5, 6}}, {'C', {7, 4, 4, 4, 7}}, {'D', {6, 5, 5, 5, 6}}, {'E', {7, 4, 6, 4, 7}},
        {'G', {7, 4, 5, 5, 7}}, {'H', {5, 5, 7, 5, 5}}, {'I', {7, 2, 2, 2, 7}}, {'L', {4, 4, 4, 4, 7}},
        {'M', {5, 7, 7, 5, 5}}, {'N', {6, 5, 5, 5, 5}}, {'O', {7, 5, 5, 5, 7}}, {'R', {6, 5, 6, 5, 5}},
        {'S', {7, 4, 7, 1, 7}}, {'T', {7, 2, 2, 2, 2}}, {'V', {5, 5, 5, 5, 2}}, {'W', {5, 5, 7, 7, 5}},
        {'X', {5, 5, 2, 5, 5}}, {'Y', {5, 5, 2, 2, 2}}, {':', {0, 2, 0, 2, 0}},
        {'F', {7, 4, 6, 4, 4}}, {'K', {5, 5, 6, 5, 5}}, {'P', {6, 5, 6, 4, 4}}, {'U', {5, 5, 5, 5, 7}}};
    if (ch >= 'a' && ch <= 'z') ch = (char)(ch - 'a' + 'A');
    for (size_t i = 0; i < sizeof font / sizeof font[0]; i++)
        if (font[i].c == ch) return font[i].rows;
    return NULL; /* a space, or a character the font lacks: left blank */
}

enum { GLYPH_SCALE = 2, GLYPH_ADVANCE = 4 * GLYPH_SCALE };

static void plot_text(hd_image *img, int x, int y, const char *text, const float rgb[3])
{
    size_t HW = (size_t)img->width * img->height;
    for (; *text; text++, x += GLYPH_ADVANCE) {
        const unsigned char *g = glyph(*text);
        if (!g) continue;
        for (int r = 0; r < 5 * GLYPH_SCALE; r++)
            for (int c = 0; c < 3 * GLYPH_SCALE; c++) {
                int px = x + c, py = y + r;
                if (!(g[r / GLYPH_SCALE] >> (2 - c / GLYPH_SCALE) & 1)) continue;
                if (px < 0 || px >= img->width || py < 0 || py >= img->height) continue;
                for (int k = 0; k < 3; k++) img->data[k * HW + (size_t)py * img->width + px] = rgb[k];
            }
    }
}

/* The loss curves: log10 of the weighted total (black) and of each unweighted term (colours),
 * averaged over buckets of iterations, on a white 900 x 460 canvas with a grid per decade, the
 * decades labelled on the y axis (1E-2 = 0.01), iterations on the x axis, and a legend on top. */
hd_status hd_train_log_plot(const hd_train_log *h, const char *path)
{
    /* one colour per term in hd_loss_names order, then the total (black) and disc (brown) */
    static const float colours[][3] = {
        {0.85f, 0.1f, 0.1f}, {0.1f, 0.6f, 0.1f}, {0.1f, 0.3f, 0.9f}, {0.9f, 0.6f, 0.0f}, {0.6f, 0.1f, 0.7f},
        {0.0f, 0.7f, 0.7f},  {0.5f, 0.5f, 0.5f}, {0.9f, 0.4f, 0.7f}, {0.55f, 0.55f, 0.0f}, {0.45f, 0.85f, 0.2f},
        {0.3f, 0.3f, 0.55f}, {0.95f, 0.3f, 0.0f}, {0.0f, 0.0f, 0.0f},  {0.7f, 0.4f, 0.2f}};
    _Static_assert(sizeof colours / sizeof colours[0] == HD_TRAIN_LOG_COLS, "one plot colour per loss column");
    const float ink[3] = {0.2f, 0.2f, 0.2f}, grid[3] = {0.85f, 0.85f, 0.85f};
    /* the plot area [left, Wd - right] x [top, Ht - bottom] */
    const int Wd = 900, Ht = 478, left = 64, right = 12, top = 66, bottom = 40;
    const int pw = Wd - left - right, ph = Ht - top - bottom;
    hd_image img = {0};
    hd_status s = hd_image_alloc(&img, Wd, Ht, 3);
    if (s != HD_OK) return s;
    for (size_t i = 0; i < (size_t)3 * Wd * Ht; i++) img.data[i] = 1.0f;
    /* legend: a swatch and the name of each curve, six to a row */
    for (int c = 0; c < HD_TRAIN_LOG_COLS; c++) {
        const char *name = c < HD_LOSS_TERMS ? hd_loss_names[c] : c == HD_LOSS_TERMS ? "total" : "disc";
        int x = 8 + (c % 6) * 148, y = 6 + (c / 6) * 18;
        for (int d = 0; d < 3; d++) plot_line(&img, x, y + 4 + d, x + 16, y + 4 + d, colours[c]);
        plot_text(&img, x + 22, y, name, colours[c]);
    }
    plot_text(&img, 4, Ht - 14, "Y: LOG10 OF THE LOSS    X: ITERATION", ink);
    double lo = 1e30, hi = -1e30;
    for (long i = 0; i < h->n * HD_TRAIN_LOG_COLS; i++) {
        float v = h->v[i];
        if (v > 0 && isfinite(v)) {
            double l = log10(v);
            lo = l < lo ? l : lo;
            hi = l > hi ? l : hi;
        }
    }
    plot_line(&img, left, top, left, top + ph, ink);
    plot_line(&img, left, top + ph, left + pw, top + ph, ink);
    if (h->n >= 1 && lo < hi + 1) {
        lo = floor(lo);
        hi = ceil(hi);
        if (hi <= lo) hi = lo + 1;
        char label[32];
        for (double d = lo; d <= hi; d += 1) {
            int y = top + (int)((hi - d) / (hi - lo) * ph);
            plot_line(&img, left + 1, y, left + pw, y, grid);
            snprintf(label, sizeof label, "1E%d", (int)d);
            plot_text(&img, left - 6 - GLYPH_ADVANCE * (int)strlen(label), y - 5, label, ink);
        }
        /* x: iterations 1 .. n (one row per iteration), five ticks */
        for (int k = 0; k <= 4; k++) {
            long it = 1 + (long)((double)(h->n - 1) * k / 4 + 0.5);
            int x = left + (int)((double)(it - 1) / (h->n > 1 ? h->n - 1 : 1) * pw);
            plot_line(&img, x, top + ph, x, top + ph + 4, ink);
            snprintf(label, sizeof label, "%ld", it);
            int w = GLYPH_ADVANCE * (int)strlen(label);
            int tx = x - w / 2;
            if (tx + w > Wd) tx = Wd - w;
            plot_text(&img, tx, top + ph + 8, label, ink);
            if (h->n == 1) break;
        }
        long bucket = h->n / pw + 1;
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
                int x = left + (int)((double)start / (h->n > 1 ? h->n - 1 : 1) * pw);
                int y = top + (int)((hi - log10(sum / cnt)) / (hi - lo) * ph);
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
