/*
 * STM32G0B1 FDCAN as the CAN downlink's controller: urb_cm0_fdcan.h. Register fields below are
 * RM0444's (FDCAN chapter, "FDCAN registers"; the G0's compact interrupt register, whose 24 flags
 * are not at the Bosch M_CAN positions). Nothing here touches a fixed address: the register block
 * and the message RAM come in through urb_cm0_can_init().
 */
#include "urb_cm0_fdcan.h"

#include <stddef.h>

/* CCCR (CC control) */
#define CCCR_INIT ((uint32_t)1u << 0)   /* initialisation mode (set by hardware at bus-off) */
#define CCCR_CCE ((uint32_t)1u << 1)    /* configuration change enable (with INIT) */
#define CCCR_DAR ((uint32_t)1u << 6)    /* disable automatic retransmission (kept 0: CAN repeats) */
#define CCCR_FDOE ((uint32_t)1u << 8)   /* FD operation (kept 0: classic CAN) */
#define CCCR_BRSE ((uint32_t)1u << 9)   /* bit-rate switching (kept 0) */

/* NBTP field positions */
#define NBTP_NSJW_SHIFT 25u
#define NBTP_NBRP_SHIFT 16u
#define NBTP_NTSEG1_SHIFT 8u

/* TSCC: time stamp counter counting bit times (TSS = 01), prescaler TCP = 1 */
#define TSCC_TSS_INTERNAL ((uint32_t)1u << 0)
#define TSCV_MASK 0xFFFFu

/* PSR (protocol status) */
#define PSR_EP ((uint32_t)1u << 5) /* error passive */
#define PSR_BO ((uint32_t)1u << 7) /* bus-off */

/* IR / IE (the G0 layout) */
#define IR_RF0N ((uint32_t)1u << 0)  /* Rx FIFO 0 new message */
#define IR_RF0L ((uint32_t)1u << 2)  /* Rx FIFO 0 message lost */
#define IR_TEFN ((uint32_t)1u << 10) /* Tx event FIFO new entry */
#define IR_TEFL ((uint32_t)1u << 12) /* Tx event FIFO element lost */
#define IR_EP ((uint32_t)1u << 17)   /* error-passive status changed */
#define IR_BO ((uint32_t)1u << 19)   /* bus-off status changed */
#define IR_USED (IR_RF0N | IR_RF0L | IR_TEFN | IR_TEFL | IR_EP | IR_BO)
#define ILE_EINT0 ((uint32_t)1u << 0)

/* RXGFC: non-matching 11-bit frames to Rx FIFO 0 (ANFS = 00), 29-bit rejected (ANFE = 10),
 * remote frames rejected (RRFS, RRFE), no filter elements (LSS = LSE = 0). */
#define RXGFC_RRFE ((uint32_t)1u << 0)
#define RXGFC_RRFS ((uint32_t)1u << 1)
#define RXGFC_ANFE_REJECT ((uint32_t)2u << 2)
#define RXGFC_URB (RXGFC_RRFE | RXGFC_RRFS | RXGFC_ANFE_REJECT)

/* Rx FIFO 0 status / acknowledge */
#define RXF0S_F0FL_MASK 0xFu
#define RXF0S_F0GI_SHIFT 8u
#define RXF0S_F0GI_MASK 0x3u

/* Tx FIFO: TXBC.TFQM = 0 is FIFO mode (frames leave in the order queued) */
#define TXFQS_TFQPI_SHIFT 16u
#define TXFQS_TFQPI_MASK 0x3u
#define TXFQS_TFQF ((uint32_t)1u << 21) /* Tx FIFO full */

/* Tx event FIFO status */
#define TXEFS_EFFL_MASK 0x7u
#define TXEFS_EFGI_SHIFT 8u
#define TXEFS_EFGI_MASK 0x3u

/* Buffer elements (Tx: T0, T1; Rx: R0, R1; Tx event: E0, E1) */
#define ELEM_XTD ((uint32_t)1u << 30)
#define ELEM_RTR ((uint32_t)1u << 29)
#define ELEM_STD_ID_SHIFT 18u
#define ELEM_STD_ID_MASK 0x7FFu
#define ELEM_DLC_SHIFT 16u
#define ELEM_DLC_MASK 0xFu
#define ELEM_FDF ((uint32_t)1u << 21)
#define T1_EFC ((uint32_t)1u << 23)  /* store a Tx event */
#define T1_MM_SHIFT 24u              /* message marker, copied into the event's E1 */
#define E1_MM_SHIFT 24u
#define R1_RXTS_MASK 0xFFFFu         /* time stamp at the start of frame */

