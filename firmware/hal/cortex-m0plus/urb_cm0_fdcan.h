/*
 * Register-level CAN port for the STM32G0B1 (Cortex-M0+): its FDCAN controller in classic CAN mode
 * (11-bit identifiers, 8 data bytes, no bit-rate switch) as the urb_can_hal_t that the CAN downlink's
 * slave (node) and master (bridge) drive (urb_can.h, urb_can_slave.h, urb_can_master.h).
 *
 * Reference: RM0444, "STM32G0x1 reference manual", chapter "FD controller area network (FDCAN)":
 * sections "Message RAM" (the fixed layout per instance), "Bit timing" and "FDCAN registers"; the
 * memory map (chapter "Memory and bus architecture") for the addresses. Sections are named by title,
 * not number, as the numbering differs between revisions.
 * The register block and the message RAM are reached through the two pointers the caller passes to
 * urb_cm0_can_init(): the glue passes URB_CM0_FDCAN1 and URB_CM0_SRAMCAN1 (the part's addresses),
 * the unit tests (tests/firmware/cm0hal/) a RAM copy of each laid out as the part's, so the same
 * code is tested on the host.
 *
 * What the port does for the downlink (every function below is O(1) or bounded by the 3-element
 * FIFOs of the message RAM):
 *  - tx: one frame into the Tx FIFO (3 buffers, FIFO mode: frames leave in the order queued), with
 *    "store Tx event" set and the abort epoch in the message marker;
 *  - the interrupt: each element of the Tx event FIFO is one frame sent, reported once in order
 *    through on_tx_done (events of frames queued before the last tx_abort are dropped, so an
 *    aborted frame that still made it onto the bus is never reported); each Rx FIFO 0 element is
 *    delivered to on_rx with the time of its start of frame (the controller's time stamp, taken at
 *    SOF, converted to the caller's microsecond clock) and acknowledged; a change of the error
 *    state (bus-off, error-passive, back to active) goes to on_state;
 *  - state: PSR.BO, PSR.EP -> urb_can_state_t; recover: leaves the initialisation mode that
 *    bus-off forces, which starts the 128 x 11 recessive-bit recovery;
 *  - lock: masks the controller's interrupt line 0 at the peripheral (ILE.EINT0).
 * No heap, no globals: the caller owns urb_cm0_can_t (the vector-table glue keeps a pointer to it).
 */
#ifndef URB_CM0_FDCAN_H
#define URB_CM0_FDCAN_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_can.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ===== The part (RM0444 memory map, FDCAN "Message RAM", "FDCAN registers") ================== */

/** FDCAN1 register block (RM0444 memory map: APB 0x4000 6400). */
#define URB_CM0_FDCAN1_BASE 0x40006400u
/** FDCAN message RAM of FDCAN1 (RM0444 memory map: SRAMCAN 0x4000 B400; FDCAN2's follows at +0x350). */
#define URB_CM0_SRAMCAN1_BASE 0x4000B400u
/** Bytes of one instance's message RAM (RM0444 FDCAN "Message RAM": 212 words). */
#define URB_CM0_SRAMCAN_BYTES 0x350u
/** Elements of each FIFO in the fixed message RAM layout (RM0444 FDCAN "Message RAM"). */
#define URB_CM0_FDCAN_RX_ELEMENTS 3u
#define URB_CM0_FDCAN_TX_ELEMENTS 3u
/** Words of an Rx / Tx buffer element (header 2 + 64 data bytes; classic CAN uses 2 + 2). */
#define URB_CM0_FDCAN_ELEMENT_WORDS 18u

