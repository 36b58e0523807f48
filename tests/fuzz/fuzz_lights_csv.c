/* fuzz_lights_csv.c: libFuzzer harness for the reader of `hdnet eval --multilight`'s lights.csv
 * (hd_ml_set_read): every accepted row has a file name inside the folder, a subject and angles
 * within their ranges. */
#include <math.h>
#include "fuzz_common.h"
#include "eval/multilight.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    hd_ml_set set;
    fuzz_write("lights.csv", data, size);
    if (hd_ml_set_read(fuzz_folder(), &set) == HD_OK) {
        if (set.count < 1) abort();
        for (int i = 0; i < set.count; i++) {
            const hd_ml_row *r = &set.rows[i];
            if (!r->file[0] || r->file[0] == '/' || strstr(r->file, "..") || !r->subject[0]) abort();
            if (!(fabsf(r->az) <= 180.0f && fabsf(r->el) <= 90.0f)) abort();
        }
        hd_ml_set_free(&set);
    }
    return 0;
}