/* Bit timing search (CiA 301: 8..25 tq per bit, sample point 87.5 %) */
#define TQ_MAX 25u
#define TQ_MIN 8u
#define BRP_MAX 512u

bool urb_cm0_can_timing(uint32_t kernel_hz, uint32_t bitrate_kbps, urb_cm0_can_timing_t *out)
{
    if ((bitrate_kbps == 0u) || (out == NULL)) {
        return false;
    }
    uint32_t const bps = bitrate_kbps * 1000u;
    /* bound: 18 candidate quanta counts */
    for (uint32_t tq = TQ_MAX; tq >= TQ_MIN; tq--) {
        uint32_t const per_bit = bps * tq;
        if ((kernel_hz % per_bit) == 0u) {
            uint32_t const brp = kernel_hz / per_bit;
            if ((brp >= 1u) && (brp <= BRP_MAX)) {
                /* tseg2 = tq / 8 rounded to nearest, at least 2: sample point 1 - tseg2/tq = 87.5 % */
                uint32_t tseg2 = (tq + 4u) / 8u;
                if (tseg2 < 2u) {
                    tseg2 = 2u;
                }
                out->brp = (uint16_t)brp;
                out->tseg2 = (uint8_t)tseg2;
                out->tseg1 = (uint16_t)(tq - 1u - tseg2);
                out->sjw = (uint8_t)tseg2; /* the largest jump phase 2 allows (2 or 3 here) */
                return true;
            }
        }
    }
    return false;
}

uint32_t urb_cm0_can_nbtp(const urb_cm0_can_timing_t *t)
{
    return (((uint32_t)t->sjw - 1u) << NBTP_NSJW_SHIFT) | (((uint32_t)t->brp - 1u) << NBTP_NBRP_SHIFT) |
           (((uint32_t)t->tseg1 - 1u) << NBTP_NTSEG1_SHIFT) | ((uint32_t)t->tseg2 - 1u);
}

/* Sets or clears CCCR.INIT and waits (bounded) until the controller reports it. */
static bool fdcan_set_init(urb_cm0_fdcan_regs_t *regs, bool on)
{
    if (on) {
        regs->cccr |= CCCR_INIT;
    } else {
        regs->cccr &= ~(CCCR_INIT | CCCR_CCE);
    }
    uint32_t const want = on ? CCCR_INIT : 0u;
    /* bound: URB_CM0_CAN_SPIN polls */
    for (uint32_t spin = 0u; spin < URB_CM0_CAN_SPIN; spin++) {
        if ((regs->cccr & CCCR_INIT) == want) {
            return true;
        }
    }
    return false;
}

static uint8_t fdcan_psr_state(uint32_t psr)
{
    uint8_t state = (uint8_t)URB_CAN_ERROR_ACTIVE;
    if ((psr & PSR_BO) != 0u) {
        state = (uint8_t)URB_CAN_BUS_OFF;
    } else if ((psr & PSR_EP) != 0u) {
        state = (uint8_t)URB_CAN_ERROR_PASSIVE;
    } else {
        state = (uint8_t)URB_CAN_ERROR_ACTIVE;
    }
    return state;
}

/* ----- urb_can_hal_t ----- */

static bool fdcan_tx(void *ctx, const urb_can_frame_t *frame)
{
    urb_cm0_can_t *p = (urb_cm0_can_t *)ctx;
    uint32_t const txfqs = p->regs->txfqs;
    if ((txfqs & TXFQS_TFQF) != 0u) {
        return false;
    }
    uint32_t const put = (txfqs >> TXFQS_TFQPI_SHIFT) & TXFQS_TFQPI_MASK;
    if (put >= URB_CM0_FDCAN_TX_ELEMENTS) {
        return false; /* not a valid index: the controller is not configured */
    }
    urb_cm0_fdcan_element_t *const e = &p->ram->tx_buffer[put];
    uint8_t const len = (frame->len <= URB_CAN_MTU) ? frame->len : (uint8_t)URB_CAN_MTU;
    uint32_t data[2] = {0u, 0u};
    for (uint8_t i = 0u; i < len; i++) {
        data[i / 4u] |= (uint32_t)frame->data[i] << (8u * ((uint32_t)i % 4u));
    }
    e->word[0] = ((uint32_t)frame->id & ELEM_STD_ID_MASK) << ELEM_STD_ID_SHIFT;
    e->word[1] = ((uint32_t)p->epoch << T1_MM_SHIFT) | T1_EFC | ((uint32_t)len << ELEM_DLC_SHIFT);
    e->word[2] = data[0];
    e->word[3] = data[1];
    p->regs->txbar = (uint32_t)1u << put;
    return true;
}

