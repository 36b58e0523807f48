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

/* ---------------------------------------------------------------- version */

/* The version this header belongs to (the shared library's soname carries the major number). */
#define HDNET_VERSION_MAJOR 0
#define HDNET_VERSION_MINOR 1
#define HDNET_VERSION_PATCH 0
/* The version of the library actually linked, "MAJOR.MINOR.PATCH" (a static string); compare it
 * with the macros to catch a header and a library that do not match. */
const char *hd_version(void);

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
/* Every output file is written to a temporary name and renamed into place, so it appears whole
 * or not at all. By default each is also fsynced before the rename (durable across power loss);
 * bulk writers (data generation, batch decomposition) may turn that off for pictures with
 * hd_set_durable_writes(0). Checkpoints and models are always fsynced. */
void hd_set_durable_writes(int on);
/* Number of OpenMP threads the library uses inside each call (0 = the OpenMP default), for calls
 * from every thread (decompose and align apply it on the calling thread). */
void hd_set_threads(int threads);

/* ---------------------------------------------------------------- images (src/io) */

/* Maximum width or height accepted from any file. */
#define HD_IMAGE_MAX_SIDE 16384
/* Maximum pixel count (width x height) any image reader decodes, checked from the header before
 * anything is allocated: HD_DEFAULT_MAX_PIXELS (100 megapixels), or the environment variable
 * HDNET_MAX_PIXELS, or what hd_set_max_pixels set (0 restores the default). */
#define HD_DEFAULT_MAX_PIXELS 100000000LL
void hd_set_max_pixels(long long pixels);

typedef struct hd_image {
    int width, height, channels;
    float *data; /* (channels, height, width), data[(c * height + y) * width + x] */
} hd_image;

/* Allocates a zeroed image; frees nothing on failure. */
hd_status hd_image_alloc(hd_image *img, int width, int height, int channels);
void hd_image_free(hd_image *img);
/* Reads PNG (8/16 bit gray, gray+alpha, RGB, RGBA, palette), JPEG or PFM, chosen by the file's
 * magic bytes, and converts to `channels` (1: luma 0.299/0.587/0.114, 3: RGB with alpha dropped
 * and gray replicated). A JPEG is turned upright by its EXIF orientation (tag 0x0112: mirrored and
 * rotated as the tag says it is to be shown; 5-8 swap width and height), so every caller sees the
 * photo as a viewer shows it. */
hd_status hd_image_read_as(const char *path, int channels, hd_image *img);
/* Converts between 1, 2, 3 and 4 channels as hd_image_read_as does; dst is allocated. */
hd_status hd_image_convert(const hd_image *src, int channels, hd_image *dst);
/* HD_ERR_NUMERIC with a reason "WHAT: N of M samples are not finite (first at channel C, x X,
 * y Y)" when any sample is NaN or infinite; HD_OK otherwise. Every image writer refuses a
 * non-finite image this way (nothing is written); callers check first to name the stage. */
hd_status hd_image_check_finite(const hd_image *img, const char *what);
/* Writes PNG with 8 or 16 bits per channel (values clamped to [0, 1]); 1-4 channels. The file is
 * written to a temporary name and renamed, so a failure leaves no partial output. */
hd_status hd_image_write_png(const char *path, const hd_image *img, int bits);
/* Writes PFM (exact float32), 1 or 3 channels; also atomic. */
hd_status hd_image_write_pfm(const char *path, const hd_image *img);
/* The formats images are written in. */
typedef enum hd_image_format {
    HD_FORMAT_PNG = 0, /* 8 bits per channel, 1-4 channels, values clamped to [0, 1] */
    HD_FORMAT_JPEG,    /* 8-bit gray or RGB (alpha dropped), at a quality 1..100 (0: 95) */
    HD_FORMAT_PFM      /* exact float32, 1 or 3 channels */
} hd_image_format;
/* Writes img in the format of path's extension (.png, .jpg / .jpeg, .pfm, any case; anything else
 * is HD_ERR_ARG naming the path, never a PNG under another name), atomically; quality is the
 * JPEG quality (1..100, 0 for the default 95), ignored otherwise. */
