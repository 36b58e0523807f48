/* clock.c: monotonic time (hd_seconds), for rates, time limits and benchmarks. */
#include <time.h>
#include "core/core.h"

double hd_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}
