/* test_tfjs_graph.c: the TF.js graph runner against an independent direct implementation of every
 * op on a small graph written here (float32, float16-quantised and int32 weights; SAME, VALID and
 * EXPLICIT padding; strides, dilations, a depthwise channel multiplier; bilinear resizes on TF's
 * three grids, transposed convolutions and AddN against a tent filter, a scatter and a sum),
 * binary16 decoding against known values, the real face models' outputs, the selfie segmentation
 * network against TensorFlow.js's own output, and broken models (bad JSON, truncated or
 * oversized weights, wrong shapes, unknown ops, missing inputs, cycles) refused with errors that
 * name the file and the node. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <cjson/cJSON.h>
#include "test.h"
#include "source_dir.h"
#include "core/core.h"
#include "graph/tfjs_graph.h"

/* ------------------------------------------------------------------ binary16 */

static void test_half(void)
{
    static const struct {
        uint16_t h;
        float f;
    } known[] = {
        {0x0000, 0.0f},          {0x3C00, 1.0f},        {0xC000, -2.0f},         {0x3800, 0.5f},
        {0x7BFF, 65504.0f},      {0x0400, 6.103515625e-05f}, {0x0001, 5.9604644775390625e-08f},
        {0x03FF, 6.0975551605224609375e-05f}, {0x3555, 0.333251953125f}, {0xBE00, -1.5f},
    };
    for (size_t i = 0; i < sizeof known / sizeof known[0]; i++) CHECK(hd_half_to_float(known[i].h) == known[i].f);
    CHECK(signbit(hd_half_to_float(0x8000)) && hd_half_to_float(0x8000) == 0.0f);
    CHECK(isinf(hd_half_to_float(0x7C00)) && hd_half_to_float(0x7C00) > 0);
    CHECK(isinf(hd_half_to_float(0xFC00)) && hd_half_to_float(0xFC00) < 0);
    CHECK(isnan(hd_half_to_float(0x7E00)));
}

/* ------------------------------------------------------------------ writing a graph model */

static void b64(const char *text, char *out)
{
    static const char *abc = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    size_t n = strlen(text), o = 0;
    for (size_t i = 0; i < n; i += 3) {
        uint32_t v = (uint32_t)(unsigned char)text[i] << 16;
        if (i + 1 < n) v |= (uint32_t)(unsigned char)text[i + 1] << 8;
        if (i + 2 < n) v |= (unsigned char)text[i + 2];
        out[o++] = abc[v >> 18 & 63];
        out[o++] = abc[v >> 12 & 63];
        out[o++] = i + 1 < n ? abc[v >> 6 & 63] : '=';
        out[o++] = i + 2 < n ? abc[v & 63] : '=';
    }
    out[o] = '\0';
}

/* Half bits of a value exactly representable as a normal binary16 number (or zero). */
static uint16_t to_half_exact(float f)
{
    if (f == 0.0f) return 0;
    uint32_t u;
    memcpy(&u, &f, 4);
    uint32_t sign = u >> 31, e = (u >> 23) & 0xff, m = u & 0x7fffff;
    return (uint16_t)(sign << 15 | (e - 127 + 15) << 10 | m >> 13);
}

typedef struct model_writer {
    cJSON *root, *nodes, *weights;
    unsigned char bin[1 << 16];
    size_t bin_len;
} model_writer;

static void mw_init(model_writer *w)
{
    memset(w, 0, sizeof *w);
    w->root = cJSON_CreateObject();
    cJSON_AddStringToObject(w->root, "format", "graph-model");
    cJSON *topo = cJSON_AddObjectToObject(w->root, "modelTopology");
    w->nodes = cJSON_AddArrayToObject(topo, "node");
    cJSON *manifest = cJSON_AddArrayToObject(w->root, "weightsManifest");
    cJSON *group = cJSON_CreateObject();
    cJSON *paths = cJSON_AddArrayToObject(group, "paths");
    cJSON_AddItemToArray(paths, cJSON_CreateString("g.bin"));
    w->weights = cJSON_AddArrayToObject(group, "weights");
    cJSON_AddItemToArray(manifest, group);
}

static cJSON *mw_node(model_writer *w, const char *name, const char *op, const char *in0, const char *in1,
                      const char *in2, const char *in3)
{
    cJSON *n = cJSON_CreateObject();
    cJSON_AddStringToObject(n, "name", name);
    cJSON_AddStringToObject(n, "op", op);
    cJSON *in = cJSON_AddArrayToObject(n, "input");
    const char *ins[4] = {in0, in1, in2, in3};
    for (int i = 0; i < 4; i++)
        if (ins[i]) cJSON_AddItemToArray(in, cJSON_CreateString(ins[i]));
    cJSON_AddObjectToObject(n, "attr");
    cJSON_AddItemToArray(w->nodes, n);
    return n;
}

static void attr_s(cJSON *node, const char *key, const char *text)
{
    char enc[64];
    b64(text, enc);
    cJSON *a = cJSON_AddObjectToObject(cJSON_GetObjectItem(node, "attr"), key);
    cJSON_AddStringToObject(a, "s", enc);
}

static void attr_ints(cJSON *node, const char *key, const int *v, int n)
{
    cJSON *a = cJSON_AddObjectToObject(cJSON_GetObjectItem(node, "attr"), key);
    cJSON *list = cJSON_AddObjectToObject(a, "list");
    cJSON *i = cJSON_AddArrayToObject(list, "i");
    for (int k = 0; k < n; k++) {
        char t[16];
        snprintf(t, sizeof t, "%d", v[k]);
        cJSON_AddItemToArray(i, cJSON_CreateString(t));
    }
}

