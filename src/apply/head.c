/* head.c: the change of light beyond the face mesh (issue 36; docs/usage.md, "The whole head"). The
 * mesh covers the face proper; the ears, the temples, the forehead above the mesh, the jaw's edge,
 * the neck and the hair kept the old light, so a relit face read as a mask. Here a head proxy posed
 * by the mesh fit (hd_aligned_face's similarity: an ellipsoid for the skull, ears included, and a
 * vertical cylinder for the neck, in the canonical mesh's centimetres) gives a normal to every
 * pixel of the head and neck; near the mesh the model's normals (warped into the photo and
 * extended smoothly past its edge) are blended into the proxy's, so the change is continuous across
 * the mesh's edge. The rule's ratio is taken on those normals, and applied:
 *   - on the skin (a colour model seeded from the face's cheeks, forehead.c's features, within the
 *     proxy's silhouette grown a little) with the whole change;
 *   - on the hair (not skin, not the background's colours, within the skull's silhouette grown a
 *     little, or the neck's) with a share (HEAD_HAIR_STRENGTH) of the change of the proxy's normals alone:
 *     hair is not skin and takes no fill from the face (also where a fringe lies over the mesh);
 *   - elsewhere (the background: where the face's segmentation network says no person, and where
 *     the colour is the background's, sampled behind the head; tested pixel by pixel) not at
 *     all: those pixels keep the input bit for bit; skin and hair share the person's weight up to
 *     its outline, whose pixels change by the person's share of their light (outline_share).
 *     With the segmentation the hair above the eyes reaches beyond the skull's proxy (a bun,
 *     curls), as far as the network's person goes (hair_reach).
 * The proxy's normals face the viewer at least PROXY_FACING: the face's own light, fitted on
 * normals that do, must not be extrapolated to the silhouette's. Inside the mesh the face's own
 * field (rule.c, warped back) is kept; it hands over to the head's within HEAD_MESH_BAND eye
 * distances outside the mesh's edge. A face aligned without the segmentation (from given
 * landmarks) is told from its background by colour alone.
 * With the body (hd_head_init's body, HD_HEAD_BODY_ALL: the background is relit too, backdrop.c)
 * the person below the chin, clothes and all, takes the change on its own normals (its outline
 * rounded off, body_normals): the network's person, its outline refined to the photo's edges by a
 * guided filter (body_outline), is the body's weight, with no colour test (a white shirt before a
 * pale wall). The head's own masks are computed on the head's window alone, so they, and the head's
 * change, are the same with the body or without; the kept brightness is the head's and the body's near the neck (hd_head_level), not the
 * rest of the clothes'. With the background kept (HD_HEAD_BODY_NEAR) only the body near the neck
 * takes the change, fading out down the chest and toward the shoulders before the person's outline
 * (neck_reach): the neck's change goes on down a bare chest and a collar instead of ending in a band
 * where the skin's colour test stops, and no relit shoulder stands against the kept wall. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "apply/apply.h"

/* The proxy, in the canonical mesh's frame (cm; x right, y up, z toward the viewer): the skull's
 * centre and semi-axes (through the forehead's top, landmark 10, and the face's sides at the ears,
 * 234 and 454, with a head 19.6 cm long and 21 cm tall), the neck's axis (vertical, through x = 0,
 * z = NECK_Z), radius and top. */
static const float SKULL_C[3] = {0.0f, 3.0f, -4.5f}, SKULL_A[3] = {7.9f, 10.5f, 9.8f};
#define NECK_Z -4.0f
#define NECK_R 5.5f
#define NECK_TOP -3.0f
/* The proxy's normals face the viewer at least this much (z; 0.4: 66 degrees from the camera's
 * axis, about where the face mesh's own edge lies). */
#define PROXY_FACING 0.4f
/* The neck ends: below NECK_BOTTOM its radius grows by 1 every NECK_FADE cm, so the skin's weight
 * (which fades from radius 1 to SKIN_REACH_NECK) ends smoothly a little below the collarbones
 * instead of running down the photo as a column (an orange suit, a bare chest under a collar). */
#define NECK_BOTTOM -12.0f
#define NECK_FADE 6.0f
/* The body below the neck (with the face's segmentation only): a vertical elliptic cylinder, the
 * chest and shoulders (TORSO_A: half the shoulders' width and the chest's depth), whose reach is the
 * body's (its normals are the person's outline rounded off, body_normals; they take over from the
 * neck's from TORSO_TOP down over TORSO_BLEND cm). Every pixel of the person there, skin, clothes
 * or hair alike, takes the change on them (hd_head_weight): the network, not the colour, tells the
 * person from the background (a white shirt before a pale wall), and no material edge (a neckline)
 * is a step of the change. */
static const float TORSO_C[3] = {0.0f, 0.0f, -6.0f}, TORSO_A[3] = {18.0f, 0.0f, 10.0f};
#define TORSO_TOP -11.0f
#define TORSO_BLEND 5.0f
/* The body's normals are rounded off toward the person's outline over about this many eye
 * distances (body_normals). */
#define BODY_ROUND 0.4f
/* The body's weight fades out from the torso's radius 1 to TORSO_REACH: far enough that the
 * network's person, not the proxy, ends the body (at 1.8 a pale stripe of the old light ran down
 * a wide shirt or an arm where the weight faded inside the person: London 068 and 022, the
 * astronaut's far arm). */
#define TORSO_REACH 4.0f
/* The body's weight rises from BODY_FROM to BODY_TO eye distances below the eyes (the chin and the
 * neck, whose skin takes the head's weight anyway): the shoulders below take it whole, with no band
 * where it starts. */
#define BODY_FROM 1.3f
#define BODY_TO 1.7f
/* With the background kept (HD_HEAD_BODY_NEAR) the body takes the change near the neck only: it
 * fades out from CHEST_FROM to CHEST_TO eye distances below the eyes, from CHEST_SIDE_FROM to
 * CHEST_SIDE_TO to either side of the face's centre line, and over CHEST_EDGE inward from the
 * person's outline. The neck's change, on the skin alone, ended in a band a little below the
 * collarbones, blotched where a pale chest failed the skin's colour test (London tuning 029, 041,
 * 086 under a side light); a relit shoulder would stand against the kept wall. Chosen by eye on
 * London tuning faces 006, 012, 029, 041 and 086 under a side light and preset 3. */
#define CHEST_FROM 2.5f
#define CHEST_TO 4.0f
#define CHEST_SIDE_FROM 1.2f
#define CHEST_SIDE_TO 2.4f
#define CHEST_EDGE 0.3f
#define BODY_GUIDE 0.04f      /* the guided filter's scale (eye distances) ... */
#define BODY_GUIDE_EPS 1e-3f  /* ... and its regulariser (luminance squared) */
/* The body's outline: the guided map q ramped from BODY_LEAST to PERSON_SURE (an outline pixel's mix
 * of shirt and wall takes about its share of the shirt's change: ramped from PERSON_LEAST, a pixel
 * 70 % shirt took 40 %, a pale line over a darkened shoulder; from 0.05, the filter's low tail took
 * the wall beside a lit shoulder by turns, a ragged fringe; London tuning 012 and 029, preset 3). */
#define BODY_LEAST 0.3f
/* How far the change reaches beyond the proxy's silhouette, as its normalised radius (1: on it). */
#define SKIN_REACH_SKULL 1.25f /* the ears, a fuller face than the proxy */
#define SKIN_REACH_NECK 1.5f
#define HAIR_REACH_SKULL 1.15f
#define HAIR_REACH_NECK 1.0f
/* Bands and blurs, in eye distances. */
#define HEAD_MESH_BAND 0.8f    /* the face's own field hands over to the head's over this band outside the mesh */
#define HEAD_NORMAL_BAND 0.6f  /* the model's normals hand over to the proxy's over this band */
#define HEAD_FIELD_BLUR 0.06f  /* the head's field is blurred by this much (the skull / neck crease) */
#define HEAD_SMOOTH 0.03f      /* the photo's blur before the colour tests (as forehead.c) */
#define HEAD_MASK_BLUR 0.04f   /* the skin and hair masks are blurred by this within the person, then ramped */
#define HEAD_HAIR_STRENGTH 0.5f
#define HEAD_LEAST 0.02f       /* beyond the face's own weight, a weight under this is 0 */
#define HEAD_NEAR_SKIN 0.12f   /* the hair within about twice this of the skin follows the skin */
#define BEARD_TO 0.0f          /* below this height (eye distances above the eyes) hair is a beard's ... */
#define HAIR_FROM 0.3f         /* ... above this the head's hair */
#define BEARD_SIDE 0.75f       /* a beard lies within this many eye distances of the face's axis ... */
#define BEARD_FADE 0.2f        /* ... fading out over this much more (the ears' edges are not a beard) */
#define SKIN_UP_FROM 0.6f      /* above these heights skin is the face's region's only */
#define SKIN_UP_TO 0.9f
#define HAIR_OVER_FROM 0.55f   /* above these heights, hair over the mesh takes the hair's change */
#define HAIR_OVER_TO 0.7f
/* The skin test: the cheeks' sample (as forehead.c) and its tolerances. */
#define CHEEK_LOW -0.8f
#define CHEEK_HIGH -0.25f
#define CHEEK_SIDE 0.7f
#define SKIN_MAD 2.5f
#define SKIN_CHROMA 0.015f
#define SKIN_DARKER 1.0f   /* log luminance below the cheeks' median still skin (a shadowed neck) */
#define SKIN_BRIGHTER 0.4f
#define SKIN_TEXTURE 0.01f
/* The background: the photo's border, this share of its side. */
#define BORDER 0.04f
#define BG_MAD 3.0f
#define BG_CHROMA 0.015f
#define BG_LOG_LUM 0.7f
#define BG_REGION_BLUR 0.06f /* eye distances */
#define BG_EDGE 0.06f        /* eye distances (at least 3 pixels): the person's outline, part background, is this wide */
/* With the face's segmentation (person_segment.c) the background is also where the person's
 * probability is under PERSON_LEAST (a busy background no colour test tells from hair: a flag, a
 * shelf); the background's colour stays the background's inside the network's person (the gaps
 * between curls, which its 256 pixels do not resolve), as without it. PERSON_SURE: where the
 * network is sure of the person (outline_share). */
