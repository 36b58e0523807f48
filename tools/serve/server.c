/* server.c: the HTTP layer of `hdnet serve` on libmicrohttpd (docs/serve.md has the API). One
 * thread per connection (bounded in number, an idle connection closed after a timeout), so a slow
 * client holds only its own thread; the model calls are serialised by the engine's lock. Every
 * answer comes from memory: the page is compiled into the binary and a request's path is only
 * ever matched against fixed routes, never mapped to a file. Errors are JSON {"error": ...} with
 * the status that fits (400 malformed, 404 unknown, 405 method, 413 too large, 415 not a PNG or
 * JPEG / not JSON, 422 no face, 503 out of memory). */
#include <arpa/inet.h>
#include <cjson/cJSON.h>
#include <math.h>
#include <microhttpd.h>
#include <netinet/in.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include "../hdnet_tool.h"
#include "serve.h"

#define JSON_BODY_MAX 65536 /* bytes of a light request */
#define ID_LEN 16

struct serve_server {
    serve_options o;
    struct MHD_Daemon *daemon;
    serve_engine engine;
    serve_store store;
    int loopback; /* bound to a loopback address: only loopback Host headers are served */
};

/* What one request has received so far. */
typedef struct request {
    serve_blob body;
    int over; /* the body passed its cap */
} request;

/* ---------------------------------------------------------------- answers */

static enum MHD_Result send_bytes(struct MHD_Connection *c, unsigned status, const char *type, const void *data,
                                  size_t size, const char *disposition)
{
    struct MHD_Response *r = MHD_create_response_from_buffer(size, (void *)data, MHD_RESPMEM_MUST_COPY);
    if (!r) return MHD_NO;
    MHD_add_response_header(r, MHD_HTTP_HEADER_CONTENT_TYPE, type);
    MHD_add_response_header(r, MHD_HTTP_HEADER_CACHE_CONTROL, "no-store");
    MHD_add_response_header(r, "X-Content-Type-Options", "nosniff");
    /* the page loads nothing from anywhere but this server */
    MHD_add_response_header(r, "Content-Security-Policy",
                            "default-src 'self'; img-src 'self' blob: data:; connect-src 'self'; "
                            "frame-ancestors 'none'");
    if (disposition) MHD_add_response_header(r, MHD_HTTP_HEADER_CONTENT_DISPOSITION, disposition);
    enum MHD_Result ok = MHD_queue_response(c, status, r);
    MHD_destroy_response(r);
    return ok;
}

static enum MHD_Result send_json(struct MHD_Connection *c, unsigned status, cJSON *json)
{
    char *text = json ? cJSON_PrintUnformatted(json) : NULL;
    cJSON_Delete(json);
    if (!text) return MHD_NO;
    enum MHD_Result ok = send_bytes(c, status, "application/json", text, strlen(text), NULL);
    free(text);
    return ok;
}