static void attr_fused(cJSON *node, const char *op1, const char *op2)
{
    cJSON *a = cJSON_AddObjectToObject(cJSON_GetObjectItem(node, "attr"), "fused_ops");
    cJSON *s = cJSON_AddArrayToObject(cJSON_AddObjectToObject(a, "list"), "s");
    char enc[64];
    b64(op1, enc);
    cJSON_AddItemToArray(s, cJSON_CreateString(enc));
    if (op2) {
        b64(op2, enc);
        cJSON_AddItemToArray(s, cJSON_CreateString(enc));
    }
}

static void attr_window(cJSON *node, int sh, int sw, int dh, int dw, const char *padding)
{
    int strides[4] = {1, sh, sw, 1}, dil[4] = {1, dh, dw, 1};
    attr_ints(node, "strides", strides, 4);
    attr_ints(node, "dilations", dil, 4);
    attr_s(node, "padding", padding);
    attr_s(node, "data_format", "NHWC");
}

typedef enum wkind { WK_F32, WK_F16, WK_I32 } wkind;

/* A Const node and its manifest entry; values appended to the shard. */
static void mw_const(model_writer *w, const char *name, const int *shape, int ndim, const float *values, wkind kind)
{
    mw_node(w, name, "Const", NULL, NULL, NULL, NULL);
    cJSON *e = cJSON_CreateObject();
    cJSON_AddStringToObject(e, "name", name);
    cJSON *sh = cJSON_AddArrayToObject(e, "shape");
    size_t count = 1;
    for (int i = 0; i < ndim; i++) {
        cJSON_AddItemToArray(sh, cJSON_CreateNumber(shape[i]));
        count *= (size_t)shape[i];
    }
    cJSON_AddStringToObject(e, "dtype", kind == WK_I32 ? "int32" : "float32");
    if (kind == WK_F16) {
        cJSON *q = cJSON_AddObjectToObject(e, "quantization");
        cJSON_AddStringToObject(q, "dtype", "float16");
        cJSON_AddStringToObject(q, "original_dtype", "float32");
    }
    cJSON_AddItemToArray(w->weights, e);
    for (size_t i = 0; i < count; i++) {
        unsigned char *p = w->bin + w->bin_len;
        if (kind == WK_F16) {
            uint16_t h = to_half_exact(values[i]);
            p[0] = (unsigned char)(h & 0xff);
            p[1] = (unsigned char)(h >> 8);
            w->bin_len += 2;
        } else {
            uint32_t u;
            if (kind == WK_I32) u = (uint32_t)(int32_t)values[i];
            else memcpy(&u, &values[i], 4);
            for (int b = 0; b < 4; b++) p[b] = (unsigned char)(u >> (8 * b));
            w->bin_len += 4;
        }
    }
}

static void write_bytes(const char *path, const void *data, size_t n)
{
    FILE *f = fopen(path, "wb");
    CHECK(f != NULL);
    if (!f) return;
    CHECK(fwrite(data, 1, n, f) == n);
    fclose(f);
}

/* Writes g.json and g.bin (bin_len bytes of the shard, to allow truncation). */
static void mw_write(model_writer *w, size_t bin_len)
{
    char *text = cJSON_PrintUnformatted(w->root);
    write_bytes("g.json", text, strlen(text));
    free(text);
    write_bytes("g.bin", w->bin, bin_len);
}

/* ------------------------------------------------------------------ the reference ops */

#define X_H 7
#define X_W 9
#define X_C 3

static float rnd(unsigned *s)
{
    *s = *s * 1103515245u + 12345u;
    return (float)((*s >> 8) & 0xffff) / 65536.0f * 2.0f - 1.0f;
}

/* Multiples of 1/64 in [-1, 1): exact in binary16. */
static float rnd_half(unsigned *s) { return floorf(rnd(s) * 64.0f) / 64.0f; }

/* Direct convolution, NHWC, HWIO filter (groups = 1) or depthwise (KH, KW, C, M);
 * pad_top/pad_left leading zeros. */
static void ref_conv(float *out, int Ho, int Wo, const float *x, int H, int W, int C, const float *f, int KH, int KW,
                     int OC, int sh, int sw, int dh, int dw, int pt, int pl, int depthwise)
{
    for (int oy = 0; oy < Ho; oy++)
        for (int ox = 0; ox < Wo; ox++)
            for (int o = 0; o < OC; o++) {
                double acc = 0;
                for (int ky = 0; ky < KH; ky++)
                    for (int kx = 0; kx < KW; kx++) {
                        int iy = oy * sh + ky * dh - pt, ix = ox * sw + kx * dw - pl;
                        if (iy < 0 || ix < 0 || iy >= H || ix >= W) continue;
                        if (depthwise) {
                            int M = OC / C, c = o / M, m = o % M;
                            acc += (double)x[(iy * W + ix) * C + c] * f[((ky * KW + kx) * C + c) * M + m];
                        } else
                            for (int c = 0; c < C; c++)
                                acc += (double)x[(iy * W + ix) * C + c] * f[((ky * KW + kx) * C + c) * OC + o];
                    }
                out[(oy * Wo + ox) * OC + o] = (float)acc;
            }
}

static void check_close(const char *what, const float *got, const float *want, int n, float tol)
{
    int bad = 0;
    for (int i = 0; i < n; i++)
        if (!(fabsf(got[i] - want[i]) <= tol * (1.0f + fabsf(want[i])))) {
            if (bad++ < 5) fprintf(stderr, "%s[%d] = %.7g, expected %.7g\n", what, i, got[i], want[i]);
        }
    CHECK(bad == 0);
}

