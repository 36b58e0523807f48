/* mesh.c: the canonical face mesh: a strict OBJ reader (v, vt, triangular f with vertex i using
 * vt i), the shipped mesh loaded once per process and shared (hd_mesh_canonical), the
 * rasterisation of the mesh's UV layout into a texel grid (which triangle covers each texel
 * centre, with what barycentric weights), and area-weighted vertex normals.
 *
 * The rasteriser works in exact integer arithmetic (UVs snapped to 1/4096 of a texel), so the
 * edge functions of two triangles that share an edge are exact negatives of each other, and the
 * top-left rule assigns every texel centre on a shared edge or vertex to exactly one triangle:
 * no holes, no double cover, and the same answer on every machine. */
#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"
#include "mesh/mesh.h"

#define OBJ_MAX_BYTES ((size_t)256 << 20)
#define OBJ_MAX_ITEMS (1 << 24)

/* A growable array of floats or ints for the reader. */
typedef struct grow {
    void *data;
    size_t count, cap, elem;
} grow;

/* Appends one element of g->elem bytes; HD_ERR_NOMEM / HD_ERR_RANGE with the path on failure. */
static hd_status grow_push(grow *g, const void *item, const char *path)
{
    if (g->count == g->cap) {
        size_t ncap = g->cap ? g->cap * 2 : 1024, bytes;
        if (ncap > OBJ_MAX_ITEMS) ncap = OBJ_MAX_ITEMS;
        if (g->count >= ncap) return hd_fail(HD_ERR_RANGE, "%s: more than %d entries of one kind", path, OBJ_MAX_ITEMS);
        if (!hd_mul_size(ncap, g->elem, &bytes)) return hd_fail(HD_ERR_RANGE, "%s: too many entries", path);
        void *nd = realloc(g->data, bytes);
        if (!nd) return hd_fail(HD_ERR_NOMEM, "%s: out of memory reading the mesh", path);
        g->data = nd;
        g->cap = ncap;
    }
    memcpy((char *)g->data + g->count * g->elem, item, g->elem);
    g->count++;
    return HD_OK;
}

/* Parses exactly n finite floats from s (white-space separated, nothing after them). */
static int parse_floats(const char *s, int n, float *out)
{
    for (int i = 0; i < n; i++) {
        char *end;
        errno = 0;
        double v = strtod(s, &end);
        if (end == s || errno == ERANGE || !isfinite(v) || fabs(v) > 1e30) return 0;
        out[i] = (float)v;
        s = end;
    }
    while (*s == ' ' || *s == '\t' || *s == '\r') s++;
    return *s == '\0';
}

/* Parses one face corner "a", "a/t", "a/t/n" or "a//n" into the 1-based vertex index a and the
 * texture index t (0 when absent); advances *s. */
static int parse_corner(const char **s, long *a, long *t)
{
    const char *p = *s;
    while (*p == ' ' || *p == '\t') p++;
    char *end;
    errno = 0;
    *a = strtol(p, &end, 10);
    if (end == p || errno) return 0;
    p = end;
    *t = 0;
    if (*p == '/') {
        p++;
        if (*p != '/') {
            *t = strtol(p, &end, 10);
            if (end == p || errno) return 0;
            p = end;
        }
        if (*p == '/') {
            p++;
            strtol(p, &end, 10);
            if (end == p || errno) return 0;
            p = end;
        }
    }
    if (*p != '\0' && *p != ' ' && *p != '\t' && *p != '\r') return 0;
    *s = p;
    return 1;
}

