/*
 * Functional postconditions of the check-tier helpers of gen/c/urb_runtime.c for the gen_runtime
 * unit, merged by Frama-C with the generated contracts in urb_runtime.h (which state only the range
 * of the result: {1, 2}, or a payload length within the frame). WP proves these on the bodies; they
 * are not assumptions. With only the range, a tier switch one byte early or late (the mutant
 * `check_tier_one_byte_early`) proved as well as the right code.
 *   tier:    the check of a frame covering `covered` bytes is CRC-8 (1 byte) up to
 *            URB_CRC8_LINK_CHECK_MAX_COVERED bytes, CRC-16 (2 bytes) above.
 *   unique:  a payload length returned by urb_link_check_payload_len fills the frame exactly:
 *            fixed bytes, the payload, then the check whose tier its covered length selects.
 */
#include "urb_runtime.h"

/*@ ensures tier: covered <= URB_CRC8_LINK_CHECK_MAX_COVERED ==> \result == 1;
    ensures tier_16: covered > URB_CRC8_LINK_CHECK_MAX_COVERED ==> \result == 2; */
size_t urb_link_check_size(size_t covered);

/*@ ensures unique_crc8: \result >= 0 && implicit + fixed + \result <= URB_CRC8_LINK_CHECK_MAX_COVERED ==>
              length == fixed + \result + 1;
    ensures unique_crc16: \result >= 0 && implicit + fixed + \result > URB_CRC8_LINK_CHECK_MAX_COVERED ==>
              length == fixed + \result + 2; */
int32_t urb_link_check_payload_len(size_t length, uint8_t implicit, uint8_t fixed);
