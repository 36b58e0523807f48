/* safetensors.c: checkpoints and models (SPEC section 6). A file is an 8-byte little-endian
 * header length N, N bytes of JSON
 *     {"NAME": {"dtype": "F32", "shape": [...], "data_offsets": [BEGIN, END]}, ...,
 *      "__metadata__": {"key": "value", ...}}
 * and then the data buffer, offsets relative to its start. The reader checks the whole header
 * (types, shapes, byte counts, bounds, overlaps, duplicate names) against the file size before it
 * reads any tensor data; the writer emits tensors contiguously in the given order, pads the header
 * with spaces to a multiple of 8 and writes atomically. Host byte order is assumed little-endian
 * for the float data (checked at run time), the header length is encoded explicitly. */
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <cjson/cJSON.h>
#include "core/core.h"
#include "io/safetensors.h"

#define ST_MAX_HEADER ((uint64_t)100 * 1024 * 1024)
#define ST_MAX_COUNT 1000000

/* What hd_safetensors.storage points at: everything the reader allocated. */
typedef struct st_storage {
    float *data;   /* all tensors, one block */
    char *strings; /* names, metadata keys and values, NUL-terminated, one block */
} st_storage;

typedef struct st_entry {
    const char *name;
    uint64_t begin, end;
} st_entry;

static int host_little_endian(void)
{
    const uint16_t one = 1;
    return *(const unsigned char *)&one == 1;
}

static int entry_by_begin(const void *a, const void *b)
{
    const st_entry *x = a, *y = b;
    if (x->begin != y->begin) return x->begin < y->begin ? -1 : 1;
    return x->end < y->end ? -1 : x->end > y->end;
}

static int string_ptr_cmp(const void *a, const void *b)
{
    return strcmp(*(const char *const *)a, *(const char *const *)b);
}

/* A JSON number that is an integer in [0, 2^53]; 1 with *out set, else 0. */
static int json_uint(const cJSON *item, uint64_t *out)
{
    if (!cJSON_IsNumber(item)) return 0;
    double v = item->valuedouble;
    if (!(v >= 0) || v > 9007199254740992.0 || v != floor(v)) return 0;
    *out = (uint64_t)v;
    return 1;
}

void hd_safetensors_free(hd_safetensors *st)
{
    if (!st) return;
    st_storage *s = st->storage;
    if (s) {
        free(s->data);
        free(s->strings);
        free(s);
    }
    free(st->tensors);
    free(st->meta_keys);
    free(st->meta_values);
    memset(st, 0, sizeof *st);
}