hd_status hd_mesh_load_obj(const char *path, hd_mesh *mesh)
{
    memset(mesh, 0, sizeof *mesh);
    char *text = NULL;
    size_t size = 0;
    hd_status st = hd_read_file(path, OBJ_MAX_BYTES, &text, &size);
    if (st != HD_OK) return st;
    if (strlen(text) != size) {
        free(text);
        return hd_fail(HD_ERR_FORMAT, "%s: not a text OBJ file (NUL byte)", path);
    }
    grow pos = {0, 0, 0, 3 * sizeof(float)}, uv = {0, 0, 0, 2 * sizeof(float)};
    grow tri = {0, 0, 0, 3 * sizeof(int)};
    long line_no = 0;
    char *line = text;
    while (st == HD_OK && line && *line) {
        char *next = strchr(line, '\n');
        if (next) *next++ = '\0';
        line_no++;
        char *s = line;
        while (*s == ' ' || *s == '\t') s++;
        size_t len = strlen(s);
        while (len && (s[len - 1] == '\r' || s[len - 1] == ' ' || s[len - 1] == '\t')) s[--len] = '\0';
        if (*s == '\0' || *s == '#') {
            line = next;
            continue;
        }
        size_t kw = strcspn(s, " \t");
        if (kw == 1 && s[0] == 'v') {
            float v[3];
            if (!parse_floats(s + 1, 3, v))
                st = hd_fail(HD_ERR_FORMAT, "%s:%ld: a vertex wants 3 finite numbers (`v x y z`)", path, line_no);
            else
                st = grow_push(&pos, v, path);
        } else if (kw == 2 && s[0] == 'v' && s[1] == 't') {
            float t[2];
            if (!parse_floats(s + 2, 2, t))
                st = hd_fail(HD_ERR_FORMAT, "%s:%ld: a texture coordinate wants 2 finite numbers (`vt u v`)", path, line_no);
            else if (t[0] < 0.0f || t[0] > 1.0f || t[1] < 0.0f || t[1] > 1.0f)
                st = hd_fail(HD_ERR_RANGE, "%s:%ld: texture coordinate (%g, %g) outside [0, 1]", path, line_no, t[0], t[1]);
            else
                st = grow_push(&uv, t, path);
        } else if (kw == 1 && s[0] == 'f') {
            const char *p = s + 1;
            int corner[3];
            int n = 0;
            for (;;) {
                while (*p == ' ' || *p == '\t') p++;
                if (*p == '\0') break;
                long a, t;
                if (!parse_corner(&p, &a, &t)) {
                    st = hd_fail(HD_ERR_FORMAT, "%s:%ld: bad face corner (want `a/a` with 1-based indices)", path, line_no);
                    break;
                }
                if (n == 3) {
                    st = hd_fail(HD_ERR_FORMAT, "%s:%ld: only triangles are supported (face has more than 3 corners)", path, line_no);
                    break;
                }
                if (a < 1 || a > OBJ_MAX_ITEMS) {
                    st = hd_fail(HD_ERR_FORMAT, "%s:%ld: vertex index %ld out of range (1-based, no negative indices)", path, line_no, a);
                    break;
                }
                if (t != 0 && t != a) {
                    st = hd_fail(HD_ERR_FORMAT, "%s:%ld: texture index %ld differs from vertex index %ld (vertex i must use vt i)", path, line_no, t, a);
                    break;
                }
                corner[n++] = (int)(a - 1);
            }
            if (st == HD_OK && n != 3)
                st = hd_fail(HD_ERR_FORMAT, "%s:%ld: a face wants 3 corners, got %d", path, line_no, n);
            if (st == HD_OK && (corner[0] == corner[1] || corner[1] == corner[2] || corner[0] == corner[2]))
                st = hd_fail(HD_ERR_FORMAT, "%s:%ld: degenerate face (a vertex repeats)", path, line_no);
            if (st == HD_OK) st = grow_push(&tri, corner, path);
        } else if ((kw == 1 && (s[0] == 'o' || s[0] == 'g' || s[0] == 's')) ||
                   (kw == 6 && (strncmp(s, "usemtl", 6) == 0 || strncmp(s, "mtllib", 6) == 0)) ||
                   (kw == 2 && s[0] == 'v' && s[1] == 'n')) {
            /* names, groups, smoothing, materials and stored normals carry nothing we use */
        } else {
            st = hd_fail(HD_ERR_FORMAT, "%s:%ld: unsupported OBJ statement '%.*s'", path, line_no, (int)(kw > 16 ? 16 : kw), s);
        }
        line = next;
    }
    free(text);
    if (st == HD_OK && pos.count == 0) st = hd_fail(HD_ERR_FORMAT, "%s: no vertices", path);
    if (st == HD_OK && tri.count == 0) st = hd_fail(HD_ERR_FORMAT, "%s: no faces", path);
    if (st == HD_OK && uv.count != pos.count)
        st = hd_fail(HD_ERR_FORMAT, "%s: %zu vertices but %zu texture coordinates (want one vt per v)", path, pos.count, uv.count);
    if (st == HD_OK) {
        const int *t = tri.data;
        for (size_t i = 0; i < tri.count * 3; i++)
            if ((size_t)t[i] >= pos.count) {
                st = hd_fail(HD_ERR_FORMAT, "%s: face %zu uses vertex %d but there are only %zu", path, i / 3 + 1, t[i] + 1, pos.count);
                break;
            }
    }
    if (st != HD_OK) {
        free(pos.data);
        free(uv.data);
        free(tri.data);
        return st;
    }
    mesh->nv = (int)pos.count;
    mesh->nt = (int)tri.count;
    mesh->pos = pos.data;
    mesh->uv = uv.data;
    mesh->tri = tri.data;
    return HD_OK;
}

hd_status hd_mesh_load_canonical(hd_mesh *mesh)
{
    memset(mesh, 0, sizeof *mesh);
    char *path = hd_find_data("canonical_face_model.obj");
    if (!path) return HD_ERR_NOTFOUND;
    hd_status st = hd_mesh_load_obj(path, mesh);
    free(path);
    return st;
}

