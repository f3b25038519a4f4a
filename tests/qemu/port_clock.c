/* The Cortex-M0+ bridge port's clock on QEMU (-M microbit): hal_now_us() must never go back, even
 * when SysTick has reloaded and its handler has not counted the millisecond yet (as seen from an
 * interrupt handler, or with interrupts masked). The real port file is compiled in whole, with its
 * vector table, reset handler, SysTick set-up and SysTick_Handler; its urb_bridge_init() call is
 * renamed to this test, which runs with SysTick ticking instead of the bridge. */
#include <stdint.h>

#include "semihost.h"

#define urb_bridge_init port_clock_test
#include "bridge_port.c"
#undef urb_bridge_init

#define ROUNDS 20u

static void line(const char *verdict, uint32_t k, const char *what, uint32_t before, uint32_t after)
{
    sh_line_t l;
    sh_clear(&l);
    sh_str(&l, verdict);
    sh_udec(&l, k);
    sh_str(&l, what);
    sh_udec(&l, before);
    sh_str(&l, " us, then ");
    sh_udec(&l, after);
    sh_str(&l, " us");
    sh_flush(&l);
}

int32_t port_clock_test(urb_bridge_t *b, const urb_bridge_config_t *cfg, const urb_bridge_hal_t *hal,
                        const urb_downlink_t *dl)
{
    (void)b;
    (void)cfg;
    (void)dl;
    sh_write0("# URB Cortex-M0+ bridge port: hal_now_us() across SysTick reloads (QEMU -M microbit)\n");
    __asm__ __volatile__("cpsie i" ::: "memory");
    uint32_t failed = 0u;
    uint32_t prev = hal->now_us(hal->ctx);
    for (uint32_t k = 1u; k <= ROUNDS; k++) {
        /* interrupts masked, as inside UART_IRQHandler: SysTick reloads and stays pending */
        uint32_t const saved = irq_save();
        uint32_t spins = 0u;
        while (((SCB_ICSR & ICSR_PENDSTSET) == 0u) && (spins < 100000000u)) {
            spins++;
        }
        uint32_t const pending = SCB_ICSR & ICSR_PENDSTSET;
        uint32_t const now = hal->now_us(hal->ctx);
        irq_restore(saved); /* SysTick_Handler counts the millisecond */
        uint32_t const after = hal->now_us(hal->ctx);
        if ((pending == 0u) || ((int32_t)(now - prev) < 0) || ((int32_t)(after - now) < 0)) {
            failed++;
            line("not ok ", k, pending == 0u ? " - SysTick never became pending: " : " - time went back: ", prev, now);
        } else {
            line("ok ", k, " - SysTick pending, time did not go back: ", prev, now);
        }
        prev = after;
    }
    sh_line_t l;
    sh_clear(&l);
    sh_str(&l, "# ");
    sh_udec(&l, ROUNDS);
    sh_str(&l, " checks, ");
    sh_udec(&l, failed);
    sh_str(&l, " failed");
    sh_flush(&l);
    sh_exit(failed == 0u ? 0u : 1u);
}