#define PERSON_LEAST 0.5f
#define PERSON_SURE 0.95f
#define PERSON_NONE 0.02f   /* surely not the person: the background's colour sample */
#define BG_NEAR_LEAST 0.05f /* of the person's window, or the photo's border is sampled */
/* With it the hair is known wherever it goes: above the eyes (from HAIR_UP_FROM to HAIR_UP_TO eye
 * distances up) it reaches out to HAIR_REACH_PERSON of the skull (a bun, curls, a full head of hair),
 * its weight fading over the last HAIR_PERSON_FADE; lower, HAIR_REACH_SKULL as without (a collar
 * and the shoulders are not hair). */
#define HAIR_REACH_PERSON 1.7f
#define HAIR_PERSON_FADE 0.25f
#define HAIR_UP_FROM 0.0f
#define HAIR_UP_TO 0.5f
#define OUTLINE_CONTRAST 0.03f /* the person's and the background's colours this far apart (RGB) tell an outline's mix */
#define OUTLINE_LEAST 0.25f    /* an outline pixel with less of the person than this is the background's */

void hd_head_free(hd_head *h)
{
    if (!h) return;
    free(h->normal), free(h->proxy), free(h->mesh), free(h->skin), free(h->hair), free(h->bg);
    free(h->body), free(h->zone), free(h->neck), free(h->wb), free(h->ws), free(h->wh), free(h->near), free(h->share);
    memset(h, 0, sizeof *h);
}

/* The ray through photo pixel (x, y) in the canonical frame: P(t) = p0 + t v, t the camera depth. */
typedef struct ray {
    float p0[3], v[3];
} ray;

static ray ray_of(const hd_aligned_face *f, float x, float y)
{
    const float *R = f->rotation, s = f->scale;
    const float c[3] = {x - f->translation[0], -y - f->translation[1], -f->translation[2]};
    ray r;
    for (int k = 0; k < 3; k++) {
        r.p0[k] = (R[0 * 3 + k] * c[0] + R[1 * 3 + k] * c[1] + R[2 * 3 + k] * c[2]) / s;
        r.v[k] = R[2 * 3 + k] / s;
    }
    return r;
}

/* The front-most crossing of ray r with the quadric sum_k ((P_k - centre_k) / axis_k)^2 = 1 over
 * the axes with axis_k > 0: its depth *t (or, missed, the depth of closest approach) and rho, the
 * normalised radius there (1 on the surface when hit, > 1 when missed). */
static void cross(const ray *r, const float centre[3], const float axis[3], float *t, float *rho)
{
    double a = 0, b = 0, c = -1;
    for (int k = 0; k < 3; k++) {
        if (!(axis[k] > 0)) continue;
        const double q = (r->p0[k] - centre[k]) / axis[k], w = r->v[k] / axis[k];
        a += w * w, b += 2 * q * w, c += q * q;
    }
    if (a <= 0) {
        *t = 0, *rho = INFINITY;
        return;
    }
    const double disc = b * b - 4 * a * c;
    if (disc >= 0) {
        *t = (float)((-b + sqrt(disc)) / (2 * a));
        *rho = 1.0f;
    } else {
        *t = (float)(-b / (2 * a));
        *rho = (float)sqrt(1.0 + c - b * b / (4 * a)); /* (c + 1) at the closest approach */
    }
}

/* The camera-frame unit normal of the quadric at P (canonical), facing the viewer (z >= 0). */
static void quadric_normal(const hd_aligned_face *f, const float P[3], const float centre[3], const float axis[3],
                           float n[3])
{
    float m[3];
    for (int k = 0; k < 3; k++) m[k] = axis[k] > 0 ? (P[k] - centre[k]) / (axis[k] * axis[k]) : 0.0f;
    const float *R = f->rotation;
    for (int k = 0; k < 3; k++) n[k] = R[k * 3 + 0] * m[0] + R[k * 3 + 1] * m[1] + R[k * 3 + 2] * m[2];
    const float len = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(len > 1e-9f)) {
        n[0] = n[1] = 0, n[2] = 1;
        return;
    }
    n[0] /= len, n[1] /= len, n[2] /= len;
    /* turned toward the viewer until z >= PROXY_FACING: the face's own light is fitted on normals
     * that face the camera and, extrapolated to the silhouette's, can turn the change's sign there
     * (an ear lit up on the side the light leaves) */
    if (n[2] < PROXY_FACING) {
        const float xy = sqrtf(n[0] * n[0] + n[1] * n[1]);
        const float k = xy > 1e-9f ? sqrtf(1 - PROXY_FACING * PROXY_FACING) / xy : 0.0f;
        n[0] *= k, n[1] *= k, n[2] = xy > 1e-9f ? PROXY_FACING : 1.0f;
    }
}

/* The proxy at photo pixel (x, y): its normal and the skull's and the neck's normalised radii;
 * with torso, *torso is 1 within the torso's silhouette, fading to 0 at TORSO_REACH, and the body's
 * normal nb (body_normals; NULL: none) takes over from the head's below TORSO_TOP. */
static void proxy_at(const hd_aligned_face *f, int x, int y, float n[3], float *rho_skull, float *rho_neck,
                     float *torso, const float nb[3])
{
    static const float NECK_C[3] = {0.0f, 0.0f, NECK_Z}, NECK_A[3] = {NECK_R, 0.0f, NECK_R};
    const ray r = ray_of(f, x + 0.5f, y + 0.5f);
    float ts, tn;
    cross(&r, SKULL_C, SKULL_A, &ts, rho_skull);
    cross(&r, NECK_C, NECK_A, &tn, rho_neck);
    float Pn[3], Ps[3];
    for (int k = 0; k < 3; k++) Ps[k] = r.p0[k] + ts * r.v[k], Pn[k] = r.p0[k] + tn * r.v[k];
    if (Pn[1] > NECK_TOP) *rho_neck = INFINITY; /* the neck is below the jaw only */
    else if (Pn[1] < NECK_BOTTOM) *rho_neck += (NECK_BOTTOM - Pn[1]) / NECK_FADE;
    const int neck = *rho_neck <= 1.0f && (*rho_skull > 1.0f || tn > ts);
    const int skull = !neck && (*rho_skull <= 1.0f || *rho_skull <= *rho_neck);
    if (skull) quadric_normal(f, Ps, SKULL_C, SKULL_A, n);
    else quadric_normal(f, Pn, NECK_C, NECK_A, n);
    if (!torso) return;
    float tt, rt, Pt[3];
    cross(&r, TORSO_C, TORSO_A, &tt, &rt);
    for (int k = 0; k < 3; k++) Pt[k] = r.p0[k] + tt * r.v[k];
    const float below = hd_field_smoothstep((TORSO_TOP - Pt[1]) / TORSO_BLEND);
    *torso = 1.0f - hd_field_smoothstep((rt - 1.0f) / (TORSO_REACH - 1.0f));
    if (!(below > 0) || !nb) return;
    float len = 0;
    for (int k = 0; k < 3; k++) n[k] += below * (nb[k] - n[k]), len += n[k] * n[k];
    len = len > 1e-12f ? 1.0f / sqrtf(len) : 0.0f;
    for (int k = 0; k < 3; k++) n[k] *= len;
}

/* Window pixel (x, y) of head h as a photo pixel index. */
static size_t photo_index(const hd_head *h, int x, int y) { return (size_t)(y + h->y0) * h->W + (x + h->x0); }

/* The window index of photo pixel (x, y) of head h, or -1 outside its window (or without the body's
 * zone). */
static long body_index(const hd_head *h, int x, int y)
{
    if (!h || !h->zone) return -1;
    x -= h->x0, y -= h->y0;
    return x < 0 || y < 0 || x >= h->w || y >= h->h ? -1 : (long)y * h->w + x;
}

/* The person's share of window pixel i where the body's zone reaches it (its outline refined,
 * body_outline), or -1 beyond the zone. */
static float body_share(const hd_head *h, size_t i)
{
    return h->zone[i] > 1e-6f ? fminf(1.0f, h->body[i] / h->zone[i]) : -1.0f;
}

