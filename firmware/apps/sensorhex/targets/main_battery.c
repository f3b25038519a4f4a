/*
 * Cortex-M0+ reference image of the SensoRHex battery node: the node library, the reference port,
 * the battery application and the board stubs. Application code: the one node instance and its
 * storage are this image's globals.
 */
#include <stddef.h>

#include "board_cm0.h"
#include "sensorhex_battery.h"
#include "urb_hal_cm0.h"
#include "urb_node.h"

static urb_hal_cm0_t port;
static urb_node_t node;
static sensorhex_battery_t app;
static uint8_t storage[SENSORHEX_BATTERY_STORAGE];

int main(void)
{
    urb_hal_cm0_init(&port);
    urb_node_config_t cfg;
    urb_node_config_default(&cfg);
    cfg.i2c_address = board_address();
    cfg.ticks_per_us = URB_HAL_CM0_TICKS_PER_US;
    sensorhex_battery_node_config(&cfg);
    sensorhex_battery_config_t acfg;
    sensorhex_battery_defaults(&acfg, board_index());
    sensorhex_battery_setup(&app, &board_battery_io, &acfg);
    urb_hal_cm0_attach(&port, &node);
    if (urb_node_init(&node, &port.hal, &sensorhex_battery_hooks, &app, &cfg, storage, (uint16_t)sizeof storage) !=
        URB_NODE_OK) {
        for (;;) {
        }
    }
    for (;;) {
        (void)urb_node_poll(&node);
        urb_hal_cm0_sleep(&node);
    }
}

void TIM2_IRQHandler(void)
{
    urb_hal_cm0_timer_irq(&port);
}

void I2C1_IRQHandler(void)
{
    urb_hal_cm0_i2c_irq(&port);
}
