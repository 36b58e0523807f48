/* model.c: the public inference API of include/hdnet.h: hd_model_load (a model file, or the
 * installed default) and hd_model_decompose (albedo, shading, normals, light and reconstruction of
 * images at the model's size, in batches through one network made at the first call). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "model/checkpoint.h"

#define HD_DECOMPOSE_BATCH 4

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
