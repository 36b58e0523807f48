/* fuzz_image.c: libFuzzer harness for the image readers (PNG, JPEG, PFM, chosen by magic bytes as
 * hd_image_read does); the FUZZ_FORMAT macro names the target (png, jpeg or pfm) so that each
 * gets its own corpus, and the harness prepends nothing: the seeds carry the magic. */
#include "fuzz_common.h"
#include "io/image_io.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = fuzz_write("input." FUZZ_FORMAT, data, size);
    hd_image img = {0};
    hd_image_info info;
    if (hd_image_read_info(path, &img, &info) == HD_OK) {
        /* a decoded image holds only finite samples of the size the header gave */
        size_t n = (size_t)img.width * img.height * img.channels;
        for (size_t i = 0; i < n; i++)
            if (img.data[i] != img.data[i]) abort();
        if (img.width != info.width || img.height != info.height) abort();
        hd_image_free(&img);
    }
    return 0;
}
