/* model.c: the public model of include/hdnet.h: hd_model_load, hd_model_decompose. A model is its
 * configuration and weights, read-only once loaded, and a pool of run states (hd_net over the
 * model's weights, made by hd_net_create_run): each decompose call takes an idle run state of its
 * batch size from the pool, or makes one, and puts it back when done. So any number of threads may
 * decompose with one model at once; each gets activations of its own, and a call's results depend
 * only on its inputs (the batch size follows the call, not the pool). */
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include "model/checkpoint.h"
#include "model/white_balance.h"
#include "model/model_probe.h"

#define HD_DECOMPOSE_BATCH 4

/* An idle run state in the pool, for batches of net.B images. */
typedef struct run_state {
    hd_net net;
    struct run_state *next;
} run_state;

struct hd_model {
    hd_net_config cfg;
    hd_param_table table;
    float *params; /* the weights: written by hd_model_load only */
    pthread_mutex_t lock; /* guards idle and eyes */
    run_state *idle[HD_DECOMPOSE_BATCH + 1]; /* idle run states by batch size */
    hd_white_balance white_balance; /* hd_model_set_white_balance's; HD_WHITE_BALANCE_OFF from hd_model_load */
    hd_background background;       /* hd_model_set_background's; HD_BACKGROUND_KEEP from hd_model_load */
    hd_shadows shadows;             /* hd_model_set_shadows'; HD_SHADOWS_CAST from hd_model_load */
    hd_image eyes; /* the eye openings at the model size (hd_eyes_uv), made by the first call that needs them */
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
    pthread_mutex_init(&m->lock, NULL);
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
    for (int b = 0; b <= HD_DECOMPOSE_BATCH; b++)
        while (model->idle[b]) {
            run_state *r = model->idle[b];
            model->idle[b] = r->next;
            hd_net_free(&r->net);
            free(r);
        }
    pthread_mutex_destroy(&model->lock);
    hd_image_free(&model->eyes);
    free(model->params);
    free(model);
}

int hd_model_size(const hd_model *model) { return model->cfg.size; }
int hd_model_width(const hd_model *model) { return model->cfg.width; }

hd_status hd_model_set_white_balance(hd_model *model, hd_white_balance mode)
{
    if (!model) return hd_fail(HD_ERR_ARG, "white balance: no model");
    if (mode != HD_WHITE_BALANCE_EYES && mode != HD_WHITE_BALANCE_OFF)
        return hd_fail(HD_ERR_ARG, "white balance: unknown mode %d", (int)mode);
    model->white_balance = mode;
    return HD_OK;
}

hd_status hd_model_set_background(hd_model *model, hd_background mode)
{
    if (!model) return hd_fail(HD_ERR_ARG, "background: no model");
    if (mode != HD_BACKGROUND_KEEP && mode != HD_BACKGROUND_RELIGHT)
        return hd_fail(HD_ERR_ARG, "background: unknown mode %d", (int)mode);
    model->background = mode;
    return HD_OK;
}

hd_background hd_model_background(const hd_model *model) { return model ? model->background : HD_BACKGROUND_KEEP; }

hd_status hd_model_set_shadows(hd_model *model, hd_shadows mode)
{
    if (!model) return hd_fail(HD_ERR_ARG, "shadows: no model");
    if (mode != HD_SHADOWS_CAST && mode != HD_SHADOWS_NONE) return hd_fail(HD_ERR_ARG, "shadows: unknown mode %d", (int)mode);
    model->shadows = mode;
    return HD_OK;
}

hd_shadows hd_model_shadows(const hd_model *model) { return model ? model->shadows : HD_SHADOWS_CAST; }

/* The eye contours at the model size, made once. */
static hd_status model_eyes(hd_model *m, const float **eyes)
{
    pthread_mutex_lock(&m->lock);
    hd_status s = m->eyes.data ? HD_OK : hd_eyes_uv(m->cfg.size, &m->eyes);
    *eyes = m->eyes.data;
    pthread_mutex_unlock(&m->lock);
    return s;
}

/* With the white balance on: divides the tint of slot rgb (3, size, size) out of it in place
 * (clamped to 1) and writes it to tint; else tint is 1, 1, 1 and rgb untouched. */
static hd_status balance_input(hd_model *m, float *rgb, float tint[3])
{
    tint[0] = tint[1] = tint[2] = 1.0f;
    if (m->white_balance == HD_WHITE_BALANCE_OFF) return HD_OK;
    const float *eyes;
    hd_status s = model_eyes(m, &eyes);
    if (s == HD_OK) s = hd_eye_tint(rgb, m->cfg.size, eyes, tint);
    if (s != HD_OK) return s;
    const size_t HW = (size_t)m->cfg.size * m->cfg.size;
    for (int c = 0; c < 3; c++) {
        if (tint[c] == 1.0f) continue;
        float inv = 1.0f / tint[c];
        for (size_t p = 0; p < HW; p++) {
            float v = rgb[c * HW + p] * inv;
            rgb[c * HW + p] = v > 1.0f ? 1.0f : v;
        }
    }
    return HD_OK;
}

