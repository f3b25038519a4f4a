/*
 * Cortex-M0+ reference port of the URB bridge: a skeleton that shows where each HAL function and
 * each interrupt goes, and that links into a complete image (for sizes and a warning-free build).
 *
 * Core parts are real (they are architectural on every Cortex-M0+): the vector table, the reset
 * handler, SysTick as the microsecond clock and heartbeat, PRIMASK critical sections, WFI.
 * Peripheral parts (UART, I2C master, USB device, GPIO) differ per vendor: they are the bsp_*
 * functions below, weak no-op defaults that a board file overrides (SAMD21, RP2040, STM32G0...).
 *
 * Interrupt wiring (each handler is O(1) and never waits):
 *   SysTick_Handler   1 ms tick: time base, and urb_bridge_heartbeat() every heartbeat period
 *   UART_IRQHandler   byte received -> urb_bridge_uart_rx(); TX empty -> urb_bridge_uart_tx_pop()
 *   DOWNLINK_IRQHandler  I2C: operation complete -> urb_i2c_master_event() (CAN, RS485: below)
 * USB runs in the main loop (bsp_usb_poll), as USB device stacks usually do.
 *
 * The downlink is chosen at build time (mk/cm0_downlinks.mk): I2C by default (the bsp_i2c_*
 * functions), -DURB_BRIDGE_DOWNLINK_CAN for the CAN master on the STM32G0B1 FDCAN port
 * (urb_cm0_fdcan.h; DOWNLINK_IRQHandler = urb_cm0_can_irq), -DURB_BRIDGE_DOWNLINK_RS485 for the
 * RS485 master on its USART port (urb_cm0_usart485.h; DOWNLINK_IRQHandler = urb_cm0_rs485_irq).
 * Those two ports are register-level for that part; the rest of this file stays the generic skeleton.
 */
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "urb_bridge.h"
#include "urb_bridge_hal.h"
#include "urb_downlink.h"
#if defined(URB_BRIDGE_DOWNLINK_CAN)
#include "urb_can_master.h"
#include "urb_cm0_fdcan.h"
#elif defined(URB_BRIDGE_DOWNLINK_RS485)
#include "urb_cm0_usart485.h"
#include "urb_rs485_master.h"
#endif

#ifndef BRIDGE_CPU_HZ
#define BRIDGE_CPU_HZ 48000000u /* core clock after bsp_clock_init() */
#endif

/* ===== Board support: override these in a board file ========================================= */

#define WEAK __attribute__((weak))

/** Clocks, pins, peripherals on; the core runs at BRIDGE_CPU_HZ afterwards. */
WEAK void bsp_clock_init(void) {}
/** UART at `baud`, 8N1, receive interrupt on. */
WEAK void bsp_uart_init(uint32_t baud) { (void)baud; }
/** Reads the received byte (called from the UART interrupt when one is there); false if none. */
WEAK bool bsp_uart_rx_byte(uint8_t *byte) { (void)byte; return false; }
/** True when the transmitter can take a byte; writes it. */
WEAK bool bsp_uart_tx_ready(void) { return false; }
WEAK void bsp_uart_tx_byte(uint8_t byte) { (void)byte; }
/** Enables / disables the transmit-empty interrupt. */
WEAK void bsp_uart_tx_irq(bool on) { (void)on; }
/** I2C master controller at `khz`, interrupts on. */
WEAK void bsp_i2c_init(uint32_t khz) { (void)khz; }
WEAK void bsp_i2c_start(void) {}
WEAK void bsp_i2c_write(uint8_t byte) { (void)byte; }
WEAK void bsp_i2c_read(bool ack) { (void)ack; }
WEAK void bsp_i2c_stop(void) {}
/** Disables the controller and its interrupt (no event after return), then re-enables it idle. */
WEAK void bsp_i2c_abort(void) {}
/** The event of the operation that completed (called from the I2C interrupt). */
WEAK urb_i2c_event_t bsp_i2c_event(uint8_t *byte) { *byte = 0u; return URB_I2C_EV_ERROR; }
/** Line levels through the pins' input buffers: bit 0 SCL, bit 1 SDA. */
WEAK uint8_t bsp_i2c_lines(void) { return URB_I2C_SCL | URB_I2C_SDA; }
/** Pins as open-drain GPIO, driven: bit set = released (pulled up), clear = low. */
WEAK void bsp_i2c_drive(uint8_t lines) { (void)lines; }
/** Pins back to the I2C controller, controller reset. */
WEAK void bsp_i2c_release(void) {}
/** Timing mark pins. */
WEAK void bsp_mark(uint8_t id, bool level) { (void)id; (void)level; }
/** USB device: SOF seen since the last call; OUT transfer received (length, 0 = none); IN buffer free. */
WEAK bool bsp_usb_sof(void) { return false; }
WEAK size_t bsp_usb_out(uint8_t *buf, size_t cap) { (void)buf; (void)cap; return 0u; }
WEAK bool bsp_usb_in_free(void) { return false; }
/** Arms the IN endpoint with buf[0..len). The peripheral may read buf until the transfer is done
 *  (a DMA descriptor, as on the SAMD21): the port leaves it untouched until bsp_usb_in_free(). */
