/* render.c: one synthetic image of a subject, straight in the aligned texture space. Per image,
 * from the stream (seed, subject, image): a head pose (yaw, pitch, roll within the jitter) and a
 * DPR-like light (ambient plus a directional lobe from the front hemisphere, sometimes a hard
 * side light). Per texel the mesh's UV raster gives the covering triangle and barycentrics; the
 * posed vertex normals of the deformed mesh are interpolated (the smooth shape), the subject's
 * detail gradient tilts them (the fine shape), and
 *     shading s = sum_k l_k b_k(n),  image = clamp(albedo * s, 0, 1).
 * Texels off the mesh, or whose smooth or detailed normal faces away (z <= 0), are masked out.
 * The coarse normals play a 3DMM fit: the canonical mesh's, interpolated the same way, in the
 * image's pose; with a coarse error E > 0, the fit's pose and shape are off by a random,
 * zero-mean error of size E (coarse_fit). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "synth/synth_internal.h"
#include "io/image_io.h"
#include "synth/synth.h"

/* Rotation matrix R = Rz(roll) Rx(pitch) Ry(yaw), angles in degrees; yaw > 0 turns the face
 * toward image right, pitch > 0 tilts it up. */
static void pose_matrix(float yaw, float pitch, float roll, float R[9])
{
    double y = yaw * M_PI / 180.0, p = -pitch * M_PI / 180.0, r = roll * M_PI / 180.0;
    double cy = cos(y), sy = sin(y), cp = cos(p), sp = sin(p), cr = cos(r), sr = sin(r);
    double Ry[9] = {cy, 0, sy, 0, 1, 0, -sy, 0, cy};
    double Rx[9] = {1, 0, 0, 0, cp, -sp, 0, sp, cp};
    double Rz[9] = {cr, -sr, 0, sr, cr, 0, 0, 0, 1};
    double T[9], M[9];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            T[3 * i + j] = 0;
            for (int k = 0; k < 3; k++) T[3 * i + j] += Rx[3 * i + k] * Ry[3 * k + j];
        }
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            M[3 * i + j] = 0;
            for (int k = 0; k < 3; k++) M[3 * i + j] += Rz[3 * i + k] * T[3 * k + j];
        }
    for (int i = 0; i < 9; i++) R[i] = (float)M[i];
}

static void rotate(const float R[9], const float *in, float *out)
{
    float x = in[0], y = in[1], z = in[2];
    out[0] = R[0] * x + R[1] * y + R[2] * z;
    out[1] = R[3] * x + R[4] * y + R[5] * z;
    out[2] = R[6] * x + R[7] * y + R[8] * z;
}

/* The light of one image: an ambient term plus a directional lobe; one in five is a hard side
 * light (low ambient, strong lobe from 60-95 degrees to a side). Shading stays >= 0 because the
 * ambient exceeds the lobe's order-2 undershoot (0.037 * intensity). */
static void draw_light(hd_rng *r, float light[HD_SH_COEFFS])
{
    float az, el, intensity, ambient;
    if (hd_rng_uniform(r) < 0.2f) {
        az = (hd_rng_uniform(r) < 0.5f ? -1.0f : 1.0f) * hd_rng_range(r, 60.0f, 95.0f);
        el = hd_rng_range(r, -20.0f, 40.0f);
        intensity = hd_rng_range(r, 1.0f, 1.6f);
        ambient = hd_rng_range(r, 0.08f, 0.25f);
    } else {
        /* uniform over the front hemisphere (z > 0): z uniform in [0, 1], angle uniform */
        float z = hd_rng_uniform(r), phi = hd_rng_range(r, 0.0f, 2.0f * (float)M_PI);
        float rho = sqrtf(fmaxf(0.0f, 1.0f - z * z));
        float dx = rho * cosf(phi), dy = rho * sinf(phi);
        az = atan2f(dx, z) * (float)(180.0 / M_PI);
        el = asinf(fminf(1.0f, fmaxf(-1.0f, dy))) * (float)(180.0 / M_PI);
        intensity = hd_rng_range(r, 0.3f, 1.3f);
        ambient = hd_rng_range(r, 0.3f, 0.8f);
    }
    hd_light_from_direction(az, el, intensity, ambient, light);
}