static enum MHD_Result send_error(struct MHD_Connection *c, unsigned status, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
static enum MHD_Result send_error(struct MHD_Connection *c, unsigned status, const char *fmt, ...)
{
    char message[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(message, sizeof message, fmt, ap);
    va_end(ap);
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "error", message);
    cJSON_AddNumberToObject(j, "status", status);
    if (status >= 500) fprintf(stderr, "hdnet serve: %u: %s\n", status, message);
    return send_json(c, status, j);
}

/* The status for a library failure. */
static unsigned status_of(hd_status st)
{
    switch (st) {
    case HD_ERR_FORMAT: return MHD_HTTP_BAD_REQUEST;
    case HD_ERR_RANGE: return MHD_HTTP_CONTENT_TOO_LARGE;
    case HD_ERR_NOTFOUND: return MHD_HTTP_UNPROCESSABLE_CONTENT;
    case HD_ERR_ARG: return MHD_HTTP_BAD_REQUEST;
    case HD_ERR_NOMEM: return MHD_HTTP_SERVICE_UNAVAILABLE;
    default: return MHD_HTTP_INTERNAL_SERVER_ERROR;
    }
}

static enum MHD_Result send_png(struct MHD_Connection *c, const hd_image *img, const char *filename)
{
    serve_blob png = {0};
    if (serve_picture_encode_png(img, &png) != HD_OK) return send_error(c, MHD_HTTP_INTERNAL_SERVER_ERROR, "%s", hd_error());
    char disposition[128];
    snprintf(disposition, sizeof disposition, "inline; filename=\"%s\"", filename);
    enum MHD_Result ok = send_bytes(c, MHD_HTTP_OK, "image/png", png.data, png.size, disposition);
    serve_blob_free(&png);
    return ok;
}

/* ---------------------------------------------------------------- JSON descriptions */

static double tenth(float v) { return round((double)v * 10.0) / 10.0; }
/* The shortest decimal that gives the float back (as light files are written, %.9g). */
static double precise(float v)
{
    char text[32];
    snprintf(text, sizeof text, "%.9g", (double)v);
    return strtod(text, NULL);
}

static cJSON *float_array(const float *v, int n, double (*round_fn)(float))
{
    cJSON *a = cJSON_CreateArray();
    for (int i = 0; i < n; i++) cJSON_AddItemToArray(a, cJSON_CreateNumber(round_fn(v[i])));
    return a;
}

/* The direction a light comes from, from its band-1 coefficients: l1, l2, l3 go with -z, y, x. */
static void add_direction(cJSON *obj, const float light[HD_SH_COEFFS])
{
    double x = light[3], y = light[2], z = -light[1], len = sqrt(x * x + y * y + z * z);
    double az = len > 0 ? atan2(x, z) * 180.0 / M_PI : 0.0, el = len > 0 ? asin(y / len) * 180.0 / M_PI : 0.0;
    cJSON_AddNumberToObject(obj, "azimuth", round(az * 10.0) / 10.0);
    cJSON_AddNumberToObject(obj, "elevation", round(el * 10.0) / 10.0);
}

static cJSON *photo_json(const serve_server *s, const serve_photo *p, const char *evicted)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "id", p->id);
    cJSON_AddNumberToObject(j, "width", p->width);
    cJSON_AddNumberToObject(j, "height", p->height);
    cJSON *faces = cJSON_AddArrayToObject(j, "faces");
    for (int k = 0; k < p->nfaces; k++) {
        const serve_face *f = &p->faces[k];
        cJSON *o = cJSON_CreateObject();
        cJSON_AddItemToObject(o, "box", float_array(f->box, 4, tenth));
        cJSON_AddNumberToObject(o, "score", round((double)f->score * 1000.0) / 1000.0);
        cJSON_AddItemToObject(o, "light", float_array(f->light, HD_SH_COEFFS, precise));
        add_direction(o, f->light);
        cJSON_AddNumberToObject(o, "scale", precise(f->scale));
        cJSON *lm = cJSON_AddArrayToObject(o, "landmarks");
        for (int i = 0; i < HD_FACE_LANDMARKS; i++) cJSON_AddItemToArray(lm, float_array(f->landmarks[i], 2, tenth));
        if (f->head[2] > 0) { /* the head's window and rule (the head_* maps hold it) */
            cJSON *h = cJSON_AddObjectToObject(o, "head");
            cJSON *win = cJSON_AddArrayToObject(h, "window");
            for (int i = 0; i < 4; i++) cJSON_AddItemToArray(win, cJSON_CreateNumber(f->head[i]));
            cJSON_AddNumberToObject(h, "guard", precise(f->head_guard));
            cJSON_AddNumberToObject(h, "blur", precise(f->head_blur));
            if (p->background_relit) { /* with the body (the background relit: the body_* maps) */
                cJSON *bw = cJSON_AddArrayToObject(h, "body_window");
                for (int i = 0; i < 4; i++) cJSON_AddItemToArray(bw, cJSON_CreateNumber(f->body_head[i]));
            }
        } else {
            cJSON_AddNullToObject(o, "head");
        }
        cJSON_AddItemToArray(faces, o);
    }
    /* the background modes a render of this photo takes (relight: the person found about every face) */
    cJSON *modes = cJSON_AddArrayToObject(j, "backgrounds");
    cJSON_AddItemToArray(modes, cJSON_CreateString("keep"));
    if (p->background_relit) cJSON_AddItemToArray(modes, cJSON_CreateString("relight"));
    else cJSON_AddStringToObject(j, "background_reason", p->background_reason);
    cJSON *depth = cJSON_AddObjectToObject(j, "depth"); /* the depth map's code (serve_photo.depth_z0) */
    cJSON_AddNumberToObject(depth, "z0", precise(p->depth_z0));
    cJSON_AddNumberToObject(depth, "step", 0.125);
    cJSON *maps = cJSON_AddObjectToObject(j, "maps");
    for (int m = 0; m < SERVE_MAPS; m++) {
        if (!p->maps[m].size) continue; /* the background relit's, for a photo without them */
        char url[96];
        snprintf(url, sizeof url, "/api/photos/%s/maps/%s.png", p->id, serve_map_names[m]);
        cJSON_AddStringToObject(maps, serve_map_names[m], url);
    }
    cJSON_AddNumberToObject(j, "max_photos", s->o.max_photos);
    if (evicted && *evicted) cJSON_AddStringToObject(j, "evicted", evicted);
    else if (evicted) cJSON_AddNullToObject(j, "evicted");
    return j;
}

