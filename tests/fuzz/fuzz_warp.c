/* fuzz_warp.c: libFuzzer harness for the aligned-face warp file reader (NAME.warp.txt, which
 * `hdnet blend` reads back). */
#include "fuzz_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    hd_aligned_face face;
    memset(&face, 0, sizeof face);
    if (hd_aligned_face_read_warp(fuzz_write("input.warp.txt", data, size), &face) == HD_OK) hd_aligned_face_free(&face);
    return 0;
}
