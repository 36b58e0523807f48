/* data_path.c: where the data shipped with hdnet (the canonical mesh, the face models, the default
 * model) is found: $HDNET_DATA, beside the executable, the install prefix compiled in, ./models. */
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "core/core.h"

/* The Makefile compiles in PREFIX/share/hdnet (make install PREFIX=...). */
#ifndef HD_DATADIR
#define HD_DATADIR "/usr/local/share/hdnet"
#endif

static int readable(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f) return 0;
    fclose(f);
    return 1;
}

const char *hd_data_install_dir(void) { return HD_DATADIR; }

char *hd_find_data(const char *name)
{
    char exe[4096], dirs[5][4200];
    int nd = 0;
    const char *env = getenv("HDNET_DATA");
    if (env && *env) snprintf(dirs[nd++], sizeof dirs[0], "%s", env);
    ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (n > 0) {
        exe[n] = '\0';
        char *slash = strrchr(exe, '/');
        if (slash) *slash = '\0';
        snprintf(dirs[nd++], sizeof dirs[0], "%s/../models", exe);
        snprintf(dirs[nd++], sizeof dirs[0], "%s/../share/hdnet", exe);
    }
    snprintf(dirs[nd++], sizeof dirs[0], "%s", HD_DATADIR);
    snprintf(dirs[nd++], sizeof dirs[0], "models");
    for (int i = 0; i < nd; i++) {
        char *p = hd_path_join(dirs[i], name);
        if (!p) return NULL;
        if (readable(p)) return p;
        free(p);
    }
    hd_fail(HD_ERR_NOTFOUND,
            "%s: not found in $HDNET_DATA, beside the executable (../models, ../share/hdnet), in %s or in ./models",
            name, HD_DATADIR);
    return NULL;
}
