/* hdnet.h: the public API of libhdnet, face inverse rendering and relighting (HD-Net) in plain C.
 *
 * Every exported name starts with hd_. Calls that can fail return an hd_status; on failure
 * hd_error() gives a one-line reason that names the file and what is wrong. The library never
 * prints and never exits: the caller decides.
 *
 * Images are float32, planar (channel-major, like one NCHW tensor of batch 1), values in [0, 1]
 * as stored in the file (no gamma conversion). Normals are unit vectors in the camera frame
 * (x right, y up, z toward the viewer). Lights are 9 spherical-harmonics coefficients in the
 * order, frame and scale of DPR's light files (see docs/conventions.md).
 *
 * Example (compiled by tests/test_header_example.c, which includes this block verbatim):
 *
 *     #include <stdio.h>
 *     #include "hdnet.h"
 *
 *     // Preview a light lit from the upper right on a sphere, and shade two normals with it.
 *     int example(const char *out_png) {
 *         float light[HD_SH_COEFFS];
 *         hd_light_from_direction(45.0f, 30.0f, 1.0f, 0.5f, light);
 *         hd_image sphere = {0};
 *         if (hd_light_sphere(light, 128, &sphere) != HD_OK ||
 *             hd_image_write_png(out_png, &sphere, 8) != HD_OK) {
 *             fprintf(stderr, "hdnet: %s\n", hd_error());
 *             hd_image_free(&sphere);
 *             return 1;
 *         }
 *         hd_image_free(&sphere);
 *         float n[3 * 2] = {0, 1,  0, 0,  1, 0}; // planar: x, y, z of (0,0,1) and (1,0,0)
 *         float s[2];
 *         hd_sh_shading_map(n, NULL, 2, light, s);
 *         printf("shading toward the viewer %.3f, toward the right %.3f\n", s[0], s[1]);
 *         return 0;
 *     }
 */
#ifndef HDNET_H
#define HDNET_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ---------------------------------------------------------------- status and errors (core) */

typedef enum hd_status {
    HD_OK = 0,
    HD_ERR_IO,          /* a file could not be opened, read or written */
    HD_ERR_FORMAT,      /* a file is malformed, truncated or of an unsupported variant */
    HD_ERR_RANGE,       /* a size or value is out of the accepted range */
    HD_ERR_NOMEM,       /* an allocation failed */
    HD_ERR_ARG,         /* the caller passed an invalid argument */
    HD_ERR_NUMERIC,     /* a NaN or infinity appeared where a finite number was required */
    HD_ERR_INTERRUPTED, /* stopped on request (signal or time limit); state was saved */
    HD_ERR_NOTFOUND     /* the thing looked for is not there (no face, no tensor, ...) */
} hd_status;

/* The reason for the last failure on this thread ("" if none). */
const char *hd_error(void);
/* A short name for a status code ("format error", ...). */
const char *hd_status_name(hd_status status);
/* Number of OpenMP threads the library uses (0 = the OpenMP default). */
void hd_set_threads(int threads);
int hd_threads(void);

/* ---------------------------------------------------------------- images (src/io) */

/* Maximum width or height accepted from any file. */
#define HD_IMAGE_MAX_SIDE 16384

typedef struct hd_image {
    int width, height, channels;
    float *data; /* (channels, height, width), data[(c * height + y) * width + x] */
} hd_image;

/* Allocates a zeroed image; frees nothing on failure. */
hd_status hd_image_alloc(hd_image *img, int width, int height, int channels);
void hd_image_free(hd_image *img);
/* Reads PNG (8/16 bit gray, gray+alpha, RGB, RGBA, palette), JPEG or PFM, chosen by the file's
 * magic bytes. Channels as stored (palette expands to RGB or RGBA). */
hd_status hd_image_read(const char *path, hd_image *img);
/* Reads and converts to `channels` (1: luma 0.299/0.587/0.114, 3: RGB with alpha dropped and
 * gray replicated). */
hd_status hd_image_read_as(const char *path, int channels, hd_image *img);
/* Converts between 1, 2, 3 and 4 channels as hd_image_read_as does; dst is allocated. */
hd_status hd_image_convert(const hd_image *src, int channels, hd_image *dst);
/* Writes PNG with 8 or 16 bits per channel (values clamped to [0, 1]); 1-4 channels. The file is
 * written to a temporary name and renamed, so a failure leaves no partial output. */
hd_status hd_image_write_png(const char *path, const hd_image *img, int bits);
/* Writes PFM (exact float32), 1 or 3 channels; also atomic. */
hd_status hd_image_write_pfm(const char *path, const hd_image *img);
/* Resizes to width x height: area filter when shrinking, bilinear when enlarging (per axis). */
hd_status hd_image_resize(const hd_image *src, int width, int height, hd_image *dst);

/* Normal maps: rgb = (n + 1) / 2 in files. Decoding renormalises to unit length and sets the
 * mask to 0 where the stored vector is (near) zero; `mask` may be NULL. */
hd_status hd_normal_decode(const hd_image *rgb, hd_image *normal, hd_image *mask);
/* Encodes unit normals; pixels with mask <= 0.5 are written as 0 (mask may be NULL). */
hd_status hd_normal_encode(const hd_image *normal, const hd_image *mask, hd_image *rgb);