static void fdcan_tx_abort(void *ctx)
{
    urb_cm0_can_t *p = (urb_cm0_can_t *)ctx;
    p->regs->txbcr = p->regs->txbrp;
    /* a frame already on the bus may still complete: its event carries the old epoch and is dropped */
    p->epoch = (uint8_t)(p->epoch + 1u);
}

static uint8_t fdcan_state(void *ctx)
{
    urb_cm0_can_t const *p = (urb_cm0_can_t const *)ctx;
    return fdcan_psr_state(p->regs->psr);
}

static void fdcan_recover(void *ctx)
{
    urb_cm0_can_t *p = (urb_cm0_can_t *)ctx;
    if ((p->regs->psr & PSR_BO) == 0u) {
        (void)fdcan_set_init(p->regs, true); /* a clear without bus-off: re-synchronise to the bus */
    }
    /* leaving INIT after bus-off starts the recovery: 128 x 11 recessive bits, then error-active */
    p->regs->cccr &= ~(CCCR_INIT | CCCR_CCE);
}

static void fdcan_lock(void *ctx, bool locked)
{
    urb_cm0_can_t *p = (urb_cm0_can_t *)ctx;
    p->regs->ile = locked ? 0u : ILE_EINT0;
}

/* ----- set-up and interrupt ----- */

bool urb_cm0_can_init(urb_cm0_can_t *port, urb_cm0_fdcan_regs_t *regs, urb_cm0_fdcan_ram_t *ram,
                      const urb_cm0_can_owner_t *owner, uint32_t kernel_hz, uint32_t bitrate_kbps)
{
    urb_cm0_can_timing_t t;
    port->regs = regs;
    port->ram = ram;
    port->owner = *owner;
    port->epoch = 0u;
    port->state = (uint8_t)URB_CAN_ERROR_ACTIVE;
    port->stats.rx_lost = 0u;
    port->stats.events_lost = 0u;
    port->stats.stale_events = 0u;
    port->us_per_bit = (bitrate_kbps != 0u) ? (1000u / bitrate_kbps) : 0u;
    port->hal.ctx = port;
    port->hal.tx = fdcan_tx;
    port->hal.tx_abort = fdcan_tx_abort;
    port->hal.state = fdcan_state;
    port->hal.recover = fdcan_recover;
    port->hal.lock = fdcan_lock;
    if (!fdcan_set_init(regs, true)) {
        return false;
    }
    regs->cccr |= CCCR_CCE;
    if (!urb_cm0_can_timing(kernel_hz, bitrate_kbps, &t) || ((port->us_per_bit * bitrate_kbps) != 1000u)) {
        return false;
    }
    regs->cccr &= ~(CCCR_DAR | CCCR_FDOE | CCCR_BRSE);
    regs->nbtp = urb_cm0_can_nbtp(&t);
    regs->tscc = TSCC_TSS_INTERNAL;
    regs->rxgfc = RXGFC_URB;
    regs->txbc = 0u;
    regs->ir = IR_USED;
    regs->ils = 0u;
    regs->ie = IR_USED;
    regs->ile = ILE_EINT0;
    return fdcan_set_init(regs, false);
}

/* The fill level and get index are read once: elements that arrive meanwhile raise RF0N again
 * (cleared before this runs) and are taken by the next interrupt. */
