/*
 * Register-level RS485 port for the STM32G0B1 (Cortex-M0+): a USART in RS485 mode with hardware
 * driver enable, as the urb_rs485_hal_t that the RS485 downlink's slave (node) and master (bridge)
 * drive (urb_rs485.h, urb_rs485_slave.h, urb_rs485_master.h).
 *
 * Reference: RM0444, chapter "Universal synchronous/asynchronous receiver transmitter
 * (USART)": section "RS232 hardware flow control and RS485 driver enable" (DEM, DEP, DEAT, DEDT)
 * and "USART registers" (the offsets of urb_cm0_usart_regs_t). The register block is reached through
 * the pointer passed to urb_cm0_rs485_init(): the glue passes URB_CM0_USART1, the unit tests
 * (tests/firmware/cm0hal/) a RAM block laid out as the part's.
 *
 * The turnaround is the USART's: with DEM set it drives the DE pin (USART1_DE on PA12, alternate
 * function 1) DEAT sixteenths of a bit before the first start bit and releases it DEDT sixteenths
 * after the last stop bit, so no software timing is involved. The transceiver's receiver stays on
 * (/RE tied low): the bridge checks its own echo for collisions (urb_rs485_master.h).
 *  - tx_start: transmitter on, transmit-empty interrupt on; the interrupt pulls bytes from the
 *    owner (on_tx_next) until it has none, then waits for transmission complete (the last stop
 *    bit) and reports nothing further: the hardware has released DE by then.
 *  - tx_abort: the USART is disabled for a moment (UE cleared: the character being sent and a
 *    byte waiting in TDR are discarded and DE drops at once), then re-enabled with the receiver on
 *    and the transmitter off until the next tx_start.
 *  - each received byte goes to on_rx with the time of the receive interrupt on the caller's
 *    microsecond clock (its stop bit was sampled at most one interrupt latency earlier);
 *  - wake_at and lock are the caller's (a timer compare and the NVIC), passed through.
 * Eight data bits, no parity, one stop bit (URB_RS485_CHAR_BITS), oversampling by 16.
 * No heap, no globals: the caller owns urb_cm0_rs485_t.
 */
#ifndef URB_CM0_USART485_H
#define URB_CM0_USART485_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_rs485.h"

