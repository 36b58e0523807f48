/* serve.h: the parts of `hdnet serve` (docs/serve.md), an HTTP server for interactive relighting
 * on libmicrohttpd: pictures in and out of memory (image_memory.c), the photos kept in memory with
 * their faces, decompositions and maps (photos.c), the model calls behind one lock (engine.c),
 * lights from requests (lights.c), the HTTP layer (server.c) and the page embedded in the binary
 * (page/, compiled into assets.c by the Makefile). */
#ifndef HD_SERVE_H
#define HD_SERVE_H

#include <pthread.h>
#include <stddef.h>
#include "hdnet.h"

/* ------------------------------------------------------------ bytes in memory (image_memory.c) */

typedef struct serve_blob {
    unsigned char *data;
    size_t size, cap;
} serve_blob;

/* Appends n bytes, growing the buffer; HD_ERR_NOMEM on failure (the blob is left as it was). */
hd_status serve_blob_append(serve_blob *b, const void *data, size_t n);
void serve_blob_free(serve_blob *b);

typedef enum serve_picture_kind { SERVE_PICTURE_UNKNOWN = 0, SERVE_PICTURE_PNG, SERVE_PICTURE_JPEG } serve_picture_kind;

/* The kind of a picture from its magic bytes. */
serve_picture_kind serve_picture_sniff(const unsigned char *data, size_t n);
/* The size a PNG or JPEG header claims, read without decoding anything (the PNG IHDR, the JPEG
 * frame header); HD_ERR_FORMAT when the header is missing or malformed. `what` names the
 * picture in errors. */
hd_status serve_picture_probe(const unsigned char *data, size_t n, const char *what, long *width, long *height);
/* Decodes a PNG or JPEG held in memory to 3 channels (hd_image_decode, then converted as
 * hd_image_read_as(path, 3) does); truncated or corrupt data is HD_ERR_FORMAT. */
hd_status serve_picture_decode(const unsigned char *data, size_t n, const char *what, hd_image *rgb);
/* Encodes an image (1-4 channels) as an 8-bit PNG in memory (hd_image_encode: the bytes
 * hd_image_write puts in a .png file). */
hd_status serve_picture_encode_png(const hd_image *img, serve_blob *png);

/* ------------------------------------------------------------ the model behind a lock (engine.c) */

/* One model and one face aligner shared by every connection. Neither is safe to call from two
 * threads at once, so every call that runs them holds `lock`. */
typedef struct serve_engine {
    pthread_mutex_t lock;
    hd_model *model;
    hd_aligner *aligner;
} serve_engine;

hd_status serve_engine_open(serve_engine *e, const char *model_path);
void serve_engine_close(serve_engine *e);

/* ------------------------------------------------------------ photos in memory (photos.c) */

typedef struct serve_face {
    float box[4]; /* x0, y0, x1, y1 in photo pixels */
    float score;
    float landmarks[HD_FACE_LANDMARKS][2];
    float light[HD_SH_COEFFS]; /* the face's own light, as the ratio rule takes it (hd_face_light) */
    float ref_light[HD_SH_COEFFS]; /* its light as a reference (hd_reference_light): what `hdnet
                                    * estimate-light` writes and a transfer from this photo takes */
    int head[4];      /* its head's window x0, y0, w, h in photo pixels (hd_head); w 0: no head */
    float head_guard; /* the head's guard g (hd_head) */
    float head_blur;  /* the blur of the head's log ratios, sigma in photo pixels (hd_head_blur) */
    int body_head[4]; /* the head's window with the body (the background relit); w 0: none */
    float scale;      /* the mesh's fit: photo pixels per cm (the cast shadows' softness, in the page) */
} serve_face;

/* The maps the page relights with, all at the photo's size (docs/serve.md, "The page"). The body_*
 * maps and people are those of the background relit (the render's with HD_BACKGROUND_RELIGHT), made
 * only for a photo whose every face's person the segmentation finds (serve_photo.background_relit). */
enum { SERVE_MAP_PHOTO = 0, SERVE_MAP_NORMAL, SERVE_MAP_SHADING, SERVE_MAP_MASK, SERVE_MAP_WEIGHT, SERVE_MAP_SKIN,
       SERVE_MAP_HEAD_NORMAL, SERVE_MAP_HEAD_PROXY, SERVE_MAP_HEAD_WEIGHTS, SERVE_MAP_HEAD_MESH,
       SERVE_MAP_BODY_WEIGHT, SERVE_MAP_BODY_LEVEL, SERVE_MAP_BODY_HEAD_NORMAL, SERVE_MAP_BODY_HEAD_PROXY,
       SERVE_MAP_BODY_HEAD_WEIGHTS, SERVE_MAP_BODY_HEAD_MESH, SERVE_MAP_PEOPLE, SERVE_MAP_DEPTH, SERVE_MAPS };