/* ---------------------------------------------------------------- checkpoints (src/io) */

#define HD_TENSOR_MAX_DIMS 8

typedef struct hd_tensor {
    const char *name;
    int ndim;
    int64_t shape[HD_TENSOR_MAX_DIMS];
    float *data; /* F32, row-major */
} hd_tensor;

typedef struct hd_safetensors {
    int count;
    hd_tensor *tensors;
    int meta_count;
    char **meta_keys;
    char **meta_values;
    void *storage; /* owns names, data and metadata */
} hd_safetensors;

/* Reads a safetensors file of F32 tensors. Every offset, shape, overlap and length is checked
 * against the file size before any data is touched. */
hd_status hd_safetensors_read(const char *path, hd_safetensors *st);
void hd_safetensors_free(hd_safetensors *st);
const hd_tensor *hd_safetensors_find(const hd_safetensors *st, const char *name);
/* The metadata value for key, or NULL. */
const char *hd_safetensors_meta(const hd_safetensors *st, const char *key);
/* Writes tensors (F32) and string metadata to a temporary file, fsyncs and renames it. */
hd_status hd_safetensors_write(const char *path, const hd_tensor *tensors, int count,
                               const char *const *meta_keys, const char *const *meta_values,
                               int meta_count);

/* ---------------------------------------------------------------- lighting (src/light) */

#define HD_SH_COEFFS 9
#define HD_LIGHT_PRESETS 7

/* The 9 basis values b_k(n) of SPEC section 2 for a camera-frame normal n. */
void hd_sh_basis(const float normal[3], float basis[HD_SH_COEFFS]);
/* s(n) = sum_k l_k b_k(n). */
float hd_sh_shade(const float light[HD_SH_COEFFS], const float normal[3]);
/* Shading of npix planar normals (x[npix], y[npix], z[npix]); where mask (may be NULL) is <= 0
 * the shading is 0. */
void hd_sh_shading_map(const float *normal, const float *mask, int npix,
                       const float light[HD_SH_COEFFS], float *shading);
/* Masked least-squares light: argmin_l sum_p m_p (b(n_p).l - s_p)^2 over m_p > 0, in double
 * precision through the ridged 9x9 normal equations. mask may be NULL (all ones). */
hd_status hd_sh_fit(const float *normal, const float *shading, const float *mask, int npix,
                    float light[HD_SH_COEFFS]);
/* Light files: 9 numbers, DPR order. Errors name the file and line. */
hd_status hd_light_read(const char *path, float light[HD_SH_COEFFS]);
hd_status hd_light_write(const char *path, const float light[HD_SH_COEFFS]);
/* A gray light of DPR's scale from a direction: azimuth and elevation in degrees (see
 * docs/conventions.md), the directional intensity and the ambient level. The light comes from
 * d = (cos(el) sin(az), sin(el), cos(el) cos(az)) in the camera frame (azimuth 0, elevation 0 = from
 * the viewer; positive azimuth toward image right, positive elevation up); the shading is largest
 * at n = d, where s(d) = ambient + intensity. The defaults below give DPR-like shading
 * (about 0.44 to 2.0 on the visible hemisphere). */
#define HD_LIGHT_DEFAULT_INTENSITY 1.5f
#define HD_LIGHT_DEFAULT_AMBIENT 0.5f
void hd_light_from_direction(float azimuth_deg, float elevation_deg, float intensity,
                             float ambient, float light[HD_SH_COEFFS]);
/* Preset k in [0, HD_LIGHT_PRESETS): one light circling the view axis. */
hd_status hd_light_preset(int k, float light[HD_SH_COEFFS]);
/* A size x size RGB picture of the light on a unit sphere (background black). */
hd_status hd_light_sphere(const float light[HD_SH_COEFFS], int size, hd_image *out);

/* ---------------------------------------------------------------- the model (src/model) */

typedef struct hd_model hd_model;

/* Loads a model (safetensors, SPEC section 6); checks every tensor's name and shape against the
 * configuration in its metadata. path NULL loads the shipped default (models/hdnet-synth.safetensors
 * found with the data search path). */
hd_status hd_model_load(const char *path, hd_model **model);
void hd_model_free(hd_model *model);
int hd_model_size(const hd_model *model);  /* input side (a multiple of 32) */
int hd_model_width(const hd_model *model); /* Common-Net width */

typedef struct hd_decomposition {
    hd_image albedo;         /* 3 channels in [0, 1] */
    hd_image shading;        /* 1 channel, >= 0 */
    hd_image normal;         /* 3 channels, unit camera-frame vectors */
    hd_image reconstruction; /* albedo * shading */
    float light[HD_SH_COEFFS];
} hd_decomposition;

/* Decomposes `count` aligned face images (3 channels, any size: each is resized to the model
 * size). Results are at the model size; out[i] is filled for images[i]. */
hd_status hd_model_decompose(hd_model *model, const hd_image *images, int count, hd_decomposition *out);
void hd_decomposition_free(hd_decomposition *d);

/* ---------------------------------------------------------------- relighting (src/apply) */

/* ---------------------------------------------------------------- synthetic faces (src/synth) */

/* ---------------------------------------------------------------- evaluation (src/eval) */

/* ---------------------------------------------------------------- photo alignment (src/align) */

#ifdef __cplusplus
}
#endif

#endif /* HDNET_H */
