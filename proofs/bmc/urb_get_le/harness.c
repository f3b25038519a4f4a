/*
 * Proof of urb_get_le (hand-written): for every position up to the contract's 65535 and size 1..4,
 * in a buffer of exactly at + size bytes, the result is the little-endian number
 * buf[at] + 256 buf[at + 1] + ... (wire rule 2); no out-of-bounds read; cost within one bus byte.
 */
#include <stdlib.h>

#include "urb_verify.h"
#include "urb_spec.h"
#include "urb_spec_gen.h"
#include "urb_runtime.h"

URB_PROOF_COST_STORAGE;

void harness(void)
{
    size_t const at = URB_NONDET_SIZE();
    size_t const size = URB_NONDET_SIZE();
    URB_ASSUME(at <= 65535u && size >= 1u && size <= 4u);
    uint8_t *const buf = malloc(at + size);
    URB_ASSUME(buf != NULL);

    URB_COST_BEGIN();
    uint32_t const got = urb_get_le(buf, at, size);
    URB_COST_END(URB_BUDGET_PER_BYTE);

    URB_ASSERT(got == spec_le(buf, at, (unsigned)size), "the little-endian number of the bytes");
    if (size == 4u) { URB_COVER("four-bytes"); }
    if (size == 1u) { URB_COVER("one-byte"); }
    free(buf);
}
