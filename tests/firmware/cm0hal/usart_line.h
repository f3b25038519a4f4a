/*
 * A behavioural model of the STM32G0 USART's transmitter, receiver and RS485 driver-enable output
 * (RM0444, USART chapter: "RS485 driver enable", "Transmitter", "Receiver"), acting on a RAM copy of
 * the register block, so that the register-level port (urb_cm0_usart485.c) can be run on the host
 * and the DE pin's level be traced against the bits on the line.
 *
 * Time advances in sixteenths of a bit (the USART's sample clock with oversampling by 16). The model
 * reads the registers the port writes and sets the ones the hardware sets:
 *  - a byte written to TDR (the model keeps TDR at USART_LINE_TDR_EMPTY while it holds none) is
 *    taken when the shift register is free: with DEM, DE is asserted DEAT sixteenths before the start
 *    bit; the 10 bits of the character follow; back-to-back characters keep DE asserted; after the
 *    last stop bit TC is set and DE released DEDT sixteenths later; ISR.TXE mirrors TDR being empty;
 *  - TE cleared: the character in the shift register completes, a byte waiting in TDR is not sent;
 *  - DEP set makes DE active low (the pin level the model traces is the electrical one);
 *  - the receiver hears the line (the transceiver's receiver stays on): each character sent is
 *    received at its stop bit (RXNE, RDR; ORE when RXNE was still set);
 *  - writes to ICR clear the flags they name (the model clears ICR after reading it);
 *  - UE cleared (reported by the port's test hook, urb_cm0_usart485.c URB_CM0_USART_TEST_HOOK): the
 *    character being sent and TDR are discarded at once, the flags reset.
 * usart_line_step() calls the port's interrupt handler whenever an enabled flag is set.
 */
#ifndef USART_LINE_H
#define USART_LINE_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_cm0_usart485.h"

#define USART_LINE_TDR_EMPTY 0xFFFFFFFFu
#define USART_LINE_MAX_BYTES 64u
#define USART_LINE_CHAR 160u /* sixteenths of a 10-bit character */

typedef struct {
    urb_cm0_usart_regs_t regs;   /* the register block the port is given */
    urb_cm0_rs485_t *port;       /* its interrupt handler is called by usart_line_step */
    uint32_t t;                  /* now, in sixteenths of a bit */
    uint8_t phase;               /* idle, lead (DE before the start bit), shift, lag (DE after the stop bit) */
    uint32_t count;              /* sixteenths left in the phase */
    uint8_t shift;               /* the character being sent */
    bool de;                     /* DE pin level (electrical, high = 1) */
    /* trace */
    uint32_t de_rises, de_falls; /* edges of the DE pin */
    uint32_t de_rise_t, de_fall_t;
    uint32_t first_start_t;      /* start bit of the first character */
    uint32_t last_stop_end_t;    /* end of the last character's stop bit */
    uint8_t sent[USART_LINE_MAX_BYTES];
    uint32_t n_sent;
    uint32_t irqs;
    uint32_t disables;           /* times the port switched the USART off (its abort) */
} usart_line_t;

/** Zeroes the model and its registers: TDR empty, TXE set, DE low. */
void usart_line_reset(usart_line_t *line);

/** Advances one sixteenth of a bit and calls the port's interrupt when an enabled flag is set. */
void usart_line_step(usart_line_t *line);

/** Runs usart_line_step `n` times. */
void usart_line_run(usart_line_t *line, uint32_t n);

/** A byte from another station arrives now (RXNE, RDR; ORE when the last was not read). */
void usart_line_receive(usart_line_t *line, uint8_t byte);

/** The port read RDR (a read has no side effect on a RAM register block: the test's on_rx, which
 *  the port calls with the byte it read, calls this to clear RXNE as the hardware does). */
void usart_line_rdr_read(usart_line_t *line);

#endif /* USART_LINE_H */