/* Medians and tolerances of the features over the window pixels where pick[i] is set. */
static int stats_of(const float *feat, size_t N, const unsigned char *pick, float *scratch, float med[NFEAT],
                    float mad[NFEAT])
{
    for (int k = 0; k < NFEAT; k++) {
        size_t n = 0;
        for (size_t i = 0; i < N; i++)
            if (pick[i]) scratch[n++] = feat[(size_t)k * N + i];
        if (!n) return 0;
        hd_median_mad(scratch, n, &med[k], &mad[k]);
    }
    return 1;
}

/* The probability that photo pixel (x, y) shows the person about face f (its segmentation; 0
 * outside the window it covers). */
static float person_at(const hd_aligned_face *f, int x, int y)
{
    x -= f->person_x0, y -= f->person_y0;
    if (x < 0 || y < 0 || x >= f->person.width || y >= f->person.height) return 0.0f;
    return f->person.data[(size_t)y * f->person.width + x];
}

/* person_at for the body: the map's last row carried on down below its window, and its first and
 * last columns out to the photo's sides (the body goes on beyond the segmented crop, a shoulder
 * to the photo's edge; where the map's edge is the wall, the wall goes on). */
static float person_below(const hd_aligned_face *f, int x, int y)
{
    const hd_image *m = &f->person;
    if (m->width < 1 || m->height < 1) return 0.0f;
    const int last = f->person_y0 + m->height - 1;
    if (y < f->person_y0) return 0.0f;
    y = y > last ? last : y;
    x = x < f->person_x0 ? f->person_x0 : x >= f->person_x0 + m->width ? f->person_x0 + m->width - 1 : x;
    return person_at(f, x, y);
}

/* The body's normals over h's window (3 planes), rounded off toward the person's outline: the
 * network's person (person_below, cut at PERSON_LEAST) blurred by BODY_ROUND eye distances is a
 * smooth height whose gradient turns the normal outward from the outline, from facing the camera
 * inside the body to PROXY_FACING on the outline itself, across the outline (so the top of a
 * shoulder faces up and an arm's side sideways). A cylinder standing for the chest gave the whole
 * side of a shirt one normal: under a side light one grey block, or, faded toward the shoulders
 * with the background kept, a grey smudge on a white shirt. Blurred over the whole photo on a
 * k-times coarser grid (the blur is wide), its gradient interpolated back bilinearly: the same
 * normals whatever the window (the body near the neck or all of it); the photo's edge is not an
 * outline (the clamped blur carries the body on past it, as the person goes on). */
static hd_status body_normals(const hd_head *h, const hd_aligned_face *f, float *nb)
{
    const size_t N = (size_t)h->w * h->h;
    const float sigma = fmaxf(2.0f, BODY_ROUND * h->frame.e);
    const int k = sigma > 8.0f ? (int)(sigma / 4.0f) : 1;
    const int cw = (h->W + k - 1) / k, ch = (h->H + k - 1) / k;
    const size_t C = (size_t)cw * ch;
    float *m = hd_calloc(C, sizeof(float)), *cnt = hd_calloc(C, sizeof(float));
    float *gx = hd_malloc(C * sizeof(float)), *gy = hd_malloc(C * sizeof(float));
    hd_status st = m && cnt && gx && gy ? HD_OK : HD_ERR_NOMEM;
    for (int y = 0; st == HD_OK && y < h->H; y++)
        for (int x = 0; x < h->W; x++) {
            const size_t c = (size_t)(y / k) * cw + (size_t)(x / k);
            m[c] += person_below(f, x, y) >= PERSON_LEAST ? 1.0f : 0.0f, cnt[c] += 1.0f;
        }
    for (size_t c = 0; st == HD_OK && c < C; c++) m[c] /= cnt[c];
    if (st == HD_OK) st = hd_field_blur(m, cw, ch, sigma / (float)k);
    /* the gradient per photo pixel, scaled so that a straight outline's is 1 where it is steepest
     * (1 / (sigma sqrt(2 pi)) there) */
    const float scale = sigma * 2.5066283f / (float)k;
    for (int y = 0; st == HD_OK && y < ch; y++)
        for (int x = 0; x < cw; x++) {
            const int xl = x > 0 ? x - 1 : x, xr = x < cw - 1 ? x + 1 : x;
            const int yu = y > 0 ? y - 1 : y, yd = y < ch - 1 ? y + 1 : y;
            const size_t c = (size_t)y * cw + x;
            gx[c] = xr > xl ? scale * (m[(size_t)y * cw + xr] - m[(size_t)y * cw + xl]) / (float)(xr - xl) : 0.0f;
            gy[c] = yd > yu ? scale * (m[(size_t)yd * cw + x] - m[(size_t)yu * cw + x]) / (float)(yd - yu) : 0.0f;
        }
    const float most = sqrtf(1.0f - PROXY_FACING * PROXY_FACING);
    for (int y = 0; st == HD_OK && y < h->h; y++)
        for (int x = 0; x < h->w; x++) {
            float u = ((float)(x + h->x0) + 0.5f) / (float)k - 0.5f, v = ((float)(y + h->y0) + 0.5f) / (float)k - 0.5f;
            u = u < 0 ? 0 : u > cw - 1 ? (float)(cw - 1) : u, v = v < 0 ? 0 : v > ch - 1 ? (float)(ch - 1) : v;
            const int x0 = (int)u, y0 = (int)v, x1 = x0 + 1 < cw ? x0 + 1 : x0, y1 = y0 + 1 < ch ? y0 + 1 : y0;
            const float a = u - (float)x0, b = v - (float)y0;
            const size_t c00 = (size_t)y0 * cw + x0, c01 = (size_t)y0 * cw + x1;
            const size_t c10 = (size_t)y1 * cw + x0, c11 = (size_t)y1 * cw + x1;
            const float dx = (1 - b) * ((1 - a) * gx[c00] + a * gx[c01]) + b * ((1 - a) * gx[c10] + a * gx[c11]);
            const float dy = (1 - b) * ((1 - a) * gy[c00] + a * gy[c01]) + b * ((1 - a) * gy[c10] + a * gy[c11]);
            /* outward is down the gradient; the photo's y runs down, the normal's up */
            float nx = -dx * most, ny = dy * most;
            const float t = sqrtf(nx * nx + ny * ny);
            if (t > most) nx *= most / t, ny *= most / t;
            const size_t i = (size_t)y * h->w + x;
            nb[i] = nx, nb[N + i] = ny, nb[2 * N + i] = sqrtf(fmaxf(0.0f, 1.0f - nx * nx - ny * ny));
        }
    free(m), free(cnt), free(gx), free(gy);
    return st;
}

/* The background's colour: medians and deviations of chroma and log luminance over the photo's
 * border (BORDER of its side; the pixels as they are), or with the face's segmentation f over the
 * pixels of the person's window it is sure are not the person (PERSON_NONE; at least
 * BG_NEAR_LEAST of the window): the wall behind the head rather than everything at the photo's
 * edge (a flag, a suit); 0 without memory. */
static int background(const hd_image *photo, const hd_aligned_face *f, float med[NFEAT], float mad[NFEAT])
{
    const int W = photo->width, H = photo->height, bw = (int)ceilf(BORDER * (W > H ? W : H));
    const size_t P = (size_t)W * H;
    float *v = hd_malloc((P ? P : 1) * sizeof(float));
    if (!v) return 0;
    size_t sure = 0;
    for (size_t p = 0; f->person.data && p < (size_t)f->person.width * f->person.height; p++)
        sure += f->person.data[p] < PERSON_NONE;
    const int near = f->person.data && (double)sure >= BG_NEAR_LEAST * f->person.width * f->person.height;
    /* the pixels sampled: the window's sure background, or the photo's border */
    const int x0 = near ? f->person_x0 : 0, y0 = near ? f->person_y0 : 0;
    const int x1 = near ? x0 + f->person.width : W, y1 = near ? y0 + f->person.height : H;
    for (int k = 0; k < NFEAT; k++) {
        size_t n = 0;
        for (int y = y0; y < y1; y++)
            for (int x = x0; x < x1; x++) {
                if (near ? !(person_at(f, x, y) < PERSON_NONE) : !(x < bw || y < bw || x >= W - bw || y >= H - bw))
                    continue;
                const size_t p = (size_t)y * W + x;
                float feat[F_TEXTURE];
                hd_colour_features(photo->data[p], photo->data[P + p], photo->data[2 * P + p], feat);
                v[n++] = k < F_TEXTURE ? feat[k] : 0.0f;
            }
        if (!n) {
            free(v);
            return 0;
        }
        hd_median_mad(v, n, &med[k], &mad[k]);
    }
    free(v);
    return 1;
}

/* Whether colour (r, g, b) is the background's (medians med, deviations mad of background()). */
static int is_background(float r, float g, float b, const float med[NFEAT], const float mad[NFEAT])
{
    float f[F_TEXTURE];
    hd_colour_features(r, g, b, f);
    return fabsf(f[F_CHROMA_R] - med[F_CHROMA_R]) <= BG_MAD * mad[F_CHROMA_R] + BG_CHROMA &&
           fabsf(f[F_CHROMA_G] - med[F_CHROMA_G]) <= BG_MAD * mad[F_CHROMA_G] + BG_CHROMA &&
           fabsf(f[F_LOG_LUM] - med[F_LOG_LUM]) <= BG_MAD * mad[F_LOG_LUM] + BG_LOG_LUM;
}