hd_status hd_image_write(const char *path, const hd_image *img, int quality);
/* hd_image_write(path, img, 0): PNG, JPEG or PFM by extension. */
hd_status hd_image_write_picture(const char *path, const hd_image *img);

/* Resizes to width x height: area filter when shrinking, bilinear when enlarging (per axis). */
hd_status hd_image_resize(const hd_image *src, int width, int height, hd_image *dst);

/* What a file held, as hd_image_read_info reports it. */
typedef struct hd_image_info {
    const char *format; /* "PNG", "JPEG" or "PFM" (a static string) */
    int width, height;
    int channels;       /* as stored (palette: 3 or 4 after expansion) */
    int bits;           /* bits per sample in the file: 1, 2, 4, 8 or 16; 32 for PFM */
    int palette;        /* 1 for a palette PNG */
    int orientation;    /* the EXIF orientation applied (JPEG; 1: none), width and height after it */
} hd_image_info;
/* Reads as stored (channels as in the file; palette expands to RGB or RGBA) and describes the file;
 * info may be NULL. */
hd_status hd_image_read_info(const char *path, hd_image *img, hd_image_info *info);
/* Images in memory, for servers and bindings that never touch files. hd_image_decode reads a PNG,
 * JPEG or PFM held in data[0..size) exactly as hd_image_read_info reads a file (magic bytes, EXIF
 * orientation, the same checks; errors say "<memory>"); info may be NULL. hd_image_encode writes
 * img in `format` into a new buffer *data of *size bytes (free it with hd_buffer_free), the same
 * bytes hd_image_write would put in a file. */
hd_status hd_image_decode(const void *data, size_t size, hd_image *img, hd_image_info *info);
hd_status hd_image_encode(const hd_image *img, hd_image_format format, int quality, unsigned char **data,
                          size_t *size);
void hd_buffer_free(void *data);

/* Normal maps: rgb = (n + 1) / 2 in files. Decoding renormalises to unit length and sets the
 * mask to 0 where the stored vector is (near) zero; `mask` may be NULL. */
hd_status hd_normal_decode(const hd_image *rgb, hd_image *normal, hd_image *mask);
/* Encodes unit normals; pixels with mask <= 0.5 are written as 0 (mask may be NULL). */
hd_status hd_normal_encode(const hd_image *normal, const hd_image *mask, hd_image *rgb);
/* In place: each pixel's vector of a 3-channel normal map over its length (0 where it is shorter
 * than 1e-6); nothing for another channel count. */
void hd_normal_renormalise(hd_image *normal);
/* A normal map resized (hd_image_resize) and renormalised: blends of unit vectors are shorter. */
hd_status hd_normal_resize(const hd_image *normal, int width, int height, hd_image *out);

/* Contact sheets (src/io/sheet.c): a grid of square cells separated by plain borders, written as an
 * 8-bit RGB PNG. Each picture is resized to the cell (area down, bilinear up). */
typedef enum hd_sheet_kind {
    HD_SHEET_PICTURE = 0, /* values as stored; 1 channel shown gray, 2 (gray + alpha) as gray */
    HD_SHEET_NORMAL,      /* unit normals shown as (n + 1) / 2, zero vectors black */
    HD_SHEET_SHADING      /* shading shown as s / 2 (1 channel) */
} hd_sheet_kind;

typedef struct hd_sheet {
    int rows, columns, cell, border;
    hd_image canvas; /* 3 channels, (columns * (cell + border) + border) wide */
} hd_sheet;

hd_status hd_sheet_init(hd_sheet *sheet, int rows, int columns, int cell, int border);
hd_status hd_sheet_put(hd_sheet *sheet, int row, int column, const hd_image *picture, hd_sheet_kind kind);
hd_status hd_sheet_write(const hd_sheet *sheet, const char *path);
void hd_sheet_free(hd_sheet *sheet);

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

/* ---------------------------------------------------------------- lighting (src/light) */

#define HD_SH_COEFFS 9
#define HD_LIGHT_PRESETS 7

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
/* Largest |coefficient| a light file may hold: the shading of such a light (at most about
 * 10 x HD_LIGHT_MAX_COEFF) and everything computed from it stay far from float overflow. */