/* Validates one tensor entry of the header; fills t (name left NULL) and e. */
static hd_status parse_tensor(const char *path, const cJSON *item, uint64_t data_size, hd_tensor *t,
                              st_entry *e, size_t *floats)
{
    const char *name = item->string;
    if (!cJSON_IsObject(item))
        return hd_fail(HD_ERR_FORMAT, "%s: tensor '%s': header entry is not an object", path, name);
    const cJSON *dtype = cJSON_GetObjectItemCaseSensitive(item, "dtype");
    const cJSON *shape = cJSON_GetObjectItemCaseSensitive(item, "shape");
    const cJSON *offsets = cJSON_GetObjectItemCaseSensitive(item, "data_offsets");
    if (!cJSON_IsString(dtype))
        return hd_fail(HD_ERR_FORMAT, "%s: tensor '%s': missing dtype", path, name);
    if (strcmp(dtype->valuestring, "F32") != 0)
        return hd_fail(HD_ERR_FORMAT, "%s: tensor '%s': dtype %.32s is not supported (only F32)", path,
                       name, dtype->valuestring);
    if (!cJSON_IsArray(shape))
        return hd_fail(HD_ERR_FORMAT, "%s: tensor '%s': missing shape", path, name);
    int ndim = cJSON_GetArraySize(shape);
    if (ndim > HD_TENSOR_MAX_DIMS)
        return hd_fail(HD_ERR_FORMAT, "%s: tensor '%s': %d dimensions (at most %d)", path, name, ndim,
                       HD_TENSOR_MAX_DIMS);
    size_t count = 1;
    int d = 0;
    const cJSON *dim;
    cJSON_ArrayForEach(dim, shape)
    {
        uint64_t v;
        if (!json_uint(dim, &v))
            return hd_fail(HD_ERR_FORMAT, "%s: tensor '%s': shape entry %d is not a non-negative integer",
                           path, name, d);
        if (v > (uint64_t)INT64_MAX || !hd_mul_size(count, (size_t)v, &count))
            return hd_fail(HD_ERR_RANGE, "%s: tensor '%s': shape overflows", path, name);
        t->shape[d++] = (int64_t)v;
    }
    t->ndim = ndim;
    uint64_t begin, end;
    if (!cJSON_IsArray(offsets) || cJSON_GetArraySize(offsets) != 2 ||
        !json_uint(cJSON_GetArrayItem(offsets, 0), &begin) || !json_uint(cJSON_GetArrayItem(offsets, 1), &end))
        return hd_fail(HD_ERR_FORMAT, "%s: tensor '%s': data_offsets is not two non-negative integers",
                       path, name);
    size_t bytes;
    if (!hd_mul_size(count, sizeof(float), &bytes))
        return hd_fail(HD_ERR_RANGE, "%s: tensor '%s': shape overflows", path, name);
    if (end < begin)
        return hd_fail(HD_ERR_FORMAT, "%s: tensor '%s': data_offsets [%llu, %llu] end before they begin",
                       path, name, (unsigned long long)begin, (unsigned long long)end);
    if (end - begin != (uint64_t)bytes)
        return hd_fail(HD_ERR_FORMAT, "%s: tensor '%s': data_offsets [%llu, %llu] hold %llu bytes but the "
                       "shape needs %zu", path, name, (unsigned long long)begin, (unsigned long long)end,
                       (unsigned long long)(end - begin), bytes);
    if (end > data_size)
        return hd_fail(HD_ERR_FORMAT, "%s: tensor '%s': data_offsets [%llu, %llu] run past the end of the "
                       "data (%llu bytes)", path, name, (unsigned long long)begin, (unsigned long long)end,
                       (unsigned long long)data_size);
    e->begin = begin;
    e->end = end;
    *floats = count;
    return HD_OK;
}

/* Step one and two: the length word and the JSON header (an object), checked against the file's
 * size; *header_out and *root_out are the caller's to free, also on failure. */
static hd_status read_header(FILE *f, const char *path, char **header_out, cJSON **root_out, uint64_t *n_out,
                             uint64_t *data_size)
{
    struct stat sb;
    if (fstat(fileno(f), &sb) != 0)
        return hd_fail(HD_ERR_IO, "%s: cannot stat: %s", path, strerror(errno));
    if (!S_ISREG(sb.st_mode))
        return hd_fail(HD_ERR_IO, "%s: not a regular file", path);
    const uint64_t file_size = (uint64_t)sb.st_size;
    unsigned char len_bytes[8];
    if (file_size < 8 || fread(len_bytes, 1, 8, f) != 8)
        return hd_fail(HD_ERR_FORMAT, "%s: bad safetensors: %llu bytes is too short for the header length", path,
                       (unsigned long long)file_size);
    uint64_t n = 0;
    for (int i = 7; i >= 0; i--) n = (n << 8) | len_bytes[i];
    if (n > file_size - 8)
        return hd_fail(HD_ERR_FORMAT, "%s: bad safetensors: header length %llu is larger than the rest of the file (%llu bytes)",
                       path, (unsigned long long)n, (unsigned long long)(file_size - 8));
    if (n > ST_MAX_HEADER)
        return hd_fail(HD_ERR_RANGE, "%s: bad safetensors: header length %llu exceeds %llu bytes", path,
                       (unsigned long long)n, (unsigned long long)ST_MAX_HEADER);
    *data_size = file_size - 8 - n;
    *n_out = n;
    char *header = *header_out = hd_malloc((size_t)n + 1);
    if (!header) return HD_ERR_NOMEM;
    if (fread(header, 1, (size_t)n, f) != (size_t)n)
        return hd_fail(HD_ERR_IO, "%s: read error in the header", path);
    header[n] = '\0';
    if (strlen(header) != n)
        return hd_fail(HD_ERR_FORMAT, "%s: bad safetensors: header holds a NUL byte", path);
    const char *parse_end = NULL;
    cJSON *root = *root_out = cJSON_ParseWithLengthOpts(header, (size_t)n, &parse_end, 0);
    if (!root) {
        size_t at = parse_end && parse_end >= header ? (size_t)(parse_end - header) : 0;
        return hd_fail(HD_ERR_FORMAT, "%s: bad safetensors: header is not valid JSON (near byte %zu)", path, at);
    }
    if (!cJSON_IsObject(root))
        return hd_fail(HD_ERR_FORMAT, "%s: bad safetensors: header is not a JSON object", path);
    return HD_OK;
}

