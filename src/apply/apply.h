/* apply.h: internal to src/apply: the pieces of the relighting rule (docs/usage.md, "The relighting
 * rule"): the smooth fields the rule works with (fields.c: hole filling, blurring, feathering) and
 * the log-ratio field itself (rule.c), which apply.c puts onto textures and photos. The face's
 * regions it works around are src/mesh's (regions.c). */
#ifndef HD_APPLY_H
#define HD_APPLY_H

#include "hdnet.h"

/* Fills v (w x h, one plane) where known[p] <= 0.5 from the known values around (push-pull over
 * a pyramid: an unknown texel gets a smooth blend of the nearest known ones). Fails only for want
 * of memory; with nothing known, v is set to 0. */
hd_status hd_field_fill(float *v, const float *known, int w, int h);
/* Gaussian blur of one plane in place, standard deviation sigma pixels (<= 0.3: nothing). */
hd_status hd_field_blur(float *v, int w, int h, float sigma);
/* Feather weights: w[p] = smoothstep(d_p / band) with d_p the (chamfer) distance in pixels from
 * pixel p to the nearest pixel where inside[p] <= 0.5 (or the picture's edge); 0 outside, rising
 * to 1 at band pixels inside. */
hd_status hd_field_feather(const float *inside, int w, int h, float band, float *weight);
/* Outward feather weights: 1 where inside[p] > 0.5, falling to 0 at band pixels outside it
 * (1 - smoothstep(d_p / band), d_p the chamfer distance from the region; the picture's edge is not
 * an edge here). */
hd_status hd_field_feather_out(const float *inside, int w, int h, float band, float *weight);
/* Fills the holes of a region in place: every pixel with inside[p] <= 0.5 that no path of such
 * pixels (4-connected) joins to the picture's edge is set to 1 (the nostrils and the lips' line of
 * a face mesh's coverage). Fails only for want of memory. */
hd_status hd_field_fill_holes(float *inside, int w, int h);
/* The smoothstep 3t^2 - 2t^3 of t clamped to [0, 1], the feathers' ramp. */
float hd_field_smoothstep(float t);

/* A face's frame in a photo (forehead.c): the eyes' midpoint (mx, my), the eye distance e and the
 * unit chin-to-forehead axis (ux, uy), in photo pixels; hd_face_frame_of gives 0 when the
 * landmarks give none (eyes closer than 2 pixels, the chin on the forehead). Pixel (x, y) lies
 * hd_face_height eye distances above the eye line and hd_face_side across the face's axis. */
typedef struct hd_face_frame {
    float mx, my, e, ux, uy;
} hd_face_frame;
int hd_face_frame_of(const hd_aligned_face *f, hd_face_frame *fr);
static inline float hd_face_side(const hd_face_frame *fr, int x, int y)
{
    return ((x + 0.5f - fr->mx) * -fr->uy + (y + 0.5f - fr->my) * fr->ux) / fr->e;
}
static inline float hd_face_height(const hd_face_frame *fr, int x, int y)
{
    return ((x + 0.5f - fr->mx) * fr->ux + (y + 0.5f - fr->my) * fr->uy) / fr->e;
}
/* The skin features (forehead.c), NFEAT planes of w x h each, from colours rgb (3 planes of w x h,
 * blurred in place): chroma r and chroma g and log luminance of the colours blurred by `smooth`
 * pixels, and the texture: the mean absolute difference between the log luminance at about a
 * pixel's scale and the blurred one, over the same blur (hair's strands score high, skin low). */
enum { F_CHROMA_R, F_CHROMA_G, F_LOG_LUM, F_TEXTURE, NFEAT };
hd_status hd_skin_features(float *rgb, int w, int h, float smooth, float *feat);
/* A colour's luminance (Rec. 709 weights). */
float hd_luma(float r, float g, float b);
/* A colour's first three skin features: f[F_CHROMA_R], f[F_CHROMA_G] (r and g over r + g + b; 1/3
 * for black) and f[F_LOG_LUM] (the log of its luminance, at least log 1e-3). */
