/* generator.c: the per-size part of the synthetic-face generator: the canonical mesh and its UV
 * raster, the fixed region maps of the aligned texture space (lips, brows, eyes, cheeks, nose,
 * under-eye, beard, forehead, fold lines), all placed by the mesh's own landmark UVs, and the
 * tileable noise fields that every subject samples at its own offsets. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "synth/synth_internal.h"
#include "synth/synth.h"

/* MediaPipe FaceMesh contours (vertex indices), image-left first. */
static const int EYE_L[] = {33, 246, 161, 160, 159, 158, 157, 173, 133, 155, 154, 153, 145, 144, 163, 7};
static const int EYE_R[] = {263, 466, 388, 387, 386, 385, 384, 398, 362, 382, 381, 380, 374, 373, 390, 249};
static const int LIPS[] = {61, 185, 40, 39, 37, 0, 267, 269, 270, 409, 291, 375, 321, 405, 314, 17, 84, 181, 91, 146};
static const int BROW_L[] = {70, 63, 105, 66, 107, 55, 65, 52, 53, 46};
static const int BROW_R[] = {300, 293, 334, 296, 336, 285, 295, 282, 283, 276};

#define COUNT(a) ((int)(sizeof(a) / sizeof((a)[0])))

void syn_rng(hd_rng *r, uint64_t seed, int subject, int image)
{
    /* stream: subject in the high bits, image + 1 in the low 24 (0 = the subject's own) */
    uint64_t stream = ((uint64_t)(uint32_t)subject << 24) | (uint64_t)((uint32_t)(image + 1) & 0xFFFFFFu);
    hd_rng_seed(r, seed ^ 0x9E3779B97F4A7C15ull, stream);
}

void syn_noise_view_pick(syn_noise_view *nv, const float *field, int size, hd_rng *r)
{
    nv->field = field;
    nv->ox = (int)hd_rng_below(r, (uint32_t)size);
    nv->oy = (int)hd_rng_below(r, (uint32_t)size);
    uint32_t bits = hd_rng_below(r, 8);
    nv->flip_x = bits & 1;
    nv->flip_y = (bits >> 1) & 1;
    nv->transpose = (bits >> 2) & 1;
}

static float smoothstep(float e0, float e1, float x)
{
    float t = (x - e0) / (e1 - e0);
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    return t * t * (3.0f - 2.0f * t);
}

/* Signed distance (UV; > 0 inside) from p to the polygon through the UVs of vertices idx. */
static float poly_sdist(const hd_mesh *m, const int *idx, int n, float px, float py)
{
    int inside = 0;
    float d = 1e30f;
    for (int i = 0, j = n - 1; i < n; j = i++) {
        float ax = m->uv[2 * idx[j]], ay = m->uv[2 * idx[j] + 1], bx = m->uv[2 * idx[i]], by = m->uv[2 * idx[i] + 1];
        if ((by > py) != (ay > py) && px < ax + (py - ay) * (bx - ax) / (by - ay)) inside = !inside;
        float e = hd_segment_distance(px, py, ax, ay, bx, by);
        if (e < d) d = e;
    }
    return inside ? d : -d;
}

/* Soft polygon weight: 1 well inside, 0 outside, a smooth ramp of half-width `soft` (UV). */
static float poly_weight(const hd_mesh *m, const int *idx, int n, float px, float py, float soft)
{
    float minx = 1, maxx = 0, miny = 1, maxy = 0;
    for (int i = 0; i < n; i++) {
        float x = m->uv[2 * idx[i]], y = m->uv[2 * idx[i] + 1];
        minx = fminf(minx, x), maxx = fmaxf(maxx, x), miny = fminf(miny, y), maxy = fmaxf(maxy, y);
    }
    if (px < minx - soft || px > maxx + soft || py < miny - soft || py > maxy + soft) return 0.0f;
    return smoothstep(-soft, soft, poly_sdist(m, idx, n, px, py));
}

/* A Gaussian blob of radius sigma (UV) centred on the UV of vertex v, shifted by (du, dv). */
static float blob(const hd_mesh *m, int v, float du, float dv, float sx, float sy, float px, float py)
{
    float x = (px - m->uv[2 * v] - du) / sx, y = (py - m->uv[2 * v + 1] - dv) / sy;
    return expf(-0.5f * (x * x + y * y));
}