static void fdcan_rx_fifo0(urb_cm0_can_t *p)
{
    uint32_t const s = p->regs->rxf0s;
    uint32_t const fill = s & RXF0S_F0FL_MASK;
    uint32_t get = (s >> RXF0S_F0GI_SHIFT) & RXF0S_F0GI_MASK;
    /* bound: the FIFO's 3 elements */
    for (uint32_t n = 0u; (n < fill) && (n < URB_CM0_FDCAN_RX_ELEMENTS) && (get < URB_CM0_FDCAN_RX_ELEMENTS); n++) {
        urb_cm0_fdcan_element_t const *const e = &p->ram->rx_fifo0[get];
        uint32_t const r0 = e->word[0];
        uint32_t const r1 = e->word[1];
        /* the start of frame on the caller's clock: now, less the bit times since the SOF stamp */
        uint32_t const now = p->owner.now_us(p->owner.owner);
        uint32_t const since = ((p->regs->tscv & TSCV_MASK) - (r1 & R1_RXTS_MASK)) & TSCV_MASK;
        if (((r0 & (ELEM_XTD | ELEM_RTR)) == 0u) && ((r1 & ELEM_FDF) == 0u)) {
            urb_can_frame_t f;
            uint32_t const dlc = (r1 >> ELEM_DLC_SHIFT) & ELEM_DLC_MASK;
            uint32_t const w2 = e->word[2];
            uint32_t const w3 = e->word[3];
            f.id = (uint16_t)((r0 >> ELEM_STD_ID_SHIFT) & ELEM_STD_ID_MASK);
            f.len = (uint8_t)((dlc <= URB_CAN_MTU) ? dlc : URB_CAN_MTU); /* DLC 9..15 is 8 bytes in classic CAN */
            for (uint8_t i = 0u; i < URB_CAN_MTU; i++) {
                uint32_t const w = (i < 4u) ? w2 : w3;
                f.data[i] = (uint8_t)(w >> (8u * ((uint32_t)i % 4u)));
            }
            p->regs->rxf0a = get; /* the element is copied: free it before the owner runs */
            p->owner.on_rx(p->owner.owner, &f, now - (since * p->us_per_bit));
        } else {
            p->regs->rxf0a = get; /* not URB's: the global filter rejects these, dropped if one comes */
        }
        get = (get + 1u) % URB_CM0_FDCAN_RX_ELEMENTS;
    }
}

/* As fdcan_rx_fifo0: the fill level and get index are read once. */
static void fdcan_tx_events(urb_cm0_can_t *p)
{
    uint32_t const s = p->regs->txefs;
    uint32_t const fill = s & TXEFS_EFFL_MASK;
    uint32_t get = (s >> TXEFS_EFGI_SHIFT) & TXEFS_EFGI_MASK;
    /* bound: the event FIFO's 3 elements */
    for (uint32_t n = 0u; (n < fill) && (n < URB_CM0_FDCAN_TX_ELEMENTS) && (get < URB_CM0_FDCAN_TX_ELEMENTS); n++) {
        uint32_t const e1 = p->ram->tx_event[(2u * get) + 1u];
        p->regs->txefa = get;
        if ((uint8_t)(e1 >> E1_MM_SHIFT) == p->epoch) {
            p->owner.on_tx_done(p->owner.owner);
        } else {
            p->stats.stale_events++;
        }
        get = (get + 1u) % URB_CM0_FDCAN_TX_ELEMENTS;
    }
}

void urb_cm0_can_irq(urb_cm0_can_t *port)
{
    uint32_t const ir = port->regs->ir & IR_USED;
    port->regs->ir = ir; /* write 1 to clear, before the FIFOs are read: a later arrival raises it again */
    if ((ir & IR_RF0L) != 0u) {
        port->stats.rx_lost++;
    }
    if ((ir & IR_TEFL) != 0u) {
        port->stats.events_lost++;
    }
    if ((ir & IR_TEFN) != 0u) {
        fdcan_tx_events(port);
    }
    if ((ir & IR_RF0N) != 0u) {
        fdcan_rx_fifo0(port);
    }
    if ((ir & (IR_BO | IR_EP)) != 0u) {
        uint8_t const state = fdcan_psr_state(port->regs->psr);
        if ((state != port->state) && (port->owner.on_state != NULL)) {
            port->owner.on_state(port->owner.owner, state);
        }
        port->state = state;
    }
}

void urb_cm0_can_stats(const urb_cm0_can_t *port, urb_cm0_can_stats_t *out)
{
    *out = port->stats;
}
