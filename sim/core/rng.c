/* rng.c: splitmix64 seeding and xoshiro256** generation. See rng.h. */
#include "rng.h"

#include <math.h>

/* Not every C99 libm defines M_PI under -std=c99. */
static const double TWO_PI = 6.283185307179586476925286766559;

static uint64_t splitmix64(uint64_t *x)
{
    uint64_t z = (*x += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

void urbsim_rng_seed(urbsim_rng_t *r, uint64_t seed)
{
    uint64_t x = seed;
    for (int i = 0; i < 4; i++) {
        r->s[i] = splitmix64(&x);
    }
    r->spare = 0.0;
    r->has_spare = 0;
}

void urbsim_rng_derive(urbsim_rng_t *r, uint64_t seed, const char *name, uint64_t index)
{
    /* FNV-1a over the name, mixed with the seed and index through splitmix64: stable across
     * platforms and independent of pointer values. */
    uint64_t h = 0xCBF29CE484222325ull;
    for (const char *p = name; *p; p++) {
        h = (h ^ (uint8_t)*p) * 0x100000001B3ull;
    }
    uint64_t x = seed ^ h;
    uint64_t mixed = splitmix64(&x) ^ index * 0xD1B54A32D192ED03ull;
    urbsim_rng_seed(r, mixed);
}

double urbsim_rng_uniform(urbsim_rng_t *r)
{
    return (double)(urbsim_rng_u64(r) >> 11) * 0x1.0p-53;
}

uint64_t urbsim_rng_below_retry(urbsim_rng_t *r, uint64_t n, uint64_t m)
{
    uint32_t n32 = (uint32_t)n;
    uint32_t threshold = (0u - n32) % n32;
    while ((uint32_t)m < threshold) {
        m = (urbsim_rng_u64(r) >> 32) * n;
    }
    return m >> 32;
}

uint64_t urbsim_rng_below_wide(urbsim_rng_t *r, uint64_t n)
{
    if (n == 0) {
        return 0;
    }
    /* Rejection on the low bits of the 128-bit product (Lemire 2019), via 64-bit halves so it is
     * plain C99. */
    uint64_t threshold = (0u - n) % n;
    for (;;) {
        uint64_t x = urbsim_rng_u64(r);
        uint64_t xl = x & 0xFFFFFFFFu, xh = x >> 32, nl = n & 0xFFFFFFFFu, nh = n >> 32;
        uint64_t ll = xl * nl, lh = xl * nh, hl = xh * nl, hh = xh * nh;
        uint64_t mid = (ll >> 32) + (lh & 0xFFFFFFFFu) + (hl & 0xFFFFFFFFu);
        uint64_t hi = hh + (lh >> 32) + (hl >> 32) + (mid >> 32);
        uint64_t lo = x * n;
        if (lo >= threshold) {
            return hi;
        }
    }
}

double urbsim_rng_normal(urbsim_rng_t *r, double mean, double sd)
{
    if (r->has_spare) {
        r->has_spare = 0;
        return mean + sd * r->spare;
    }
    double u1;
    do {
        u1 = urbsim_rng_uniform(r);
    } while (u1 <= 0.0);
    double u2 = urbsim_rng_uniform(r);
    double mag = sqrt(-2.0 * log(u1));
    r->spare = mag * sin(TWO_PI * u2);
    r->has_spare = 1;
    return mean + sd * mag * cos(TWO_PI * u2);
}

uint64_t urbsim_rng_geometric(urbsim_rng_t *r, double p)
{
    if (!(p > 0.0)) {
        return UINT64_MAX;
    }
    if (p >= 1.0) {
        return 1;
    }
    double u;
    do {
        u = urbsim_rng_uniform(r);
    } while (u <= 0.0);
    double k = floor(log(u) / log1p(-p)) + 1.0;
    return k >= 1.8e19 ? UINT64_MAX : (uint64_t)k;
}
