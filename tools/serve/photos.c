/* photos.c: the photos `hdnet serve` keeps in memory. An upload is decoded (its header size checked
 * against the pixel cap first), every face is aligned and decomposed once, and the maps the page
 * relights with are built at the photo's size: each face's predicted normals and shading, brought
 * from the model's size to the face texture's (hd_normal_resize: renormalised) and
 * warped back into the photo with the face's mesh (hd_warp_back), and a mask that is 1 inside the
 * faces and falls to 0 over a few pixels at their edge, and the weight the render applies each
 * face's change with (hd_photo_face_weight: the feather inside the mesh's edge, the forehead grown
 * to the hairline with its outward fade; then over the whole head, hd_head_weight), the skin where
 * the render's log r is the model's own (the mesh outside the eyes, mouth and brows of
 * hd_face_regions_uv), each warped as the render warps its field, and the heads' normals and
 * weights (hd_head, as hd_apply_photo sets them up): the page's preview takes them. The store keeps at most N photos and evicts the least
 * recently used; a photo in use by a request is freed only when that request lets it go. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/random.h>
#include "../hdnet_tool.h"
#include "serve.h"

const char *const serve_map_names[SERVE_MAPS] = {
    "photo",       "normal",      "shading",          "mask",           "weight",
    "skin",        "head_normal", "head_proxy",       "head_weights",   "head_mesh",
    "body_weight", "body_level",  "body_head_normal", "body_head_proxy", "body_head_weights",
    "body_head_mesh", "people", "depth"};

void serve_photo_free(serve_photo *p)
{
    if (!p) return;
    hd_image_free(&p->image);
    free(p->faces);
    for (int m = 0; m < SERVE_MAPS; m++) serve_blob_free(&p->maps[m]);
    free(p);
}

/* One pass of a box filter of radius r along rows (dx = 1) or columns, edges clamped. */
static void box_pass(const float *src, float *dst, int W, int H, int r, int along_rows)
{
    const int n = along_rows ? W : H, lines = along_rows ? H : W;
    const size_t step = along_rows ? 1 : (size_t)W, line_step = along_rows ? (size_t)W : 1;
    for (int l = 0; l < lines; l++) {
        const float *s = src + (size_t)l * line_step;
        float *d = dst + (size_t)l * line_step;
        double acc = 0.0;
        for (int i = -r; i <= r; i++) acc += s[(size_t)(i < 0 ? 0 : i >= n ? n - 1 : i) * step];
        for (int i = 0; i < n; i++) {
            d[(size_t)i * step] = (float)(acc / (2 * r + 1));
            int out = i - r, in = i + r + 1;
            acc -= s[(size_t)(out < 0 ? 0 : out) * step];
            acc += s[(size_t)(in >= n ? n - 1 : in) * step];
        }
    }
}

/* mask = coverage * blur(coverage): 1 well inside, about 1/2 at the edge, 0 outside. */
static hd_status feather(hd_image *mask, int r)
{
    const int W = mask->width, H = mask->height;
    hd_image a = {0}, b = {0};
    hd_status st = hd_image_alloc(&a, W, H, 1);
    if (st == HD_OK) st = hd_image_alloc(&b, W, H, 1);
    if (st == HD_OK) {
        box_pass(mask->data, a.data, W, H, r, 1);
        box_pass(a.data, b.data, W, H, r, 0);
        for (size_t p = 0; p < (size_t)W * H; p++) mask->data[p] *= b.data[p];
    }
    hd_image_free(&a);
    hd_image_free(&b);
    return st;
}

/* The photo-sized maps the maps are built in (before encoding). */
typedef struct face_maps {
    hd_image normal, shading, mask, skin, depth; /* depth: -INFINITY off the faces */
} face_maps;

/* Adds face f's normals and shading (decomposition d) and its skin (the mesh outside the regions
 * the render fills: hd_face_regions_uv) to the photo-sized maps where its warp covers; a later
 * face overwrites an earlier one, as hd_relight_photo blends them in order. */
