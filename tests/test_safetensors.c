/* test_safetensors.c: checkpoint files. A round trip of several tensors (including a scalar and
 * an empty one) with metadata, the exact bytes of the layout (length word, padding, contiguous
 * offsets), and one hand-made broken file per kind of error, each refused with a reason that
 * names the file (and the tensor where there is one). */
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "test.h"
#include "core/core.h"
#include "io/safetensors.h"

static void test_round_trip(void)
{
    hd_rng rng;
    hd_rng_seed(&rng, 5, 1);
    float a[2 * 3 * 3 * 3], b[7], c[1];
    for (size_t i = 0; i < sizeof a / sizeof *a; i++) a[i] = hd_rng_normal(&rng);
    for (size_t i = 0; i < 7; i++) b[i] = hd_rng_normal(&rng);
    c[0] = -0.0f;
    hd_tensor t[4] = {
        {"enc0.w", 4, {2, 3, 3, 3}, a},
        {"enc0.b", 1, {7}, b},
        {"scalar", 0, {0}, c},
        {"empty", 2, {0, 5}, NULL},
    };
    const char *keys[3] = {"format_version", "width", "quote\"d"};
    const char *values[3] = {"1", "48", "a \"value\"\nwith a newline"};
    CHECK(hd_safetensors_write("rt.safetensors", t, 4, keys, values, 3) == HD_OK);
    CHECK(access("rt.safetensors", F_OK) == 0);

    /* The layout: a little-endian length that is a multiple of 8, JSON, spaces, then data. */
    char *raw;
    size_t size;
    CHECK(hd_read_file("rt.safetensors", 1 << 20, &raw, &size) == HD_OK);
    uint64_t n = 0;
    for (int i = 7; i >= 0; i--) n = (n << 8) | (unsigned char)raw[i];
    CHECK(n % 8 == 0);
    CHECK(size == 8 + n + sizeof a + sizeof b + sizeof c);
    CHECK(raw[8] == '{');
    CHECK(memcmp(raw + 8 + n, a, sizeof a) == 0);
    CHECK(memcmp(raw + 8 + n + sizeof a, b, sizeof b) == 0);
    free(raw);

    hd_safetensors st;
    CHECK(hd_safetensors_read("rt.safetensors", &st) == HD_OK);
    CHECK(st.count == 4 && st.meta_count == 3);
    for (int i = 0; i < 4 && i < st.count; i++) {
        CHECK(strcmp(st.tensors[i].name, t[i].name) == 0); /* order kept */
        CHECK(st.tensors[i].ndim == t[i].ndim);
        for (int d = 0; d < t[i].ndim; d++) CHECK(st.tensors[i].shape[d] == t[i].shape[d]);
    }
    const hd_tensor *ta = hd_safetensors_find(&st, "enc0.w"), *tc = hd_safetensors_find(&st, "scalar");
    CHECK(ta && memcmp(ta->data, a, sizeof a) == 0);
    CHECK(tc && memcmp(tc->data, c, sizeof c) == 0);
    CHECK(hd_safetensors_find(&st, "nope") == NULL);
    CHECK(hd_safetensors_meta(&st, "width") && strcmp(hd_safetensors_meta(&st, "width"), "48") == 0);
    CHECK(hd_safetensors_meta(&st, "quote\"d") && strcmp(hd_safetensors_meta(&st, "quote\"d"), values[2]) == 0);
    CHECK(hd_safetensors_meta(&st, "missing") == NULL);
    hd_safetensors_free(&st);
    CHECK(st.count == 0 && st.tensors == NULL);

    /* No tensors, no metadata: still a valid file. */
    CHECK(hd_safetensors_write("none.safetensors", NULL, 0, NULL, NULL, 0) == HD_OK);
    CHECK(hd_safetensors_read("none.safetensors", &st) == HD_OK);
    CHECK(st.count == 0 && st.meta_count == 0);
    hd_safetensors_free(&st);

    /* Writer errors leave no file. */
    hd_tensor dup[2] = {{"x", 1, {1}, c}, {"x", 1, {1}, c}};
    CHECK(hd_safetensors_write("dup.safetensors", dup, 2, NULL, NULL, 0) == HD_ERR_ARG);
    CHECK(access("dup.safetensors", F_OK) != 0);
    hd_tensor neg = {"y", 1, {-1}, c};
    CHECK(hd_safetensors_write("neg.safetensors", &neg, 1, NULL, NULL, 0) == HD_ERR_ARG);
}