/* "photo", "normal", "shading", "mask", "weight", "skin", "head_normal", "head_proxy", "head_weights",
 * "head_mesh", then "body_" before weight, level and the four head maps, "people", and "depth" (the
 * faces' meshes' depth, for their cast shadows: serve_photo.depth_z0) */
extern const char *const serve_map_names[SERVE_MAPS];

typedef struct serve_photo {
    char id[17];        /* 16 hex digits */
    int width, height;
    hd_image image;     /* the decoded photo, 3 channels */
    int nfaces;
    serve_face *faces;
    serve_blob maps[SERVE_MAPS]; /* each an 8-bit PNG (the background's empty without background_relit) */
    int background_relit;        /* the photo has the maps of the background relit ... */
    char background_reason[192]; /* ... or why not */
    float depth_z0;     /* the "depth" map's origin: a pixel's depth is depth_z0 + (256 R + G - 1) / 8 photo
                         * pixels toward the camera where B is 255 (no face where B is 0) */
    /* owned by the store */
    unsigned long last_used;
    int refs;
    int evicted;
} serve_photo;

/* Decodes, aligns and decomposes an uploaded picture and builds its maps. Errors: HD_ERR_FORMAT
 * (not a readable PNG or JPEG), HD_ERR_RANGE (more than max_pixels pixels, found from the header
 * before anything is allocated), HD_ERR_NOTFOUND (no face). */
hd_status serve_photo_make(serve_engine *e, const unsigned char *data, size_t n, long max_pixels,
                              serve_photo **out);
void serve_photo_free(serve_photo *p);

/* At most `max` photos, the least recently used evicted first. Lookups hand out a reference
 * that must be given back with serve_store_release; an evicted photo is freed when its last
 * reference goes. */
typedef struct serve_store {
    pthread_mutex_t lock;
    serve_photo **slots;
    int max, count;
    unsigned long clock;
    long evictions;
} serve_store;

hd_status serve_store_init(serve_store *s, int max);
void serve_store_free(serve_store *s);
/* Adds p (which receives a fresh id); *evicted_id (17 bytes, may be NULL) gets the id of the photo
 * evicted to make room, or "". */
void serve_store_add(serve_store *s, serve_photo *p, char *evicted_id);
/* The photo with this id (a reference), or NULL. */
serve_photo *serve_store_get(serve_store *s, const char *id);
void serve_store_release(serve_store *s, serve_photo *p);
/* Removes a photo; 0 if there was none. */
int serve_store_remove(serve_store *s, const char *id);
int serve_store_count(serve_store *s);

/* ------------------------------------------------------------ lights from requests (lights.c) */

/* A light from a JSON request body: {"light": [9 numbers]}, {"preset": K} or {"azimuth": AZ,
 * "elevation": EL [, "intensity": I] [, "ambient": A]} (defaults as `hdnet relight --dir`), an
 * optional "brightness": "keep" (the default) or "free", and an optional "background": "keep" (the
 * default) or "relight". The reason for a refusal goes to `reason`. */
hd_status serve_light_from_json(const char *body, size_t n, float light[HD_SH_COEFFS], hd_brightness *brightness,
                             hd_background *background, char *reason, size_t reason_size);
/* The background mode a word names: "keep" or "relight" (`hdnet relight --background`); anything
 * else (NULL too) is refused with a reason. */
hd_status serve_background_from_word(const char *word, hd_background *background, char *reason, size_t reason_size);
/* The same from a URL query's values (NULL when absent): preset, or azimuth and elevation with
 * intensity and ambient. */
hd_status serve_light_from_query(const char *preset, const char *azimuth, const char *elevation, const char *intensity,
                              const char *ambient, float light[HD_SH_COEFFS], char *reason, size_t reason_size);
/* A light as a DPR-style text file (9 numbers, one a line, %.9g), malloc'ed. */
char *serve_light_text(const float light[HD_SH_COEFFS]);

/* ------------------------------------------------------------ the page (assets.c, generated) */

typedef struct serve_asset {
    const char *path; /* "/", "/app.js", ... */
    const char *type; /* the Content-Type */
    const unsigned char *data;
    size_t size;
} serve_asset;
extern const serve_asset serve_assets[]; /* ends with path NULL */

/* ------------------------------------------------------------ the server (server.c) */

typedef struct serve_options {
    const char *host;       /* the address to bind, "127.0.0.1" by default */
    int port;               /* 0: any free port */
    const char *model_path; /* NULL: the shipped model */
    int threads;            /* OpenMP threads of the library (0: its default) */
    size_t max_upload;      /* bytes of one request body */
    long max_pixels;        /* decoded pixels of one photo */
    int max_photos;         /* photos kept in memory */
    int timeout_s;          /* an idle connection is closed after this */
    int max_connections;
} serve_options;

typedef struct serve_server serve_server;

/* Loads the model and starts listening; *port_out gets the bound port. */
hd_status serve_server_start(const serve_options *o, serve_server **out, int *port_out);
/* Stops accepting, waits for the connections in progress, frees everything. */
void serve_server_stop(serve_server *s);

#endif /* HD_SERVE_H */
