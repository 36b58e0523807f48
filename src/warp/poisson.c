/* poisson.c: seamless cloning (Perez, Gangnet, Blake 2003). Over the region Omega of the target
 * covered by the source's mask, solve the discrete Poisson equation with the source's gradients
 * as guidance and the target on the boundary:
 *
 *   for p in Omega:  4 f_p - sum_{q in N(p), q in Omega} f_q
 *                     = sum_{q in N(p), q not in Omega} T_q + sum_{q in N(p)} (S_p - S_q)
 *
 * (5-point stencil, N(p) the 4 neighbours). The matrix is the Dirichlet Laplacian of Omega:
 * symmetric positive definite. It is solved per channel by conjugate gradients preconditioned
 * with one multigrid V-cycle (red-black Gauss-Seidel smoothing, 2x2 cell coarsening with
 * averaging restriction and piecewise-constant prolongation, Galerkin-scaled coarse stencils;
 * symmetric, so CG stays valid) over the region's bounding box, at full resolution. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/core.h"

/* Grids are stored with one cell of zero padding on each side: cell (x, y) of a w x h grid is at
 * (y + 1) * (w + 2) + x + 1, so the four neighbours of any cell can be read without tests. */
typedef struct level {
    int w, h, stride;
    size_t cells;         /* (w + 2) * (h + 2) */
    unsigned char *in;    /* 1 in Omega at this level */
    float *u, *f, *r;     /* solution, right-hand side, residual */
    float coef;           /* the operator here: (A u)_p = coef * (4 u_p - sum_{q in Omega} u_q) */
} level;

#define MAX_LEVELS 16
#define SMOOTH_SWEEPS 2
#define COARSE_SWEEPS 30
#define MAX_ITERATIONS 1000
/* Grids smaller than this run on one thread: a parallel region costs more than it saves. */
#define PARALLEL_CELLS (1 << 20)

typedef struct solver {
    int nlevels;
    level lv[MAX_LEVELS];
    float *b, *x, *res, *z, *p, *ap; /* right-hand side and CG vectors, on level 0's layout */
} solver;

static void solver_free(solver *s)
{
    for (int l = 0; l < s->nlevels; l++) {
        free(s->lv[l].in);
        free(s->lv[l].u);
        free(s->lv[l].f);
        free(s->lv[l].r);
    }
    free(s->b);
    free(s->x);
    free(s->res);
    free(s->z);
    free(s->p);
    free(s->ap);
    memset(s, 0, sizeof *s);
}

static float *grid_floats(size_t cells) { return hd_calloc(cells, sizeof(float)); }

/* Builds the level hierarchy from level 0's Omega (already in s->lv[0].in). */
static hd_status solver_build(solver *s)
{
    level *L = &s->lv[0];
    if (!(L->u = grid_floats(L->cells)) || !(L->f = grid_floats(L->cells)) || !(L->r = grid_floats(L->cells)))
        return HD_ERR_NOMEM;
    L->coef = 1.0f;
    s->nlevels = 1;
    while (s->nlevels < MAX_LEVELS) {
        level *fine = &s->lv[s->nlevels - 1];
        if (fine->w <= 4 || fine->h <= 4) break;
        level *c = &s->lv[s->nlevels];
        c->w = (fine->w + 1) / 2;
        c->h = (fine->h + 1) / 2;
        c->stride = c->w + 2;
        c->cells = (size_t)c->stride * (c->h + 2);
        c->coef = fine->coef * 0.5f; /* Galerkin R A P with R = P^T / 4, P constant: A_c = A_f / 2 */
        s->nlevels++;
        if (!(c->in = hd_calloc(c->cells, 1)) || !(c->u = grid_floats(c->cells)) || !(c->f = grid_floats(c->cells)) ||
            !(c->r = grid_floats(c->cells)))
            return HD_ERR_NOMEM;
        for (int y = 0; y < fine->h; y++)
            for (int x = 0; x < fine->w; x++)
                if (fine->in[(size_t)(y + 1) * fine->stride + x + 1])
                    c->in[(size_t)(y / 2 + 1) * c->stride + x / 2 + 1] = 1;
    }
    size_t n = s->lv[0].cells;
    if (!(s->b = grid_floats(n)) || !(s->x = grid_floats(n)) || !(s->res = grid_floats(n)) || !(s->z = grid_floats(n)) || !(s->p = grid_floats(n)) ||
        !(s->ap = grid_floats(n)))
        return HD_ERR_NOMEM;
    return HD_OK;
}

