/* apply.c: the one place that applies a model to an aligned face texture or to a photo, in memory
 * (docs/usage.md, "The relighting rule"): decompose each face once, then for every target light
 * (and the delit face, and the face under its own light when asked) build the rule's log-ratio
 * field in texture space (rule.c) and put it onto the picture: on a texture directly, feathered
 * inside the mask; on a photo warped back through the landmark mesh, feathered from the face's
 * edge in photo pixels, so that outside the face the photo is untouched bit for bit. The old rule
 * (HD_RULE_PAPER) goes through relight.c and the Poisson blend instead. The hdnet commands are
 * options and files around these calls; the thin public calls of hdnet.h (calls.c) are requests to
 * them. Of src/apply's other files it uses the rule's pieces and photo.c's faces, never calls.c. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "apply/apply.h"

/* The feather band in a texture, a share of its side (a photo's: forehead.c). */
#define FEATHER_TEXTURE 0.01f

void hd_apply_result_free(hd_apply_result *r)
{
    if (!r) return;
    for (int i = 0; r->relit && i < r->count; i++) hd_image_free(&r->relit[i]);
    free(r->relit);
    free(r->face_light);
    hd_aligned_faces_free(r->faces, r->nfaces);
    hd_image_free(&r->delit);
    hd_image_free(&r->self);
    memset(r, 0, sizeof *r);
}


static hd_status copy_image(const hd_image *src, hd_image *dst)
{
    hd_status st = hd_image_alloc(dst, src->width, src->height, src->channels);
    if (st == HD_OK)
        memcpy(dst->data, src->data, (size_t)src->width * (size_t)src->height * (size_t)src->channels * sizeof(float));
    return st;
}

/* The operation the request is for, as its error reasons name it. */
static const char *operation(const hd_apply_request *q)
{
    return q && q->operation ? q->operation : "relight";
}

/* The pieces of the rule (rule.c, forehead.c, head.c, relight.c) begin their reasons with
 * "relight:"; a public call's failure names the operation op it was asked for instead. */
static hd_status named(const char *op, hd_status st)
{
    static const char piece[] = "relight: ";
    if (st != HD_OK && st != HD_ERR_NOMEM && strcmp(op, "relight") != 0 &&
        strncmp(hd_error(), piece, sizeof piece - 1) == 0)
        return hd_fail(st, "%s: %s", op, hd_error() + sizeof piece - 1);
    return st;
}

static hd_status check_request(const hd_apply_request *q, const hd_image *picture)
{
    const char *op = operation(q);
    if (!q || q->count < 0 || (q->count > 0 && !q->lights))
        return hd_fail(HD_ERR_ARG, "%s: the request's lights are missing", op);
    if (q->rule != HD_RULE_RATIO && q->rule != HD_RULE_PAPER) return hd_fail(HD_ERR_ARG, "%s: unknown rule %d", op, (int)q->rule);
    if (q->rule == HD_RULE_PAPER)
        for (int i = 0; i < q->count; i++)
            if (!hd_light_rgb_is_grey(&q->lights[i]))
                return hd_fail(HD_ERR_ARG, "%s: the paper's rule takes grey lights only (light %d is coloured)", op, i);
    if (!picture || !picture->data || picture->channels != 3)
        return hd_fail(HD_ERR_ARG, "%s: a picture has 3 channels (has %d)", op, picture ? picture->channels : 0);
    return HD_OK;
}

/* Allocates the outputs as copies of the picture. */
static hd_status result_init(const hd_apply_request *q, const hd_image *picture, hd_apply_result *r)
{
    memset(r, 0, sizeof *r);
    r->relit = hd_calloc(q->count > 0 ? (size_t)q->count : 1, sizeof *r->relit);
    if (!r->relit) return HD_ERR_NOMEM;
    r->count = q->count;
    hd_status st = HD_OK;
    for (int i = 0; i < q->count && st == HD_OK; i++) st = copy_image(picture, &r->relit[i]);
    if (st == HD_OK && q->delight) st = copy_image(picture, &r->delit);
    if (st == HD_OK && q->self) st = copy_image(picture, &r->self);
    return st;
}

/* The k-th job of a request: its target light (NULL: flat), brightness, output. k runs over the
 * lights, then the delit face, then the face under its own light. */
typedef struct job {
    const hd_light_rgb *target;
    hd_light_rgb own;
    hd_brightness brightness;
    hd_image *out;
} job;

/* What the ratio rule takes of a face besides its normals: its own light, the guard, and the
 * head's pose when the face casts shadows (NULL: none). */
typedef struct face_rule {
    float source[HD_SH_COEFFS];
    float guard;
    const float *rotation;
} face_rule;

