/*
 * Cortex-M0+ reference port of the node HAL: a register-level skeleton for a generic STM32G0-like
 * part (32-bit general-purpose timer TIM2 at the core clock, I2C1 with slave byte control).
 *
 * Everything marked VENDOR in urb_hal_cm0.c (register addresses, bit positions, clock and pin
 * setup, IRQ numbers) must be checked against the part's reference manual; the rest (the event
 * mapping onto urb_node_i2c_event, the compare handling, the sleep idiom) is generic.
 *
 * Wiring in the application's main (no globals in this port: the application owns the instances):
 *     static urb_hal_cm0_t port; static urb_node_t node;
 *     urb_hal_cm0_init(&port);  urb_hal_cm0_attach(&port, &node);  urb_node_init(&node, &port.hal, ...);
 *     for (;;) { urb_node_poll(&node); urb_hal_cm0_sleep(&node); }
 *     void TIM2_IRQHandler(void) { urb_hal_cm0_timer_irq(&port); }
 *     void I2C1_IRQHandler(void) { urb_hal_cm0_i2c_irq(&port); }
 * Both IRQs get the same NVIC priority (the library requires that they never preempt each other).
 */
#ifndef URB_HAL_CM0_H
#define URB_HAL_CM0_H

#include <stdint.h>

#include "urb_node.h"
#include "urb_node_hal.h"

/** Timer ticks per microsecond: TIM2 runs at the 48 MHz core clock, no prescaler. */
#define URB_HAL_CM0_TICKS_PER_US 48u

/** One port instance. */
typedef struct {
    urb_node_hal_t hal;  /**< filled by urb_hal_cm0_init; pass &port->hal to urb_node_init */
    urb_node_t *node;    /**< the node the interrupts are dispatched to */
} urb_hal_cm0_t;

/** Clocks, timer, I2C peripheral (address set later by the library), GPIO marks, NVIC. */
void urb_hal_cm0_init(urb_hal_cm0_t *port);
/** Names the node the two interrupt handlers dispatch to (before urb_node_init). */
void urb_hal_cm0_attach(urb_hal_cm0_t *port, urb_node_t *node);
/** TIM2 interrupt: the heartbeat compare. */
void urb_hal_cm0_timer_irq(urb_hal_cm0_t *port);
/** I2C1 interrupt: maps the peripheral's flags onto urb_node_i2c_event. */
void urb_hal_cm0_i2c_irq(urb_hal_cm0_t *port);
/** Sleeps until the next interrupt unless the node has work (race-free: checked with IRQs masked). */
void urb_hal_cm0_sleep(const urb_node_t *node);

#endif /* URB_HAL_CM0_H */
