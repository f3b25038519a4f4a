/*
 * fw_bridge_check.h: the frame check (urb_link_check) as the bridge proofs see it.
 *
 * The bridge's parsers and its I2C master never look inside a check value: they compute it and
 * compare it with the received check bytes. By data independence their properties hold for every
 * check function, so the bridge proofs replace the CRC with an arbitrary value of the right width
 * (fw_bridge_check.c). That keeps the solver from inverting a CRC to decide which branch a frame
 * takes, a question it cannot answer within minutes. What the CRC itself computes is proved by
 * proofs/bmc/urb_link_check and urb_crc*; its cost is charged here from the same cost model.
 */
#ifndef FW_BRIDGE_CHECK_H
#define FW_BRIDGE_CHECK_H

#include <stddef.h>
#include <stdint.h>

/* Cycles of urb_link_check over n covered bytes: the call, then two nibble-table lookups per byte
 * (proofs/bmc/cost_model.json; the same figure the codec proofs' check stub charges). */
#define FW_LINK_CHECK_CYCLES(n) (132u + 46u * (uint32_t)(n))

/* Covered bytes the stub accepts: the longest uplink or downlink frame check covers 35. */
#define FW_LINK_CHECK_COVERED_MAX 35u

/* Calls to urb_link_check made so far (the harnesses count checks per request). */
extern uint32_t fw_bridge_check_calls;
/* The value the last call returned (a harness compares it with the check bytes it sent). */
extern uint32_t fw_bridge_check_last;

#endif /* FW_BRIDGE_CHECK_H */