/* A Placeholder (-1, h, wd, c). */
static void placeholder(model_writer *w, const char *name, int h, int wd, int c)
{
    cJSON *x = mw_node(w, name, "Placeholder", NULL, NULL, NULL, NULL);
    cJSON *dim = cJSON_AddArrayToObject(
        cJSON_AddObjectToObject(cJSON_AddObjectToObject(cJSON_GetObjectItem(x, "attr"), "shape"), "shape"), "dim");
    const int sizes[4] = {-1, h, wd, c};
    for (int i = 0; i < 4; i++) {
        char t[16];
        snprintf(t, sizeof t, "%d", sizes[i]);
        cJSON *d = cJSON_CreateObject();
        cJSON_AddStringToObject(d, "size", t);
        cJSON_AddItemToArray(dim, d);
    }
}

/* Builds the test graph:
 *   c1 = FusedConv2D(x, f1 3x3x3x5, b1, alpha1)  stride 2, SAME, BiasAdd + Prelu   (1,4,5,5)
 *   d1 = DepthwiseConv2dNative(c1, fd 3x3x5x2)    stride 1, SAME, dilation 2        (1,4,5,10)
 *   c2 = FusedConv2D(d1, f2 1x1x10x5, b2)         VALID, BiasAdd (float16 weights)  (1,4,5,5)
 *   r1 = Relu(AddV2(c1, c2))
 *   p1 = Pad(r1, [[0,0],[1,0],[0,1],[0,3]])                                          (1,5,6,8)
 *   m1 = MaxPool(p1) 2x2 stride 2 SAME                                               (1,3,3,8)
 *   e1 = FusedConv2D(p1, f3 2x2x8x4, b3) stride 1, EXPLICIT (1,2,0,1), dilation 2, BiasAdd + Relu
 *   s1 = Reshape(Sigmoid(m1), [-1, 72]);  out_a = Identity(s1), out_b = Identity(e1)
 * Returns the weights through the arrays so that the reference can use them. */
static float f1[3 * 3 * 4 * 5], b1[5], alpha1[5], fd[3 * 3 * 5 * 2], f2[10 * 5], b2[5], f3[2 * 2 * 8 * 4], b3[4];

static void build_test_graph(model_writer *w, const char *c1_filter_shape_override)
{
    unsigned s = 7;
    for (size_t i = 0; i < sizeof f1 / sizeof *f1; i++) f1[i] = rnd(&s); /* room for the 4-channel variant */
    for (int i = 0; i < 5; i++) b1[i] = rnd(&s), alpha1[i] = 0.25f * rnd(&s);
    for (size_t i = 0; i < sizeof fd / sizeof *fd; i++) fd[i] = rnd(&s);
    for (size_t i = 0; i < sizeof f2 / sizeof *f2; i++) f2[i] = rnd_half(&s);
    for (int i = 0; i < 5; i++) b2[i] = rnd_half(&s);
    for (size_t i = 0; i < sizeof f3 / sizeof *f3; i++) f3[i] = rnd(&s);
    for (int i = 0; i < 4; i++) b3[i] = rnd(&s);
    mw_init(w);
    placeholder(w, "x", X_H, X_W, X_C);
    int sf1[4] = {3, 3, 3, 5}, s5[1] = {5}, sa[3] = {1, 1, 5}, sfd[4] = {3, 3, 5, 2}, sf2[4] = {1, 1, 10, 5};
    int sf3[4] = {2, 2, 8, 4}, s4[1] = {4}, spad[2] = {4, 2}, sshape[1] = {2};
    if (c1_filter_shape_override) sf1[2] = atoi(c1_filter_shape_override);
    mw_const(w, "f1", sf1, 4, f1, WK_F32);
    mw_const(w, "b1", s5, 1, b1, WK_F32);
    mw_const(w, "alpha1", sa, 3, alpha1, WK_F32);
    mw_const(w, "fd", sfd, 4, fd, WK_F32);
    mw_const(w, "f2", sf2, 4, f2, WK_F16);
    mw_const(w, "b2", s5, 1, b2, WK_F16);
    mw_const(w, "f3", sf3, 4, f3, WK_F32);
    mw_const(w, "b3", s4, 1, b3, WK_F32);
    float pads[8] = {0, 0, 1, 0, 0, 1, 0, 3}, target[2] = {-1, 72};
    mw_const(w, "pads", spad, 2, pads, WK_I32);
    mw_const(w, "target", sshape, 1, target, WK_I32);
    cJSON *n = mw_node(w, "c1", "_FusedConv2D", "x", "f1", "b1", "alpha1");
    attr_window(n, 2, 2, 1, 1, "SAME");
    attr_fused(n, "BiasAdd", "Prelu");
    n = mw_node(w, "d1", "DepthwiseConv2dNative", "c1", "fd", NULL, NULL);
    attr_window(n, 1, 1, 2, 2, "SAME");
    n = mw_node(w, "c2", "_FusedConv2D", "d1:0", "f2", "b2", NULL);
    attr_window(n, 1, 1, 1, 1, "VALID");
    attr_fused(n, "BiasAdd", NULL);
    mw_node(w, "a1", "AddV2", "c1", "c2", NULL, NULL);
    mw_node(w, "r1", "Relu", "a1", NULL, NULL, NULL);
    mw_node(w, "p1", "Pad", "r1", "pads", NULL, NULL);
    n = mw_node(w, "m1", "MaxPool", "p1", NULL, NULL, NULL);
    attr_window(n, 2, 2, 1, 1, "SAME");
    int ks[4] = {1, 2, 2, 1};
    attr_ints(n, "ksize", ks, 4);
    n = mw_node(w, "e1", "_FusedConv2D", "p1", "f3", "b3", NULL);
    attr_window(n, 1, 1, 2, 2, "EXPLICIT");
    int exp[8] = {0, 0, 1, 2, 0, 1, 0, 0};
    attr_ints(n, "explicit_paddings", exp, 8);
    attr_fused(n, "BiasAdd", "Relu");
    mw_node(w, "g1", "Sigmoid", "m1", NULL, NULL, NULL);
    mw_node(w, "s1", "Reshape", "g1", "target", NULL, NULL);
    mw_node(w, "out_a", "Identity", "s1", NULL, NULL, NULL);
    mw_node(w, "out_b", "Identity", "e1", "^c1", NULL, NULL);
}

