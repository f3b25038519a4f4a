/*
 * Board stubs (see board_cm0.h). Every address here is VENDOR / board-specific.
 */
#include "board_cm0.h"

#include <stddef.h>

#define REG32(addr) (*(volatile uint32_t *)(uintptr_t)(addr))
#define GPIOB_IDR REG32(0x50000410u)
#define TIM3_CNT REG32(0x40000424u)  /* encoder mode */
#define TIM1_CCR1 REG32(0x40012C34u) /* PWM, magnitude */
#define GPIOA_BSRR REG32(0x50000018u) /* direction pin PA8 */
#define ADC_DR REG32(0x40012440u)     /* placeholder: one conversion result register */

uint8_t board_address(void)
{
    return (uint8_t)(0x10u + (GPIOB_IDR & 0x7u));
}

uint8_t board_index(void)
{
    return (uint8_t)(GPIOB_IDR & 0x7u);
}

static int16_t adc_scaled(int32_t gain, int32_t offset)
{
    uint32_t const raw = ADC_DR & 0xFFFu; /* 12-bit conversion result */
    int32_t const v = (((int32_t)raw * gain) / 4096) + offset;
    return (int16_t)((v > 32767) ? 32767 : ((v < -32768) ? -32768 : v));
}

static uint16_t m_encoder(void *ctx)
{
    (void)ctx;
    return (uint16_t)TIM3_CNT;
}
static int16_t m_current(void *ctx)
{
    (void)ctx;
    return adc_scaled(40000, -20000); /* +-20 A */
}
static int16_t m_voltage(void *ctx)
{
    (void)ctx;
    return adc_scaled(48000, -24000);
}
static int16_t m_temp(void *ctx)
{
    (void)ctx;
    return adc_scaled(15000, -2000);
}
static bool m_hall(void *ctx)
{
    (void)ctx;
    return (GPIOB_IDR & ((uint32_t)1u << 8)) != 0u;
}
static void m_drive(void *ctx, int16_t mv)
{
    (void)ctx;
    uint32_t const mag = (uint32_t)((mv < 0) ? -(int32_t)mv : (int32_t)mv);
    GPIOA_BSRR = (mv < 0) ? ((uint32_t)1u << 8) : ((uint32_t)1u << 24);
    TIM1_CCR1 = (mag * 1200u) / 24000u; /* ARR 1200: 40 kHz PWM at 48 MHz, 24 V supply */
}

const sensorhex_motor_io_t board_motor_io = {NULL, m_encoder, m_current, m_voltage, m_temp, m_hall, m_drive};

static bool b_present(void *ctx, uint8_t pack)
{
    (void)ctx;
    uint32_t const pin = 9u + (uint32_t)pack; /* presence inputs PB9..PB11 */
    return (GPIOB_IDR & ((uint32_t)1u << pin)) != 0u;
}
static uint16_t b_voltage(void *ctx, uint8_t pack)
{
    (void)ctx;
    (void)pack;
    return (uint16_t)adc_scaled(16000, 0);
}
static int16_t b_current(void *ctx, uint8_t pack)
{
    (void)ctx;
    (void)pack;
    return adc_scaled(60000, -30000);
}
static int8_t b_temp(void *ctx, uint8_t pack)
{
    (void)ctx;
    (void)pack;
    return (int8_t)(adc_scaled(150, -20));
}
static bool b_charger(void *ctx)
{
    (void)ctx;
    return (GPIOB_IDR & ((uint32_t)1u << 12)) != 0u;
}

const sensorhex_battery_io_t board_battery_io = {NULL, b_present, b_voltage, b_current, b_temp, b_charger};

static bool i_read(void *ctx, sensorhex_imu_reading_t *out)
{
    (void)ctx;
    /* bound: 3 axes */
    for (uint8_t a = 0u; a < 3u; a++) {
        out->accel[a] = adc_scaled(39200, -19600);
        out->gyro[a] = adc_scaled(17400, -8700);
    }
    out->temp = (int8_t)adc_scaled(150, -20);
    return true;
}

const sensorhex_imu_io_t board_imu_io = {NULL, i_read};

static uint16_t r_distance(void *ctx)
{
    (void)ctx;
    return (uint16_t)adc_scaled(2000, 0);
}
static uint8_t r_strength(void *ctx)
{
    (void)ctx;
    return (uint8_t)(ADC_DR >> 4);
}

const sensorhex_ir_io_t board_ir_io = {NULL, r_distance, r_strength};