/* The shared canonical meshes: one per file (by its real path), appended under the lock, never
 * changed or freed once there (so a pointer handed out stays valid and needs no lock to read). */
typedef struct shared_mesh {
    struct shared_mesh *next;
    char *path;
    hd_mesh mesh;
} shared_mesh;
static pthread_mutex_t shared_lock = PTHREAD_MUTEX_INITIALIZER;
static shared_mesh *shared_meshes;

hd_status hd_mesh_canonical(const hd_mesh **mesh)
{
    *mesh = NULL;
    char *found = hd_find_data("canonical_face_model.obj");
    if (!found) return HD_ERR_NOTFOUND;
    char *path = realpath(found, NULL);
    if (!path) {
        hd_status st = hd_fail(HD_ERR_IO, "%s: cannot resolve: %s", found, strerror(errno));
        free(found);
        return st;
    }
    free(found);
    hd_status st = HD_OK;
    pthread_mutex_lock(&shared_lock);
    shared_mesh *s = shared_meshes;
    while (s && strcmp(s->path, path) != 0) s = s->next;
    if (!s) {
        s = hd_calloc(1, sizeof *s);
        if (!s)
            st = hd_fail(HD_ERR_NOMEM, "%s: out of memory loading the canonical mesh", path);
        else if ((st = hd_mesh_load_obj(path, &s->mesh)) != HD_OK) {
            free(s);
            s = NULL;
        } else {
            s->path = path;
            path = NULL;
            s->next = shared_meshes;
            shared_meshes = s;
        }
    }
    pthread_mutex_unlock(&shared_lock);
    free(path);
    if (s) *mesh = &s->mesh;
    return st;
}

void hd_mesh_free(hd_mesh *mesh)
{
    if (!mesh) return;
    free(mesh->pos);
    free(mesh->uv);
    free(mesh->tri);
    memset(mesh, 0, sizeof *mesh);
}

/* ---- UV rasterisation */

#define SUB_BITS 12 /* vertex positions snapped to 1/4096 texel */
#define SUB (1 << SUB_BITS)

/* Edge function of the directed edge a->b at p: cross(b - a, p - a), exact in 64 bits for
 * coordinates below 2^27 (size <= 16384 texels times 4096 sub-steps, plus margin). */
static inline int64_t edge_fn(int64_t ax, int64_t ay, int64_t bx, int64_t by, int64_t px, int64_t py)
{
    return (bx - ax) * (py - ay) - (by - ay) * (px - ax);
}

/* Top-left rule for a positively oriented triangle (cross(p1 - p0, p2 - p0) > 0 with v down,
 * i.e. clockwise on screen): a point exactly on the directed edge a->b belongs to this triangle
 * iff the edge is a left edge (going up, dy < 0) or a top edge (horizontal going right); the
 * neighbour traverses the shared edge the other way and gets the complement. */
static inline int edge_owns(int64_t ax, int64_t ay, int64_t bx, int64_t by)
{
    int64_t dx = bx - ax, dy = by - ay;
    return dy < 0 || (dy == 0 && dx > 0);
}

