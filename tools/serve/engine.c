/* engine.c: the model and the face aligner `hdnet serve` shares between its connections. Neither
 * may be run by two threads at once (include/hdnet.h), so callers hold the engine's lock around
 * every call that runs them; everything else a request does (decoding, warping maps, encoding
 * PNGs) runs outside it, in parallel. */
#include <string.h>
#include "serve.h"

hd_status serve_engine_open(serve_engine *e, const char *model_path)
{
    memset(e, 0, sizeof *e);
    hd_status st = hd_model_load(model_path, &e->model);
    if (st == HD_OK) st = hd_aligner_load(&e->aligner);
    if (st == HD_OK && pthread_mutex_init(&e->lock, NULL) != 0) st = HD_ERR_NOMEM;
    if (st != HD_OK) {
        if (e->model) hd_model_free(e->model);
        hd_aligner_free(e->aligner);
        memset(e, 0, sizeof *e);
    }
    return st;
}

void serve_engine_close(serve_engine *e)
{
    if (!e->model) return;
    pthread_mutex_destroy(&e->lock);
    hd_model_free(e->model);
    hd_aligner_free(e->aligner);
    memset(e, 0, sizeof *e);
}