static void test_ops(void)
{
    model_writer *w = calloc(1, sizeof *w);
    build_test_graph(w, NULL);
    mw_write(w, w->bin_len);
    hd_tfjs_graph *g = NULL;
    hd_status st = hd_tfjs_load("g.json", &g);
    if (st != HD_OK) fprintf(stderr, "load: %s\n", hd_error());
    CHECK(st == HD_OK);
    if (!g) {
        cJSON_Delete(w->root);
        free(w);
        return;
    }
    int h, wd, c;
    hd_tfjs_input_shape(g, &h, &wd, &c);
    CHECK(h == X_H && wd == X_W && c == X_C);
    float x[X_H * X_W * X_C];
    unsigned s = 99;
    for (int i = 0; i < X_H * X_W * X_C; i++) x[i] = rnd(&s);
    CHECK(hd_tfjs_run(g, x) == HD_OK);

    /* Reference. c1: SAME stride 2 on 7x9 with k 3: out 4x5, pad total (3*2+3-7)=2 -> top 1;
     * (4*2+3-9)=2 -> left 1. */
    float c1[4 * 5 * 5], d1[4 * 5 * 10], c2[4 * 5 * 5], r1[4 * 5 * 5], p1[5 * 6 * 8], m1[3 * 3 * 8], e1[64 * 4];
    ref_conv(c1, 4, 5, x, 7, 9, 3, f1, 3, 3, 5, 2, 2, 1, 1, 1, 1, 0);
    for (int i = 0; i < 20; i++)
        for (int o = 0; o < 5; o++) {
            float v = c1[i * 5 + o] + b1[o];
            c1[i * 5 + o] = v >= 0 ? v : alpha1[o] * v;
        }
    /* d1: SAME, dilation 2, k 3 -> effective 5: pad total 4 -> 2 before. */
    ref_conv(d1, 4, 5, c1, 4, 5, 5, fd, 3, 3, 10, 1, 1, 2, 2, 2, 2, 1);
    ref_conv(c2, 4, 5, d1, 4, 5, 10, f2, 1, 1, 5, 1, 1, 1, 1, 0, 0, 0);
    for (int i = 0; i < 100; i++) {
        float v = c1[i] + c2[i] + b2[i % 5];
        r1[i] = v > 0 ? v : 0;
    }
    memset(p1, 0, sizeof p1);
    for (int y = 0; y < 4; y++)
        for (int xx = 0; xx < 5; xx++)
            for (int k = 0; k < 5; k++) p1[((y + 1) * 6 + xx) * 8 + k] = r1[(y * 5 + xx) * 5 + k];
    /* m1: 2x2 stride 2 SAME on 5x6: out 3x3, pad total (2*2+2-5)=1 -> 0 before, the extra row out. */
    for (int oy = 0; oy < 3; oy++)
        for (int ox = 0; ox < 3; ox++)
            for (int k = 0; k < 8; k++) {
                float mx = -INFINITY;
                for (int dy = 0; dy < 2; dy++)
                    for (int dx = 0; dx < 2; dx++) {
                        int iy = 2 * oy + dy, ix = 2 * ox + dx;
                        if (iy < 5 && ix < 6) mx = fmaxf(mx, p1[(iy * 6 + ix) * 8 + k]);
                    }
                m1[(oy * 3 + ox) * 8 + k] = 1.0f / (1.0f + expf(-mx));
            }
    /* e1: EXPLICIT (1, 2) rows and (0, 1) columns, dilation 2, k 2 -> effective 3:
     * out (5+3-3)/1+1 = 6 rows, (6+1-3)+1 = 5 columns. */
    int eh = 6, ew = 5;
    ref_conv(e1, eh, ew, p1, 5, 6, 8, f3, 2, 2, 4, 1, 1, 2, 2, 1, 0, 0);
    for (int i = 0; i < eh * ew * 4; i++) {
        float v = e1[i] + b3[i % 4];
        e1[i] = v > 0 ? v : 0;
    }
    int nd, dims[4];
    const float *out_a = hd_tfjs_output(g, "out_a:0", &nd, dims);
    CHECK(out_a && nd == 2 && dims[0] == 1 && dims[1] == 72);
    if (out_a) check_close("out_a", out_a, m1, 72, 1e-5f);
    const float *out_b = hd_tfjs_output(g, "out_b", &nd, dims);
    CHECK(out_b && nd == 4 && dims[1] == eh && dims[2] == ew && dims[3] == 4);
    if (out_b && nd == 4 && dims[1] == eh && dims[2] == ew) check_close("out_b", out_b, e1, eh * ew * 4, 1e-5f);
    /* Intermediate values are not kept (their memory is reused); e1 depends on d1 anyway. */
    CHECK(hd_tfjs_output(g, "d1", &nd, dims) == NULL && strstr(hd_error(), "not an output"));
    (void)d1;
    CHECK(hd_tfjs_output(g, "nope", NULL, NULL) == NULL && strstr(hd_error(), "nope"));
    /* A second run on other data gives that data's answer (no state kept between runs). */
    for (int i = 0; i < X_H * X_W * X_C; i++) x[i] = 0.0f;
    CHECK(hd_tfjs_run(g, x) == HD_OK);
    out_b = hd_tfjs_output(g, "out_b", NULL, NULL);
    double diff = 0;
    for (int i = 0; out_b && i < eh * ew * 4; i++) diff += fabsf(out_b[i] - e1[i]);
    CHECK(out_b && diff > 1e-3);
    hd_tfjs_free(g);
    cJSON_Delete(w->root);
    free(w);
}