#define HD_LIGHT_MAX_COEFF 1e6f
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
/* A coloured light: 9 SH coefficients per colour channel (R, G, B), same frame and scale as a grey
 * light (docs/formats.md, "RGB light files"). A grey light is three equal rows. */
typedef struct hd_light_rgb {
    float sh[3][HD_SH_COEFFS];
} hd_light_rgb;
void hd_light_rgb_from_grey(const float light[HD_SH_COEFFS], hd_light_rgb *out);
/* 1 when the three rows are equal. */
int hd_light_rgb_is_grey(const hd_light_rgb *light);
/* A light file of 9 numbers (grey) or 27 (red's 9, then green's, then blue's), one or more a
 * line; errors name the file. Writing gives 9 lines for a grey light, else 27. */
hd_status hd_light_read_rgb(const char *path, hd_light_rgb *light);
hd_status hd_light_write_rgb(const char *path, const hd_light_rgb *light);
/* hd_light_from_direction times a colour (linear RGB factors, each >= 0). */
void hd_light_rgb_from_direction(float azimuth_deg, float elevation_deg, float intensity, float ambient,
                                 const float colour[3], hd_light_rgb *light);
/* The light of an equirectangular environment map (RGB, any size; the centre column looks from
 * the viewer toward the face, u grows toward the image's right (azimuth), the top row is straight
 * up), turned by rotation_deg about the vertical axis (positive: the map's content moves toward
 * the image's right): the diffuse shading (1/pi) int L(w) max(n.w, 0) dw, fitted with 9 SH
 * coefficients per channel (a uniform map of radiance 1 gives shading 1). */
hd_status hd_light_from_envmap(const hd_image *map, float rotation_deg, hd_light_rgb *light);
/* A size x size RGB picture of the light on a unit sphere (background black), shown as s / 2. */
hd_status hd_light_rgb_sphere(const hd_light_rgb *light, int size, hd_image *out);

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
    hd_image reconstruction; /* albedo * shading * camera_tint: the input as the model explains it */
    float light[HD_SH_COEFFS];
    /* The colour cast of the input (per-channel gains of mean 1, clamped to 0.7..1.4) that the model
     * divided out before decomposing it (HD_WHITE_BALANCE_EYES); 1, 1, 1 without (the default).
     * The albedo and shading are those of the balanced face. */
    float camera_tint[3];
} hd_decomposition;

/* What hd_model_decompose does about the camera's colour cast. OFF (the default): the input goes
 * to the network as it is. EYES: the input's tint is read from the whites of its eyes
 * (src/model/white_balance.c) and divided out before the network sees it: for photos with a strong cast
 * (a warm white balance: albedo error 0.072 -> 0.048 on synthetic faces), at a cost on blurred or
 * JPEG-compressed faces of neutral balance (docs/usage.md, "White balance"). */
typedef enum { HD_WHITE_BALANCE_OFF = 0, HD_WHITE_BALANCE_EYES = 1 } hd_white_balance;
/* Sets it for every later call with this model (not while another thread decomposes with it). */
hd_status hd_model_set_white_balance(hd_model *model, hd_white_balance mode);

/* What relighting a photo does to its background. KEEP (the default): the input, bit for bit.
 * RELIGHT: the background takes the change of a flat wall facing the camera under the same lights
 * (one factor per channel, from the first face's own light; docs/usage.md, "The background"), and
 * the person's body below the chin, clothes and all, takes the light on a torso proxy; it
 * needs the person segmentation to find each face's person (else HD_ERR_ARG). Photos only:
 * an aligned texture has no background. Sets it for every later call with this model. */
typedef enum { HD_BACKGROUND_KEEP = 0, HD_BACKGROUND_RELIGHT = 1 } hd_background;
hd_status hd_model_set_background(hd_model *model, hd_background mode);
hd_background hd_model_background(const hd_model *model);

/* What relighting a photo does about the shadows a face casts on itself: the nose's on the cheek,
 * the brows' on the eyes, the upper lip's on the lower (docs/usage.md, "Cast shadows"). CAST (the
 * default): the face mesh in the head's pose casts the distant part of the face's own light and
 * of the target light, and the ratio rule takes both into account. NONE: no cast shadows (the rule
 * as it was before them). An aligned texture has no pose, so never any. Sets it for every later
 * call with this model. */
