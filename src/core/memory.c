/* memory.c: checked size arithmetic, reporting allocators and the arena. */
#include <stdlib.h>
#include <string.h>
#include "core/core.h"

int hd_mul_size(size_t a, size_t b, size_t *out)
{
    if (a != 0 && b > SIZE_MAX / a) return 0;
    *out = a * b;
    return 1;
}

int hd_mul3_size(size_t a, size_t b, size_t c, size_t *out)
{
    size_t ab;
    return hd_mul_size(a, b, &ab) && hd_mul_size(ab, c, out);
}

void *hd_malloc(size_t bytes)
{
    void *p = malloc(bytes ? bytes : 1);
    if (!p) hd_fail(HD_ERR_NOMEM, "out of memory allocating %zu bytes", bytes);
    return p;
}

void *hd_calloc(size_t count, size_t size)
{
    void *p = calloc(count ? count : 1, size ? size : 1);
    if (!p) hd_fail(HD_ERR_NOMEM, "out of memory allocating %zu x %zu bytes", count, size);
    return p;
}

hd_status hd_arena_init(hd_arena *a, size_t bytes)
{
    a->used = 0;
    a->size = (bytes + 63) & ~(size_t)63;
    a->base = aligned_alloc(64, a->size ? a->size : 64);
    if (!a->base) {
        a->size = 0;
        return hd_fail(HD_ERR_NOMEM, "out of memory allocating an arena of %zu bytes", bytes);
    }
    return HD_OK;
}

float *hd_arena_floats(hd_arena *a, size_t count)
{
    size_t bytes;
    if (!hd_mul_size(count, sizeof(float), &bytes) || bytes > SIZE_MAX - 63) {
        hd_fail(HD_ERR_RANGE, "arena request of %zu floats overflows", count);
        return NULL;
    }
    bytes = (bytes + 63) & ~(size_t)63;
    if (bytes > a->size - a->used) {
        hd_fail(HD_ERR_NOMEM, "arena full: %zu bytes requested, %zu of %zu left", bytes,
                a->size - a->used, a->size);
        return NULL;
    }
    float *p = (float *)(a->base + a->used);
    a->used += bytes;
    return p;
}

void hd_arena_reset(hd_arena *a) { a->used = 0; }

void hd_arena_free(hd_arena *a)
{
    free(a->base);
    a->base = NULL;
    a->size = a->used = 0;
}