static hd_status add_face_maps(const hd_aligned_face *f, const hd_decomposition *d, face_maps *fm)
{
    /* two warps: the normals, and the shading and regions as the planes of one texture
     * (hd_warp_back takes at most 4 channels) */
    hd_image n_tex = {0}, r_tex = {0}, s_tex = {0}, tex = {0}, n_ph = {0}, ph = {0}, cover = {0}, cover2 = {0};
    hd_image z_tex = {0}, z_ph = {0}, cover3 = {0};
    const hd_mesh *mesh = NULL;
    hd_status st = hd_normal_resize(&d->normal, f->size, f->size, &n_tex);
    /* the mesh's depth as the render's cast shadows pose it (hd_mesh_cast_shadow_uv), in photo pixels */
    if (st == HD_OK) st = hd_mesh_canonical(&mesh);
    if (st == HD_OK) st = hd_mesh_posed_depth_uv(mesh, f->scale, f->rotation, f->translation[2], f->size, &z_tex);
    if (st == HD_OK) st = hd_warp_back(f, &z_tex, &f->mask, &z_ph, &cover3);
    if (st == HD_OK) st = hd_image_resize(&d->shading, f->size, f->size, &s_tex);
    if (st == HD_OK) st = hd_face_regions_uv(f->size, &r_tex);
    if (st == HD_OK) st = hd_image_alloc(&tex, f->size, f->size, 2);
    if (st == HD_OK) {
        const size_t T = (size_t)f->size * f->size;
        memcpy(tex.data, s_tex.data, T * sizeof(float));
        memcpy(tex.data + T, r_tex.data, T * sizeof(float));
        st = hd_warp_back(f, &n_tex, &f->mask, &n_ph, &cover);
    }
    if (st == HD_OK) st = hd_warp_back(f, &tex, &f->mask, &ph, &cover2);
    if (st == HD_OK) {
        hd_normal_renormalise(&n_ph);
        const size_t HW = (size_t)fm->normal.width * fm->normal.height;
        const float *shading = ph.data, *regions = ph.data + HW;
        for (size_t p = 0; p < HW; p++) {
            if (cover.data[p] <= 0.0f) continue;
            for (int c = 0; c < 3; c++) fm->normal.data[c * HW + p] = n_ph.data[c * HW + p];
            fm->shading.data[p] = shading[p];
            fm->mask.data[p] = 1.0f;
            fm->skin.data[p] = regions[p] <= 0.5f ? 1.0f : 0.0f;
        }
        for (size_t p = 0; p < HW; p++)
            if (cover3.data[p] > 0.0f) fm->depth.data[p] = z_ph.data[p];
    }
    hd_image *all[] = {&n_tex, &r_tex, &s_tex, &tex, &n_ph, &ph, &cover, &cover2, &z_tex, &z_ph, &cover3};
    for (size_t k = 0; k < sizeof all / sizeof all[0]; k++) hd_image_free(all[k]);
    return st;
}

/* The maps of one background mode (hd_face_weights, docs/usage.md "The whole head" and "The
 * background"), photo-sized: the render's weight, the largest of the faces'; the brightness's level
 * weight (hd_head_level: the weight without the body's share); over each face's head window, a
 * later face's over an earlier's, the blended normals and the proxy's, the skin's and the hair's
 * weights with how near the skin (ws, wh, near) and how much of the face's own field holds (mesh);
 * with the background relit, the people (NULL when kept). */
typedef struct mode_maps {
    hd_image weight, level, normal, proxy, weights, mesh;
    float *people;
} mode_maps;

static hd_status mode_maps_alloc(mode_maps *mm, int W, int H, int body)
{
    hd_status st = hd_image_alloc(&mm->weight, W, H, 1);
    if (st == HD_OK) st = hd_image_alloc(&mm->level, W, H, 1);
    if (st == HD_OK) st = hd_image_alloc(&mm->normal, W, H, 3);
    if (st == HD_OK) st = hd_image_alloc(&mm->proxy, W, H, 3);
    if (st == HD_OK) st = hd_image_alloc(&mm->weights, W, H, 3);
    if (st == HD_OK) st = hd_image_alloc(&mm->mesh, W, H, 1);
    if (st == HD_OK && body && !(mm->people = hd_calloc((size_t)W * H, sizeof(float)))) st = HD_ERR_NOMEM;
    return st;
}

static void mode_maps_free(mode_maps *mm)
{
    hd_image *all[] = {&mm->weight, &mm->level, &mm->normal, &mm->proxy, &mm->weights, &mm->mesh};
    for (size_t k = 0; k < sizeof all / sizeof all[0]; k++) hd_image_free(all[k]);
    free(mm->people);
}

