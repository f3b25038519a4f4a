/*
 * Proof of urb_put_le (hand-written): for every position up to the contract's 65535, size 1..4 and
 * value, in a buffer of exactly at + size bytes, afterwards buf[at + k] is byte k of the value
 * (wire rule 2) and buf[0 .. at - 1] keep their values; no out-of-bounds write; cost within one
 * bus byte.
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
    uint32_t const value = URB_NONDET_U32();
    URB_ASSUME(at <= 65535u && size >= 1u && size <= 4u);
    uint8_t *const buf = malloc(at + size);
    URB_ASSUME(buf != NULL);
    size_t const j = URB_NONDET_SIZE(); /* for every byte of the buffer */
    URB_ASSUME(j < at + size);
    uint8_t const old = buf[j];

    URB_COST_BEGIN();
    urb_put_le(buf, at, size, value);
    URB_COST_END(URB_BUDGET_PER_BYTE);

    if (j >= at) {
        size_t const k = j - at;
        uint32_t const scale = (k == 0u) ? 1u : (k == 1u) ? 256u : (k == 2u) ? 65536u : 16777216u;
        URB_ASSERT((uint32_t)buf[j] == ((value / scale) & 0xFFu), "byte k of the number is byte k of the value");
    } else {
        URB_ASSERT(buf[j] == old, "bytes before the number keep their values");
    }
    if (j + 1u == at + size && size == 4u) { URB_COVER("top-byte-of-four"); }
    if (j < at) { URB_COVER("byte-before-the-number"); }
    free(buf);
}