/* out = A u on level L (0 outside Omega). */
static void apply_operator(const level *L, const float *u, float *out)
{
#pragma omp parallel for schedule(static) if (L->cells >= PARALLEL_CELLS)
    for (int y = 1; y <= L->h; y++)
        for (int x = 1; x <= L->w; x++) {
            size_t i = (size_t)y * L->stride + x;
            out[i] = L->in[i] ? L->coef * (4 * u[i] - u[i - 1] - u[i + 1] - u[i - L->stride] - u[i + L->stride]) : 0.0f;
        }
}

/* One Gauss-Seidel half sweep over the cells of colour (x + y) % 2 == color:
 * u_p = (f_p / coef + sum_q u_q) / 4, with u = 0 outside Omega. */
static void gs_color(level *L, int color)
{
#pragma omp parallel for schedule(static) if (L->cells >= PARALLEL_CELLS)
    for (int y = 1; y <= L->h; y++)
        for (int x = 1 + ((y + 1 + color) & 1); x <= L->w; x += 2) {
            size_t i = (size_t)y * L->stride + x;
            if (!L->in[i]) continue;
            L->u[i] = 0.25f * (L->f[i] / L->coef + L->u[i - 1] + L->u[i + 1] + L->u[i - L->stride] + L->u[i + L->stride]);
        }
}

/* One V-cycle for A u = f on level l from u = 0; symmetric (red-black before, black-red after). */
static void v_cycle(solver *s, int l)
{
    level *L = &s->lv[l];
    memset(L->u, 0, L->cells * sizeof(float));
    if (l == s->nlevels - 1) {
        for (int k = 0; k < COARSE_SWEEPS; k++) {
            gs_color(L, 0);
            gs_color(L, 1);
            gs_color(L, 1);
            gs_color(L, 0);
        }
        return;
    }
    for (int k = 0; k < SMOOTH_SWEEPS; k++) {
        gs_color(L, 0);
        gs_color(L, 1);
    }
    apply_operator(L, L->u, L->r);
    level *C = &s->lv[l + 1];
    memset(C->f, 0, C->cells * sizeof(float));
    /* restriction: f_c = (1/4) sum over the 2x2 children of (f - A u) */
#pragma omp parallel for schedule(static) if (L->cells >= PARALLEL_CELLS)
    for (int cy = 0; cy < C->h; cy++)
        for (int y = 2 * cy; y < 2 * cy + 2 && y < L->h; y++)
            for (int x = 0; x < L->w; x++) {
                size_t i = (size_t)(y + 1) * L->stride + x + 1;
                if (L->in[i]) C->f[(size_t)(cy + 1) * C->stride + x / 2 + 1] += 0.25f * (L->f[i] - L->r[i]);
            }
    v_cycle(s, l + 1);
    /* prolongation: every child takes its parent's correction */
#pragma omp parallel for schedule(static) if (L->cells >= PARALLEL_CELLS)
    for (int y = 0; y < L->h; y++)
        for (int x = 0; x < L->w; x++) {
            size_t i = (size_t)(y + 1) * L->stride + x + 1;
            if (L->in[i]) L->u[i] += C->u[(size_t)(y / 2 + 1) * C->stride + x / 2 + 1];
        }
    for (int k = 0; k < SMOOTH_SWEEPS; k++) {
        gs_color(L, 1);
        gs_color(L, 0);
    }
}

static double dot(const float *a, const float *b, size_t n)
{
    double sum = 0;
#pragma omp parallel for reduction(+ : sum) schedule(static) if (n >= PARALLEL_CELLS)
    for (size_t i = 0; i < n; i++) sum += (double)a[i] * b[i];
    return sum;
}

/* z = M r: one V-cycle from zero with r as the right-hand side. */
static void precondition(solver *s, const float *r, float *z)
{
    level *L0 = &s->lv[0];
    memcpy(L0->f, r, L0->cells * sizeof(float));
    v_cycle(s, 0);
    memcpy(z, L0->u, L0->cells * sizeof(float));
}