/* An 8-bit map's value for a weight: one level for a weight above 0 but under half a level, so that
 * the map is 0 exactly where the weight is. */
static float level_of_weight(float w) { return w > 0.0f && w < 0.5f / 255.0f ? 1.0f / 255.0f : w; }

/* Face f's weights as hd_apply_photo computes them (hd_face_weights: with mm->people, the body's and
 * the face's person too) into mm, as the largest over the faces so far; its head's maps over its
 * window, and the window into `window` (w 0: no head), its guard and blur into sf. scratch is
 * photo-sized. */
static hd_status add_face_weight(const hd_aligned_face *f, const hd_decomposition *d, const hd_image *photo, int k,
                                 float *scratch, mode_maps *mm, int window[4], serve_face *sf)
{
    hd_head h;
    memset(&h, 0, sizeof h);
    float *level = NULL;
    hd_status st = hd_face_weights(f, d, photo, sf->light, 0.0f, mm->people, k, scratch, &h);
    if (st == HD_OK) st = hd_head_level(&h, scratch, &level);
    const float *lv = level ? level : scratch;
    for (size_t p = 0; st == HD_OK && p < (size_t)photo->width * photo->height; p++) {
        if (scratch[p] > mm->weight.data[p]) mm->weight.data[p] = scratch[p];
        if (lv[p] > mm->level.data[p]) mm->level.data[p] = lv[p];
    }
    free(level);
    memset(window, 0, 4 * sizeof *window);
    if (st == HD_OK && h.normal) {
        window[0] = h.x0, window[1] = h.y0, window[2] = h.w, window[3] = h.h;
        sf->head_guard = h.g, sf->head_blur = hd_head_blur(&h);
        const size_t N = (size_t)h.w * h.h, P = (size_t)h.W * h.H;
        for (int y = 0; y < h.h; y++)
            for (int x = 0; x < h.w; x++) {
                const size_t i = (size_t)y * h.w + x, p = (size_t)(y + h.y0) * h.W + (x + h.x0);
                for (int c = 0; c < 3; c++) {
                    mm->normal.data[c * P + p] = (h.normal[c * N + i] + 1.0f) * 0.5f;
                    mm->proxy.data[c * P + p] = (h.proxy[c * N + i] + 1.0f) * 0.5f;
                }
                mm->weights.data[p] = level_of_weight(h.ws[i]);
                mm->weights.data[P + p] = level_of_weight(h.wh[i]);
                mm->weights.data[2 * P + p] = h.near[i];
                /* 255 exactly where the face's own field holds fully (the page's mesh >= 1) */
                mm->mesh.data[p] = h.mesh[i] >= 1.0f ? 1.0f : fminf(h.mesh[i], 254.0f / 255.0f);
            }
    }
    hd_head_free(&h);
    return st;
}

/* Encodes one mode's maps into maps[..._at] (-1: not this mode's): weight, level (with the background
 * relit only: kept, it is the weight), the four head maps from head_at on, and the people (the
 * weights and the people 0 exactly where they are). */
static hd_status encode_mode(mode_maps *mm, serve_blob *maps, int weight_at, int level_at, int head_at, int people_at)
{
    const size_t P = (size_t)mm->weight.width * mm->weight.height;
    for (size_t q = 0; q < P; q++) {
        mm->weight.data[q] = level_of_weight(mm->weight.data[q]);
        mm->level.data[q] = level_of_weight(mm->level.data[q]);
        if (mm->people) mm->people[q] = level_of_weight(mm->people[q]);
    }
    hd_status st = serve_picture_encode_png(&mm->weight, &maps[weight_at]);
    if (st == HD_OK && level_at >= 0) st = serve_picture_encode_png(&mm->level, &maps[level_at]);
    const hd_image *head[] = {&mm->normal, &mm->proxy, &mm->weights, &mm->mesh};
    for (int k = 0; k < 4 && st == HD_OK; k++) st = serve_picture_encode_png(head[k], &maps[head_at + k]);
    if (st == HD_OK && people_at >= 0) {
        hd_image people = {mm->weight.width, mm->weight.height, 1, mm->people};
        st = serve_picture_encode_png(&people, &maps[people_at]);
    }
    return st;
}

