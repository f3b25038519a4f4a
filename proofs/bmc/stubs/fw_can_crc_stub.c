/*
 * fw_can_crc_stub.c: a cheap stand-in for the CRC-16 byte step in the CAN state-machine proofs
 * (fw_can_master, fw_can_slave). Those proofs check what the master and slave do with the
 * reassembler's verdict, not the CRC itself (fw_can_transfer proves segmentation and reassembly
 * with the bit-serial CRC, urb_crc16_link_check_byte the table). The stand-in is the CRC with the
 * generator x^16 + 1 in the table form (register (h, l) and byte b give (l, h ^ b)): linear like
 * the real one, so a transfer followed by its own check bytes leaves 0 (a segmenter's transfer
 * passes) and changing any one byte does not, while the solver sees two XORs instead of a table.
 * Cost: the bit-serial step's charge (24 + 8 x 10 cycles), above the table step's.
 */
#include "urb_runtime.h"
#include "urb_verify.h"

uint16_t urb_crc16_link_check_byte(uint16_t crc, uint8_t byte)
{
    URB_COST(24 + 8 * 10);
    return (uint16_t)((uint16_t)(crc << 8) ^ (uint16_t)((crc >> 8) ^ byte));
}