/** The FDCAN register block at its documented offsets (RM0444 "FDCAN register map"). */
typedef struct {
    volatile uint32_t crel;      /**< 0x000 core release */
    volatile uint32_t endn;      /**< 0x004 endian */
    volatile uint32_t rsvd0;     /**< 0x008 */
    volatile uint32_t dbtp;      /**< 0x00C data bit timing (FD only) */
    volatile uint32_t test;      /**< 0x010 test */
    volatile uint32_t rwd;       /**< 0x014 RAM watchdog */
    volatile uint32_t cccr;      /**< 0x018 CC control */
    volatile uint32_t nbtp;      /**< 0x01C nominal bit timing and prescaler */
    volatile uint32_t tscc;      /**< 0x020 timestamp counter configuration */
    volatile uint32_t tscv;      /**< 0x024 timestamp counter value */
    volatile uint32_t tocc;      /**< 0x028 timeout counter configuration */
    volatile uint32_t tocv;      /**< 0x02C timeout counter value */
    volatile uint32_t rsvd1[4];  /**< 0x030..0x03C */
    volatile uint32_t ecr;       /**< 0x040 error counters */
    volatile uint32_t psr;       /**< 0x044 protocol status */
    volatile uint32_t tdcr;      /**< 0x048 transmitter delay compensation */
    volatile uint32_t rsvd2;     /**< 0x04C */
    volatile uint32_t ir;        /**< 0x050 interrupt flags (write 1 to clear) */
    volatile uint32_t ie;        /**< 0x054 interrupt enable */
    volatile uint32_t ils;       /**< 0x058 interrupt line select */
    volatile uint32_t ile;       /**< 0x05C interrupt line enable */
    volatile uint32_t rsvd3[8];  /**< 0x060..0x07C */
    volatile uint32_t rxgfc;     /**< 0x080 global filter configuration */
    volatile uint32_t xidam;     /**< 0x084 extended ID AND mask */
    volatile uint32_t hpms;      /**< 0x088 high-priority message status */
    volatile uint32_t rsvd4;     /**< 0x08C */
    volatile uint32_t rxf0s;     /**< 0x090 Rx FIFO 0 status */
    volatile uint32_t rxf0a;     /**< 0x094 Rx FIFO 0 acknowledge */
    volatile uint32_t rxf1s;     /**< 0x098 Rx FIFO 1 status */
    volatile uint32_t rxf1a;     /**< 0x09C Rx FIFO 1 acknowledge */
    volatile uint32_t rsvd5[8];  /**< 0x0A0..0x0BC */
    volatile uint32_t txbc;      /**< 0x0C0 Tx buffer configuration */
    volatile uint32_t txfqs;     /**< 0x0C4 Tx FIFO/queue status */
    volatile uint32_t txbrp;     /**< 0x0C8 Tx buffer request pending */
    volatile uint32_t txbar;     /**< 0x0CC Tx buffer add request */
    volatile uint32_t txbcr;     /**< 0x0D0 Tx buffer cancellation request */
    volatile uint32_t txbto;     /**< 0x0D4 Tx buffer transmission occurred */
    volatile uint32_t txbcf;     /**< 0x0D8 Tx buffer cancellation finished */
    volatile uint32_t txbtie;    /**< 0x0DC Tx buffer transmission interrupt enable */
    volatile uint32_t txbcie;    /**< 0x0E0 Tx buffer cancellation finished interrupt enable */
    volatile uint32_t txefs;     /**< 0x0E4 Tx event FIFO status */
    volatile uint32_t txefa;     /**< 0x0E8 Tx event FIFO acknowledge */
} urb_cm0_fdcan_regs_t;

/** One Rx or Tx buffer element: word 0 identifier and flags, word 1 DLC and marker/time stamp,
 *  words 2.. the data bytes, byte 0 in the least significant byte (RM0444 FDCAN "Rx buffer and FIFO
 *  element", "Tx buffer element"). */
typedef struct {
    volatile uint32_t word[URB_CM0_FDCAN_ELEMENT_WORDS];
} urb_cm0_fdcan_element_t;

/** One instance's message RAM (RM0444 FDCAN "Message RAM": the fixed layout). */
typedef struct {
    volatile uint32_t std_filter[28];                              /**< 0x000 11-bit filters */
    volatile uint32_t ext_filter[16];                              /**< 0x070 29-bit filters (2 words each) */
    urb_cm0_fdcan_element_t rx_fifo0[URB_CM0_FDCAN_RX_ELEMENTS];   /**< 0x0B0 */
    urb_cm0_fdcan_element_t rx_fifo1[URB_CM0_FDCAN_RX_ELEMENTS];   /**< 0x188 */
    volatile uint32_t tx_event[2u * URB_CM0_FDCAN_TX_ELEMENTS];    /**< 0x260 Tx event FIFO (2 words each) */
    urb_cm0_fdcan_element_t tx_buffer[URB_CM0_FDCAN_TX_ELEMENTS];  /**< 0x278 Tx FIFO/queue */
} urb_cm0_fdcan_ram_t;

/** The part's FDCAN1 and its message RAM, for the vector-table glue. */
#define URB_CM0_FDCAN1 ((urb_cm0_fdcan_regs_t *)URB_CM0_FDCAN1_BASE)
#define URB_CM0_SRAMCAN1 ((urb_cm0_fdcan_ram_t *)URB_CM0_SRAMCAN1_BASE)

/* ===== Bit timing ============================================================================ */

/** Nominal bit timing in time quanta (RM0444 FDCAN "Bit timing": bit = (1 + tseg1 + tseg2) tq, tq = brp /
 *  fdcan_ker_ck), before the registers' minus-one encoding. */
typedef struct {
    uint16_t brp;   /**< prescaler 1..512 */
    uint16_t tseg1; /**< propagation + phase 1, 2..256 tq */
    uint8_t tseg2;  /**< phase 2, 2..128 tq */
    uint8_t sjw;    /**< resynchronisation jump width, 1..tseg2 */
} urb_cm0_can_timing_t;

