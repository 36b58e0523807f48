/* fuzz_safetensors.c: libFuzzer harness for the safetensors reader, and for hd_model_load on the
 * same bytes (the model loader checks names, shapes and the configuration on top of it). */
#include "fuzz_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = fuzz_write("input.safetensors", data, size);
    hd_safetensors st = {0};
    if (hd_safetensors_read(path, &st) == HD_OK) hd_safetensors_free(&st);
#ifdef FUZZ_MODEL
    hd_model *model = NULL;
    if (hd_model_load(path, &model) == HD_OK) hd_model_free(model);
#endif
    return 0;
}