/* v blurred by sigma over the person only (normalised by the blurred share of pixels that are not
 * the background, person): the background's pixels count for nothing and end at 0. */
static hd_status blur_within(float *v, const float *bg, const float *person, int w, int h, float sigma)
{
    const size_t N = (size_t)w * h;
    for (size_t i = 0; i < N; i++) v[i] *= 1 - bg[i];
    hd_status st = hd_field_blur(v, w, h, sigma);
    for (size_t i = 0; st == HD_OK && i < N; i++) {
        const float u = bg[i] < 0.5f && person[i] > 1e-6f ? v[i] / person[i] : 0.0f;
        v[i] = u < 0 ? 0 : u > 1 ? 1 : u;
    }
    return st;
}

/* Grows region (0 / 1, w x h) through the pixels where through is > 0.5, at most reach steps
 * (4-neighbours) from where it was: what is connected to it by such pixels, nearby. */
static hd_status grow_through(float *region, const float *through, int w, int h, int reach)
{
    const size_t N = (size_t)w * h;
    int *step = hd_malloc((N ? N : 1) * sizeof(int));
    size_t *queue = hd_malloc((N ? N : 1) * sizeof(size_t)), head = 0, tail = 0;
    if (!step || !queue) {
        free(step), free(queue);
        return HD_ERR_NOMEM;
    }
    for (size_t i = 0; i < N; i++) {
        step[i] = region[i] > 0.5f ? 0 : -1;
        if (!step[i]) queue[tail++] = i;
    }
    while (head < tail) {
        const size_t i = queue[head++];
        const int x = (int)(i % (size_t)w), y = (int)(i / (size_t)w);
        if (step[i] >= reach) continue;
        const size_t next[4] = {x > 0 ? i - 1 : i, x + 1 < w ? i + 1 : i, y > 0 ? i - (size_t)w : i,
                                y + 1 < h ? i + (size_t)w : i};
        for (int k = 0; k < 4; k++)
            if (step[next[k]] < 0 && through[next[k]] > 0.5f) {
                step[next[k]] = step[i] + 1;
                region[next[k]] = 1.0f;
                queue[tail++] = next[k];
            }
    }
    free(step), free(queue);
    return HD_OK;
}

/* The window's colours (3 planes) into rgb. */
static void window_rgb(const hd_head *h, const hd_image *photo, float *rgb)
{
    const size_t N = (size_t)h->w * h->h, P = (size_t)h->W * h->H;
    for (int c = 0; c < 3; c++)
        for (int y = 0; y < h->h; y++)
            memcpy(rgb + (size_t)c * N + (size_t)y * h->w, photo->data + (size_t)c * P + photo_index(h, 0, y),
                   (size_t)h->w * sizeof(float));
}

/* The person's share of the light of photo pixel p (P pixels a plane) that mixes the person's
 * colour cf and the background's cb (3 planes of N, at i): the pixel I = a F + (1 - a) B relit by r
 * is I + a F (r - 1), so its weight is a F / I (luminances), a from the colours (I projected on the
 * line from B to F: blond hair and a grey wall may share a luminance, not a colour); -1 where the
 * two colours are too close to tell a mix (OUTLINE_CONTRAST) or the pixel is black. */
static float mix_share(const hd_image *photo, size_t p, size_t P, const float *cf, const float *cb, size_t i, size_t N)
{
    float num = 0, den = 0, I[3], F[3];
    for (int c = 0; c < 3; c++) {
        I[c] = photo->data[(size_t)c * P + p], F[c] = cf[(size_t)c * N + i];
        const float fb = F[c] - cb[(size_t)c * N + i];
        num += (I[c] - cb[(size_t)c * N + i]) * fb, den += fb * fb;
    }
    const float li = hd_luma(I[0], I[1], I[2]), lf = hd_luma(F[0], F[1], F[2]);
    if (!(den > OUTLINE_CONTRAST * OUTLINE_CONTRAST) || !(li > 1e-3f)) return -1.0f;
    float a = num / den;
    a = a < 0 ? 0 : a > 1 ? 1 : a;
    const float w = a * lf / li;
    return w > 1 ? 1 : w;
}

/* The person's share of the light reaching the camera at each pixel of its outline (share, 1
 * elsewhere; the background h->bg and person, 1 inside the person and less on its outline, both
 * final): an outline pixel I mixes the person's colour F (carried out from the person's inside)
 * and the background's B (carried in from the background), I = a F + (1 - a) B, so that relit by
 * r it is I + a F (r - 1): its weight is a F / I (luminances), a from the colours (I projected on
 * the line from B to F: blond hair and a grey wall may share a luminance, not a colour). Without it the outline's
 * pixels took the whole change, their background's part with it (a white rim round an ear under a
 * light that brightens it). A share under OUTLINE_LEAST is 0: the pixel is the background's. With
 * the face's segmentation f, F is carried out from where the network is sure of the person
 * (PERSON_SURE), and where the two colours are too close to tell a mix the share is its
 * probability ramped from PERSON_LEAST to PERSON_SURE (the change fades over its soft edge). */
static hd_status outline_share(const hd_head *h, const hd_aligned_face *f, const hd_image *photo, const float *person,
                               float *share)
{
    const size_t N = (size_t)h->w * h->h, P = (size_t)h->W * h->H;
    float *cb = hd_malloc(3 * N * sizeof(float)), *cf = hd_malloc(3 * N * sizeof(float));
    float *known = hd_malloc(N * sizeof(float));
    hd_status st = cb && cf && known ? HD_OK : HD_ERR_NOMEM;
    if (st == HD_OK) {
        window_rgb(h, photo, cb);
        memcpy(cf, cb, 3 * N * sizeof(float));
        memcpy(known, h->bg, N * sizeof(float));
    }
    for (int c = 0; c < 3 && st == HD_OK; c++) st = hd_field_fill(cb + (size_t)c * N, known, h->w, h->h);
    for (int y = 0; st == HD_OK && y < h->h; y++)
        for (int x = 0; x < h->w; x++) {
            const size_t i = (size_t)y * h->w + x;
            known[i] = person[i] >= 1.0f && !(f->person.data && person_at(f, x + h->x0, y + h->y0) < PERSON_SURE);
        }
    for (int c = 0; c < 3 && st == HD_OK; c++) st = hd_field_fill(cf + (size_t)c * N, known, h->w, h->h);
    for (int y = 0; st == HD_OK && y < h->h; y++)
        for (int x = 0; x < h->w; x++) {
            const size_t i = (size_t)y * h->w + x, p = photo_index(h, x, y);
            share[i] = 1.0f;
            if (h->bg[i] > 0.5f || person[i] >= 1.0f) continue;
            const float w = mix_share(photo, p, P, cf, cb, i, N);
            if (w < 0) { /* no telling them apart */
                if (f->person.data) {
                    const float v = hd_field_smoothstep((person_at(f, x + h->x0, y + h->y0) - PERSON_LEAST) /
                                                        (PERSON_SURE - PERSON_LEAST));
                    share[i] = v < OUTLINE_LEAST ? 0 : v;
                }
                continue;
            }
            share[i] = w < OUTLINE_LEAST ? 0 : w;
        }
    free(cb), free(cf), free(known);
    return st;
}

/* The body's outline (h->body holds the torso's reach below the chin): the network's map (carried
 * on down below its window) refined to the photo's own edges by a guided filter (He, Sun and Tang,
 * ECCV 2010) on the luminance, then ramped from BODY_LEAST to PERSON_SURE.
 * The map's pixels are two or three of the photo's: alone, its soft edge reached into the wall (a
 * dark rim above a shoulder) or, cut where it is sure, stopped short of a white shirt's edge against
 * a pale wall, in steps; the colour test cannot tell that shirt from that wall at all. */
static hd_status body_outline(hd_head *h, const hd_aligned_face *f, const hd_image *photo)
{
    const size_t N = (size_t)h->w * h->h, P = (size_t)h->W * h->H;
    float *I = hd_malloc(N * sizeof(float)), *p = hd_malloc(N * sizeof(float));
    float *mI = hd_malloc(N * sizeof(float)), *mp = hd_malloc(N * sizeof(float));
    float *II = hd_malloc(N * sizeof(float)), *Ip = hd_malloc(N * sizeof(float));
    hd_status st = I && p && mI && mp && II && Ip ? HD_OK : HD_ERR_NOMEM;
    const float sigma = fmaxf(2.0f, BODY_GUIDE * h->frame.e);
    for (int y = 0; st == HD_OK && y < h->h; y++)
        for (int x = 0; x < h->w; x++) {
            const size_t i = (size_t)y * h->w + x, q = photo_index(h, x, y);
            I[i] = hd_luma(photo->data[q], photo->data[P + q], photo->data[2 * P + q]);
            p[i] = person_below(f, x + h->x0, y + h->y0);
            mI[i] = I[i], mp[i] = p[i], II[i] = I[i] * I[i], Ip[i] = I[i] * p[i];
        }
    float *planes[] = {mI, mp, II, Ip};
    for (int k = 0; k < 4 && st == HD_OK; k++) st = hd_field_blur(planes[k], h->w, h->h, sigma);
    /* q = a I + b with a, b the local linear fit of the map on the luminance, themselves smoothed */
    for (size_t i = 0; st == HD_OK && i < N; i++) {
        const float var = II[i] - mI[i] * mI[i], cov = Ip[i] - mI[i] * mp[i];
        const float a = cov / (var + BODY_GUIDE_EPS);
        II[i] = a, Ip[i] = mp[i] - a * mI[i];
    }
    if (st == HD_OK) st = hd_field_blur(II, h->w, h->h, sigma);
    if (st == HD_OK) st = hd_field_blur(Ip, h->w, h->h, sigma);
    /* where the network is sure there is no person (PERSON_NONE) the wall stays the wall's: the
     * filter's low tail reaches a few pixels into it */
    for (size_t i = 0; st == HD_OK && i < N; i++)
        if (h->body[i] > 0)
            h->body[i] *= p[i] < PERSON_NONE ? 0.0f
                                             : hd_field_smoothstep((II[i] * I[i] + Ip[i] - BODY_LEAST) /
                                                                   (PERSON_SURE - BODY_LEAST));
    free(I), free(p), free(mI), free(mp), free(II), free(Ip);
    return st;
}

