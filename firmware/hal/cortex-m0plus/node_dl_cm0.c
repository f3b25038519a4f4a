/*
 * Cortex-M0+ (STM32G0B1) reference image of a node on the CAN or the RS485 downlink: the node
 * library built for that downlink (mk/node_downlinks.mk, urb_node_downlink.h), the echo application
 * (firmware/apps/echo: outbox 1 is a copy of inbox 1, 8 bytes each) and the register-level ports
 * urb_cm0_fdcan.c / urb_cm0_usart485.c. Built twice by mk/cm0_downlinks.mk: -DURB_CM0_NODE_RS485
 * gives the RS485 image, without it the CAN image.
 *
 * Application glue, like targets/main_node.c: the one node, port and downlink slave are this
 * image's statics, and the vector table (startup_cm0.c) calls the handlers below by name.
 * Time: TIM2 counts microseconds (prescaler 47 at 48 MHz), the one clock of the node library
 * (ticks_per_us 1, as the downlink slaves' time stamps and windows are in microseconds), the CAN
 * port's start-of-frame stamps and the RS485 receiver's byte stamps; CC1 is the heartbeat compare,
 * CC2 the RS485 silence deadline (urb_rs485_hal_t.wake_at). Every downlink interrupt has the timer's
 * priority, as urb_node_downlink.h requires.
 * VENDOR (RM0444; check against the board): clocks (core and APB at 48 MHz, set by the board before
 * main; FDCAN and USART1 kernel clocks are PCLK after reset), pins, IRQ numbers.
 */
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "echo_app.h"
#include "urb_node.h"
#include "urb_node_hal.h"

#if defined(URB_CM0_NODE_RS485)
#include "urb_cm0_usart485.h"
#include "urb_node_rs485.h"
#else
#include "urb_cm0_fdcan.h"
#include "urb_node_can.h"
#endif

#define REG32(addr) (*(volatile uint32_t *)(uintptr_t)(addr))

/* ----- VENDOR: STM32G0B1 (RM0444 "Reset and clock control", "General-purpose I/Os", TIM2) ----- */
#define CORE_HZ 48000000u
#define RCC_BASE 0x40021000u
#define RCC_IOPENR REG32(RCC_BASE + 0x34u)
#define RCC_APBENR1 REG32(RCC_BASE + 0x3Cu)
#define RCC_APBENR2 REG32(RCC_BASE + 0x40u)
#define RCC_IOPENR_GPIOA ((uint32_t)1u << 0)
#define RCC_IOPENR_GPIOB ((uint32_t)1u << 1)
#define RCC_APBENR1_TIM2 ((uint32_t)1u << 0)
#define RCC_APBENR1_FDCAN ((uint32_t)1u << 12)
#define RCC_APBENR2_USART1 ((uint32_t)1u << 14)

#define GPIOA_BASE 0x50000000u
#define GPIOB_BASE 0x50000400u
#define GPIO_MODER(b) REG32((b) + 0x00u)
#define GPIO_BSRR(b) REG32((b) + 0x18u)
#define GPIO_AFRH(b) REG32((b) + 0x24u)

#define TIM2_BASE 0x40000000u
#define TIM2_CR1 REG32(TIM2_BASE + 0x00u)
#define TIM2_DIER REG32(TIM2_BASE + 0x0Cu)
#define TIM2_SR REG32(TIM2_BASE + 0x10u)
#define TIM2_EGR REG32(TIM2_BASE + 0x14u)
#define TIM2_CNT REG32(TIM2_BASE + 0x24u)
#define TIM2_PSC REG32(TIM2_BASE + 0x28u)
#define TIM2_ARR REG32(TIM2_BASE + 0x2Cu)
#define TIM2_CCR1 REG32(TIM2_BASE + 0x34u)
#define TIM2_CCR2 REG32(TIM2_BASE + 0x38u)
#define TIM_CR1_CEN ((uint32_t)1u << 0)
#define TIM_EGR_UG ((uint32_t)1u << 0)
#define TIM_CC1 ((uint32_t)1u << 1) /* DIER.CC1IE, SR.CC1IF */
#define TIM_CC2 ((uint32_t)1u << 2) /* DIER.CC2IE, SR.CC2IF, EGR.CC2G */

#define IRQ_TIM2 15u
#define IRQ_FDCAN_IT0 21u /* shared with TIM16 */
#define IRQ_USART1 27u
#define NVIC_ISER REG32(0xE000E100u)
#define NVIC_IPR(n) REG32(0xE000E400u + (4u * ((n) / 4u)))
#define IRQ_PRIORITY 0x80u

