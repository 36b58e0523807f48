/* tfjs_graph.c: loads a TensorFlow.js graph model (JSON GraphDef + weight shards) and runs it on the
 * CPU. Load does all the checking: the manifest's byte count against the shards, every node's op,
 * attributes, inputs and shapes; a run is then a plain walk over the nodes in topological order,
 * each writing an NHWC float32 buffer in one arena, planned at load so that buffers whose lives do
 * not overlap share memory (Reshape and Identity alias their input).
 *
 * Letters: H, W, C input height, width, channels; Ho, Wo, OC output; KH, KW kernel; sh, sw
 * strides; dh, dw dilations; M depthwise channel multiplier. Filters are TF's HWIO (KH, KW, C, OC)
 * and depthwise filters (KH, KW, C, M). */
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <limits.h>
#include <cjson/cJSON.h>
#include "core/core.h"
#include "graph/tfjs_graph.h"

#define MAX_JSON_BYTES ((size_t)64 << 20)
#define MAX_WEIGHT_BYTES ((size_t)1 << 30)
#define MAX_ELEMENTS ((size_t)1 << 30) /* per tensor: keeps every index inside an int for BLAS */
#define MAX_INPUTS 4
/* Work (multiply-adds) below which a kernel runs on one thread: the face models' layers are small,
 * and waking threads for each of them costs more than it saves on a busy machine. */
#define PARALLEL_WORK ((size_t)8 << 20)

typedef enum op_kind {
    OP_PLACEHOLDER,
    OP_CONST,
    OP_IDENTITY,
    OP_CONV2D,    /* _FusedConv2D, Conv2D */
    OP_DEPTHWISE, /* DepthwiseConv2dNative, FusedDepthwiseConv2dNative */
    OP_ADD,
    OP_SUB,
    OP_MUL,
    OP_PRELU,
    OP_RELU,
    OP_RELU6,
    OP_SIGMOID,
    OP_TANH,
    OP_PAD,
    OP_MAXPOOL,
    OP_AVGPOOL,
    OP_RESHAPE,
    OP_ADDN,
    OP_RESIZE_BILINEAR,
    OP_CONV2D_TRANSPOSE
} op_kind;

static const struct {
    const char *name;
    op_kind kind;
} op_table[] = {
    {"Placeholder", OP_PLACEHOLDER},
    {"Const", OP_CONST},
    {"Identity", OP_IDENTITY},
    {"_FusedConv2D", OP_CONV2D},
    {"Conv2D", OP_CONV2D},
    {"DepthwiseConv2dNative", OP_DEPTHWISE},
    {"FusedDepthwiseConv2dNative", OP_DEPTHWISE},
    {"Add", OP_ADD},
    {"AddV2", OP_ADD},
    {"Sub", OP_SUB},
    {"Mul", OP_MUL},
    {"Prelu", OP_PRELU},
    {"Relu", OP_RELU},
    {"Relu6", OP_RELU6},
    {"Sigmoid", OP_SIGMOID},
    {"Tanh", OP_TANH},
    {"Pad", OP_PAD},
    {"PadV2", OP_PAD},
    {"MaxPool", OP_MAXPOOL},
    {"AvgPool", OP_AVGPOOL},
    {"Reshape", OP_RESHAPE},
    {"AddN", OP_ADDN},
    {"ResizeBilinear", OP_RESIZE_BILINEAR},
    {"Conv2DBackpropInput", OP_CONV2D_TRANSPOSE},
};

typedef enum act_kind { ACT_NONE, ACT_RELU, ACT_RELU6, ACT_PRELU, ACT_LEAKY } act_kind;

typedef struct tg_value {
    int ndim;
    int dims[HD_TFJS_MAX_DIMS];
    size_t size;    /* product of dims */
    float *data;    /* float values (NULL for int32 constants) */
    int32_t *ints;  /* int32 constants only */
} tg_value;

typedef struct tg_node {
    char *name;
    char *op;
    op_kind kind;
    int nin;
    int in[MAX_INPUTS]; /* node indices of the data inputs */
    /* windowed ops (convolutions, pooling) */
    int kh, kw, sh, sw, dh, dw, pad_top, pad_left;
    int has_bias;        /* conv: in[2] is the bias */
    act_kind act;        /* conv: fused activation; PReLU's alpha is in[3] (or in[2] without bias) */
    int alpha_in;        /* index into in[] of the PReLU alpha, or -1 */
    float leaky_alpha;
    float pad_value;     /* PadV2 */
    int align_corners, half_pixel; /* ResizeBilinear */
    int pads[HD_TFJS_MAX_DIMS][2];
    int consumers;       /* how many nodes read this one */
    int is_output;       /* its buffer survives the run (it is, or aliases, a graph output) */
    tg_value out;
} tg_node;

struct hd_tfjs_graph {
    char *path;
    int nnodes;
    tg_node *nodes;
    int *order; /* topological order of all nodes */
    int input;  /* the Placeholder */
    float *weight_floats;
    int32_t *weight_ints;
    hd_arena arena;
    float *col; /* im2col scratch */
    size_t col_size;
};

/* ------------------------------------------------------------------ small helpers */

float hd_half_to_float(uint16_t h)
{
    uint32_t sign = (uint32_t)(h >> 15) << 31, exponent = (h >> 10) & 0x1f, mantissa = h & 0x3ff, bits;
    float v;
    if (exponent == 0) { /* zero or subnormal: m * 2^-24, exact in float */
        v = (float)mantissa * 5.9604644775390625e-08f;
        return sign ? -v : v;
    }
    if (exponent == 31) bits = sign | 0x7f800000u | mantissa << 13;          /* infinity, NaN */
    else bits = sign | (exponent + 127 - 15) << 23 | mantissa << 13;         /* rebias 15 -> 127 */
    memcpy(&v, &bits, sizeof v);
    return v;
}

static char *dup_string(const char *s)
{
    size_t n = strlen(s) + 1;
    char *d = hd_malloc(n);
    if (d) memcpy(d, s, n);
    return d;
}