WEAK void bsp_usb_in_arm(const uint8_t *buf, size_t len) { (void)buf; (void)len; }

/* ===== Core peripherals (architectural) ====================================================== */

#define SYST_CSR (*(volatile uint32_t *)0xE000E010u)
#define SYST_RVR (*(volatile uint32_t *)0xE000E014u)
#define SYST_CVR (*(volatile uint32_t *)0xE000E018u)
#define SCB_ICSR (*(volatile uint32_t *)0xE000ED04u)
#define ICSR_PENDSTSET ((uint32_t)1u << 26) /* SysTick exception pending (reads 1 until the handler is entered) */

static inline uint32_t irq_save(void)
{
    uint32_t primask;
    __asm__ __volatile__("mrs %0, primask\n cpsid i" : "=r"(primask)::"memory");
    return primask;
}

static inline void irq_restore(uint32_t primask)
{
    __asm__ __volatile__("msr primask, %0" ::"r"(primask) : "memory");
}

/* ===== Port state (application level, not library code) ====================================== */

typedef struct {
    volatile uint32_t ms;          /* SysTick ticks */
    uint32_t hb_period_us;         /* heartbeat period, 0 = off */
    uint32_t hb_acc_us;            /* time since the last heartbeat tick */
} port_t;

static port_t g_port;
static urb_bridge_t g_bridge;
#if defined(URB_BRIDGE_DOWNLINK_CAN)
#define DOWNLINK_CAN_KBPS 1000u
static urb_cm0_can_t g_can;
static urb_can_master_t g_master;
#elif defined(URB_BRIDGE_DOWNLINK_RS485)
#define DOWNLINK_RS485_BAUD 1000000u
static urb_cm0_rs485_t g_rs485;
static urb_rs485_master_t g_master;
#else
static urb_i2c_master_t g_master;
#endif
static uint8_t g_usb_out_buf[URB_BRIDGE_USB_BUF];
/* Apart from the OUT buffer: an IN transfer still being sent reads this one (bsp_usb_in_arm) while
 * the next OUT transfer is copied out of the peripheral. */
static uint8_t g_usb_in_buf[URB_BRIDGE_USB_BUF];

/* ===== Bridge HAL ============================================================================= */