/* How near the neck window pixel (x, y) of h lies: 1 down to CHEST_FROM eye distances below the eyes
 * and within CHEST_SIDE_FROM of the face's centre line, fading to 0 at CHEST_TO and CHEST_SIDE_TO. */
static float near_neck(const hd_head *h, int x, int y)
{
    const float depth = -hd_face_height(&h->frame, x + h->x0, y + h->y0);
    const float side = fabsf(hd_face_side(&h->frame, x + h->x0, y + h->y0));
    return (1 - hd_field_smoothstep((depth - CHEST_FROM) / (CHEST_TO - CHEST_FROM))) *
           (1 - hd_field_smoothstep((side - CHEST_SIDE_FROM) / (CHEST_SIDE_TO - CHEST_SIDE_FROM)));
}

/* The body's reach near the neck (h->neck): near_neck, and within CHEST_EDGE fading toward the
 * person's outline (the body's outline, body_outline, where the torso reaches; the network's map
 * above it). With the background kept (HD_HEAD_BODY_NEAR) the body's weight is cut to it, so the
 * change ends inside the person, smoothly, on skin and clothes alike; with the background relit it
 * is the body's part of the brightness kept (hd_head_weight's wb), the same as with it kept. */
static hd_status neck_reach(hd_head *h, const hd_aligned_face *f)
{
    const size_t N = (size_t)h->w * h->h;
    float *inside = hd_malloc(N * sizeof(float));
    h->neck = hd_malloc(N * sizeof(float));
    hd_status st = inside && h->neck ? HD_OK : HD_ERR_NOMEM;
    for (int y = 0; st == HD_OK && y < h->h; y++)
        for (int x = 0; x < h->w; x++) {
            const size_t i = (size_t)y * h->w + x;
            const float body = body_share(h, i), share = body >= 0 ? body : person_below(f, x + h->x0, y + h->y0);
            inside[i] = share >= 0.5f ? 1.0f : 0.0f;
        }
    if (st == HD_OK) st = hd_field_feather(inside, h->w, h->h, fmaxf(2.0f, CHEST_EDGE * h->frame.e), h->neck);
    for (int y = 0; st == HD_OK && y < h->h; y++)
        for (int x = 0; x < h->w; x++) h->neck[(size_t)y * h->w + x] *= near_neck(h, x, y);
    free(inside);
    return st;
}

/* How far the hair reaches at photo pixel (x, y), as the skull's normalised radius, and the weight
 * of hair at radius rs there (1 up to the fade). */
static float hair_reach(const hd_head *h, int segmented, int x, int y, float rs, float *weight)
{
    *weight = 1.0f;
    if (!segmented) return HAIR_REACH_SKULL;
    const float up = hd_field_smoothstep((hd_face_height(&h->frame, x, y) - HAIR_UP_FROM) / (HAIR_UP_TO - HAIR_UP_FROM));
    const float reach = HAIR_REACH_SKULL + up * (HAIR_REACH_PERSON - HAIR_REACH_SKULL);
    const float from = fmaxf(HAIR_REACH_SKULL, reach - HAIR_PERSON_FADE);
    if (reach - from > 1e-3f) *weight = 1.0f - hd_field_smoothstep((rs - from) / (reach - from));
    return reach;
}

/* Whether pixel i of the features (N pixels a plane) is the skin of medians med, deviations mad. */
static int is_skin(const float *feat, size_t N, size_t i, const float med[NFEAT], const float mad[NFEAT])
{
    const float cr = feat[(size_t)F_CHROMA_R * N + i], cg = feat[(size_t)F_CHROMA_G * N + i];
    const float ll = feat[(size_t)F_LOG_LUM * N + i], tx = feat[(size_t)F_TEXTURE * N + i];
    return fabsf(cr - med[F_CHROMA_R]) <= SKIN_MAD * mad[F_CHROMA_R] + SKIN_CHROMA &&
           fabsf(cg - med[F_CHROMA_G]) <= SKIN_MAD * mad[F_CHROMA_G] + SKIN_CHROMA &&
           ll >= med[F_LOG_LUM] - SKIN_DARKER && ll <= med[F_LOG_LUM] + SKIN_BRIGHTER &&
           tx <= med[F_TEXTURE] + SKIN_MAD * mad[F_TEXTURE] + SKIN_TEXTURE;
}

/* The skin, hair and background masks of the window (the photo's colours, the proxy's reach). The
 * background is 0 or 1, tested on the photo's own pixels (no blur, so the person's outline stays
 * where it is); the skin and the hair are blurred within the person and share its weight, so the
 * change holds up to the outline (a fade there left a pale rim of unchanged edge pixels round a
 * darkened face, and reached into the background) and does not dip where skin meets hair. */
