/*
 * Startup of the Cortex-M0 test program on QEMU's `-M microbit` (nRF51822: Cortex-M0, flash at
 * 0x0, 16 KiB RAM at 0x20000000; see microbit.ld): vector table, .data copy, .bss clear, main,
 * then main's return value as QEMU's exit status over semihosting.
 *
 * Every exception reports over semihosting and ends the run with a distinct status, so a fault can
 * never look like a pass or a hang: HardFault -> 3 (ARMv6-M escalates every fault, an unaligned
 * LDR/STR included, to HardFault), any other exception or interrupt -> 4.
 */
#include <stdint.h>

#include "semihost.h"

#define QT_STATUS_HARDFAULT 3u
#define QT_STATUS_EXCEPTION 4u

extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _estack;
int main(void);

void Reset_Handler(void);
void HardFault_Handler(void);
void Default_Handler(void);
void qt_hardfault(const uint32_t *frame, uint32_t exc_return);

typedef void (*handler_t)(void);

typedef struct {
    uint32_t *stack;
    handler_t vectors[15 + 32]; /* 15 system exceptions, 32 nRF51 interrupts */
} vector_table_t;

__attribute__((section(".isr_vector"), used)) static const vector_table_t vector_table = {
    &_estack,
    {
        Reset_Handler, Default_Handler /* NMI */, HardFault_Handler, 0, 0, 0, 0, 0, 0, 0,
        Default_Handler /* SVCall */, 0, 0, Default_Handler /* PendSV */, Default_Handler /* SysTick */,
        Default_Handler, Default_Handler, Default_Handler, Default_Handler, Default_Handler, Default_Handler,
        Default_Handler, Default_Handler, Default_Handler, Default_Handler, Default_Handler, Default_Handler,
        Default_Handler, Default_Handler, Default_Handler, Default_Handler, Default_Handler, Default_Handler,
        Default_Handler, Default_Handler, Default_Handler, Default_Handler, Default_Handler, Default_Handler,
        Default_Handler, Default_Handler, Default_Handler, Default_Handler, Default_Handler, Default_Handler,
        Default_Handler, Default_Handler,
    },
};

void Reset_Handler(void)
{
    /* bound: the size of .data / .bss, fixed at link time */
    uint32_t const *src = &_sidata;
    for (uint32_t *dst = &_sdata; dst < &_edata; dst++) {
        *dst = *src++;
    }
    for (uint32_t *dst = &_sbss; dst < &_ebss; dst++) {
        *dst = 0u;
    }
    sh_exit((uint32_t)main());
}

/* The stacked exception frame (r0-r3, r12, lr, pc, xpsr) is on the stack EXC_RETURN names. */
__attribute__((naked)) void HardFault_Handler(void)
{
    __asm__ volatile(
        "movs r0, #4        \n"
        "mov  r1, lr        \n"
        "tst  r0, r1        \n"
        "beq  1f            \n"
        "mrs  r0, psp       \n"
        "b    2f            \n"
        "1:                 \n"
        "mrs  r0, msp       \n"
        "2:                 \n"
        "ldr  r2, =qt_hardfault \n"
        "bx   r2            \n"
        ".ltorg             \n");
}

void qt_hardfault(const uint32_t *frame, uint32_t exc_return)
{
    sh_line_t line;
    uint32_t const pc = frame[6];
    sh_clear(&line);
    sh_str(&line, "HardFault: pc=");
    sh_hex(&line, pc, 8u);
    sh_str(&line, " lr=");
    sh_hex(&line, frame[5], 8u);
    sh_str(&line, " r0=");
    sh_hex(&line, frame[0], 8u);
    sh_str(&line, " r3=");
    sh_hex(&line, frame[3], 8u);
    sh_str(&line, " exc_return=");
    sh_hex(&line, exc_return, 8u);
    if (pc < 0x40000u && (pc & 1u) == 0u) { /* in flash: show the faulting Thumb instruction */
        sh_str(&line, " insn=");
        sh_hex(&line, *(const uint16_t *)(uintptr_t)pc, 4u);
    }
    sh_flush(&line);
    sh_str(&line, "# ARMv6-M has no fault status registers: an unaligned LDR/STR, a bad address, an undefined");
    sh_flush(&line);
    sh_str(&line, "# instruction or an escalated exception; tests/qemu/run.sh names the source line of pc");
    sh_flush(&line);
    sh_exit(QT_STATUS_HARDFAULT);
}

void Default_Handler(void)
{
    uint32_t ipsr;
    __asm__ volatile("mrs %0, ipsr" : "=r"(ipsr));
    sh_line_t line;
    sh_clear(&line);
    sh_str(&line, "unexpected exception ");
    sh_udec(&line, ipsr & 0x3Fu);
    sh_flush(&line);
    sh_exit(QT_STATUS_EXCEPTION);
}