/* Solves A x = b (b in s->b, start in s->x) to |b - A x| <= tol |b| by preconditioned CG,
 * restarting from the true residual when the recursively updated one has drifted (float
 * vectors, double sums). Reports the iterations and the true final relative residual. */
static void pcg(solver *s, double tol, int *iterations, double *rel_residual)
{
    level *L0 = &s->lv[0];
    size_t n = L0->cells;
    double bnorm = sqrt(dot(s->b, s->b, n));
    *iterations = 0;
    *rel_residual = 0;
    if (bnorm == 0) {
        memset(s->x, 0, n * sizeof(float));
        return;
    }
    for (int restart = 0;; restart++) {
        apply_operator(L0, s->x, s->res);
        for (size_t i = 0; i < n; i++) s->res[i] = s->b[i] - s->res[i];
        double rel = sqrt(dot(s->res, s->res, n)) / bnorm;
        *rel_residual = rel;
        if (rel <= tol || *iterations >= MAX_ITERATIONS || restart > 8) return;
        precondition(s, s->res, s->z);
        memcpy(s->p, s->z, n * sizeof(float));
        double rz = dot(s->res, s->z, n);
        while (*iterations < MAX_ITERATIONS) {
            apply_operator(L0, s->p, s->ap);
            double pap = dot(s->p, s->ap, n);
            if (!(pap > 0)) break;
            /* alpha = r.z / p.Ap;  x += alpha p;  r -= alpha Ap */
            double alpha = rz / pap, rr = 0;
#pragma omp parallel for reduction(+ : rr) schedule(static) if (n >= PARALLEL_CELLS)
            for (size_t i = 0; i < n; i++) {
                s->x[i] += (float)(alpha * s->p[i]);
                s->res[i] -= (float)(alpha * s->ap[i]);
                rr += (double)s->res[i] * s->res[i];
            }
            ++*iterations;
            if (sqrt(rr) <= 0.5 * tol * bnorm) break;
            precondition(s, s->res, s->z);
            /* beta = r'.z' / r.z;  p = z' + beta p */
            double rz_new = dot(s->res, s->z, n), beta = rz_new / rz;
            rz = rz_new;
#pragma omp parallel for schedule(static) if (n >= PARALLEL_CELLS)
            for (size_t i = 0; i < n; i++) s->p[i] = s->z[i] + (float)(beta * s->p[i]);
        }
    }
}

