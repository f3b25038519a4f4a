/*
 * fw_node_crc_stub.c: the link_check byte steps for proofs of code that only CARRIES a check (the
 * node's I2C state machine): an order-sensitive mix instead of the table-driven CRC.
 *
 * Why: ESBMC 8.4 expands the nested table lookups of a CRC over symbolic bytes without sharing,
 * so a 14-byte frame did not finish symbolic execution in 200 s. The state machine never looks
 * inside the CRC: it starts it, feeds bytes, picks the tier and sends or compares the final value.
 * Those decisions are what the harness checks; any order-sensitive byte step exposes a byte left
 * out, fed twice, fed out of order, the wrong tier or a swapped check byte. The real functions are
 * proved against the spec by their own proofs (proofs/bmc/urb_crc8_link_check_byte etc.).
 *
 * Cost: each step charges what prepare.py charges the real function (call 24 + 3 statements x 3
 * cycles for a byte step, 24 + 3 for a final), so the cost bound keeps its meaning.
 */
#include "urb_runtime.h"

#include "urb_verify.h"

uint8_t urb_crc8_link_check_byte(uint8_t crc, uint8_t byte)
{
    URB_COST(33u);
    return (uint8_t)((uint8_t)((crc << 1) | (crc >> 7)) ^ byte ^ 0x2Fu);
}

uint8_t urb_crc8_link_check_final(uint8_t crc)
{
    URB_COST(27u);
    return (uint8_t)(crc ^ 0xFFu);
}

uint16_t urb_crc16_link_check_byte(uint16_t crc, uint8_t byte)
{
    URB_COST(33u);
    return (uint16_t)((uint16_t)((crc << 3) | (crc >> 13)) ^ (uint16_t)((uint16_t)byte << 5) ^ byte ^ 0x1021u);
}

uint16_t urb_crc16_link_check_final(uint16_t crc)
{
    URB_COST(27u);
    return crc;
}
