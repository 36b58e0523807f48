/* error.c: the thread-local failure reason behind hd_error() (control bytes of input quoted in it
 * are escaped as \xNN, so a reason never drives the terminal), and the library-wide thread count. */
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <omp.h>
#include "core/core.h"

static _Thread_local char error_text[1024];

hd_status hd_fail(hd_status code, const char *fmt, ...)
{
    /* Formatted into a local buffer first: callers may pass hd_error() itself as an argument. */
    char text[sizeof error_text];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    hd_escape_into(error_text, sizeof error_text, text);
    return code;
}

void hd_escape_into(char *dst, size_t size, const char *src)
{
    static const char hex[] = "0123456789abcdef";
    size_t k = 0;
    if (size == 0) return;
    for (const unsigned char *s = (const unsigned char *)src; *s; s++) {
        int control = *s < 0x20 || *s == 0x7f;
        size_t need = control ? 4 : 1;
        if (k + need >= size) break;
        if (control) {
            dst[k++] = '\\';
            dst[k++] = 'x';
            dst[k++] = hex[*s >> 4];
            dst[k++] = hex[*s & 15];
        } else {
            dst[k++] = (char)*s;
        }
    }
    dst[k] = '\0';
}

void hd_clear_error(void) { error_text[0] = '\0'; }

const char *hd_error(void) { return error_text; }

const char *hd_status_name(hd_status status)
{
    switch (status) {
    case HD_OK: return "ok";
    case HD_ERR_IO: return "i/o error";
    case HD_ERR_FORMAT: return "format error";
    case HD_ERR_RANGE: return "out of range";
    case HD_ERR_NOMEM: return "out of memory";
    case HD_ERR_ARG: return "invalid argument";
    case HD_ERR_NUMERIC: return "not a finite number";
    case HD_ERR_INTERRUPTED: return "interrupted";
    case HD_ERR_NOTFOUND: return "not found";
    }
    return "unknown status";
}

/* The count set by hd_set_threads, for every thread: OpenMP's own setting is per thread, so the
 * entry points that run parallel loops apply this one on the thread that calls them. */
static _Atomic int library_threads;

void hd_set_threads(int threads)
{
    if (threads > 0) {
        library_threads = threads;
        omp_set_num_threads(threads);
    }
}

void hd_apply_threads(void)
{
    int n = library_threads;
    if (n > 0 && omp_get_max_threads() != n) omp_set_num_threads(n);
}

int hd_threads(void) { return omp_get_max_threads(); }
