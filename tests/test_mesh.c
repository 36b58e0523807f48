/* test_mesh.c: the canonical face mesh (counts, SPEC section 2's landmark UVs, winding), the strict
 * OBJ reader's errors, the UV rasteriser (barycentrics reproduce the texel centre; shared edges and
 * vertices covered exactly once) and area-weighted vertex normals. */
#include <stdlib.h>
#include <string.h>
#include "test.h"
#include "core/core.h"
#include "mesh/mesh.h"
#include "test_models.h"


static void write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    fputs(text, f);
    fclose(f);
}

static void test_canonical(void)
{
    hd_mesh m;
    if (!test_load_canonical(&m)) {
        test_failures++;
        return;
    }
    CHECK(m.nv == 468);
    CHECK(m.nt == 898);
    static const struct { int v; float u, w; } marks[] = {
        {1, 0.500f, 0.547f},   {33, 0.280f, 0.376f},  {263, 0.720f, 0.376f}, {61, 0.382f, 0.695f},
        {291, 0.618f, 0.695f}, {152, 0.500f, 0.954f}, {10, 0.500f, 0.107f},
    };
    for (size_t i = 0; i < sizeof marks / sizeof marks[0]; i++) {
        CHECK_NEAR(m.uv[2 * marks[i].v], marks[i].u, 0.005);
        CHECK_NEAR(m.uv[2 * marks[i].v + 1], marks[i].w, 0.005);
    }
    /* the nose tip is the front-most point of the midline and the forehead is above the chin */
    CHECK(m.pos[3 * 1 + 2] > m.pos[3 * 152 + 2]);
    CHECK(m.pos[3 * 10 + 1] > m.pos[3 * 152 + 1]);
    /* u grows with x: vertex 33 (image left) has x < 0 */
    CHECK(m.pos[3 * 33] < 0.0f && m.pos[3 * 263] > 0.0f);
    /* counter-clockwise seen from the front: almost every face normal points toward the viewer */
    float *n = malloc((size_t)m.nv * 3 * sizeof(float));
    int front = 0;
    for (int t = 0; t < m.nt; t++) {
        const float *a = m.pos + 3 * m.tri[3 * t], *b = m.pos + 3 * m.tri[3 * t + 1], *c = m.pos + 3 * m.tri[3 * t + 2];
        float nz = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        front += nz > 0;
    }
    CHECK(front > m.nt * 95 / 100);
    hd_mesh_vertex_normals(&m, m.pos, n);
    CHECK(n[3 * 1 + 2] > 0.9f); /* the nose tip faces the viewer */
    CHECK(n[3 * 33] < 0.0f);    /* the outer eye corner on the image left turns left */
    for (int v = 0; v < m.nv; v++)
        CHECK_NEAR(n[3 * v] * n[3 * v] + n[3 * v + 1] * n[3 * v + 1] + n[3 * v + 2] * n[3 * v + 2], 1.0, 1e-5);
    free(n);

    /* raster: the interpolated UV of each covered texel is its centre */
    hd_uv_raster r;
    int size = 64;
    CHECK(hd_mesh_uv_raster(&m, size, &r) == HD_OK);
    int covered = 0;
    double worst = 0;
    for (int y = 0; y < size; y++)
        for (int x = 0; x < size; x++) {
            int i = y * size + x, t = r.tri[i];
            if (t < 0) continue;
            covered++;
            const float *b = r.bary + 3 * i;
            float u = 0, v = 0, sum = 0;
            for (int k = 0; k < 3; k++) {
                CHECK(b[k] >= 0.0f && b[k] <= 1.0f);
                u += b[k] * m.uv[2 * m.tri[3 * t + k]];
                v += b[k] * m.uv[2 * m.tri[3 * t + k] + 1];
                sum += b[k];
            }
            CHECK_NEAR(sum, 1.0, 1e-5);
            double e = fabs(u - (x + 0.5) / size) + fabs(v - (y + 0.5) / size);
            if (e > worst) worst = e;
        }
    CHECK(worst < 1e-4);
    /* the face covers a large part of its layout, and the landmarks are inside */
    CHECK(covered > size * size / 2 && covered < size * size);
    int nose = (int)(0.547f * size) * size + (int)(0.5f * size);
    CHECK(r.tri[nose] >= 0);
    CHECK(r.tri[0] < 0); /* a corner of the texture is outside the face */
    hd_uv_raster_free(&r);
    CHECK(hd_mesh_uv_raster(&m, 0, &r) == HD_ERR_RANGE);
    hd_mesh_free(&m);
}

