/*
 * An in-memory CAN bus for the CAN downlink's tests and fuzz target: ports with a FIFO transmit
 * queue (urb_can_hal_t), arbitration by identifier, the worst-case frame length in bit times,
 * fault confinement (TEC/REC, error-passive over 127, bus-off over 255, recovery after 128 x 11
 * recessive bits) and injected faults per frame: an error frame, a frame the sender sees fail in
 * the last bit of its end of frame (the receivers keep it: a duplicate follows), a frame lost by
 * some receivers. Deterministic: the same calls give the same trace.
 */
#ifndef CAN_BUS_H
#define CAN_BUS_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_can.h"

#define CAN_BUS_PORTS 8u
#define CAN_BUS_QUEUE 8u

/* What happens to the next frame (can_bus_t.fault). */
#define CAN_FAULT_NONE 0x0000u
#define CAN_FAULT_ERROR 0x0100u  /* an error frame: nobody takes it, the sender tries again */
#define CAN_FAULT_EOF 0x0200u    /* the receivers take it, the sender sees an error and sends it again */
#define CAN_FAULT_DROP 0x00FFu   /* mask: bit p set = port p loses it (the rest take it) */

typedef struct can_bus can_bus_t;

typedef struct {
    urb_can_hal_t hal;                 /* what the owner gets */
    can_bus_t *bus;
    uint8_t index;
    uint8_t slots;                     /* frames the controller holds at most (a real one: 3) */
    urb_can_frame_t queue[CAN_BUS_QUEUE];
    uint8_t queued;
    uint16_t tec, rec;
    uint8_t state;                     /* urb_can_state_t */
    bool recovering;
    uint32_t recover_at;
    /* owner's entry points */
    void *owner;
    void (*on_rx)(void *owner, const urb_can_frame_t *f, uint32_t t);
    void (*on_tx_done)(void *owner);
    void (*on_state)(void *owner, uint8_t state);
    uint32_t tx_aborts, recovers;
} can_port_t;

struct can_bus {
    can_port_t *ports[CAN_BUS_PORTS];
    uint8_t n;
    uint32_t now_us;
    uint16_t bitrate_kbps;
    /* fault of the next frame sent; a test sets it, the bus clears it after use */
    uint16_t next_fault;
    /* or a function asked for every frame (the fuzz target's script); NULL: next_fault */
    uint16_t (*fault)(void *ctx, const can_port_t *sender, const urb_can_frame_t *f);
    void *fault_ctx;
    uint32_t frames, errors;
};

void can_bus_init(can_bus_t *b, uint16_t bitrate_kbps);
/** Attaches *p with its owner's entry points; returns false when the bus is full. */
bool can_bus_attach(can_bus_t *b, can_port_t *p, uint8_t slots, void *owner,
                    void (*on_rx)(void *, const urb_can_frame_t *, uint32_t), void (*on_tx_done)(void *),
                    void (*on_state)(void *, uint8_t));
/** Sends the frame that wins arbitration now, if any: true when the bus was busy. */
bool can_bus_step(can_bus_t *b);
/** Microseconds of `bits` bit times at the bus rate, rounded up. */
uint32_t can_bus_us(const can_bus_t *b, uint32_t bits);

#endif /* CAN_BUS_H */
