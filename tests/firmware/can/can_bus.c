/* In-memory CAN bus (can_bus.h). */
#include "can_bus.h"

#include <string.h>

uint32_t can_bus_us(const can_bus_t *b, uint32_t bits)
{
    return (bits * 1000u + b->bitrate_kbps - 1u) / b->bitrate_kbps;
}

static can_port_t *port_of(void *ctx)
{
    return (can_port_t *)ctx;
}

static bool hal_tx(void *ctx, const urb_can_frame_t *f)
{
    can_port_t *p = port_of(ctx);
    if (p->queued >= p->slots) {
        return false;
    }
    p->queue[p->queued++] = *f;
    return true;
}

static void hal_tx_abort(void *ctx)
{
    can_port_t *p = port_of(ctx);
    p->queued = 0u;
    p->tx_aborts++;
}

static uint8_t hal_state(void *ctx)
{
    return port_of(ctx)->state;
}

static void hal_recover(void *ctx)
{
    can_port_t *p = port_of(ctx);
    p->recovers++;
    p->recovering = true;
    p->recover_at = p->bus->now_us + can_bus_us(p->bus, URB_CAN_RECOVERY_BITS);
}

void can_bus_init(can_bus_t *b, uint16_t bitrate_kbps)
{
    memset(b, 0, sizeof *b);
    b->bitrate_kbps = bitrate_kbps;
}

bool can_bus_attach(can_bus_t *b, can_port_t *p, uint8_t slots, void *owner,
                    void (*on_rx)(void *, const urb_can_frame_t *, uint32_t), void (*on_tx_done)(void *),
                    void (*on_state)(void *, uint8_t))
{
    if (b->n >= CAN_BUS_PORTS) {
        return false;
    }
    memset(p, 0, sizeof *p);
    p->hal.ctx = p;
    p->hal.tx = hal_tx;
    p->hal.tx_abort = hal_tx_abort;
    p->hal.state = hal_state;
    p->hal.recover = hal_recover;
    p->hal.lock = NULL;
    p->bus = b;
    p->index = b->n;
    p->slots = (slots == 0u || slots > CAN_BUS_QUEUE) ? CAN_BUS_QUEUE : slots;
    p->owner = owner;
    p->on_rx = on_rx;
    p->on_tx_done = on_tx_done;
    p->on_state = on_state;
    b->ports[b->n++] = p;
    return true;
}

static void set_state(can_port_t *p)
{
    uint8_t s = URB_CAN_ERROR_ACTIVE;
    if (p->tec > 255u) {
        s = URB_CAN_BUS_OFF;
    } else if ((p->tec > 127u) || (p->rec > 127u)) {
        s = URB_CAN_ERROR_PASSIVE;
    }
    if (s != p->state) {
        p->state = s;
        if (s == URB_CAN_BUS_OFF) {
            p->recovering = false;
        }
        if (p->on_state != NULL) {
            p->on_state(p->owner, s);
        }
    }
}

static void pop(can_port_t *p)
{
    memmove(&p->queue[0], &p->queue[1], (size_t)(p->queued - 1u) * sizeof p->queue[0]);
    p->queued--;
}

bool can_bus_step(can_bus_t *b)
{
    /* recoveries that are due (the bus counts as idle long enough when a port is bus-off alone) */
    for (uint8_t i = 0u; i < b->n; i++) {
        can_port_t *p = b->ports[i];
        if (p->recovering && (int32_t)(b->now_us - p->recover_at) >= 0) {
            p->recovering = false;
            p->tec = 0u;
            p->rec = 0u;
            set_state(p);
        }
    }
    can_port_t *win = NULL;
    for (uint8_t i = 0u; i < b->n; i++) {
        can_port_t *p = b->ports[i];
        if ((p->queued > 0u) && (p->state != URB_CAN_BUS_OFF) && ((win == NULL) || (p->queue[0].id < win->queue[0].id))) {
            win = p;
        }
    }
    if (win == NULL) {
        return false;
    }
    urb_can_frame_t const f = win->queue[0];
    uint32_t const t0 = b->now_us;
    b->now_us += can_bus_us(b, urb_can_frame_bits_max(f.len, false));
    uint16_t fault = b->next_fault;
    if (b->fault != NULL) {
        fault = b->fault(b->fault_ctx, win, &f);
    }
    b->next_fault = CAN_FAULT_NONE;
    bool acked = false;
    for (uint8_t i = 0u; i < b->n; i++) {
        can_port_t *p = b->ports[i];
        if ((p != win) && (p->state != URB_CAN_BUS_OFF)) {
            acked = true;
        }
    }
    if ((fault & CAN_FAULT_ERROR) != 0u || !acked) {
        b->errors++;
        b->now_us += can_bus_us(b, 23u); /* error flag(s), delimiter, intermission */
        if (!acked && (win->tec > 127u)) {
            return true; /* an error-passive sender's ACK error does not count (ISO 11898-1) */
        }
        win->tec = (uint16_t)(win->tec + 8u);
        for (uint8_t i = 0u; i < b->n; i++) {
            can_port_t *p = b->ports[i];
            if ((p != win) && (p->state != URB_CAN_BUS_OFF)) {
                p->rec = (uint16_t)(p->rec + 1u);
                set_state(p);
            }
        }
        set_state(win);
        return true;
    }
    b->frames++;
    for (uint8_t i = 0u; i < b->n; i++) {
        can_port_t *p = b->ports[i];
        if ((p == win) || (p->state == URB_CAN_BUS_OFF) || ((fault & (1u << i)) != 0u)) {
            continue;
        }
        if (p->rec > 0u) {
            p->rec--;
        }
        set_state(p);
        if (p->on_rx != NULL) {
            p->on_rx(p->owner, &f, t0);
        }
    }
    if ((fault & CAN_FAULT_EOF) != 0u) {
        b->errors++;
        b->now_us += can_bus_us(b, 23u);
        win->tec = (uint16_t)(win->tec + 8u);
        set_state(win);
        return true; /* the sender saw an error in the last bit: the frame stays queued */
    }
    if (win->tec > 0u) {
        win->tec--;
    }
    set_state(win);
    if (win->queued > 0u && memcmp(&win->queue[0], &f, sizeof f) == 0) {
        pop(win);
        if (win->on_tx_done != NULL) {
            win->on_tx_done(win->owner);
        }
    }
    return true;
}
