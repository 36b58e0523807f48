/* files.c: whole-file reads and path helpers (atomic writes: atomic.c). */
#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include "core/core.h"

char *hd_strdup(const char *s)
{
    size_t n = strlen(s) + 1;
    char *d = hd_malloc(n);
    if (d) memcpy(d, s, n);
    return d;
}

hd_status hd_read_file(const char *path, size_t max_bytes, char **data, size_t *size)
{
    *data = NULL;
    *size = 0;
    FILE *f = fopen(path, "rb");
    if (!f) return hd_fail(HD_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    size_t cap = max_bytes < 4096 ? max_bytes : 4096, len = 0;
    char *buf = hd_malloc(cap + 1);
    if (!buf) {
        fclose(f);
        return HD_ERR_NOMEM;
    }
    for (;;) {
        if (len == cap) {
            if (cap >= max_bytes) {
                if (fgetc(f) == EOF) break;
                free(buf);
                fclose(f);
                return hd_fail(HD_ERR_RANGE, "%s: larger than %zu bytes", path, max_bytes);
            }
            size_t ncap = cap * 2 > max_bytes ? max_bytes : cap * 2;
            char *nb = realloc(buf, ncap + 1);
            if (!nb) {
                free(buf);
                fclose(f);
                return hd_fail(HD_ERR_NOMEM, "%s: out of memory reading", path);
            }
            buf = nb;
            cap = ncap;
        }
        size_t got = fread(buf + len, 1, cap - len, f);
        len += got;
        if (got == 0) break;
    }
    int bad = ferror(f);
    fclose(f);
    if (bad) {
        free(buf);
        return hd_fail(HD_ERR_IO, "%s: read error", path);
    }
    buf[len] = '\0';
    *data = buf;
    *size = len;
    return HD_OK;
}

char *hd_path_join(const char *dir, const char *name)
{
    size_t a = strlen(dir), b = strlen(name);
    char *p = hd_malloc(a + b + 2);
    if (!p) return NULL;
    memcpy(p, dir, a);
    size_t k = a;
    if (a > 0 && dir[a - 1] != '/') p[k++] = '/';
    memcpy(p + k, name, b + 1);
    return p;
}

/* Where the extension of the last path component starts (its length when it has none). */
static size_t stem_end(const char *path)
{
    const char *slash = strrchr(path, '/');
    const char *base = slash ? slash + 1 : path;
    const char *dot = strrchr(base, '.');
    return dot && dot != base ? (size_t)(dot - path) : strlen(path);
}

char *hd_path_stem(const char *path)
{
    const char *slash = strrchr(path, '/');
    size_t start = slash ? (size_t)(slash + 1 - path) : 0, n = stem_end(path) - start;
    char *s = hd_malloc(n + 1);
    if (s) {
        memcpy(s, path + start, n);
        s[n] = '\0';
    }
    return s;
}

char *hd_path_companion(const char *path, const char *suffix)
{
    size_t stem = stem_end(path), n = strlen(suffix) + 1;
    char *p = hd_malloc(stem + n);
    if (p) {
        memcpy(p, path, stem);
        memcpy(p + stem, suffix, n);
    }
    return p;
}

int hd_is_dir(const char *path)
{
    struct stat sb;
    return stat(path, &sb) == 0 && S_ISDIR(sb.st_mode);
}

hd_status hd_mkdirs(const char *path)
{
    char *p = hd_strdup(path);
    if (!p) return HD_ERR_NOMEM;
    for (char *s = p + 1;; s++) {
        if (*s == '/' || *s == '\0') {
            char c = *s;
            *s = '\0';
            if (mkdir(p, 0777) != 0 && errno != EEXIST) {
                hd_note_write_errno(errno);
                hd_status st = hd_fail(HD_ERR_IO, "%s: cannot create directory: %s", p, strerror(errno));
                free(p);
                return st;
            }
            *s = c;
            if (c == '\0') break;
        }
    }
    int ok = hd_is_dir(path);
    free(p);
    return ok ? HD_OK : hd_fail(HD_ERR_IO, "%s: exists and is not a directory", path);
}