hd_status hd_poisson_blend(const hd_image *source, const hd_image *mask, int offset_x, int offset_y,
                           double tolerance, hd_image *target, hd_poisson_report *report)
{
    double start = hd_seconds();
    if (report) memset(report, 0, sizeof *report);
    if (!source || !source->data || !mask || !mask->data || !target || !target->data)
        return hd_fail(HD_ERR_ARG, "blend: empty source, mask or target");
    if (mask->channels != 1 || mask->width != source->width || mask->height != source->height)
        return hd_fail(HD_ERR_ARG, "blend: the mask must be 1 channel of the source's size (%dx%d), got %d channel(s) %dx%d",
                       source->width, source->height, mask->channels, mask->width, mask->height);
    if (source->channels != target->channels || source->channels < 1 || source->channels > 4)
        return hd_fail(HD_ERR_ARG, "blend: the source has %d channels, the target %d", source->channels, target->channels);
    if (offset_x < -HD_IMAGE_MAX_SIDE || offset_x > HD_IMAGE_MAX_SIDE || offset_y < -HD_IMAGE_MAX_SIDE ||
        offset_y > HD_IMAGE_MAX_SIDE)
        return hd_fail(HD_ERR_RANGE, "blend: offset %d,%d out of range", offset_x, offset_y);
    if (tolerance <= 0) tolerance = HD_POISSON_TOLERANCE;
    if (!(tolerance < 1)) return hd_fail(HD_ERR_RANGE, "blend: tolerance %g is not below 1", tolerance);
    int sw = source->width, sh = source->height, tw = target->width, th = target->height;
    /* Omega: mask > 0.5, strictly inside the source and the target (its neighbours exist in both) */
#define IN_OMEGA(x, y)                                                                                     \
    ((x) >= 1 && (y) >= 1 && (x) < sw - 1 && (y) < sh - 1 && (x) + offset_x >= 1 && (y) + offset_y >= 1 && \
     (x) + offset_x < tw - 1 && (y) + offset_y < th - 1 && mask->data[(size_t)(y) * sw + (x)] > 0.5f)
    int bx0 = sw, by0 = sh, bx1 = -1, by1 = -1;
    long count = 0;
    for (int y = 0; y < sh; y++)
        for (int x = 0; x < sw; x++)
            if (IN_OMEGA(x, y)) {
                if (x < bx0) bx0 = x;
                if (x > bx1) bx1 = x;
                if (y < by0) by0 = y;
                if (y > by1) by1 = y;
                count++;
            }
    if (report) {
        report->unknowns = (int)count;
        report->channels = source->channels;
        report->tolerance = tolerance;
    }
    if (count == 0) {
        if (report) report->seconds = hd_seconds() - start;
        return HD_OK; /* nothing to blend: the target is unchanged */
    }
    solver s;
    memset(&s, 0, sizeof s);
    level *L = &s.lv[0];
    L->w = bx1 - bx0 + 1;
    L->h = by1 - by0 + 1;
    L->stride = L->w + 2;
    if (!hd_mul_size((size_t)L->stride, (size_t)L->h + 2, &L->cells))
        return hd_fail(HD_ERR_RANGE, "blend: region too large");
    hd_status st = HD_OK;
    if (!(L->in = hd_calloc(L->cells, 1))) return HD_ERR_NOMEM;
    s.nlevels = 1;
    for (int y = by0; y <= by1; y++)
        for (int x = bx0; x <= bx1; x++)
            if (IN_OMEGA(x, y)) L->in[(size_t)(y - by0 + 1) * L->stride + x - bx0 + 1] = 1;
    if ((st = solver_build(&s))) goto done;
    size_t splane = (size_t)sw * sh, tplane = (size_t)tw * th;
    for (int c = 0; c < source->channels; c++) {
        const float *S = &source->data[c * splane];
        float *T = &target->data[c * tplane];
        /* right-hand side: boundary values of the target plus the guidance 4 S_p - sum_q S_q;
         * start from the source shifted by the mean boundary difference T - S */
        double shift = 0;
        long nshift = 0;
        static const int dx[4] = {-1, 1, 0, 0}, dy[4] = {0, 0, -1, 1};
        memset(s.b, 0, L->cells * sizeof(float));
        memset(s.x, 0, L->cells * sizeof(float));
        for (int y = by0; y <= by1; y++)
            for (int x = bx0; x <= bx1; x++) {
                size_t g = (size_t)(y - by0 + 1) * L->stride + x - bx0 + 1;
                if (!L->in[g]) continue;
                double b = 4.0 * S[(size_t)y * sw + x];
                for (int k = 0; k < 4; k++) {
                    int qx = x + dx[k], qy = y + dy[k];
                    b -= S[(size_t)qy * sw + qx];
                    if (!L->in[g + dx[k] + (ptrdiff_t)dy[k] * L->stride]) {
                        double t = T[(size_t)(qy + offset_y) * tw + qx + offset_x];
                        b += t;
                        shift += t - S[(size_t)qy * sw + qx];
                        nshift++;
                    }
                }
                s.b[g] = (float)b;
            }
        shift = nshift ? shift / nshift : 0;
        for (int y = by0; y <= by1; y++)
            for (int x = bx0; x <= bx1; x++) {
                size_t g = (size_t)(y - by0 + 1) * L->stride + x - bx0 + 1;
                if (L->in[g]) s.x[g] = (float)(S[(size_t)y * sw + x] + shift);
            }
        int iters;
        double rel;
        pcg(&s, tolerance, &iters, &rel);
        if (report && c < 4) {
            report->iterations[c] = iters;
            report->residual[c] = rel;
        }
        if (!(rel <= tolerance)) {
            st = hd_fail(HD_ERR_NUMERIC, "blend: the Poisson solver stopped at relative residual %.3g after %d iterations (tolerance %.3g)",
                         rel, iters, tolerance);
            goto done;
        }
        for (int y = by0; y <= by1; y++)
            for (int x = bx0; x <= bx1; x++) {
                size_t g = (size_t)(y - by0 + 1) * L->stride + x - bx0 + 1;
                if (L->in[g]) T[(size_t)(y + offset_y) * tw + x + offset_x] = s.x[g];
            }
    }
#undef IN_OMEGA
done:
    solver_free(&s);
    if (report) report->seconds = hd_seconds() - start;
    return st;
}