/* ------------------------------------------------------------------ broken models */

/* Loads g.json, expecting failure with `code` and a reason containing both fragments. */
static void expect_fail(const char *what, hd_status code, const char *frag1, const char *frag2)
{
    hd_tfjs_graph *g = NULL;
    hd_status st = hd_tfjs_load("g.json", &g);
    int ok = st == code && g == NULL && strstr(hd_error(), frag1) && (!frag2 || strstr(hd_error(), frag2));
    if (!ok) fprintf(stderr, "%s: status %d, reason '%s'\n", what, (int)st, hd_error());
    CHECK(ok);
    hd_tfjs_free(g);
}

static void edit_node(model_writer *w, const char *name, const char *key, const char *value)
{
    cJSON *n;
    cJSON_ArrayForEach(n, w->nodes) {
        if (strcmp(cJSON_GetObjectItem(n, "name")->valuestring, name) == 0) {
            if (strcmp(key, "input0") == 0)
                cJSON_ReplaceItemInArray(cJSON_GetObjectItem(n, "input"), 0, cJSON_CreateString(value));
            else cJSON_ReplaceItemInObject(n, key, cJSON_CreateString(value));
        }
    }
}

/* Issue 15's audit: a few-KB model whose Pad adds 8192 rows and columns on each side of a
 * (1, 7, 9, 3) input used to reserve 3.2 GB of activations (within the 2^30 elements a tensor may
 * have); the loader refuses it from the shapes, naming the node. */
static void test_pad_bomb(model_writer *w)
{
    mw_init(w);
    cJSON *x = mw_node(w, "x", "Placeholder", NULL, NULL, NULL, NULL);
    cJSON *dim = cJSON_AddArrayToObject(
        cJSON_AddObjectToObject(cJSON_AddObjectToObject(cJSON_GetObjectItem(x, "attr"), "shape"), "shape"), "dim");
    const char *sizes[4] = {"-1", "7", "9", "3"};
    for (int i = 0; i < 4; i++) {
        cJSON *d = cJSON_CreateObject();
        cJSON_AddStringToObject(d, "size", sizes[i]);
        cJSON_AddItemToArray(dim, d);
    }
    int spad[2] = {4, 2};
    float pads[8] = {0, 0, 8192, 8192, 8192, 8192, 0, 0}; /* 806 M floats, 3.2 GB */
    mw_const(w, "pads", spad, 2, pads, WK_I32);
    mw_node(w, "bomb", "Pad", "x", "pads", NULL, NULL);
    mw_write(w, w->bin_len);
    expect_fail("Pad bomb", HD_ERR_FORMAT, "'bomb'", "more than 64 times the model's input");
    cJSON_Delete(w->root);
    /* a pad that fits the cap still loads */
    mw_init(w);
    x = mw_node(w, "x", "Placeholder", NULL, NULL, NULL, NULL);
    dim = cJSON_AddArrayToObject(
        cJSON_AddObjectToObject(cJSON_AddObjectToObject(cJSON_GetObjectItem(x, "attr"), "shape"), "shape"), "dim");
    for (int i = 0; i < 4; i++) {
        cJSON *d = cJSON_CreateObject();
        cJSON_AddStringToObject(d, "size", sizes[i]);
        cJSON_AddItemToArray(dim, d);
    }
    float small[8] = {0, 0, 8, 8, 8, 8, 0, 0};
    mw_const(w, "pads", spad, 2, small, WK_I32);
    mw_node(w, "fine", "Pad", "x", "pads", NULL, NULL);
    mw_write(w, w->bin_len);
    hd_tfjs_graph *g = NULL;
    CHECK(hd_tfjs_load("g.json", &g) == HD_OK);
    hd_tfjs_free(g);
    cJSON_Delete(w->root);
}

