/*
 * Stub of urb_link_check() for the bridge proofs (see fw_bridge_check.h): every byte it covers
 * must be readable, the value is arbitrary within the check's width, the cost is the model's.
 */
#include "urb_verify.h"

#include "fw_bridge_check.h"
#include "urb_runtime.h"

uint32_t fw_bridge_check_calls = 0u;
uint32_t fw_bridge_check_last = 0u;

uint32_t urb_link_check(const uint8_t *prefix, size_t prefix_len, const uint8_t *data, size_t len)
{
    size_t const n = prefix_len + len;
    URB_ASSERT(n <= FW_LINK_CHECK_COVERED_MAX, "check stub: no frame check covers more bytes");
    URB_ASSUME(n <= FW_LINK_CHECK_COVERED_MAX);
    URB_COST(FW_LINK_CHECK_CYCLES(n));
    fw_bridge_check_calls++;
    /* the first and last covered bytes lie in one object each, so every covered byte is valid */
    if (prefix_len > 0u) {
        uint8_t const ends = (uint8_t)(prefix[0] ^ prefix[prefix_len - 1u]);
        (void)ends;
    }
    if (len > 0u) {
        uint8_t const ends = (uint8_t)(data[0] ^ data[len - 1u]);
        (void)ends;
    }
    uint32_t const value = URB_NONDET_U32();
    fw_bridge_check_last = (n <= URB_CRC8_LINK_CHECK_MAX_COVERED) ? (value & 0xFFu) : (value & 0xFFFFu);
    return fw_bridge_check_last;
}