void hd_colour_features(float r, float g, float b, float f[F_TEXTURE]);
/* Median and median absolute deviation of v[0..n) (n > 0; v is reordered). */
void hd_median_mad(float *v, size_t n, float *med, float *mad);

/* The region of face f in the photo that the change of light may reach (forehead.c): coverage
 * (where the face mesh lands, > 0.5 inside; photo-sized) grown from its upper edge into the pixels
 * above the brows that look like the face's skin (measured on its cheeks), up to `grow` eye
 * distances away (the mesh stops short of the hairline). region (photo-sized) is 1 inside, 0
 * outside; grow <= 0 gives the coverage itself. */
#define HD_FOREHEAD_GROW 0.7f
hd_status hd_photo_face_region(const hd_aligned_face *f, const hd_image *photo, const float *coverage, float grow,
                               float *region);
/* The feather weights of face f in photo (forehead.c; weight photo-sized): rising from 0 at the
 * mesh's edge (coverage) to 1 over 0.3 eye distances inside it, and above the brows from 0 at the
 * grown region's edge (the hairline) to 1 over 0.12 eye distances. */
hd_status hd_photo_face_feather(const hd_aligned_face *f, const hd_image *photo, const float *coverage, float *weight);
/* The weights with which the ratio rule applies face f's change to photo (apply.c: hd_apply_photo,
 * hd_relight_photo, hd_apply_face; weight photo-sized): hd_photo_face_feather of the coverage of
 * f's mask warped into the photo (hd_warp_back), its holes filled (hd_field_fill_holes: the change
 * does not fade around the nostrils and along the lips, where the mesh has holes). photo is the
 * photo as given, before any face is changed. `hdnet serve` sends it to the page (its "weight"
 * map). */
hd_status hd_photo_face_weight(const hd_aligned_face *f, const hd_image *photo, float *weight);

/* The log of the relighting ratio (s(N, l_target) + g) / (s(N, l_source) + g) (rule.c) at size x
 * size texels: `channels` planes (1 for a grey target, 3 for a coloured one), defined everywhere
 * (the regions and the texels outside mask filled from the skin, then blurred). d at the model's
 * size; mask (any size, 1 channel, may be NULL) is the face's; g = guard (<= 0: HD_RATIO_GUARD)
 * x the mean source shading over the skin. target NULL: flat light (delighting). rotation (the
 * aligned face's, row-major; NULL: none) casts the face mesh's shadows in that pose: each light's
 * shading loses its distant part (hd_light_distant_part) where the mesh hides that light
 * (hd_mesh_cast_shadow_uv), down to at most SHADOW_FLOOR of it (docs/usage.md, "Cast shadows"). */
hd_status hd_ratio_field(const hd_decomposition *d, const hd_image *mask, int size, const float source[HD_SH_COEFFS],
                         float guard, const hd_light_rgb *target, const float *rotation, hd_image *log_ratio);

/* Applies a log-ratio field (1 or 3 planes, at the image's size) to image with feather weights w
 * (may be NULL: all ones): out = image * exp(w * (log_ratio + log k)), k the brightness factor
 * (1 for HD_BRIGHTNESS_FREE; for KEEP the one that keeps the mean luminance weighted by level of
 * the picture relit with weights level, over the pixels where w > 0; level NULL: w),
 * limited per pixel so that no channel passes 1 (one factor for the pixel, so the colour is kept).
 * Where w is 0 the output is the input bit for bit. out is image's own copy, changed in place.
 * offset (may be NULL) gets log k. */
hd_status hd_ratio_apply(const hd_image *log_ratio, const float *weight, const float *level, hd_brightness brightness,
                         hd_image *image, double *offset);

/* The background as a flat backdrop (backdrop.c; hd_model_set_background; its people:
 * hd_backdrop_add_person, below hd_head): the per-channel log change of a wall facing the camera
 * from source to target (NULL: flat light), with the rule's guard (a share of the wall's source
 * shading; <= 0: HD_RATIO_GUARD); */
