/*
 * STM32G0B1 USART in RS485 mode as the RS485 downlink's transceiver: urb_cm0_usart485.h. Nothing
 * here touches a fixed address: the register block comes in through urb_cm0_rs485_init().
 */
#include "urb_cm0_usart485.h"

#include <stddef.h>

#define BRR_MIN 16u /* oversampling by 16: BRR >= 16 (RM0444, "USART baud rate generation") */
#define DE_FIELD_MASK ((uint32_t)0x1Fu)
#define ISR_ERRORS (URB_CM0_USART_ISR_PE | URB_CM0_USART_ISR_FE | URB_CM0_USART_ISR_NE | URB_CM0_USART_ISR_ORE)

/* The host tests' USART model (tests/firmware/cm0hal/usart_line.h) cannot see a register value that
 * is written and overwritten within one call; tx_abort's "USART off" is such a value, so a test
 * build reports it to the model. Firmware builds define nothing. */
#if defined(URB_CM0_USART_TEST_HOOK)
void urb_cm0_usart_test_disabled(urb_cm0_usart_regs_t *regs);
#define REPORT_DISABLED(regs) urb_cm0_usart_test_disabled(regs)
#else
#define REPORT_DISABLED(regs) ((void)(regs))
#endif

uint32_t urb_cm0_rs485_brr(uint32_t kernel_hz, uint32_t baud)
{
    if (baud == 0u) {
        return 0u;
    }
    uint32_t const brr = (kernel_hz + (baud / 2u)) / baud;
    return (brr >= BRR_MIN) ? brr : 0u;
}

static void rs485_tx_start(void *ctx)
{
    urb_cm0_rs485_t *p = (urb_cm0_rs485_t *)ctx;
    p->sending = true;
    p->regs->icr = URB_CM0_USART_ICR_TCCF;
    p->regs->cr1 = (p->regs->cr1 & ~URB_CM0_USART_CR1_TCIE) | URB_CM0_USART_CR1_TE | URB_CM0_USART_CR1_TXEIE;
}

static void rs485_tx_abort(void *ctx)
{
    urb_cm0_rs485_t *p = (urb_cm0_rs485_t *)ctx;
    uint32_t const cr1 = p->regs->cr1 & ~(URB_CM0_USART_CR1_TXEIE | URB_CM0_USART_CR1_TCIE | URB_CM0_USART_CR1_TE);
    /* UE cleared: the character being sent and the byte waiting in TDR are discarded and DE is
     * released at once (clearing TE alone would finish the character and send TDR at the next
     * tx_start); then the receiver is back on, the transmitter off until tx_start */
    p->regs->cr1 = cr1 & ~URB_CM0_USART_CR1_UE;
    REPORT_DISABLED(p->regs);
    p->regs->cr1 = cr1 | URB_CM0_USART_CR1_UE;
    p->sending = false;
}

static void rs485_wake_at(void *ctx, uint32_t at_us)
{
    urb_cm0_rs485_t *p = (urb_cm0_rs485_t *)ctx;
    p->owner.wake_at(p->owner.owner, at_us);
}

static void rs485_lock(void *ctx, bool locked)
{
    urb_cm0_rs485_t *p = (urb_cm0_rs485_t *)ctx;
    p->owner.lock(p->owner.owner, locked);
}

bool urb_cm0_rs485_init(urb_cm0_rs485_t *port, urb_cm0_usart_regs_t *regs, const urb_cm0_rs485_owner_t *owner,
                        uint32_t kernel_hz, uint32_t baud)
{
    port->regs = regs;
    port->owner = *owner;
    port->sending = false;
    port->stats.overruns = 0u;
    port->stats.line_errors = 0u;
    port->hal.ctx = port;
    port->hal.tx_start = rs485_tx_start;
    port->hal.tx_abort = rs485_tx_abort;
    port->hal.wake_at = (owner->wake_at != NULL) ? rs485_wake_at : NULL;
    port->hal.lock = (owner->lock != NULL) ? rs485_lock : NULL;
    regs->cr1 = 0u; /* UE off: the configuration below may only change while the USART is disabled */
    uint32_t const brr = urb_cm0_rs485_brr(kernel_hz, baud);
    if (brr == 0u) {
        return false;
    }
    regs->brr = brr;
    regs->presc = 0u;
    regs->cr2 = 0u; /* one stop bit, no receiver timeout */
    regs->cr3 = URB_CM0_USART_CR3_DEM; /* DEP = 0: DE active high */
    regs->icr = ISR_ERRORS | URB_CM0_USART_ICR_TCCF;
    regs->cr1 = (((uint32_t)URB_CM0_RS485_DE_SIXTEENTHS & DE_FIELD_MASK) << URB_CM0_USART_CR1_DEAT_SHIFT) |
                (((uint32_t)URB_CM0_RS485_DE_SIXTEENTHS & DE_FIELD_MASK) << URB_CM0_USART_CR1_DEDT_SHIFT) |
                URB_CM0_USART_CR1_RXNEIE | URB_CM0_USART_CR1_RE | URB_CM0_USART_CR1_TE | URB_CM0_USART_CR1_UE;
    return true;
}

void urb_cm0_rs485_irq(urb_cm0_rs485_t *port)
{
    urb_cm0_usart_regs_t *const regs = port->regs;
    uint32_t const isr = regs->isr;
    uint32_t const cr1 = regs->cr1;
    if ((isr & ISR_ERRORS) != 0u) {
        regs->icr = isr & ISR_ERRORS;
        if ((isr & URB_CM0_USART_ISR_ORE) != 0u) {
            port->stats.overruns++;
        }
        if ((isr & (URB_CM0_USART_ISR_FE | URB_CM0_USART_ISR_NE | URB_CM0_USART_ISR_PE)) != 0u) {
            port->stats.line_errors++;
        }
    }
    if ((isr & URB_CM0_USART_ISR_RXNE) != 0u) {
        uint8_t const byte = (uint8_t)(regs->rdr & 0xFFu);
        port->owner.on_rx(port->owner.owner, byte, port->owner.now_us(port->owner.owner));
    }
    if (((cr1 & URB_CM0_USART_CR1_TXEIE) != 0u) && ((isr & URB_CM0_USART_ISR_TXE) != 0u)) {
        uint8_t byte = 0u;
        if (port->owner.on_tx_next(port->owner.owner, &byte)) {
            regs->tdr = byte;
        } else {
            /* all bytes handed over: the USART releases DE DEDT after the last stop bit (TC) */
            regs->cr1 = (regs->cr1 & ~URB_CM0_USART_CR1_TXEIE) | URB_CM0_USART_CR1_TCIE;
        }
    }
    if (((cr1 & URB_CM0_USART_CR1_TCIE) != 0u) && ((isr & URB_CM0_USART_ISR_TC) != 0u)) {
        regs->icr = URB_CM0_USART_ICR_TCCF;
        regs->cr1 &= ~URB_CM0_USART_CR1_TCIE;
        port->sending = false;
    }
}

bool urb_cm0_rs485_sending(const urb_cm0_rs485_t *port)
{
    return port->sending;
}

void urb_cm0_rs485_stats(const urb_cm0_rs485_t *port, urb_cm0_rs485_stats_t *out)
{
    *out = port->stats;
}