/* s(n) with the basis of SPEC section 2 written out (X = x, Y = -z, Z = y). */
static inline float shade(const float l[HD_SH_COEFFS], float x, float y, float z)
{
    const float c0 = 0.8862269254527579f, c1 = 1.023326707946488f, c2 = 0.8580855308097834f,
                c3 = 0.2477079561003757f, c4 = 0.4290427654048917f;
    float X = x, Y = -z, Z = y;
    return l[0] * c0 + c1 * (l[1] * Y + l[2] * Z + l[3] * X) + c2 * (l[4] * Y * X + l[5] * Y * Z + l[7] * X * Z) +
           l[6] * c3 * (3.0f * Z * Z - 1.0f) + l[8] * c4 * (X * X - Y * Y);
}

/* Texel i masked out: 0 in every plane. */
static void clear_texel(hd_synth_face *f, int i, size_t P)
{
    f->mask.data[i] = 0.0f;
    f->shading.data[i] = 0.0f;
    for (int k = 0; k < 3; k++) {
        f->image.data[k * P + i] = 0.0f;
        f->normal.data[k * P + i] = 0.0f;
        f->albedo.data[k * P + i] = 0.0f;
        f->normal_gt.data[k * P + i] = 0.0f;
    }
}

void hd_synth_face_free(hd_synth_face *f)
{
    if (!f) return;
    hd_image_free(&f->image);
    hd_image_free(&f->mask);
    hd_image_free(&f->normal);
    hd_image_free(&f->albedo);
    hd_image_free(&f->normal_gt);
    hd_image_free(&f->shading);
}

/* The modelled 3DMM fit of one image (the coarse normals), drawn from its own stream so that the
 * image's pose and light are the same whatever the error. With size E > 0, three zero-mean parts:
 *   pose   yaw, pitch and roll each off by a normal draw of standard deviation E * COARSE_POSE,
 *          or pose_sd degrees where that is given (> 0), clipped at 2.5 standard deviations;
 *   shape  the canonical mesh deformed like a random identity, E * COARSE_SHAPE identity spreads
 *          (at most one);
 *   tilt   a smooth height field h = sum_w sin(k_w . x + phi_w) of COARSE_WAVES plane waves (1 to
 *          3 cycles across the texture, random directions and phases) whose gradient tilts the
 *          normals by E degrees RMS: the fit's local shape errors.
 * Every draw is symmetric about 0, so the error averages out over images. At E = 20 (hdnet
 * synth's default) the coarse normals are off by about 23 degrees on average. */
#define COARSE_STREAM 0xC0A45E5EED5ull
#define COARSE_POSE 0.5f
#define COARSE_SHAPE 0.05f
#define COARSE_WAVES 6