void hd_backdrop_log_ratio(const float source[HD_SH_COEFFS], const hd_light_rgb *target, float guard,
                           float log_ratio[3]);
/* image *= exp((1 - people) * (log_ratio + offset)), each channel clamped to 1. */
void hd_backdrop_apply(const float log_ratio[3], double offset, const float *people, hd_image *image);

/* A frame's background relit as a wall (hd_apply_face, then hd_backdrop_apply over people with
 * the first face's wall change and offset). */
typedef struct hd_face_backdrop {
    float *people;              /* photo-sized, zeroed by the caller: each face adds its person */
    float source[HD_SH_COEFFS]; /* set by each call: the face's own light ... */
    double offset;              /* ... and its brightness offset (log k) */
} hd_face_backdrop;
/* The rule on one face of a photo already aligned (f) and decomposed (d, which may be smoothed, as
 * a video does): photo (3 channels, the frame's size; earlier faces may be changed already) is
 * changed in place toward target (NULL: flat light, delighting), from the face's own light
 * (hd_face_light of d by `source`), with the shadows the face casts unless shadows is
 * HD_SHADOWS_NONE, feathered from the face's edge, as hd_apply_photo does for
 * each face. backdrop (NULL: the background kept) relights the body as well and adds the face's
 * person to backdrop->people (the face needs its person map, else HD_ERR_ARG), as hd_apply_photo
 * does with HD_BACKGROUND_RELIGHT. */
hd_status hd_apply_face(const hd_aligned_face *f, const hd_decomposition *d, const hd_light_rgb *target,
                        hd_brightness brightness, hd_source_light source, hd_shadows shadows, hd_image *photo,
                        hd_face_backdrop *backdrop);

/* The change of light beyond the face mesh (head.c, docs/usage.md "The whole head"): per face, a
 * head proxy posed by the mesh fit (an ellipsoid skull, a cylinder neck), its normals blended with
 * the model's near the mesh, the skin and hair masks of a colour model seeded from the face, in a
 * window (x0, y0, w, h) of the W x H photo. */
/* Turns the model's normals d of face f (aligned from a photo) toward the landmark fit's pose
 * (repose.c): by `share` (0..1) of the rotation that best carries them onto f's coarse normals over
 * f's mask; *angle_deg (may be NULL) gets the angle turned. share <= 0 leaves them. The share the
 * photo paths use, HD_REPOSE_SHARE, was chosen on the Yale tuning subjects (docs/evaluation.md). */
#define HD_REPOSE_SHARE 0.5f
hd_status hd_face_repose(const hd_aligned_face *f, hd_decomposition *d, float share, float *angle_deg);
/* The decomposition of face f of a photo: hd_model_decompose of its texture, the normals turned by
 * hd_face_repose(HD_REPOSE_SHARE). Every path that decomposes a photo's face takes it. */
hd_status hd_face_decompose(hd_model *model, const hd_aligned_face *f, hd_decomposition *d);

typedef struct hd_head {
    int W, H, x0, y0, w, h;
    int mx0, my0, mw, mh; /* the head's own window within it (its masks'; the rest is the body's) */
    hd_face_frame frame;
    float g;       /* the rule's guard */
    float *normal; /* 3 planes of w x h: the model's normals near the mesh, the proxy's beyond */
    float *proxy;  /* 3 planes: the proxy's alone (the hair's) */
    float *mesh;   /* how much of the face's own field holds: 1 on the mesh, 0 beyond a band */
    float *skin, *hair; /* soft masks, 0 .. 1 */
    float *bg;          /* 1 where the colour is the background's (the photo's border) */
    float *body;        /* the body's weight below the chin (hd_head_init's body; else 0) ... */
    float *zone;        /* ... and the body's zone (the torso's reach below the chin) before its outline */
    float *neck;        /* the body's reach near the neck (with the body; else NULL: head.c, neck_reach) */
    float *ws, *wh;     /* the skin's and the hair's weights (hd_head_weight) */
    float *wb;          /* the body's share of ws beyond the neck's reach, left out of the brightness
                         * kept (HD_HEAD_BODY_ALL only; else NULL) */
    float *near;        /* 1 at the skin's edge, falling into the hair */
    float *share;       /* the person's share of an outline pixel (1 inside it; the head's own window) */
} hd_head;
/* What of the person below the chin takes the change (hd_head_init's body, with the face's person
 * segmentation only; head.c): none; the body near the neck, fading out down the chest and toward the
 * shoulders before the person's outline (the background kept: the neck's change goes on down a bare
 * chest and a collar instead of ending in a band, and no relit shoulder stands against the kept
 * wall); or all of it, skin, clothes and hair alike (the background relit as well). */
