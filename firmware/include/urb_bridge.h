/*
 * URB bridge: the firmware between the CPU's uplinks (RS232, USB) and a downlink (I2C, ...).
 *
 * What it does (paper Sec. V-A..V-D; behaviour fixed by spec/tla/Bridge.tla, UsbUplink.tla and
 * Discovery.tla, whose action names the sources cite):
 *  - parses request frames from the RS232 byte stream (idle-gap and hunting resynchronisation,
 *    spec/schema/README.md) and from USB batches (one OUT transfer per 1-ms frame);
 *  - admits them into one bounded FIFO in arrival order: BAD_REQUEST, SIZE_MISMATCH and BUSY are
 *    decided at admission but answered in arrival order; nothing is retransmitted;
 *  - serves the oldest pending request on the downlink, or itself for address 0 (outbox 0
 *    BridgeInfo, outbox 1 BridgeScan, inbox 0 BridgeCommand);
 *  - sends each response on the uplink its request came from, in request order; USB responses
 *    are double-buffered (the batch of frame n is read during frame n+1);
 *  - scans the downlink at start and on command, learning each node's mailbox sizes;
 *  - broadcasts SYNC on the downlink every heartbeat period.
 *
 * State lives in a caller-owned urb_bridge_t: no heap, no globals, any number of bridges per
 * process. Concurrency: the functions marked ISR may run in interrupts and touch only fields
 * shared through single-writer indices; all others must be called from one thread (the main
 * loop), never concurrently with each other. Every function is bounded (see the loop-bound
 * comments in firmware/bridge/ and build/firmware/bridge_costs.md for measured worst cases).
 */
#ifndef URB_BRIDGE_H
#define URB_BRIDGE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "urb_bridge_hal.h"
#include "urb_core.h"
#include "urb_downlink.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ===== Capacities (compile time; the struct holds arrays of these sizes) ==================== */

#ifndef URB_BRIDGE_FIFO_MAX
#define URB_BRIDGE_FIFO_MAX 16u /**< Most data slots (queued requests with a payload buffer) */
#endif
#ifndef URB_BRIDGE_RING_MAX
#define URB_BRIDGE_RING_MAX 32u /**< Response slots: outstanding requests per bridge (host window) */
#endif
#ifndef URB_BRIDGE_MAX_NODES
#define URB_BRIDGE_MAX_NODES 32u /**< Nodes whose mailbox sizes the bridge remembers */
#endif
#ifndef URB_BRIDGE_USB_BUF
#define URB_BRIDGE_USB_BUF 512u /**< Largest USB transfer in either direction */
#endif
#define URB_BRIDGE_RX_RING 64u  /**< UART receive ring (bytes between two polls), power of two */
#define URB_BRIDGE_TX_RING 128u /**< UART transmit ring, power of two, >= 35 (one response) */
#define URB_BRIDGE_FRAME_MAX 37u /**< Longest uplink request frame */
#define URB_BRIDGE_PARSE_BUF (2u * URB_BRIDGE_FRAME_MAX) /**< RS232 assembler: one held candidate and room to
                                                          append, so hunting never shifts bytes */
#ifndef URB_BRIDGE_HUNT_CHECKS
#define URB_BRIDGE_HUNT_CHECKS 4u /**< RS232 frame checks per poll; the rest waits for the next poll */
#endif
#ifndef URB_BRIDGE_RX_PER_POLL
#define URB_BRIDGE_RX_PER_POLL 16u /**< RS232 ring bytes taken per poll: with the checks, one poll's parsing
                                        stays within half the 1-ms cycle (spec/schema/README.md) */
#endif

#define URB_BRIDGE_FW_MAJOR 0u /**< Firmware version reported in BridgeInfo */
#define URB_BRIDGE_FW_MINOR 1u
#define URB_BRIDGE_FW_PATCH 0u

/* ===== Configuration ========================================================================= */

/** Bridge configuration; urb_bridge_default_config() fills in the defaults. */
typedef struct {
    uint8_t fifo_depth;      /**< Data slots in use, 1..URB_BRIDGE_FIFO_MAX (default 16) */
    uint32_t baud;           /**< RS232 bit rate, for the idle gap (default 115200) */
    uint32_t idle_gap_us;    /**< Line idle longer than this drops a partial frame (default: 2 byte times) */
    uint16_t heartbeat_us;   /**< SYNC period in microseconds, 0 = no SYNC (default 1000) */
    bool scan_at_start;      /**< Scan the downlink before serving the first request (default true) */
} urb_bridge_config_t;