static hd_status masks(hd_head *h, const hd_aligned_face *f, const hd_image *photo, const float *coverage,
                       const float *rho)
{
    const size_t N = (size_t)h->w * h->h;
    float *rgb = hd_malloc(3 * N * sizeof(float)), *feat = hd_malloc(NFEAT * N * sizeof(float));
    float *scratch = hd_malloc(N * sizeof(float)), *person = hd_malloc(N * sizeof(float));
    float *share = hd_malloc(N * sizeof(float));
    unsigned char *pick = hd_calloc(N, 1), *own = hd_calloc(N, 1);
    hd_status st = rgb && feat && scratch && person && share && pick && own ? HD_OK : HD_ERR_NOMEM;
    for (size_t i = 0; st == HD_OK && i < N; i++) share[i] = 1.0f;
    float skin_med[NFEAT], skin_mad[NFEAT], bg_med[NFEAT], bg_mad[NFEAT];
    const int segmented = f->person.data != NULL;
    const int have_colour = st == HD_OK && background(photo, f, bg_med, bg_mad), have_bg = segmented || have_colour;
    if (st == HD_OK) window_rgb(h, photo, rgb);
    for (int y = 0; st == HD_OK && y < h->h; y++)
        for (int x = 0; x < h->w; x++) {
            const size_t i = (size_t)y * h->w + x;
            const float p = segmented ? person_at(f, x + h->x0, y + h->y0) : 0.0f;
            const int colour = have_colour && is_background(rgb[i], rgb[N + i], rgb[2 * N + i], bg_med, bg_mad);
            h->bg[i] = (float)(colour || (segmented && p < PERSON_LEAST));
        }
    /* the skin on the photo's own colours (blurred a little): the cheeks' sample, then the test;
     * it wins over the background's colour (a beige wall) */
    if (st == HD_OK) st = hd_skin_features(rgb, h->w, h->h, HEAD_SMOOTH * h->frame.e, feat);
    int have_skin = 0;
    if (st == HD_OK) {
        for (int y = 0; y < h->h; y++)
            for (int x = 0; x < h->w; x++) {
                const int gx = x + h->x0, gy = y + h->y0;
                const float ht = hd_face_height(&h->frame, gx, gy);
                pick[(size_t)y * h->w + x] = coverage[photo_index(h, x, y)] > 0.5f && ht >= CHEEK_LOW &&
                                             ht <= CHEEK_HIGH && fabsf(hd_face_side(&h->frame, gx, gy)) <= CHEEK_SIDE;
            }
        have_skin = stats_of(feat, N, pick, scratch, skin_med, skin_mad);
    }
    for (size_t i = 0; st == HD_OK && i < N; i++) {
        const int x = (int)(i % (size_t)h->w) + h->x0, y = (int)(i / (size_t)h->w) + h->y0;
        own[i] = (unsigned char)(have_skin && is_skin(feat, N, i, skin_med, skin_mad) &&
                                 !(segmented && person_at(f, x, y) < PERSON_LEAST));
        if (own[i]) h->bg[i] = 0.0f;
    }
    /* again on the colours with the background and the person's outermost pixels (within BG_EDGE:
     * the outline's pixels are part background) filled from the person's inside: mixed with the
     * background's colour, a shadowed neck's edge failed both tests and kept the old light, a dark
     * rim under a light that brightens, a pale one under a light that darkens; a pixel of the
     * background's own colour stays the background's */
    for (size_t i = 0; st == HD_OK && i < N; i++) scratch[i] = 1.0f - h->bg[i];
    if (st == HD_OK && have_bg && have_skin)
        st = hd_field_feather(scratch, h->w, h->h, fmaxf(3.0f, BG_EDGE * h->frame.e), person);
    if (st == HD_OK && have_bg && have_skin) {
        window_rgb(h, photo, rgb);
        for (size_t i = 0; i < N; i++) scratch[i] = person[i] >= 1.0f ? 1.0f : 0.0f;
        for (int c = 0; c < 3 && st == HD_OK; c++) st = hd_field_fill(rgb + (size_t)c * N, scratch, h->w, h->h);
        if (st == HD_OK) st = hd_skin_features(rgb, h->w, h->h, HEAD_SMOOTH * h->frame.e, feat);
    }
    for (size_t i = 0; st == HD_OK && i < N; i++) {
        const int skin = own[i] || (have_skin && h->bg[i] < 0.5f && is_skin(feat, N, i, skin_med, skin_mad));
        h->skin[i] = (float)skin;
        scratch[i] = h->bg[i];
    }
    /* the background as a region: small patches of its colour inside the hair (blond hair against
     * a beige wall) are hair, or the hair changed and stayed by turns (blotches) (the blur rounds
     * off the region's concave corners too: the notch between an earlobe and the jaw, which the
     * outline's share below gives back to the background) ... */
    if (st == HD_OK) st = hd_field_blur(scratch, h->w, h->h, BG_REGION_BLUR * h->frame.e);
    for (int y = 0; st == HD_OK && y < h->h; y++)
        for (int x = 0; x < h->w; x++) {
            const size_t i = (size_t)y * h->w + x;
            person[i] = scratch[i] > 0.5f && h->bg[i] > 0.5f ? 1.0f : 0.0f;
            scratch[i] = person[i] > 0.5f && (x == 0 || y == 0 || x == h->w - 1 || y == h->h - 1) ? 1.0f : 0.0f;
        }
    /* ... and what of it is enclosed by the person (a patch inside blond hair) is the person's:
     * the background reaches the window's edge */
    if (st == HD_OK) st = grow_through(scratch, person, h->w, h->h, h->w + h->h);
    for (size_t i = 0; st == HD_OK && i < N; i++) h->bg[i] = scratch[i];
    /* the person's outline against that background, and the person's share of its pixels */
    for (size_t i = 0; st == HD_OK && i < N; i++) scratch[i] = 1.0f - h->bg[i];
    if (st == HD_OK && have_bg) st = hd_field_feather(scratch, h->w, h->h, fmaxf(3.0f, BG_EDGE * h->frame.e), person);
    if (st == HD_OK && have_bg) st = outline_share(h, f, photo, person, share);
    for (size_t i = 0; st == HD_OK && i < N; i++) {
        const float rs = rho[2 * i], rn = rho[2 * i + 1];
        float fade;
        const float reach = hair_reach(h, segmented, (int)(i % (size_t)h->w) + h->x0, (int)(i / (size_t)h->w) + h->y0,
                                       rs, &fade);
        const int hair = h->skin[i] < 0.5f && h->bg[i] < 0.5f && (rs <= reach || rn <= HAIR_REACH_NECK);
        h->hair[i] = hair ? (rn <= HAIR_REACH_NECK ? 1.0f : fade) : 0.0f;
        person[i] = 1.0f - h->bg[i];
    }
    /* softened within the person: skin and hair share its weight, which fades (ramped) only where
     * neither goes on (a collar, the proxy's reach), never toward the background */
    const float sigma = HEAD_MASK_BLUR * h->frame.e;
    if (st == HD_OK) st = hd_field_blur(person, h->w, h->h, sigma);
    if (st == HD_OK) st = blur_within(h->skin, h->bg, person, h->w, h->h, sigma);
    if (st == HD_OK) st = blur_within(h->hair, h->bg, person, h->w, h->h, sigma);
    for (size_t i = 0; st == HD_OK && i < N; i++) {
        const float u = h->skin[i] + h->hair[i];
        const float k = u > 1e-6f ? hd_field_smoothstep((u - 0.3f) / 0.5f) / u : 0.0f;
        h->skin[i] *= k, h->hair[i] *= k;
    }
    /* the skin's weight fades out toward the proxy's reach (no edge where the skin goes on: the
     * shoulders, a chest), from radius 1 to the reach; on the outline, the person's share of the
     * pixel changes */
    for (size_t i = 0; st == HD_OK && i < N; i++) {
        const float fs = 1 - hd_field_smoothstep((rho[2 * i] - 1) / (SKIN_REACH_SKULL - 1));
        const float fn = 1 - hd_field_smoothstep((rho[2 * i + 1] - 1) / (SKIN_REACH_NECK - 1));
        h->skin[i] *= (fs > fn ? fs : fn) * share[i];
        h->hair[i] *= share[i];
        h->share[i] = share[i];
    }
    free(rgb), free(feat), free(scratch), free(person), free(share), free(pick), free(own);
    return st;
}

/* masks() over the head's own window (sx0, sy0, sw x sh, within h's): with the body, h's window
 * reaches down the torso, and the masks' window-wide steps (the background's region grown from the
 * window's edge, the colours filled from the person's inside, the blurs) would move the head's
 * outline with it: the background relit or not, the head is the same. Outside it no skin and no
 * hair (the body's weight is the person there), the background's flag set. */
static hd_status head_masks(hd_head *h, const hd_aligned_face *f, const hd_image *photo, const float *coverage,
                            const float *rho, int sx0, int sy0, int sw, int sh)
{
    h->mx0 = sx0, h->my0 = sy0, h->mw = sw, h->mh = sh;
    if (sx0 == h->x0 && sy0 == h->y0 && sw == h->w && sh == h->h) return masks(h, f, photo, coverage, rho);
    hd_head s = *h;
    s.x0 = sx0, s.y0 = sy0, s.w = sw, s.h = sh;
    const size_t M = (size_t)sw * sh, N = (size_t)h->w * h->h;
    s.bg = hd_malloc(M * sizeof(float)), s.skin = hd_malloc(M * sizeof(float)), s.hair = hd_malloc(M * sizeof(float));
    s.share = hd_malloc(M * sizeof(float));
    float *r = hd_malloc(2 * M * sizeof(float));
    hd_status st = s.bg && s.skin && s.hair && s.share && r ? HD_OK : HD_ERR_NOMEM;
    for (int y = 0; st == HD_OK && y < sh; y++)
        for (int x = 0; x < sw; x++) {
            const size_t j = (size_t)y * sw + x, i = (size_t)(y + sy0 - h->y0) * h->w + (size_t)(x + sx0 - h->x0);
            r[2 * j] = rho[2 * i], r[2 * j + 1] = rho[2 * i + 1];
        }
    if (st == HD_OK) st = masks(&s, f, photo, coverage, r);
    for (size_t i = 0; st == HD_OK && i < N; i++) h->bg[i] = h->share[i] = 1.0f, h->skin[i] = h->hair[i] = 0.0f;
    for (int y = 0; st == HD_OK && y < sh; y++)
        for (int x = 0; x < sw; x++) {
            const size_t j = (size_t)y * sw + x, i = (size_t)(y + sy0 - h->y0) * h->w + (size_t)(x + sx0 - h->x0);
            h->bg[i] = s.bg[j], h->skin[i] = s.skin[j], h->hair[i] = s.hair[j], h->share[i] = s.share[j];
        }
    free(s.bg), free(s.skin), free(s.hair), free(s.share), free(r);
    return st;
}

/* The rule's guard g (rule.c): a share (guard; <= 0: HD_RATIO_GUARD) of the face's mean source
 * shading over its mask. */
static hd_status guard_of(const hd_decomposition *d, const hd_image *mask, const float source[HD_SH_COEFFS],
                          float guard, float *g)
{
    const int S = d->normal.width;
    const size_t T = (size_t)S * d->normal.height;
    hd_image m = {0};
    float *s = hd_malloc((T ? T : 1) * sizeof(float));
    hd_status st = s ? HD_OK : HD_ERR_NOMEM;
    if (st == HD_OK && mask && mask->data) st = hd_image_resize(mask, S, d->normal.height, &m);
    double mean = 0;
    long count = 0;
    if (st == HD_OK) {
        hd_sh_shading_map(d->normal.data, NULL, (int)T, source, s);
        for (size_t p = 0; p < T; p++)
            if (!m.data || m.data[p] > 0.5f) mean += s[p] > 0 ? s[p] : 0, count++;
    }
    const float share = guard > 0 && isfinite(guard) ? guard : HD_RATIO_GUARD;
    *g = share * (count > 0 && mean > 0 ? (float)(mean / count) : 1.0f);
    free(s);
    hd_image_free(&m);
    return st;
}

