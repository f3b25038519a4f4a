/*
 * rng.h: the simulation's only source of randomness.
 *
 * xoshiro256** (Blackman and Vigna) seeded through splitmix64. Every random draw in the simulation
 * goes through one of these generators, so a run is reproducible from its seed. Each device gets
 * its own stream, derived from the world seed and a stable stream name (urbsim_rng_derive), so
 * adding a node or reordering events in one device does not change the draws of another: the
 * crystal error of node 3 stays the same whether or not the scenario also has node 4.
 */
#ifndef URBSIM_RNG_H
#define URBSIM_RNG_H

#include <stdint.h>

typedef struct {
    uint64_t s[4];
    /* Box-Muller produces normals in pairs; the spare is kept so draws stay reproducible. */
    double spare;
    int has_spare;
} urbsim_rng_t;

/** Seed a generator from a 64-bit seed (any value, 0 included). */
void urbsim_rng_seed(urbsim_rng_t *r, uint64_t seed);

/** Seed a generator for the stream `name` (a NUL-terminated label such as "node/rs232/2/clock")
 *  and number `index` of the world seeded with `seed`. Distinct names give independent streams. */
void urbsim_rng_derive(urbsim_rng_t *r, uint64_t seed, const char *name, uint64_t index);

/** Next 64 uniformly distributed bits. Inline with urbsim_rng_below: every interrupt draws its
 *  latency, and the call cost as much as the draw (measured: bench/sim_speed.py, 2026-11-25). */
static inline uint64_t urbsim_rng_u64(urbsim_rng_t *r)
{
    uint64_t *s = r->s;
    uint64_t x = s[1] * 5u;
    uint64_t result = ((x << 7) | (x >> 57)) * 9u;
    uint64_t t = s[1] << 17;
    s[2] ^= s[0];
    s[3] ^= s[1];
    s[1] ^= s[2];
    s[0] ^= s[3];
    s[2] ^= t;
    s[3] = (s[3] << 45) | (s[3] >> 19);
    return result;
}

/** Uniform double in [0, 1), 53 bits of precision. */
double urbsim_rng_uniform(urbsim_rng_t *r);

/** The rare continuations of urbsim_rng_below: a 32-bit draw `m` in the biased zone, and n = 0 or
 *  n >= 2^32. */
uint64_t urbsim_rng_below_retry(urbsim_rng_t *r, uint64_t n, uint64_t m);
uint64_t urbsim_rng_below_wide(urbsim_rng_t *r, uint64_t n);

/** Uniform integer in [0, n) without modulo bias (Lemire's method); n = 0 returns 0. */
static inline uint64_t urbsim_rng_below(urbsim_rng_t *r, uint64_t n)
{
    if (n - 1u < 0xFFFFFFFFu) { /* 1 <= n < 2^32: the common case, interrupt jitter in cycles */
        uint64_t m = (urbsim_rng_u64(r) >> 32) * n;
        /* Only a low part below n can be in the biased zone (its threshold, a division, is below n). */
        return (uint32_t)m >= (uint32_t)n ? m >> 32 : urbsim_rng_below_retry(r, n, m);
    }
    return urbsim_rng_below_wide(r, n);
}

/** Normally distributed double with the given mean and standard deviation (Box-Muller). */
double urbsim_rng_normal(urbsim_rng_t *r, double mean, double sd);

/**
 * Number of Bernoulli(p) trials up to and including the next success (geometric distribution),
 * used to place bit errors: with bit error rate p, the next flipped bit is this many bits ahead.
 * p <= 0 returns UINT64_MAX (never); p >= 1 returns 1.
 */
uint64_t urbsim_rng_geometric(urbsim_rng_t *r, double p);

#endif /* URBSIM_RNG_H */