/* Fills field (P) with tileable value-noise fBm: octaves of a random lattice of `cells` x `cells`
 * values (doubling each octave, halving the amplitude), smooth-stepped bilinear interpolation,
 * period S; normalised to zero mean and unit standard deviation. */
static hd_status noise_field(float *field, int size, int cells, int octaves, uint64_t seed)
{
    size_t n = (size_t)size * size;
    memset(field, 0, n * sizeof(float));
    hd_rng r;
    hd_rng_seed(&r, seed, 77);
    float amp = 1.0f;
    for (int o = 0; o < octaves; o++, cells *= 2, amp *= 0.5f) {
        if (cells > size) cells = size;
        float *lat = hd_malloc((size_t)cells * cells * sizeof(float));
        if (!lat) return HD_ERR_NOMEM;
        for (int i = 0; i < cells * cells; i++) lat[i] = hd_rng_range(&r, -1.0f, 1.0f);
        for (int y = 0; y < size; y++) {
            float fy = ((float)y + 0.5f) * (float)cells / (float)size;
            int iy = (int)floorf(fy);
            float ty = fy - (float)iy;
            ty = ty * ty * (3 - 2 * ty);
            int y0 = iy % cells, y1 = (iy + 1) % cells;
            for (int x = 0; x < size; x++) {
                float fx = ((float)x + 0.5f) * (float)cells / (float)size;
                int ix = (int)floorf(fx);
                float tx = fx - (float)ix;
                tx = tx * tx * (3 - 2 * tx);
                int x0 = ix % cells, x1 = (ix + 1) % cells;
                float a = lat[y0 * cells + x0] + tx * (lat[y0 * cells + x1] - lat[y0 * cells + x0]);
                float b = lat[y1 * cells + x0] + tx * (lat[y1 * cells + x1] - lat[y1 * cells + x0]);
                field[(size_t)y * size + x] += amp * (a + ty * (b - a));
            }
        }
        free(lat);
    }
    double sum = 0, sum2 = 0;
    for (size_t i = 0; i < n; i++) sum += field[i], sum2 += (double)field[i] * field[i];
    double mean = sum / (double)n, var = sum2 / (double)n - mean * mean;
    float inv = var > 1e-12 ? (float)(1.0 / sqrt(var)) : 1.0f;
    for (size_t i = 0; i < n; i++) field[i] = (field[i] - (float)mean) * inv;
    return HD_OK;
}