/* Step three, everything checked: the names, the tensor data and the metadata into storage (its
 * strings and data allocated here, freed by the caller on failure too). */
static hd_status read_data(FILE *f, const char *path, const cJSON *root, const cJSON *meta, uint64_t n,
                           size_t string_bytes, size_t total_floats, hd_safetensors *st, st_storage *storage)
{
    const cJSON *item;
    storage->strings = hd_malloc(string_bytes ? string_bytes : 1);
    storage->data = hd_malloc(total_floats ? total_floats * sizeof(float) : sizeof(float));
    if (!storage->strings || !storage->data)
        return hd_fail(HD_ERR_NOMEM, "%s: out of memory for %zu floats", path, total_floats);
    char *sp = storage->strings;
    float *dp = storage->data;
    uint64_t data_start = 8 + n;
    int k = 0;
    cJSON_ArrayForEach(item, root)
    {
        if (item == meta) continue;
        hd_tensor *t = &st->tensors[k++];
        size_t len = strlen(item->string) + 1;
        memcpy(sp, item->string, len);
        t->name = sp;
        sp += len;
        t->data = dp;
        size_t floats = 1;
        for (int d = 0; d < t->ndim; d++) floats *= (size_t)t->shape[d];
        const cJSON *offsets = cJSON_GetObjectItemCaseSensitive(item, "data_offsets");
        uint64_t begin = (uint64_t)cJSON_GetArrayItem(offsets, 0)->valuedouble;
        if (floats > 0 && (fseeko(f, (off_t)(data_start + begin), SEEK_SET) != 0 ||
                           fread(dp, sizeof(float), floats, f) != floats))
            return hd_fail(HD_ERR_IO, "%s: tensor '%s': read error", path, t->name);
        dp += floats;
    }
    int m = 0;
    if (meta) {
        const cJSON *kv;
        cJSON_ArrayForEach(kv, meta)
        {
            size_t a = strlen(kv->string) + 1, b = strlen(kv->valuestring) + 1;
            memcpy(sp, kv->string, a);
            st->meta_keys[m] = sp;
            sp += a;
            memcpy(sp, kv->valuestring, b);
            st->meta_values[m] = sp;
            sp += b;
            m++;
        }
    }
    return HD_OK;
}

/* Reads the file in three checked steps: the length word, the JSON header (every entry validated
 * against the file size, overlaps and duplicates refused), then the tensor data. */