static enum MHD_Result health(struct MHD_Connection *c, serve_server *s)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "status", "ok");
    char version[64];
    snprintf(version, sizeof version, "hdnet %s", hd_version());
    cJSON_AddStringToObject(j, "version", version);
    cJSON *model = cJSON_AddObjectToObject(j, "model");
    cJSON_AddNumberToObject(model, "size", hd_model_size(s->engine.model));
    cJSON_AddNumberToObject(model, "width", hd_model_width(s->engine.model));
    cJSON_AddNumberToObject(j, "photos", serve_store_count(&s->store));
    cJSON_AddNumberToObject(j, "max_photos", s->o.max_photos);
    pthread_mutex_lock(&s->store.lock);
    cJSON_AddNumberToObject(j, "evictions", (double)s->store.evictions);
    pthread_mutex_unlock(&s->store.lock);
    cJSON *limits = cJSON_AddObjectToObject(j, "limits");
    cJSON_AddNumberToObject(limits, "max_upload_bytes", (double)s->o.max_upload);
    cJSON_AddNumberToObject(limits, "max_pixels", (double)s->o.max_pixels);
    cJSON_AddNumberToObject(limits, "timeout_s", s->o.timeout_s);
    cJSON_AddNumberToObject(limits, "max_connections", s->o.max_connections);
    return send_json(c, MHD_HTTP_OK, j);
}

static enum MHD_Result presets(struct MHD_Connection *c)
{
    cJSON *a = cJSON_CreateArray();
    for (int k = 0; k < HD_LIGHT_PRESETS; k++) {
        float light[HD_SH_COEFFS];
        hd_light_preset(k, light);
        cJSON *o = cJSON_CreateObject();
        cJSON_AddNumberToObject(o, "preset", k);
        cJSON_AddItemToObject(o, "light", float_array(light, HD_SH_COEFFS, precise));
        add_direction(o, light);
        cJSON_AddItemToArray(a, o);
    }
    cJSON *j = cJSON_CreateObject();
    cJSON_AddItemToObject(j, "presets", a);
    cJSON_AddNumberToObject(j, "default_intensity", HD_LIGHT_DEFAULT_INTENSITY);
    cJSON_AddNumberToObject(j, "default_ambient", HD_LIGHT_DEFAULT_AMBIENT);
    return send_json(c, MHD_HTTP_OK, j);
}

static enum MHD_Result send_light_file(struct MHD_Connection *c, const float light[HD_SH_COEFFS], const char *name)
{
    char *text = serve_light_text(light);
    if (!text) return send_error(c, MHD_HTTP_SERVICE_UNAVAILABLE, "out of memory");
    char disposition[96];
    snprintf(disposition, sizeof disposition, "attachment; filename=\"%s\"", name);
    enum MHD_Result ok = send_bytes(c, MHD_HTTP_OK, "text/plain; charset=utf-8", text, strlen(text), disposition);
    free(text);
    return ok;
}

/* ---------------------------------------------------------------- request helpers */

static const char *query(struct MHD_Connection *c, const char *key)
{
    return MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, key);
}

/* Whether the request's Content-Type (parameters ignored) is one of the `|`-separated types. */
static int content_type_is(struct MHD_Connection *c, const char *types)
{
    const char *ct = MHD_lookup_connection_value(c, MHD_HEADER_KIND, MHD_HTTP_HEADER_CONTENT_TYPE);
    if (!ct) return 0;
    size_t len = strcspn(ct, "; \t");
    for (const char *t = types; *t;) {
        size_t tl = strcspn(t, "|");
        if (tl == len && strncasecmp(ct, t, len) == 0) return 1;
        t += tl + (t[tl] == '|');
    }
    return 0;
}

