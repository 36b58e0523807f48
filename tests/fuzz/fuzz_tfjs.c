/* fuzz_tfjs.c: libFuzzer harness for the TF.js graph loader. An input is a 4-byte little-endian
 * length N, N bytes of model JSON (written as model.json) and the rest as the weight shard g.bin
 * (the seeds' manifests name g.bin). A graph that loads is also run once on a zero input, so the
 * arena and the ops' output sizes are exercised too. */
#include "fuzz_common.h"
#include "graph/tfjs_graph.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 4) return 0;
    size_t n = (size_t)data[0] | (size_t)data[1] << 8 | (size_t)data[2] << 16 | (size_t)data[3] << 24;
    if (n > size - 4) n = size - 4;
    const char *json = fuzz_write("model.json", data + 4, n);
    char json_path[256];
    snprintf(json_path, sizeof json_path, "%s", json);
    fuzz_write("g.bin", data + 4 + n, size - 4 - n);
    hd_tfjs_graph *g = NULL;
    if (hd_tfjs_load(json_path, &g) != HD_OK) return 0;
    int h, w, c;
    hd_tfjs_input_shape(g, &h, &w, &c);
    size_t count = (size_t)h * w * c;
    if (h > 0 && w > 0 && c > 0 && count <= 1u << 20) {
        float *input = calloc(count, sizeof *input);
        if (input) (void)hd_tfjs_run(g, input);
        free(input);
    }
    hd_tfjs_free(g);
    return 0;
}
