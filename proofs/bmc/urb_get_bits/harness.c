/*
 * Proof of urb_get_bits (hand-written): for every offset up to the contract's 65535 and every width
 * 1..32, in a buffer of exactly the bytes the contract names (0 .. (offset + width - 1) / 8), the
 * result holds bit offset + i of the buffer at bit i (wire rule 1: bit k is bit k % 8 of byte k / 8)
 * and nothing above `width`; no out-of-bounds read; at most five rounds; cost within one bus byte.
 */
#include <stdlib.h>

#include "urb_verify.h"
#include "urb_spec.h"
#include "urb_spec_gen.h"
#include "urb_runtime.h"

#ifndef URB_OFFSET_BOUND
#define URB_OFFSET_BOUND 65535u /* the contract's small_offset */
#endif

URB_PROOF_COST_STORAGE;

void harness(void)
{
    size_t const offset = URB_NONDET_SIZE();
    uint8_t const width = URB_NONDET_U8();
    URB_ASSUME(offset <= URB_OFFSET_BOUND && width >= 1u && width <= 32u);
    size_t const size = (offset + width - 1u) / 8u + 1u; /* bytes 0 .. last the contract makes valid */
    uint8_t *const buf = malloc(size);                   /* arbitrary contents */
    URB_ASSUME(buf != NULL);

    URB_COST_BEGIN();
    uint32_t const got = urb_get_bits(buf, offset, width);
    URB_COST_END(URB_BUDGET_PER_BYTE);

    unsigned const i = URB_NONDET_U8(); /* for every bit position of the result */
    URB_ASSUME(i < 32u);
    if (i < width) {
        URB_ASSERT(((got >> i) & 1u) == spec_bit(buf, offset + i), "bit i of the value is bit offset + i of the buffer");
    } else {
        URB_ASSERT(((got >> i) & 1u) == 0u, "no bits above width");
    }
    /* cover points: a field that crosses a byte boundary, a full 32-bit field, a bit above the width */
    if ((offset % 8u) + width > 8u) { URB_COVER("field-spans-bytes"); }
    if (width == 32u) { URB_COVER("full-width"); }
    if (i >= width) { URB_COVER("bit-above-width"); }
    free(buf);
}