static void test_broken(void)
{
    model_writer *w = calloc(1, sizeof *w);
    hd_tfjs_graph *g = NULL;

    test_pad_bomb(w);

    CHECK(hd_tfjs_load("missing.json", &g) == HD_ERR_IO && strstr(hd_error(), "missing.json"));

    build_test_graph(w, NULL);
    mw_write(w, w->bin_len - 6);
    expect_fail("truncated bin", HD_ERR_FORMAT, "g.bin", "truncated");
    cJSON_Delete(w->root);

    build_test_graph(w, NULL);
    w->bin_len += 8;
    mw_write(w, w->bin_len);
    expect_fail("long bin", HD_ERR_FORMAT, "g.bin", "longer");
    cJSON_Delete(w->root);

    build_test_graph(w, NULL);
    mw_write(w, w->bin_len);
    unlink("g.bin");
    expect_fail("no bin", HD_ERR_IO, "g.bin", NULL);
    cJSON_Delete(w->root);

    /* A filter declared with 4 input channels (the data shifted accordingly): the shapes disagree. */
    build_test_graph(w, "4");
    mw_write(w, w->bin_len);
    expect_fail("wrong filter shape", HD_ERR_FORMAT, "'c1'", "input channels");
    cJSON_Delete(w->root);

    build_test_graph(w, NULL);
    edit_node(w, "g1", "op", "Softmax");
    mw_write(w, w->bin_len);
    expect_fail("unknown op", HD_ERR_FORMAT, "'g1'", "unsupported op");
    cJSON_Delete(w->root);

    build_test_graph(w, NULL);
    edit_node(w, "r1", "input0", "a7");
    mw_write(w, w->bin_len);
    expect_fail("missing input", HD_ERR_FORMAT, "'r1'", "'a7'");
    cJSON_Delete(w->root);

    build_test_graph(w, NULL);
    edit_node(w, "r1", "input0", "p1");
    mw_write(w, w->bin_len);
    expect_fail("cycle", HD_ERR_FORMAT, "cycle", NULL);
    cJSON_Delete(w->root);

    build_test_graph(w, NULL);
    cJSON *e;
    cJSON_ArrayForEach(e, w->weights) {
        if (strcmp(cJSON_GetObjectItem(e, "name")->valuestring, "b3") == 0)
            cJSON_ReplaceItemInObject(e, "name", cJSON_CreateString("b3x"));
    }
    mw_write(w, w->bin_len);
    expect_fail("const without weight", HD_ERR_FORMAT, "'b3'", "weightsManifest");
    cJSON_Delete(w->root);

    build_test_graph(w, NULL);
    edit_node(w, "c1", "op", "DepthwiseConv2dNative"); /* 15 outputs: the 5 biases no longer fit */
    mw_write(w, w->bin_len);
    expect_fail("bias size", HD_ERR_FORMAT, "'c1'", "bias");
    cJSON_Delete(w->root);

    /* Truncated JSON text. */
    build_test_graph(w, NULL);
    mw_write(w, w->bin_len);
    {
        char *text = cJSON_PrintUnformatted(w->root);
        write_bytes("g.json", text, strlen(text) / 2);
        free(text);
    }
    expect_fail("truncated json", HD_ERR_FORMAT, "g.json", "JSON");
    write_bytes("g.json", "[1, 2]", 6);
    expect_fail("not an object", HD_ERR_FORMAT, "g.json", NULL);
    const char *empty = "{\"modelTopology\": {\"node\": []}, \"weightsManifest\": []}";
    write_bytes("g.json", empty, strlen(empty));
    expect_fail("no nodes", HD_ERR_FORMAT, "g.json", "node");
    cJSON_Delete(w->root);
    free(w);
}


/* ------------------------------------------------------------------ the upsampling ops */

#define U_H 5
#define U_W 6
#define U_C 3

/* Bilinear resize as a tent filter: out (o) = sum_k in (k) max(0, 1 - |s - k|) along each axis, s
 * the source position of TF's grid (align_corners: o (in - 1) / (out - 1); half_pixel_centers:
 * (o + 0.5) in / out - 0.5; else o in / out), clamped to [0, in - 1]. */
static double tent_pos(int o, int in, int out, int align, int half)
{
    double s = align ? (out > 1 ? (double)o * (in - 1) / (out - 1) : 0) : half ? (o + 0.5) * in / out - 0.5 : (double)o * in / out;
    return s < 0 ? 0 : s > in - 1 ? in - 1 : s;
}

static void ref_resize(const float *x, float *out, int Ho, int Wo, int align, int half)
{
    for (int oy = 0; oy < Ho; oy++)
        for (int ox = 0; ox < Wo; ox++)
            for (int c = 0; c < U_C; c++) {
                const double sy = tent_pos(oy, U_H, Ho, align, half), sx = tent_pos(ox, U_W, Wo, align, half);
                double acc = 0;
                for (int y = 0; y < U_H; y++)
                    for (int xx = 0; xx < U_W; xx++)
                        acc += x[(y * U_W + xx) * U_C + c] * fmax(0, 1 - fabs(sy - y)) * fmax(0, 1 - fabs(sx - xx));
                out[(oy * Wo + ox) * U_C + c] = (float)acc;
            }
}

/* Transposed convolution by scattering: every input pixel adds filter (ky, kx, o, c) x (iy, ix, c) to
 * output (iy s - pad + ky, ix s - pad + kx, o); the filter is (K, K, OC, U_C). */
static void ref_transpose(const float *x, const float *f, int K, int OC, int s, int pad_t, int pad_l, float *out, int Ho,
                          int Wo)
{
    memset(out, 0, (size_t)Ho * Wo * OC * sizeof *out);
    for (int iy = 0; iy < U_H; iy++)
        for (int ix = 0; ix < U_W; ix++)
            for (int ky = 0; ky < K; ky++)
                for (int kx = 0; kx < K; kx++) {
                    const int oy = iy * s - pad_t + ky, ox = ix * s - pad_l + kx;
                    if (oy < 0 || ox < 0 || oy >= Ho || ox >= Wo) continue;
                    for (int o = 0; o < OC; o++)
                        for (int c = 0; c < U_C; c++)
                            out[(oy * Wo + ox) * OC + o] += f[((ky * K + kx) * OC + o) * U_C + c] * x[(iy * U_W + ix) * U_C + c];
                }
}

static float ft1[3 * 3 * 4 * U_C], ft2[3 * 3 * 2 * U_C];


static void attr_b(cJSON *node, const char *key, int value)
{
    cJSON *a = cJSON_AddObjectToObject(cJSON_GetObjectItem(node, "attr"), key);
    cJSON_AddBoolToObject(a, "b", value);
}

/* x (1, 5, 6, 3):
 *   rh = ResizeBilinear(x, [9, 11]) half_pixel_centers; ra = ResizeBilinear(x, [8, 4]) align_corners;
 *   rn = ResizeBilinear(x, [10, 13]) neither;
 *   t1 = Conv2DBackpropInput([1, 9, 11, 4], ft1 3x3x4x3, x) stride 2, SAME (padding 1 at the top and left);
 *   t2 = Conv2DBackpropInput([1, 11, 13, 2], ft2 3x3x2x3, x) stride 2, VALID;
 *   an = AddN(x, Relu(x), Sigmoid(x)). */