typedef enum { HD_SHADOWS_CAST = 0, HD_SHADOWS_NONE = 1 } hd_shadows;
hd_status hd_model_set_shadows(hd_model *model, hd_shadows mode);
hd_shadows hd_model_shadows(const hd_model *model);

/* Decomposes `count` aligned face images (1-4 channels are converted to RGB; any size: each is
 * resized to the model size), in batches of up to 4. Results are at the model size; out[i] is
 * filled for images[i] (free each with hd_decomposition_free); on failure nothing is left
 * allocated. Thread-safe: one model serves any number of threads at once (its weights are
 * read-only; each call works in a workspace of its own, taken from the model's pool and kept
 * there for the next call, so the first call of each batch size in each concurrent thread
 * allocates it). Results depend only on the images and their count, never on other threads. */
hd_status hd_model_decompose(hd_model *model, const hd_image *images, int count, hd_decomposition *out);
void hd_decomposition_free(hd_decomposition *d);

/* ---------------------------------------------------------------- photo alignment (src/align) */

/* From a photograph to the aligned texture space of SPEC section 2 and back (docs/alignment.md).
 *
 * Frames. Photo coordinates are continuous pixels: x right, y down, pixel (i, j) covers
 * [i, i+1) x [j, j+1), so its centre is (i + 0.5, j + 0.5). Landmarks are the 468 vertices of the
 * canonical mesh as found in the photo: (x, y) in photo coordinates and a depth z in the same
 * units as x; which way z points is found by the fit (see depth_sign). Texture coordinates are
 * the canonical mesh's UVs (u right, v down) scaled to the texture side S, texel (x, y) centred
 * at ((x + 0.5) / S, (y + 0.5) / S). Normals are in the camera frame (x right, y up, z toward the
 * viewer). */

#define HD_FACE_LANDMARKS 468

typedef struct hd_aligned_face {
    int size;          /* texture side S */
    hd_image texture;  /* 3 x S x S: the photo unwarped (0 outside the mesh's UV layout) */
    hd_image mask;     /* 1 x S x S: 1 where the texel is inside the mesh, on a triangle facing
                        * the camera, not hidden by another part of the face, its normal has
                        * z > 0 and it falls inside the photo; else 0 */
    hd_image normal;   /* 3 x S x S: coarse normals, unit, camera frame; 0 where mask is 0 */
    float landmarks[HD_FACE_LANDMARKS][3]; /* photo coordinates (x, y) and depth z */
    int photo_width, photo_height;         /* the photo the face was found in */
    float score;       /* detector confidence in [0, 1] (1 when landmarks were given) */
    float box[4];      /* detection box x0, y0, x1, y1 in photo coordinates (the landmarks'
                        * bounding box when the landmarks were given) */
    /* The similarity fit of the canonical mesh P (cm, camera-style frame) to the landmarks,
     * taken to the camera frame as c = (x, -y, depth_sign * z):
     *   c_i ~ scale * rotation * P_i + translation  (rotation row-major, det +1). */
    float scale, rotation[9], translation[3];
    float depth_sign;  /* +1 when landmark z grows toward the viewer, -1 when away (MediaPipe) */
    float fit_rms;     /* root-mean-square residual of the fit, in pixels */
    /* Where the person is about this face (MediaPipe's selfie segmentation on a crop posed by the
     * fit; docs/face_detect.md, "Where the person is"): 1 x w x h, the probability that each pixel
     * of the photo's window from (person_x0, person_y0) shows the person. Filled by an aligner's
     * run; empty (data NULL) for a face aligned from given landmarks, which the relighting then
     * tells from its background by colour alone. */
    hd_image person;
    int person_x0, person_y0;
} hd_aligned_face;

/* Detects every face in `photo` (any channel count; converted to RGB), finds its landmarks and
 * aligns it at texture side `size`. *faces is an array of *count faces, largest score first.
 * When no face is found: HD_ERR_NOTFOUND ("no face found ...") with *faces NULL and *count 0. */
