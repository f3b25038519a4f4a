/*
 * fw_node_ident_stub.c: urb_identification_encode by its proved contract, for proofs of code that
 * calls the encoder (the node's main loop refreshing outbox 0).
 *
 * Why: outbox 0 lives inside urb_node_t (mb0), and ESBMC 8.4 encodes each of the encoder's 25+
 * stores through a pointer into the struct as a byte-level update of the whole 336-byte node at a
 * symbolic offset (which buffer is written depends on the outbox's front): Boolector ran out of
 * memory at 4 GiB on one urb_node_poll. The encoder is proved on its own
 * (proofs/bmc/urb_identification_encode: memory safety, round trip, worst-case cost), so here it
 * is replaced by that contract: its preconditions are asserted (the caller must meet them), the
 * buffer's first and last byte must be readable (the 25 bytes lie in one object), and it charges
 * the encoder's recorded worst case, FW_IDENT_ENCODE_COST (the Makefile passes the number in
 * proofs/bmc/urb_identification_encode/COST, so it follows that proof). The bytes it would write
 * are left as they were: the callers under proof never read them back.
 */
#include "urb_core.h"

#include "urb_verify.h"

#ifndef FW_IDENT_ENCODE_COST
#error "pass -DFW_IDENT_ENCODE_COST=<cycles> (proofs/bmc/urb_identification_encode/COST)"
#endif

int32_t urb_identification_encode(const urb_identification_t *msg, uint8_t *buf, size_t capacity)
{
    URB_COST(FW_IDENT_ENCODE_COST);
    URB_ASSERT((msg != NULL) && (buf != NULL), "identification encode: message and buffer");
    URB_ASSERT(capacity >= URB_IDENTIFICATION_SIZE, "identification encode: the buffer holds the message");
    URB_ASSERT(msg->index <= 63u, "identification encode: index fits its 6 bits");
    for (uint8_t n = 0u; n < 8u; n++) {
        URB_ASSERT((msg->inbox_sizes[n] <= 63u) && (msg->outbox_sizes[n] <= 63u), "identification encode: sizes fit 6 bits");
    }
    uint8_t const first = buf[0];
    uint8_t const last = buf[URB_IDENTIFICATION_SIZE - 1u];
    (void)first;
    (void)last;
    return (int32_t)URB_IDENTIFICATION_SIZE;
}
