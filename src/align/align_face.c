/* unwarp.c: one face from its 468 landmarks into the aligned texture space (SPEC section 2): the
 * similarity fit of the canonical mesh (for the coarse normals and the depth direction), the
 * unwarped texture (each texel's barycentric position in its UV triangle carried to the landmark
 * triangle in the photo, bilinear sampling), the visibility mask and the coarse normals. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "align/photo_raster.h"
#include "align/align.h"

/* Largest eigenpair of a symmetric 4x4 matrix by cyclic Jacobi rotations; vec gets the unit
 * eigenvector. */
static void sym4_top_eigenvector(double a[4][4], double vec[4])
{
    double v[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
    for (int sweep = 0; sweep < 50; sweep++) {
        double off = 0;
        for (int p = 0; p < 4; p++)
            for (int q = p + 1; q < 4; q++) off += a[p][q] * a[p][q];
        if (off < 1e-30) break;
        for (int p = 0; p < 4; p++)
            for (int q = p + 1; q < 4; q++) {
                if (fabs(a[p][q]) < 1e-300) continue;
                /* rotation angle that zeroes a[p][q]: tan(2 theta) = 2 a_pq / (a_qq - a_pp) */
                double theta = 0.5 * atan2(2 * a[p][q], a[q][q] - a[p][p]);
                double c = cos(theta), s = sin(theta);
                for (int k = 0; k < 4; k++) { /* A <- A J */
                    double akp = a[k][p], akq = a[k][q];
                    a[k][p] = c * akp - s * akq;
                    a[k][q] = s * akp + c * akq;
                }
                for (int k = 0; k < 4; k++) { /* A <- J^T A */
                    double apk = a[p][k], aqk = a[q][k];
                    a[p][k] = c * apk - s * aqk;
                    a[q][k] = s * apk + c * aqk;
                }
                for (int k = 0; k < 4; k++) {
                    double vkp = v[k][p], vkq = v[k][q];
                    v[k][p] = c * vkp - s * vkq;
                    v[k][q] = s * vkp + c * vkq;
                }
            }
    }
    int best = 0;
    for (int k = 1; k < 4; k++)
        if (a[k][k] > a[best][best]) best = k;
    double norm = 0;
    for (int k = 0; k < 4; k++) norm += v[k][best] * v[k][best];
    norm = sqrt(norm);
    for (int k = 0; k < 4; k++) vec[k] = v[k][best] / norm;
}

/* (align.h) Horn 1987: the unit quaternion of R is the top eigenvector of the 4x4 matrix built from S. */
void hd_best_rotation(const double S[3][3], double R[9])
{
    double N[4][4] = {
        {S[0][0] + S[1][1] + S[2][2], S[1][2] - S[2][1], S[2][0] - S[0][2], S[0][1] - S[1][0]},
        {S[1][2] - S[2][1], S[0][0] - S[1][1] - S[2][2], S[0][1] + S[1][0], S[2][0] + S[0][2]},
        {S[2][0] - S[0][2], S[0][1] + S[1][0], -S[0][0] + S[1][1] - S[2][2], S[1][2] + S[2][1]},
        {S[0][1] - S[1][0], S[2][0] + S[0][2], S[1][2] + S[2][1], -S[0][0] - S[1][1] + S[2][2]}};
    double q[4];
    sym4_top_eigenvector(N, q);
    double w = q[0], x = q[1], y = q[2], z = q[3];
    R[0] = w * w + x * x - y * y - z * z;
    R[1] = 2 * (x * y - w * z);
    R[2] = 2 * (x * z + w * y);
    R[3] = 2 * (x * y + w * z);
    R[4] = w * w - x * x + y * y - z * z;
    R[5] = 2 * (y * z - w * x);
    R[6] = 2 * (x * z - w * y);
    R[7] = 2 * (y * z + w * x);
    R[8] = w * w - x * x - y * y + z * z;
}

/* Least-squares similarity c_i ~ s R p_i + t (R by hd_best_rotation from the cross-covariance of
 * the centred points; s = sum c'.R p' / sum |p'|^2).
 * Returns the rms residual. */
static double fit_similarity(int n, const float *p, const float (*c)[3], double *s_out, double R[9], double t[3])
{
    double mp[3] = {0, 0, 0}, mc[3] = {0, 0, 0};
    for (int i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            mp[k] += p[3 * i + k];
            mc[k] += c[i][k];
        }
    for (int k = 0; k < 3; k++) {
        mp[k] /= n;
        mc[k] /= n;
    }
    double S[3][3] = {{0}}, pp = 0; /* S_ab = sum p'_a c'_b */
    for (int i = 0; i < n; i++) {
        double dp[3], dc[3];
        for (int k = 0; k < 3; k++) {
            dp[k] = p[3 * i + k] - mp[k];
            dc[k] = c[i][k] - mc[k];
        }
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++) S[a][b] += dp[a] * dc[b];
        pp += dp[0] * dp[0] + dp[1] * dp[1] + dp[2] * dp[2];
    }
    hd_best_rotation(S, R);
    double num = 0;
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++) num += R[3 * b + a] * S[a][b]; /* sum_i c'_i . R p'_i */
    double s = pp > 0 ? num / pp : 0;
    for (int k = 0; k < 3; k++) t[k] = mc[k] - s * (R[3 * k] * mp[0] + R[3 * k + 1] * mp[1] + R[3 * k + 2] * mp[2]);
    double err = 0;
    for (int i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            const float *pi = &p[3 * i];
            double e = s * (R[3 * k] * pi[0] + R[3 * k + 1] * pi[1] + R[3 * k + 2] * pi[2]) + t[k] - c[i][k];
            err += e * e;
        }
    *s_out = s;
    return sqrt(err / n);
}

