/* source_dir.h: where the C tests find the source tree (models/, examples/, tests/data/), from
 * the test binary's own place. Apart from test.h because it needs unistd.h, whose names (dup,
 * ...) some tests use for their own helpers. */
#ifndef HD_TEST_SOURCE_DIR_H
#define HD_TEST_SOURCE_DIR_H

#include <stdio.h>
#include <string.h>
#include <unistd.h>

/* The source tree, from the test binary's place (BUILD/tests/test_x -> BUILD/../..; BUILD is one
 * folder of the tree): "." where /proc/self/exe cannot be read. */
static inline const char *test_source_dir(void)
{
    static char dir[4200];
    char exe[4096];
    ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (n <= 0 || !memchr(exe, '/', (size_t)n)) return ".";
    exe[n] = '\0';
    *strrchr(exe, '/') = '\0';
    snprintf(dir, sizeof dir, "%s/../..", exe);
    return dir;
}

#endif /* HD_TEST_SOURCE_DIR_H */