#define MARK_PIN(m) ((uint32_t)1u << (uint32_t)(m)) /* PA0..PA2 */
#define ECHO_BYTES 8u
#define ECHO_STORAGE (4u * ECHO_BYTES) /* inbox 1 and outbox 1, two buffers each */
#define NODE_ADDRESS 1u

/* The vector table (startup_cm0.c) refers to these by name. */
void TIM2_IRQHandler(void);
#if defined(URB_CM0_NODE_RS485)
void USART1_IRQHandler(void);
#define RS485_BAUD 1000000u
static urb_cm0_rs485_t dl_port;
static urb_node_rs485_t downlink;
#else
void TIM16_FDCAN_IT0_IRQHandler(void);
#define CAN_KBPS 1000u
static urb_cm0_can_t dl_port;
static urb_node_can_t downlink;
#endif

static urb_node_t dl_node;
static urb_node_hal_t node_hal;
static echo_app_t echo_state;
static uint8_t echo_storage[ECHO_STORAGE];

static uint32_t dl_clock_now(void *ctx)
{
    (void)ctx;
    return TIM2_CNT;
}

static void dl_timer_compare(void *ctx, uint32_t at)
{
    (void)ctx;
    TIM2_CCR1 = at;
    TIM2_SR = ~TIM_CC1; /* rc_w0: clear a stale match */
    TIM2_DIER |= TIM_CC1;
}

static void dl_no_address(void *ctx, uint8_t address)
{
    (void)ctx; /* the slave filters on the address it was attached with */
    (void)address;
}

static void dl_mark(void *ctx, urb_node_mark_t m)
{
    (void)ctx;
    GPIO_BSRR(GPIOA_BASE) = MARK_PIN(m);
    GPIO_BSRR(GPIOA_BASE) = MARK_PIN(m) << 16;
}

static void dl_nvic_enable(uint32_t irq)
{
    uint32_t const shift = 8u * (irq % 4u);
    NVIC_IPR(irq) = (NVIC_IPR(irq) & ~((uint32_t)0xFFu << shift)) | ((uint32_t)IRQ_PRIORITY << shift);
    NVIC_ISER = (uint32_t)1u << irq;
}

#if defined(URB_CM0_NODE_RS485)
static void slave_rs485_rx(void *owner, uint8_t byte, uint32_t t_us)
{
    urb_rs485_slave_rx(&((urb_node_rs485_t *)owner)->slave, byte, t_us);
}

static bool slave_rs485_tx_next(void *owner, uint8_t *byte)
{
    return urb_rs485_slave_tx_next(&((urb_node_rs485_t *)owner)->slave, byte);
}

static void slave_rs485_wake_at(void *owner, uint32_t at_us)
{
    (void)owner;
    TIM2_CCR2 = at_us;
    TIM2_SR = ~TIM_CC2;
    TIM2_DIER |= TIM_CC2;
    if ((int32_t)(at_us - TIM2_CNT) <= 0) {
        TIM2_EGR = TIM_CC2; /* already passed: a compare match now would come only after the wrap (71 min) */
    }
}

static bool downlink_init(void)
{
    /* PA9 TX, PA10 RX, PA12 DE: alternate function 1 */
    GPIO_MODER(GPIOA_BASE) = (GPIO_MODER(GPIOA_BASE) & ~((uint32_t)0x33Cu << 16)) | ((uint32_t)0x228u << 16);
    GPIO_AFRH(GPIOA_BASE) = (GPIO_AFRH(GPIOA_BASE) & ~(uint32_t)0xF0FF0u) | (uint32_t)0x10110u;
    RCC_APBENR2 |= RCC_APBENR2_USART1;
    urb_cm0_rs485_owner_t const owner = {&downlink,    slave_rs485_rx,      slave_rs485_tx_next,
                                         dl_clock_now, slave_rs485_wake_at, NULL};
    return urb_cm0_rs485_init(&dl_port, URB_CM0_USART1, &owner, CORE_HZ, RS485_BAUD);
}

static bool downlink_attach(const urb_node_config_t *cfg)
{
    return urb_node_rs485_attach(&downlink, &dl_node, cfg, &dl_port.hal, RS485_BAUD, TIM2_CNT);
}

void USART1_IRQHandler(void)
{
    urb_cm0_rs485_irq(&dl_port);
}
#else
static void slave_can_rx(void *owner, const urb_can_frame_t *frame, uint32_t t_us)
{
    urb_can_slave_rx(&((urb_node_can_t *)owner)->slave, frame, t_us);
}