/* Host names a page on this machine may use: a DNS name pointed at 127.0.0.1 by someone else's
 * page (DNS rebinding) is refused while the server is bound to loopback. */
static int host_allowed(struct MHD_Connection *c, const serve_server *s)
{
    if (!s->loopback) return 1;
    const char *host = MHD_lookup_connection_value(c, MHD_HEADER_KIND, MHD_HTTP_HEADER_HOST);
    if (!host) return 1; /* HTTP/1.0 without Host */
    size_t len = host[0] == '[' ? strcspn(host, "]") + 1 : strcspn(host, ":");
    return (len == 9 && strncasecmp(host, "localhost", 9) == 0) || (len == 5 && strncmp(host, "[::1]", 5) == 0) ||
           (len >= 9 && strncmp(host, "127.", 4) == 0 && strspn(host, "0123456789.") == len);
}

static int valid_id(const char *id, size_t len)
{
    if (len != ID_LEN) return 0;
    for (size_t i = 0; i < len; i++)
        if (!strchr("0123456789abcdef", id[i])) return 0;
    return 1;
}

/* ---------------------------------------------------------------- the photo routes */

static enum MHD_Result upload(struct MHD_Connection *c, serve_server *s, request *r)
{
    if (!content_type_is(c, "image/png|image/jpeg|image/jpg"))
        return send_error(c, MHD_HTTP_UNSUPPORTED_MEDIA_TYPE, "send the photo as image/png or image/jpeg");
    if (r->body.size == 0) return send_error(c, MHD_HTTP_BAD_REQUEST, "the body is empty: send a PNG or JPEG");
    if (serve_picture_sniff(r->body.data, r->body.size) == SERVE_PICTURE_UNKNOWN)
        return send_error(c, MHD_HTTP_UNSUPPORTED_MEDIA_TYPE, "the body is not a PNG or JPEG");
    serve_photo *p = NULL;
    hd_status st = serve_photo_make(&s->engine, r->body.data, r->body.size, s->o.max_pixels, &p);
    if (st != HD_OK) return send_error(c, status_of(st), "%s", hd_error());
    char evicted[ID_LEN + 1];
    serve_store_add(&s->store, p, evicted);
    /* p may be evicted by another upload from here on: describe it under a reference */
    serve_photo *held = serve_store_get(&s->store, p->id);
    if (!held) return send_error(c, MHD_HTTP_SERVICE_UNAVAILABLE, "the photo was evicted at once (too many uploads)");
    cJSON *j = photo_json(s, held, evicted);
    serve_store_release(&s->store, held);
    return send_json(c, MHD_HTTP_CREATED, j);
}

/* relight, delight or transfer of photo p: the whole photo through hd_relight_photo, the library
 * call of `hdnet relight`, `delight` and `transfer`, so the pixels are theirs. */
