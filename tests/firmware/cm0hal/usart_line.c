/* The USART model of usart_line.h. */
#include "usart_line.h"

#include <string.h>

enum { PHASE_IDLE = 0, PHASE_LEAD = 1, PHASE_SHIFT = 2, PHASE_LAG = 3 };

#define DE_FIELD(cr1, shift) (((cr1) >> (shift)) & 0x1Fu)

/* The line the port's abort reports to (one model at a time in a test program). */
static usart_line_t *current_line;

void urb_cm0_usart_test_disabled(urb_cm0_usart_regs_t *regs);

void urb_cm0_usart_test_disabled(urb_cm0_usart_regs_t *regs)
{
    usart_line_t *const line = current_line;
    if ((line == NULL) || (&line->regs != regs) || ((regs->cr1 & URB_CM0_USART_CR1_UE) != 0u)) {
        return;
    }
    /* UE cleared: current operations discarded, status flags reset (TXE reads 1 again once enabled) */
    line->phase = PHASE_IDLE;
    regs->tdr = USART_LINE_TDR_EMPTY;
    regs->isr = URB_CM0_USART_ISR_TXE;
    line->disables++;
}

void usart_line_reset(usart_line_t *line)
{
    urb_cm0_rs485_t *const port = line->port;
    memset(line, 0, sizeof *line);
    line->port = port;
    line->regs.tdr = USART_LINE_TDR_EMPTY;
    line->regs.isr = URB_CM0_USART_ISR_TXE;
    line->first_start_t = UINT32_MAX;
    current_line = line;
}

void usart_line_receive(usart_line_t *line, uint8_t byte)
{
    if ((line->regs.cr1 & URB_CM0_USART_CR1_RE) == 0u) {
        return;
    }
    if ((line->regs.isr & URB_CM0_USART_ISR_RXNE) != 0u) {
        line->regs.isr |= URB_CM0_USART_ISR_ORE;
    }
    line->regs.rdr = byte;
    line->regs.isr |= URB_CM0_USART_ISR_RXNE;
}

static bool enabled(const urb_cm0_usart_regs_t *r, uint32_t bit)
{
    return (r->cr1 & bit) != 0u;
}

static void load(usart_line_t *line)
{
    line->shift = (uint8_t)line->regs.tdr;
    line->regs.tdr = USART_LINE_TDR_EMPTY;
    if (line->first_start_t == UINT32_MAX) {
        line->first_start_t = line->t;
    }
    line->phase = PHASE_SHIFT;
    line->count = USART_LINE_CHAR;
}

static void transmitter(usart_line_t *line)
{
    urb_cm0_usart_regs_t *const r = &line->regs;
    bool const te = enabled(r, URB_CM0_USART_CR1_TE) && enabled(r, URB_CM0_USART_CR1_UE);
    bool const dem = (r->cr3 & URB_CM0_USART_CR3_DEM) != 0u;
    bool const waiting = te && (r->tdr != USART_LINE_TDR_EMPTY);
    switch (line->phase) {
    case PHASE_IDLE:
        if (waiting) {
            r->isr &= ~URB_CM0_USART_ISR_TC;
            line->phase = PHASE_LEAD;
            line->count = dem ? DE_FIELD(r->cr1, URB_CM0_USART_CR1_DEAT_SHIFT) : 0u;
            if (line->count == 0u) {
                load(line);
            }
        }
        break;
    case PHASE_LEAD:
        if (!te) {
            line->phase = PHASE_IDLE;
        } else if (--line->count == 0u) {
            load(line);
        }
        break;
    case PHASE_SHIFT:
        if (--line->count == 0u) {
            if (line->n_sent < USART_LINE_MAX_BYTES) {
                line->sent[line->n_sent] = line->shift;
            }
            line->n_sent++;
            line->last_stop_end_t = line->t;
            usart_line_receive(line, line->shift); /* our own echo */
            if (waiting) {
                load(line);
            } else {
                r->isr |= URB_CM0_USART_ISR_TC;
                line->phase = PHASE_LAG;
                line->count = dem ? DE_FIELD(r->cr1, URB_CM0_USART_CR1_DEDT_SHIFT) : 0u;
                if (line->count == 0u) {
                    line->phase = PHASE_IDLE;
                }
            }
        }
        break;
    default: /* PHASE_LAG */
        if (waiting) {
            load(line);
        } else if (--line->count == 0u) {
            line->phase = PHASE_IDLE;
        }
        break;
    }
    r->isr = (r->tdr == USART_LINE_TDR_EMPTY) ? (r->isr | URB_CM0_USART_ISR_TXE) : (r->isr & ~URB_CM0_USART_ISR_TXE);
}

void usart_line_step(usart_line_t *line)
{
    urb_cm0_usart_regs_t *const r = &line->regs;
    if (r->icr != 0u) { /* write 1 to clear */
        r->isr &= ~r->icr;
        r->icr = 0u;
    }
    transmitter(line);
    bool const active = ((r->cr3 & URB_CM0_USART_CR3_DEM) != 0u) && (line->phase != PHASE_IDLE);
    bool const level = ((r->cr3 & URB_CM0_USART_CR3_DEP) != 0u) ? !active : active;
    if (level && !line->de) {
        line->de_rises++;
        line->de_rise_t = line->t;
    } else if (!level && line->de) {
        line->de_falls++;
        line->de_fall_t = line->t;
    }
    line->de = level;
    line->t++;
    uint32_t const rx_flags = URB_CM0_USART_ISR_RXNE | URB_CM0_USART_ISR_ORE;
    bool const irq = (enabled(r, URB_CM0_USART_CR1_RXNEIE) && ((r->isr & rx_flags) != 0u)) ||
                     (enabled(r, URB_CM0_USART_CR1_TXEIE) && ((r->isr & URB_CM0_USART_ISR_TXE) != 0u)) ||
                     (enabled(r, URB_CM0_USART_CR1_TCIE) && ((r->isr & URB_CM0_USART_ISR_TC) != 0u));
    if (irq && (line->port != NULL)) {
        line->irqs++;
        urb_cm0_rs485_irq(line->port);
        if (r->icr != 0u) {
            r->isr &= ~r->icr;
            r->icr = 0u;
        }
    }
}

void usart_line_rdr_read(usart_line_t *line)
{
    line->regs.isr &= ~URB_CM0_USART_ISR_RXNE;
}

void usart_line_run(usart_line_t *line, uint32_t n)
{
    for (uint32_t i = 0u; i < n; i++) {
        usart_line_step(line);
    }
}