hd_status hd_head_init(const hd_aligned_face *f, const hd_decomposition *d, const hd_image *photo,
                       const float source[HD_SH_COEFFS], float guard, int body, hd_head *h)
{
    memset(h, 0, sizeof *h);
    if (!f || !d || !d->normal.data || d->normal.channels != 3 || !photo || !photo->data || photo->channels != 3)
        return hd_fail(HD_ERR_ARG, "relight: the head needs a face, its normals and a 3-channel photo");
    if (!hd_face_frame_of(f, &h->frame) || !(f->scale > 0)) return HD_OK; /* no frame: the face alone */
    hd_status st = guard_of(d, &f->mask, source, guard, &h->g);
    if (st != HD_OK) return st;
    const int W = photo->width, H = photo->height, torso_on = body != HD_HEAD_BODY_NONE && f->person.data;
    const size_t P = (size_t)W * H;
    h->W = W, h->H = H;
    /* the window: the proxy's reach, from a coarse scan of the photo; the head's own (box 0) and,
     * with the body, the torso's reach below the chin too (box 1) */
    int box[2][4] = {{W, H, -1, -1}, {W, H, -1, -1}}; /* x0, y0, x1, y1 */
    const int stride = (int)fmaxf(1.0f, 0.05f * h->frame.e);
    for (int y = 0; y < H; y += stride)
        for (int x = 0; x < W; x += stride) {
            float n[3], rs, rn, torso = 0.0f;
            proxy_at(f, x, y, n, &rs, &rn, torso_on ? &torso : NULL, NULL);
            const int head = rs <= (f->person.data ? HAIR_REACH_PERSON : SKIN_REACH_SKULL) || rn <= SKIN_REACH_NECK;
            const float depth = -hd_face_height(&h->frame, x, y);
            const int near = body == HD_HEAD_BODY_ALL ||
                             (depth < CHEST_TO && fabsf(hd_face_side(&h->frame, x, y)) < CHEST_SIDE_TO);
            const int in[2] = {head, head || (torso > 0 && depth > BODY_FROM && near)};
            for (int k = 0; k < 2; k++)
                if (in[k]) {
                    int *b = box[k];
                    b[0] = x < b[0] ? x : b[0], b[1] = y < b[1] ? y : b[1], b[2] = x > b[2] ? x : b[2], b[3] = y > b[3] ? y : b[3];
                }
        }
    if (box[1][2] < 0) return HD_OK;
    for (int k = 0; k < 2; k++) {
        int *b = box[k];
        if (b[2] < 0) b[0] = box[1][0], b[1] = box[1][1], b[2] = box[1][0], b[3] = box[1][1]; /* no head: one pixel */
        b[0] = b[0] - stride < 0 ? 0 : b[0] - stride, b[1] = b[1] - stride < 0 ? 0 : b[1] - stride;
        b[2] = b[2] + stride >= W ? W - 1 : b[2] + stride, b[3] = b[3] + stride >= H ? H - 1 : b[3] + stride;
    }
    const int x0 = box[1][0], y0 = box[1][1];
    h->x0 = x0, h->y0 = y0, h->w = box[1][2] - x0 + 1, h->h = box[1][3] - y0 + 1;
    const size_t N = (size_t)h->w * h->h;
    h->normal = hd_malloc(3 * N * sizeof(float)), h->proxy = hd_malloc(3 * N * sizeof(float));
    h->mesh = hd_malloc(N * sizeof(float)), h->skin = hd_malloc(N * sizeof(float)), h->hair = hd_malloc(N * sizeof(float));
    h->bg = hd_malloc(N * sizeof(float)), h->body = hd_calloc(N, sizeof(float)), h->zone = hd_calloc(N, sizeof(float));
    h->wb = torso_on && body == HD_HEAD_BODY_ALL ? hd_calloc(N, sizeof(float)) : NULL;
    h->share = hd_malloc(N * sizeof(float));
    float *rho = hd_malloc(2 * N * sizeof(float)), *cover = hd_malloc(P * sizeof(float));
    float *nblend = hd_malloc(P * sizeof(float)), *nb = torso_on ? hd_malloc(3 * N * sizeof(float)) : NULL;
    hd_image nw = {0}, cov = {0};
    st = h->normal && h->proxy && h->mesh && h->skin && h->hair && h->bg && h->body && h->zone && h->share &&
                 (h->wb || !torso_on || body != HD_HEAD_BODY_ALL) && rho && cover && nblend && (nb || !torso_on)
             ? HD_OK
             : HD_ERR_NOMEM;
    if (st == HD_OK && torso_on) st = body_normals(h, f, nb);
    /* the model's normals in the photo, extended past the mesh's edge */
    if (st == HD_OK) st = hd_warp_back(f, &d->normal, NULL, &nw, &cov);
    if (st == HD_OK) {
        memcpy(cover, cov.data, P * sizeof(float));
        st = hd_field_fill_holes(cover, W, H);
    }
    for (int c = 0; c < 3 && st == HD_OK; c++) st = hd_field_fill(nw.data + (size_t)c * P, cov.data, W, H);
    float *mesh_full = NULL;
    if (st == HD_OK && !(mesh_full = hd_malloc(P * sizeof(float)))) st = HD_ERR_NOMEM;
    if (st == HD_OK) st = hd_field_feather_out(cover, W, H, fmaxf(2.0f, HEAD_MESH_BAND * h->frame.e), mesh_full);
    if (st == HD_OK) st = hd_field_feather_out(cover, W, H, fmaxf(2.0f, HEAD_NORMAL_BAND * h->frame.e), nblend);
    for (int y = 0; st == HD_OK && y < h->h; y++)
        for (int x = 0; x < h->w; x++) {
            const size_t i = (size_t)y * h->w + x, p = photo_index(h, x, y);
            float n[3], torso = 0.0f;
            const float nbi[3] = {nb ? nb[i] : 0, nb ? nb[N + i] : 0, nb ? nb[2 * N + i] : 1};
            proxy_at(f, x + x0, y + y0, n, &rho[2 * i], &rho[2 * i + 1], torso_on ? &torso : NULL, nb ? nbi : NULL);
            /* the body: the person (the network's map, carried on down below its window) on the
             * torso, its soft edge ramped as the outline's (PERSON_LEAST to PERSON_SURE) */
            const float low = hd_field_smoothstep((-hd_face_height(&h->frame, x + x0, y + y0) - BODY_FROM) /
                                                  (BODY_TO - BODY_FROM));
            h->body[i] = h->zone[i] = torso * low;
            const float b = nblend[p];
            float m[3], len = 0;
            for (int k = 0; k < 3; k++) {
                h->proxy[(size_t)k * N + i] = n[k];
                m[k] = b * nw.data[(size_t)k * P + p] + (1 - b) * n[k];
                len += m[k] * m[k];
            }
            len = len > 1e-12f ? 1.0f / sqrtf(len) : 0.0f;
            for (int k = 0; k < 3; k++) h->normal[(size_t)k * N + i] = m[k] * len;
            h->mesh[i] = mesh_full[p];
        }
    if (st == HD_OK)
        st = head_masks(h, f, photo, cover, rho, box[0][0], box[0][1], box[0][2] - box[0][0] + 1, box[0][3] - box[0][1] + 1);
    if (st == HD_OK && torso_on) st = body_outline(h, f, photo);
    if (st == HD_OK && torso_on) st = neck_reach(h, f);
    for (size_t i = 0; st == HD_OK && torso_on && body == HD_HEAD_BODY_NEAR && i < N; i++) h->body[i] *= h->neck[i];
    /* hair over the mesh above the brows (a fringe) is hair, not the face's skin */
    for (int y = 0; st == HD_OK && y < h->h; y++)
        for (int x = 0; x < h->w; x++) {
            const size_t i = (size_t)y * h->w + x;
            const float up = hd_field_smoothstep((hd_face_height(&h->frame, x + x0, y + y0) - HAIR_OVER_FROM) /
                                                 (HAIR_OVER_TO - HAIR_OVER_FROM));
            h->mesh[i] *= 1.0f - up * h->hair[i];
        }
    free(rho), free(cover), free(nblend), free(nb), free(mesh_full);
    hd_image_free(&nw), hd_image_free(&cov);
    if (st != HD_OK) hd_head_free(h);
    return st;
}

/* log((max(s(n, target), 0) + g) / (max(s(n, source), 0) + g)) over N normals (3 planes); target
 * NULL: flat light (1). */
static void log_ratio(const float *normal, size_t N, const float source[HD_SH_COEFFS], const float *target, float g,
                      float *out, float *scratch)
{
    hd_sh_shading_map(normal, NULL, (int)N, source, scratch);
    if (target) hd_sh_shading_map(normal, NULL, (int)N, target, out);
    for (size_t i = 0; i < N; i++) {
        const float s = scratch[i] > 0 ? scratch[i] : 0.0f, t = target ? (out[i] > 0 ? out[i] : 0.0f) : 1.0f;
        out[i] = t == s ? 0.0f : logf((t + g) / (s + g));
    }
}