static uint32_t hal_now_us(void *ctx)
{
    port_t *p = (port_t *)ctx;
    uint32_t const per_us = BRIDGE_CPU_HZ / 1000000u;
    uint32_t ms, cvr, pend;
    /* Read the millisecond count and the down-counter consistently. Retrying while `ms` changed is
     * not enough: the counter reloads (CVR back near the top) some time before SysTick_Handler
     * increments `ms`. From an interrupt at SysTick's priority or above (UART_IRQHandler) the
     * handler cannot run at all until we return, and in thread mode its entry takes longer than
     * the reads below; in both cases `ms` is still the old count while CVR is already in the next
     * millisecond, and the time would go back by 1 ms (a spurious idle gap or I2C timeout in the
     * bridge). So also read the SysTick pending bit before and after CVR: if it changed, the
     * reload happened between the reads, retry; if it is set on both sides, the reload came before
     * CVR and the handler has not counted it yet: add that millisecond here. (One pending bit
     * counts one reload: interrupts must not stay masked for 1 ms or more, as everywhere else.) */
    do {
        ms = p->ms;
        pend = SCB_ICSR & ICSR_PENDSTSET;
        cvr = SYST_CVR;
    } while ((ms != p->ms) || (pend != (SCB_ICSR & ICSR_PENDSTSET)));
#ifdef URB_MUTANT_CLOCK_IGNORES_PENDING /* seeded bug (tests/qemu/port_clock.c): the old read */
    pend = 0u;
#endif
    if (pend != 0u) {
        ms += 1u;
    }
    return ms * 1000u + ((BRIDGE_CPU_HZ / 1000u - 1u) - cvr) / per_us;
}

static void hal_heartbeat_period(void *ctx, uint32_t period_us)
{
    port_t *p = (port_t *)ctx;
    uint32_t const s = irq_save();
    p->hb_period_us = period_us; /* 1-ms resolution here; a timer channel gives exact periods */
    p->hb_acc_us = 0u;
    irq_restore(s);
}

static void hal_uart_tx_kick(void *ctx)
{
    (void)ctx;
    bsp_uart_tx_irq(true); /* the TX-empty interrupt drains the bridge's ring */
}

static void hal_mark(void *ctx, uint8_t id, bool level)
{
    (void)ctx;
    bsp_mark(id, level);
}

static const urb_bridge_hal_t g_hal = {&g_port, hal_now_us, hal_heartbeat_period, hal_uart_tx_kick, hal_mark};

#if defined(URB_BRIDGE_DOWNLINK_CAN)
static uint32_t dl_now_us(void *owner) { (void)owner; return hal_now_us(&g_port); }
static void can_rx(void *owner, const urb_can_frame_t *frame, uint32_t t_us)
{
    (void)t_us; /* the master needs no time stamp */
    urb_can_master_rx((urb_can_master_t *)owner, frame);
}
static void can_tx_done(void *owner) { urb_can_master_tx_done((urb_can_master_t *)owner); }
#elif defined(URB_BRIDGE_DOWNLINK_RS485)
#define NVIC_ISER (*(volatile uint32_t *)0xE000E100u)
#define NVIC_ICER (*(volatile uint32_t *)0xE000E180u)
#define DOWNLINK_IRQ_BIT ((uint32_t)1u << 1) /* the vector table's placeholder IRQ 1 */
static uint32_t dl_now_us(void *owner) { (void)owner; return hal_now_us(&g_port); }
static void rs485_rx(void *owner, uint8_t byte, uint32_t t_us)
{
    urb_rs485_master_rx((urb_rs485_master_t *)owner, byte, t_us);
}
static bool rs485_tx_next(void *owner, uint8_t *byte)
{
    return urb_rs485_master_tx_next((urb_rs485_master_t *)owner, byte);
}
static void rs485_lock(void *owner, bool locked)
{
    (void)owner;
    if (locked) {
        NVIC_ICER = DOWNLINK_IRQ_BIT;
        __asm__ __volatile__("dsb\n isb" ::: "memory"); /* no USART interrupt after this returns */
    } else {
        NVIC_ISER = DOWNLINK_IRQ_BIT;
    }
}
#else
static void i2c_start(void *ctx) { (void)ctx; bsp_i2c_start(); }
static void i2c_write(void *ctx, uint8_t byte) { (void)ctx; bsp_i2c_write(byte); }
static void i2c_read(void *ctx, bool ack) { (void)ctx; bsp_i2c_read(ack); }
static void i2c_stop(void *ctx) { (void)ctx; bsp_i2c_stop(); }
static void i2c_abort(void *ctx) { (void)ctx; bsp_i2c_abort(); }
static uint8_t i2c_lines(void *ctx) { (void)ctx; return bsp_i2c_lines(); }
static void i2c_drive(void *ctx, uint8_t lines) { (void)ctx; bsp_i2c_drive(lines); }
static void i2c_release(void *ctx) { (void)ctx; bsp_i2c_release(); }