#ifdef __cplusplus
extern "C" {
#endif

/** USART1 register block (RM0444 memory map: APB 0x4001 3800). */
#define URB_CM0_USART1_BASE 0x40013800u

/** The USART register block at its documented offsets (RM0444, "USART register map"). */
typedef struct {
    volatile uint32_t cr1;   /**< 0x00 control 1 */
    volatile uint32_t cr2;   /**< 0x04 control 2 */
    volatile uint32_t cr3;   /**< 0x08 control 3 */
    volatile uint32_t brr;   /**< 0x0C baud rate */
    volatile uint32_t gtpr;  /**< 0x10 guard time and prescaler */
    volatile uint32_t rtor;  /**< 0x14 receiver timeout */
    volatile uint32_t rqr;   /**< 0x18 request */
    volatile uint32_t isr;   /**< 0x1C interrupt and status */
    volatile uint32_t icr;   /**< 0x20 interrupt flag clear */
    volatile uint32_t rdr;   /**< 0x24 receive data */
    volatile uint32_t tdr;   /**< 0x28 transmit data */
    volatile uint32_t presc; /**< 0x2C prescaler */
} urb_cm0_usart_regs_t;

/** The part's USART1, for the vector-table glue. */
#define URB_CM0_USART1 ((urb_cm0_usart_regs_t *)URB_CM0_USART1_BASE)

/* Register bits the port uses (RM0444, "USART registers"; FIFO mode off). */
#define URB_CM0_USART_CR1_UE ((uint32_t)1u << 0)     /**< USART enable */
#define URB_CM0_USART_CR1_RE ((uint32_t)1u << 2)     /**< receiver enable */
#define URB_CM0_USART_CR1_TE ((uint32_t)1u << 3)     /**< transmitter enable */
#define URB_CM0_USART_CR1_RXNEIE ((uint32_t)1u << 5) /**< receive-not-empty (and overrun) interrupt */
#define URB_CM0_USART_CR1_TCIE ((uint32_t)1u << 6)   /**< transmission-complete interrupt */
#define URB_CM0_USART_CR1_TXEIE ((uint32_t)1u << 7)  /**< transmit-data-empty interrupt */
#define URB_CM0_USART_CR1_DEDT_SHIFT 16u             /**< DE deassertion time, 1/16 bit, 5 bits */
#define URB_CM0_USART_CR1_DEAT_SHIFT 21u             /**< DE assertion time, 1/16 bit, 5 bits */
#define URB_CM0_USART_CR3_DEM ((uint32_t)1u << 14)   /**< driver enable mode */
#define URB_CM0_USART_CR3_DEP ((uint32_t)1u << 15)   /**< driver enable polarity: 1 = active low */
#define URB_CM0_USART_ISR_PE ((uint32_t)1u << 0)     /**< parity error */
#define URB_CM0_USART_ISR_FE ((uint32_t)1u << 1)     /**< framing error */
#define URB_CM0_USART_ISR_NE ((uint32_t)1u << 2)     /**< noise */
#define URB_CM0_USART_ISR_ORE ((uint32_t)1u << 3)    /**< overrun */
#define URB_CM0_USART_ISR_RXNE ((uint32_t)1u << 5)   /**< a byte in RDR */
#define URB_CM0_USART_ISR_TC ((uint32_t)1u << 6)     /**< transmission complete (last stop bit sent) */
#define URB_CM0_USART_ISR_TXE ((uint32_t)1u << 7)    /**< TDR empty */
#define URB_CM0_USART_ICR_TCCF ((uint32_t)1u << 6)   /**< clears TC */

/** DE lead and lag in sixteenths of a bit (DEAT, DEDT; at most 31): one bit time each, which covers
 *  a transceiver's driver enable and disable times (tens of ns to 1 us) up to 1 Mb/s. */
#define URB_CM0_RS485_DE_SIXTEENTHS 16u

/** What the port reports to its owner (the RS485 slave or master), from the interrupt. */
typedef struct {
    void *owner; /**< passed to each callback */
    /** A byte was received at `t_us` on the caller's microsecond clock. */
    void (*on_rx)(void *owner, uint8_t byte, uint32_t t_us);
    /** The transmitter can take a byte: true and *byte, or false when the frame is all sent. */
    bool (*on_tx_next)(void *owner, uint8_t *byte);
    /** The caller's free-running microsecond clock. */
    uint32_t (*now_us)(void *owner);
    /** Optional, passed through as urb_rs485_hal_t.wake_at (the node's silence timer). */
    void (*wake_at)(void *owner, uint32_t at_us);
    /** Optional, passed through as urb_rs485_hal_t.lock (masks this USART's interrupt). */
    void (*lock)(void *owner, bool locked);
} urb_cm0_rs485_owner_t;

/** Counters for diagnostics. */
typedef struct {
    uint32_t overruns;   /**< bytes lost: a byte arrived before the last was read (ORE) */
    uint32_t line_errors; /**< bytes received with a framing or noise error (still delivered) */
} urb_cm0_rs485_stats_t;

/** One RS485 port; caller-owned; members other than `hal` are private. */
typedef struct {
    urb_rs485_hal_t hal;  /**< the downlink's view: pass &port->hal to the slave or master */
    urb_cm0_usart_regs_t *regs;
    urb_cm0_rs485_owner_t owner;
    bool sending;         /**< between tx_start and the last stop bit (or tx_abort) */
    urb_cm0_rs485_stats_t stats;
} urb_cm0_rs485_t;

/** The BRR value for `baud` from the USART kernel clock `kernel_hz` with oversampling by 16:
 *  kernel_hz / baud rounded to nearest; 0 when that is below 16 (the rate is out of reach). O(1). */
uint32_t urb_cm0_rs485_brr(uint32_t kernel_hz, uint32_t baud);

/** Initialises the USART at *regs for RS485 at `baud` from `kernel_hz`: 8N1, hardware driver
 *  enable active high with URB_CM0_RS485_DE_SIXTEENTHS of lead and lag, receiver and receive
 *  interrupt on, transmitter on. Fills port->hal (tx_start, tx_abort, and the owner's wake_at and
 *  lock). The clock, the pins (TX, RX, DE) and the NVIC are the glue's. False (USART left
 *  disabled) when urb_cm0_rs485_brr gives 0. */
bool urb_cm0_rs485_init(urb_cm0_rs485_t *port, urb_cm0_usart_regs_t *regs, const urb_cm0_rs485_owner_t *owner,
                        uint32_t kernel_hz, uint32_t baud);

/** The USART's interrupt: errors counted and cleared, a received byte to on_rx, a transmit slot
 *  filled from on_tx_next, the end of transmission noted. O(1). */
void urb_cm0_rs485_irq(urb_cm0_rs485_t *port);

/** True between tx_start and the end of the frame's last stop bit (or tx_abort). */
bool urb_cm0_rs485_sending(const urb_cm0_rs485_t *port);

/** Copies the counters into *out. */
void urb_cm0_rs485_stats(const urb_cm0_rs485_t *port, urb_cm0_rs485_stats_t *out);

#ifdef __cplusplus
}
#endif

#endif /* URB_CM0_USART485_H */