/* Whether every face has its person map (the background can be relit); else the reason. */
static int background_can_be_relit(serve_photo *p, const hd_aligned_face *faces)
{
    for (int k = 0; k < p->nfaces; k++)
        if (!faces[k].person.data) {
            snprintf(p->background_reason, sizeof p->background_reason,
                     "the background is relit only where the person segmentation finds the person, and it did not "
                     "about face %d", k);
            return 0;
        }
    return 1;
}

/* The depth map as 8-bit RGB: B 1 on a face (0 off them), R and G the high and low bytes of 1 + 8 x
 * (depth - z0), z0 the least depth on the faces (written to *z0). */
static hd_status encode_depth(const hd_image *depth, float *z0, serve_blob *png)
{
    const size_t P = (size_t)depth->width * depth->height;
    float lo = INFINITY;
    for (size_t p = 0; p < P; p++)
        if (isfinite(depth->data[p])) lo = fminf(lo, depth->data[p]);
    *z0 = isfinite(lo) ? lo : 0.0f;
    hd_image rgb = {0};
    hd_status st = hd_image_alloc(&rgb, depth->width, depth->height, 3);
    for (size_t p = 0; st == HD_OK && p < P; p++) {
        const float z = depth->data[p];
        const long v = isfinite(z) ? 1 + lroundf(fminf(8.0f * (z - *z0), 65534.0f)) : 0;
        rgb.data[p] = (float)(v >> 8) / 255.0f, rgb.data[P + p] = (float)(v & 255) / 255.0f;
        rgb.data[2 * P + p] = v ? 1.0f : 0.0f;
    }
    if (st == HD_OK) st = serve_picture_encode_png(&rgb, png);
    hd_image_free(&rgb);
    return st;
}

/* The maps of a photo as PNGs: the photo, normals as (n + 1) / 2 (0 off the faces), shading as
 * s / 2, the feathered mask, the skin (1 where the render's log r is the model's own, 0 where it is
 * filled), and each background mode's (mode_maps; weights with a weight above 0 but under half a
 * level sent as one level, so the map is 0 exactly where the render leaves the photo as it is;
 * normals as (n + 1) / 2). The background relit's cost about as much again as the kept's (the
 * torso, the body's outline, the person): made here, once, outside the engine's lock. */
static hd_status make_maps(serve_photo *p, const hd_aligned_face *faces, const hd_decomposition *ds)
{
    const int W = p->width, H = p->height;
    face_maps fm = {0};
    mode_maps keep = {0}, body = {0};
    hd_image encoded = {0};
    p->background_relit = background_can_be_relit(p, faces);
    hd_status st = hd_image_alloc(&fm.normal, W, H, 3);
    if (st == HD_OK) st = hd_image_alloc(&fm.shading, W, H, 1);
    if (st == HD_OK) st = hd_image_alloc(&fm.mask, W, H, 1);
    if (st == HD_OK) st = hd_image_alloc(&fm.skin, W, H, 1);
    if (st == HD_OK) st = hd_image_alloc(&fm.depth, W, H, 1);
    for (size_t q = 0; st == HD_OK && q < (size_t)W * H; q++) fm.depth.data[q] = -INFINITY;
    if (st == HD_OK) st = mode_maps_alloc(&keep, W, H, 0);
    if (st == HD_OK && p->background_relit) st = mode_maps_alloc(&body, W, H, 1);
    float *scratch = st == HD_OK ? hd_malloc((size_t)W * H * sizeof(float)) : NULL;
    if (st == HD_OK && !scratch) st = HD_ERR_NOMEM;
    float face_side = 0.0f;
    for (int k = 0; k < p->nfaces && st == HD_OK; k++) {
        serve_face *sf = &p->faces[k];
        sf->scale = faces[k].scale;
        st = add_face_maps(&faces[k], &ds[k], &fm);
        if (st == HD_OK) st = add_face_weight(&faces[k], &ds[k], &p->image, k, scratch, &keep, sf->head, sf);
        if (st == HD_OK && p->background_relit)
            st = add_face_weight(&faces[k], &ds[k], &p->image, k, scratch, &body, sf->body_head, sf);
        float side = fminf(faces[k].box[2] - faces[k].box[0], faces[k].box[3] - faces[k].box[1]);
        if (side > face_side) face_side = side;
    }
    if (st == HD_OK) st = hd_normal_encode(&fm.normal, &fm.mask, &encoded);
    if (st == HD_OK) st = feather(&fm.mask, (int)fmaxf(2.0f, roundf(0.02f * face_side)));
    if (st == HD_OK) {
        for (size_t q = 0; q < (size_t)W * H; q++) fm.shading.data[q] *= 0.5f;
        st = serve_picture_encode_png(&p->image, &p->maps[SERVE_MAP_PHOTO]);
    }
    if (st == HD_OK) st = serve_picture_encode_png(&encoded, &p->maps[SERVE_MAP_NORMAL]);
    if (st == HD_OK) st = serve_picture_encode_png(&fm.shading, &p->maps[SERVE_MAP_SHADING]);
    if (st == HD_OK) st = serve_picture_encode_png(&fm.mask, &p->maps[SERVE_MAP_MASK]);
    if (st == HD_OK) st = serve_picture_encode_png(&fm.skin, &p->maps[SERVE_MAP_SKIN]);
    if (st == HD_OK) st = encode_depth(&fm.depth, &p->depth_z0, &p->maps[SERVE_MAP_DEPTH]);
    if (st == HD_OK) st = encode_mode(&keep, p->maps, SERVE_MAP_WEIGHT, -1, SERVE_MAP_HEAD_NORMAL, -1);
    if (st == HD_OK && p->background_relit)
        st = encode_mode(&body, p->maps, SERVE_MAP_BODY_WEIGHT, SERVE_MAP_BODY_LEVEL, SERVE_MAP_BODY_HEAD_NORMAL,
                         SERVE_MAP_PEOPLE);
    free(scratch);
    hd_image *all[] = {&fm.normal, &fm.shading, &fm.mask, &fm.skin, &fm.depth, &encoded};
    for (size_t k = 0; k < sizeof all / sizeof all[0]; k++) hd_image_free(all[k]);
    mode_maps_free(&keep);
    mode_maps_free(&body);
    return st;
}