/** Computes the bit timing for `bitrate_kbps` from the FDCAN kernel clock `kernel_hz`: the largest
 *  number of time quanta per bit from 25 down to 8 that divides the clock exactly (CiA 301's range),
 *  sample point at 87.5 % (CiA 301), SJW = tseg2 (2 or 3 with at most 25 quanta). False (nothing
 *  written) when no number of quanta in that range gives the rate exactly or the prescaler would
 *  exceed 512. At 48 MHz:
 *  1000 kb/s brp 2, 500 kb/s brp 4, 250 kb/s brp 8, each 24 tq = 1 + 20 + 3. O(18). */
bool urb_cm0_can_timing(uint32_t kernel_hz, uint32_t bitrate_kbps, urb_cm0_can_timing_t *out);

/** The NBTP register value of *t (RM0444 FDCAN_NBTP: NSJW[31:25], NBRP[24:16], NTSEG1[15:8],
 *  NTSEG2[6:0], each minus one). O(1). */
uint32_t urb_cm0_can_nbtp(const urb_cm0_can_timing_t *t);

/* ===== The port ============================================================================== */

/** What the port reports to its owner (the CAN slave or master), from the interrupt. */
typedef struct {
    void *owner; /**< passed to each callback */
    /** A frame arrived; `t_us` is its start of frame on the caller's microsecond clock. */
    void (*on_rx)(void *owner, const urb_can_frame_t *frame, uint32_t t_us);
    /** The oldest queued frame was sent. */
    void (*on_tx_done)(void *owner);
    /** Optional (NULL: not reported): the controller's urb_can_state_t changed to `state`. */
    void (*on_state)(void *owner, uint8_t state);
    /** The caller's free-running microsecond clock (the node's 1 MHz timer, the bridge's now_us). */
    uint32_t (*now_us)(void *owner);
} urb_cm0_can_owner_t;

/** Counters for diagnostics. */
typedef struct {
    uint32_t rx_lost;      /**< frames lost: Rx FIFO 0 was full (RF0L) */
    uint32_t events_lost;  /**< Tx events lost (TEFL): a frame-sent report may be missing */
    uint32_t stale_events; /**< frames sent after a tx_abort, not reported */
} urb_cm0_can_stats_t;

/** One CAN port; caller-owned; members other than `hal` are private. */
typedef struct {
    urb_can_hal_t hal;                /**< the downlink's view: pass &port->hal to the slave or master */
    urb_cm0_fdcan_regs_t *regs;
    urb_cm0_fdcan_ram_t *ram;
    urb_cm0_can_owner_t owner;
    uint32_t us_per_bit;              /**< time stamp counter unit (one bit time) in microseconds */
    uint8_t epoch;                    /**< abort generation, carried in each frame's message marker */
    uint8_t state;                    /**< last state reported to on_state */
    urb_cm0_can_stats_t stats;
} urb_cm0_can_t;

/** Initialises the controller at *regs with message RAM *ram for classic CAN at `bitrate_kbps`
 *  from `kernel_hz` (urb_cm0_can_timing; 1000 / `bitrate_kbps` must be a whole number of
 *  microseconds: 1000, 500, 250, 125 kb/s), accepting every 11-bit data frame into Rx FIFO 0
 *  (the slave and master filter by identifier), automatic retransmission on, interrupts on line 0
 *  for Rx FIFO 0 new element and lost, Tx event new element and lost, error-passive and bus-off;
 *  then joins the bus (leaves initialisation mode). The clock, the pins and the NVIC are the
 *  glue's. Fills port->hal (tx, tx_abort, state, recover, lock). False, with the controller left in
 *  initialisation mode, for a rate that urb_cm0_can_timing refuses or when the controller does not
 *  acknowledge the mode change within URB_CM0_CAN_SPIN polls. */
bool urb_cm0_can_init(urb_cm0_can_t *port, urb_cm0_fdcan_regs_t *regs, urb_cm0_fdcan_ram_t *ram,
                      const urb_cm0_can_owner_t *owner, uint32_t kernel_hz, uint32_t bitrate_kbps);

/** Polls of CCCR.INIT granted to the controller for a mode change (RM0444 FDCAN "Operating modes": it follows
 *  within two kernel clocks plus a started frame). */
#define URB_CM0_CAN_SPIN 100000u

/** The controller's interrupt (line 0): reports sent frames, received frames and state changes to
 *  the owner, acknowledging each FIFO element and flag. At most 3 + 3 elements per call. */
void urb_cm0_can_irq(urb_cm0_can_t *port);

/** Copies the counters into *out. */
void urb_cm0_can_stats(const urb_cm0_can_t *port, urb_cm0_can_stats_t *out);

#ifdef __cplusplus
}
#endif

#endif /* URB_CM0_FDCAN_H */
