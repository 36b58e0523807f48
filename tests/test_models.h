/* test_models.h: how the C tests find the shipped data (models/: the canonical mesh, the face
 * networks) when they run from a scratch directory: HDNET_TESTDATA is <source>/tests/data, so the
 * source tree's models are at <source>/tests/data/../../models. */
#ifndef HD_TEST_MODELS_H
#define HD_TEST_MODELS_H

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "mesh/mesh.h"

/* Points HDNET_DATA at the source tree's models/ (when it is unset, or always with overwrite). */
static inline void test_use_source_models(int overwrite)
{
    const char *td = getenv("HDNET_TESTDATA");
    if (!td || (!overwrite && getenv("HDNET_DATA"))) return;
    char dir[4096];
    snprintf(dir, sizeof dir, "%s", td);
    char *slash = strrchr(dir, '/'); /* HDNET_TESTDATA is <source>/tests/data */
    if (slash) *slash = '\0';
    size_t len = strlen(dir);
    snprintf(dir + len, sizeof dir - len, "/../models");
    setenv("HDNET_DATA", dir, 1);
}

/* Loads the canonical mesh, from the source tree's models/ if not found where hdnet looks. */
static inline int test_load_canonical(hd_mesh *m)
{
    if (hd_mesh_load_canonical(m) == HD_OK) return 1;
    /* from the build tree the test binary has no ../models: use the source tree's */
    test_use_source_models(1);
    if (hd_mesh_load_canonical(m) == HD_OK) return 1;
    fprintf(stderr, "cannot load the canonical mesh: %s\n", hd_error());
    return 0;
}

#endif /* HD_TEST_MODELS_H */