hd_status serve_photo_make(serve_engine *e, const unsigned char *data, size_t n, long max_pixels,
                              serve_photo **out)
{
    *out = NULL;
    const char *what = "upload";
    long w = 0, h = 0;
    hd_status st = serve_picture_probe(data, n, what, &w, &h);
    if (st != HD_OK) return st;
    if (w <= 0 || h <= 0) return hd_fail(HD_ERR_FORMAT, "%s: image size %ldx%ld is empty", what, w, h);
    if ((double)w * (double)h > (double)max_pixels)
        return hd_fail(HD_ERR_RANGE, "%s: %ldx%ld is %.0f pixels, over the limit of %ld (--max-pixels)", what, w, h,
                       (double)w * (double)h, max_pixels);
    serve_photo *p = hd_calloc(1, sizeof *p);
    if (!p) return HD_ERR_NOMEM;
    st = serve_picture_decode(data, n, what, &p->image);
    if (st != HD_OK) {
        free(p);
        return st;
    }
    p->width = p->image.width;
    p->height = p->image.height;
    hd_aligned_face *faces = NULL;
    hd_decomposition *ds = NULL;
    int nfaces = 0;
    pthread_mutex_lock(&e->lock);
    st = hd_photo_faces(e->aligner, e->model, &p->image, &faces, &nfaces);
    if (st == HD_OK && !(ds = hd_calloc((size_t)nfaces, sizeof *ds))) st = HD_ERR_NOMEM;
    for (int k = 0; k < nfaces && st == HD_OK; k++) st = hd_face_decompose(e->model, &faces[k], &ds[k]);
    pthread_mutex_unlock(&e->lock);
    if (st == HD_OK && !(p->faces = hd_calloc((size_t)nfaces, sizeof *p->faces))) st = HD_ERR_NOMEM;
    if (st == HD_OK) {
        p->nfaces = nfaces;
        for (int k = 0; k < nfaces; k++) {
            serve_face *sf = &p->faces[k];
            memcpy(sf->box, faces[k].box, sizeof sf->box);
            sf->score = faces[k].score;
            for (int i = 0; i < HD_FACE_LANDMARKS; i++) {
                sf->landmarks[i][0] = faces[k].landmarks[i][0];
                sf->landmarks[i][1] = faces[k].landmarks[i][1];
            }
        }
        /* the face's own light, as the ratio rule takes it (the page's live preview divides by it) */
        for (int k = 0; k < nfaces && st == HD_OK; k++) st = hd_face_light(&ds[k], &faces[k].mask, HD_SOURCE_FIT, p->faces[k].light);
        for (int k = 0; k < nfaces && st == HD_OK; k++)
            st = hd_reference_light(&ds[k], &faces[k].mask, HD_SOURCE_FIT, p->faces[k].ref_light);
        if (st == HD_OK) st = make_maps(p, faces, ds);
    }
    for (int k = 0; ds && k < nfaces; k++) hd_decomposition_free(&ds[k]);
    free(ds);
    hd_aligned_faces_free(faces, nfaces);
    if (st != HD_OK) {
        serve_photo_free(p);
        return st;
    }
    *out = p;
    return HD_OK;
}

