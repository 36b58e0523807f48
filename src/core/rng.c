/* rng.c: PCG32 (M. O'Neill, "PCG: A Family of Simple Fast Space-Efficient Statistically Good
 * Algorithms for Random Number Generation"), our one source of randomness, seeded and
 * checkpointable. */
#include <math.h>
#include "core/core.h"

uint32_t hd_rng_u32(hd_rng *r)
{
    uint64_t old = r->state;
    r->state = old * 6364136223846793005ULL + r->inc;
    uint32_t xorshifted = (uint32_t)(((old >> 18u) ^ old) >> 27u);
    uint32_t rot = (uint32_t)(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((-rot) & 31));
}

void hd_rng_seed(hd_rng *r, uint64_t seed, uint64_t stream)
{
    r->state = 0;
    r->inc = (stream << 1u) | 1u;
    hd_rng_u32(r);
    r->state += seed;
    hd_rng_u32(r);
}

float hd_rng_uniform(hd_rng *r) { return (float)(hd_rng_u32(r) >> 8) * (1.0f / 16777216.0f); }

float hd_rng_range(hd_rng *r, float lo, float hi) { return lo + (hi - lo) * hd_rng_uniform(r); }

float hd_rng_normal(hd_rng *r)
{
    /* u1 in (0, 1] so that the log is finite. */
    double u1 = ((double)(hd_rng_u32(r) >> 8) + 1.0) / 16777216.0;
    double u2 = (double)(hd_rng_u32(r) >> 8) / 16777216.0;
    return (float)(sqrt(-2.0 * log(u1)) * cos(6.283185307179586 * u2));
}

uint32_t hd_rng_below(hd_rng *r, uint32_t n)
{
    if (n == 0) return 0;
    /* Lemire-style rejection keeps the draw unbiased. */
    uint32_t threshold = (uint32_t)(-n) % n;
    for (;;) {
        uint32_t x = hd_rng_u32(r);
        if (x >= threshold) return x % n;
    }
}
