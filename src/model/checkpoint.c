/* checkpoint.c: writing and reading models and training checkpoints (safetensors with hdnet
 * metadata), and the public model API of include/hdnet.h: hd_model_load and hd_model_decompose. */
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "model/checkpoint.h"

#define HD_DECOMPOSE_BATCH 4

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
    hd_status st = hd_safetensors_write(path, t, count, keys, values, all.count);
    free(t);
    free(names);
    return st;
}

hd_status hd_checkpoint_meta_long(const hd_safetensors *st, const char *path, const char *key, long long *v)
{
    const char *s = hd_safetensors_meta(st, key);
    if (!s) return hd_fail(HD_ERR_FORMAT, "%s: metadata has no '%s'", path, key);
    char *end;
    errno = 0;
    long long x = strtoll(s, &end, 10);
    if (end == s || *end || errno) return hd_fail(HD_ERR_FORMAT, "%s: metadata '%s' is not an integer: '%s'", path, key, s);
    *v = x;
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

/* ---------------------------------------------------------------- the public model API */

struct hd_model {
    hd_net_config cfg;
    hd_param_table table;
    float *params;
    hd_net net; /* made at the first decompose */
    int have_net;
};

hd_status hd_model_load(const char *path, hd_model **model)
{
    *model = NULL;
    char *found = NULL;
    if (!path) {
        found = hd_find_data("hdnet-synth.safetensors");
        if (!found) {
            char why[400];
            snprintf(why, sizeof why, "%s", hd_error());
            return hd_fail(HD_ERR_NOTFOUND, "no model given and the default model is not installed: %s", why);
        }
        path = found;
    }
    hd_safetensors st = {0};
    hd_status s = hd_safetensors_read(path, &st);
    hd_model *m = NULL;
    if (s != HD_OK) goto done;
    m = hd_calloc(1, sizeof *m);
    if (!m) {
        s = HD_ERR_NOMEM;
        goto done;
    }
    if ((s = hd_checkpoint_config(&st, path, &m->cfg)) != HD_OK) goto done;
    hd_net_param_table(&m->cfg, &m->table);
    m->params = hd_calloc(m->table.total, sizeof(float));
    if (!m->params) {
        s = HD_ERR_NOMEM;
        goto done;
    }
    hd_tensor_group g = {&m->table, "", m->params};
    s = hd_checkpoint_take(&st, path, &g);
done:
    hd_safetensors_free(&st);
    free(found);
    if (s != HD_OK) {
        hd_model_free(m);
        return s;
    }
    *model = m;
    return HD_OK;
}

void hd_model_free(hd_model *model)
{
    if (!model) return;
    if (model->have_net) hd_net_free(&model->net);
    free(model->params);
    free(model);
}

int hd_model_size(const hd_model *model) { return model->cfg.size; }
int hd_model_width(const hd_model *model) { return model->cfg.width; }

void hd_decomposition_free(hd_decomposition *d)
{
    if (!d) return;
    hd_image_free(&d->albedo);
    hd_image_free(&d->shading);
    hd_image_free(&d->normal);
    hd_image_free(&d->reconstruction);
    memset(d, 0, sizeof *d);
}

/* Puts image img, as 3 channels at the model size, into slot dst (3, size, size). */
static hd_status load_input(const hd_image *img, int size, float *dst, int index)
{
    if (!img || !img->data || img->width < 1 || img->height < 1 || img->channels < 1 || img->channels > 4)
        return hd_fail(HD_ERR_ARG, "image %d to decompose is empty or has %d channels", index, img ? img->channels : 0);
    hd_image rgb = {0}, sized = {0};
    const hd_image *cur = img;
    hd_status s = HD_OK;
    if (cur->channels != 3) {
        if ((s = hd_image_convert(cur, 3, &rgb)) != HD_OK) return s;
        cur = &rgb;
    }
    if (cur->width != size || cur->height != size) {
        if ((s = hd_image_resize(cur, size, size, &sized)) != HD_OK) goto done;
        cur = &sized;
    }
    memcpy(dst, cur->data, (size_t)3 * size * size * sizeof(float));
done:
    hd_image_free(&rgb);
    hd_image_free(&sized);
    return s;
}

hd_status hd_model_decompose(hd_model *model, const hd_image *images, int count, hd_decomposition *out)
{
    if (!model || (count > 0 && (!images || !out))) return hd_fail(HD_ERR_ARG, "hd_model_decompose: missing argument");
    if (count <= 0) return HD_OK;
    for (int i = 0; i < count; i++) memset(&out[i], 0, sizeof out[i]);
    hd_status s;
    if (!model->have_net) {
        int B = count < HD_DECOMPOSE_BATCH ? count : HD_DECOMPOSE_BATCH;
        if ((s = hd_net_create(&model->net, &model->cfg, B, HD_NET_INFER, HD_CONV_AUTO)) != HD_OK) return s;
        memcpy(model->net.params, model->params, model->table.total * sizeof(float));
        model->have_net = 1;
    }
    hd_net *net = &model->net;
    int size = model->cfg.size;
    size_t HW = (size_t)size * size;
    for (int first = 0; first < count; first += net->B) {
        int n = count - first < net->B ? count - first : net->B;
        memset(net->input, 0, (size_t)net->B * 3 * HW * sizeof(float));
        for (int k = 0; k < n; k++)
            if ((s = load_input(&images[first + k], size, net->input + (size_t)k * 3 * HW, first + k)) != HD_OK) goto fail;
        hd_net_forward(net);
        for (int k = 0; k < n; k++) {
            hd_decomposition *d = &out[first + k];
            if ((s = hd_image_alloc(&d->albedo, size, size, 3)) != HD_OK ||
                (s = hd_image_alloc(&d->shading, size, size, 1)) != HD_OK ||
                (s = hd_image_alloc(&d->normal, size, size, 3)) != HD_OK ||
                (s = hd_image_alloc(&d->reconstruction, size, size, 3)) != HD_OK)
                goto fail;
            memcpy(d->albedo.data, net->albedo + (size_t)k * 3 * HW, 3 * HW * sizeof(float));
            memcpy(d->shading.data, net->shading + (size_t)k * HW, HW * sizeof(float));
            memcpy(d->normal.data, net->normal + (size_t)k * 3 * HW, 3 * HW * sizeof(float));
            for (int c = 0; c < 3; c++)
                for (size_t p = 0; p < HW; p++)
                    d->reconstruction.data[c * HW + p] = d->albedo.data[c * HW + p] * d->shading.data[p];
            memcpy(d->light, net->light + (size_t)k * HD_SH_COEFFS, sizeof d->light);
        }
    }
    return HD_OK;
fail:
    for (int i = 0; i < count; i++) hd_decomposition_free(&out[i]);
    return s;
}
