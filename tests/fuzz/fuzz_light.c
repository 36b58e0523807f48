/* fuzz_light.c: libFuzzer harness for the light-file reader (9 numbers, each finite and within
 * HD_LIGHT_MAX_COEFF when accepted). */
#include <math.h>
#include "fuzz_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    float light[HD_SH_COEFFS];
    if (hd_light_read(fuzz_write("input.light.txt", data, size), light) == HD_OK)
        for (int k = 0; k < HD_SH_COEFFS; k++)
            if (!(fabsf(light[k]) <= HD_LIGHT_MAX_COEFF)) abort();
    return 0;
}
