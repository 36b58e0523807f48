/* test_core.c: the core services: RNG determinism and range, checked sizes, arena, atomic files,
 * progress lines. */
#include <string.h>
#include <stdlib.h>
#include "test.h"
#include "core/core.h"

static void test_rng(void)
{
    hd_rng a, b;
    hd_rng_seed(&a, 42, 7);
    hd_rng_seed(&b, 42, 7);
    for (int i = 0; i < 1000; i++) CHECK(hd_rng_u32(&a) == hd_rng_u32(&b));
    hd_rng_seed(&b, 43, 7);
    int same = 0;
    for (int i = 0; i < 100; i++) same += hd_rng_u32(&a) == hd_rng_u32(&b);
    CHECK(same < 5);
    double sum = 0, sum2 = 0;
    for (int i = 0; i < 100000; i++) {
        float u = hd_rng_uniform(&a);
        CHECK(u >= 0.0f && u < 1.0f);
        float n = hd_rng_normal(&a);
        sum += n;
        sum2 += (double)n * n;
    }
    CHECK_NEAR(sum / 100000, 0.0, 0.02);
    CHECK_NEAR(sum2 / 100000, 1.0, 0.03);
    for (int i = 0; i < 1000; i++) CHECK(hd_rng_below(&a, 7) < 7);
    /* Saving the two words restores the exact sequence. */
    hd_rng saved = a;
    uint32_t x = hd_rng_u32(&a);
    CHECK(hd_rng_u32(&saved) == x);
}

static void test_sizes_and_arena(void)
{
    size_t out = 0;
    CHECK(hd_mul_size(1u << 20, 1u << 20, &out) && out == (size_t)1 << 40);
    CHECK(!hd_mul_size(SIZE_MAX / 2, 3, &out));
    CHECK(!hd_mul3_size(1u << 31, 1u << 31, 1u << 31, &out));
    hd_arena ar;
    CHECK(hd_arena_init(&ar, 1000) == HD_OK);
    float *p = hd_arena_floats(&ar, 10), *q = hd_arena_floats(&ar, 10);
    CHECK(p && q && q >= p + 10 && ((uintptr_t)q % 64) == 0);
    CHECK(hd_arena_floats(&ar, 1000) == NULL);
    CHECK(strstr(hd_error(), "arena full") != NULL);
    hd_arena_free(&ar);
}

static void test_atomic_file(void)
{
    hd_atomic_file af;
    CHECK(hd_atomic_open(&af, "atomic.txt") == HD_OK);
    fputs("hello\n", af.f);
    CHECK(hd_atomic_commit(&af) == HD_OK);
    char *data;
    size_t n;
    CHECK(hd_read_file("atomic.txt", 1 << 20, &data, &n) == HD_OK);
    CHECK(n == 6 && strcmp(data, "hello\n") == 0);
    free(data);
    CHECK(hd_atomic_open(&af, "atomic.txt") == HD_OK);
    fputs("torn", af.f);
    hd_atomic_abort(&af);
    CHECK(hd_read_file("atomic.txt", 1 << 20, &data, &n) == HD_OK);
    CHECK(strcmp(data, "hello\n") == 0); /* the old file survives an abandoned write */
    free(data);
    CHECK(hd_read_file("atomic.txt", 3, &data, &n) == HD_ERR_RANGE);
    CHECK(hd_atomic_open(&af, "no/such/dir/x") == HD_ERR_IO);
    CHECK(strstr(hd_error(), "no/such/dir/x") != NULL);
    CHECK(hd_mkdirs("a/b/c") == HD_OK && hd_is_dir("a/b/c"));
}

static void test_path_stems(void)
{
    const char *cases[][3] = {{"dir/a.b/face.png", "face", "dir/a.b/face.mask.png"},
                              {"face.jpg", "face", "face.mask.png"},
                              {"dir/.hidden", ".hidden", "dir/.hidden.mask.png"},
                              {"dir/noext", "noext", "dir/noext.mask.png"},
                              {"x.tar.gz", "x.tar", "x.tar.mask.png"}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char *stem = hd_path_stem(cases[i][0]), *comp = hd_path_companion(cases[i][0], ".mask.png");
        CHECK(stem && strcmp(stem, cases[i][1]) == 0);
        CHECK(comp && strcmp(comp, cases[i][2]) == 0);
        free(stem);
        free(comp);
    }
}

int main(void)
{
    test_path_stems();
    test_rng();
    test_sizes_and_arena();
    test_atomic_file();
    return test_summary("core");
}