/* ---------------------------------------------------------------- the store */

hd_status serve_store_init(serve_store *s, int max)
{
    memset(s, 0, sizeof *s);
    if (max < 1) return hd_fail(HD_ERR_ARG, "the store holds at least one photo (asked for %d)", max);
    if (!(s->slots = hd_calloc((size_t)max, sizeof *s->slots))) return HD_ERR_NOMEM;
    if (pthread_mutex_init(&s->lock, NULL) != 0) {
        free(s->slots);
        return hd_fail(HD_ERR_NOMEM, "cannot create a lock");
    }
    s->max = max;
    return HD_OK;
}

void serve_store_free(serve_store *s)
{
    if (!s->slots) return;
    for (int i = 0; i < s->count; i++) serve_photo_free(s->slots[i]);
    free(s->slots);
    pthread_mutex_destroy(&s->lock);
    memset(s, 0, sizeof *s);
}

/* Takes slot i out (the lock held); frees the photo unless a request still holds it. */
static void drop_slot(serve_store *s, int i)
{
    serve_photo *p = s->slots[i];
    s->slots[i] = s->slots[--s->count];
    p->evicted = 1;
    if (p->refs == 0) serve_photo_free(p);
}

void serve_store_add(serve_store *s, serve_photo *p, char *evicted_id)
{
    uint64_t r = 0;
    if (getrandom(&r, sizeof r, 0) != (ssize_t)sizeof r) r = (uint64_t)(hd_seconds() * 1e9);
    pthread_mutex_lock(&s->lock);
    r ^= (uint64_t)++s->clock << 1; /* distinct even if getrandom failed twice in a nanosecond */
    snprintf(p->id, sizeof p->id, "%016llx", (unsigned long long)r);
    if (evicted_id) evicted_id[0] = 0;
    if (s->count == s->max) {
        int oldest = 0;
        for (int i = 1; i < s->count; i++)
            if (s->slots[i]->last_used < s->slots[oldest]->last_used) oldest = i;
        if (evicted_id) memcpy(evicted_id, s->slots[oldest]->id, sizeof p->id);
        drop_slot(s, oldest);
        s->evictions++;
    }
    p->last_used = s->clock;
    s->slots[s->count++] = p;
    pthread_mutex_unlock(&s->lock);
}

serve_photo *serve_store_get(serve_store *s, const char *id)
{
    serve_photo *found = NULL;
    pthread_mutex_lock(&s->lock);
    for (int i = 0; i < s->count; i++)
        if (strcmp(s->slots[i]->id, id) == 0) {
            found = s->slots[i];
            found->refs++;
            found->last_used = ++s->clock;
            break;
        }
    pthread_mutex_unlock(&s->lock);
    return found;
}

void serve_store_release(serve_store *s, serve_photo *p)
{
    if (!p) return;
    pthread_mutex_lock(&s->lock);
    int gone = --p->refs == 0 && p->evicted;
    pthread_mutex_unlock(&s->lock);
    if (gone) serve_photo_free(p);
}

int serve_store_remove(serve_store *s, const char *id)
{
    int removed = 0;
    pthread_mutex_lock(&s->lock);
    for (int i = 0; i < s->count; i++)
        if (strcmp(s->slots[i]->id, id) == 0) {
            drop_slot(s, i);
            removed = 1;
            break;
        }
    pthread_mutex_unlock(&s->lock);
    return removed;
}

int serve_store_count(serve_store *s)
{
    pthread_mutex_lock(&s->lock);
    int n = s->count;
    pthread_mutex_unlock(&s->lock);
    return n;
}
