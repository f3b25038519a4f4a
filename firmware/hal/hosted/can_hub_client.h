/*
 * A CAN controller for hosted programs (the bridge and nodes built for a POSIX host): a client of
 * tools/can_hub.py, which joins every client and one python-can bus (virtual, or socketcan for a
 * real bus). The hub's wire format: one 13-byte record per SOCK_SEQPACKET message, the identifier
 * as a 32-bit little-endian word, the data length, 8 data bytes.
 *
 * The controller never goes bus-off (the hub has no errors: the in-memory bus of the tests and the
 * simulation model them). A frame is "sent" when the hub took it; the report comes from the next
 * urb_can_hub_poll(), never from inside tx (the HAL contract, urb_can.h).
 */
#ifndef URB_CAN_HUB_CLIENT_H
#define URB_CAN_HUB_CLIENT_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_can.h"

#define URB_CAN_HUB_RECORD 13u /**< bytes of one frame on the hub's socket */

/** One connection to the hub; caller-owned. `hal` is the table to give the CAN core. */
typedef struct {
    urb_can_hal_t hal;
    int fd;
    uint32_t unreported; /* frames the hub took whose frame-sent report is still due */
    uint32_t sent, received, dropped_records;
} urb_can_hub_client_t;

/** Connects *c to the hub listening on `path`; false (errno set, nothing open) when it cannot. */
bool urb_can_hub_connect(urb_can_hub_client_t *c, const char *path);

/** Reports the frames sent since the last call (on_tx_done once each), then every frame the hub
 *  delivered (on_rx, with `owner`); returns false when the hub closed the connection. */
bool urb_can_hub_poll(urb_can_hub_client_t *c, void *owner, void (*on_rx)(void *owner, const urb_can_frame_t *f),
                      void (*on_tx_done)(void *owner));

/** Closes the connection. */
void urb_can_hub_close(urb_can_hub_client_t *c);

#endif /* URB_CAN_HUB_CLIENT_H */