/* An idle run state for batches of B from the pool, or a new one. */
static hd_status take_run_state(hd_model *m, int B, run_state **out)
{
    pthread_mutex_lock(&m->lock);
    run_state *r = m->idle[B];
    if (r) m->idle[B] = r->next;
    pthread_mutex_unlock(&m->lock);
    if (!r) {
        r = hd_calloc(1, sizeof *r);
        if (!r) return HD_ERR_NOMEM;
        hd_status s = hd_net_create_run(&r->net, &m->cfg, B, HD_CONV_AUTO, m->params);
        if (s != HD_OK) {
            free(r);
            return s;
        }
    }
    *out = r;
    return HD_OK;
}

static void give_back(hd_model *m, run_state *r)
{
    pthread_mutex_lock(&m->lock);
    r->next = m->idle[r->net.B];
    m->idle[r->net.B] = r;
    pthread_mutex_unlock(&m->lock);
}

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
    hd_apply_threads();
    run_state *r;
    hd_status s = take_run_state(model, count < HD_DECOMPOSE_BATCH ? count : HD_DECOMPOSE_BATCH, &r);
    if (s != HD_OK) return s;
    hd_net *net = &r->net;
    int size = model->cfg.size;
    size_t HW = (size_t)size * size;
    for (int first = 0; first < count; first += net->B) {
        int n = count - first < net->B ? count - first : net->B;
        memset(net->input, 0, (size_t)net->B * 3 * HW * sizeof(float));
        float tints[HD_DECOMPOSE_BATCH][3];
        for (int k = 0; k < n; k++)
            if ((s = load_input(&images[first + k], size, net->input + (size_t)k * 3 * HW, first + k)) != HD_OK ||
                (s = balance_input(model, net->input + (size_t)k * 3 * HW, tints[k])) != HD_OK)
                goto fail;
        hd_net_forward(net, NULL);
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
                    d->reconstruction.data[c * HW + p] = d->albedo.data[c * HW + p] * d->shading.data[p] * tints[k][c];
            memcpy(d->light, net->light + (size_t)k * HD_SH_COEFFS, sizeof d->light);
            memcpy(d->camera_tint, tints[k], sizeof d->camera_tint);
        }
    }
    give_back(model, r);
    return HD_OK;
fail:
    give_back(model, r);
    for (int i = 0; i < count; i++) hd_decomposition_free(&out[i]);
    return s;
}

/* The given shading, at the model's size, scaled to S-Net's mean over the mask, into dst (HW). */
static hd_status held_shading(const hd_image *shading, const hd_image *mask, const float *predicted, int size, float *dst)
{
    hd_image sized = {0}, msized = {0};
    const hd_image *cur = shading, *m = mask;
    hd_status s = HD_OK;
    if (cur->width != size || cur->height != size) {
        if ((s = hd_image_resize(cur, size, size, &sized)) != HD_OK) goto done;
        cur = &sized;
    }
    if (m && (m->width != size || m->height != size)) {
        if ((s = hd_image_resize(m, size, size, &msized)) != HD_OK) goto done;
        m = &msized;
    }
    const size_t HW = (size_t)size * size;
    double given = 0, own = 0;
    for (size_t p = 0; p < HW; p++)
        if (!m || m->data[p] > 0.5f) given += cur->data[p], own += predicted[p];
    if (!(given > 0) || !isfinite(given)) {
        s = hd_fail(HD_ERR_ARG, "the given shading has no positive mean over the mask");
        goto done;
    }
    const float k = (float)(own / given);
    for (size_t p = 0; p < HW; p++) dst[p] = cur->data[p] * k;
done:
    hd_image_free(&sized);
    hd_image_free(&msized);
    return s;
}

hd_status hd_model_normals_from_shading(hd_model *model, const hd_image *image, const hd_image *shading,
                                        const hd_image *mask, hd_image *normal, float light[HD_SH_COEFFS])
{
    if (normal) memset(normal, 0, sizeof *normal);
    if (!model || !image || !normal || !shading || !shading->data || shading->channels != 1 ||
        (mask && (!mask->data || mask->channels != 1 || mask->width != shading->width || mask->height != shading->height)))
        return hd_fail(HD_ERR_ARG, "hd_model_normals_from_shading: a missing argument, or a shading or mask not of 1 channel "
                                   "and one size");
    hd_apply_threads();
    run_state *r;
    hd_status s = take_run_state(model, 1, &r);
    if (s != HD_OK) return s;
    hd_net *net = &r->net;
    const int size = model->cfg.size;
    const size_t HW = (size_t)size * size;
    float tint[3], *hold = hd_malloc(HW * sizeof(float));
    if (!hold) s = HD_ERR_NOMEM;
    if (s == HD_OK) s = load_input(image, size, net->input, 0);
    if (s == HD_OK) s = balance_input(model, net->input, tint);
    if (s == HD_OK) {
        hd_net_forward(net, NULL);
        s = held_shading(shading, mask, net->shading, size, hold);
    }
    if (s == HD_OK) {
        hd_net_pass pass;
        memset(&pass, 0, sizeof pass);
        pass.n_input_hold = hold;
        hd_net_forward(net, &pass);
        s = hd_image_alloc(normal, size, size, 3);
    }
    if (s == HD_OK) {
        memcpy(normal->data, net->normal, 3 * HW * sizeof(float));
        if (light) memcpy(light, net->light, HD_SH_COEFFS * sizeof(float));
    }
    free(hold);
    give_back(model, r);
    return s;
}
