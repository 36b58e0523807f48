/* checkpoint.c: the checkpoint format (SPEC section 6): tensor groups written and read under
 * their names, the hdnet metadata (format, version, configuration) and its one number parser,
 * and inference models (hd_model_write). */
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "model/checkpoint.h"
#include "io/safetensors.h"

void hd_meta_set(hd_meta *m, const char *key, const char *fmt, ...)
{
    int i = 0;
    while (i < m->count && strcmp(m->keys[i], key) != 0) i++;
    if (i == HD_CHECKPOINT_MAX_META) return;
    if (i == m->count) m->count++;
    snprintf(m->keys[i], sizeof m->keys[i], "%s", key);
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(m->values[i], sizeof m->values[i], fmt, ap);
    va_end(ap);
}

hd_status hd_checkpoint_write_tensors(const char *path, const hd_net_config *cfg, const hd_tensor *tensors, int count,
                                      const hd_meta *meta)
{
    hd_meta all = {0};
    hd_meta_set(&all, "format", "hdnet");
    hd_meta_set(&all, "format_version", "%d", HD_NET_FORMAT_VERSION);
    hd_meta_set(&all, "width", "%d", cfg->width);
    hd_meta_set(&all, "size", "%d", cfg->size);
    if (meta)
        for (int i = 0; i < meta->count; i++) hd_meta_set(&all, meta->keys[i], "%s", meta->values[i]);
    const char *keys[HD_CHECKPOINT_MAX_META], *values[HD_CHECKPOINT_MAX_META];
    for (int i = 0; i < all.count; i++) {
        keys[i] = all.keys[i];
        values[i] = all.values[i];
    }
    return hd_safetensors_write(path, tensors, count, keys, values, all.count);
}

hd_status hd_checkpoint_write(const char *path, const hd_net_config *cfg, const hd_tensor_group *groups, int ngroups,
                              const hd_meta *meta)
{
    int count = 0;
    for (int g = 0; g < ngroups; g++) count += groups[g].table->count;
    hd_tensor *t = hd_calloc((size_t)count + 1, sizeof *t);
    char (*names)[128] = hd_calloc((size_t)count + 1, sizeof *names);
    if (!t || !names) {
        free(t);
        free(names);
        return HD_ERR_NOMEM;
    }
    int n = 0;
    for (int g = 0; g < ngroups; g++) {
        const hd_param_table *tab = groups[g].table;
        for (int i = 0; i < tab->count; i++, n++) {
            snprintf(names[n], sizeof names[n], "%s%s", groups[g].prefix, tab->p[i].name);
            t[n].name = names[n];
            t[n].ndim = tab->p[i].ndim;
            for (int d = 0; d < t[n].ndim; d++) t[n].shape[d] = tab->p[i].shape[d];
            t[n].data = groups[g].data + tab->p[i].offset;
        }
    }
    hd_status st = hd_checkpoint_write_tensors(path, cfg, t, count, meta);
    free(t);
    free(names);
    return st;
}

/* The one metadata number parser: an optional '-' and decimal digits, nothing else. */
static hd_status meta_number(const hd_safetensors *st, const char *path, const char *key, int *negative,
                             unsigned long long *magnitude)
{
    const char *s = hd_safetensors_meta(st, key);
    if (!s) return hd_fail(HD_ERR_FORMAT, "%s: metadata has no '%s'", path, key);
    const char *digits = s + (*s == '-');
    char *end;
    errno = 0;
    unsigned long long x = strtoull(digits, &end, 10);
    if (*digits < '0' || *digits > '9' || *end || errno)
        return hd_fail(HD_ERR_FORMAT, "%s: metadata '%s' is not an integer: '%s'", path, key, s);
    *negative = *s == '-' && x != 0;
    *magnitude = x;
    return HD_OK;
}

hd_status hd_checkpoint_meta_long(const hd_safetensors *st, const char *path, const char *key, long long *v)
{
    int neg;
    unsigned long long x;
    hd_status s = meta_number(st, path, key, &neg, &x);
    if (s != HD_OK) return s;
    if (x > (unsigned long long)LLONG_MAX + (unsigned long long)neg)
        return hd_fail(HD_ERR_FORMAT, "%s: metadata '%s' is out of range: '%s'", path, key, hd_safetensors_meta(st, key));
    *v = neg ? (long long)(0 - x) : (long long)x;
    return HD_OK;
}

