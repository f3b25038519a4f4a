/*
 * Private declarations shared by the bridge sources (not part of the public API).
 */
#ifndef URB_BRIDGE_INTERNAL_H
#define URB_BRIDGE_INTERNAL_H

#include "urb_bridge.h"

/* Keeps the compiler from moving plain loads/stores across this point. The interrupt side
 * publishes a result by writing data then a volatile phase; the main loop reads the phase and then
 * the data, and without the barrier the compiler may hoist those data loads above the phase load. */
#if defined(__GNUC__) || defined(__clang__)
#define URB_BARRIER() __asm__ __volatile__("" ::: "memory")
#else
#define URB_BARRIER() ((void)0)
#endif

#define URB_BRIDGE_PENDING 0xFFu  /* ring status: waiting for the downlink */
#define URB_BRIDGE_NO_SLOT 0xFFu  /* ring slot: admission error, no payload buffer */
#define URB_BRIDGE_RX_GAP 0x100u  /* rx ring flag: an idle gap (or an overrun) precedes this byte */

enum { URBB_UPLINK_RS232 = 0u, URBB_UPLINK_USB = 1u };
enum {
    URBB_ACT_NONE = 0u, URBB_ACT_REQUEST = 1u, URBB_ACT_SCAN = 2u, URBB_ACT_SYNC = 3u, URBB_ACT_PROBE = 4u,
    URBB_ACT_LEARN = 5u
};

/* bridge.c: a complete candidate frame of `len` bytes from `uplink`. Returns false when it fails
 * its check (the caller then discards one byte and hunts on), true when it was admitted (as a
 * request, or answered BAD_REQUEST when it passed its check but breaks a schema rule). */
bool urbb_frame(urb_bridge_t *b, uint8_t uplink, const uint8_t *frame, uint8_t len);

/* bridge_uplink.c: the uplink side of poll(): parse the bytes the UART interrupt queued, with at
 * most URB_BRIDGE_HUNT_CHECKS frame checks and URB_BRIDGE_RX_PER_POLL bytes (the rest waits for the
 * next call). */
void urbb_uart_drain(urb_bridge_t *b, uint32_t now);

/* bridge_uplink.c: urbb_uart_drain with a budget of `checks` frame checks. It stops only where a
 * check is due and none is left, in a state the next call resumes from, so any split of the work
 * into calls admits the same frames in the same order (proofs/bmc/fw_bridge_rs232_parser). */
void urbb_uart_parse(urb_bridge_t *b, uint32_t now, uint8_t checks);

/* bridge_uplink.c: queue one encoded response on `uplink`; false when it has no room now. */
bool urbb_uplink_send(urb_bridge_t *b, uint8_t uplink, const uint8_t *frame, uint8_t len);

/* bridge_uplink.c: reset the uplink state at init. */
void urbb_uplink_init(urb_bridge_t *b);

#endif /* URB_BRIDGE_INTERNAL_H */
