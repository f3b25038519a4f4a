/*
 * Cortex-M0+ reference image of one SensoRHex node: the node library, the reference port, one
 * application and the board stubs. Built once per application (mk/firmware_node.mk) with
 * -DSENSORHEX_APP=<motor|battery|imu|ir> and -DSENSORHEX_APP_STORAGE=SENSORHEX_<APP>_STORAGE, so
 * the four images share this file. Application code: the one node instance and its storage are
 * this image's globals.
 */
#include <stddef.h>

#include "board_cm0.h"
#include "urb_hal_cm0.h"
#include "urb_node.h"

#if !defined(SENSORHEX_APP) || !defined(SENSORHEX_APP_STORAGE)
#error "build with -DSENSORHEX_APP=<motor|battery|imu|ir> -DSENSORHEX_APP_STORAGE=SENSORHEX_<APP>_STORAGE"
#endif

/* sensorhex_<app><suffix> and board_<app>_io, from the application name. */
#define PASTE3_(a, b, c) a##b##c
#define PASTE3(a, b, c) PASTE3_(a, b, c)
#define APP(suffix) PASTE3(sensorhex_, SENSORHEX_APP, suffix)
#define BOARD_IO PASTE3(board_, SENSORHEX_APP, _io)

/* The vector table (startup_cm0.c) refers to these by name. */
void TIM2_IRQHandler(void);
void I2C1_IRQHandler(void);

static urb_hal_cm0_t port;
static urb_node_t node;
static APP(_t) app;
static uint8_t storage[SENSORHEX_APP_STORAGE];

int main(void)
{
    urb_hal_cm0_init(&port);
    urb_node_config_t cfg;
    urb_node_config_default(&cfg);
    cfg.i2c_address = board_address();
    cfg.ticks_per_us = URB_HAL_CM0_TICKS_PER_US;
    APP(_node_config)(&cfg);
    APP(_config_t) acfg;
    APP(_defaults)(&acfg, board_index());
    APP(_setup)(&app, &BOARD_IO, &acfg);
    urb_hal_cm0_attach(&port, &node);
    if (urb_node_init(&node, &port.hal, &APP(_hooks), &app, &cfg, storage, (uint16_t)sizeof storage) !=
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