hd_status hd_align_photo(const hd_image *photo, int size, hd_aligned_face **faces, int *count);
/* The same for many photos: the detector and landmark models (shipped, found with the data search
 * path) are loaded once (about 0.5 s) and reused. Thread-safe: one aligner serves any number of
 * threads at once; a run that finds every loaded copy of the two models busy in other threads loads
 * another (0.5 s, about 3 MB), which stays for later runs. */
typedef struct hd_aligner hd_aligner;
hd_status hd_aligner_load(hd_aligner **aligner);
void hd_aligner_free(hd_aligner *aligner);
/* The face detection threshold hd_aligner_run uses from now on, in (0, 1] (default 0.75, the
 * detector's own; out of range: left as it was). */
void hd_aligner_set_min_score(hd_aligner *aligner, float min_score);
hd_status hd_aligner_run(hd_aligner *aligner, const hd_image *photo, int size, hd_aligned_face **faces, int *count);
/* Frees one face's images (the face hd_decompose_photo fills); hd_aligned_faces_free frees an
 * array of faces (hd_aligner_run's, hd_photo_faces') and the array. */
void hd_aligned_face_free(hd_aligned_face *face);
void hd_aligned_faces_free(hd_aligned_face *faces, int count);

/* Writes dir/<stem>.png (texture, 8 bit), <stem>.mask.png (8 bit), <stem>.normal.png (16 bit,
 * SPEC section 2 encoding), <stem>.landmarks.txt (468 lines "x y z") and <stem>.warp.txt (every
 * field of the face but the images: what hd_warp_back needs). Each file is written atomically. */
hd_status hd_aligned_face_write(const hd_aligned_face *face, const char *dir, const char *stem);
/* Reads a .warp.txt file into `face` (images left empty: size, landmarks, photo size, fit).
 * Errors name the file and the line. */
hd_status hd_aligned_face_read_warp(const char *path, hd_aligned_face *face);

/* Warps an aligned texture (any side, any channel count; e.g. a relit face at the model size)
 * back into photo space: for each pixel of the photo_width x photo_height frame, the front-most
 * front-facing landmark triangle under its centre gives barycentrics, hence a UV, where the
 * texture is sampled bilinearly using only texels with tex_mask > 0.5 (tex_mask, of any size, is
 * read at the texel's UV; NULL: face->mask, or if that is empty the texels inside the mesh's UV
 * layout). *warped gets the texture's channels, *coverage 1 channel: 1 where the pixel received a
 * face value, else 0 (and warped 0). */
hd_status hd_warp_back(const hd_aligned_face *face, const hd_image *texture, const hd_image *tex_mask,
                       hd_image *warped, hd_image *coverage);

/* What the Poisson solver did, per channel (up to 4). */
typedef struct hd_poisson_report {
    int unknowns;            /* pixels solved for */
    int channels;
    int iterations[4];       /* conjugate-gradient iterations */
    double residual[4];      /* final relative residual |b - A f| / |b| */
    double tolerance;        /* the tolerance asked for */
    double seconds;
} hd_poisson_report;

#define HD_POISSON_TOLERANCE 1e-4

/* Seamless cloning (Perez et al. 2003): places `source` in `target` with its top-left pixel at
 * (offset_x, offset_y) and, over the pixels where mask (1 channel, source-sized) > 0.5 and that
 * lie strictly inside both the source and the target (their 4 neighbours exist in both; the
 * others count as boundary), solves  Laplacian(f) = Laplacian(source)  with f = target on
 * the region's boundary (5-point stencil, source differences as the guidance field), in place in
 * `target`, per channel, by conjugate gradients preconditioned with a multigrid V-cycle, to the
 * relative residual `tolerance` (<= 0: HD_POISSON_TOLERANCE). Channels must match. Fails with
 * HD_ERR_NUMERIC if the solver cannot reach the tolerance. report may be NULL. */
hd_status hd_poisson_blend(const hd_image *source, const hd_image *mask, int offset_x, int offset_y,
                           double tolerance, hd_image *target, hd_poisson_report *report);