/* Writes a safetensors file from a header text and `data_bytes` zero bytes of data; the length
 * word is the header's length unless `length` is not 0. */
static void write_raw(const char *path, const char *header, size_t data_bytes, uint64_t length)
{
    FILE *f = fopen(path, "wb");
    uint64_t n = length ? length : strlen(header);
    for (int i = 0; i < 8; i++) fputc((int)((n >> (8 * i)) & 0xFF), f);
    fputs(header, f);
    for (size_t i = 0; i < data_bytes; i++) fputc(0, f);
    fclose(f);
}

static void expect_error(const char *path, const char *header, size_t data_bytes, uint64_t length,
                         const char *needle1, const char *needle2)
{
    write_raw(path, header, data_bytes, length);
    hd_safetensors st;
    hd_status s = hd_safetensors_read(path, &st);
    CHECK(s != HD_OK);
    CHECK(st.count == 0 && st.tensors == NULL && st.storage == NULL);
    const char *e = hd_error();
    if (s == HD_OK || !strstr(e, path) || (needle1 && !strstr(e, needle1)) || (needle2 && !strstr(e, needle2))) {
        fprintf(stderr, "%s: reason lacks '%s'/'%s': %s\n", path, needle1 ? needle1 : "",
                needle2 ? needle2 : "", e);
        test_failures++;
    }
    if (s == HD_OK) hd_safetensors_free(&st);
}

static void test_errors(void)
{
    hd_safetensors st;
    CHECK(hd_safetensors_read("missing.safetensors", &st) == HD_ERR_IO);
    CHECK(strstr(hd_error(), "missing.safetensors") != NULL);
    FILE *f = fopen("short.safetensors", "wb");
    fputs("abc", f);
    fclose(f);
    CHECK(hd_safetensors_read("short.safetensors", &st) == HD_ERR_FORMAT);
    CHECK(strstr(hd_error(), "short.safetensors") != NULL);

    const char *ok = "{\"a\":{\"dtype\":\"F32\",\"shape\":[2],\"data_offsets\":[0,8]}}";
    write_raw("ok.safetensors", ok, 8, 0);
    CHECK(hd_safetensors_read("ok.safetensors", &st) == HD_OK);
    hd_safetensors_free(&st);

    expect_error("len.safetensors", ok, 8, 1000, "header length 1000", NULL);
    expect_error("len_huge.safetensors", ok, 8, UINT64_MAX, "header length", NULL);
    expect_error("notjson.safetensors", "this is not json at all", 0, 0, "not valid JSON", NULL);
    expect_error("badjson.safetensors", "{\"a\":{\"dtype\":\"F32\",", 0, 0, "not valid JSON", NULL);
    expect_error("array.safetensors", "[1,2]", 0, 0, "not a JSON object", NULL);
    expect_error("mismatch.safetensors", "{\"w\":{\"dtype\":\"F32\",\"shape\":[3],\"data_offsets\":[0,8]}}", 12, 0,
                 "'w'", "shape needs 12");
    expect_error("overlap.safetensors",
                 "{\"p\":{\"dtype\":\"F32\",\"shape\":[2],\"data_offsets\":[0,8]},"
                 "\"q\":{\"dtype\":\"F32\",\"shape\":[2],\"data_offsets\":[4,12]}}",
                 12, 0, "overlap", "'q'");
    expect_error("past.safetensors", "{\"w\":{\"dtype\":\"F32\",\"shape\":[4],\"data_offsets\":[8,24]}}", 16, 0,
                 "'w'", "past the end");
    expect_error("f16.safetensors", "{\"h\":{\"dtype\":\"F16\",\"shape\":[2],\"data_offsets\":[0,4]}}", 4, 0,
                 "'h'", "F16");
    expect_error("negshape.safetensors", "{\"n\":{\"dtype\":\"F32\",\"shape\":[-2],\"data_offsets\":[0,0]}}", 0,
                 0, "'n'", "shape");
    expect_error("fracshape.safetensors", "{\"n\":{\"dtype\":\"F32\",\"shape\":[1.5],\"data_offsets\":[0,4]}}", 4,
                 0, "'n'", "shape");
    expect_error("bigshape.safetensors",
                 "{\"n\":{\"dtype\":\"F32\",\"shape\":[4294967296,4294967296,4294967296],\"data_offsets\":[0,4]}}",
                 4, 0, "'n'", "overflow");
    expect_error("backwards.safetensors", "{\"b\":{\"dtype\":\"F32\",\"shape\":[0],\"data_offsets\":[8,4]}}", 8, 0,
                 "'b'", "end before");
    expect_error("nooffsets.safetensors", "{\"b\":{\"dtype\":\"F32\",\"shape\":[1]}}", 4, 0, "'b'", "data_offsets");
    expect_error("meta.safetensors", "{\"__metadata__\":{\"width\":48}}", 0, 0, "'width'", "not a string");
    expect_error("dupname.safetensors",
                 "{\"d\":{\"dtype\":\"F32\",\"shape\":[1],\"data_offsets\":[0,4]},"
                 "\"d\":{\"dtype\":\"F32\",\"shape\":[1],\"data_offsets\":[4,8]}}",
                 8, 0, "'d'", "twice");
    expect_error("dims.safetensors",
                 "{\"m\":{\"dtype\":\"F32\",\"shape\":[1,1,1,1,1,1,1,1,1],\"data_offsets\":[0,4]}}", 4, 0, "'m'",
                 "dimensions");
    /* Empty tensors at the same offset as others are not overlaps. */
    write_raw("empties.safetensors",
              "{\"e\":{\"dtype\":\"F32\",\"shape\":[0],\"data_offsets\":[4,4]},"
              "\"p\":{\"dtype\":\"F32\",\"shape\":[2],\"data_offsets\":[0,8]}}",
              8, 0);
    CHECK(hd_safetensors_read("empties.safetensors", &st) == HD_OK);
    hd_safetensors_free(&st);
}

