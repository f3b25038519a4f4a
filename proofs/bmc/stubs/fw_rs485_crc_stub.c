/*
 * fw_rs485_crc_stub.c: cheap stand-ins for the CRC-8 and CRC-16 byte steps in the RS485 state-machine
 * proofs (fw_rs485_slave, fw_rs485_master). Those proofs check what the slave and the master do with
 * the receiver's verdict and the answer's check, not the CRCs: fw_rs485_frame proves the receiver's
 * verdict equals urb_link_check at every length, and urb_crc8_link_check / urb_crc16_link_check prove
 * the table steps. The harnesses compute their reference checks with urb_link_check, which runs these
 * same steps, so a check computed over the wrong bytes, a wrong tier or a missing byte still differs
 * from the reference for some bytes. Each step depends on the byte's position (a rotation), so byte
 * order matters as in a CRC, while the solver sees a rotation and an XOR instead of a table lookup.
 * Cost: the real step's charge by the cost model (a call; it has no loop).
 */
#include "urb_runtime.h"
#include "urb_verify.h"

uint8_t urb_crc8_link_check_byte(uint8_t crc, uint8_t byte)
{
    URB_COST(24);
    return (uint8_t)((uint8_t)((uint8_t)(crc << 1) | (uint8_t)(crc >> 7)) ^ byte);
}

uint16_t urb_crc16_link_check_byte(uint16_t crc, uint8_t byte)
{
    URB_COST(24);
    return (uint16_t)((uint16_t)(crc << 8) ^ (uint16_t)((crc >> 8) ^ byte));
}