static const urb_i2c_hal_t g_i2c_hal = {NULL, i2c_start, i2c_write, i2c_read, i2c_stop,
                                        i2c_abort, i2c_lines, i2c_drive, i2c_release};
#endif

/* ===== Interrupt handlers ===================================================================== */

void SysTick_Handler(void);
void UART_IRQHandler(void);
void DOWNLINK_IRQHandler(void);

void SysTick_Handler(void)
{
    g_port.ms = g_port.ms + 1u;
    if (g_port.hb_period_us != 0u) {
        g_port.hb_acc_us += 1000u;
        if (g_port.hb_acc_us >= g_port.hb_period_us) {
            g_port.hb_acc_us -= g_port.hb_period_us;
            urb_bridge_heartbeat(&g_bridge);
        }
    }
}

void UART_IRQHandler(void)
{
    uint8_t byte;
    if (bsp_uart_rx_byte(&byte)) {
        urb_bridge_uart_rx(&g_bridge, byte, hal_now_us(&g_port));
    }
    if (bsp_uart_tx_ready()) {
        if (urb_bridge_uart_tx_pop(&g_bridge, &byte)) {
            bsp_uart_tx_byte(byte);
        } else {
            bsp_uart_tx_irq(false);
        }
    }
}

/* The downlink's interrupt: the I2C controller, the FDCAN (line 0) or the RS485 USART. */
void DOWNLINK_IRQHandler(void)
{
#if defined(URB_BRIDGE_DOWNLINK_CAN)
    urb_cm0_can_irq(&g_can);
#elif defined(URB_BRIDGE_DOWNLINK_RS485)
    urb_cm0_rs485_irq(&g_rs485);
#else
    uint8_t byte;
    urb_i2c_event_t const ev = bsp_i2c_event(&byte);
    urb_i2c_master_event(&g_master, ev, byte);
#endif
}

/* ===== Main loop ============================================================================== */

int main(void);