/* Every prefix and many random corruptions of a valid file either read or fail cleanly (no
 * crash, no leak under make check, nothing left allocated, a reason naming the file). */
static void test_fuzz(void)
{
    char *data;
    size_t size;
    if (hd_read_file("rt.safetensors", 1 << 20, &data, &size) != HD_OK) {
        CHECK(!"cannot read rt.safetensors");
        return;
    }
    hd_rng rng;
    hd_rng_seed(&rng, 7, 1);
    int failures = 0;
    for (int trial = 0; trial < (int)size + 1000; trial++) {
        size_t n = size;
        char *copy = malloc(size);
        memcpy(copy, data, size);
        if (trial < (int)size) {
            n = (size_t)trial;
        } else {
            /* corrupt the length word and header mostly, where the checks live */
            uint32_t span = trial % 4 == 0 ? (uint32_t)size : (uint32_t)(size - 62 * sizeof(float));
            int k = 1 + (int)hd_rng_below(&rng, 3);
            for (int i = 0; i < k; i++) {
                static const char pick[] = "{}[]\",:0123456789-.eE \\";
                size_t at = hd_rng_below(&rng, span);
                copy[at] = trial % 3 ? pick[hd_rng_below(&rng, sizeof pick - 1)] : (char)hd_rng_u32(&rng);
            }
        }
        remove("fuzz.safetensors");
        FILE *f = fopen("fuzz.safetensors", "wb");
        fwrite(copy, 1, n, f);
        fclose(f);
        free(copy);
        hd_safetensors st;
        if (hd_safetensors_read("fuzz.safetensors", &st) == HD_OK) {
            for (int i = 0; i < st.count; i++) CHECK(st.tensors[i].name && (st.tensors[i].data || st.tensors[i].ndim > 0));
            hd_safetensors_free(&st);
        } else {
            failures++;
            CHECK(st.tensors == NULL && st.storage == NULL);
            CHECK(strstr(hd_error(), "fuzz.safetensors") != NULL);
        }
    }
    CHECK(failures >= (int)size);
    free(data);
}

int main(void)
{
    test_round_trip();
    test_errors();
    test_fuzz();
    return test_summary("test_safetensors");
}