/* splitmix64's finaliser: a bijective 64-bit hash. */
static uint64_t mix64(uint64_t z)
{
    z += 0x9E3779B97F4A7C15ull;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

typedef struct coarse_fit {
    float R[9];                               /* the fit's pose */
    float gain;                               /* tan(E) / RMS |grad h|; 0 without error */
    float kx[COARSE_WAVES], ky[COARSE_WAVES]; /* wave vectors, radians per texel */
    float *cx, *sx, *cy, *sy;                 /* (COARSE_WAVES, S): cos, sin of k_x x and of k_y y + phi */
} coarse_fit;

/* Draws the fit of image `image` into fit (whose tables hold 4 * COARSE_WAVES * S floats) and f's
 * coarse pose; cn (V, 3) gets the fitted mesh's posed vertex normals; pos (V, 3) is scratch. */
static void coarse_fit_draw(const hd_synth *s, const hd_synth_subject *sub, int image, float E, float pose_sd,
                            hd_synth_face *f, coarse_fit *fit, float *pos, float *cn)
{
    const int V = s->mesh.nv, S = s->size;
    fit->gain = 0.0f;
    f->coarse_yaw_deg = f->yaw_deg, f->coarse_pitch_deg = f->pitch_deg, f->coarse_roll_deg = f->roll_deg;
    if (!(pose_sd > 0.0f)) pose_sd = COARSE_POSE * E;
    if (!(E > 0.0f) && !(pose_sd > 0.0f)) {
        pose_matrix(f->yaw_deg, f->pitch_deg, f->roll_deg, fit->R);
        for (int v = 0; v < V; v++) rotate(fit->R, s->canon_normal + 3 * v, cn + 3 * v);
        return;
    }
    /* PCG streams that differ in a few bits of the increment start out correlated, so the fit's
     * seed and stream are hashed from (seed, subject, image) */
    uint64_t id = ((uint64_t)(uint32_t)sub->subject << 24) | (uint64_t)((uint32_t)image & 0xFFFFFFu);
    hd_rng r;
    hd_rng_seed(&r, mix64(sub->seed ^ mix64(id ^ COARSE_STREAM)), mix64(id + COARSE_STREAM));
    float e[3];
    for (int k = 0; k < 3; k++) {
        float z = hd_rng_normal(&r);
        e[k] = pose_sd * (z < -2.5f ? -2.5f : z > 2.5f ? 2.5f : z);
    }
    f->coarse_yaw_deg += e[0];
    f->coarse_pitch_deg += e[1];
    f->coarse_roll_deg += e[2];
    syn_shape_make(&s->mesh, &r, fminf(1.0f, COARSE_SHAPE * E), pos); /* beyond 1 the jaw can fold */
    hd_mesh_vertex_normals(&s->mesh, pos, cn);
    pose_matrix(f->coarse_yaw_deg, f->coarse_pitch_deg, f->coarse_roll_deg, fit->R);
    for (int v = 0; v < V; v++) rotate(fit->R, cn + 3 * v, cn + 3 * v);
    /* the tilt waves; over the phases, the mean of |grad h|^2 is sum_w |k_w|^2 / 2 */
    double k2 = 0;
    for (int w = 0; w < COARSE_WAVES; w++) {
        double cycles = hd_rng_range(&r, 1.0f, 3.0f), theta = hd_rng_range(&r, 0.0f, 2.0f * (float)M_PI);
        double phi = hd_rng_range(&r, 0.0f, 2.0f * (float)M_PI), k = 2.0 * M_PI * cycles / S;
        fit->kx[w] = (float)(k * cos(theta));
        fit->ky[w] = (float)(k * sin(theta));
        k2 += k * k;
        for (int t = 0; t < S; t++) {
            double ax = fit->kx[w] * (t + 0.5), ay = fit->ky[w] * (t + 0.5) + phi;
            fit->cx[w * S + t] = (float)cos(ax), fit->sx[w * S + t] = (float)sin(ax);
            fit->cy[w * S + t] = (float)cos(ay), fit->sy[w * S + t] = (float)sin(ay);
        }
    }
    fit->gain = (float)(tan(E * M_PI / 180.0) / sqrt(k2 / 2.0));
}

/* The coarse normal c (unit) at texel (x, y) tilted by the fit's height field:
 * c' = normalize(c - g_x T_u - g_y T_v), with T the texture axes of the fit's pose projected on the
 * tangent plane and g = gain * grad h, grad h = sum_w k_w cos(k_w . x + phi_w). */
static void coarse_tilt(const coarse_fit *fit, int S, int x, int y, float c[3])
{
    float hx = 0.0f, hy = 0.0f;
    for (int w = 0; w < COARSE_WAVES; w++) {
        /* cos(a + b) = cos a cos b - sin a sin b */
        float cw = fit->cx[w * S + x] * fit->cy[w * S + y] - fit->sx[w * S + x] * fit->sy[w * S + y];
        hx += fit->kx[w] * cw;
        hy += fit->ky[w] * cw;
    }
    const float *R = fit->R;
    const float ax_u[3] = {R[0], R[3], R[6]}, ax_v[3] = {-R[1], -R[4], -R[7]};
    float du = ax_u[0] * c[0] + ax_u[1] * c[1] + ax_u[2] * c[2], dv = ax_v[0] * c[0] + ax_v[1] * c[1] + ax_v[2] * c[2];
    float g0 = fit->gain * hx, g1 = fit->gain * hy, m[3];
    for (int k = 0; k < 3; k++) m[k] = c[k] - g0 * (ax_u[k] - du * c[k]) - g1 * (ax_v[k] - dv * c[k]);
    float len = sqrtf(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
    for (int k = 0; k < 3; k++) c[k] = m[k] / len;
}

hd_status hd_synth_render(const hd_synth *s, const hd_synth_subject *sub, int image, float pose_jitter_deg,
                          float coarse_error_deg, hd_synth_face *out)
{
    return hd_synth_render_fit(s, sub, image, pose_jitter_deg, coarse_error_deg, 0.0f, out);
}

hd_status hd_synth_render_fit(const hd_synth *s, const hd_synth_subject *sub, int image, float pose_jitter_deg,
                              float coarse_error_deg, float coarse_pose_deg, hd_synth_face *out)
{
    if (image < 0 || image >= 0xFFFFFF) return hd_fail(HD_ERR_ARG, "synth: image index %d out of range", image);
    if (!(pose_jitter_deg >= 0.0f && pose_jitter_deg <= 45.0f))
        return hd_fail(HD_ERR_RANGE, "synth: pose jitter %g outside [0, 45] degrees", pose_jitter_deg);
    if (!(coarse_error_deg >= 0.0f && coarse_error_deg <= HD_SYNTH_COARSE_ERROR_MAX))
        return hd_fail(HD_ERR_RANGE, "synth: coarse-normal error %g outside [0, %g] degrees", coarse_error_deg,
                       HD_SYNTH_COARSE_ERROR_MAX);
    if (!(coarse_pose_deg <= HD_SYNTH_COARSE_ERROR_MAX))
        return hd_fail(HD_ERR_RANGE, "synth: coarse pose error %g is not under %g degrees", coarse_pose_deg,
                       HD_SYNTH_COARSE_ERROR_MAX);
    const int S = s->size, V = s->mesh.nv;
    const size_t P = (size_t)S * S;
    hd_status st = HD_OK;
    hd_image *planes[6] = {&out->image, &out->mask, &out->normal, &out->albedo, &out->normal_gt, &out->shading};
    static const int channels[6] = {3, 1, 3, 3, 3, 1};
    /* Reuse the buffers of a previous call when they fit (fresh pages cost more than the
     * render). Texels off the mesh are 0 since their allocation and never written; the loop
     * below writes every covered texel, 0 where it is masked out. */
    for (int k = 0; k < 6 && st == HD_OK; k++) {
        hd_image *im = planes[k];
        if (!(im->data && im->width == S && im->height == S && im->channels == channels[k])) {
            hd_image_free(im);
            st = hd_image_alloc(im, S, S, channels[k]);
        }
    }
    if (st != HD_OK) {
        hd_synth_face_free(out);
        return st;
    }
    float *vn = hd_malloc(((size_t)V * 9 + (size_t)4 * COARSE_WAVES * S) * sizeof(float));
    if (!vn) return HD_ERR_NOMEM;
    float *cn = vn + (size_t)V * 3, *fit_pos = vn + (size_t)V * 6;
    coarse_fit fit;
    fit.cx = vn + (size_t)V * 9;
    fit.sx = fit.cx + (size_t)COARSE_WAVES * S;
    fit.cy = fit.sx + (size_t)COARSE_WAVES * S;
    fit.sy = fit.cy + (size_t)COARSE_WAVES * S;
    hd_rng r;
    syn_rng(&r, sub->seed, sub->subject, image);
    float J = pose_jitter_deg;
    out->yaw_deg = J > 0 ? hd_rng_range(&r, -J, J) : 0.0f;
    out->pitch_deg = J > 0 ? hd_rng_range(&r, -J, J) : 0.0f;
    out->roll_deg = J > 0 ? hd_rng_range(&r, -J, J) : 0.0f;
    draw_light(&r, out->light);
    float R[9];
    pose_matrix(out->yaw_deg, out->pitch_deg, out->roll_deg, R);
    /* posed vertex normals of the subject's shape and of the fitted canonical mesh (rotations
     * carry normals unchanged in length) */
    hd_mesh_vertex_normals(&s->mesh, sub->pos, vn);
    for (int v = 0; v < V; v++) rotate(R, vn + 3 * v, vn + 3 * v);
    coarse_fit_draw(s, sub, image, coarse_error_deg, coarse_pose_deg, out, &fit, fit_pos, cn);
    /* texture axes in the camera frame: +u is the face's +x, +v its -y */
    const float ax_u[3] = {R[0], R[3], R[6]}, ax_v[3] = {-R[1], -R[4], -R[7]};
    const int *tri = s->mesh.tri;
    const float *L = out->light;
    float *img = out->image.data, *msk = out->mask.data, *nc = out->normal.data, *alb = out->albedo.data;
    float *ng = out->normal_gt.data, *sh = out->shading.data;
    const float *gx = sub->grad, *gy = sub->grad + P;
    for (int ci = 0; ci < s->ncovered; ci++) {
        int i = s->covered[ci];
        const int *t = tri + 3 * s->raster.tri[i];
        const float *b = s->raster.bary + 3 * (size_t)i;
        const float *n0 = vn + 3 * t[0], *n1 = vn + 3 * t[1], *n2 = vn + 3 * t[2];
        float n[3] = {b[0] * n0[0] + b[1] * n1[0] + b[2] * n2[0], b[0] * n0[1] + b[1] * n1[1] + b[2] * n2[1],
                      b[0] * n0[2] + b[1] * n1[2] + b[2] * n2[2]};
        float len = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (!(len > 1e-8f) || n[2] <= 0.0f) {
            clear_texel(out, i, P);
            continue;
        }
        n[0] /= len, n[1] /= len, n[2] /= len;
        /* detail: n' = normalize(n - gx T_u - gy T_v), T the texture axes projected on the
         * tangent plane (the surface p + h n has normal n - grad h to first order) */
        float du = ax_u[0] * n[0] + ax_u[1] * n[1] + ax_u[2] * n[2];
        float dv = ax_v[0] * n[0] + ax_v[1] * n[1] + ax_v[2] * n[2];
        /* the detail fades out toward the silhouette (n.z < 0.3) so that it never turns a
         * visible texel away: fade = smoothstep(0, 0.3, n.z) */
        float fz = n[2] < 0.3f ? n[2] / 0.3f : 1.0f, fade = fz * fz * (3.0f - 2.0f * fz);
        float g0 = fade * gx[i], g1 = fade * gy[i];
        float m[3];
        for (int k = 0; k < 3; k++) m[k] = n[k] - g0 * (ax_u[k] - du * n[k]) - g1 * (ax_v[k] - dv * n[k]);
        len = sqrtf(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
        m[0] /= len, m[1] /= len, m[2] /= len;
        if (m[2] <= 0.0f) {
            clear_texel(out, i, P);
            continue;
        }
        const float *c0 = cn + 3 * t[0], *c1 = cn + 3 * t[1], *c2 = cn + 3 * t[2];
        float c[3] = {b[0] * c0[0] + b[1] * c1[0] + b[2] * c2[0], b[0] * c0[1] + b[1] * c1[1] + b[2] * c2[1],
                      b[0] * c0[2] + b[1] * c1[2] + b[2] * c2[2]};
        len = sqrtf(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
        if (!(len > 1e-8f)) {
            clear_texel(out, i, P);
            continue;
        }
        for (int k = 0; k < 3; k++) c[k] /= len;
        if (fit.gain != 0.0f) coarse_tilt(&fit, S, i % S, i / S, c);
        float s_val = shade(L, m[0], m[1], m[2]);
        msk[i] = 1.0f;
        sh[i] = s_val;
        for (int k = 0; k < 3; k++) {
            nc[k * P + i] = c[k];
            ng[k * P + i] = m[k];
            float a = sub->albedo[k * P + i];
            alb[k * P + i] = a;
            float v = a * s_val;
            img[k * P + i] = v < 0.0f ? 0.0f : v > 1.0f ? 1.0f : v;
        }
    }
    free(vn);
    return HD_OK;
}

/* rgb = (n + 1) / 2 on the mask, 0 elsewhere: hd_normal_encode into a caller's buffer. */
static void encode_normals(const hd_image *normal, const hd_image *mask, hd_image *rgb)
{
    size_t P = (size_t)normal->width * normal->height;
    for (int c = 0; c < 3; c++)
        for (size_t p = 0; p < P; p++)
            rgb->data[c * P + p] = mask->data[p] > 0.5f ? (normal->data[c * P + p] + 1.0f) * 0.5f : 0.0f;
}

hd_status hd_synth_face_write(const char *dir, const char *name, const hd_synth_face *f)
{
    return hd_synth_face_write_effort(dir, name, f, HD_PNG_FAST); /* thousands of files: speed over the last few % of size */
}

hd_status hd_synth_face_write_effort(const char *dir, const char *name, const hd_synth_face *f, hd_png_effort effort)
{
    static const char *const suffix[] = {".png", ".mask.png", ".normal.png", ".albedo.png",
                                         ".normal_gt.png", ".shading.png", ".shading.pfm", ".light.txt"};
    const hd_image *planes[6] = {&f->image, &f->mask, &f->normal, &f->albedo, &f->normal_gt, &f->shading};
    static const int channels[6] = {3, 1, 3, 3, 3, 1};
    for (int k = 0; k < 6; k++)
        if (!planes[k]->data || planes[k]->channels != channels[k] || planes[k]->width != f->shading.width ||
            planes[k]->height != f->shading.height)
            return hd_fail(HD_ERR_ARG, "%s/%s: not a rendered face (plane %d is %dx%dx%d)", dir, name, k,
                           planes[k]->width, planes[k]->height, planes[k]->channels);
    char file[4096];
    /* encoded normals, then s / 2 in its first plane; every value is written before use */
    hd_image scratch = {f->shading.width, f->shading.height, 3, NULL};
    if (!(scratch.data = hd_malloc((size_t)scratch.width * scratch.height * 3 * sizeof(float)))) return HD_ERR_NOMEM;
    hd_image plane = {scratch.width, scratch.height, 1, scratch.data};
    hd_status st = HD_OK;
    for (int k = 0; k < 8 && st == HD_OK; k++) {
        if (snprintf(file, sizeof file, "%s/%s%s", dir, name, suffix[k]) >= (int)sizeof file) {
            st = hd_fail(HD_ERR_RANGE, "%s/%s: path too long", dir, name);
            break;
        }
        switch (k) {
        case 0: st = hd_image_write_png_effort(file, &f->image, 8, effort); break;
        case 1: st = hd_image_write_png_effort(file, &f->mask, 8, effort); break;
        case 2:
            encode_normals(&f->normal, &f->mask, &scratch);
            st = hd_image_write_png_effort(file, &scratch, 16, effort);
            break;
        case 3: st = hd_image_write_png_effort(file, &f->albedo, 8, effort); break;
        case 4:
            encode_normals(&f->normal_gt, &f->mask, &scratch);
            st = hd_image_write_png_effort(file, &scratch, 16, effort);
            break;
        case 5: {
            /* shading.png stores s / 2 in 16 bits (shading up to 2) */
            size_t P = (size_t)f->shading.width * f->shading.height;
            for (size_t i = 0; i < P; i++) plane.data[i] = 0.5f * f->shading.data[i];
            st = hd_image_write_png_effort(file, &plane, 16, effort);
            break;
        }
        case 6: st = hd_image_write_pfm(file, &f->shading); break;
        case 7: st = hd_light_write(file, f->light); break;
        }
    }
    hd_image_free(&scratch);
    return st;
}