static void slave_can_tx_done(void *owner)
{
    urb_can_slave_tx_done(&((urb_node_can_t *)owner)->slave);
}

static void slave_can_state(void *owner, uint8_t state)
{
    urb_can_slave_state(&((urb_node_can_t *)owner)->slave, state);
}

static bool downlink_init(void)
{
    /* PB8 FDCAN1_RX, PB9 FDCAN1_TX: alternate function 3 */
    GPIO_MODER(GPIOB_BASE) = (GPIO_MODER(GPIOB_BASE) & ~((uint32_t)0xFu << 16)) | ((uint32_t)0xAu << 16);
    GPIO_AFRH(GPIOB_BASE) = (GPIO_AFRH(GPIOB_BASE) & ~(uint32_t)0xFFu) | (uint32_t)0x33u;
    RCC_APBENR1 |= RCC_APBENR1_FDCAN;
    urb_cm0_can_owner_t const owner = {&downlink, slave_can_rx, slave_can_tx_done, slave_can_state, dl_clock_now};
    return urb_cm0_can_init(&dl_port, URB_CM0_FDCAN1, URB_CM0_SRAMCAN1, &owner, CORE_HZ, CAN_KBPS);
}

static bool downlink_attach(const urb_node_config_t *cfg)
{
    return urb_node_can_attach(&downlink, &dl_node, cfg, &dl_port.hal, CAN_KBPS);
}

void TIM16_FDCAN_IT0_IRQHandler(void)
{
    urb_cm0_can_irq(&dl_port);
}
#endif

void TIM2_IRQHandler(void)
{
    uint32_t const sr = TIM2_SR;
    if ((sr & TIM_CC1) != 0u) {
        TIM2_SR = ~TIM_CC1;
        TIM2_DIER &= ~TIM_CC1; /* re-armed by set_compare */
        urb_node_timer_event(&dl_node);
    }
#if defined(URB_CM0_NODE_RS485)
    if ((sr & TIM_CC2) != 0u) {
        TIM2_SR = ~TIM_CC2;
        TIM2_DIER &= ~TIM_CC2; /* re-armed by wake_at */
        urb_rs485_slave_poll(&downlink.slave, TIM2_CNT);
    }
#endif
}

static void dl_halt(void)
{
    for (;;) {
    }
}

int main(void);

int main(void)
{
    RCC_IOPENR |= RCC_IOPENR_GPIOA | RCC_IOPENR_GPIOB;
    RCC_APBENR1 |= RCC_APBENR1_TIM2;
    GPIO_MODER(GPIOA_BASE) = (GPIO_MODER(GPIOA_BASE) & ~0x3Fu) | 0x15u; /* PA0..PA2 outputs (marks) */
    TIM2_PSC = (CORE_HZ / 1000000u) - 1u;
    TIM2_ARR = 0xFFFFFFFFu;
    TIM2_EGR = TIM_EGR_UG; /* load the prescaler */
    TIM2_CR1 = TIM_CR1_CEN;

    node_hal.ctx = NULL;
    node_hal.now = dl_clock_now;
    node_hal.set_compare = dl_timer_compare;
    node_hal.sync_capture = NULL;
    node_hal.set_address = dl_no_address;
    node_hal.mark = dl_mark;
    node_hal.identify = NULL;

    urb_node_config_t cfg;
    urb_node_config_default(&cfg);
    cfg.i2c_address = NODE_ADDRESS;
    cfg.ticks_per_us = 1u;
    echo_state.class_id = 1u;
    echo_state.index = 0u;
    echo_state.fingerprint = 0x00C0FFEEu;
    echo_state.in_size[1] = ECHO_BYTES;
    echo_state.out_size[1] = ECHO_BYTES;
    if (!downlink_init()) {
        dl_halt();
    }
    if (urb_node_init(&dl_node, &node_hal, &echo_app_hooks, &echo_state, &cfg, echo_storage,
                      (uint16_t)sizeof echo_storage) != URB_NODE_OK) {
        dl_halt();
    }
    if (!downlink_attach(&cfg)) {
        dl_halt();
    }
    dl_nvic_enable(IRQ_TIM2);
#if defined(URB_CM0_NODE_RS485)
    dl_nvic_enable(IRQ_USART1);
#else
    dl_nvic_enable(IRQ_FDCAN_IT0);
#endif
    for (;;) {
        (void)urb_node_poll(&dl_node);
        __asm__ __volatile__("cpsid i" ::: "memory");
        if (!urb_node_has_work(&dl_node)) {
            __asm__ __volatile__("wfi" ::: "memory");
        }
        __asm__ __volatile__("cpsie i" ::: "memory");
    }
}
