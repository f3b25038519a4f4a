/*
 * Proof of urb_put_bits (hand-written): for every offset up to the contract's 65535, width 1..32 and
 * value, in a buffer of exactly the bytes the contract names, afterwards bit offset + i of the buffer
 * is bit i of the value for i < width and every other bit keeps its value; no out-of-bounds access;
 * at most five rounds; cost within one bus byte.
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
    uint32_t const value = URB_NONDET_U32();
    URB_ASSUME(offset <= URB_OFFSET_BOUND && width >= 1u && width <= 32u);
    size_t const size = (offset + width - 1u) / 8u + 1u;
    uint8_t *const buf = malloc(size); /* arbitrary contents */
    URB_ASSUME(buf != NULL);
    size_t const j = URB_NONDET_SIZE(); /* for every bit of the buffer */
    URB_ASSUME(j < 8u * size);
    uint32_t const old = spec_bit(buf, j);

    URB_COST_BEGIN();
    urb_put_bits(buf, offset, width, value);
    URB_COST_END(URB_BUDGET_PER_BYTE);

    if (j >= offset && j < offset + width) {
        URB_ASSERT(spec_bit(buf, j) == ((value >> (j - offset)) & 1u), "bits in the field take the value, LSB first");
    } else {
        URB_ASSERT(spec_bit(buf, j) == old, "every other bit keeps its value");
    }
    /* cover points: a bit inside the field and one beside it in the same byte, a field across bytes */
    if (j >= offset && j < offset + width) { URB_COVER("bit-in-field"); }
    if ((j / 8u == offset / 8u) && (j < offset)) { URB_COVER("bit-beside-field"); }
    if ((offset % 8u) + width > 8u) { URB_COVER("field-spans-bytes"); }
    free(buf);
}