enum { HD_HEAD_BODY_NONE = 0, HD_HEAD_BODY_NEAR = 1, HD_HEAD_BODY_ALL = 2 };
/* Sets up face f's head (d: its decomposition, at the model's size; source: its own light; guard
 * as hd_ratio_field's). body (HD_HEAD_BODY_*, with the face's person segmentation only): what of the
 * person below the chin takes the change too, on its own normals (its outline rounded off). Without
 * a frame (degenerate landmarks) h stays empty, and hd_head_apply leaves the face's field alone. Free
 * with hd_head_free. */
hd_status hd_head_init(const hd_aligned_face *f, const hd_decomposition *d, const hd_image *photo,
                       const float source[HD_SH_COEFFS], float guard, int body, hd_head *h);
void hd_head_free(hd_head *h);
/* The weights of face f over its head, once per face: weight (photo-sized) holds the face's own
 * (hd_photo_face_weight) and becomes, in the head's window, the skin's (1 on the skin, the face's
 * where the mesh's field holds: eyes, lips, brows) plus the hair's (a share, 0.5, where there is
 * no skin); the background keeps 0. */
hd_status hd_head_weight(hd_head *h, float *weight);
/* The weights of hd_head_weight without the body's share, for the brightness to keep the head's
 * mean, not the clothes' (hd_ratio_apply's level): a new photo-sized array in *level, or NULL
 * where h has no body (the weights as they are). */
hd_status hd_head_level(const hd_head *h, const float *weight, float **level);
/* How much photo pixel (x, y) lies in h's body (0 .. 1; 0 outside it or without the body). */
float hd_head_body_zone(const hd_head *h, int x, int y);
/* The person's share of photo pixel (x, y) where h's body reaches (its outline refined to the
 * photo's edges, head.c's body_outline); -1 beyond the body's zone or without the body. */
float hd_head_body_person(const hd_head *h, int x, int y);
/* How much of photo pixel (x, y) is the background by the head's own masks (1: its colour test and
 * the region grown from the window's edge, the wall between curls; on the person's outline, a
 * strand's edge, the background's share of the pixel; 0 outside the head's own window). */
float hd_head_background(const hd_head *h, int x, int y);
/* The backdrop's people (backdrop.c): people = max(people, weight, face f's person map) over the
 * W x H photo (weight: the face's and head's weights, as hd_head_weight leaves them; the map's last
 * row carried on down the photo, the body below its window; within head's body zone, the weights
 * instead of the map). */
hd_status hd_backdrop_add_person(const hd_aligned_face *f, const float *weight, const hd_head *head, int W, int H,
                                 float *people);
/* Face f's weights over photo (feather, photo-sized) and its head (head, for hd_head_free), as the
 * ratio rule applies them (apply.c; d its decomposition, source its own light, guard as
 * hd_ratio_field's): hd_photo_face_weight, hd_head_init and hd_head_weight. With people (the
 * background relit) the body too, and the face's person added to people (hd_backdrop_add_person),
 * which needs the person segmentation's map, else HD_ERR_ARG (k: the face's number for the reason,
 * or -1 to name it by its box). `hdnet serve` builds its maps with it. */
