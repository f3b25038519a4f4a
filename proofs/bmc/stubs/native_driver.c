/*
 * native_driver.c: runs a proof harness compiled with a plain C compiler (URB_VERIFY_NATIVE).
 *
 * Every URB_NONDET_* value comes from a xorshift generator; a failed URB_ASSUME abandons the run
 * (longjmp back here), a failed URB_ASSERT prints the property and aborts. `make native` in a
 * proof folder builds it under ASan+UBSan and runs NATIVE_RUNS random inputs: a quick sanity
 * check of the harness itself (the proof is the ESBMC run). It also prints the largest cost seen,
 * a lower bound of the proved worst case.
 *
 *   native [runs [seed]]
 */
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>

#include "urb_verify.h"

void harness(void);

static jmp_buf reject_jump;
static uint64_t state = 0x9E3779B97F4A7C15u;
static uint64_t draws;

uint64_t urb_native_next(void)
{
    /* Small values and boundaries are where codecs break: bias one draw in four toward them. */
    state ^= state << 13;
    state ^= state >> 7;
    state ^= state << 17;
    draws++;
    switch (state & 7u) {
    case 0u: return (state >> 8) & 0x3Fu;
    case 1u: return ~(uint64_t)0 - ((state >> 8) & 3u);
    default: return state >> 3;
    }
}

void urb_native_fill(void *array, size_t size)
{
    uint8_t *const bytes = array;
    for (size_t i = 0u; i < size; i++) {
        bytes[i] = (uint8_t)urb_native_next();
    }
}

void urb_native_reject(void)
{
    longjmp(reject_jump, 1);
}

void urb_native_fail(const char *name, const char *file, int line)
{
    fprintf(stderr, "%s:%d: property failed: %s (after %llu draws)\n", file, line, name, (unsigned long long)draws);
    abort();
}

int main(int argc, char **argv)
{
    unsigned long runs = (argc > 1) ? strtoul(argv[1], NULL, 10) : 1000ul;
    if (argc > 2) {
        state = strtoull(argv[2], NULL, 0) | 1u;
    }
    unsigned long kept = 0ul;
    uint32_t worst = 0u;
    for (unsigned long i = 0ul; i < runs; i++) {
        if (setjmp(reject_jump) == 0) {
            urb_proof_cost = 0u;
            harness();
            kept++;
            if (urb_proof_cost > worst) {
                worst = urb_proof_cost;
            }
        }
    }
    printf("native: %lu runs, %lu passed every assumption, all properties held, largest final cost %lu\n",
           runs, kept, (unsigned long)worst);
    return 0;
}
