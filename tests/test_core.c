/* test_core.c: the core services: RNG determinism and range, checked sizes, arena, atomic files
 * (never through a symlink, temporaries O_EXCL with an unguessable name and mode 0644 under the
 * umask, output sets, stale temporaries, the folder lock), escaping, progress lines. */
#include <dirent.h>
#include <string.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>
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

/* How many entries of dir start with prefix. */
static int count_prefixed(const char *dir, const char *prefix)
{
    DIR *d = opendir(dir);
    int n = 0;
    struct dirent *e;
    while (d && (e = readdir(d)) != NULL) n += strncmp(e->d_name, prefix, strlen(prefix)) == 0;
    if (d) closedir(d);
    return n;
}

static int exists(const char *path)
{
    struct stat sb;
    return lstat(path, &sb) == 0;
}

static void test_atomic_safety(void)
{
    CHECK(hd_mkdirs("safe") == HD_OK);
    FILE *f = fopen("safe/target", "w");
    fputs("precious", f);
    fclose(f);
    /* a symlink at the output itself: refused, the target untouched */
    CHECK(symlink("target", "safe/out") == 0);
    hd_atomic_file af;
    CHECK(hd_atomic_open(&af, "safe/out") == HD_ERR_IO);
    CHECK(strstr(hd_error(), "safe/out: is a symbolic link") != NULL);
    FILE *ap = hd_open_append("safe/out");
    CHECK(ap == NULL);
    if (ap) fclose(ap);
    char *data;
    size_t n;
    CHECK(hd_read_file("safe/target", 100, &data, &n) == HD_OK && strcmp(data, "precious") == 0);
    free(data);
    unlink("safe/out");
    /* the old guessable name is planted: the temporary is elsewhere, the output a regular file */
    char old[64];
    snprintf(old, sizeof old, "safe/out.tmp.%ld", (long)getpid());
    CHECK(symlink("target", old) == 0);
    /* this host's tag: gethostname's bytes, each but [A-Za-z0-9-] as '_', at most 64 */
    char host[HD_HOST_TAG_SIZE], raw[256] = "", want[400];
    hd_host_tag(host);
    CHECK(gethostname(raw, sizeof raw - 1) == 0 && raw[0]);
    CHECK(strlen(host) == (strlen(raw) < 64 ? strlen(raw) : 64));
    for (size_t i = 0; host[i]; i++) {
        char c = raw[i];
        int plain = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-';
        CHECK(host[i] == (plain ? c : '_'));
    }
    snprintf(want, sizeof want, "safe/out.tmp.%s.%ld.", host, (long)getpid());
    mode_t mask = umask(022);
    CHECK(hd_atomic_open(&af, "safe/out") == HD_OK);
    CHECK(strncmp(af.tmp_path, want, strlen(want)) == 0 && strlen(af.tmp_path) == strlen(want) + 16);
    struct stat sb;
    CHECK(stat(af.tmp_path, &sb) == 0 && (sb.st_mode & 0777) == 0644);
    fputs("new", af.f);
    CHECK(hd_atomic_commit(&af) == HD_OK);
    umask(mask);
    CHECK(lstat("safe/out", &sb) == 0 && S_ISREG(sb.st_mode));
    CHECK(hd_read_file("safe/target", 100, &data, &n) == HD_OK && strcmp(data, "precious") == 0);
    free(data);
    /* two opens of one path get different temporaries */
    hd_atomic_file a2, b2;
    CHECK(hd_atomic_open(&a2, "safe/two") == HD_OK && hd_atomic_open(&b2, "safe/two") == HD_OK);
    CHECK(strcmp(a2.tmp_path, b2.tmp_path) != 0);
    hd_atomic_abort(&a2);
    hd_atomic_abort(&b2);
    CHECK(count_prefixed("safe", "two") == 0);

    /* output sets: nothing appears before the end; end(0) leaves nothing at all */
    hd_atomic_set_begin();
    CHECK(hd_atomic_open(&af, "safe/set1") == HD_OK && hd_atomic_commit(&af) == HD_OK);
    CHECK(hd_atomic_open(&af, "safe/set2") == HD_OK && hd_atomic_commit(&af) == HD_OK);
    CHECK(!exists("safe/set1") && !exists("safe/set2") && count_prefixed("safe", "set") == 2);
    CHECK(hd_atomic_set_end(0) == HD_OK);
    CHECK(count_prefixed("safe", "set") == 0);
    hd_atomic_set_begin();
    CHECK(hd_atomic_open(&af, "safe/set1") == HD_OK && hd_atomic_commit(&af) == HD_OK);
    CHECK(hd_atomic_open(&af, "safe/set2") == HD_OK && hd_atomic_commit(&af) == HD_OK);
    CHECK(hd_atomic_set_end(1) == HD_OK);
    CHECK(exists("safe/set1") && exists("safe/set2") && count_prefixed("safe", "set") == 2);

    /* stale temporaries: a dead process's of this host go; a live one's, another host's (MPI ranks
     * on several hosts share an output folder: a PID there says nothing here), one without a host
     * (the older form) and other files stay */
    CHECK(hd_mkdirs("stale") == HD_OK);
    char names[8][400];
    const char *forms[8] = {"stale/a.png.tmp.%s.999999999.0123456789abcdef", /* this host, dead: goes */
                            "stale/b.png.tmp.%s.1.0123456789abcdef",         /* this host, alive */
                            "stale/c.tmp.%s.999999999.short",                /* not ours */
                            "stale/d.tmp.txt",
                            "stale/e.png.tmp.%sx.999999999.0123456789abcdef",  /* another host */
                            "stale/f.png.tmp.node-%s.999999999.0123456789abcdef", /* another, ending like ours */
                            "stale/g.png.tmp.999999999.0123456789abcdef",    /* no host */
                            "stale/h.png.tmp.%s.99x9.0123456789abcdef"};     /* not ours */
    for (int i = 0; i < 8; i++) {
        snprintf(names[i], sizeof names[i], forms[i], host);
        f = fopen(names[i], "w");
        if (f) fclose(f);
    }
    CHECK(hd_remove_stale_temporaries("stale") == 1);
    CHECK(!exists(names[0]));
    for (int i = 1; i < 8; i++) CHECK(exists(names[i]));

    /* the folder lock: a second holder (another open file description) is refused */
    int l1 = -1, l2 = -1;
    CHECK(hd_lock_folder("safe", &l1) == HD_OK);
    CHECK(hd_lock_folder("safe", &l2) == HD_ERR_IO && strstr(hd_error(), "another hdnet process") != NULL);
    hd_unlock_folder(l1);
    CHECK(hd_lock_folder("safe", &l2) == HD_OK);
    hd_unlock_folder(l2);

    /* escaping: control bytes of input never reach a terminal raw */
    char esc[32];
    hd_escape_into(esc, sizeof esc, "a\x1b[31mb\n\x7f");
    CHECK(strcmp(esc, "a\\x1b[31mb\\x0a\\x7f") == 0);
    hd_escape_into(esc, 6, "ab\x1b");
    CHECK(strcmp(esc, "ab") == 0); /* cut at a whole character */
    hd_fail(HD_ERR_FORMAT, "x\x1by");
    CHECK(strcmp(hd_error(), "x\\x1by") == 0);
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
    test_atomic_safety();
    return test_summary("core");
}