static enum MHD_Result render(struct MHD_Connection *c, serve_server *s, serve_photo *p, const char *op, request *r)
{
    float light[HD_SH_COEFFS];
    hd_brightness brightness = HD_BRIGHTNESS_KEEP;
    hd_background background = HD_BACKGROUND_KEEP;
    const int delight = strcmp(op, "delight") == 0;
    char reason[256];
    if (strcmp(op, "relight") == 0) { /* the background in the JSON body, with the light */
        if (!content_type_is(c, "application/json"))
            return send_error(c, MHD_HTTP_UNSUPPORTED_MEDIA_TYPE, "send the light as application/json");
        if (query(c, "background"))
            return send_error(c, MHD_HTTP_BAD_REQUEST, "relight takes \"background\" in its JSON body, not the query");
        if (serve_light_from_json((const char *)r->body.data, r->body.size, light, &brightness, &background, reason,
                                  sizeof reason) != HD_OK)
            return send_error(c, MHD_HTTP_BAD_REQUEST, "%s", reason);
    } else if (query(c, "background") && /* delight and transfer: ?background=, with ?ref= */
               serve_background_from_word(query(c, "background"), &background, reason, sizeof reason) != HD_OK) {
        return send_error(c, MHD_HTTP_BAD_REQUEST, "%s", reason);
    }
    if (strcmp(op, "transfer") == 0) {
        const char *ref_id = query(c, "ref");
        if (!ref_id) return send_error(c, MHD_HTTP_BAD_REQUEST, "transfer needs ?ref=ID (the photo whose light to take)");
        serve_photo *ref = valid_id(ref_id, strlen(ref_id)) ? serve_store_get(&s->store, ref_id) : NULL;
        if (!ref) return send_error(c, MHD_HTTP_NOT_FOUND, "no photo '%.32s' in memory (unknown, deleted or evicted)", ref_id);
        /* face 0's light as a reference: what hd_estimate_light_photo (hdnet transfer --ref) estimates */
        memcpy(light, ref->faces[0].ref_light, sizeof light);
        serve_store_release(&s->store, ref);
    } else if (!delight && strcmp(op, "relight") != 0) {
        return send_error(c, MHD_HTTP_NOT_FOUND, "no such operation '%.32s'", op);
    }
    hd_image out = {0};
    int nfaces = 0;
    pthread_mutex_lock(&s->engine.lock);
    /* the mode for this call only: the model is shared, and the next request may want the other */
    const hd_background was = hd_model_background(s->engine.model);
    hd_status st = hd_model_set_background(s->engine.model, background);
    if (st == HD_OK)
        st = delight ? hd_relight_photo(s->engine.model, s->engine.aligner, &p->image, NULL, 0,
                                              HD_BRIGHTNESS_KEEP, NULL, &out, &nfaces)
                           : hd_relight_photo(s->engine.model, s->engine.aligner, &p->image,
                                              (const float (*)[HD_SH_COEFFS])light, 1, brightness, &out, NULL, &nfaces);
    const hd_status restored = hd_model_set_background(s->engine.model, was);
    pthread_mutex_unlock(&s->engine.lock);
    if (st == HD_OK && restored != HD_OK) {
        hd_image_free(&out);
        st = restored;
    }
    if (st != HD_OK) return send_error(c, status_of(st), "%s", hd_error());
    char filename[64];
    snprintf(filename, sizeof filename, "%s-%s.png", p->id, delight ? "delit" : "relit");
    enum MHD_Result ok = send_png(c, &out, filename);
    hd_image_free(&out);
    return ok;
}

/* /api/photos/ID[/rest] */
static enum MHD_Result photo_route(struct MHD_Connection *c, serve_server *s, const char *method, const char *path,
                                   request *r)
{
    size_t id_len = strcspn(path, "/");
    const char *rest = path + id_len;
    char id[ID_LEN + 1];
    if (!valid_id(path, id_len)) return send_error(c, MHD_HTTP_NOT_FOUND, "no photo '%.32s' (ids are 16 hex digits)", path);
    memcpy(id, path, ID_LEN);
    id[ID_LEN] = 0;
    const int get = strcmp(method, "GET") == 0 || strcmp(method, "HEAD") == 0, post = strcmp(method, "POST") == 0;
    if (*rest == 0 && strcmp(method, "DELETE") == 0) {
        if (!serve_store_remove(&s->store, id)) return send_error(c, MHD_HTTP_NOT_FOUND, "no photo '%s' in memory", id);
        cJSON *j = cJSON_CreateObject();
        cJSON_AddStringToObject(j, "deleted", id);
        return send_json(c, MHD_HTTP_OK, j);
    }
    serve_photo *p = serve_store_get(&s->store, id);
    if (!p)
        return send_error(c, MHD_HTTP_NOT_FOUND,
                          "no photo '%s' in memory (unknown, deleted, or evicted: the server keeps the %d most "
                          "recently used)", id, s->o.max_photos);
    enum MHD_Result ok;
    if (*rest == 0 && get) {
        ok = send_json(c, MHD_HTTP_OK, photo_json(s, p, NULL));
    } else if (strncmp(rest, "/maps/", 6) == 0 && get) {
        const char *name = rest + 6;
        int m = 0;
        for (; m < SERVE_MAPS; m++) {
            size_t n = strlen(serve_map_names[m]);
            if (strncmp(name, serve_map_names[m], n) == 0 && strcmp(name + n, ".png") == 0) break;
        }
        if (m == SERVE_MAPS)
            ok = send_error(c, MHD_HTTP_NOT_FOUND, "no map '%.32s' (the upload's \"maps\" names them)", name);
        else if (!p->maps[m].size)
            ok = send_error(c, MHD_HTTP_NOT_FOUND, "no map '%.32s' for this photo: %s", name, p->background_reason);
        else
            ok = send_bytes(c, MHD_HTTP_OK, "image/png", p->maps[m].data, p->maps[m].size, NULL);
    } else if (strcmp(rest, "/light.txt") == 0 && get) {
        const char *fs = query(c, "face");
        char *end = NULL;
        long k = fs ? strtol(fs, &end, 10) : 0;
        if (fs && (end == fs || *end || k < 0 || k >= p->nfaces))
            ok = send_error(c, MHD_HTTP_BAD_REQUEST, "face must be 0..%d", p->nfaces - 1);
        else {
            char name[48];
            snprintf(name, sizeof name, "%s-face%ld.light.txt", p->id, k);
            ok = send_light_file(c, p->faces[k].ref_light, name);
        }
    } else if ((strcmp(rest, "/relight") == 0 || strcmp(rest, "/delight") == 0 || strcmp(rest, "/transfer") == 0)) {
        ok = post ? render(c, s, p, rest + 1, r)
                  : send_error(c, MHD_HTTP_METHOD_NOT_ALLOWED, "%s is POST", rest + 1);
    } else {
        ok = send_error(c, MHD_HTTP_NOT_FOUND, "no such resource");
    }
    serve_store_release(&s->store, p);
    return ok;
}

