/* clip_frames.c: clips as folders of frames (video.h): a folder of PNG, JPEG or PFM pictures read
 * in name order, and a folder of PNG frames written frame000000.png, frame000001.png, ... */
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>
#include "core/core.h"
#include "video/clip_frames.h"

static int is_picture(const char *name)
{
    const char *dot = strrchr(name, '.');
    if (!dot || name[0] == '.') return 0;
    return !strcasecmp(dot, ".png") || !strcasecmp(dot, ".jpg") || !strcasecmp(dot, ".jpeg") || !strcasecmp(dot, ".pfm");
}

static int cmp_names(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

void hd_frame_list_free(hd_frame_list *l)
{
    for (int i = 0; i < l->count; i++) free(l->names[i]);
    free(l->names);
    free(l->dir);
    memset(l, 0, sizeof *l);
}

hd_status hd_frame_list_open(const char *dir, hd_frame_list *l)
{
    memset(l, 0, sizeof *l);
    DIR *d = opendir(dir);
    if (!d) return hd_fail(HD_ERR_IO, "%s: cannot open the folder of frames", dir);
    hd_status st = HD_OK;
    int cap = 0;
    struct dirent *e;
    while ((e = readdir(d)) && st == HD_OK) {
        if (!is_picture(e->d_name)) continue;
        if (l->count == cap) {
            int nc = cap ? 2 * cap : 64;
            char **nn = realloc(l->names, (size_t)nc * sizeof *nn);
            if (!nn) {
                st = HD_ERR_NOMEM;
                break;
            }
            l->names = nn;
            cap = nc;
        }
        if (!(l->names[l->count] = strdup(e->d_name))) st = HD_ERR_NOMEM;
        else l->count++;
    }
    closedir(d);
    if (st == HD_OK && l->count == 0) st = hd_fail(HD_ERR_NOTFOUND, "%s: no frames (PNG, JPEG or PFM files) in the folder", dir);
    if (st == HD_OK && !(l->dir = strdup(dir))) st = HD_ERR_NOMEM;
    if (st != HD_OK) {
        hd_frame_list_free(l);
        return st;
    }
    qsort(l->names, (size_t)l->count, sizeof *l->names, cmp_names);
    return HD_OK;
}

hd_status hd_frame_list_read(hd_frame_list *l, hd_image *frame, int *got)
{
    *got = 0;
    if (l->next >= l->count) return HD_OK;
    char *path = hd_path_join(l->dir, l->names[l->next]);
    if (!path) return HD_ERR_NOMEM;
    hd_status st = hd_image_read_as(path, 3, frame);
    free(path);
    if (st != HD_OK) return st;
    l->next++;
    *got = 1;
    return HD_OK;
}

hd_status hd_frame_folder_create(const char *dir, hd_frame_folder *f)
{
    memset(f, 0, sizeof *f);
    hd_status st = hd_mkdirs(dir);
    if (st != HD_OK) return st;
    if (!(f->dir = strdup(dir))) return HD_ERR_NOMEM;
    return HD_OK;
}

static char *frame_path(const hd_frame_folder *f, long i)
{
    char name[32];
    snprintf(name, sizeof name, "frame%06ld.png", i);
    return hd_path_join(f->dir, name);
}

hd_status hd_frame_folder_write(hd_frame_folder *f, const hd_image *frame)
{
    char *path = frame_path(f, f->written);
    if (!path) return HD_ERR_NOMEM;
    hd_status st = hd_image_write_png(path, frame, 8);
    free(path);
    if (st == HD_OK) f->written++;
    return st;
}

void hd_frame_folder_finish(hd_frame_folder *f, int ok)
{
    if (!ok)
        for (long i = 0; i < f->written; i++) {
            char *path = frame_path(f, i);
            if (path) unlink(path);
            free(path);
        }
    free(f->dir);
    memset(f, 0, sizeof *f);
}
