/*
 * urb_crc16_link_check_byte as the bit-serial CRC-16 step (poly 0x1021, MSB first): the definition
 * proofs/bmc/urb_crc16_link_check_byte proves the table-driven code equal to for every register and
 * byte. Shift-and-xor chains suit the bit-level solver far better than table look-ups with symbolic
 * indices (the round trip over 34 bytes timed out with the table). Same cost as the table step.
 */
#include "urb_runtime.h"
#include "urb_verify.h"

uint16_t urb_crc16_link_check_byte(uint16_t crc, uint8_t byte)
{
    URB_COST(24);
    uint16_t c = (uint16_t)(crc ^ (uint16_t)((uint16_t)byte << 8));
    for (uint8_t i = 0u; i < 8u; i++) {
        URB_COST(10);
        c = ((c & 0x8000u) != 0u) ? (uint16_t)((uint16_t)(c << 1) ^ 0x1021u) : (uint16_t)(c << 1);
    }
    return c;
}
