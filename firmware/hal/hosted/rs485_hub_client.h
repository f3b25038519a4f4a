/*
 * An RS485 transceiver for hosted programs (the bridge and nodes built for a POSIX host): a station
 * of tools/rs485_hub.py, the line that owns the line time. The hub sends events (a received byte
 * with its stop-bit time stamp, a transmit slot, a wake-up), each with the line time; the station
 * reacts in zero line time and acknowledges with its next character and its next wake-up. The
 * hub's docstring has the wire format (8-byte SOCK_SEQPACKET messages, `<BBHI`).
 *
 * The owner (a master or a slave, and what runs on it) gives three functions: rx for each byte
 * received (its own echo too), tick at each event after rx (poll the master or slave and the
 * application at line time `now`), tx_next for each transmit slot after tx_start (the UART's
 * transmit interrupt). Line time is what the owner uses as its clock for the RS485 side: a hosted
 * program that waits for the wall clock instead would break the line's silences whenever the host
 * deschedules it.
 */
#ifndef URB_RS485_HUB_CLIENT_H
#define URB_RS485_HUB_CLIENT_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_rs485.h"

#define URB_RS485_HUB_MESSAGE 8u /**< bytes of one message on the hub's socket */

/** What the client calls on its owner; `owner` is the pointer given to urb_rs485_hub_service. */
typedef struct {
    void (*rx)(void *owner, uint8_t byte, uint32_t t);  /**< a byte received at line time t */
    void (*tick)(void *owner, uint32_t now);            /**< an event at line time now: poll */
    bool (*tx_next)(void *owner, uint8_t *byte);        /**< the next character, false when done */
    /** Optional (NULL: none): true and *at when the owner wants a tick at line time *at besides
     *  the transceiver's wake_at (an application timer); asked after every tick. */
    bool (*timer)(void *owner, uint32_t *at);
} urb_rs485_hub_owner_t;

/** One station on the hub; caller-owned. `hal` is the transceiver to give the master or slave. */
typedef struct {
    urb_rs485_hal_t hal;
    int fd;
    uint32_t now;       /* line time of the last event */
    uint16_t seq;       /* last hub message handled */
    bool owe_ack;       /* that message is not acknowledged yet */
    bool driving;       /* tx_start came and the owner still has characters */
    bool in_flight;     /* a character of ours is on the line */
    bool wake_set;      /* the owner's wake_at request */
    uint32_t wake;
    bool told_wake;     /* the wake-up the hub has */
    uint32_t told_at;
    uint32_t sent, received;
} urb_rs485_hub_client_t;

/** Connects *c to the hub listening on `path` as a station at `baud`, and waits (at most 5 s) for
 *  the hub's welcome, which gives the line time (c->now). False (errno set, nothing open) when
 *  it cannot: ECONNREFUSED/ENOENT (no hub), ECONNRESET (the hub refused the baud rate, its
 *  stderr says why), ETIMEDOUT (no welcome). */
bool urb_rs485_hub_connect(urb_rs485_hub_client_t *c, const char *path, uint32_t baud);

/** What to do about urb_rs485_hub_connect's failure `err` (its errno), for an error message. */
const char *urb_rs485_hub_advice(int err);

/** Handles every message the hub has sent (rx, then tick, then the transmit slot, per message)
 *  and acknowledges each with the next character and the earliest wake-up (wake_at's, the
 *  owner's timer's). Returns false when the hub closed the connection (or sent what is not one
 *  of its messages: then errno is EPROTO). */
bool urb_rs485_hub_service(urb_rs485_hub_client_t *c, void *owner, const urb_rs485_hub_owner_t *ops);

/** After the owner acted outside an event (the bridge began a transaction from its uplink):
 *  starts driving if tx_start came, and tells the hub a changed wake-up. False when the hub is
 *  gone. */
bool urb_rs485_hub_flush(urb_rs485_hub_client_t *c, void *owner, const urb_rs485_hub_owner_t *ops);

/** Closes the connection. */
void urb_rs485_hub_close(urb_rs485_hub_client_t *c);

#endif /* URB_RS485_HUB_CLIENT_H */
