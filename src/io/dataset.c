/* dataset.c: scanning SPEC section 5 folders into a sorted list of samples with their companions,
 * and reading a camera record's colour gain (NAME.camera.txt). */
#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <errno.h>
#include "core/core.h"
#include "io/dataset.h"

static const char *const companion_suffix[] = {".mask.png",    ".normal.png", ".albedo.png", ".normal_gt.png",
                                               ".shading.png", ".light.txt",  ".camera.txt"};
enum { N_COMPANIONS = 7 };

static int ends_with(const char *s, const char *suffix)
{
    size_t a = strlen(s), b = strlen(suffix);
    return a >= b && strcmp(s + a - b, suffix) == 0;
}

static int is_companion(const char *file)
{
    for (int k = 0; k < N_COMPANIONS; k++)
        if (ends_with(file, companion_suffix[k])) return 1;
    /* other derived files we or other tools write next to images */
    return ends_with(file, ".shading.pfm") || strstr(file, ".") != strrchr(file, '.');
}

static int is_image(const char *file)
{
    if (file[0] == '.' || is_companion(file)) return 0;
    return ends_with(file, ".png") || ends_with(file, ".jpg") || ends_with(file, ".jpeg") ||
           ends_with(file, ".PNG") || ends_with(file, ".JPG") || ends_with(file, ".JPEG");
}

static int cmp_str(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

/* Lists the entries of dir (sorted, without . and ..). */
static hd_status list_dir(const char *dir, char ***names, int *count)
{
    *names = NULL;
    *count = 0;
    DIR *d = opendir(dir);
    if (!d) return hd_fail(HD_ERR_IO, "%s: cannot open folder: %s", dir, strerror(errno));
    int cap = 0, n = 0;
    char **v = NULL;
    struct dirent *e;
    while ((e = readdir(d))) {
        if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0) continue;
        if (n == cap) {
            cap = cap ? cap * 2 : 64;
            char **nv = realloc(v, (size_t)cap * sizeof *v);
            if (!nv) goto nomem;
            v = nv;
        }
        v[n] = strdup(e->d_name);
        if (!v[n]) goto nomem;
        n++;
    }
    closedir(d);
    if (n) qsort(v, (size_t)n, sizeof *v, cmp_str);
    *names = v;
    *count = n;
    return HD_OK;
nomem:
    closedir(d);
    for (int i = 0; i < n; i++) free(v[i]);
    free(v);
    return hd_fail(HD_ERR_NOMEM, "%s: out of memory listing the folder", dir);
}

static void free_names(char **names, int n)
{
    for (int i = 0; i < n; i++) free(names[i]);
    free(names);
}

static int file_exists(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f) return 0;
    fclose(f);
    return 1;
}

/* Adds the images of one subject folder. */
static hd_status scan_subject(hd_dataset *ds, int *cap, const char *subject_dir, const char *subject)
{
    char **names;
    int n;
    hd_status st = list_dir(subject_dir, &names, &n);
    if (st) return st;
    for (int i = 0; i < n && st == HD_OK; i++) {
        if (!is_image(names[i])) continue;
        if (ds->count == *cap) {
            *cap = *cap ? *cap * 2 : 256;
            hd_sample *ns = realloc(ds->samples, (size_t)*cap * sizeof *ns);
            if (!ns) {
                st = hd_fail(HD_ERR_NOMEM, "out of memory scanning %s", subject_dir);
                break;
            }
            ds->samples = ns;
        }
        hd_sample *s = &ds->samples[ds->count];
        memset(s, 0, sizeof *s);
        s->subject = strdup(subject);
        s->image = hd_path_join(subject_dir, names[i]);
        const char *dot = strrchr(names[i], '.');
        s->name = strndup(names[i], (size_t)(dot - names[i]));
        if (!s->subject || !s->image || !s->name) {
            st = hd_fail(HD_ERR_NOMEM, "out of memory scanning %s", subject_dir);
            ds->count++;
            break;
        }
        char **slots[N_COMPANIONS] = {&s->mask, &s->normal, &s->albedo, &s->normal_gt, &s->shading, &s->light, &s->camera};
        for (int k = 0; k < N_COMPANIONS; k++) {
            size_t len = strlen(s->name) + strlen(companion_suffix[k]) + 1;
            char *file = malloc(len);
            if (!file) {
                st = hd_fail(HD_ERR_NOMEM, "out of memory scanning %s", subject_dir);
                break;
            }
            snprintf(file, len, "%s%s", s->name, companion_suffix[k]);
            char *path = hd_path_join(subject_dir, file);
            free(file);
            if (path && file_exists(path)) *slots[k] = path;
            else free(path);
        }
        ds->count++;
    }
    free_names(names, n);
    return st;
}

