/*
 * Board stubs for the Cortex-M0+ reference images of the SensoRHex nodes: the sensor interfaces
 * implemented with placeholder register reads (VENDOR / board-specific: ADC channels, the encoder
 * timer, the PWM timer, address straps). They exist so the images link and their sizes are
 * realistic; a real board replaces this file.
 */
#ifndef BOARD_CM0_H
#define BOARD_CM0_H

#include <stdint.h>

#include "sensorhex_battery.h"
#include "sensorhex_imu.h"
#include "sensorhex_ir.h"
#include "sensorhex_motor.h"

/** I2C address from the board's strap pins. */
uint8_t board_address(void);
/** Node index from the board's strap pins. */
uint8_t board_index(void);

extern const sensorhex_motor_io_t board_motor_io;
extern const sensorhex_battery_io_t board_battery_io;
extern const sensorhex_imu_io_t board_imu_io;
extern const sensorhex_ir_io_t board_ir_io;

#endif /* BOARD_CM0_H */