/* What hd_warp_back_blend puts into the photo. */
typedef enum hd_warp_mode {
    HD_WARP_REPLACE, /* the texture itself: the face is redrawn at the texture's resolution */
    HD_WARP_CHANGE   /* the photo plus the change the texture makes, texture - face->texture (the
                      * latter resampled to the texture's size): the photo's own detail is kept at
                      * full resolution, so a face larger than the texture stays sharp */
} hd_warp_mode;

/* Warps `texture` (an aligned result for `face`, e.g. a relit texture at any side, sampled where
 * face->mask > 0.5, or inside the UV layout if face->mask is empty) back into `photo` (the photo
 * the face came from, same size and channels as the texture) as `mode` says, and blends it in
 * with hd_poisson_blend (tolerance <= 0: HD_POISSON_TOLERANCE) over the warped region shrunk by
 * one pixel, so that outside the face the photo is untouched and no seam shows. report may be
 * NULL. A face entirely outside the photo leaves it unchanged (report->unknowns 0). */
hd_status hd_warp_back_blend(const hd_aligned_face *face, const hd_image *texture, hd_warp_mode mode,
                             double tolerance, hd_image *photo, hd_poisson_report *report);

/* ---------------------------------------------------------------- relighting (src/apply) */

/* How bright a relit face is. */
typedef enum hd_brightness {
    /* The relit face is scaled by one factor k >= 0 so that the mask-weighted mean over pixels and
     * channels of clamp(k * relit, 0, 1) equals that of the input (solved through the clamp). */
    HD_BRIGHTNESS_KEEP = 0,
    HD_BRIGHTNESS_FREE /* the target light's own level */
} hd_brightness;

/* ---- applying a model to a texture or a photo: the one home (src/apply/apply.c, docs/usage.md
 * "The relighting rule"). */
typedef enum hd_relight_rule {
    /* out = I * (s(N, l_target) + g) / (s(N, l_source) + g): l_source the face's own light (hd_face_light), g a
     * guard; the eyes, the inside of the mouth and the brows take the change of the skin around
     * them; the change fades to nothing at the face's edge (feathered), the rest is the input's bit
     * for bit. Exactly the identity when the light does not change. The default. */
    HD_RULE_RATIO = 0,
    /* The paper's A_final = I / S times s(N, l_target) (src/apply/relight.c), Poisson-blended into
     * a photo: kept to measure against (hdnet eval --rule paper). */
    HD_RULE_PAPER
} hd_relight_rule;

/* The face's own light, l_source of the ratio rule (docs/usage.md, "The source light"). */
typedef enum hd_source_light {
    /* The least-squares light of the predicted shading S on the predicted normals N over the
     * face's skin (its mask without the eyes, the inside of the mouth and the brows): hd_face_light. */
    HD_SOURCE_FIT = 0,
    /* L-Net's estimate, the decomposition's light. */
    HD_SOURCE_LNET
} hd_source_light;

/* HD_SOURCE_FIT's pull toward the face's best ambient + distant light (the strength of the prior). */
#define HD_SOURCE_PRIOR 0.1f
/* The ratio rule's guard g = HD_RATIO_GUARD x the face's mean source shading over its skin. */
#define HD_RATIO_GUARD 0.01f

/* What to make of each face. Zero-filled fields past `brightness` take the defaults. */
typedef struct hd_apply_request {
    const hd_light_rgb *lights; /* count target lights (may be NULL when count is 0) */
    int count;
    int delight;                /* also the face under flat light */
    int self;                   /* also the face under its own light (the identity) */
    hd_relight_rule rule;
    hd_brightness brightness;   /* for the lights and the delit face */
    hd_source_light source;     /* the face's own light (ratio rule) */
    float guard;                /* g as a share of the mean source shading; <= 0: HD_RATIO_GUARD */
    const char *operation;      /* what the caller asked for, naming it in error reasons ("delight",
                                   "transfer", "eval"); NULL: "relight" */
} hd_apply_request;