hd_status hd_dataset_scan(const char *dir, hd_dataset *ds, void (*warn)(const char *message))
{
    (void)warn;
    memset(ds, 0, sizeof *ds);
    char **names;
    int n, cap = 0;
    hd_status st = list_dir(dir, &names, &n);
    if (st) return st;
    /* Images directly in dir form one subject named after the folder. */
    int direct = 0;
    for (int i = 0; i < n; i++) direct += is_image(names[i]);
    if (direct) {
        /* The subject is the folder's own name: "a/b/data/" and "./data" give "data". */
        size_t len = strlen(dir);
        while (len > 1 && dir[len - 1] == '/') len--;
        size_t start = len;
        while (start > 0 && dir[start - 1] != '/') start--;
        char *subject = strndup(dir + start, len - start);
        if (!subject) st = hd_fail(HD_ERR_NOMEM, "out of memory scanning %s", dir);
        else st = scan_subject(ds, &cap, dir, strcmp(subject, ".") == 0 || !*subject ? "images" : subject);
        free(subject);
    }
    for (int i = 0; i < n && st == HD_OK; i++) {
        char *sub = hd_path_join(dir, names[i]);
        if (!sub) {
            st = HD_ERR_NOMEM;
            break;
        }
        if (names[i][0] != '.' && hd_is_dir(sub)) st = scan_subject(ds, &cap, sub, names[i]);
        free(sub);
    }
    free_names(names, n);
    if (st == HD_OK && ds->count == 0) st = hd_fail(HD_ERR_NOTFOUND, "%s: no images found (PNG or JPEG, in subject folders)", dir);
    if (st == HD_OK) {
        ds->subject_start = malloc(((size_t)ds->count + 1) * sizeof *ds->subject_start);
        if (!ds->subject_start) st = hd_fail(HD_ERR_NOMEM, "out of memory scanning %s", dir);
    }
    if (st != HD_OK) {
        hd_dataset_free(ds);
        return st;
    }
    for (int i = 0; i < ds->count; i++)
        if (i == 0 || strcmp(ds->samples[i].subject, ds->samples[i - 1].subject) != 0)
            ds->subject_start[ds->subject_count++] = i;
    ds->subject_start[ds->subject_count] = ds->count;
    return HD_OK;
}

void hd_dataset_free(hd_dataset *ds)
{
    for (int i = 0; i < ds->count; i++) {
        hd_sample *s = &ds->samples[i];
        free(s->subject);
        free(s->name);
        free(s->image);
        free(s->mask);
        free(s->normal);
        free(s->albedo);
        free(s->normal_gt);
        free(s->shading);
        free(s->light);
        free(s->camera);
    }
    free(ds->samples);
    free(ds->subject_start);
    memset(ds, 0, sizeof *ds);
}

long hd_dataset_pair_count(const hd_dataset *ds)
{
    long pairs = 0;
    for (int s = 0; s < ds->subject_count; s++) {
        long k = ds->subject_start[s + 1] - ds->subject_start[s];
        pairs += k * (k - 1) / 2;
    }
    return pairs;
}

/* The effects of a camera record and how many numbers each line holds; colour ones multiply the gain. */
static const struct {
    const char *name;
    int numbers, colour;
} camera_effects[] = {
    {"light_colour", 3, 1}, {"blur_sigma", 1, 0}, {"noise", 2, 0}, {"white_balance", 3, 1}, {"jpeg_quality", 1, 0},
};

hd_status hd_camera_gain_read(const char *path, float gain[3])
{
    char *text = NULL;
    size_t n = 0;
    hd_status st = hd_read_file(path, 1 << 16, &text, &n);
    if (st != HD_OK) return st;
    float g[3] = {1.0f, 1.0f, 1.0f};
    int line = 0;
    for (char *p = text, *next; p && *p && st == HD_OK; p = next) {
        line++;
        next = strchr(p, '\n');
        if (next) *next++ = '\0';
        char word[32];
        int used = 0;
        if (sscanf(p, " %31s%n", word, &used) != 1) continue; /* a blank line */
        int k = 0, K = (int)(sizeof camera_effects / sizeof camera_effects[0]);
        while (k < K && strcmp(word, camera_effects[k].name) != 0) k++;
        if (k == K) {
            st = hd_fail(HD_ERR_FORMAT, "%s:%d: unknown camera effect '%s' (light_colour, blur_sigma, noise, "
                                        "white_balance or jpeg_quality)", path, line, word);
            break;
        }
        double v[4];
        int count = 0, len;
        const char *q = p + used;
        while (count < 4 && sscanf(q, "%lf%n", &v[count], &len) == 1) {
            q += len;
            count++;
        }
        while (*q == ' ' || *q == '\t' || *q == '\r') q++;
        if (count != camera_effects[k].numbers || *q) {
            st = hd_fail(HD_ERR_FORMAT, "%s:%d: %s takes %d number%s", path, line, word, camera_effects[k].numbers,
                         camera_effects[k].numbers == 1 ? "" : "s");
            break;
        }
        if (!camera_effects[k].colour) continue;
        for (int c = 0; c < 3; c++) {
            if (!(isfinite(v[c]) && v[c] > 0.0 && v[c] < 10.0)) {
                st = hd_fail(HD_ERR_FORMAT, "%s:%d: %s gain %g is not in (0, 10)", path, line, word, v[c]);
                break;
            }
            g[c] *= (float)v[c];
        }
    }
    free(text);
    if (st == HD_OK) memcpy(gain, g, sizeof g);
    return st;
}