/* A fan of 8 triangles around the texel centre (0.5, 0.5) of a 4x4 grid whose edges pass through
 * texel centres: every centre of the square is covered exactly once, by the expected rule. */
/* The texels covered when each triangle of m is rasterised alone, summed over the triangles. */
static int covered_one_by_one(const hd_mesh *m, int size)
{
    int sum = 0;
    for (int t = 0; t < m->nt; t++) {
        hd_mesh one = *m;
        hd_uv_raster r;
        one.nt = 1;
        one.tri = m->tri + 3 * t;
        hd_status st = hd_mesh_uv_raster(&one, size, &r);
        CHECK(st == HD_OK);
        if (st != HD_OK) return -1;
        for (int i = 0; i < size * size; i++) sum += r.tri[i] >= 0;
        hd_uv_raster_free(&r);
    }
    return sum;
}

static void test_raster_edges(void)
{
    write_text("fan.obj",
               "# a square split into a fan around its centre\n"
               "v 0 0 0\nv 0 0 0\nv 0 0 0\nv 0 0 0\nv 0 0 0\nv 0 0 0\nv 0 0 0\nv 0 0 0\nv 0 0 0\n"
               "vt 0.125 0.125\nvt 0.5 0.125\nvt 0.875 0.125\nvt 0.875 0.5\nvt 0.875 0.875\n"
               "vt 0.5 0.875\nvt 0.125 0.875\nvt 0.125 0.5\nvt 0.5 0.5\n"
               "f 9/9 1/1 2/2\nf 9/9 2/2 3/3\nf 9/9 3/3 4/4\nf 9/9 4/4 5/5\n"
               "f 9/9 5/5 6/6\nf 9/9 6/6 7/7\nf 9/9 7/7 8/8\nf 9/9 8/8 1/1\n");
    hd_mesh m;
    CHECK(hd_mesh_load_obj("fan.obj", &m) == HD_OK);
    CHECK(m.nv == 9 && m.nt == 8);
    hd_uv_raster r;
    /* size 4: centres at 0.125, 0.375, 0.625, 0.875: all 16 lie on the closed square, and the
     * diagonals pass through (0.375, 0.375) and (0.625, 0.625); size 8: none on the boundary */
    for (int size = 4; size <= 8; size *= 2) {
        if (hd_mesh_uv_raster(&m, size, &r) != HD_OK) {
            test_failures++;
            continue;
        }
        int count = 0;
        for (int i = 0; i < size * size; i++) count += r.tri[i] >= 0;
        /* texel centres with 0.125 <= c <= 0.875 in both axes; the outer boundary follows the
         * top-left rule: on a 4-grid the left/top rows are kept, the right/bottom ones dropped */
        int expect = size == 4 ? 9 : 36;
        CHECK(count == expect);
        if (count != expect) fprintf(stderr, "size %d: %d texels covered, expected %d\n", size, count, expect);
        hd_uv_raster_free(&r);
        /* each triangle rasterised alone: the counts add up to the whole (no texel owned twice) */
        CHECK(covered_one_by_one(&m, size) == expect);
    }
    hd_mesh_free(&m);
    /* Four triangles meeting at a texel centre, whatever the orientation of the input: the
     * centre is owned by exactly one (count stays exact) */
    write_text("quad.obj",
               "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 0.5 0\n"
               "vt 0.0625 0.0625\nvt 0.9375 0.0625\nvt 0.9375 0.9375\nvt 0.0625 0.9375\nvt 0.5625 0.5625\n"
               "f 5 1 2\nf 5/5 3/3 2/2\nf 5/5 3/3 4/4\nf 5/5/1 1/1/1 4/4/1\n");
    CHECK(hd_mesh_load_obj("quad.obj", &m) == HD_OK);
    CHECK(hd_mesh_uv_raster(&m, 8, &r) == HD_OK);
    /* texel centres (x+0.5)/8 in [0.0625, 0.9375]: the left/top edges are kept (x = 0..6) and
     * the right/bottom ones dropped: 7 x 7 */
    int count = 0;
    for (int i = 0; i < 64; i++) count += r.tri[i] >= 0;
    CHECK(count == 49);
    CHECK(r.tri[4 * 8 + 4] >= 0); /* the shared vertex itself */
    hd_uv_raster_free(&r);
    CHECK(covered_one_by_one(&m, 8) == 49);
    hd_mesh_free(&m);
}