hd_status hd_safetensors_read(const char *path, hd_safetensors *st)
{
    memset(st, 0, sizeof *st);
    if (!host_little_endian())
        return hd_fail(HD_ERR_ARG, "%s: safetensors reading needs a little-endian host", path);
    FILE *f = fopen(path, "rb");
    if (!f) return hd_fail(HD_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    hd_status status = HD_OK;
    char *header = NULL;
    cJSON *root = NULL;
    st_entry *entries = NULL;
    const char **names = NULL;
    st_storage *storage = NULL;
    uint64_t n = 0, data_size = 0;
    status = read_header(f, path, &header, &root, &n, &data_size);
    if (status != HD_OK) goto done;
    /* Count tensors and metadata entries. */
    int count = 0, meta_count = 0;
    const cJSON *item, *meta = NULL;
    cJSON_ArrayForEach(item, root)
    {
        if (!item->string) continue;
        if (strcmp(item->string, "__metadata__") == 0) {
            if (meta) {
                status = hd_fail(HD_ERR_FORMAT, "%s: bad safetensors: two __metadata__ entries", path);
                goto done;
            }
            meta = item;
        } else if (++count > ST_MAX_COUNT) {
            status = hd_fail(HD_ERR_RANGE, "%s: bad safetensors: more than %d tensors", path, ST_MAX_COUNT);
            goto done;
        }
    }
    if (meta) {
        if (!cJSON_IsObject(meta)) {
            status = hd_fail(HD_ERR_FORMAT, "%s: bad safetensors: __metadata__ is not an object", path);
            goto done;
        }
        const cJSON *kv;
        cJSON_ArrayForEach(kv, meta)
        {
            if (!cJSON_IsString(kv)) {
                status = hd_fail(HD_ERR_FORMAT, "%s: bad safetensors: metadata '%s' is not a string", path,
                                 kv->string ? kv->string : "?");
                goto done;
            }
            meta_count++;
        }
    }
    st->tensors = hd_calloc(count ? count : 1, sizeof(hd_tensor));
    entries = hd_calloc(count ? count : 1, sizeof(st_entry));
    names = hd_calloc(count ? count : 1, sizeof(char *));
    st->meta_keys = hd_calloc(meta_count ? meta_count : 1, sizeof(char *));
    st->meta_values = hd_calloc(meta_count ? meta_count : 1, sizeof(char *));
    storage = hd_calloc(1, sizeof *storage);
    if (!st->tensors || !entries || !names || !st->meta_keys || !st->meta_values || !storage) {
        status = HD_ERR_NOMEM;
        goto done;
    }
    /* Validate every tensor; sum the floats and the string bytes. */
    size_t total_floats = 0, string_bytes = 0;
    int k = 0;
    cJSON_ArrayForEach(item, root)
    {
        if (item == meta) continue;
        size_t floats = 0;
        status = parse_tensor(path, item, data_size, &st->tensors[k], &entries[k], &floats);
        if (status != HD_OK) goto done;
        entries[k].name = item->string;
        names[k] = item->string;
        total_floats += floats; /* each <= data_size / 4, no overflow */
        string_bytes += strlen(item->string) + 1;
        k++;
    }
    qsort(names, count, sizeof *names, string_ptr_cmp);
    for (int i = 1; i < count; i++)
        if (strcmp(names[i - 1], names[i]) == 0) {
            status = hd_fail(HD_ERR_FORMAT, "%s: bad safetensors: tensor '%s' appears twice", path, names[i]);
            goto done;
        }
    qsort(entries, count, sizeof *entries, entry_by_begin);
    for (int i = 1; i < count; i++) {
        /* Empty tensors own no bytes and overlap nothing. */
        const st_entry *a = &entries[i - 1], *b = &entries[i];
        if (a->end > b->begin && a->begin != a->end && b->begin != b->end) {
            status = hd_fail(HD_ERR_FORMAT, "%s: bad safetensors: tensors '%s' [%llu, %llu] and '%s' [%llu, "
                             "%llu] overlap", path, a->name, (unsigned long long)a->begin,
                             (unsigned long long)a->end, b->name, (unsigned long long)b->begin,
                             (unsigned long long)b->end);
            goto done;
        }
    }
    if (meta) {
        const cJSON *kv;
        cJSON_ArrayForEach(kv, meta) string_bytes += strlen(kv->string) + strlen(kv->valuestring) + 2;
    }
    status = read_data(f, path, root, meta, n, string_bytes, total_floats, st, storage);
    if (status != HD_OK) goto done;
    st->count = count;
    st->meta_count = meta_count;
    st->storage = storage;
    storage = NULL;
done:
    fclose(f);
    free(header);
    cJSON_Delete(root);
    free(entries);
    free(names);
    if (storage) {
        free(storage->data);
        free(storage->strings);
        free(storage);
    }
    if (status != HD_OK) hd_safetensors_free(st);
    return status;
}

const hd_tensor *hd_safetensors_find(const hd_safetensors *st, const char *name)
{
    for (int i = 0; i < st->count; i++)
        if (strcmp(st->tensors[i].name, name) == 0) return &st->tensors[i];
    return NULL;
}

const char *hd_safetensors_meta(const hd_safetensors *st, const char *key)
{
    for (int i = 0; i < st->meta_count; i++)
        if (strcmp(st->meta_keys[i], key) == 0) return st->meta_values[i];
    return NULL;
}

/* Builds the header JSON (tensors in order, contiguous offsets, metadata last), pads it with
 * spaces to a multiple of 8, and writes length, header and data through an atomic file. */
hd_status hd_safetensors_write(const char *path, const hd_tensor *tensors, int count,
                               const char *const *meta_keys, const char *const *meta_values,
                               int meta_count)
{
    if (!host_little_endian())
        return hd_fail(HD_ERR_ARG, "%s: safetensors writing needs a little-endian host", path);
    if (count < 0 || meta_count < 0 || (count > 0 && !tensors))
        return hd_fail(HD_ERR_ARG, "%s: invalid tensor list", path);
    cJSON *root = cJSON_CreateObject();
    if (!root) return hd_fail(HD_ERR_NOMEM, "%s: out of memory building the header", path);
    hd_status status = HD_OK;
    char *json = NULL;
    uint64_t offset = 0;
    for (int i = 0; i < count; i++) {
        const hd_tensor *t = &tensors[i];
        if (!t->name || t->ndim < 0 || t->ndim > HD_TENSOR_MAX_DIMS || strcmp(t->name, "__metadata__") == 0) {
            status = hd_fail(HD_ERR_ARG, "%s: tensor %d: invalid name or dimension count", path, i);
            goto done;
        }
        if (cJSON_GetObjectItemCaseSensitive(root, t->name)) {
            status = hd_fail(HD_ERR_ARG, "%s: tensor '%s' given twice", path, t->name);
            goto done;
        }
        size_t floats = 1;
        double dims[HD_TENSOR_MAX_DIMS];
        for (int d = 0; d < t->ndim; d++) {
            if (t->shape[d] < 0 || !hd_mul_size(floats, (size_t)t->shape[d], &floats)) {
                status = hd_fail(HD_ERR_ARG, "%s: tensor '%s': invalid shape", path, t->name);
                goto done;
            }
            dims[d] = (double)t->shape[d];
        }
        if (floats > 0 && !t->data) {
            status = hd_fail(HD_ERR_ARG, "%s: tensor '%s': no data", path, t->name);
            goto done;
        }
        for (size_t k = 0; k < floats; k++)
            if (!isfinite(t->data[k])) {
                status = hd_fail(HD_ERR_NUMERIC, "%s: not written: tensor '%s' holds a non-finite value at %zu", path,
                                 t->name, k);
                goto done;
            }
        cJSON *entry = cJSON_AddObjectToObject(root, t->name);
        cJSON *shape = cJSON_CreateDoubleArray(dims, t->ndim);
        double offs[2] = {(double)offset, (double)(offset + (uint64_t)floats * 4)};
        cJSON *offsets = cJSON_CreateDoubleArray(offs, 2);
        if (!entry || !shape || !offsets || !cJSON_AddStringToObject(entry, "dtype", "F32")) {
            cJSON_Delete(shape);
            cJSON_Delete(offsets);
            status = hd_fail(HD_ERR_NOMEM, "%s: out of memory building the header", path);
            goto done;
        }
        cJSON_AddItemToObject(entry, "shape", shape);
        cJSON_AddItemToObject(entry, "data_offsets", offsets);
        offset += (uint64_t)floats * 4;
    }
    if (meta_count > 0) {
        cJSON *meta = cJSON_AddObjectToObject(root, "__metadata__");
        for (int i = 0; meta && i < meta_count; i++) {
            if (!meta_keys[i] || !meta_values[i]) {
                status = hd_fail(HD_ERR_ARG, "%s: metadata entry %d is NULL", path, i);
                goto done;
            }
            if (!cJSON_AddStringToObject(meta, meta_keys[i], meta_values[i])) meta = NULL;
        }
        if (!meta) {
            status = hd_fail(HD_ERR_NOMEM, "%s: out of memory building the header", path);
            goto done;
        }
    }
    json = cJSON_PrintUnformatted(root);
    if (!json) {
        status = hd_fail(HD_ERR_NOMEM, "%s: out of memory building the header", path);
        goto done;
    }
    size_t len = strlen(json), padded = (len + 7) / 8 * 8;
    unsigned char len_bytes[8];
    for (int i = 0; i < 8; i++) len_bytes[i] = (unsigned char)((uint64_t)padded >> (8 * i));
    hd_atomic_file af;
    if ((status = hd_atomic_open(&af, path)) != HD_OK) goto done;
    fwrite(len_bytes, 1, 8, af.f);
    fwrite(json, 1, len, af.f);
    for (size_t i = len; i < padded; i++) fputc(' ', af.f);
    for (int i = 0; i < count; i++) {
        size_t floats = 1;
        for (int d = 0; d < tensors[i].ndim; d++) floats *= (size_t)tensors[i].shape[d];
        if (floats > 0) fwrite(tensors[i].data, sizeof(float), floats, af.f);
    }
    status = hd_atomic_commit_durable(&af);
done:
    free(json);
    cJSON_Delete(root);
    return status;
}