static int jobs_of(const hd_apply_request *q, hd_apply_result *r, const float own[HD_SH_COEFFS], job *jobs)
{
    int n = 0;
    for (int i = 0; i < q->count; i++) jobs[n++] = (job){&q->lights[i], {{{0}}}, q->brightness, &r->relit[i]};
    if (q->delight)
        jobs[n++] = (job){NULL, {{{0}}}, q->rule == HD_RULE_PAPER ? HD_BRIGHTNESS_FREE : q->brightness, &r->delit};
    if (q->self) {
        jobs[n] = (job){NULL, {{{0}}}, q->brightness, &r->self};
        hd_light_rgb_from_grey(own, &jobs[n].own);
        jobs[n].target = &jobs[n].own;
        n++;
    }
    return n;
}

/* One job on a texture (out is the texture's copy): the rule, feathered inside the mask. */
static hd_status texture_job(const hd_image *tex, const hd_decomposition *d, const hd_image *mask,
                             const float *feather, hd_relight_rule rule, const face_rule *fr, const job *jb)
{
    if (rule == HD_RULE_PAPER) {
        hd_image out = {0};
        hd_status st = hd_relight_paper(tex, d, mask, jb->target ? jb->target->sh[0] : NULL, jb->brightness, &out);
        if (st == HD_OK) {
            hd_image_free(jb->out);
            *jb->out = out;
        }
        return st;
    }
    const int W = tex->width, H = tex->height, side = W > H ? W : H;
    hd_image field = {0}, sized = {0};
    hd_status st = hd_ratio_field(d, mask, side, fr->source, fr->guard, jb->target, NULL, &field);
    if (st == HD_OK && (W != side || H != side)) {
        st = hd_image_resize(&field, W, H, &sized);
        hd_image_free(&field);
        field = sized;
    }
    if (st == HD_OK) st = hd_ratio_apply(&field, feather, NULL, jb->brightness, jb->out, NULL);
    hd_image_free(&field);
    return st;
}

/* Feather weights of a texture's mask (NULL: all ones), at the texture's size. */
static hd_status texture_feather(const hd_image *tex, const hd_image *mask, float **weight)
{
    const int W = tex->width, H = tex->height;
    const size_t P = (size_t)W * H;
    *weight = hd_malloc((P ? P : 1) * sizeof(float));
    if (!*weight) return HD_ERR_NOMEM;
    hd_image m = {0};
    hd_status st = HD_OK;
    if (mask) st = mask->width == W && mask->height == H ? copy_image(mask, &m) : hd_image_resize(mask, W, H, &m);
    else if ((st = hd_image_alloc(&m, W, H, 1)) == HD_OK)
        for (size_t p = 0; p < P; p++) m.data[p] = 1.0f;
    if (st == HD_OK) st = hd_field_feather(m.data, W, H, FEATHER_TEXTURE * (W > H ? W : H), *weight);
    /* a soft mask value scales the change too */
    for (size_t p = 0; st == HD_OK && p < P; p++) {
        float v = m.data[p] < 0 ? 0 : m.data[p] > 1 ? 1 : m.data[p];
        (*weight)[p] *= v;
    }
    hd_image_free(&m);
    if (st != HD_OK) {
        free(*weight);
        *weight = NULL;
    }
    return st;
}

hd_status hd_apply_decomposition(const hd_image *texture, const hd_decomposition *d, const hd_image *mask,
                                 const hd_apply_request *q, hd_apply_result *r)
{
    memset(r, 0, sizeof *r);
    hd_status st = check_request(q, texture);
    if (st != HD_OK) return st;
    if (mask && (!mask->data || mask->channels != 1))
        return hd_fail(HD_ERR_ARG, "%s: a mask has 1 channel (has %d)", operation(q), mask->channels);
    if ((st = result_init(q, texture, r)) != HD_OK) {
        hd_apply_result_free(r);
        return st;
    }
    face_rule fr = {{0}, q->guard, NULL}; /* a texture has no pose: no cast shadows */
    r->face_light = hd_malloc(sizeof *r->face_light);
    if (!r->face_light) st = HD_ERR_NOMEM;
    else if ((st = hd_face_light(d, mask, q->source, fr.source)) == HD_OK)
        memcpy(r->face_light[0], fr.source, sizeof fr.source);
    float *feather = NULL;
    if (st == HD_OK && q->rule == HD_RULE_RATIO) st = texture_feather(texture, mask, &feather);
    job *jobs = hd_malloc((size_t)(q->count + 2) * sizeof *jobs);
    if (!jobs && st == HD_OK) st = HD_ERR_NOMEM;
    int n = st == HD_OK ? jobs_of(q, r, fr.source, jobs) : 0;
    for (int k = 0; k < n && st == HD_OK; k++) st = texture_job(texture, d, mask, feather, q->rule, &fr, &jobs[k]);
    free(jobs);
    free(feather);
    if (st != HD_OK) {
        hd_apply_result_free(r);
        return named(operation(q), st);
    }
    r->nfaces = 1;
    return HD_OK;
}

