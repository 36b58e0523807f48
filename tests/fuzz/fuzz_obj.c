/* fuzz_obj.c: libFuzzer harness for the OBJ mesh reader (the canonical face mesh's format). */
#include "fuzz_common.h"
#include "mesh/mesh.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    hd_mesh mesh;
    memset(&mesh, 0, sizeof mesh);
    if (hd_mesh_load_obj(fuzz_write("input.obj", data, size), &mesh) == HD_OK) hd_mesh_free(&mesh);
    return 0;
}