hd_status hd_mesh_uv_raster(const hd_mesh *mesh, int size, hd_uv_raster *raster)
{
    memset(raster, 0, sizeof *raster);
    if (!mesh || mesh->nt <= 0 || !mesh->uv || !mesh->tri)
        return hd_fail(HD_ERR_ARG, "uv raster: empty mesh");
    if (size < 1 || size > HD_IMAGE_MAX_SIDE)
        return hd_fail(HD_ERR_RANGE, "uv raster: size %d outside [1, %d]", size, HD_IMAGE_MAX_SIDE);
    size_t n = (size_t)size * (size_t)size, bytes;
    if (!hd_mul3_size(n, 3, sizeof(float), &bytes)) return hd_fail(HD_ERR_RANGE, "uv raster: size %d too large", size);
    raster->tri = hd_malloc(n * sizeof(int));
    raster->bary = hd_malloc(bytes);
    if (!raster->tri || !raster->bary) {
        hd_uv_raster_free(raster);
        return HD_ERR_NOMEM;
    }
    raster->size = size;
    for (size_t i = 0; i < n; i++) raster->tri[i] = -1;
    memset(raster->bary, 0, bytes);
    const double scale = (double)size * SUB;
    for (int t = 0; t < mesh->nt; t++) {
        int id[3] = {mesh->tri[3 * t], mesh->tri[3 * t + 1], mesh->tri[3 * t + 2]};
        int64_t X[3], Y[3];
        for (int k = 0; k < 3; k++) {
            X[k] = (int64_t)llround((double)mesh->uv[2 * id[k]] * scale);
            Y[k] = (int64_t)llround((double)mesh->uv[2 * id[k] + 1] * scale);
        }
        int64_t area = edge_fn(X[0], Y[0], X[1], Y[1], X[2], Y[2]);
        if (area == 0) continue; /* degenerate in UV: covers nothing */
        /* order the corners so that the triangle is positively oriented; slot k keeps the
         * weight of the mesh corner perm[k] */
        int perm[3] = {0, 1, 2};
        if (area < 0) {
            perm[1] = 2;
            perm[2] = 1;
            area = -area;
        }
        int64_t x0 = X[perm[0]], y0 = Y[perm[0]], x1 = X[perm[1]], y1 = Y[perm[1]], x2 = X[perm[2]], y2 = Y[perm[2]];
        int64_t minx = x0 < x1 ? (x0 < x2 ? x0 : x2) : (x1 < x2 ? x1 : x2);
        int64_t maxx = x0 > x1 ? (x0 > x2 ? x0 : x2) : (x1 > x2 ? x1 : x2);
        int64_t miny = y0 < y1 ? (y0 < y2 ? y0 : y2) : (y1 < y2 ? y1 : y2);
        int64_t maxy = y0 > y1 ? (y0 > y2 ? y0 : y2) : (y1 > y2 ? y1 : y2);
        /* texel x has its centre at x * SUB + SUB / 2 */
        int64_t tx0 = (minx - SUB / 2 + SUB - 1) / SUB, tx1 = (maxx - SUB / 2) / SUB;
        int64_t ty0 = (miny - SUB / 2 + SUB - 1) / SUB, ty1 = (maxy - SUB / 2) / SUB;
        if (minx < SUB / 2) tx0 = 0;
        if (miny < SUB / 2) ty0 = 0;
        if (tx1 > size - 1) tx1 = size - 1;
        if (ty1 > size - 1) ty1 = size - 1;
        int own0 = edge_owns(x1, y1, x2, y2), own1 = edge_owns(x2, y2, x0, y0), own2 = edge_owns(x0, y0, x1, y1);
        for (int64_t ty = ty0; ty <= ty1; ty++) {
            int64_t py = ty * SUB + SUB / 2;
            for (int64_t tx = tx0; tx <= tx1; tx++) {
                int64_t px = tx * SUB + SUB / 2;
                /* w_k = the edge function of the edge opposite corner k: proportional to its
                 * barycentric weight */
                int64_t w0 = edge_fn(x1, y1, x2, y2, px, py);
                int64_t w1 = edge_fn(x2, y2, x0, y0, px, py);
                int64_t w2 = edge_fn(x0, y0, x1, y1, px, py);
                if (w0 < 0 || w1 < 0 || w2 < 0) continue;
                if ((w0 == 0 && !own0) || (w1 == 0 && !own1) || (w2 == 0 && !own2)) continue;
                size_t i = (size_t)ty * (size_t)size + (size_t)tx;
                if (raster->tri[i] >= 0) continue; /* overlapping UVs: the lowest triangle index wins */
                raster->tri[i] = t;
                float *b = raster->bary + 3 * i;
                b[perm[0]] = (float)((double)w0 / (double)area);
                b[perm[1]] = (float)((double)w1 / (double)area);
                b[perm[2]] = (float)((double)w2 / (double)area);
            }
        }
    }
    return HD_OK;
}

void hd_uv_raster_free(hd_uv_raster *raster)
{
    if (!raster) return;
    free(raster->tri);
    free(raster->bary);
    memset(raster, 0, sizeof *raster);
}

/* ---- normals */

void hd_mesh_vertex_normals(const hd_mesh *mesh, const float *pos, float *normals)
{
    memset(normals, 0, (size_t)mesh->nv * 3 * sizeof(float));
    for (int t = 0; t < mesh->nt; t++) {
        const float *a = pos + 3 * mesh->tri[3 * t], *b = pos + 3 * mesh->tri[3 * t + 1], *c = pos + 3 * mesh->tri[3 * t + 2];
        /* face normal times twice the area: (b - a) x (c - a) */
        float e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        float e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        float f[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
        for (int k = 0; k < 3; k++) {
            float *n = normals + 3 * mesh->tri[3 * t + k];
            n[0] += f[0];
            n[1] += f[1];
            n[2] += f[2];
        }
    }
    for (int v = 0; v < mesh->nv; v++) {
        float *n = normals + 3 * v;
        float len = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (len > 0.0f) {
            n[0] /= len;
            n[1] /= len;
            n[2] /= len;
        } else { /* a vertex in no triangle (or only degenerate ones): face the viewer */
            n[0] = 0.0f;
            n[1] = 0.0f;
            n[2] = 1.0f;
        }
    }
}
