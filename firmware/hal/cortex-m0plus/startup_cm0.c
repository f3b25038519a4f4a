/*
 * Minimal Cortex-M0+ startup for the reference images: vector table, .data copy, .bss clear,
 * main. The IRQ handlers are weak aliases of Default_Handler; the application defines the ones
 * it uses (TIM2_IRQHandler, I2C1_IRQHandler; the CAN and RS485 node images TIM16_FDCAN_IT0_IRQHandler,
 * USART1_IRQHandler). VENDOR: the IRQ list follows the STM32G0 table.
 */
#include <stdint.h>

extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _estack;
int main(void);

void Reset_Handler(void);
void Default_Handler(void);
void NMI_Handler(void) __attribute__((weak, alias("Default_Handler")));
void HardFault_Handler(void) __attribute__((weak, alias("Default_Handler")));
void SVC_Handler(void) __attribute__((weak, alias("Default_Handler")));
void PendSV_Handler(void) __attribute__((weak, alias("Default_Handler")));
void SysTick_Handler(void) __attribute__((weak, alias("Default_Handler")));
void TIM2_IRQHandler(void) __attribute__((weak, alias("Default_Handler")));
void I2C1_IRQHandler(void) __attribute__((weak, alias("Default_Handler")));
void TIM16_FDCAN_IT0_IRQHandler(void) __attribute__((weak, alias("Default_Handler")));
void USART1_IRQHandler(void) __attribute__((weak, alias("Default_Handler")));

typedef void (*handler_t)(void);

typedef struct {
    uint32_t *stack;
    handler_t vectors[47];
} vector_table_t;

__attribute__((section(".isr_vector"), used)) static const vector_table_t vector_table = {
    &_estack,
    {
        Reset_Handler, NMI_Handler, HardFault_Handler, 0, 0, 0, 0, 0, 0, 0, SVC_Handler, 0, 0, PendSV_Handler,
        SysTick_Handler,
        /* IRQ 0..31 */
        Default_Handler, Default_Handler, Default_Handler, Default_Handler, Default_Handler, Default_Handler,
        Default_Handler, Default_Handler, Default_Handler, Default_Handler, Default_Handler, Default_Handler,
        Default_Handler, Default_Handler, Default_Handler, TIM2_IRQHandler /* 15 */, Default_Handler,
        Default_Handler, Default_Handler, Default_Handler, Default_Handler,
        TIM16_FDCAN_IT0_IRQHandler /* 21 */, Default_Handler, I2C1_IRQHandler /* 23 */, Default_Handler,
        Default_Handler, Default_Handler, USART1_IRQHandler /* 27 */, Default_Handler, Default_Handler,
        Default_Handler, Default_Handler,
    },
};

void Reset_Handler(void)
{
    /* bound: the size of .data / .bss, fixed at link time */
    uint32_t const *src = &_sidata;
    uint32_t *dst = &_sdata;
    while (dst < &_edata) {
        *dst = *src;
        dst++;
        src++;
    }
    dst = &_sbss;
    while (dst < &_ebss) {
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