static void build_upsampling_graph(model_writer *w)
{
    unsigned s = 11;
    for (size_t i = 0; i < sizeof ft1 / sizeof *ft1; i++) ft1[i] = rnd(&s);
    for (size_t i = 0; i < sizeof ft2 / sizeof *ft2; i++) ft2[i] = rnd(&s);
    mw_init(w);
    placeholder(w, "x", U_H, U_W, U_C);
    int s2[1] = {2}, s4[1] = {4}, sf1[4] = {3, 3, 4, U_C}, sf2[4] = {3, 3, 2, U_C};
    float size_h[2] = {9, 11}, size_a[2] = {8, 4}, size_n[2] = {10, 13}, out1[4] = {1, 9, 11, 4}, out2[4] = {1, 11, 13, 2};
    mw_const(w, "size_h", s2, 1, size_h, WK_I32);
    mw_const(w, "size_a", s2, 1, size_a, WK_I32);
    mw_const(w, "size_n", s2, 1, size_n, WK_I32);
    mw_const(w, "out1", s4, 1, out1, WK_I32);
    mw_const(w, "out2", s4, 1, out2, WK_I32);
    mw_const(w, "ft1", sf1, 4, ft1, WK_F32);
    mw_const(w, "ft2", sf2, 4, ft2, WK_F32);
    cJSON *n = mw_node(w, "rh", "ResizeBilinear", "x", "size_h", NULL, NULL);
    attr_b(n, "half_pixel_centers", 1);
    attr_b(n, "align_corners", 0);
    n = mw_node(w, "ra", "ResizeBilinear", "x", "size_a", NULL, NULL);
    attr_b(n, "align_corners", 1);
    mw_node(w, "rn", "ResizeBilinear", "x", "size_n", NULL, NULL);
    n = mw_node(w, "t1", "Conv2DBackpropInput", "out1", "ft1", "x", NULL);
    attr_window(n, 2, 2, 1, 1, "SAME");
    n = mw_node(w, "t2", "Conv2DBackpropInput", "out2", "ft2", "x", NULL);
    attr_window(n, 2, 2, 1, 1, "VALID");
    mw_node(w, "xr", "Relu", "x", NULL, NULL, NULL);
    mw_node(w, "xs", "Sigmoid", "x", NULL, NULL, NULL);
    mw_node(w, "an", "AddN", "x", "xr", "xs", NULL);
}

static const float *output_of(hd_tfjs_graph *g, const char *name, int h, int wd, int c)
{
    int nd, dims[4];
    const float *o = hd_tfjs_output(g, name, &nd, dims);
    CHECK(o && nd == 4 && dims[0] == 1 && dims[1] == h && dims[2] == wd && dims[3] == c);
    return o && nd == 4 && dims[1] == h && dims[2] == wd && dims[3] == c ? o : NULL;
}

static void test_upsampling_ops(void)
{
    model_writer *w = calloc(1, sizeof *w);
    build_upsampling_graph(w);
    mw_write(w, w->bin_len);
    hd_tfjs_graph *g = NULL;
    hd_status st = hd_tfjs_load("g.json", &g);
    if (st != HD_OK) fprintf(stderr, "load: %s\n", hd_error());
    CHECK(st == HD_OK);
    float x[U_H * U_W * U_C], want[11 * 13 * 4];
    unsigned s = 5;
    for (int i = 0; i < U_H * U_W * U_C; i++) x[i] = rnd(&s);
    if (g) {
        CHECK(hd_tfjs_run(g, x) == HD_OK);
        const float *o;
        if ((o = output_of(g, "rh", 9, 11, U_C))) ref_resize(x, want, 9, 11, 0, 1), check_close("rh", o, want, 9 * 11 * U_C, 1e-5f);
        if ((o = output_of(g, "ra", 8, 4, U_C))) ref_resize(x, want, 8, 4, 1, 0), check_close("ra", o, want, 8 * 4 * U_C, 1e-5f);
        if ((o = output_of(g, "rn", 10, 13, U_C))) ref_resize(x, want, 10, 13, 0, 0), check_close("rn", o, want, 10 * 13 * U_C, 1e-5f);
        /* align_corners keeps the corners exactly */
        if ((o = output_of(g, "ra", 8, 4, U_C)))
            CHECK(o[0] == x[0] && o[(8 * 4 - 1) * U_C + 2] == x[(U_H * U_W - 1) * U_C + 2]);
        if ((o = output_of(g, "t1", 9, 11, 4)))
            ref_transpose(x, ft1, 3, 4, 2, 1, 1, want, 9, 11), check_close("t1", o, want, 9 * 11 * 4, 1e-5f);
        if ((o = output_of(g, "t2", 11, 13, 2)))
            ref_transpose(x, ft2, 3, 2, 2, 0, 0, want, 11, 13), check_close("t2", o, want, 11 * 13 * 2, 1e-5f);
        if ((o = output_of(g, "an", U_H, U_W, U_C))) {
            for (int i = 0; i < U_H * U_W * U_C; i++) want[i] = x[i] + fmaxf(x[i], 0) + 1 / (1 + expf(-x[i]));
            check_close("an", o, want, U_H * U_W * U_C, 1e-6f);
        }
    }
    hd_tfjs_free(g);
    /* refused at load, naming the node: both grids at once, output sizes that do not fit the filter,
     * a window that does not convolve back to the input, AddN of two shapes */
    static const struct {
        const char *node, *attr, *value, *frag;
    } broken[] = {
        {"rh", "align_corners", "b", "align_corners"},
        {"t2", "input0", "out1", "output channels"},
        {"t1", "padding", "VALID", "convolves to"}, /* 9 x 11 convolves to 4 x 5 with VALID, not 5 x 6 */
        {"an", "input0", "rh", "shape"},
    };
    cJSON_Delete(w->root);
    for (size_t k = 0; k < sizeof broken / sizeof broken[0]; k++) {
        build_upsampling_graph(w);
        cJSON *n;
        cJSON_ArrayForEach(n, w->nodes) {
            if (strcmp(cJSON_GetObjectItem(n, "name")->valuestring, broken[k].node) != 0) continue;
            if (strcmp(broken[k].attr, "input0") == 0) {
                edit_node(w, broken[k].node, "input0", broken[k].value);
                break;
            }
            cJSON_DeleteItemFromObject(cJSON_GetObjectItem(n, "attr"), broken[k].attr);
            if (strcmp(broken[k].value, "b") == 0) attr_b(n, broken[k].attr, 1);
            else attr_s(n, broken[k].attr, broken[k].value);
        }
        mw_write(w, w->bin_len);
        char name[64];
        snprintf(name, sizeof name, "'%s'", broken[k].node);
        expect_fail(broken[k].frag, HD_ERR_FORMAT, name, broken[k].frag);
        cJSON_Delete(w->root);
    }
    free(w);
}