hd_status syn_regions_build(hd_synth *s)
{
    const hd_mesh *m = &s->mesh;
    const int S = s->size;
    const size_t P = (size_t)S * S;
    for (int k = 0; k < SYN_REGION_COUNT; k++)
        if (!(s->region[k] = hd_calloc(P, sizeof(float)))) return HD_ERR_NOMEM;
    for (int k = 0; k < SYN_NOISE_COUNT; k++)
        if (!(s->noise[k] = hd_malloc(P * sizeof(float)))) return HD_ERR_NOMEM;
    hd_status st;
    if ((st = noise_field(s->noise[SYN_NOISE_LOW], S, 3, 3, 101)) != HD_OK) return st;
    if ((st = noise_field(s->noise[SYN_NOISE_MID], S, 12, 3, 202)) != HD_OK) return st;
    if ((st = noise_field(s->noise[SYN_NOISE_FINE], S, S / 4 > 1 ? S / 4 : 1, 2, 303)) != HD_OK) return st;
    if ((st = noise_field(s->noise[SYN_NOISE_TEXEL], S, S, 1, 404)) != HD_OK) return st;

    const float *uv = m->uv;
    /* eye frames: centre between the corners and between the lids; cm per UV from the 3D mesh */
    float ec[2][2], escale[2][2];
    const int corner[2][4] = {{33, 133, 159, 145}, {263, 362, 386, 374}};
    for (int e = 0; e < 2; e++) {
        const int *c = corner[e];
        ec[e][0] = 0.5f * (uv[2 * c[0]] + uv[2 * c[1]]);
        ec[e][1] = 0.5f * (uv[2 * c[2] + 1] + uv[2 * c[3] + 1]);
        escale[e][0] = fabsf(m->pos[3 * c[0]] - m->pos[3 * c[1]]) / fabsf(uv[2 * c[0]] - uv[2 * c[1]]);
        escale[e][1] = fabsf(m->pos[3 * c[2] + 1] - m->pos[3 * c[3] + 1]) / fabsf(uv[2 * c[2] + 1] - uv[2 * c[3] + 1]);
    }
    /* nasolabial folds: from beside the nose wing (129 / 358) to below and outside the mouth
     * corner (61 / 291) */
    const float fold[2][4] = {
        {uv[2 * 129] - 0.015f, uv[2 * 129 + 1] + 0.005f, uv[2 * 61] - 0.035f, uv[2 * 61 + 1] + 0.045f},
        {uv[2 * 358] + 0.015f, uv[2 * 358 + 1] + 0.005f, uv[2 * 291] + 0.035f, uv[2 * 291 + 1] + 0.045f},
    };
    const float forehead_top = uv[2 * 10 + 1] + 0.03f;
    const float forehead_bottom = fminf(uv[2 * 105 + 1], uv[2 * 334 + 1]) - 0.03f;
    const float nose_base = uv[2 * 2 + 1];
    for (int ci = 0; ci < s->ncovered; ci++) {
        int i = s->covered[ci];
        float px = ((float)(i % S) + 0.5f) / (float)S, py = ((float)(i / S) + 0.5f) / (float)S;
        s->region[SYN_REGION_LIPS][i] = poly_weight(m, LIPS, COUNT(LIPS), px, py, 0.006f);
        s->region[SYN_REGION_BROWS][i] = fmaxf(poly_weight(m, BROW_L, COUNT(BROW_L), px, py, 0.008f),
                                               poly_weight(m, BROW_R, COUNT(BROW_R), px, py, 0.008f));
        float el = poly_weight(m, EYE_L, COUNT(EYE_L), px, py, 0.003f);
        float er = poly_weight(m, EYE_R, COUNT(EYE_R), px, py, 0.003f);
        s->region[SYN_REGION_EYES][i] = fmaxf(el, er);
        int e = px < 0.5f ? 0 : 1;
        s->region[SYN_REGION_EYE_X][i] = (px - ec[e][0]) * escale[e][0];
        s->region[SYN_REGION_EYE_Y][i] = (py - ec[e][1]) * escale[e][1];
        s->region[SYN_REGION_CHEEKS][i] = blob(m, 50, 0.0f, 0.0f, 0.06f, 0.05f, px, py) +
                                          blob(m, 280, 0.0f, 0.0f, 0.06f, 0.05f, px, py);
        s->region[SYN_REGION_NOSE][i] = fminf(1.0f, blob(m, 4, 0.0f, 0.0f, 0.03f, 0.035f, px, py) +
                                                        0.7f * blob(m, 129, 0.0f, 0.0f, 0.02f, 0.02f, px, py) +
                                                        0.7f * blob(m, 358, 0.0f, 0.0f, 0.02f, 0.02f, px, py));
        s->region[SYN_REGION_UNDER_EYE][i] = fminf(1.0f, blob(m, 145, 0.0f, 0.02f, 0.05f, 0.022f, px, py) +
                                                             blob(m, 374, 0.0f, 0.02f, 0.05f, 0.022f, px, py) +
                                                             0.6f * blob(m, 159, 0.0f, -0.01f, 0.045f, 0.018f, px, py) +
                                                             0.6f * blob(m, 386, 0.0f, -0.01f, 0.045f, 0.018f, px, py));
        /* beard: below a curve from the sideburns (v ~ 0.45 at the sides) to under the nose */
        float line = nose_base + 0.005f - 0.9f * (px - 0.5f) * (px - 0.5f);
        s->region[SYN_REGION_BEARD][i] = smoothstep(line, line + 0.03f, py) * (1.0f - s->region[SYN_REGION_LIPS][i]);
        s->region[SYN_REGION_FOREHEAD][i] = smoothstep(forehead_top, forehead_top + 0.03f, py) *
                                            (1.0f - smoothstep(forehead_bottom - 0.03f, forehead_bottom, py)) *
                                            (1.0f - smoothstep(0.25f, 0.32f, fabsf(px - 0.5f)));
        float dfold = fminf(hd_segment_distance(px, py, fold[0][0], fold[0][1], fold[0][2], fold[0][3]),
                            hd_segment_distance(px, py, fold[1][0], fold[1][1], fold[1][2], fold[1][3]));
        s->region[SYN_REGION_NASOLABIAL][i] = dfold * SYN_CM_PER_UV;
        /* mentolabial groove: a short horizontal line between the lower lip and the chin */
        float sv = 0.5f * (uv[2 * 17 + 1] + uv[2 * 199 + 1]);
        s->region[SYN_REGION_SULCUS][i] = hd_segment_distance(px, py, 0.5f - 0.05f, sv, 0.5f + 0.05f, sv) * SYN_CM_PER_UV;
        /* alar creases: arcs around the nose wings (distance to a circle about 129 / 358) */
        float ax = px < 0.5f ? uv[2 * 129] + 0.012f : uv[2 * 358] - 0.012f, ay = uv[2 * 129 + 1] + 0.008f;
        float ad = fabsf(sqrtf((px - ax) * (px - ax) + (py - ay) * (py - ay)) - 0.03f);
        int outer_side = px < 0.5f ? px < ax : px > ax; /* only the outer half of the arc */
        s->region[SYN_REGION_ALAR][i] = (outer_side && py > ay - 0.02f ? ad : 1.0f) * SYN_CM_PER_UV;
        /* crow's feet: about the outer eye corner, only on its outer side */
        int oc = px < 0.5f ? 33 : 263;
        float dx = (px - uv[2 * oc]) * SYN_CM_PER_UV, dy = (py - uv[2 * oc + 1]) * SYN_CM_PER_UV;
        int outer = px < 0.5f ? dx < 0 : dx > 0;
        s->region[SYN_REGION_CROW][i] = outer ? sqrtf(dx * dx + dy * dy) : 99.0f;
        s->region[SYN_REGION_CROW_ANGLE][i] = atan2f(dy, fabsf(dx));
    }
    return HD_OK;
}