hd_status hd_apply_texture(hd_model *model, const hd_image *texture, const hd_image *mask, const hd_apply_request *q,
                           hd_apply_result *r)
{
    memset(r, 0, sizeof *r);
    hd_status st = check_request(q, texture);
    if (st != HD_OK) return st;
    hd_decomposition d;
    memset(&d, 0, sizeof d);
    st = hd_model_decompose(model, texture, 1, &d);
    if (st == HD_OK) st = hd_apply_decomposition(texture, &d, mask, q, r);
    hd_decomposition_free(&d);
    return st;
}

/* One job on face f of a photo (out is the photo's copy, with earlier faces already changed). */
static hd_status photo_job(const hd_aligned_face *f, const hd_decomposition *d, const float *feather,
                           const hd_head *head, hd_relight_rule rule, const face_rule *fr, const job *jb,
                           double *offset)
{
    hd_image tex_out = {0}, field = {0}, warped = {0}, coverage = {0};
    hd_status st;
    if (rule == HD_RULE_PAPER) {
        st = hd_relight_paper(&f->texture, d, &f->mask, jb->target ? jb->target->sh[0] : NULL, jb->brightness, &tex_out);
        if (st == HD_OK) st = hd_warp_back_blend(f, &tex_out, HD_WARP_CHANGE, 0, jb->out, NULL);
        hd_image_free(&tex_out);
        return st;
    }
    st = hd_ratio_field(d, &f->mask, f->texture.width, fr->source, fr->guard, jb->target, fr->rotation, &field);
    if (st == HD_OK) st = hd_warp_back(f, &field, NULL, &warped, &coverage);
    /* the field beyond the mesh (where the region grew over the forehead) from the mesh's edge */
    const size_t P = (size_t)warped.width * (size_t)warped.height;
    for (int c = 0; st == HD_OK && c < warped.channels; c++)
        st = hd_field_fill(warped.data + (size_t)c * P, coverage.data, warped.width, warped.height);
    if (st == HD_OK) st = hd_head_apply(head, fr->source, jb->target, &warped); /* beyond the mesh (head.c) */
    float *level = NULL; /* the brightness kept over the head, not the body's clothes */
    if (st == HD_OK && jb->brightness == HD_BRIGHTNESS_KEEP) st = hd_head_level(head, feather, &level);
    if (st == HD_OK) st = hd_ratio_apply(&warped, feather, level, jb->brightness, jb->out, offset);
    free(level);
    hd_image_free(&field);
    hd_image_free(&warped);
    hd_image_free(&coverage);
    return st;
}

hd_status hd_photo_face_weight(const hd_aligned_face *f, const hd_image *photo, float *feather)
{
    hd_image warped = {0}, coverage = {0};
    hd_status st = hd_warp_back(f, &f->mask, NULL, &warped, &coverage);
    if (st == HD_OK) st = hd_field_fill_holes(coverage.data, coverage.width, coverage.height);
    if (st == HD_OK) st = hd_photo_face_feather(f, photo, coverage.data, feather);
    hd_image_free(&warped);
    hd_image_free(&coverage);
    return st;
}

hd_status hd_face_weights(const hd_aligned_face *f, const hd_decomposition *d, const hd_image *photo,
                          const float source[HD_SH_COEFFS], float guard, float *people, int k, float *feather,
                          hd_head *head)
{
    if (people && !f->person.data) {
        char which[64];
        if (k >= 0) snprintf(which, sizeof which, "face %d", k);
        else snprintf(which, sizeof which, "the face at %.0f, %.0f", (double)f->box[0], (double)f->box[1]);
        return hd_fail(HD_ERR_ARG,
                       "the background is relit only where the person segmentation finds the person, "
                       "and it did not about %s",
                       which);
    }
    hd_status st = hd_photo_face_weight(f, photo, feather);
    if (st == HD_OK) st = hd_head_init(f, d, photo, source, guard, people ? HD_HEAD_BODY_ALL : HD_HEAD_BODY_NEAR, head);
    if (st == HD_OK) st = hd_head_weight(head, feather);
    if (st == HD_OK && people) st = hd_backdrop_add_person(f, feather, head, photo->width, photo->height, people);
    return st;
}