/* ------------------------------------------------------------------ the shipped models */

static char *models_dir(void)
{
    static char dir[4300];
    snprintf(dir, sizeof dir, "%s/models", test_source_dir());
    return dir;
}

static void test_face_models(void)
{
    char path[4400];
    const char *dir = models_dir();
    static const struct {
        const char *file, *outputs[4];
        int sizes[4];
    } models[] = {
        {"blazeface-front.json", {"Identity", "Identity_1", "Identity_2", "Identity_3"}, {512, 384, 8192, 6144}},
        {"facemesh.json", {"Identity", "Identity_1", "Identity_2", NULL}, {266, 1, 1404, 0}},
    };
    for (int m = 0; m < 2; m++) {
        snprintf(path, sizeof path, "%s/face-models/%s", dir, models[m].file);
        hd_tfjs_graph *g = NULL;
        hd_status st = hd_tfjs_load(path, &g);
        if (st != HD_OK) fprintf(stderr, "%s\n", hd_error());
        CHECK(st == HD_OK);
        if (!g) continue;
        int h, w, c;
        hd_tfjs_input_shape(g, &h, &w, &c);
        CHECK(c == 3 && h == w && (h == 128 || h == 192));
        float *x = calloc((size_t)h * w * c, sizeof *x);
        CHECK(hd_tfjs_run(g, x) == HD_OK);
        for (int k = 0; k < 4 && models[m].outputs[k]; k++) {
            int nd, dims[4];
            const float *o = hd_tfjs_output(g, models[m].outputs[k], &nd, dims);
            size_t n = 1;
            for (int i = 0; o && i < nd; i++) n *= (size_t)dims[i];
            CHECK(o && n == (size_t)models[m].sizes[k]);
        }
        free(x);
        hd_tfjs_free(g);
    }
}

/* The selfie segmentation network against TensorFlow.js's own CPU backend on the same input
 * (tests/data/segment/london-001-256.png / 255; its output recorded as london-001-256.selfie.png,
 * round(255 p), by tests/reference/record_selfie.js): every pixel within half a level. */
static void test_selfie_reference(void)
{
    char path[4400];
    snprintf(path, sizeof path, "%s/face-models/selfie.json", models_dir());
    hd_tfjs_graph *g = NULL;
    hd_status st = hd_tfjs_load(path, &g);
    if (st != HD_OK) fprintf(stderr, "%s\n", hd_error());
    CHECK(st == HD_OK);
    hd_image in = {0}, ref = {0};
    snprintf(path, sizeof path, "%s/tests/data/segment/london-001-256.png", test_source_dir());
    CHECK(hd_image_read_as(path, 3, &in) == HD_OK && in.width == 256 && in.height == 256);
    snprintf(path, sizeof path, "%s/tests/data/segment/london-001-256.selfie.png", test_source_dir());
    CHECK(hd_image_read_as(path, 1, &ref) == HD_OK && ref.width == 256 && ref.height == 256);
    if (g && in.data && ref.data && in.width == 256 && ref.width == 256) {
        const size_t P = 256 * 256;
        float *x = malloc(P * 3 * sizeof *x);
        for (size_t p = 0; x && p < P; p++)
            for (int c = 0; c < 3; c++) x[3 * p + c] = in.data[c * P + p]; /* planar to NHWC */
        CHECK(x && hd_tfjs_run(g, x) == HD_OK);
        int nd, dims[4];
        const float *o = hd_tfjs_output(g, "activation_10", &nd, dims);
        CHECK(o && nd == 4 && dims[1] == 256 && dims[2] == 256 && dims[3] == 1);
        double worst = 0, person = 0;
        for (size_t p = 0; o && p < P; p++) {
            worst = fmax(worst, fabs(o[p] - ref.data[p]));
            person += o[p] > 0.5f;
        }
        printf("selfie against TF.js: largest difference %.5f (half a level %.5f); person %.1f %% of the crop\n", worst,
               0.5 / 255, 100 * person / P);
        CHECK(worst <= 0.5 / 255 + 1e-4);
        CHECK(person > 0.2 * P && person < 0.8 * P); /* the reference is a person, not a blank */
        free(x);
    }
    hd_image_free(&in), hd_image_free(&ref);
    hd_tfjs_free(g);
}

int main(void)
{
    test_half();
    test_ops();
    test_broken();
    test_upsampling_ops();
    test_face_models();
    test_selfie_reference();
    return test_summary("tfjs_graph");
}