/* The face's own light of a decomposition, as the ratio rule uses it: HD_SOURCE_LNET copies
 * d->light; HD_SOURCE_FIT fits d->shading on d->normal over the texels where mask
 * (1 channel, any size, resized to the decomposition's; NULL: all) is > 0.5 outside the face
 * regions a face model does not explain, the face below the nose weighted a quarter (an
 * expression moves it, the light does not; docs/usage.md, "The source light"): the weighted
 * least-squares light pulled (HD_SOURCE_PRIOR) toward the best ambient + distant light
 * (src/light/fit.c) of the same weighted shading. The weight assumes the decomposition is in the
 * aligned texture layout (docs/spec.md section 2), as every decomposition hd_model_decompose
 * makes is. */
hd_status hd_face_light(const hd_decomposition *d, const hd_image *mask, hd_source_light source,
                        float light[HD_SH_COEFFS]);
/* The light of a reference face, the target light a transfer takes from it (hd_estimate_light,
 * `hdnet transfer --ref`, `hdnet estimate-light`): with HD_SOURCE_FIT the fit of hd_face_light with
 * each texel weighted by 1 / max(n_z, 0.5)^2 and a weaker pull toward the lobe (src/mesh/reference_light.c;
 * docs/evaluation.md: its direction is nearer the truth on real photos); with HD_SOURCE_LNET d->light.
 * It is not the face's own light: relighting a face under its reference light changes it a little. */
hd_status hd_reference_light(const hd_decomposition *d, const hd_image *mask, hd_source_light source,
                             float light[HD_SH_COEFFS]);

/* What comes back: pictures of the input's size (a photo: copies of the photo with every face
 * changed; a texture: the texture). */
typedef struct hd_apply_result {
    hd_image *relit;                       /* count pictures */
    int count;
    hd_image delit, self;                  /* when asked for */
    int nfaces;
    float (*face_light)[HD_SH_COEFFS];     /* nfaces: each face's own light (the request's source) */
    hd_aligned_face *faces;                /* a photo's nfaces faces as aligned; NULL for a texture */
} hd_apply_result;

/* A photo (3 channels): every face aligned, decomposed once, changed as asked. No face:
 * HD_ERR_NOTFOUND and nothing allocated. */
hd_status hd_apply_photo(hd_model *model, hd_aligner *aligner, const hd_image *photo, const hd_apply_request *request,
                         hd_apply_result *result);
/* An aligned face texture (3 channels) with its mask (1 channel, any size; NULL: all ones). */
hd_status hd_apply_texture(hd_model *model, const hd_image *texture, const hd_image *mask,
                           const hd_apply_request *request, hd_apply_result *result);
void hd_apply_result_free(hd_apply_result *result);

/* Grey-light shortcuts with a model, texture in, texture out: each decomposes its aligned face
 * texture(s) one at a time and applies the ratio rule (hd_apply_texture; hd_delight_face keeps the
 * brightness). */
hd_status hd_relight_face(hd_model *model, const hd_image *image, const hd_image *mask,
                          const float light[HD_SH_COEFFS], hd_brightness brightness, hd_image *out);
hd_status hd_delight_face(hd_model *model, const hd_image *image, const hd_image *mask, hd_image *out);
/* The face's own light, as the ratio rule takes it (hd_face_light with HD_SOURCE_FIT: the fit of
 * the predicted shading on the predicted normals, pulled toward its best ambient + distant light;
 * over the whole texture without the face regions). decompose's light stays L-Net's. */
hd_status hd_estimate_light(hd_model *model, const hd_image *image, float light[HD_SH_COEFFS]);
/* The same with a mask (1 channel, any size; NULL: all ones) and a choice of source. */
hd_status hd_estimate_face_light(hd_model *model, const hd_image *image, const hd_image *mask, hd_source_light source,
                                 float light[HD_SH_COEFFS]);

/* The mask of a face image: its companion NAME.mask.png beside the image (NAME = the file name
 * without its last extension) if present, else fallback (a path, may be NULL), else all ones; one
 * channel resized to width x height. *source (may be NULL) receives the path used, malloc'ed
 * (NULL for all ones). */
hd_status hd_face_mask_read(const char *image_path, const char *fallback, int width, int height,
                            hd_image *mask, char **source);

