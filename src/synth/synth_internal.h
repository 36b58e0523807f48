/* synth_internal.h: what the files of the synthetic-face generator share: the per-size generator
 * (mesh, UV raster, fixed region maps of the aligned texture space, tileable noise fields) and
 * one subject's identity (deformed shape, fine-detail gradients, albedo texture).
 *
 * Letters: S = texture side (texels), P = S * S texels, V = mesh vertices (468). UV units: the
 * aligned texture is [0, 1]^2, u right, v down; one UV unit is about SYN_CM_PER_UV cm of face. */
#ifndef HD_SYNTH_INTERNAL_H
#define HD_SYNTH_INTERNAL_H

#include "core/core.h"
#include "mesh/mesh.h"
#include "synth/synth.h"

/* Face size in the canonical mesh: the outer eye corners are 8.9 cm and 0.44 UV apart, forehead to
 * chin 17.7 cm and 0.85 UV. */
#define SYN_CM_PER_UV 20.5f

enum { SYN_NOISE_LOW, SYN_NOISE_MID, SYN_NOISE_FINE, SYN_NOISE_TEXEL, SYN_NOISE_COUNT };

/* Soft region weights in [0, 1] over the texture, fixed by the mesh's landmark UVs. */
enum {
    SYN_REGION_LIPS,
    SYN_REGION_BROWS,
    SYN_REGION_EYES,      /* inside the eye openings */
    SYN_REGION_CHEEKS,
    SYN_REGION_NOSE,
    SYN_REGION_UNDER_EYE, /* lids and the hollows below the eyes */
    SYN_REGION_BEARD,
    SYN_REGION_FOREHEAD,
    SYN_REGION_NASOLABIAL, /* distance (cm) to the nasolabial fold lines, not a weight */
    SYN_REGION_CROW,       /* distance (cm) to the nearest outer eye corner, outer side only; else 99 */
    SYN_REGION_CROW_ANGLE, /* angle (radians) about that corner */
    SYN_REGION_EYE_X,      /* inside an eye: offset from the eye's centre, cm (x right) */
    SYN_REGION_EYE_Y,      /* ... (y down) */
    SYN_REGION_SULCUS,     /* distance (cm) to the mentolabial groove between lower lip and chin */
    SYN_REGION_ALAR,       /* distance (cm) to the alar creases around the nose wings */
    SYN_REGION_COUNT
};

struct hd_synth {
    int size;
    hd_mesh mesh;
    hd_uv_raster raster;
    float *canon_normal; /* (V, 3) vertex normals of the undeformed mesh */
    int ncovered;
    int *covered;        /* (ncovered) indices of texels the mesh covers, ascending */
    float *region[SYN_REGION_COUNT]; /* each (P) */
    float *noise[SYN_NOISE_COUNT];   /* each (P), tileable with period S, zero mean, unit std */
};

struct hd_synth_subject {
    uint64_t seed;
    int subject;
    float *pos;    /* (V, 3) deformed mesh (cm) */
    float *albedo; /* (3, P) */
    float *grad;   /* (2, P) fine-detail height gradient dh/dx, dh/dy (cm per cm, x along u, y along v) */
};

/* The RNG stream of (seed, subject, image); image = -1 is the subject's own stream. */
void syn_rng(hd_rng *r, uint64_t seed, int subject, int image);

/* A tileable noise field lookup with a per-subject offset and flip. */
typedef struct syn_noise_view {
    const float *field;
    int ox, oy, flip_x, flip_y, transpose;
} syn_noise_view;
static inline float syn_noise_at(const syn_noise_view *nv, int size, int x, int y)
{
    if (nv->flip_x) x = size - 1 - x;
    if (nv->flip_y) y = size - 1 - y;
    if (nv->transpose) {
        int t = x;
        x = y;
        y = t;
    }
    x += nv->ox;
    y += nv->oy;
    if (x >= size) x -= size;
    if (y >= size) y -= size;
    return nv->field[(size_t)y * (size_t)size + (size_t)x];
}
void syn_noise_view_pick(syn_noise_view *nv, const float *field, int size, hd_rng *r);

/* A deformed canonical mesh pos (V, 3): global scales in width, length and depth, then the
 * landmark bumps (subject.c, table BUMPS), every deviation times gain; gain 1 is a subject's
 * identity, drawn from r in a fixed order. */
void syn_shape_make(const hd_mesh *m, hd_rng *r, float gain, float *pos);

/* Builds the region maps and noise fields of a generator whose mesh and raster are loaded. */
hd_status syn_regions_build(hd_synth *s);

#endif /* HD_SYNTH_INTERNAL_H */