static void test_obj_errors(void)
{
    static const struct { const char *text, *want; } bad[] = {
        {"v 0 0\nvt 0 0\nf 1 1 1\n", ":1: a vertex wants 3"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3 1/1\n", ":7: only triangles"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 4/4\n", "face 1 uses vertex 4"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/2 2/2 3/3\n", "vertex i must use vt i"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nf 1 2 3\n", "3 vertices but 2 texture"},
        {"v 0 0 0\nvt 0 1.5\n", ":2: texture coordinate (0, 1.5) outside"},
        {"v nan 0 0\n", ":1: a vertex wants 3"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf -1 2 3\n", "out of range"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1 2 2\n", "degenerate"},
        {"v 0 0 0\nvt 0 0\nxyz 1\n", ":3: unsupported OBJ statement 'xyz'"},
        {"# nothing\n", "no vertices"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        write_text("bad.obj", bad[i].text);
        hd_mesh m;
        hd_status st = hd_mesh_load_obj("bad.obj", &m);
        CHECK(st != HD_OK);
        if (!strstr(hd_error(), bad[i].want) || !strstr(hd_error(), "bad.obj")) {
            fprintf(stderr, "case %zu: error '%s' lacks '%s'\n", i, hd_error(), bad[i].want);
            test_failures++;
        }
        CHECK(m.pos == NULL && m.nv == 0);
    }
    hd_mesh m;
    CHECK(hd_mesh_load_obj("missing.obj", &m) == HD_ERR_IO);
    CHECK(strstr(hd_error(), "missing.obj") != NULL);
}

/* Normals of a flat grid point along z; of a tilted plane along its normal; and at a vertex
 * shared by a large and a small face they lean toward the large one (area weighting). */
static void test_normals(void)
{
    enum { G = 5 };
    hd_mesh m = {0};
    m.nv = G * G;
    m.nt = 2 * (G - 1) * (G - 1);
    m.pos = calloc((size_t)m.nv * 3, sizeof(float));
    m.uv = calloc((size_t)m.nv * 2, sizeof(float));
    m.tri = calloc((size_t)m.nt * 3, sizeof(int));
    for (int y = 0; y < G; y++)
        for (int x = 0; x < G; x++) {
            m.pos[3 * (y * G + x)] = (float)x;
            m.pos[3 * (y * G + x) + 1] = (float)y;
        }
    int t = 0;
    for (int y = 0; y + 1 < G; y++)
        for (int x = 0; x + 1 < G; x++) {
            int a = y * G + x, b = a + 1, c = a + G, d = c + 1; /* y up: c above a */
            int tr[6] = {a, b, d, a, d, c};                      /* counter-clockwise from +z */
            memcpy(m.tri + 3 * t, tr, sizeof tr);
            t += 2;
        }
    float *n = malloc((size_t)m.nv * 3 * sizeof(float));
    hd_mesh_vertex_normals(&m, m.pos, n);
    for (int v = 0; v < m.nv; v++) {
        CHECK_NEAR(n[3 * v], 0, 1e-6);
        CHECK_NEAR(n[3 * v + 1], 0, 1e-6);
        CHECK_NEAR(n[3 * v + 2], 1, 1e-6);
    }
    /* tilt: z = 0.5 x, normal (-0.5, 0, 1) / |.| */
    float *p = malloc((size_t)m.nv * 3 * sizeof(float));
    memcpy(p, m.pos, (size_t)m.nv * 3 * sizeof(float));
    for (int v = 0; v < m.nv; v++) p[3 * v + 2] = 0.5f * p[3 * v];
    hd_mesh_vertex_normals(&m, p, n);
    for (int v = 0; v < m.nv; v++) {
        CHECK_NEAR(n[3 * v], -0.5 / sqrt(1.25), 1e-5);
        CHECK_NEAR(n[3 * v + 2], 1 / sqrt(1.25), 1e-5);
    }
    free(p);
    free(n);
    free(m.pos);
    free(m.uv);
    free(m.tri);

    /* two faces sharing vertex 0: one in the z = 0 plane of area 2 (normal +z), one in the x = 0
     * plane of area 0.5 (normal +x): the normal is (0.5, 0, 2) / |.| */
    float pos[] = {0, 0, 0, 2, 0, 0, 0, 2, 0, 0, 1, 0, 0, 0, 1};
    int tri[] = {0, 1, 2, 0, 3, 4};
    hd_mesh two = {5, 2, pos, NULL, tri};
    float nn[15];
    hd_mesh_vertex_normals(&two, pos, nn);
    double len = sqrt(0.25 + 4.0);
    CHECK_NEAR(nn[0], 0.5 / len, 1e-6);
    CHECK_NEAR(nn[1], 0, 1e-6);
    CHECK_NEAR(nn[2], 2 / len, 1e-6);
}


/* A ridge on a plane, lit from one side at 30 degrees above the plane (cast_shadow.c): the plane
 * beyond the ridge is in its shadow out to h / tan 30 = 1.73 from the crest, the far slope too (it
 * rises faster than the ray), everything else sees the light; turning the ridge and the light
 * together turns nothing. x: columns -4 -1 0 1 4 (z 0 0 1 0 0), y: -2 and 2; u = (x + 4) / 8. */
static void ridge_mesh(hd_mesh *m, float *pos, float *uv, int *tri)
{
    static const float xs[5] = {-4, -1, 0, 1, 4}, zs[5] = {0, 0, 1, 0, 0};
    for (int r = 0; r < 2; r++)
        for (int c = 0; c < 5; c++) {
            const int i = 5 * r + c;
            pos[3 * i] = xs[c], pos[3 * i + 1] = r ? 2.0f : -2.0f, pos[3 * i + 2] = zs[c];
            uv[2 * i] = (xs[c] + 4) / 8, uv[2 * i + 1] = r ? 0.0f : 1.0f;
        }
    for (int c = 0; c < 4; c++) {
        int *t = tri + 6 * c;
        t[0] = c, t[1] = c + 1, t[2] = c + 6, t[3] = c, t[4] = c + 6, t[5] = c + 5;
    }
    *m = (hd_mesh){10, 8, pos, uv, tri};
}

static void test_cast_shadow_ridge(void)
{
    float pos[30], uv[20];
    int tri[24];
    hd_mesh m;
    ridge_mesh(&m, pos, uv, tri);
    const float I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, a = 30 * (float)M_PI / 180;
    const float light[3] = {cosf(a), 0, sinf(a)};
    const int S = 128;
    hd_image v = {0}, vt = {0};
    CHECK(hd_mesh_cast_shadow_uv(&m, I, light, S, 0.05f, &v) == HD_OK);
    /* the same, turned by 20 degrees of yaw and 10 of pitch (R = Rx Ry), the light with it */
    const float cy = cosf(0.349f), sy = sinf(0.349f), cx = cosf(0.175f), sx = sinf(0.175f);
    const float R[9] = {cy, 0, sy, sx * sy, cx, -sx * cy, -cx * sy, sx, cx * cy};
    float lt[3];
    for (int r = 0; r < 3; r++) lt[r] = R[3 * r] * light[0] + R[3 * r + 1] * light[1] + R[3 * r + 2] * light[2];
    CHECK(hd_mesh_cast_shadow_uv(&m, R, lt, S, 0.05f, &vt) == HD_OK);
    int bad = 0, bad_turned = 0, n = 0;
    for (int y = S / 4; v.data && vt.data && y < 3 * S / 4; y++)
        for (int x = 0; x < S; x++) {
            const float px = (x + 0.5f) / S * 8 - 4, want = (px > -1.5f && px < -1.1f) || (px > -0.8f && px < -0.2f) ? 0.0f
                                                           : px < -2.1f || px > 0.1f                            ? 1.0f
                                                                                                               : -1.0f;
            if (want < 0) continue;
            const size_t i = (size_t)y * S + x;
            n++;
            bad += fabsf(v.data[i] - want) > 0.05f, bad_turned += fabsf(vt.data[i] - want) > 0.05f;
        }
    printf("cast shadow of a ridge: %d and %d (turned) of %d texels off the analytic answer\n", bad, bad_turned, n);
    CHECK(n > 5000 && bad == 0 && bad_turned == 0);
    /* bad arguments */
    hd_image w = {0};
    const float zero[3] = {0, 0, 0};
    CHECK(hd_mesh_cast_shadow_uv(&m, I, zero, S, 0.05f, &w) == HD_ERR_ARG && !w.data);
    CHECK(hd_mesh_cast_shadow_uv(&m, I, light, S, 0.0f, &w) == HD_ERR_ARG && !w.data);
    hd_image_free(&v), hd_image_free(&vt);
}

/* The canonical face lit from the image's left at 60 degrees: the nose shades the right cheek, so
 * the texels in shadow lie on the image's right half (u > 0.5) nearly all; a light from the camera
 * casts no shadow at all. */
static void test_cast_shadow_face(void)
{
    const hd_mesh *m = NULL;
    CHECK(hd_mesh_canonical(&m) == HD_OK);
    if (!m) return;
    const float I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, side[3] = {-0.866f, 0, 0.5f}, front[3] = {0, 0, 1};
    const int S = 128;
    hd_image v = {0};
    CHECK(hd_mesh_cast_shadow_uv(m, I, side, S, 0.3f, &v) == HD_OK);
    int left = 0, right = 0;
    for (int y = 0; v.data && y < S; y++)
        for (int x = 0; x < S; x++)
            if (v.data[(size_t)y * S + x] < 0.5f) *(x < S / 2 ? &left : &right) += 1;
    printf("canonical face, light from the left: %d texels in shadow on the left, %d on the right\n", left, right);
    CHECK(right > 200 && left * 20 < right);
    hd_image_free(&v);
    CHECK(hd_mesh_cast_shadow_uv(m, I, front, S, 0.3f, &v) == HD_OK);
    int all = 1;
    for (size_t i = 0; v.data && i < (size_t)S * S; i++) all &= v.data[i] == 1.0f;
    CHECK(v.data && all);
    hd_image_free(&v);
}

/* hd_mesh_posed_depth_uv: the depth at the nose tip's texel (landmark 1) is scale z_1 + offset for
 * the unturned mesh, and the mesh's depth turned half a turn about y is the negative; 0 off the
 * mesh. */
static void test_posed_depth(void)
{
    const hd_mesh *m = NULL;
    CHECK(hd_mesh_canonical(&m) == HD_OK);
    if (!m) return;
    const int S = 256;
    const float I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, back[9] = {-1, 0, 0, 0, 1, 0, 0, 0, -1};
    hd_image a = {0}, b = {0};
    CHECK(hd_mesh_posed_depth_uv(m, 2.0f, I, 5.0f, S, &a) == HD_OK);
    CHECK(hd_mesh_posed_depth_uv(m, 2.0f, back, 5.0f, S, &b) == HD_OK);
    if (!a.data || !b.data) return;
    const int x = (int)(m->uv[2] * S), y = (int)(m->uv[3] * S);
    CHECK_NEAR(a.data[(size_t)y * S + x], 2.0f * m->pos[5] + 5.0f, 0.1);
    int same = 1;
    for (size_t i = 0; i < (size_t)S * S; i++)
        same &= a.data[i] == 0.0f ? b.data[i] == 0.0f : fabsf((a.data[i] - 5.0f) + (b.data[i] - 5.0f)) < 1e-4f;
    CHECK(same && a.data[0] == 0.0f);
    hd_image_free(&a), hd_image_free(&b);
}

int main(void)
{
    test_canonical();
    test_raster_edges();
    test_obj_errors();
    test_normals();
    test_cast_shadow_ridge();
    test_cast_shadow_face();
    test_posed_depth();
    return test_summary("test_mesh");
}
