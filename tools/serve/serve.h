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

typedef struct hd_blob {
    unsigned char *data;
    size_t size, cap;
} hd_blob;

/* Appends n bytes, growing the buffer; HD_ERR_NOMEM on failure (the blob is left as it was). */
hd_status hd_blob_append(hd_blob *b, const void *data, size_t n);
void hd_blob_free(hd_blob *b);

typedef enum hd_picture_kind { HD_PICTURE_UNKNOWN = 0, HD_PICTURE_PNG, HD_PICTURE_JPEG } hd_picture_kind;

/* The kind of a picture from its magic bytes. */
hd_picture_kind hd_picture_sniff(const unsigned char *data, size_t n);
/* The size a PNG or JPEG header claims, read without decoding anything (the PNG IHDR, the JPEG
 * frame header); HD_ERR_FORMAT when the header is missing or malformed. `what` names the
 * picture in errors. */
hd_status hd_picture_probe(const unsigned char *data, size_t n, const char *what, long *width, long *height);
/* Decodes a PNG or JPEG held in memory to 3 channels (hd_image_decode, then converted as
 * hd_image_read_as(path, 3) does); truncated or corrupt data is HD_ERR_FORMAT. */
hd_status hd_picture_decode(const unsigned char *data, size_t n, const char *what, hd_image *rgb);
/* Encodes an image (1-4 channels) as an 8-bit PNG in memory (hd_image_encode: the bytes
 * hd_image_write puts in a .png file). */
hd_status hd_picture_encode_png(const hd_image *img, hd_blob *png);

/* ------------------------------------------------------------ the model behind a lock (engine.c) */

/* One model and one face aligner shared by every connection. Neither is safe to call from two
 * threads at once, so every call that runs them holds `lock`. */
typedef struct hd_engine {
    pthread_mutex_t lock;
    hd_model *model;
    hd_aligner *aligner;
} hd_engine;

hd_status hd_engine_open(hd_engine *e, const char *model_path);
void hd_engine_close(hd_engine *e);

/* ------------------------------------------------------------ photos in memory (photos.c) */

typedef struct hd_serve_face {
    float box[4]; /* x0, y0, x1, y1 in photo pixels */
    float score;
    float landmarks[HD_FACE_LANDMARKS][2];
    float light[HD_SH_COEFFS]; /* the model's estimate (L-Net) for this face */
} hd_serve_face;

/* The maps the page relights with, all at the photo's size (docs/serve.md, "The page"). */
enum { HD_MAP_PHOTO = 0, HD_MAP_NORMAL, HD_MAP_SHADING, HD_MAP_MASK, HD_MAPS };
extern const char *const hd_map_names[HD_MAPS]; /* "photo", "normal", "shading", "mask" */

typedef struct hd_serve_photo {
    char id[17];        /* 16 hex digits */
    int width, height;
    hd_image image;     /* the decoded photo, 3 channels */
    int nfaces;
    hd_serve_face *faces;
    hd_blob maps[HD_MAPS]; /* each an 8-bit PNG */
    /* owned by the store */
    unsigned long last_used;
    int refs;
    int evicted;
} hd_serve_photo;

/* Decodes, aligns and decomposes an uploaded picture and builds its maps. Errors: HD_ERR_FORMAT
 * (not a readable PNG or JPEG), HD_ERR_RANGE (more than max_pixels pixels, found from the header
 * before anything is allocated), HD_ERR_NOTFOUND (no face). */
hd_status hd_serve_photo_make(hd_engine *e, const unsigned char *data, size_t n, long max_pixels,
                              hd_serve_photo **out);
void hd_serve_photo_free(hd_serve_photo *p);

/* At most `max` photos, the least recently used evicted first. Lookups hand out a reference
 * that must be given back with hd_store_release; an evicted photo is freed when its last
 * reference goes. */
typedef struct hd_store {
    pthread_mutex_t lock;
    hd_serve_photo **slots;
    int max, count;
    unsigned long clock;
    long evictions;
} hd_store;

hd_status hd_store_init(hd_store *s, int max);
void hd_store_free(hd_store *s);
/* Adds p (which receives a fresh id); *evicted_id (17 bytes, may be NULL) gets the id of the photo
 * evicted to make room, or "". */
void hd_store_add(hd_store *s, hd_serve_photo *p, char *evicted_id);
/* The photo with this id (a reference), or NULL. */
hd_serve_photo *hd_store_get(hd_store *s, const char *id);
void hd_store_release(hd_store *s, hd_serve_photo *p);
/* Removes a photo; 0 if there was none. */
int hd_store_remove(hd_store *s, const char *id);
int hd_store_count(hd_store *s);

/* ------------------------------------------------------------ lights from requests (lights.c) */

/* A light from a JSON request body: {"light": [9 numbers]}, {"preset": K} or {"azimuth": AZ,
 * "elevation": EL [, "intensity": I] [, "ambient": A]} (defaults as `hdnet relight --dir`), and an
 * optional "brightness": "keep" (the default) or "free". The reason for a refusal goes to
 * `reason`. */
hd_status hd_light_from_json(const char *body, size_t n, float light[HD_SH_COEFFS], hd_brightness *brightness,
                             char *reason, size_t reason_size);
/* The same from a URL query's values (NULL when absent): preset, or azimuth and elevation with
 * intensity and ambient. */
hd_status hd_light_from_query(const char *preset, const char *azimuth, const char *elevation, const char *intensity,
                              const char *ambient, float light[HD_SH_COEFFS], char *reason, size_t reason_size);
/* A light as a DPR-style text file (9 numbers, one a line, %.9g), malloc'ed. */
char *hd_light_text(const float light[HD_SH_COEFFS]);

/* ------------------------------------------------------------ the page (assets.c, generated) */

typedef struct hd_serve_asset {
    const char *path; /* "/", "/app.js", ... */
    const char *type; /* the Content-Type */
    const unsigned char *data;
    size_t size;
} hd_serve_asset;
extern const hd_serve_asset hd_serve_assets[]; /* ends with path NULL */

/* ------------------------------------------------------------ the server (server.c) */

typedef struct hd_serve_options {
    const char *host;       /* the address to bind, "127.0.0.1" by default */
    int port;               /* 0: any free port */
    const char *model_path; /* NULL: the shipped model */
    int threads;            /* OpenMP threads of the library (0: its default) */
    size_t max_upload;      /* bytes of one request body */
    long max_pixels;        /* decoded pixels of one photo */
    int max_photos;         /* photos kept in memory */
    int timeout_s;          /* an idle connection is closed after this */
    int max_connections;
} hd_serve_options;

typedef struct hd_server hd_server;

/* Loads the model and starts listening; *port_out gets the bound port. */
hd_status hd_server_start(const hd_serve_options *o, hd_server **out, int *port_out);
/* Stops accepting, waits for the connections in progress, frees everything. */
void hd_server_stop(hd_server *s);

#endif /* HD_SERVE_H */