hd_status hd_face_weights(const hd_aligned_face *f, const hd_decomposition *d, const hd_image *photo,
                          const float source[HD_SH_COEFFS], float guard, float *people, int k, float *feather,
                          hd_head *head);
/* Extends one job's field over the head, in place: the face's log-ratio field warped into the
 * photo and filled (photo-sized, 1 or 3 planes), on the skin handed over to the ratio on the
 * blended normals beyond the mesh, on the hair the ratio on the proxy's normals. target NULL:
 * flat light. After hd_head_weight. */
hd_status hd_head_apply(const hd_head *h, const float source[HD_SH_COEFFS], const hd_light_rgb *target,
                        hd_image *field);
/* The blur hd_head_apply gives the head's log ratios (a Gaussian's sigma, photo pixels; 0 for an
 * empty head): for a client that redoes hd_head_apply from h's maps (`hdnet serve`'s page). */
float hd_head_blur(const hd_head *h);

/* The paper's relighting (relight.c, docs/usage.md), kept to measure against. The final albedo is
 * the input over the predicted shading, per colour channel: A_final = clamp(I / max(S,
 * HD_SHADING_FLOOR), 0, 1); the relit face is A_final * max(s(N, l_target), 0), clamped to [0, 1].
 * The image may be of any size: the decomposition's shading and normals (at the model size) are
 * resized to it (normals renormalised). A mask is one channel of any size (resized likewise) or
 * NULL for all ones; the output is m * relit + (1 - m) * I, so masked-out pixels keep the input. */
#define HD_SHADING_FLOOR 1e-3f
/* A_final at the image's size (3 channels); image is 3 channels. */
hd_status hd_relight_albedo(const hd_image *image, const hd_decomposition *d, hd_image *albedo);
/* Relights image (decomposed as d) under light; out is allocated at the image's size. */
hd_status hd_relight(const hd_image *image, const hd_decomposition *d, const hd_image *mask,
                     const float light[HD_SH_COEFFS], hd_brightness brightness, hd_image *out);
/* The albedo under flat light (s = 1): m * A_final + (1 - m) * I. No brightness matching. */
hd_status hd_delight(const hd_image *image, const hd_decomposition *d, const hd_image *mask, hd_image *out);
/* Relights image under the light estimated for a reference face (ref->light). */
hd_status hd_transfer(const hd_image *image, const hd_decomposition *d, const hd_image *mask,
                      const hd_decomposition *ref, hd_brightness brightness, hd_image *out);

/* The paper's rule on a texture (relight.c): light NULL is flat light without brightness matching. */
hd_status hd_relight_paper(const hd_image *image, const hd_decomposition *d, const hd_image *mask, const float *light,
                           hd_brightness brightness, hd_image *out);


/* The before / after sheet of a photo's face 0 (sheet.c, docs/usage.md): row 0 the paper's rule,
 * row 1 the ratio rule; columns: the photo, the seven presets (brightness kept), the delit face;
 * each cell the face's square crop at the photo's full resolution. */
hd_status hd_relight_sheet(hd_model *model, hd_aligner *aligner, const hd_image *photo, hd_image *canvas);

/* ---- calls of the public family with no client outside the library and its tests */
/* hd_apply_texture on a decomposition already made (d of `texture`; source: the face's light). */
hd_status hd_apply_decomposition(const hd_image *texture, const hd_decomposition *d, const hd_image *mask,
                                 const hd_apply_request *request, hd_apply_result *result);
/* A texture relit under the light estimated for the texture ref (hd_estimate_light, then
 * hd_relight_face). */
hd_status hd_transfer_face(hd_model *model, const hd_image *image, const hd_image *mask,
                           const hd_image *ref, hd_brightness brightness, hd_image *out);
/* Faces of a photo are unwarped at max(HD_PHOTO_TEXTURE_SIZE, model size) texels a side, so the
 * relit texture keeps more detail than the model's own size. */
#define HD_PHOTO_TEXTURE_SIZE 256
int hd_photo_texture_size(const hd_model *model);

#endif /* HD_APPLY_H */
