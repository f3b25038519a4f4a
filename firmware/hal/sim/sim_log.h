/*
 * sim_log.h: a fixed-size ring of timestamped marks (heartbeats, end of acquisition, SYNC time
 * stamps, bridge serve/emit edges) that Python drains for the experiments. When Python does not
 * drain it in time the oldest entries are overwritten and counted in `lost`.
 */
#ifndef URBSIM_SIM_LOG_H
#define URBSIM_SIM_LOG_H

#include <stdint.h>

#define SIM_LOG_CAP 8192u /* power of two */

typedef struct {
    uint64_t t[SIM_LOG_CAP];   /**< virtual time, ns */
    uint32_t v[SIM_LOG_CAP];   /**< kind << 24 | value */
    uint32_t head, len;
    uint64_t lost;
} sim_log_t;

static inline void sim_log_put(sim_log_t *l, uint64_t t, uint32_t kind, uint32_t value)
{
#ifdef URBSIM_MUTANT_LOG_WRAP /* seeded bug (tools/sim_sanitized.py): the wrap test is off by one */
    uint32_t i = l->head + l->len;
    if (i > SIM_LOG_CAP) {
        i -= SIM_LOG_CAP;
    }
#else
    uint32_t i = (l->head + l->len) & (SIM_LOG_CAP - 1u);
#endif
    l->t[i] = t;
    l->v[i] = (kind << 24) | (value & 0xFFFFFFu);
    if (l->len == SIM_LOG_CAP) {
        l->head = (l->head + 1u) & (SIM_LOG_CAP - 1u);
        l->lost++;
    } else {
        l->len++;
    }
}

/** Move up to cap entries (oldest first) into t/v; returns how many. */
static inline uint32_t sim_log_drain(sim_log_t *l, uint64_t *t, uint32_t *v, uint32_t cap)
{
    uint32_t n = 0;
    while (n < cap && l->len) {
        t[n] = l->t[l->head];
        v[n] = l->v[l->head];
        l->head = (l->head + 1u) & (SIM_LOG_CAP - 1u);
        l->len--;
        n++;
    }
    return n;
}

#endif /* URBSIM_SIM_LOG_H */
