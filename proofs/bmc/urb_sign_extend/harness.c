/*
 * Proof of urb_sign_extend (hand-written): for every raw value and width 2..32, the result is the
 * two's complement value of the low `width` bits of raw (computed in 64 bits by spec_signed), with
 * no signed overflow and no undefined shift; cost within one bus byte.
 */
#include "urb_verify.h"
#include "urb_spec.h"
#include "urb_spec_gen.h"
#include "urb_runtime.h"

URB_PROOF_COST_STORAGE;

void harness(void)
{
    uint32_t const raw = URB_NONDET_U32();
    uint8_t const width = URB_NONDET_U8();
    URB_ASSUME(width >= 2u && width <= 32u);

    URB_COST_BEGIN();
    int32_t const got = urb_sign_extend(raw, width);
    URB_COST_END(URB_BUDGET_PER_BYTE);

    URB_ASSERT((int64_t)got == spec_signed(raw, width), "the two's complement value of the low width bits");
    if (got < 0) { URB_COVER("negative"); }
    if (got >= 0) { URB_COVER("non-negative"); }
}