int main(void)
{
    urb_bridge_config_t cfg;
    urb_downlink_t dl;
    bsp_clock_init();
    SYST_RVR = BRIDGE_CPU_HZ / 1000u - 1u;
    SYST_CVR = 0u;
    SYST_CSR = 7u; /* core clock, interrupt, enable */
    urb_bridge_default_config(&cfg);
    bsp_uart_init(cfg.baud);
#if defined(URB_BRIDGE_DOWNLINK_CAN)
    urb_can_master_config_t mcfg;
    urb_can_master_default_config(&mcfg);
    mcfg.bitrate_kbps = DOWNLINK_CAN_KBPS;
    mcfg.timeout_us = urb_can_master_timeout_us(DOWNLINK_CAN_KBPS);
    mcfg.recover_us = urb_can_master_recover_us(DOWNLINK_CAN_KBPS);
    urb_cm0_can_owner_t const owner = {&g_master, can_rx, can_tx_done, NULL, dl_now_us};
    if (!urb_cm0_can_init(&g_can, URB_CM0_FDCAN1, URB_CM0_SRAMCAN1, &owner, BRIDGE_CPU_HZ, DOWNLINK_CAN_KBPS)) {
        for (;;) {
        }
    }
    urb_can_master_init(&g_master, &g_can.hal, &mcfg);
    urb_can_master_downlink(&g_master, &dl);
#elif defined(URB_BRIDGE_DOWNLINK_RS485)
    urb_cm0_rs485_owner_t const owner = {&g_master, rs485_rx, rs485_tx_next, dl_now_us, NULL, rs485_lock};
    if (!urb_cm0_rs485_init(&g_rs485, URB_CM0_USART1, &owner, BRIDGE_CPU_HZ, DOWNLINK_RS485_BAUD)) {
        for (;;) {
        }
    }
    urb_rs485_master_init(&g_master, &g_rs485.hal, DOWNLINK_RS485_BAUD, hal_now_us(&g_port));
    urb_rs485_master_downlink(&g_master, &dl);
    NVIC_ISER = DOWNLINK_IRQ_BIT;
#else
    urb_i2c_master_config_t mcfg;
    urb_i2c_master_default_config(&mcfg);
    bsp_i2c_init(mcfg.bitrate_kbps);
    urb_i2c_master_init(&g_master, &g_i2c_hal, &mcfg);
    urb_i2c_master_downlink(&g_master, &dl);
#endif
    if (urb_bridge_init(&g_bridge, &cfg, &g_hal, &dl) != URB_OK) {
        for (;;) {
        }
    }
    for (;;) {
        if (bsp_usb_sof()) {
            urb_bridge_usb_sof(&g_bridge);
        }
        size_t const n = bsp_usb_out(g_usb_out_buf, sizeof g_usb_out_buf);
        if (n > 0u) {
            (void)urb_bridge_usb_out(&g_bridge, g_usb_out_buf, n);
        }
        if (bsp_usb_in_free()) {
            size_t const m = urb_bridge_usb_in(&g_bridge, g_usb_in_buf, sizeof g_usb_in_buf);
            if (m > 0u) {
                bsp_usb_in_arm(g_usb_in_buf, m);
            }
        }
        urb_bridge_poll(&g_bridge);
        /* Sleep only when nothing is pending; checked with interrupts masked so a byte arriving
         * in between wakes the WFI instead of being left for the next tick. */
        uint32_t const s = irq_save();
        if (urb_bridge_idle(&g_bridge)) {
            __asm__ __volatile__("wfi");
        }
        irq_restore(s);
    }
}

/* ===== Startup ================================================================================ */

extern uint32_t __data_load[], __data_start[], __data_end[], __bss_start[], __bss_end[], __stack_top[];
void Reset_Handler(void);
void Default_Handler(void);

void Reset_Handler(void)
{
    uint32_t const *src = __data_load;
    uint32_t *dst = __data_start;
    /* loop bound: the .data section, fixed at link time */
    while (dst < __data_end) {
        *dst = *src;
        dst++;
        src++;
    }
    dst = __bss_start;
    while (dst < __bss_end) {
        *dst = 0u;
        dst++;
    }
    (void)main();
    for (;;) {
    }
}

void Default_Handler(void)
{
    for (;;) {
    }
}

typedef void (*vector_t)(void);

/* 16 system vectors, then the vendor IRQs; the board file places the UART and the downlink at
 * their IRQ numbers (here 0 and 1 as placeholders). */
__attribute__((section(".vectors"), used)) static const vector_t g_vectors[16 + 2] = {
    (vector_t)(uintptr_t)__stack_top,
    Reset_Handler,
    Default_Handler, /* NMI */
    Default_Handler, /* HardFault */
    0, 0, 0, 0, 0, 0, 0,
    Default_Handler, /* SVCall */
    0, 0,
    Default_Handler, /* PendSV */
    SysTick_Handler,
    UART_IRQHandler,
    DOWNLINK_IRQHandler,
};

/* The compiler may call these for struct copies; no C library is linked. */
void *memcpy(void *dst, const void *src, size_t n);
void *memset(void *dst, int c, size_t n);

void *memcpy(void *dst, const void *src, size_t n)
{
    uint8_t *d = (uint8_t *)dst;
    const uint8_t *s = (const uint8_t *)src;
    for (size_t i = 0u; i < n; i++) {
        d[i] = s[i];
    }
    return dst;
}

void *memset(void *dst, int c, size_t n)
{
    uint8_t *d = (uint8_t *)dst;
    for (size_t i = 0u; i < n; i++) {
        d[i] = (uint8_t)c;
    }
    return dst;
}