/* ---------------------------------------------------------------- dispatch */

static enum MHD_Result route(struct MHD_Connection *c, serve_server *s, const char *url, const char *method, request *r)
{
    if (!host_allowed(c, s))
        return send_error(c, MHD_HTTP_FORBIDDEN, "this server answers only to localhost, 127.x.x.x or [::1]");
    if (strstr(url, "..") || strchr(url, '\\') || strstr(url, "//"))
        return send_error(c, MHD_HTTP_BAD_REQUEST, "bad path");
    const int get = strcmp(method, "GET") == 0 || strcmp(method, "HEAD") == 0;
    if (strcmp(url, "/api/health") == 0) return get ? health(c, s) : send_error(c, MHD_HTTP_METHOD_NOT_ALLOWED, "GET only");
    if (strcmp(url, "/api/presets") == 0) return get ? presets(c) : send_error(c, MHD_HTTP_METHOD_NOT_ALLOWED, "GET only");
    if (strcmp(url, "/api/light.txt") == 0) {
        if (!get) return send_error(c, MHD_HTTP_METHOD_NOT_ALLOWED, "GET only");
        float light[HD_SH_COEFFS];
        char reason[256];
        if (serve_light_from_query(query(c, "preset"), query(c, "azimuth"), query(c, "elevation"), query(c, "intensity"),
                                query(c, "ambient"), light, reason, sizeof reason) != HD_OK)
            return send_error(c, MHD_HTTP_BAD_REQUEST, "%s", reason);
        return send_light_file(c, light, "light.txt");
    }
    if (strcmp(url, "/api/photos") == 0)
        return strcmp(method, "POST") == 0 ? upload(c, s, r)
                                           : send_error(c, MHD_HTTP_METHOD_NOT_ALLOWED, "POST a photo here");
    if (strncmp(url, "/api/photos/", 12) == 0) return photo_route(c, s, method, url + 12, r);
    if (strncmp(url, "/api/", 5) == 0) return send_error(c, MHD_HTTP_NOT_FOUND, "no such API route");
    for (const serve_asset *a = serve_assets; a->path; a++)
        if (strcmp(url, a->path) == 0)
            return get ? send_bytes(c, MHD_HTTP_OK, a->type, a->data, a->size, NULL)
                       : send_error(c, MHD_HTTP_METHOD_NOT_ALLOWED, "GET only");
    return send_error(c, MHD_HTTP_NOT_FOUND, "not found");
}

/* The cap on a request's body: the upload limit for photos, 64 KiB for everything else. */
static size_t body_cap(const serve_server *s, const char *url)
{
    return strcmp(url, "/api/photos") == 0 ? s->o.max_upload : JSON_BODY_MAX;
}