hd_status hd_checkpoint_meta_u64(const hd_safetensors *st, const char *path, const char *key, uint64_t *v)
{
    int neg;
    unsigned long long x;
    hd_status s = meta_number(st, path, key, &neg, &x);
    if (s != HD_OK) return s;
    if (neg) return hd_fail(HD_ERR_FORMAT, "%s: metadata '%s' is negative: '%s'", path, key, hd_safetensors_meta(st, key));
    *v = (uint64_t)x;
    return HD_OK;
}

hd_status hd_checkpoint_config(const hd_safetensors *st, const char *path, hd_net_config *cfg)
{
    const char *format = hd_safetensors_meta(st, "format");
    if (!format || strcmp(format, "hdnet") != 0)
        return hd_fail(HD_ERR_FORMAT, "%s: not an hdnet model (metadata 'format' is %s%s%s)", path, format ? "'" : "",
                       format ? format : "missing", format ? "'" : "");
    long long version, width, size;
    hd_status s;
    if ((s = hd_checkpoint_meta_long(st, path, "format_version", &version)) != HD_OK) return s;
    if (version < 1 || version > HD_NET_FORMAT_VERSION)
        return hd_fail(HD_ERR_FORMAT, "%s: format version %lld is not supported (this hdnet reads up to %d)", path,
                       version, HD_NET_FORMAT_VERSION);
    if ((s = hd_checkpoint_meta_long(st, path, "width", &width)) != HD_OK) return s;
    if ((s = hd_checkpoint_meta_long(st, path, "size", &size)) != HD_OK) return s;
    if (width < 1 || width > 1024 || size < 32 || size > 4096 || size % 32)
        return hd_fail(HD_ERR_FORMAT, "%s: configuration width %lld, size %lld is invalid", path, width, size);
    cfg->width = (int)width;
    cfg->size = (int)size;
    return HD_OK;
}

hd_status hd_checkpoint_take(const hd_safetensors *st, const char *path, const hd_tensor_group *g)
{
    char name[160];
    for (int i = 0; i < g->table->count; i++) {
        const hd_param *p = &g->table->p[i];
        snprintf(name, sizeof name, "%s%s", g->prefix, p->name);
        const hd_tensor *t = hd_safetensors_find(st, name);
        if (!t) return hd_fail(HD_ERR_FORMAT, "%s: tensor '%s' is missing", path, name);
        int ok = t->ndim == p->ndim;
        for (int d = 0; ok && d < p->ndim; d++) ok = t->shape[d] == p->shape[d];
        if (!ok) {
            char want[64] = "", got[64] = "";
            for (int d = 0; d < p->ndim; d++)
                snprintf(want + strlen(want), sizeof want - strlen(want), "%s%lld", d ? "," : "", (long long)p->shape[d]);
            for (int d = 0; d < t->ndim && d < HD_TENSOR_MAX_DIMS; d++)
                snprintf(got + strlen(got), sizeof got - strlen(got), "%s%lld", d ? "," : "", (long long)t->shape[d]);
            return hd_fail(HD_ERR_FORMAT, "%s: tensor '%s' has shape [%s], expected [%s]", path, name, got, want);
        }
        for (size_t k = 0; k < p->count; k++)
            if (!isfinite(t->data[k]))
                return hd_fail(HD_ERR_NUMERIC, "%s: tensor '%s' holds a NaN or infinity at index %zu", path, name, k);
        memcpy(g->data + p->offset, t->data, p->count * sizeof(float));
    }
    return HD_OK;
}

hd_status hd_model_write(const char *path, const hd_net_config *cfg, const float *params, long iteration, int stage)
{
    hd_param_table t;
    hd_net_param_table(cfg, &t);
    hd_tensor_group g = {&t, "", (float *)params};
    hd_meta m = {0};
    hd_meta_set(&m, "kind", "model");
    hd_meta_set(&m, "iteration", "%ld", iteration);
    hd_meta_set(&m, "stage", "%d", stage);
    return hd_checkpoint_write(path, cfg, &g, 1, &m);
}