hd_status hd_align_fit(const hd_mesh *mesh, hd_aligned_face *face)
{
    if (mesh->nv != HD_FACE_LANDMARKS)
        return hd_fail(HD_ERR_FORMAT, "the face mesh has %d vertices, the landmarks %d", mesh->nv, HD_FACE_LANDMARKS);
    float(*cam)[3] = hd_malloc(sizeof(float[HD_FACE_LANDMARKS][3]));
    if (!cam) return HD_ERR_NOMEM;
    double best_rms = INFINITY;
    for (int sign = -1; sign <= 1; sign += 2) {
        for (int i = 0; i < HD_FACE_LANDMARKS; i++) hd_landmark_camera(face->landmarks[i], (float)sign, cam[i]);
        double s, R[9], t[3];
        double rms = fit_similarity(HD_FACE_LANDMARKS, mesh->pos, (const float (*)[3])cam, &s, R, t);
        if (!(rms < best_rms)) continue;
        best_rms = rms;
        face->scale = (float)s;
        for (int k = 0; k < 9; k++) face->rotation[k] = (float)R[k];
        for (int k = 0; k < 3; k++) face->translation[k] = (float)t[k];
        face->depth_sign = (float)sign;
        face->fit_rms = (float)rms;
    }
    free(cam);
    if (!isfinite(best_rms) || !(face->scale > 0))
        return hd_fail(HD_ERR_RANGE, "the landmarks are degenerate (no similarity fit)");
    return HD_OK;
}

void hd_aligned_face_free(hd_aligned_face *face)
{
    if (!face) return;
    hd_image_free(&face->texture);
    hd_image_free(&face->mask);
    hd_image_free(&face->normal);
    hd_image_free(&face->person);
}

void hd_aligned_faces_free(hd_aligned_face *faces, int count)
{
    if (!faces) return;
    for (int i = 0; i < count; i++) hd_aligned_face_free(&faces[i]);
    free(faces);
}

/* Bilinear sample of channel plane `src` (w x h) at continuous pixel position (px, py) (pixel
 * centres at +0.5), clamped at the borders. */
static float sample_bilinear(const float *src, int w, int h, float px, float py)
{
    px = fminf(fmaxf(px, -1.0f), w + 1.0f); /* the border is replicated anyway */
    py = fminf(fmaxf(py, -1.0f), h + 1.0f);
    float fx = px - 0.5f, fy = py - 0.5f;
    int ix = (int)floorf(fx), iy = (int)floorf(fy);
    float ax = fx - ix, ay = fy - iy;
    int x0 = ix < 0 ? 0 : ix >= w ? w - 1 : ix, x1 = ix + 1 < 0 ? 0 : ix + 1 >= w ? w - 1 : ix + 1;
    int y0 = iy < 0 ? 0 : iy >= h ? h - 1 : iy, y1 = iy + 1 < 0 ? 0 : iy + 1 >= h ? h - 1 : iy + 1;
    float top = (1 - ax) * src[(size_t)y0 * w + x0] + ax * src[(size_t)y0 * w + x1];
    float bot = (1 - ax) * src[(size_t)y1 * w + x0] + ax * src[(size_t)y1 * w + x1];
    return (1 - ay) * top + ay * bot;
}