static enum MHD_Result on_request(void *cls, struct MHD_Connection *c, const char *url, const char *method,
                                  const char *version, const char *upload_data, size_t *upload_data_size,
                                  void **con_cls)
{
    (void)version;
    serve_server *s = cls;
    request *r = *con_cls;
    if (!r) { /* the headers are in; the body (if any) follows in later calls */
        if (!(r = calloc(1, sizeof *r))) return MHD_NO;
        *con_cls = r;
        const char *len = MHD_lookup_connection_value(c, MHD_HEADER_KIND, MHD_HTTP_HEADER_CONTENT_LENGTH);
        if (len && strtoull(len, NULL, 10) > body_cap(s, url)) {
            r->over = 1;
            return send_error(c, MHD_HTTP_CONTENT_TOO_LARGE, "the body is %s bytes, over the limit of %zu%s", len,
                              body_cap(s, url), body_cap(s, url) == s->o.max_upload ? " (--max-upload)" : "");
        }
        return MHD_YES;
    }
    if (*upload_data_size) {
        if (r->over) { /* an answer is queued already: drop the rest */
            *upload_data_size = 0;
            return MHD_YES;
        }
        if (r->body.size + *upload_data_size > body_cap(s, url)) return MHD_NO; /* no length given: close */
        if (serve_blob_append(&r->body, upload_data, *upload_data_size) != HD_OK) return MHD_NO;
        *upload_data_size = 0;
        return MHD_YES;
    }
    if (r->over) return MHD_YES;
    return route(c, s, url, method, r);
}

static void on_completed(void *cls, struct MHD_Connection *c, void **con_cls, enum MHD_RequestTerminationCode code)
{
    (void)cls;
    (void)c;
    (void)code;
    request *r = *con_cls;
    if (!r) return;
    serve_blob_free(&r->body);
    free(r);
    *con_cls = NULL;
}

/* ---------------------------------------------------------------- start and stop */

hd_status serve_server_start(const serve_options *o, serve_server **out, int *port_out)
{
    *out = NULL;
    struct sockaddr_in a4;
    struct sockaddr_in6 a6;
    memset(&a4, 0, sizeof a4);
    memset(&a6, 0, sizeof a6);
    const struct sockaddr *addr;
    int loopback, ipv6 = 0;
    if (o->port < 0 || o->port > 65535) return hd_fail(HD_ERR_ARG, "port %d is not in 0..65535", o->port);
    if (inet_pton(AF_INET, o->host, &a4.sin_addr) == 1) {
        a4.sin_family = AF_INET;
        a4.sin_port = htons((uint16_t)o->port);
        addr = (const struct sockaddr *)&a4;
        loopback = (ntohl(a4.sin_addr.s_addr) >> 24) == 127;
    } else if (inet_pton(AF_INET6, o->host, &a6.sin6_addr) == 1) {
        a6.sin6_family = AF_INET6;
        a6.sin6_port = htons((uint16_t)o->port);
        addr = (const struct sockaddr *)&a6;
        loopback = IN6_IS_ADDR_LOOPBACK(&a6.sin6_addr);
        ipv6 = 1;
    } else {
        return hd_fail(HD_ERR_ARG, "--host '%s' is not an IPv4 or IPv6 address", o->host);
    }
    serve_server *s = hd_calloc(1, sizeof *s);
    if (!s) return HD_ERR_NOMEM;
    s->o = *o;
    s->loopback = loopback;
    hd_status st = serve_engine_open(&s->engine, o->model_path);
    if (st == HD_OK) st = serve_store_init(&s->store, o->max_photos);
    if (st != HD_OK) {
        serve_engine_close(&s->engine);
        free(s);
        return st;
    }
    unsigned flags = MHD_USE_INTERNAL_POLLING_THREAD | MHD_USE_THREAD_PER_CONNECTION | MHD_USE_POLL |
                     (ipv6 ? MHD_USE_IPv6 : 0);
    s->daemon = MHD_start_daemon(flags, (uint16_t)o->port, NULL, NULL, on_request, s, MHD_OPTION_SOCK_ADDR, addr,
                                 MHD_OPTION_CONNECTION_TIMEOUT, (unsigned)o->timeout_s, MHD_OPTION_CONNECTION_LIMIT,
                                 (unsigned)o->max_connections, MHD_OPTION_NOTIFY_COMPLETED, on_completed, s,
                                 MHD_OPTION_END);
    if (!s->daemon) {
        serve_store_free(&s->store);
        serve_engine_close(&s->engine);
        free(s);
        return hd_fail(HD_ERR_IO, "cannot listen on %s port %d (in use, or not an address of this machine)", o->host,
                       o->port);
    }
    const union MHD_DaemonInfo *info = MHD_get_daemon_info(s->daemon, MHD_DAEMON_INFO_BIND_PORT);
    *port_out = info ? info->port : o->port;
    *out = s;
    return HD_OK;
}

void serve_server_stop(serve_server *s)
{
    if (!s) return;
    MHD_stop_daemon(s->daemon);
    serve_store_free(&s->store);
    serve_engine_close(&s->engine);
    free(s);
}