static uint32_t load_u32le(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* Decodes standard base64 text into out (at most cap - 1 bytes, NUL-terminated); 0 if invalid. */
static int base64_decode(const char *text, char *out, size_t cap)
{
    uint32_t acc = 0;
    int bits = 0;
    size_t n = 0;
    for (const char *p = text; *p && *p != '='; p++) {
        int v;
        if (*p >= 'A' && *p <= 'Z') v = *p - 'A';
        else if (*p >= 'a' && *p <= 'z') v = *p - 'a' + 26;
        else if (*p >= '0' && *p <= '9') v = *p - '0' + 52;
        else if (*p == '+') v = 62;
        else if (*p == '/') v = 63;
        else return 0;
        acc = acc << 6 | (uint32_t)v;
        bits += 6;
        if (bits >= 8) {
            bits -= 8;
            if (n + 1 >= cap) return 0;
            out[n++] = (char)((acc >> bits) & 0xff);
        }
    }
    out[n] = '\0';
    return 1;
}

/* A protobuf-JSON integer: a number or a decimal string. */
static int json_int(const cJSON *item, long long *v)
{
    if (cJSON_IsNumber(item)) {
        double d = item->valuedouble;
        if (d != floor(d) || fabs(d) > 9e15) return 0;
        *v = (long long)d;
        return 1;
    }
    if (cJSON_IsString(item)) {
        char *end;
        *v = strtoll(item->valuestring, &end, 10);
        return end != item->valuestring && *end == '\0';
    }
    return 0;
}

static const cJSON *node_attr(const cJSON *node, const char *key)
{
    return cJSON_GetObjectItemCaseSensitive(cJSON_GetObjectItemCaseSensitive(node, "attr"), key);
}

/* attr {"s": base64} as text; returns 0 if absent or malformed. */
static int attr_string(const cJSON *node, const char *key, char *out, size_t cap)
{
    const cJSON *s = cJSON_GetObjectItemCaseSensitive(node_attr(node, key), "s");
    return cJSON_IsString(s) && base64_decode(s->valuestring, out, cap);
}

/* attr {"list": {"i": [...]}}: returns the count (-1 if absent or malformed), fills up to max. */
static int attr_ints(const cJSON *node, const char *key, long long *out, int max)
{
    const cJSON *a = node_attr(node, key);
    if (!a) return -1;
    const cJSON *list = cJSON_GetObjectItemCaseSensitive(a, "list");
    if (!cJSON_IsObject(list)) return -1;
    const cJSON *i = cJSON_GetObjectItemCaseSensitive(list, "i");
    if (!i) return 0; /* an empty list */
    if (!cJSON_IsArray(i)) return -1;
    int n = 0;
    const cJSON *e;
    cJSON_ArrayForEach(e, i) {
        long long v;
        if (n >= max || !json_int(e, &v)) return -1;
        out[n++] = v;
    }
    return n;
}

static size_t align_floats(size_t n) { return (n + 15) & ~(size_t)15; }

/* ------------------------------------------------------------------ the weights manifest */

typedef enum wtype { W_F32, W_I32, W_F16, W_U8, W_U16 } wtype;

typedef struct wentry {
    const char *name; /* inside the parsed JSON */
    int ndim;
    int dims[HD_TFJS_MAX_DIMS];
    size_t count, offset, bytes; /* offset within its group's concatenated shards */
    int group;
    wtype type;
    float qmin, qscale;
} wentry;

typedef struct manifest {
    int nw, ngroups;
    wentry *w;
    unsigned char **group_data;
    size_t *group_size;
} manifest;

static void manifest_free(manifest *m)
{
    for (int i = 0; i < m->ngroups; i++) free(m->group_data ? m->group_data[i] : NULL);
    free(m->group_data);
    free(m->group_size);
    free(m->w);
    memset(m, 0, sizeof *m);
}

static int parse_shape(const cJSON *shape, int *ndim, int dims[HD_TFJS_MAX_DIMS], size_t *count)
{
    if (!cJSON_IsArray(shape)) return 0;
    int n = cJSON_GetArraySize(shape);
    if (n > HD_TFJS_MAX_DIMS) return 0;
    size_t c = 1;
    int k = 0;
    const cJSON *e;
    cJSON_ArrayForEach(e, shape) {
        long long v;
        if (!json_int(e, &v) || v < 0 || v > INT_MAX) return 0;
        dims[k++] = (int)v;
        if (!hd_mul_size(c, (size_t)v, &c) || c > MAX_ELEMENTS) return 0;
    }
    *ndim = n;
    *count = c;
    return 1;
}

/* One weight of the manifest (entry e, the index-th, in group gi) into w, with the size of one of
 * its stored elements in *elem; the shape's element count is checked against MAX_ELEMENTS. */
static hd_status weight_entry(const cJSON *e, const char *json_path, int index, int gi, wentry *w, size_t *elem_size)
{
    const cJSON *name = cJSON_GetObjectItemCaseSensitive(e, "name");
    const cJSON *dtype = cJSON_GetObjectItemCaseSensitive(e, "dtype");
    const cJSON *quant = cJSON_GetObjectItemCaseSensitive(e, "quantization");
    if (!cJSON_IsString(name) || !cJSON_IsString(dtype))
        return hd_fail(HD_ERR_FORMAT, "%s: weight %d of the manifest has no name or dtype", json_path, index);
    w->name = name->valuestring;
    w->group = gi;
    if (!parse_shape(cJSON_GetObjectItemCaseSensitive(e, "shape"), &w->ndim, w->dims, &w->count))
        return hd_fail(HD_ERR_FORMAT, "%s: weight '%s': shape missing, of rank over %d or too large",
                       json_path, w->name, HD_TFJS_MAX_DIMS);
    size_t elem;
    if (quant) {
        const cJSON *qd = cJSON_GetObjectItemCaseSensitive(quant, "dtype");
        if (strcmp(dtype->valuestring, "float32") != 0 || !cJSON_IsString(qd))
            return hd_fail(HD_ERR_FORMAT, "%s: weight '%s': unsupported quantization", json_path, w->name);
        if (strcmp(qd->valuestring, "float16") == 0) {
            w->type = W_F16;
            elem = 2;
        } else if (strcmp(qd->valuestring, "uint8") == 0 || strcmp(qd->valuestring, "uint16") == 0) {
            const cJSON *qmin = cJSON_GetObjectItemCaseSensitive(quant, "min");
            const cJSON *qscale = cJSON_GetObjectItemCaseSensitive(quant, "scale");
            if (!cJSON_IsNumber(qmin) || !cJSON_IsNumber(qscale))
                return hd_fail(HD_ERR_FORMAT, "%s: weight '%s': quantization without min and scale", json_path, w->name);
            w->type = qd->valuestring[4] == '8' ? W_U8 : W_U16;
            elem = w->type == W_U8 ? 1 : 2;
            w->qmin = (float)qmin->valuedouble;
            w->qscale = (float)qscale->valuedouble;
        } else {
            return hd_fail(HD_ERR_FORMAT, "%s: weight '%s': unsupported quantization dtype '%s'", json_path,
                           w->name, qd->valuestring);
        }
    } else if (strcmp(dtype->valuestring, "float32") == 0) {
        w->type = W_F32;
        elem = 4;
    } else if (strcmp(dtype->valuestring, "int32") == 0) {
        w->type = W_I32;
        elem = 4;
    } else {
        return hd_fail(HD_ERR_FORMAT, "%s: weight '%s': unsupported dtype '%s'", json_path, w->name,
                       dtype->valuestring);
    }
    *elem_size = elem;
    return HD_OK;
}

/* The shards of manifest group g (paths relative to dir), concatenated into *data (malloc'ed,
 * `bytes` long): their total must be exactly what the group's weights need. */
static hd_status read_shards(const cJSON *g, const char *dir, const char *json_path, size_t bytes,
                             unsigned char **data)
{
    *data = NULL;
    const cJSON *paths = cJSON_GetObjectItemCaseSensitive(g, "paths"), *p;
    if (!cJSON_IsArray(paths)) return hd_fail(HD_ERR_FORMAT, "%s: a weightsManifest entry has no paths array", json_path);
    unsigned char *buf = hd_malloc(bytes);
    if (!buf) return HD_ERR_NOMEM;
    hd_status st = HD_OK;
    size_t have = 0;
    cJSON_ArrayForEach(p, paths) {
        if (!cJSON_IsString(p) || strstr(p->valuestring, "..") || p->valuestring[0] == '/') {
            st = hd_fail(HD_ERR_FORMAT, "%s: a shard path is not a plain relative file name", json_path);
            break;
        }
        char *shard_path = hd_path_join(dir, p->valuestring), *got = NULL;
        size_t n;
        st = shard_path ? hd_read_file(shard_path, MAX_WEIGHT_BYTES, &got, &n) : HD_ERR_NOMEM;
        if (st == HD_OK && n > bytes - have)
            st = hd_fail(HD_ERR_FORMAT, "%s: longer than the manifest says (the weights of %s need %zu bytes in all)",
                         shard_path, json_path, bytes);
        if (st == HD_OK) {
            memcpy(buf + have, got, n);
            have += n;
            if (have < bytes && !cJSON_IsString(p->next))
                st = hd_fail(HD_ERR_FORMAT, "%s: truncated: %zu bytes, the weights of %s need %zu", shard_path, have,
                             json_path, bytes);
        }
        free(got);
        free(shard_path);
        if (st != HD_OK) break;
    }
    if (st == HD_OK && have != bytes)
        st = hd_fail(HD_ERR_FORMAT, "%s: the shards hold %zu bytes, the weights need %zu", json_path, have, bytes);
    if (st != HD_OK) {
        free(buf);
        return st;
    }
    *data = buf;
    return HD_OK;
}

/* Reads the manifest and its shards; every size is checked before anything is allocated from it. */
static hd_status manifest_load(manifest *m, const cJSON *root, const char *json_path)
{
    memset(m, 0, sizeof *m);
    const cJSON *groups = cJSON_GetObjectItemCaseSensitive(root, "weightsManifest");
    if (!cJSON_IsArray(groups)) return hd_fail(HD_ERR_FORMAT, "%s: no weightsManifest array", json_path);
    int ng = cJSON_GetArraySize(groups), nw = 0;
    const cJSON *g;
    cJSON_ArrayForEach(g, groups) {
        const cJSON *ws = cJSON_GetObjectItemCaseSensitive(g, "weights");
        if (!cJSON_IsArray(ws)) return hd_fail(HD_ERR_FORMAT, "%s: a weightsManifest entry has no weights array", json_path);
        nw += cJSON_GetArraySize(ws);
    }
    m->w = hd_calloc((size_t)nw + 1, sizeof *m->w);
    m->group_data = hd_calloc((size_t)ng + 1, sizeof *m->group_data);
    m->group_size = hd_calloc((size_t)ng + 1, sizeof *m->group_size);
    if (!m->w || !m->group_data || !m->group_size) {
        manifest_free(m);
        return HD_ERR_NOMEM;
    }
    m->ngroups = ng;
    /* The folder of the JSON: shard paths are relative to it. */
    const char *slash = strrchr(json_path, '/');
    size_t dir_len = slash ? (size_t)(slash - json_path) : 0;
    char *dir = hd_malloc(dir_len + 2);
    if (!dir) {
        manifest_free(m);
        return HD_ERR_NOMEM;
    }
    if (slash) memcpy(dir, json_path, dir_len);
    else dir[dir_len++] = '.';
    dir[dir_len] = '\0';

    hd_status st = HD_OK;
    int gi = 0;
    size_t total = 0;
    cJSON_ArrayForEach(g, groups) {
        size_t offset = 0;
        const cJSON *e;
        cJSON_ArrayForEach(e, cJSON_GetObjectItemCaseSensitive(g, "weights")) {
            wentry *w = &m->w[m->nw];
            size_t elem = 0;
            if ((st = weight_entry(e, json_path, m->nw, gi, w, &elem)) != HD_OK) goto done;
            if (!hd_mul_size(w->count, elem, &w->bytes) || w->bytes > MAX_WEIGHT_BYTES - offset) {
                st = hd_fail(HD_ERR_RANGE, "%s: weights add up to more than %zu bytes", json_path, MAX_WEIGHT_BYTES);
                goto done;
            }
            w->offset = offset;
            offset += w->bytes;
            m->nw++;
        }
        if (offset > MAX_WEIGHT_BYTES - total) {
            st = hd_fail(HD_ERR_RANGE, "%s: weights add up to more than %zu bytes", json_path, MAX_WEIGHT_BYTES);
            goto done;
        }
        total += offset;
        if ((st = read_shards(g, dir, json_path, offset, &m->group_data[gi])) != HD_OK) goto done;
        m->group_size[gi] = offset;
        gi++;
    }
done:
    free(dir);
    if (st != HD_OK) manifest_free(m);
    return st;
}

/* Decodes weight w into floats (or ints for int32). */
static void decode_weight(const manifest *m, const wentry *w, float *f, int32_t *i)
{
    const unsigned char *p = m->group_data[w->group] + w->offset;
    for (size_t k = 0; k < w->count; k++) {
        switch (w->type) {
        case W_F32: {
            uint32_t u = load_u32le(p + 4 * k);
            memcpy(&f[k], &u, 4);
            break;
        }
        case W_I32: i[k] = (int32_t)load_u32le(p + 4 * k); break;
        case W_F16: f[k] = hd_half_to_float((uint16_t)(p[2 * k] | p[2 * k + 1] << 8)); break;
        case W_U8: f[k] = w->qmin + w->qscale * (float)p[k]; break;          /* min + scale * q */
        case W_U16: f[k] = w->qmin + w->qscale * (float)(p[2 * k] | p[2 * k + 1] << 8); break;
        }
    }
}

/* ------------------------------------------------------------------ graph structure */

typedef struct name_index {
    const char *name;
    int index;
} name_index;

static int cmp_name_index(const void *a, const void *b)
{
    return strcmp(((const name_index *)a)->name, ((const name_index *)b)->name);
}

static int find_node(const name_index *sorted, int n, const char *name)
{
    name_index key = {name, 0};
    const name_index *hit = bsearch(&key, sorted, (size_t)n, sizeof key, cmp_name_index);
    return hit ? hit->index : -1;
}

void hd_tfjs_free(hd_tfjs_graph *g)
{
    if (!g) return;
    for (int i = 0; i < g->nnodes; i++) {
        free(g->nodes[i].name);
        free(g->nodes[i].op);
    }
    free(g->nodes);
    free(g->order);
    free(g->weight_floats);
    free(g->weight_ints);
    hd_arena_free(&g->arena);
    free(g->path);
    free(g);
}

#define NODE_FAIL(g, n, ...) node_fail((g), (n), __VA_ARGS__)

static hd_status node_fail(const hd_tfjs_graph *g, const tg_node *n, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
static hd_status node_fail(const hd_tfjs_graph *g, const tg_node *n, const char *fmt, ...)
{
    char what[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    return hd_fail(HD_ERR_FORMAT, "%s: node '%s' (%s): %s", g->path, n->name, n->op, what);
}

static int set_shape(tg_value *v, int ndim, const int *dims)
{
    size_t size = 1;
    for (int i = 0; i < ndim; i++) {
        if (dims[i] < 0 || !hd_mul_size(size, (size_t)dims[i], &size) || size > MAX_ELEMENTS) return 0;
        v->dims[i] = dims[i];
    }
    v->ndim = ndim;
    v->size = size;
    return 1;
}

/* Output size and leading padding of one spatial axis of a windowed op (TF's rules):
 * VALID: out = (in - eff) / s + 1; SAME: out = ceil(in / s), pad = max((out-1) s + eff - in, 0),
 * before = pad / 2; EXPLICIT: out = (in + before + after - eff) / s + 1; eff = (k - 1) d + 1. */
typedef enum pad_kind { PAD_SAME, PAD_VALID, PAD_EXPLICIT } pad_kind;
static int window_axis(int in, int k, int s, int d, pad_kind pk, long long before, long long after, int *out,
                       int *pad_before)
{
    long long eff = (long long)(k - 1) * d + 1;
    long long o, b = 0;
    if (pk == PAD_VALID) o = in >= eff ? (in - eff) / s + 1 : 0;
    else if (pk == PAD_SAME) {
        o = (in + s - 1) / s;
        long long total = (o - 1) * s + eff - in;
        b = total > 0 ? total / 2 : 0;
    } else {
        long long padded = in + before + after;
        o = padded >= eff ? (padded - eff) / s + 1 : 0;
        b = before;
    }
    if (o <= 0 || o > INT_MAX) return 0;
    *out = (int)o;
    *pad_before = (int)b;
    return 1;
}

/* Reads strides, dilations, padding and explicit_paddings of a windowed node and sets
 * out dims (1, Ho, Wo, oc). ksize: the kernel from the filter (conv) or the ksize attr (pool). */
static hd_status setup_window(hd_tfjs_graph *g, tg_node *n, const cJSON *js, const tg_value *x, int kh, int kw, int oc)
{
    long long strides[4], dil[4] = {1, 1, 1, 1}, exp[8] = {0};
    char fmt[32], pad[32];
    if (attr_string(js, "data_format", fmt, sizeof fmt) && strcmp(fmt, "NHWC") != 0)
        return NODE_FAIL(g, n, "data_format %s is not supported (NHWC only)", fmt);
    if (attr_ints(js, "strides", strides, 4) != 4 || strides[0] != 1 || strides[3] != 1 || strides[1] < 1 ||
        strides[2] < 1 || strides[1] > 1024 || strides[2] > 1024)
        return NODE_FAIL(g, n, "strides must be [1, sh, sw, 1]");
    int nd = attr_ints(js, "dilations", dil, 4);
    if (nd != -1 && (nd != 4 || dil[0] != 1 || dil[3] != 1 || dil[1] < 1 || dil[2] < 1 || dil[1] > 1024 || dil[2] > 1024))
        return NODE_FAIL(g, n, "dilations must be [1, dh, dw, 1]");
    if (!attr_string(js, "padding", pad, sizeof pad)) return NODE_FAIL(g, n, "no padding attribute");
    pad_kind pk;
    if (strcmp(pad, "SAME") == 0) pk = PAD_SAME;
    else if (strcmp(pad, "VALID") == 0) pk = PAD_VALID;
    else if (strcmp(pad, "EXPLICIT") == 0) {
        pk = PAD_EXPLICIT;
        if (attr_ints(js, "explicit_paddings", exp, 8) != 8 || exp[0] || exp[1] || exp[6] || exp[7])
            return NODE_FAIL(g, n, "EXPLICIT padding needs 8 explicit_paddings, zero on batch and channels");
        for (int i = 2; i < 6; i++)
            if (exp[i] < 0 || exp[i] > 65536) return NODE_FAIL(g, n, "explicit padding %lld out of range", exp[i]);
    } else return NODE_FAIL(g, n, "padding %s is not supported", pad);
    n->kh = kh;
    n->kw = kw;
    n->sh = (int)strides[1];
    n->sw = (int)strides[2];
    n->dh = (int)dil[1];
    n->dw = (int)dil[2];
    int dims[4] = {1, 0, 0, oc};
    if (!window_axis(x->dims[1], kh, n->sh, n->dh, pk, exp[2], exp[3], &dims[1], &n->pad_top) ||
        !window_axis(x->dims[2], kw, n->sw, n->dw, pk, exp[4], exp[5], &dims[2], &n->pad_left))
        return NODE_FAIL(g, n, "a %dx%d window does not fit the %dx%d input", kh, kw, x->dims[1], x->dims[2]);
    if (!set_shape(&n->out, 4, dims)) return NODE_FAIL(g, n, "output too large");
    return HD_OK;
}

static int is_nhwc1(const tg_value *v) { return v->ndim == 4 && v->dims[0] == 1 && !v->ints; }

/* Shapes the output of broadcasting a and b (numpy rules, right-aligned). */
static int broadcast_shape(const tg_value *a, const tg_value *b, tg_value *out)
{
    int nd = a->ndim > b->ndim ? a->ndim : b->ndim, dims[HD_TFJS_MAX_DIMS];
    for (int i = 0; i < nd; i++) {
        int ia = a->ndim - nd + i, ib = b->ndim - nd + i;
        int da = ia >= 0 ? a->dims[ia] : 1, db = ib >= 0 ? b->dims[ib] : 1;
        if (da != db && da != 1 && db != 1) return 0;
        dims[i] = da == 1 ? db : da;
    }
    return set_shape(out, nd, dims);
}

/* shape_node of a Conv2D or DepthwiseConv2D (x its input): the fused ops (a bias, then Relu, Relu6,
 * Prelu or LeakyRelu), the filter, bias and alpha constants checked against the input, the window
 * and the im2col scratch it needs. */
static hd_status shape_conv(hd_tfjs_graph *g, tg_node *n, const cJSON *js, const tg_value *x)
{
    char ops[4][32];
    int nops = 0;
    const cJSON *fo = cJSON_GetObjectItemCaseSensitive(node_attr(js, "fused_ops"), "list");
    const cJSON *s, *sl = cJSON_GetObjectItemCaseSensitive(fo, "s");
    if (sl) {
        cJSON_ArrayForEach(s, sl) {
            if (nops == 4 || !cJSON_IsString(s) || !base64_decode(s->valuestring, ops[nops], sizeof ops[0]))
                return NODE_FAIL(g, n, "malformed fused_ops");
            nops++;
        }
    }
    int k = 0;
    n->alpha_in = -1;
    n->act = ACT_NONE;
    if (k < nops && strcmp(ops[k], "BiasAdd") == 0) {
        n->has_bias = 1;
        k++;
    }
    if (k < nops) {
        if (strcmp(ops[k], "Relu") == 0) n->act = ACT_RELU;
        else if (strcmp(ops[k], "Relu6") == 0) n->act = ACT_RELU6;
        else if (strcmp(ops[k], "Prelu") == 0) n->act = ACT_PRELU;
        else if (strcmp(ops[k], "LeakyRelu") == 0) {
            n->act = ACT_LEAKY;
            const cJSON *f = cJSON_GetObjectItemCaseSensitive(node_attr(js, "leakyrelu_alpha"), "f");
            n->leaky_alpha = cJSON_IsNumber(f) ? (float)f->valuedouble : 0.2f;
        } else return NODE_FAIL(g, n, "fused op '%s' is not supported", ops[k]);
        k++;
    }
    if (k < nops) return NODE_FAIL(g, n, "fused op '%s' is not supported here", ops[k]);
    int want = 2 + n->has_bias + (n->act == ACT_PRELU);
    if (n->nin != want) return NODE_FAIL(g, n, "expects %d inputs for its fused ops, has %d", want, n->nin);
    if (n->act == ACT_PRELU) n->alpha_in = 2 + n->has_bias;
    if (!is_nhwc1(x)) return NODE_FAIL(g, n, "input must be a float tensor (1, H, W, C)");
    const tg_node *fn = &g->nodes[n->in[1]];
    const tg_value *f = &fn->out;
    if (fn->kind != OP_CONST || f->ndim != 4)
        return NODE_FAIL(g, n, "filter '%s' must be a constant of rank 4", fn->name);
    if (f->dims[2] != x->dims[3])
        return NODE_FAIL(g, n, "filter '%s' has %d input channels, the input has %d", fn->name, f->dims[2], x->dims[3]);
    size_t oc;
    if (!hd_mul_size((size_t)f->dims[2], (size_t)f->dims[3], &oc) || oc > INT_MAX)
        return NODE_FAIL(g, n, "too many output channels");
    if (n->kind == OP_CONV2D) oc = (size_t)f->dims[3];
    for (int i = 2; i < n->nin; i++) {
        const tg_node *p = &g->nodes[n->in[i]];
        if (p->kind != OP_CONST || p->out.size != oc)
            return NODE_FAIL(g, n, "%s '%s' must be a constant of %zu values, has %zu",
                             i == n->alpha_in ? "PReLU alpha" : "bias", p->name, oc, p->out.size);
    }
    if (f->dims[0] < 1 || f->dims[1] < 1 || oc < 1) return NODE_FAIL(g, n, "empty filter");
    hd_status st = setup_window(g, n, js, x, f->dims[0], f->dims[1], (int)oc);
    if (st != HD_OK) return st;
    if (n->kind == OP_CONV2D) {
        size_t kk, col;
        if (!hd_mul3_size((size_t)f->dims[0], (size_t)f->dims[1], (size_t)f->dims[2], &kk) || kk > INT_MAX ||
            !hd_mul3_size((size_t)n->out.dims[1], (size_t)n->out.dims[2], kk, &col) || col > MAX_ELEMENTS)
            return NODE_FAIL(g, n, "convolution too large");
        if (col > g->col_size) g->col_size = col;
    }
    return HD_OK;
}

/* shape_node of a Pad or PadV2: the paddings (and the pad value) constants checked, the padded shape. */
static hd_status shape_pad(hd_tfjs_graph *g, tg_node *n, const tg_value *x)
{
    int want = strcmp(n->op, "PadV2") == 0 ? 3 : 2;
    if (n->nin != want) return NODE_FAIL(g, n, "expects %d inputs, has %d", want, n->nin);
    const tg_node *pn = &g->nodes[n->in[1]];
    if (pn->kind != OP_CONST || pn->out.ndim != 2 || pn->out.dims[0] != x->ndim || pn->out.dims[1] != 2)
        return NODE_FAIL(g, n, "paddings '%s' must be a constant int32 (%d, 2)", pn->name, x->ndim);
    if (want == 3) {
        const tg_node *cv = &g->nodes[n->in[2]];
        if (cv->kind != OP_CONST || cv->out.size != 1) return NODE_FAIL(g, n, "the pad value must be a scalar constant");
        n->pad_value = cv->out.data[0];
    }
    int dims[HD_TFJS_MAX_DIMS];
    for (int i = 0; i < x->ndim; i++) {
        int32_t b = pn->out.ints[2 * i], a = pn->out.ints[2 * i + 1];
        if (b < 0 || a < 0 || (long long)x->dims[i] + b + a > INT_MAX)
            return NODE_FAIL(g, n, "padding (%d, %d) out of range", (int)b, (int)a);
        n->pads[i][0] = b;
        n->pads[i][1] = a;
        dims[i] = x->dims[i] + b + a;
    }
    if (!set_shape(&n->out, x->ndim, dims)) return NODE_FAIL(g, n, "output too large");
    return HD_OK;
}

/* shape_node of a Reshape: the target shape constant, at most one -1 inferred from the size. */
static hd_status shape_reshape(hd_tfjs_graph *g, tg_node *n, const tg_value *x)
{
    if (n->nin != 2) return NODE_FAIL(g, n, "expects 2 inputs, has %d", n->nin);
    const tg_node *sn = &g->nodes[n->in[1]];
    if (sn->kind != OP_CONST || sn->out.ndim != 1 || sn->out.dims[0] > HD_TFJS_MAX_DIMS)
        return NODE_FAIL(g, n, "shape '%s' must be a constant int32 vector of at most %d values", sn->name,
                         HD_TFJS_MAX_DIMS);
    int nd = sn->out.dims[0], dims[HD_TFJS_MAX_DIMS], infer = -1;
    size_t known = 1;
    for (int i = 0; i < nd; i++) {
        int32_t d = sn->out.ints[i];
        if (d == -1 && infer < 0) {
            infer = i;
            dims[i] = 1;
        } else if (d < 0) return NODE_FAIL(g, n, "bad target shape");
        else {
            dims[i] = d;
            if (!hd_mul_size(known, (size_t)d, &known)) return NODE_FAIL(g, n, "bad target shape");
        }
    }
    if (infer >= 0) {
        if (known == 0 || x->size % known || x->size / known > INT_MAX)
            return NODE_FAIL(g, n, "cannot reshape %zu values to the target shape", x->size);
        dims[infer] = (int)(x->size / known);
    }
    if (!set_shape(&n->out, nd, dims) || n->out.size != x->size)
        return NODE_FAIL(g, n, "cannot reshape %zu values to the target shape", x->size);
    return HD_OK;
}

/* attr `key` of a node as a boolean ("b"); absent means 0. */
static int attr_bool(const cJSON *node, const char *key)
{
    return cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(node_attr(node, key), "b"));
}

/* shape_node of a ResizeBilinear: the size constant (new height, width), and which of TF's three
 * sampling grids it asks for (align_corners, half_pixel_centers, or neither; not both). */
static hd_status shape_resize(hd_tfjs_graph *g, tg_node *n, const cJSON *js, const tg_value *x)
{
    if (n->nin != 2) return NODE_FAIL(g, n, "expects 2 inputs, has %d", n->nin);
    if (!is_nhwc1(x)) return NODE_FAIL(g, n, "input must be a float tensor (1, H, W, C)");
    const tg_node *sn = &g->nodes[n->in[1]];
    if (sn->kind != OP_CONST || sn->out.size != 2)
        return NODE_FAIL(g, n, "size '%s' must be a constant int32 (height, width)", sn->name);
    int32_t h = sn->out.ints[0], w = sn->out.ints[1];
    if (h < 1 || w < 1 || h > 65536 || w > 65536) return NODE_FAIL(g, n, "size %d x %d out of range", (int)h, (int)w);
    n->align_corners = attr_bool(js, "align_corners");
    n->half_pixel = attr_bool(js, "half_pixel_centers");
    if (n->align_corners && n->half_pixel)
        return NODE_FAIL(g, n, "align_corners and half_pixel_centers cannot both be set");
    int dims[4] = {1, h, w, x->dims[3]};
    if (!set_shape(&n->out, 4, dims)) return NODE_FAIL(g, n, "output too large");
    return HD_OK;
}

/* shape_node of a Conv2DBackpropInput (a transposed convolution): inputs (output sizes, filter,
 * x). The output is the constant sizes (1, H, W, OC); the filter (KH, KW, OC, C) with C the
 * channels of x; the convolution it transposes must take that output back to x's size. */
static hd_status shape_transpose(hd_tfjs_graph *g, tg_node *n, const cJSON *js)
{
    if (n->nin != 3) return NODE_FAIL(g, n, "expects 3 inputs (sizes, filter, x), has %d", n->nin);
    const tg_node *sn = &g->nodes[n->in[0]], *fn = &g->nodes[n->in[1]];
    const tg_value *x = &g->nodes[n->in[2]].out, *f = &fn->out;
    if (!is_nhwc1(x)) return NODE_FAIL(g, n, "input must be a float tensor (1, H, W, C)");
    if (sn->kind != OP_CONST || sn->out.size != 4)
        return NODE_FAIL(g, n, "sizes '%s' must be a constant int32 of 4 values", sn->name);
    if (fn->kind != OP_CONST || f->ndim != 4) return NODE_FAIL(g, n, "filter '%s' must be a constant of rank 4", fn->name);
    const int32_t *os = sn->out.ints;
    if (os[0] != 1 || os[1] < 1 || os[2] < 1 || os[3] != f->dims[2] || os[1] > 65536 || os[2] > 65536)
        return NODE_FAIL(g, n, "output sizes (%d, %d, %d, %d) do not fit the filter's %d output channels", (int)os[0],
                         (int)os[1], (int)os[2], (int)os[3], f->dims[2]);
    if (f->dims[3] != x->dims[3])
        return NODE_FAIL(g, n, "filter '%s' reads %d channels, the input has %d", fn->name, f->dims[3], x->dims[3]);
    if (f->dims[0] < 1 || f->dims[1] < 1 || f->dims[2] < 1) return NODE_FAIL(g, n, "empty filter");
    /* The forward convolution's window, on a tensor of the output's size. */
    tg_value fwd_in = {0};
    int din[4] = {1, os[1], os[2], x->dims[3]};
    if (!set_shape(&fwd_in, 4, din)) return NODE_FAIL(g, n, "output too large");
    hd_status st = setup_window(g, n, js, &fwd_in, f->dims[0], f->dims[1], x->dims[3]);
    if (st != HD_OK) return st;
    if (n->dh != 1 || n->dw != 1) return NODE_FAIL(g, n, "dilations are not supported here");
    if (n->out.dims[1] != x->dims[1] || n->out.dims[2] != x->dims[2])
        return NODE_FAIL(g, n, "a %d x %d output convolves to %d x %d, not the input's %d x %d", (int)os[1], (int)os[2],
                         n->out.dims[1], n->out.dims[2], x->dims[1], x->dims[2]);
    int dims[4] = {1, os[1], os[2], os[3]};
    if (!set_shape(&n->out, 4, dims)) return NODE_FAIL(g, n, "output too large");
    return HD_OK;
}

/* Infers node n's output shape from its (already shaped) inputs and checks its attributes. */
static hd_status shape_node(hd_tfjs_graph *g, tg_node *n, const cJSON *js)
{
    tg_value *x = n->nin > 0 ? &g->nodes[n->in[0]].out : NULL;
    if (n->nin == 0 && n->kind != OP_PLACEHOLDER && n->kind != OP_CONST) return NODE_FAIL(g, n, "has no input");
    for (int i = 0; i < n->nin; i++) {
        const tg_node *src = &g->nodes[n->in[i]];
        int wants_ints = ((n->kind == OP_PAD || n->kind == OP_RESHAPE || n->kind == OP_RESIZE_BILINEAR) && i == 1) ||
                         (n->kind == OP_CONV2D_TRANSPOSE && i == 0);
        if (wants_ints != (src->out.ints != NULL))
            return NODE_FAIL(g, n, "input %d ('%s') is %s, expected %s", i, src->name, src->out.ints ? "int32" : "float",
                             wants_ints ? "an int32 constant" : "float");
    }
    switch (n->kind) {
    case OP_PLACEHOLDER:
    case OP_CONST: return HD_OK; /* shaped at creation */
    case OP_IDENTITY:
    case OP_RELU:
    case OP_RELU6:
    case OP_SIGMOID:
    case OP_TANH:
        if (n->nin != 1) return NODE_FAIL(g, n, "expects 1 input, has %d", n->nin);
        set_shape(&n->out, x->ndim, x->dims);
        return HD_OK;
    case OP_ADD:
    case OP_SUB:
    case OP_MUL:
    case OP_PRELU:
        if (n->nin != 2) return NODE_FAIL(g, n, "expects 2 inputs, has %d", n->nin);
        if (!broadcast_shape(x, &g->nodes[n->in[1]].out, &n->out))
            return NODE_FAIL(g, n, "input shapes do not broadcast");
        return HD_OK;
    case OP_CONV2D:
    case OP_DEPTHWISE:
        return shape_conv(g, n, js, x);
    case OP_MAXPOOL:
    case OP_AVGPOOL: {
        long long ks[4];
        if (n->nin != 1) return NODE_FAIL(g, n, "expects 1 input, has %d", n->nin);
        if (!is_nhwc1(x)) return NODE_FAIL(g, n, "input must be a float tensor (1, H, W, C)");
        if (attr_ints(js, "ksize", ks, 4) != 4 || ks[0] != 1 || ks[3] != 1 || ks[1] < 1 || ks[2] < 1 || ks[1] > 4096 ||
            ks[2] > 4096)
            return NODE_FAIL(g, n, "ksize must be [1, kh, kw, 1]");
        return setup_window(g, n, js, x, (int)ks[1], (int)ks[2], x->dims[3]);
    }
    case OP_PAD:
        return shape_pad(g, n, x);
    case OP_RESHAPE:
        return shape_reshape(g, n, x);
    case OP_ADDN:
        for (int i = 1; i < n->nin; i++) {
            const tg_value *y = &g->nodes[n->in[i]].out;
            if (y->ndim != x->ndim || memcmp(y->dims, x->dims, (size_t)x->ndim * sizeof *x->dims) != 0)
                return NODE_FAIL(g, n, "input %d's shape differs from input 0's", i);
        }
        set_shape(&n->out, x->ndim, x->dims);
        return HD_OK;
    case OP_RESIZE_BILINEAR:
        return shape_resize(g, n, js, x);
    case OP_CONV2D_TRANSPOSE:
        return shape_transpose(g, n, js);
    }
    return NODE_FAIL(g, n, "unhandled op");
}

/* Reads the Placeholder's shape attr: (-1 or 1, H, W, C). */
static hd_status shape_placeholder(hd_tfjs_graph *g, tg_node *n, const cJSON *js)
{
    const cJSON *dim = cJSON_GetObjectItemCaseSensitive(
        cJSON_GetObjectItemCaseSensitive(node_attr(js, "shape"), "shape"), "dim");
    int dims[4], k = 0;
    const cJSON *d;
    if (!cJSON_IsArray(dim) || cJSON_GetArraySize(dim) != 4)
        return NODE_FAIL(g, n, "the input must have a shape of rank 4 (NHWC)");
    cJSON_ArrayForEach(d, dim) {
        long long v;
        if (!json_int(cJSON_GetObjectItemCaseSensitive(d, "size"), &v)) return NODE_FAIL(g, n, "malformed shape");
        if (k == 0 && v == -1) v = 1;
        if (v < 1 || v > 65536 || (k == 0 && v != 1)) return NODE_FAIL(g, n, "input dimension %d is %lld (batch 1 and known sizes only)", k, v);
        dims[k++] = (int)v;
    }
    if (!set_shape(&n->out, 4, dims)) return NODE_FAIL(g, n, "input too large");
    return HD_OK;
}

/* Places every computing node's output in the arena (Identity and Reshape alias their input):
 * a buffer lives from the step that writes it to the last step that reads it (through aliases),
 * the graph's outputs to the end, and takes the lowest offset free for that whole span, so that
 * buffers whose lives do not overlap share memory. The im2col scratch comes first. */
static size_t buffer_floats(const tg_node *n) { return align_floats(n->out.size ? n->out.size : 1); }

/* Activation caps against the model's declared input size (the Placeholder's floats): no op's
 * output may exceed TG_OP_CAP times it, nor the whole arena TG_ARENA_CAP times it (the shipped
 * face models need at most 2.3x for one op and 15x for the arena, im2col scratch included). A
 * few-KB model cannot make hdnet reserve gigabytes (a Pad of 65536 used to reserve 5.6 GB). */
#define TG_OP_CAP 64
#define TG_ARENA_CAP 256
#define TG_CAP_FLOOR (1u << 16) /* floats always allowed, however small the input */

static size_t capped(size_t input_floats, size_t factor)
{
    size_t base = input_floats > TG_CAP_FLOOR ? input_floats : TG_CAP_FLOOR;
    return base > SIZE_MAX / factor ? SIZE_MAX : base * factor;
}

static hd_status plan_arena(hd_tfjs_graph *g)
{
    int nn = g->nnodes;
    size_t input_floats = g->nodes[g->input].out.size;
    for (int i = 0; i < nn; i++) {
        const tg_node *n = &g->nodes[i];
        if (n->kind != OP_CONST && n->out.size > capped(input_floats, TG_OP_CAP))
            return NODE_FAIL(g, n, "output of %zu floats is more than %d times the model's input (%zu floats)",
                             n->out.size, TG_OP_CAP, input_floats);
    }
    int *owner = hd_malloc((size_t)nn * sizeof *owner), *last = hd_malloc((size_t)nn * sizeof *last);
    size_t *offset = hd_calloc((size_t)nn, sizeof *offset);
    int *live = hd_malloc((size_t)nn * sizeof *live), nlive = 0;
    hd_status st = HD_OK;
    if (!owner || !last || !offset || !live) {
        st = HD_ERR_NOMEM;
        goto done;
    }
    for (int k = 0; k < nn; k++) {
        int i = g->order[k];
        const tg_node *n = &g->nodes[i];
        owner[i] = n->kind == OP_IDENTITY || n->kind == OP_RESHAPE ? owner[n->in[0]] : i;
        last[i] = k;
        for (int j = 0; j < n->nin; j++) {
            int o = owner[n->in[j]];
            if (last[o] < k) last[o] = k;
        }
    }
    for (int i = 0; i < nn; i++)
        if (g->nodes[i].consumers == 0) last[owner[i]] = INT_MAX; /* outputs survive the run */
    size_t base = align_floats(g->col_size), top = base;
    for (int k = 0; k < nn; k++) {
        int i = g->order[k];
        const tg_node *n = &g->nodes[i];
        if (n->kind == OP_CONST || owner[i] != i) continue;
        int keep = 0;
        for (int l = 0; l < nlive; l++)
            if (last[live[l]] >= k) live[keep++] = live[l];
        nlive = keep;
        size_t size = buffer_floats(n), best = SIZE_MAX;
        /* Candidate offsets: the base and the end of each live buffer; keep the lowest that fits. */
        for (int c = -1; c < nlive; c++) {
            size_t at = c < 0 ? base : offset[live[c]] + buffer_floats(&g->nodes[live[c]]);
            if (at >= best) continue;
            int clash = 0;
            for (int l = 0; l < nlive && !clash; l++) {
                size_t lo = offset[live[l]], hi = lo + buffer_floats(&g->nodes[live[l]]);
                clash = at < hi && lo < at + size;
            }
            if (!clash) best = at;
        }
        if (best > SIZE_MAX / sizeof(float) - size) {
            st = hd_fail(HD_ERR_RANGE, "%s: activations too large", g->path);
            goto done;
        }
        offset[i] = best;
        live[nlive++] = i;
        if (best + size > top) top = best + size;
    }
    if (top > capped(input_floats, TG_ARENA_CAP)) {
        st = hd_fail(HD_ERR_RANGE, "%s: the activations need %zu floats, more than %d times the model's input (%zu floats)",
                     g->path, top, TG_ARENA_CAP, input_floats);
        goto done;
    }
    st = hd_arena_init(&g->arena, top * sizeof(float));
    if (st != HD_OK) goto done;
    float *mem = (float *)(void *)g->arena.base;
    g->arena.used = g->arena.size;
    g->col = g->col_size ? mem : NULL;
    for (int k = 0; k < nn; k++) {
        int i = g->order[k];
        tg_node *n = &g->nodes[i];
        if (n->kind == OP_CONST) continue;
        n->out.data = mem + offset[owner[i]];
        n->is_output = last[owner[i]] == INT_MAX;
    }
done:
    free(owner);
    free(last);
    free(offset);
    free(live);
    return st;
}

/* build_graph's inputs of every node (js[i] its JSON, sorted the names for lookup): "name" or
 * "name:0" (control inputs "^name" are ordering hints only and ignored); each counts in its
 * node's indeg and its source's consumers. The one Placeholder becomes g->input. */
static hd_status link_inputs(hd_tfjs_graph *g, const cJSON **js, const name_index *sorted, int *indeg)
{
    g->input = -1;
    const int nn = g->nnodes;
    for (int i = 0; i < nn; i++) {
        tg_node *n = &g->nodes[i];
        const cJSON *in;
        cJSON_ArrayForEach(in, cJSON_GetObjectItemCaseSensitive(js[i], "input")) {
            if (!cJSON_IsString(in)) return NODE_FAIL(g, n, "an input is not a string");
            if (in->valuestring[0] == '^') continue;
            char ref[512];
            snprintf(ref, sizeof ref, "%s", in->valuestring);
            char *colon = strrchr(ref, ':');
            if (colon) {
                if (strcmp(colon, ":0") != 0)
                    return NODE_FAIL(g, n, "input '%s': only the first output of a node is supported", ref);
                *colon = '\0';
            }
            int src = find_node(sorted, nn, ref);
            if (src < 0) return NODE_FAIL(g, n, "input '%s' is not a node of the graph", ref);
            if (n->nin == MAX_INPUTS) return NODE_FAIL(g, n, "more than %d inputs", MAX_INPUTS);
            n->in[n->nin++] = src;
            g->nodes[src].consumers++;
            indeg[i]++;
        }
        if (n->kind == OP_PLACEHOLDER) {
            if (g->input >= 0) return NODE_FAIL(g, n, "a second input (one Placeholder only)");
            g->input = i;
        }
    }
    if (g->input < 0) return hd_fail(HD_ERR_FORMAT, "%s: the graph has no Placeholder input", g->path);
    return HD_OK;
}

/* build_graph's constants: every Const must be a manifest weight, of the shape its node declares;
 * their values decoded into the graph's weight arenas (floats, and int32 apart). */
static hd_status bind_constants(hd_tfjs_graph *g, const cJSON **js, const manifest *m)
{
    const int nn = g->nnodes;
    size_t nfloats = 0, nints = 0;
    for (int i = 0; i < nn; i++) {
        tg_node *n = &g->nodes[i];
        if (n->kind != OP_CONST) continue;
        int w;
        for (w = 0; w < m->nw; w++)
            if (strcmp(m->w[w].name, n->name) == 0) break;
        if (w == m->nw) return NODE_FAIL(g, n, "no weight of this name in the weightsManifest");
        wentry *we = &m->w[w];
        const cJSON *tshape = cJSON_GetObjectItemCaseSensitive(
            cJSON_GetObjectItemCaseSensitive(cJSON_GetObjectItemCaseSensitive(node_attr(js[i], "value"), "tensor"),
                                             "tensorShape"),
            "dim");
        if (tshape) {
            int k = 0, ok = cJSON_IsArray(tshape) && cJSON_GetArraySize(tshape) == we->ndim;
            const cJSON *e;
            cJSON_ArrayForEach(e, tshape) {
                long long v;
                if (!ok || !json_int(cJSON_GetObjectItemCaseSensitive(e, "size"), &v) || v != we->dims[k]) ok = 0;
                k++;
            }
            if (!ok) return NODE_FAIL(g, n, "its declared shape differs from the manifest's");
        }
        set_shape(&n->out, we->ndim, we->dims);
        size_t *count = we->type == W_I32 ? &nints : &nfloats;
        *count += align_floats(we->count);
    }
    g->weight_floats = hd_malloc(nfloats * sizeof(float));
    g->weight_ints = hd_malloc(nints * sizeof(int32_t));
    if (!g->weight_floats || !g->weight_ints) return HD_ERR_NOMEM;
    nfloats = nints = 0;
    for (int i = 0; i < nn; i++) {
        tg_node *n = &g->nodes[i];
        if (n->kind != OP_CONST) continue;
        int w;
        for (w = 0; w < m->nw; w++)
            if (strcmp(m->w[w].name, n->name) == 0) break;
        wentry *we = &m->w[w];
        if (we->type == W_I32) {
            n->out.ints = g->weight_ints + nints;
            nints += align_floats(we->count);
        } else {
            n->out.data = g->weight_floats + nfloats;
            nfloats += align_floats(we->count);
        }
        decode_weight(m, we, n->out.data, n->out.ints);
    }
    return HD_OK;
}

/* Builds nodes from the parsed JSON; on failure the graph is freed by the caller. */
static hd_status build_graph(hd_tfjs_graph *g, const cJSON *root, manifest *m)
{
    const cJSON *topo = cJSON_GetObjectItemCaseSensitive(root, "modelTopology");
    const cJSON *nodes = cJSON_GetObjectItemCaseSensitive(topo, "node");
    if (!cJSON_IsArray(nodes) || cJSON_GetArraySize(nodes) == 0)
        return hd_fail(HD_ERR_FORMAT, "%s: no modelTopology.node array", g->path);
    int nn = cJSON_GetArraySize(nodes);
    g->nodes = hd_calloc((size_t)nn, sizeof *g->nodes);
    g->order = hd_calloc((size_t)nn, sizeof *g->order);
    name_index *sorted = hd_calloc((size_t)nn, sizeof *sorted);
    const cJSON **js = hd_calloc((size_t)nn, sizeof *js);
    int *indeg = hd_calloc((size_t)nn, sizeof *indeg);
    hd_status st = HD_OK;
    if (!g->nodes || !g->order || !sorted || !js || !indeg) {
        st = HD_ERR_NOMEM;
        goto done;
    }
    /* Names and ops. */
    const cJSON *e;
    cJSON_ArrayForEach(e, nodes) {
        tg_node *n = &g->nodes[g->nnodes];
        const cJSON *name = cJSON_GetObjectItemCaseSensitive(e, "name");
        const cJSON *op = cJSON_GetObjectItemCaseSensitive(e, "op");
        if (!cJSON_IsString(name) || !cJSON_IsString(op)) {
            st = hd_fail(HD_ERR_FORMAT, "%s: node %d has no name or op", g->path, g->nnodes);
            goto done;
        }
        n->name = dup_string(name->valuestring);
        n->op = dup_string(op->valuestring);
        if (!n->name || !n->op) {
            st = HD_ERR_NOMEM;
            goto done;
        }
        js[g->nnodes] = e;
        sorted[g->nnodes].name = n->name;
        sorted[g->nnodes].index = g->nnodes;
        g->nnodes++;
        size_t k;
        for (k = 0; k < sizeof op_table / sizeof op_table[0]; k++)
            if (strcmp(op_table[k].name, n->op) == 0) break;
        if (k == sizeof op_table / sizeof op_table[0]) {
            st = NODE_FAIL(g, n, "unsupported op");
            goto done;
        }
        n->kind = op_table[k].kind;
    }
    qsort(sorted, (size_t)nn, sizeof *sorted, cmp_name_index);
    for (int i = 1; i < nn; i++)
        if (strcmp(sorted[i - 1].name, sorted[i].name) == 0) {
            st = hd_fail(HD_ERR_FORMAT, "%s: two nodes are called '%s'", g->path, sorted[i].name);
            goto done;
        }
    if ((st = link_inputs(g, js, sorted, indeg)) != HD_OK || (st = bind_constants(g, js, m)) != HD_OK) goto done;
    /* Topological order (Kahn): a node runs after all its inputs; a cycle is an error. */
    int head = 0, tail = 0;
    for (int i = 0; i < nn; i++)
        if (indeg[i] == 0) g->order[tail++] = i;
    while (head < tail) {
        int u = g->order[head++];
        for (int i = 0; i < nn; i++)
            for (int k = 0; k < g->nodes[i].nin; k++)
                if (g->nodes[i].in[k] == u && --indeg[i] == 0) g->order[tail++] = i;
    }
    if (tail != nn) {
        for (int i = 0; i < nn; i++)
            if (indeg[i] > 0) {
                st = NODE_FAIL(g, &g->nodes[i], "part of a cycle");
                goto done;
            }
    }
    /* Shapes, in order. */
    for (int k = 0; k < nn; k++) {
        int i = g->order[k];
        tg_node *n = &g->nodes[i];
        st = n->kind == OP_PLACEHOLDER ? shape_placeholder(g, n, js[i]) : shape_node(g, n, js[i]);
        if (st != HD_OK) goto done;
    }
    st = plan_arena(g);
done:
    free(sorted);
    free(js);
    free(indeg);
    return st;
}

hd_status hd_tfjs_load(const char *json_path, hd_tfjs_graph **graph)
{
    *graph = NULL;
    char *text;
    size_t len;
    hd_status st = hd_read_file(json_path, MAX_JSON_BYTES, &text, &len);
    if (st != HD_OK) return st;
    cJSON *root = cJSON_ParseWithLength(text, len);
    free(text);
    if (!root) return hd_fail(HD_ERR_FORMAT, "%s: not valid JSON", json_path);
    hd_tfjs_graph *g = hd_calloc(1, sizeof *g);
    manifest m;
    memset(&m, 0, sizeof m);
    if (!g || !(g->path = dup_string(json_path))) {
        st = HD_ERR_NOMEM;
        goto fail;
    }
    if (!cJSON_IsObject(root)) {
        st = hd_fail(HD_ERR_FORMAT, "%s: not a TF.js graph model (the top level is not an object)", json_path);
        goto fail;
    }
    const cJSON *format = cJSON_GetObjectItemCaseSensitive(root, "format");
    if (cJSON_IsString(format) && strcmp(format->valuestring, "graph-model") != 0) {
        st = hd_fail(HD_ERR_FORMAT, "%s: format '%s' is not a TF.js graph-model", json_path, format->valuestring);
        goto fail;
    }
    st = manifest_load(&m, root, json_path);
    if (st != HD_OK) goto fail;
    st = build_graph(g, root, &m);
    if (st != HD_OK) goto fail;
    manifest_free(&m);
    cJSON_Delete(root);
    *graph = g;
    return HD_OK;
fail:
    manifest_free(&m);
    cJSON_Delete(root);
    hd_tfjs_free(g);
    return st;
}

void hd_tfjs_input_shape(const hd_tfjs_graph *g, int *height, int *width, int *channels)
{
    const tg_value *v = &g->nodes[g->input].out;
    *height = v->dims[1];
    *width = v->dims[2];
    *channels = v->dims[3];
}

/* ------------------------------------------------------------------ kernels */

/* out (P, OC) += bias, then the activation: relu max(x, 0); relu6 min(max(x, 0), 6);
 * prelu x >= 0 ? x : alpha_c x; leaky x >= 0 ? x : a x. */
/* The activations both the fused convolutions and the unary ops apply. */
static inline float relu(float v) { return v > 0.0f ? v : 0.0f; }
static inline float relu6(float v) { return v > 0.0f ? (v < 6.0f ? v : 6.0f) : 0.0f; }

static void bias_act(float *out, size_t P, int OC, const float *bias, act_kind act, const float *alpha, float leaky)
{
    for (long p = 0; p < (long)P; p++) {
        float *o = out + (size_t)p * OC;
        if (bias)
            for (int c = 0; c < OC; c++) o[c] += bias[c];
        switch (act) {
        case ACT_NONE: break;
        case ACT_RELU:
            for (int c = 0; c < OC; c++) o[c] = relu(o[c]);
            break;
        case ACT_RELU6:
            for (int c = 0; c < OC; c++) o[c] = relu6(o[c]);
            break;
        case ACT_PRELU:
            for (int c = 0; c < OC; c++) o[c] = o[c] >= 0.0f ? o[c] : alpha[c] * o[c];
            break;
        case ACT_LEAKY:
            for (int c = 0; c < OC; c++) o[c] = o[c] >= 0.0f ? o[c] : leaky * o[c];
            break;
        }
    }
}

static const float *input_data(const hd_tfjs_graph *g, const tg_node *n, int i)
{
    return g->nodes[n->in[i]].out.data;
}

/* out (P, N) = a (P, K) . w (K, N), by tiles of 4 rows x 16 columns kept in registers over the whole
 * K loop. Our own loop rather than BLAS: these products are small (N <= 1404, K <= 800), and BLAS's
 * worker threads waking and yielding for each of them cost more than the arithmetic. */
#define TILE_P 4
#define TILE_N 16
static void matmul(float *restrict out, const float *restrict a, const float *restrict w, int P, int K, int N)
{
#pragma omp parallel for schedule(static) if ((size_t)P * K * N > PARALLEL_WORK)
    for (int p0 = 0; p0 < P; p0 += TILE_P) {
        int rows = P - p0 < TILE_P ? P - p0 : TILE_P;
        for (int n0 = 0; n0 < N; n0 += TILE_N) {
            int cols = N - n0 < TILE_N ? N - n0 : TILE_N;
            float acc[TILE_P][TILE_N] = {{0}};
            if (rows == TILE_P && cols == TILE_N) {
                const float *a0 = a + (size_t)p0 * K;
                for (int k = 0; k < K; k++) {
                    const float *wk = w + (size_t)k * N + n0;
                    float v0 = a0[k], v1 = a0[K + k], v2 = a0[2 * K + k], v3 = a0[3 * K + k];
                    for (int j = 0; j < TILE_N; j++) {
                        acc[0][j] += v0 * wk[j];
                        acc[1][j] += v1 * wk[j];
                        acc[2][j] += v2 * wk[j];
                        acc[3][j] += v3 * wk[j];
                    }
                }
            } else {
                for (int r = 0; r < rows; r++) {
                    const float *ar = a + (size_t)(p0 + r) * K;
                    for (int k = 0; k < K; k++) {
                        const float *wk = w + (size_t)k * N + n0;
                        for (int j = 0; j < cols; j++) acc[r][j] += ar[k] * wk[j];
                    }
                }
            }
            for (int r = 0; r < rows; r++) memcpy(out + (size_t)(p0 + r) * N + n0, acc[r], (size_t)cols * sizeof(float));
        }
    }
}

/* Convolution as im2col + matmul: out (Ho Wo, OC) = col (Ho Wo, KH KW C) . filter (KH KW C, OC),
 * where col holds the input patch of each output pixel (zeros where the window leaves the input). */
static void run_conv(hd_tfjs_graph *g, tg_node *n)
{
    const tg_value *x = &g->nodes[n->in[0]].out;
    int H = x->dims[1], W = x->dims[2], C = x->dims[3];
    int Ho = n->out.dims[1], Wo = n->out.dims[2], OC = n->out.dims[3];
    int K = n->kh * n->kw * C;
    const float *a = x->data;
    if (!(n->kh == 1 && n->kw == 1 && n->sh == 1 && n->sw == 1 && n->pad_top == 0 && n->pad_left == 0 && Ho == H && Wo == W)) {
        float *col = g->col;
#pragma omp parallel for schedule(static) if ((size_t)Ho * Wo * K > PARALLEL_WORK)
        for (int oy = 0; oy < Ho; oy++)
            for (int ox = 0; ox < Wo; ox++) {
                float *row = col + ((size_t)oy * Wo + ox) * K;
                for (int ky = 0; ky < n->kh; ky++) {
                    int iy = oy * n->sh - n->pad_top + ky * n->dh;
                    for (int kx = 0; kx < n->kw; kx++) {
                        int ix = ox * n->sw - n->pad_left + kx * n->dw;
                        float *dst = row + ((size_t)ky * n->kw + kx) * C;
                        if (iy < 0 || iy >= H || ix < 0 || ix >= W) memset(dst, 0, (size_t)C * sizeof *dst);
                        else memcpy(dst, x->data + ((size_t)iy * W + ix) * C, (size_t)C * sizeof *dst);
                    }
                }
            }
        a = col;
    }
    matmul(n->out.data, a, input_data(g, n, 1), Ho * Wo, K, OC);
    bias_act(n->out.data, (size_t)Ho * Wo, OC, n->has_bias ? input_data(g, n, 2) : NULL, n->act,
             n->alpha_in >= 0 ? input_data(g, n, n->alpha_in) : NULL, n->leaky_alpha);
}

/* Depthwise convolution: out (y, x, c M + m) = sum_{ky, kx} in (y sh - pt + ky dh, x sw - pl + kx dw, c)
 * filter (ky, kx, c, m). */
static void run_depthwise(hd_tfjs_graph *g, tg_node *n)
{
    const tg_value *x = &g->nodes[n->in[0]].out;
    const float *w = input_data(g, n, 1);
    int H = x->dims[1], W = x->dims[2], C = x->dims[3];
    int Ho = n->out.dims[1], Wo = n->out.dims[2], OC = n->out.dims[3], M = OC / C;
#pragma omp parallel for schedule(static) if ((size_t)Ho * Wo * OC * n->kh * n->kw > PARALLEL_WORK)
    for (int oy = 0; oy < Ho; oy++)
        for (int ox = 0; ox < Wo; ox++) {
            float *o = n->out.data + ((size_t)oy * Wo + ox) * OC;
            memset(o, 0, (size_t)OC * sizeof *o);
            for (int ky = 0; ky < n->kh; ky++) {
                int iy = oy * n->sh - n->pad_top + ky * n->dh;
                if (iy < 0 || iy >= H) continue;
                for (int kx = 0; kx < n->kw; kx++) {
                    int ix = ox * n->sw - n->pad_left + kx * n->dw;
                    if (ix < 0 || ix >= W) continue;
                    const float *xi = x->data + ((size_t)iy * W + ix) * C;
                    const float *wk = w + ((size_t)ky * n->kw + kx) * OC;
                    if (M == 1)
                        for (int c = 0; c < C; c++) o[c] += xi[c] * wk[c];
                    else
                        for (int c = 0; c < C; c++)
                            for (int m = 0; m < M; m++) o[c * M + m] += xi[c] * wk[c * M + m];
                }
            }
        }
    bias_act(n->out.data, (size_t)Ho * Wo, OC, n->has_bias ? input_data(g, n, 2) : NULL, n->act,
             n->alpha_in >= 0 ? input_data(g, n, n->alpha_in) : NULL, n->leaky_alpha);
}

/* Max or average over each window's positions inside the input (padding never counts). */
static void run_pool(hd_tfjs_graph *g, tg_node *n)
{
    const tg_value *x = &g->nodes[n->in[0]].out;
    int H = x->dims[1], W = x->dims[2], C = x->dims[3];
    int Ho = n->out.dims[1], Wo = n->out.dims[2];
    int is_max = n->kind == OP_MAXPOOL;
#pragma omp parallel for schedule(static) if ((size_t)Ho * Wo * C * n->kh * n->kw > PARALLEL_WORK)
    for (int oy = 0; oy < Ho; oy++)
        for (int ox = 0; ox < Wo; ox++) {
            float *o = n->out.data + ((size_t)oy * Wo + ox) * C;
            int count = 0;
            for (int c = 0; c < C; c++) o[c] = is_max ? -INFINITY : 0.0f;
            for (int ky = 0; ky < n->kh; ky++) {
                int iy = oy * n->sh - n->pad_top + ky * n->dh;
                if (iy < 0 || iy >= H) continue;
                for (int kx = 0; kx < n->kw; kx++) {
                    int ix = ox * n->sw - n->pad_left + kx * n->dw;
                    if (ix < 0 || ix >= W) continue;
                    const float *xi = x->data + ((size_t)iy * W + ix) * C;
                    count++;
                    if (is_max)
                        for (int c = 0; c < C; c++) o[c] = xi[c] > o[c] ? xi[c] : o[c];
                    else
                        for (int c = 0; c < C; c++) o[c] += xi[c];
                }
            }
            if (!is_max && count > 0)
                for (int c = 0; c < C; c++) o[c] /= (float)count;
        }
}

/* Dims right-aligned to rank 4, with the element strides of v (0 along broadcast axes). */
static void strides4(const tg_value *v, const tg_value *out, size_t st[4])
{
    size_t s = 1;
    for (int i = 3; i >= 0; i--) {
        int k = v->ndim - 4 + i, ko = out->ndim - 4 + i;
        int d = k >= 0 ? v->dims[k] : 1, dout = ko >= 0 ? out->dims[ko] : 1;
        st[i] = d == 1 && dout != 1 ? 0 : s;
        s *= (size_t)d;
    }
}

/* out = a (op) b with numpy broadcasting; prelu: a >= 0 ? a : b a. */
static void run_binary(hd_tfjs_graph *g, tg_node *n)
{
    const tg_value *a = &g->nodes[n->in[0]].out, *b = &g->nodes[n->in[1]].out;
    size_t sa[4], sb[4];
    int d[4];
    strides4(a, &n->out, sa);
    strides4(b, &n->out, sb);
    for (int i = 0; i < 4; i++) d[i] = n->out.ndim - 4 + i >= 0 ? n->out.dims[n->out.ndim - 4 + i] : 1;
    float *o = n->out.data;
    for (int i0 = 0; i0 < d[0]; i0++)
        for (int i1 = 0; i1 < d[1]; i1++)
#pragma omp parallel for schedule(static) if ((size_t)d[2] * d[3] > PARALLEL_WORK)
            for (int i2 = 0; i2 < d[2]; i2++) {
                const float *pa = a->data + i0 * sa[0] + i1 * sa[1] + i2 * sa[2];
                const float *pb = b->data + i0 * sb[0] + i1 * sb[1] + i2 * sb[2];
                float *po = o + (((size_t)i0 * d[1] + i1) * d[2] + i2) * d[3];
                size_t s3a = sa[3], s3b = sb[3];
                switch (n->kind) {
                case OP_ADD:
                    for (int i3 = 0; i3 < d[3]; i3++) po[i3] = pa[i3 * s3a] + pb[i3 * s3b];
                    break;
                case OP_SUB:
                    for (int i3 = 0; i3 < d[3]; i3++) po[i3] = pa[i3 * s3a] - pb[i3 * s3b];
                    break;
                case OP_MUL:
                    for (int i3 = 0; i3 < d[3]; i3++) po[i3] = pa[i3 * s3a] * pb[i3 * s3b];
                    break;
                default: /* OP_PRELU */
                    for (int i3 = 0; i3 < d[3]; i3++) {
                        float v = pa[i3 * s3a];
                        po[i3] = v >= 0.0f ? v : pb[i3 * s3b] * v;
                    }
                    break;
                }
            }
}

static void run_unary(hd_tfjs_graph *g, tg_node *n)
{
    const float *x = input_data(g, n, 0);
    float *o = n->out.data;
    size_t N = n->out.size;
    switch (n->kind) {
    case OP_RELU:
        for (size_t i = 0; i < N; i++) o[i] = relu(x[i]);
        break;
    case OP_RELU6:
        for (size_t i = 0; i < N; i++) o[i] = relu6(x[i]);
        break;
    case OP_SIGMOID:
        for (size_t i = 0; i < N; i++) o[i] = 1.0f / (1.0f + expf(-x[i])); /* 1 / (1 + e^-x) */
        break;
    default: /* OP_TANH */
        for (size_t i = 0; i < N; i++) o[i] = tanhf(x[i]);
        break;
    }
}

/* Constant padding: out[i + before] = in[i], the rest pad_value. */
static void run_pad(hd_tfjs_graph *g, tg_node *n)
{
    const tg_value *x = &g->nodes[n->in[0]].out;
    int off = 4 - x->ndim, di[4], dout[4], before[4];
    for (int i = 0; i < 4; i++) {
        int k = i - off;
        di[i] = k >= 0 ? x->dims[k] : 1;
        dout[i] = k >= 0 ? n->out.dims[k] : 1;
        before[i] = k >= 0 ? n->pads[k][0] : 0;
    }
    float *o = n->out.data;
    for (size_t i = 0; i < n->out.size; i++) o[i] = n->pad_value;
    for (int i0 = 0; i0 < di[0]; i0++)
        for (int i1 = 0; i1 < di[1]; i1++)
            for (int i2 = 0; i2 < di[2]; i2++) {
                size_t src = (((size_t)i0 * di[1] + i1) * di[2] + i2) * di[3];
                size_t dst = ((((size_t)(i0 + before[0]) * dout[1] + i1 + before[1]) * dout[2] + i2 + before[2]) * dout[3]) +
                             before[3];
                memcpy(o + dst, x->data + src, (size_t)di[3] * sizeof *o);
            }
}

/* out = the sum of the inputs (all of one shape). */
static void run_addn(hd_tfjs_graph *g, tg_node *n)
{
    float *o = n->out.data;
    memcpy(o, input_data(g, n, 0), n->out.size * sizeof *o);
    for (int i = 1; i < n->nin; i++) {
        const float *x = input_data(g, n, i);
        for (size_t k = 0; k < n->out.size; k++) o[k] += x[k];
    }
}

/* One axis of a bilinear resize: output position o reads the input between lo and hi with weight
 * t on hi. TF's grids: align_corners maps the first and last samples onto each other (scale
 * (in - 1) / (out - 1)); half_pixel_centers maps pixel centres (o + 0.5) scale - 0.5; otherwise
 * o scale, with scale in / out. Positions before the first sample read it. */
static void resize_axis(int o, int in, int out, int align_corners, int half_pixel, int *lo, int *hi, float *t)
{
    double scale = align_corners && out > 1 ? (double)(in - 1) / (out - 1) : (double)in / out;
    double src = half_pixel ? (o + 0.5) * scale - 0.5 : o * scale;
    if (src < 0) src = 0;
    int f = (int)floor(src);
    if (f > in - 1) f = in - 1;
    *lo = f;
    *hi = f + 1 < in ? f + 1 : in - 1;
    *t = (float)(src - f);
    if (*hi == *lo) *t = 0.0f;
}

static void run_resize(hd_tfjs_graph *g, tg_node *n)
{
    const tg_value *x = &g->nodes[n->in[0]].out;
    int H = x->dims[1], W = x->dims[2], C = x->dims[3], Ho = n->out.dims[1], Wo = n->out.dims[2];
#pragma omp parallel for schedule(static) if ((size_t)Ho * Wo * C > PARALLEL_WORK)
    for (int oy = 0; oy < Ho; oy++) {
        int y0, y1;
        float ty;
        resize_axis(oy, H, Ho, n->align_corners, n->half_pixel, &y0, &y1, &ty);
        for (int ox = 0; ox < Wo; ox++) {
            int x0, x1;
            float tx;
            resize_axis(ox, W, Wo, n->align_corners, n->half_pixel, &x0, &x1, &tx);
            const float *a = x->data + ((size_t)y0 * W + x0) * C, *b = x->data + ((size_t)y0 * W + x1) * C;
            const float *c = x->data + ((size_t)y1 * W + x0) * C, *d = x->data + ((size_t)y1 * W + x1) * C;
            float *o = n->out.data + ((size_t)oy * Wo + ox) * C;
            for (int k = 0; k < C; k++) {
                float top = a[k] + (b[k] - a[k]) * tx, bottom = c[k] + (d[k] - c[k]) * tx;
                o[k] = top + (bottom - top) * ty;
            }
        }
    }
}

/* Transposed convolution (the gradient of a convolution with respect to its input): each output
 * pixel (y, x) gathers input pixels (iy, ix) with iy sh - pt + ky = y, ix sw - pl + kx = x:
 * out (y, x, o) = sum x (iy, ix, c) filter (ky, kx, o, c). */
static void run_transpose(hd_tfjs_graph *g, tg_node *n)
{
    const tg_value *x = &g->nodes[n->in[2]].out;
    const float *w = input_data(g, n, 1);
    int H = x->dims[1], W = x->dims[2], C = x->dims[3];
    int Ho = n->out.dims[1], Wo = n->out.dims[2], OC = n->out.dims[3];
#pragma omp parallel for schedule(static) if ((size_t)Ho * Wo * OC * C > PARALLEL_WORK)
    for (int oy = 0; oy < Ho; oy++)
        for (int ox = 0; ox < Wo; ox++) {
            float *o = n->out.data + ((size_t)oy * Wo + ox) * OC;
            memset(o, 0, (size_t)OC * sizeof *o);
            for (int ky = 0; ky < n->kh; ky++) {
                int ty = oy + n->pad_top - ky;
                if (ty < 0 || ty % n->sh || ty / n->sh >= H) continue;
                for (int kx = 0; kx < n->kw; kx++) {
                    int tx = ox + n->pad_left - kx;
                    if (tx < 0 || tx % n->sw || tx / n->sw >= W) continue;
                    const float *xi = x->data + ((size_t)(ty / n->sh) * W + tx / n->sw) * C;
                    const float *wk = w + ((size_t)ky * n->kw + kx) * OC * C;
                    for (int k = 0; k < OC; k++) {
                        float acc = 0.0f;
                        for (int c = 0; c < C; c++) acc += xi[c] * wk[(size_t)k * C + c];
                        o[k] += acc;
                    }
                }
            }
        }
}

hd_status hd_tfjs_run(hd_tfjs_graph *g, const float *input)
{
    tg_node *in = &g->nodes[g->input];
    memcpy(in->out.data, input, in->out.size * sizeof(float));
    for (int k = 0; k < g->nnodes; k++) {
        tg_node *n = &g->nodes[g->order[k]];
        switch (n->kind) {
        case OP_PLACEHOLDER:
        case OP_CONST:
        case OP_IDENTITY:
        case OP_RESHAPE: break;
        case OP_CONV2D: run_conv(g, n); break;
        case OP_DEPTHWISE: run_depthwise(g, n); break;
        case OP_MAXPOOL:
        case OP_AVGPOOL: run_pool(g, n); break;
        case OP_ADD:
        case OP_SUB:
        case OP_MUL:
        case OP_PRELU: run_binary(g, n); break;
        case OP_RELU:
        case OP_RELU6:
        case OP_SIGMOID:
        case OP_TANH: run_unary(g, n); break;
        case OP_PAD: run_pad(g, n); break;
        case OP_ADDN: run_addn(g, n); break;
        case OP_RESIZE_BILINEAR: run_resize(g, n); break;
        case OP_CONV2D_TRANSPOSE: run_transpose(g, n); break;
        }
    }
    /* The graph's outputs (nodes nobody reads) must be finite. */
    for (int i = 0; i < g->nnodes; i++) {
        const tg_node *n = &g->nodes[i];
        if (n->consumers || n->kind == OP_CONST || !n->out.data) continue;
        for (size_t k = 0; k < n->out.size; k++)
            if (!isfinite(n->out.data[k]))
                return hd_fail(HD_ERR_NUMERIC, "%s: output '%s' has a non-finite value at %zu", g->path, n->name, k);
    }
    return HD_OK;
}

const float *hd_tfjs_output(const hd_tfjs_graph *g, const char *name, int *ndim, int dims[HD_TFJS_MAX_DIMS])
{
    size_t len = strlen(name);
    if (len >= 2 && strcmp(name + len - 2, ":0") == 0) len -= 2;
    for (int i = 0; i < g->nnodes; i++) {
        const tg_node *n = &g->nodes[i];
        if (strlen(n->name) == len && strncmp(n->name, name, len) == 0 && n->out.data) {
            if (!n->is_output) {
                hd_fail(HD_ERR_NOTFOUND, "%s: '%s' is not an output of the graph (its buffer is reused)", g->path, name);
                return NULL;
            }
            if (ndim) *ndim = n->out.ndim;
            if (dims)
                for (int k = 0; k < n->out.ndim; k++) dims[k] = n->out.dims[k];
            return n->out.data;
        }
    }
    hd_fail(HD_ERR_NOTFOUND, "%s: no float node called '%s'", g->path, name);
    return NULL;
}