/** Counters for diagnostics and tests (never reset by the bridge). */
typedef struct {
    uint32_t rx_bytes;          /**< UART bytes received */
    uint32_t rx_overruns;       /**< UART bytes lost because the receive ring was full */
    uint32_t frames;            /**< Request frames accepted (both uplinks) */
    uint32_t hunt_discards;     /**< Bytes discarded while hunting for a frame start */
    uint32_t gap_drops;         /**< Partial frames dropped at an idle gap or a transfer end */
    uint32_t usb_batches;       /**< USB OUT transfers accepted */
    uint32_t usb_bad_batches;   /**< USB OUT transfers dropped (bad header, too long) */
    uint32_t usb_cut_batches;   /**< USB OUT transfers whose data stopped parsing before their end (a
                                     frame failed its check or was cut short): the rest was dropped */
    uint32_t usb_late_reads;    /**< Frames whose previous response batch had not been read yet */
    uint32_t busy;              /**< Requests answered BUSY */
    uint32_t window_overflow;   /**< Requests dropped because every response slot was taken
                                     (the host exceeded its window: outside the contract) */
    uint32_t responses;         /**< Responses sent */
    uint32_t syncs;             /**< SYNC broadcasts started */
    uint32_t syncs_missed;      /**< Heartbeat ticks whose SYNC was skipped (downlink busy too long) */
    uint32_t scans;             /**< Scans completed */
    uint32_t hunt_yields;       /**< Polls whose RS232 parsing stopped at URB_BRIDGE_HUNT_CHECKS checks
                                     (the rest was parsed by the next polls) */
} urb_bridge_stats_t;

/* ===== State (caller-owned; fields are private) =============================================== */

/** RS232 request frame assembler: the bytes held are buf[start .. start + len). */
typedef struct {
    uint8_t buf[URB_BRIDGE_PARSE_BUF];
    uint8_t start;  /* the candidate frame's first byte: hunting advances it instead of shifting */
    uint8_t len;    /* bytes held, at most URB_BRIDGE_FRAME_MAX */
    bool flushing;  /* an idle gap ended the candidate: dropping bytes until nothing is held */
} urb_bridge_parser_t;

/** One response slot: a request's place in the answer order. */
typedef struct {
    uint8_t seq;     /* request sequence number */
    uint8_t status;  /* urb_status_t, or URB_BRIDGE_PENDING */
    uint8_t uplink;  /* where the response goes */
    uint8_t slot;    /* data slot index, or URB_BRIDGE_NO_SLOT for admission errors */
} urb_bridge_resp_t;

/** One data slot: a request header and its 32-byte payload (write data, or read result). */
typedef struct {
    uint8_t address, mailbox, length;
    bool read;
    uint8_t resp;    /* its response slot */
    uint8_t data[32];
} urb_bridge_slot_t;

/** Mailbox sizes of one node, learnt from its identification. */
typedef struct {
    uint8_t address;      /* 0 = entry unused */
    uint8_t in[8], out[8];
} urb_bridge_node_t;

/** One bridge. Initialise with urb_bridge_init(); never copy while running. */
typedef struct {
    urb_bridge_config_t cfg;
    const urb_bridge_hal_t *hal;
    urb_downlink_t dl;
    /* UART receive ring: written by urb_bridge_uart_rx (ISR), read by poll. */
    volatile uint16_t rx_ring[URB_BRIDGE_RX_RING]; /* byte | URB_BRIDGE_RX_GAP */
    volatile uint8_t rx_head;  /* ISR */
    volatile uint8_t rx_tail;  /* poll */
    volatile uint8_t rx_overrun; /* ISR */
    uint32_t rx_last_us;       /* ISR */
    uint32_t rx_gap_us;        /* byte time + idle gap: a longer distance between two bytes is a gap */
    bool rx_started;           /* ISR */
    /* UART transmit ring: written by poll, drained by urb_bridge_uart_tx_pop (ISR). */
    volatile uint8_t tx_ring[URB_BRIDGE_TX_RING];
    volatile uint8_t tx_head;  /* poll */
    volatile uint8_t tx_tail;  /* ISR */
    /* Heartbeat: ticks counted by the ISR, SYNCs sent counted by poll. */
    volatile uint8_t hb_ticks; /* ISR */
    uint8_t hb_done;           /* poll */
    /* Frame assemblers. */
    urb_bridge_parser_t rs232;
    /* Response ring (arrival order) and data slots (a FIFO inside it). */
    urb_bridge_resp_t ring[URB_BRIDGE_RING_MAX];
    uint8_t ring_head, ring_count;
    urb_bridge_slot_t slots[URB_BRIDGE_FIFO_MAX];
    uint8_t slot_head, slot_count, slot_served; /* slot_served: slots already served (from head) */
    /* What the downlink is doing for us. */
    uint8_t activity;
    bool probing;  /* the oldest pending request's node did not acknowledge: probe it, then answer */
    bool size_checked; /* the oldest pending request's length was checked against the identification
                          its node just gave (a node whose sizes the table does not hold) */
    bool scanning, scan_for_request;
    uint8_t scan_addr;
    uint8_t scan_buf[URB_IDENTIFICATION_SIZE];
    /* What the bridge knows about its downlink. */
    uint8_t present[16];                 /* presence (BridgeScan bitmap), bit a%8 of byte a/8: set by the
                                            scan and when a node answers, cleared when a probe finds it gone */
    uint8_t node_of[128];                /* index + 1 into nodes[], 0 = sizes unknown */
    urb_bridge_node_t nodes[URB_BRIDGE_MAX_NODES];
    /* USB: responses of the current frame, and of the previous one awaiting the IN transfer. */
    uint8_t usb_buf[2][URB_BRIDGE_USB_BUF];
    uint16_t usb_len[2];
    uint8_t usb_count[2];
    uint16_t usb_frame[2];
    uint8_t usb_cur;
    bool usb_prev_ready;
    uint16_t usb_last_frame;
    urb_bridge_stats_t stats;
} urb_bridge_t;