hd_status hd_apply_face(const hd_aligned_face *f, const hd_decomposition *d, const hd_light_rgb *target,
                        hd_brightness brightness, hd_source_light source, hd_shadows shadows, hd_image *photo,
                        hd_face_backdrop *backdrop)
{
    const char *op = target ? "relight" : "delight";
    if (!f || !d || !photo || !photo->data || photo->channels != 3)
        return hd_fail(HD_ERR_ARG, "%s: a face, its decomposition and a 3-channel photo are needed", op);
    const size_t P = (size_t)photo->width * (size_t)photo->height;
    float *feather = hd_malloc((P ? P : 1) * sizeof(float));
    if (!feather) return HD_ERR_NOMEM;
    job jb = {target, {{{0}}}, brightness, photo};
    face_rule fr = {{0}, 0.0f, shadows == HD_SHADOWS_CAST ? f->rotation : NULL};
    hd_head head;
    memset(&head, 0, sizeof head);
    hd_status st = hd_face_light(d, &f->mask, source, fr.source);
    if (st == HD_OK) st = hd_face_weights(f, d, photo, fr.source, fr.guard, backdrop ? backdrop->people : NULL, -1, feather, &head);
    if (st == HD_OK && backdrop) memcpy(backdrop->source, fr.source, sizeof fr.source);
    if (st == HD_OK) st = photo_job(f, d, feather, &head, HD_RULE_RATIO, &fr, &jb, backdrop ? &backdrop->offset : NULL);
    hd_head_free(&head);
    free(feather);
    return named(op, st);
}

hd_status hd_apply_photo(hd_model *model, hd_aligner *aligner, const hd_image *photo, const hd_apply_request *q,
                         hd_apply_result *r)
{
    memset(r, 0, sizeof *r);
    hd_status st = check_request(q, photo);
    if (st != HD_OK) return st;
    hd_aligned_face *faces = NULL;
    int n = 0;
    if ((st = hd_photo_faces(aligner, model, photo, &faces, &n)) != HD_OK) return st;
    if ((st = result_init(q, photo, r)) != HD_OK) {
        hd_aligned_faces_free(faces, n);
        hd_apply_result_free(r);
        return st;
    }
    r->faces = faces;
    r->nfaces = n;
    r->face_light = hd_calloc((size_t)n, sizeof *r->face_light);
    job *jobs = hd_malloc((size_t)(q->count + 2) * sizeof *jobs);
    const size_t P = (size_t)photo->width * (size_t)photo->height;
    float *feather = q->rule == HD_RULE_RATIO ? hd_malloc((P ? P : 1) * sizeof(float)) : NULL;
    /* the background as a backdrop (backdrop.c): where the people are, and the first face's
     * brightness offset of each job */
    const int backdrop = q->rule == HD_RULE_RATIO && hd_model_background(model) == HD_BACKGROUND_RELIGHT;
    float *people = backdrop ? hd_calloc(P ? P : 1, sizeof(float)) : NULL;
    double *offsets = backdrop ? hd_calloc((size_t)(q->count + 2), sizeof(double)) : NULL;
    if (!r->face_light || !jobs || (q->rule == HD_RULE_RATIO && !feather) || (backdrop && (!people || !offsets)))
        st = HD_ERR_NOMEM;
    for (int k = 0; k < n && st == HD_OK; k++) {
        const hd_aligned_face *f = &faces[k];
        hd_decomposition d;
        memset(&d, 0, sizeof d);
        face_rule fr = {{0}, q->guard, hd_model_shadows(model) == HD_SHADOWS_CAST ? f->rotation : NULL};
        st = hd_face_decompose(model, f, &d);
        if (st == HD_OK) st = hd_face_light(&d, &f->mask, q->source, fr.source);
        if (st == HD_OK) memcpy(r->face_light[k], fr.source, sizeof fr.source);
        hd_head head;
        memset(&head, 0, sizeof head);
        if (st == HD_OK && feather) st = hd_face_weights(f, &d, photo, fr.source, fr.guard, people, k, feather, &head);
        int m = st == HD_OK ? jobs_of(q, r, fr.source, jobs) : 0;
        for (int i = 0; i < m && st == HD_OK; i++)
            st = photo_job(f, &d, feather, &head, q->rule, &fr, &jobs[i], backdrop && k == 0 ? &offsets[i] : NULL);
        hd_head_free(&head);
        hd_decomposition_free(&d);
    }
    /* the backdrop under each job's light, from the first face's own */
    if (st == HD_OK && backdrop && n > 0) {
        const int m = jobs_of(q, r, r->face_light[0], jobs);
        for (int i = 0; i < m; i++) {
            float lr[3];
            hd_backdrop_log_ratio(r->face_light[0], jobs[i].target, q->guard, lr);
            hd_backdrop_apply(lr, offsets[i], people, jobs[i].out);
        }
    }
    free(people);
    free(offsets);
    free(jobs);
    free(feather);
    if (st != HD_OK) {
        hd_apply_result_free(r);
        return named(operation(q), st);
    }
    return HD_OK;
}
