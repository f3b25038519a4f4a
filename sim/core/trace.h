/*
 * trace.h: the NDJSON event trace of a simulation run.
 *
 * One JSON object per line, keys in a fixed order, integers only (times in ns), so that two runs
 * with the same seed produce the same bytes. Every line is folded into a 64-bit FNV-1a hash even
 * when no file is written: the determinism test compares hashes of long runs without storing them.
 *
 * Lines are filtered by category (a bit mask) before they are formatted, so a disabled category
 * costs one branch. The kinds of lines and their fields are listed in sim/README.md ("Trace
 * format"); the TLA+ trace validation (sim/urb_sim/tracecheck.py) reads the bridge and mailbox
 * categories.
 */
#ifndef URBSIM_TRACE_H
#define URBSIM_TRACE_H

#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>

#include "kernel.h"

enum {
    URBSIM_TR_BUS = 1u << 0,     /**< wire-level: every byte on UART, I2C, USB packets */
    URBSIM_TR_FRAME = 1u << 1,   /**< uplink frames and USB transfers as wholes */
    URBSIM_TR_BRIDGE = 1u << 2,  /**< bridge request/response events (trace validation) */
    URBSIM_TR_MAILBOX = 1u << 3, /**< node mailbox events (trace validation) */
    URBSIM_TR_FAULT = 1u << 4,   /**< injected faults and the firmware's reaction */
    URBSIM_TR_SYNC = 1u << 5,    /**< heartbeat and SYNC events */
    URBSIM_TR_HOST = 1u << 6,    /**< host CPU ticks and wake-ups */
    URBSIM_TR_ALL = 0x7Fu,
};

typedef struct {
    FILE *file;        /**< NULL: hash only */
    uint32_t mask;     /**< categories written and hashed */
    uint64_t hash;     /**< FNV-1a 64 of every line written so far (newlines included) */
    uint64_t lines;
} urbsim_trace_t;

/** No file, nothing enabled, hash at the FNV offset basis. */
void urbsim_trace_init(urbsim_trace_t *tr);

/** True when lines of category `cat` are recorded (test before building expensive fields). */
static inline int urbsim_trace_on(const urbsim_trace_t *tr, uint32_t cat)
{
    return (tr->mask & cat) != 0u;
}

/**
 * Record one line: {"t":<now>,"cat":"<cat name>","dev":"<dev>","ev":"<ev>"<rest>} where `rest` is
 * printf-formatted and must start with a comma (or be empty), e.g. ",\"byte\":%u". Lines longer
 * than 1 KiB are truncated (and still valid JSON is not guaranteed then: keep fields short).
 */
void urbsim_trace(urbsim_trace_t *tr, uint32_t cat, urbsim_ns_t now, const char *dev, const char *ev,
                  const char *rest, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 6, 7)))
#endif
    ;

/** Append bytes as a JSON string of hex digits into out (2 * n + 1 bytes of room). */
void urbsim_hex(char *out, const uint8_t *data, size_t n);

#endif /* URBSIM_TRACE_H */