/* Photos and aligned textures (src/apply/photo.c; the calls on a whole photo: calls.c;
 * docs/usage.md). The commands take a photograph
 * by default and an aligned texture with --aligned, or when the file has an aligned companion
 * (NAME.mask.png or NAME.normal.png) beside it. */
typedef enum hd_input_kind { HD_INPUT_PHOTO = 0, HD_INPUT_TEXTURE } hd_input_kind;
hd_input_kind hd_input_kind_of(const char *path);

/* Every face of `photo` aligned (hd_aligner_run) at max(256, model size) texels a side, so the
 * relit texture keeps more detail than the model's own size; no face at all is
 * HD_ERR_NOTFOUND ("no face found"). Free with hd_aligned_faces_free. */
hd_status hd_photo_faces(hd_aligner *aligner, const hd_model *model, const hd_image *photo,
                         hd_aligned_face **faces, int *count);
/* Relights every face of a photo (3 channels) under each of `count` grey lights (count may be 0)
 * by the ratio rule: hd_apply_photo with HD_RULE_RATIO, relit[i] a copy of the photo with every
 * face changed, feathered from its edge. delit (may be NULL) gets the delit faces likewise. *nfaces (may be NULL) gets the faces done.
 * No face: HD_ERR_NOTFOUND and nothing allocated. Pixels outside the faces keep the photo exactly. */
hd_status hd_relight_photo(hd_model *model, hd_aligner *aligner, const hd_image *photo,
                           const float (*lights)[HD_SH_COEFFS], int count, hd_brightness brightness,
                           hd_image *relit, hd_image *delit, int *nfaces);
/* The own light (HD_SOURCE_FIT) of the best-scoring face of a photo (its aligned texture and mask):
 * face_light[0] of hd_apply_photo. */
hd_status hd_estimate_light_photo(hd_model *model, hd_aligner *aligner, const hd_image *photo,
                                  float light[HD_SH_COEFFS], int *nfaces);
/* The same with a choice of source. */
hd_status hd_estimate_face_light_photo(hd_model *model, hd_aligner *aligner, const hd_image *photo,
                                       hd_source_light source, float light[HD_SH_COEFFS], int *nfaces);
/* The decomposition (at the model's size, in the aligned texture space) of the best-scoring face
 * of a photo; face (may be NULL) receives that face (free with hd_aligned_face_free). */
hd_status hd_decompose_photo(hd_model *model, hd_aligner *aligner, const hd_image *photo, hd_decomposition *d,
                             hd_aligned_face *face);
/* Every face of photo relit under the light estimated for the best face of reference (a photo):
 * hd_estimate_light_photo then hd_relight_photo, as `hdnet transfer` does with photos. */
hd_status hd_transfer_photo(hd_model *model, hd_aligner *aligner, const hd_image *photo, const hd_image *reference,
                            hd_brightness brightness, hd_image *out, int *nfaces);
/* A photo decomposed (what `hdnet decompose` writes for a photo): every face aligned and decomposed
 * (d[k] at the model's size), the photo with each face's reconstruction A * S warped back and
 * Poisson-blended in (HD_WARP_REPLACE), and the maps warped back into the photo's frame at its
 * full resolution: albedo (3), shading (1), normals (3, unit; 0 outside), and the face mask (1:
 * 1 where a face's visible part lands, else 0); where faces overlap, the better-scoring one. person
 * (1): where the people are, the largest of the faces' person maps (hd_aligned_face.person; 0
 * beyond their windows). */
typedef struct hd_photo_maps {
    int nfaces;
    hd_aligned_face *faces;
    hd_decomposition *d;
    hd_image recon, albedo, shading, normal, mask, person;
} hd_photo_maps;
hd_status hd_decompose_photo_maps(hd_model *model, hd_aligner *aligner, const hd_image *photo, hd_photo_maps *maps);
void hd_photo_maps_free(hd_photo_maps *maps);

/* A decomposition on a contact sheet (hd_sheet, with the images above): fills columns 0..4 of row
 * with input | albedo | shading | normal | reconstruction. */
hd_status hd_sheet_put_decomposition(hd_sheet *sheet, int row, const hd_image *input,
                                     const hd_decomposition *d);

#ifdef __cplusplus
}
#endif

#endif /* HDNET_H */