/* ===== API ===================================================================================== */

/** Fills *cfg with the defaults: 16 slots, 115200 Bd, 2-byte-time idle gap, 1 ms SYNC, scan at start. */
void urb_bridge_default_config(urb_bridge_config_t *cfg);

/** Initialises *b (config copied, hal and dl->ctx kept by reference; the queue starts empty, as after
 *  Bridge.tla BridgeReset) and starts the heartbeat. URB_ERR_ARGUMENT: NULL pointer, depth not 1..MAX. */
int32_t urb_bridge_init(urb_bridge_t *b, const urb_bridge_config_t *cfg, const urb_bridge_hal_t *hal,
                        const urb_downlink_t *dl);

/** Main loop: parses received bytes, advances the downlink, serves and answers requests. Bounded. */
void urb_bridge_poll(urb_bridge_t *b);

/** True when poll() has nothing to do until the next event (a port may sleep). */
bool urb_bridge_idle(const urb_bridge_t *b);

/** ISR: one byte received on the RS232 uplink at time t_us (its stop bit). O(1), never waits. */
void urb_bridge_uart_rx(urb_bridge_t *b, uint8_t byte, uint32_t t_us);

/** ISR: the next byte to transmit on the RS232 uplink; false when there is none. O(1). */
bool urb_bridge_uart_tx_pop(urb_bridge_t *b, uint8_t *byte);

/** ISR: one heartbeat period elapsed; the SYNC goes out as soon as the downlink is free. O(1). */
void urb_bridge_heartbeat(urb_bridge_t *b);

/** USB start of frame (UsbUplink.tla Tick): the current response batch becomes the one to read. */
void urb_bridge_usb_sof(urb_bridge_t *b);

/** USB OUT transfer (a UsbBatchHeader and its request frames back to back): admits the requests in
 *  order. The first frame that fails its check or is cut short ends the transfer: the rest is
 *  dropped and counted (usb_cut_batches); USB delivers transfers intact, so nothing is hunted for.
 *  At most one failing frame check per transfer. Returns false (transfer dropped, no responses)
 *  for a bad header or a transfer over URB_BRIDGE_USB_BUF. */
bool urb_bridge_usb_out(urb_bridge_t *b, const uint8_t *data, size_t len);

/** USB IN transfer: copies the previous frame's response batch into buf; returns its length, or 0
 *  when it was already read or does not fit in `cap`. */
size_t urb_bridge_usb_in(urb_bridge_t *b, uint8_t *buf, size_t cap);

/** The bridge's counters. */
const urb_bridge_stats_t *urb_bridge_stats(const urb_bridge_t *b);

/** True when the bridge holds `address` present (the BridgeScan bit): found by the last scan or
 *  answering since, and not found gone by a probe since. */
bool urb_bridge_present(const urb_bridge_t *b, uint8_t address);

/** Requests waiting for their response (admitted, not yet sent). */
uint8_t urb_bridge_outstanding(const urb_bridge_t *b);

#ifdef __cplusplus
}
#endif

#endif /* URB_BRIDGE_H */