hd_status hd_synth_create(int size, hd_synth **out)
{
    *out = NULL;
    if (size < 16 || size > 4096) return hd_fail(HD_ERR_RANGE, "synth: size %d outside [16, 4096]", size);
    hd_synth *s = hd_calloc(1, sizeof *s);
    if (!s) return HD_ERR_NOMEM;
    s->size = size;
    hd_status st = hd_mesh_load_canonical(&s->mesh);
    if (st == HD_OK) st = hd_mesh_uv_raster(&s->mesh, size, &s->raster);
    if (st == HD_OK && !(s->canon_normal = hd_malloc((size_t)s->mesh.nv * 3 * sizeof(float)))) st = HD_ERR_NOMEM;
    if (st == HD_OK) {
        hd_mesh_vertex_normals(&s->mesh, s->mesh.pos, s->canon_normal);
        size_t P = (size_t)size * size;
        for (size_t i = 0; i < P; i++) s->ncovered += s->raster.tri[i] >= 0;
        if (!(s->covered = hd_malloc((size_t)(s->ncovered ? s->ncovered : 1) * sizeof(int)))) st = HD_ERR_NOMEM;
    }
    if (st == HD_OK) {
        int k = 0;
        for (size_t i = 0; i < (size_t)size * size; i++)
            if (s->raster.tri[i] >= 0) s->covered[k++] = (int)i;
        st = syn_regions_build(s);
    }
    if (st != HD_OK) {
        hd_synth_free(s);
        return st;
    }
    *out = s;
    return HD_OK;
}

void hd_synth_free(hd_synth *s)
{
    if (!s) return;
    hd_mesh_free(&s->mesh);
    hd_uv_raster_free(&s->raster);
    free(s->canon_normal);
    free(s->covered);
    for (int k = 0; k < SYN_REGION_COUNT; k++) free(s->region[k]);
    for (int k = 0; k < SYN_NOISE_COUNT; k++) free(s->noise[k]);
    free(s);
}

int hd_synth_size(const hd_synth *s) { return s->size; }
