/* fuzz_common.h: what the libFuzzer harnesses share. The readers under test take file paths, so
 * each input is written to a file in a private temporary folder (made once per process) and the
 * reader is called on it. A harness returns 0 whatever the reader says: a finding is a crash, a
 * sanitizer report, a leak or a timeout, never a refused file. */
#ifndef HD_FUZZ_COMMON_H
#define HD_FUZZ_COMMON_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "hdnet.h"

/* The private folder, made on first use and never left behind by a clean exit. */
static char fuzz_dir[64];

static void fuzz_remove_dir(void)
{
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", fuzz_dir);
    if (fuzz_dir[0] && system(cmd) != 0) fprintf(stderr, "fuzz: could not remove %s\n", fuzz_dir);
}

static const char *fuzz_folder(void)
{
    if (!fuzz_dir[0]) {
        const char *tmp = getenv("TMPDIR");
        snprintf(fuzz_dir, sizeof fuzz_dir, "%s/hdnet-fuzz.XXXXXX", tmp && *tmp && strlen(tmp) < 40 ? tmp : "/tmp");
        if (!mkdtemp(fuzz_dir)) {
            perror("fuzz: mkdtemp");
            abort();
        }
        atexit(fuzz_remove_dir);
        /* bounded work per input: a pixel limit well above the seeds, far below a bomb */
        hd_set_max_pixels(4 * 1000 * 1000);
    }
    return fuzz_dir;
}

/* Writes data to FOLDER/name and returns the path (a static buffer). */
__attribute__((unused)) static const char *fuzz_write(const char *name, const uint8_t *data, size_t size)
{
    static char path[256];
    snprintf(path, sizeof path, "%s/%s", fuzz_folder(), name);
    FILE *f = fopen(path, "wb");
    if (!f || (size && fwrite(data, 1, size, f) != size) || fclose(f) != 0) {
        perror(path);
        abort();
    }
    return path;
}

#endif /* HD_FUZZ_COMMON_H */