hd_status hd_head_weight(hd_head *h, float *weight)
{
    if (!h || !h->normal) return HD_OK;
    if (!weight) return hd_fail(HD_ERR_ARG, "relight: no weights for the head");
    const size_t N = (size_t)h->w * h->h;
    if (!h->ws && !(h->ws = hd_malloc(N * sizeof(float)))) return HD_ERR_NOMEM;
    if (!h->wh && !(h->wh = hd_malloc(N * sizeof(float)))) return HD_ERR_NOMEM;
    if (!h->near && !(h->near = hd_malloc(N * sizeof(float)))) return HD_ERR_NOMEM;
    /* how near the skin: the hair's strength and field rise from the hair's own to the skin's over
     * about HEAD_NEAR_SKIN eye distances from the skin's edge (no step at the hairline) */
    memcpy(h->near, h->skin, N * sizeof(float));
    hd_status st = hd_field_blur(h->near, h->w, h->h, HEAD_NEAR_SKIN * h->frame.e);
    if (st != HD_OK) return st;
    for (size_t i = 0; i < N; i++) h->near[i] = fminf(1.0f, 2.0f * h->near[i]);
    /* the face's weight where the mesh's field holds (eyes, lips, brows), the skin's anywhere, the
     * hair's (weaker) where there is no skin */
    for (int y = 0; y < h->h; y++)
        for (int x = 0; x < h->w; x++) {
            const size_t i = (size_t)y * h->w + x, p = photo_index(h, x, y);
            /* below the eyes what is neither skin nor background is a beard or hair on the skin:
             * it changes as the skin does (half the change over patches of skin left blotches) */
            const int gx = x + h->x0, gy = y + h->y0;
            const float low = (1 - hd_field_smoothstep((hd_face_height(&h->frame, gx, gy) - BEARD_TO) / (HAIR_FROM - BEARD_TO))) *
                              (1 - hd_field_smoothstep((fabsf(hd_face_side(&h->frame, gx, gy)) - BEARD_SIDE) / BEARD_FADE));
            /* above the brows, skin-coloured pixels beyond the face's region (the forehead grown
             * to the hairline, forehead.c) are hair: blond hair passes the skin test in patches,
             * which took the skin's change and the hair's by turns (blotches) */
            const float up = hd_field_smoothstep((hd_face_height(&h->frame, gx, gy) - SKIN_UP_FROM) / (SKIN_UP_TO - SKIN_UP_FROM));
            const float skin = h->skin[i] * (1 - up * (1 - fminf(1.0f, weight[p])));
            const float hair = fmaxf(h->hair[i], h->skin[i] - skin);
            h->ws[i] = fmaxf(fmaxf(weight[p] * h->mesh[i], skin), low * hair);
            /* the hair takes what the skin leaves of the person (skin and hair share it: no dip
             * where they meet) */
            h->wh[i] = (HEAD_HAIR_STRENGTH + (1 - HEAD_HAIR_STRENGTH) * h->near[i]) * fmaxf(0.0f, fminf(hair, 1 - h->ws[i]));
            /* the background keeps the photo bit for bit, but on the face mesh, where it keeps the
             * face's own weight (an eye's white may have the background's colour; a face taken for
             * background, a grey photo, faded with the mesh's feather instead of ending in a step
             * where that weight is whole) */
            if (h->bg[i] > 0.5f && !(weight[p] >= 1.0f)) h->ws[i] = weight[p] * h->mesh[i], h->wh[i] = 0.0f;
            /* the body takes what the head leaves of it, on the skin's field (the torso's normals):
             * skin, clothes and hair alike, whatever the colour test said */
            const float b = fmaxf(0.0f, fminf(h->body[i], 1.0f - h->ws[i] - h->wh[i]));
            h->ws[i] += b;
            /* the brightness kept is the head's and the body's near the neck, as with the background
             * kept (HD_HEAD_BODY_NEAR), so the head is the same picture either way */
            if (h->wb) h->wb[i] = b * (1 - h->neck[i]);
            /* beyond the face, a change too small to see is none (the masks' blur reaches past
             * the person by a few pixels at 1e-4) */
            if (!(weight[p] > 0) && h->ws[i] + h->wh[i] < HEAD_LEAST) {
                h->ws[i] = h->wh[i] = 0.0f;
                if (h->wb) h->wb[i] = 0.0f;
            }
            weight[p] = h->ws[i] + h->wh[i];
        }
    return HD_OK;
}

hd_status hd_head_level(const hd_head *h, const float *weight, float **level)
{
    *level = NULL;
    if (!h || !h->wb) return HD_OK;
    const size_t P = (size_t)h->W * h->H;
    if (!(*level = hd_malloc((P ? P : 1) * sizeof(float)))) return HD_ERR_NOMEM;
    memcpy(*level, weight, P * sizeof(float));
    for (int y = 0; y < h->h; y++)
        for (int x = 0; x < h->w; x++) {
            const size_t p = photo_index(h, x, y);
            (*level)[p] = fmaxf(0.0f, (*level)[p] - h->wb[(size_t)y * h->w + x]);
        }
    return HD_OK;
}

float hd_head_body_zone(const hd_head *h, int x, int y)
{
    const long i = body_index(h, x, y);
    return i < 0 ? 0.0f : h->zone[i];
}

float hd_head_body_person(const hd_head *h, int x, int y)
{
    const long i = body_index(h, x, y);
    return i < 0 ? -1.0f : body_share(h, (size_t)i);
}

float hd_head_background(const hd_head *h, int x, int y)
{
    if (!h || !h->bg || x < h->mx0 || y < h->my0 || x >= h->mx0 + h->mw || y >= h->my0 + h->mh) return 0.0f;
    const size_t i = (size_t)(y - h->y0) * h->w + (size_t)(x - h->x0);
    return h->bg[i] > 0.5f ? 1.0f : 1.0f - h->share[i];
}

float hd_head_blur(const hd_head *h) { return h && h->normal ? HEAD_FIELD_BLUR * h->frame.e : 0.0f; }

hd_status hd_head_apply(const hd_head *h, const float source[HD_SH_COEFFS], const hd_light_rgb *target,
                        hd_image *field)
{
    if (!h || !h->normal) return HD_OK; /* no head: the face's field as it is */
    if (!h->ws || !h->wh) return hd_fail(HD_ERR_ARG, "relight: the head's weights are not set");
    if (!field || !field->data || field->width != h->W || field->height != h->H)
        return hd_fail(HD_ERR_ARG, "relight: the head's field does not fit the photo");
    const size_t N = (size_t)h->w * h->h, P = (size_t)h->W * h->H;
    const int C = field->channels;
    float *skin_lr = hd_malloc(N * sizeof(float)), *hair_lr = hd_malloc(N * sizeof(float));
    float *scratch = hd_malloc(N * sizeof(float)), *offset = hd_malloc(N * sizeof(float));
    float *known = hd_malloc(N * sizeof(float));
    hd_status st = skin_lr && hair_lr && scratch && offset && known ? HD_OK : HD_ERR_NOMEM;
    for (int c = 0; c < C && st == HD_OK; c++) {
        const float *tl = target ? target->sh[c] : NULL;
        log_ratio(h->normal, N, source, tl, h->g, skin_lr, scratch);
        log_ratio(h->proxy, N, source, tl, h->g, hair_lr, scratch);
        st = hd_field_blur(skin_lr, h->w, h->h, hd_head_blur(h));
        if (st == HD_OK) st = hd_field_blur(hair_lr, h->w, h->h, hd_head_blur(h));
        float *F = field->data + (size_t)c * P;
        /* beyond the face the change stays within the face's own: the proxy's up- and side-facing
         * normals may see a light the face does not */
        float lo = INFINITY, hi = -INFINITY;
        for (int y = 0; y < h->h; y++)
            for (int x = 0; x < h->w; x++)
                if (h->mesh[(size_t)y * h->w + x] >= 1.0f) {
                    const float v = F[photo_index(h, x, y)];
                    lo = v < lo ? v : lo, hi = v > hi ? v : hi;
                }
        if (!(lo <= hi)) lo = hi = 0;
        for (size_t i = 0; i < N; i++) {
            skin_lr[i] = skin_lr[i] < lo ? lo : skin_lr[i] > hi ? hi : skin_lr[i];
            hair_lr[i] = hair_lr[i] < lo ? lo : hair_lr[i] > hi ? hi : hair_lr[i];
        }
        /* the face's field minus the head's on the mesh, carried past its edge and faded out over
         * the hand-over band: the skin's change is the face's on the mesh, continuous across its
         * edge, and the head's beyond */
        for (int y = 0; y < h->h; y++)
            for (int x = 0; x < h->w; x++) {
                const size_t i = (size_t)y * h->w + x;
                offset[i] = h->mesh[i] >= 1.0f ? F[photo_index(h, x, y)] - skin_lr[i] : 0.0f;
                known[i] = h->mesh[i] >= 1.0f ? 1.0f : 0.0f;
            }
        st = hd_field_fill(offset, known, h->w, h->h);
        for (int y = 0; st == HD_OK && y < h->h; y++)
            for (int x = 0; x < h->w; x++) {
                const size_t i = (size_t)y * h->w + x, p = photo_index(h, x, y);
                const float sum = h->ws[i] + h->wh[i];
                const float ls = skin_lr[i] + h->mesh[i] * offset[i];
                /* the hair next to the skin takes the skin's change, further in its own */
                const float hl = h->near[i] * ls + (1 - h->near[i]) * hair_lr[i];
                const float v = (h->ws[i] * ls + h->wh[i] * hl) / sum;
                if (sum > 0) F[p] = v < lo ? lo : v > hi ? hi : v;
            }
    }
    free(skin_lr), free(hair_lr), free(scratch), free(offset), free(known);
    return st;
}