hd_status hd_align_face_on(const hd_mesh *canonical, const hd_image *photo, const float landmarks[HD_FACE_LANDMARKS][3],
                           int size, hd_aligned_face *face)
{
    memset(face, 0, sizeof *face);
    if (!photo || !photo->data || photo->channels != 3 || photo->width < 1 || photo->height < 1)
        return hd_fail(HD_ERR_ARG, "align: the photo must be a non-empty 3-channel image");
    if (size < 16 || size > 4096) return hd_fail(HD_ERR_RANGE, "align: texture size %d is not in [16, 4096]", size);
    for (int i = 0; i < HD_FACE_LANDMARKS; i++)
        for (int k = 0; k < 3; k++) {
            if (!isfinite(landmarks[i][k])) return hd_fail(HD_ERR_NUMERIC, "align: landmark %d is not finite", i);
            face->landmarks[i][k] = landmarks[i][k];
        }
    face->size = size;
    face->photo_width = photo->width;
    face->photo_height = photo->height;
    face->score = 1.0f;
    face->box[0] = face->box[1] = INFINITY;
    face->box[2] = face->box[3] = -INFINITY;
    for (int i = 0; i < HD_FACE_LANDMARKS; i++) {
        face->box[0] = fminf(face->box[0], landmarks[i][0]);
        face->box[1] = fminf(face->box[1], landmarks[i][1]);
        face->box[2] = fmaxf(face->box[2], landmarks[i][0]);
        face->box[3] = fmaxf(face->box[3], landmarks[i][1]);
    }
    float face_width = face->box[2] - face->box[0];
    if (!(face_width >= 1.0f) || !(face->box[3] - face->box[1] >= 1.0f))
        return hd_fail(HD_ERR_RANGE, "align: the landmarks span less than a pixel");

    const hd_mesh *mesh = canonical;
    hd_status st;
    hd_uv_raster uvr = {0};
    hd_photo_raster pr = {0};
    float *vn = NULL;
    if ((st = hd_align_fit(mesh, face))) goto done;
    if ((st = hd_mesh_uv_raster(mesh, size, &uvr))) goto done;
    if ((st = hd_photo_raster_build(mesh, (const float (*)[3])face->landmarks, face->depth_sign, photo->width,
                                    photo->height, &pr)))
        goto done;
    if (!(vn = hd_malloc((size_t)mesh->nv * 3 * sizeof *vn))) {
        st = HD_ERR_NOMEM;
        goto done;
    }
    if ((st = hd_image_alloc(&face->texture, size, size, 3)) || (st = hd_image_alloc(&face->mask, size, size, 1)) ||
        (st = hd_image_alloc(&face->normal, size, size, 3)))
        goto done;
    /* Vertex normals of the fitted canonical mesh: a similarity rotates them by R. */
    hd_mesh_vertex_normals(mesh, mesh->pos, vn);
    for (int i = 0; i < mesh->nv; i++) {
        float n[3], *R = face->rotation;
        for (int k = 0; k < 3; k++) n[k] = R[3 * k] * vn[3 * i] + R[3 * k + 1] * vn[3 * i + 1] + R[3 * k + 2] * vn[3 * i + 2];
        memcpy(&vn[3 * i], n, sizeof n);
    }
    /* A texel is hidden when another surface lies in front of it by more than this depth. */
    const float occlusion_eps = 0.015f * face_width;
    const size_t plane = (size_t)size * size, pplane = (size_t)photo->width * photo->height;
    const float ds = face->depth_sign;
#pragma omp parallel for schedule(static)
    for (int y = 0; y < size; y++)
        for (int x = 0; x < size; x++) {
            size_t i = (size_t)y * size + x;
            int t = uvr.tri[i];
            if (t < 0) continue;
            const float *b = &uvr.bary[3 * i];
            const int *v = &mesh->tri[3 * t];
            /* the texel's place in the photo: p = sum_k b_k L_{v_k} */
            float px = 0, py = 0, pz = 0, n[3] = {0, 0, 0};
            for (int k = 0; k < 3; k++) {
                px += b[k] * face->landmarks[v[k]][0];
                py += b[k] * face->landmarks[v[k]][1];
                pz += b[k] * ds * face->landmarks[v[k]][2];
                for (int j = 0; j < 3; j++) n[j] += b[k] * vn[3 * v[k] + j];
            }
            for (int c = 0; c < 3; c++)
                face->texture.data[c * plane + i] = sample_bilinear(&photo->data[c * pplane], photo->width, photo->height, px, py);
            float len = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            if (!(len > 0)) continue;
            for (int j = 0; j < 3; j++) n[j] /= len;
            int visible = n[2] > 0 && hd_landmark_tri_front(mesh, (const float (*)[3])face->landmarks, t) &&
                          px >= 0 && py >= 0 && px <= photo->width && py <= photo->height;
            if (visible) {
                /* occlusion: the front-most triangle under the texel's photo position, its plane's
                 * depth there against the texel's own depth */
                int qx = (int)floorf(px) - pr.x0, qy = (int)floorf(py) - pr.y0;
                if (qx >= pr.width) qx = pr.width - 1;
                if (qy >= pr.height) qy = pr.height - 1;
                if (qx >= 0 && qy >= 0) {
                    int t2 = pr.tri[(size_t)qy * pr.width + qx];
                    /* triangles sharing a vertex with t are the same stretch of surface */
                    const int *v2 = t2 >= 0 ? &mesh->tri[3 * t2] : NULL;
                    int neighbour = v2 && (v2[0] == v[0] || v2[0] == v[1] || v2[0] == v[2] || v2[1] == v[0] ||
                                           v2[1] == v[1] || v2[1] == v[2] || v2[2] == v[0] || v2[2] == v[1] ||
                                           v2[2] == v[2]);
                    if (t2 >= 0 && t2 != t && !neighbour) {
                        const float *a = face->landmarks[v2[0]], *bb = face->landmarks[v2[1]], *c = face->landmarks[v2[2]];
                        double area = (double)(bb[0] - a[0]) * (c[1] - a[1]) - (double)(bb[1] - a[1]) * (c[0] - a[0]);
                        double wa = ((bb[0] - px) * (c[1] - py) - (bb[1] - py) * (c[0] - px)) / area;
                        double wb = ((c[0] - px) * (a[1] - py) - (c[1] - py) * (a[0] - px)) / area;
                        double z2 = ds * (wa * a[2] + wb * bb[2] + (1 - wa - wb) * c[2]);
                        /* the plane of t2 is read up to a pixel away from where it was rasterised:
                         * allow its depth change over one pixel, |dz/dx| + |dz/dy| */
                        double dzdx = ds * ((bb[1] - c[1]) * a[2] + (c[1] - a[1]) * bb[2] + (a[1] - bb[1]) * c[2]) / area;
                        double dzdy = ds * ((c[0] - bb[0]) * a[2] + (a[0] - c[0]) * bb[2] + (bb[0] - a[0]) * c[2]) / area;
                        if (z2 > pz + occlusion_eps + fabs(dzdx) + fabs(dzdy)) visible = 0;
                    }
                }
            }
            if (!visible) continue;
            face->mask.data[i] = 1.0f;
            for (int j = 0; j < 3; j++) face->normal.data[j * plane + i] = n[j];
        }
done:
    free(vn);
    hd_uv_raster_free(&uvr);
    hd_photo_raster_free(&pr);
    if (st) hd_aligned_face_free(face);
    return st;
}

hd_status hd_align_face(const hd_image *photo, const float landmarks[HD_FACE_LANDMARKS][3], int size,
                        hd_aligned_face *face)
{
    memset(face, 0, sizeof *face);
    const hd_mesh *mesh;
    hd_status st = hd_mesh_canonical(&mesh);
    return st ? st : hd_align_face_on(mesh, photo, landmarks, size, face);
}
