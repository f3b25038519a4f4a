/*
 * Cortex-M0+ reference port (see urb_hal_cm0.h). Register-level, no vendor headers: every
 * address and bit below is VENDOR (STM32G0 numbering, RM0444) and must be checked for the part.
 */
#include "urb_hal_cm0.h"

#include <stddef.h>

#define REG32(addr) (*(volatile uint32_t *)(uintptr_t)(addr))

/* ----- VENDOR: STM32G0 peripheral map ----- */
#define RCC_BASE 0x40021000u
#define RCC_IOPENR REG32(RCC_BASE + 0x34u)
#define RCC_APBENR1 REG32(RCC_BASE + 0x3Cu)
#define RCC_IOPENR_GPIOA ((uint32_t)1u << 0)
#define RCC_IOPENR_GPIOB ((uint32_t)1u << 1)
#define RCC_APBENR1_TIM2 ((uint32_t)1u << 0)
#define RCC_APBENR1_I2C1 ((uint32_t)1u << 21)

#define GPIOA_BASE 0x50000000u
#define GPIOB_BASE 0x50000400u
#define GPIO_MODER(b) REG32((b) + 0x00u)
#define GPIO_OTYPER(b) REG32((b) + 0x04u)
#define GPIO_BSRR(b) REG32((b) + 0x18u)
#define GPIO_AFRL(b) REG32((b) + 0x20u)

#define TIM2_BASE 0x40000000u
#define TIM2_CR1 REG32(TIM2_BASE + 0x00u)
#define TIM2_DIER REG32(TIM2_BASE + 0x0Cu)
#define TIM2_SR REG32(TIM2_BASE + 0x10u)
#define TIM2_CNT REG32(TIM2_BASE + 0x24u)
#define TIM2_PSC REG32(TIM2_BASE + 0x28u)
#define TIM2_ARR REG32(TIM2_BASE + 0x2Cu)
#define TIM2_CCR1 REG32(TIM2_BASE + 0x34u)
#define TIM_CR1_CEN ((uint32_t)1u << 0)
#define TIM_DIER_CC1IE ((uint32_t)1u << 1)
#define TIM_SR_CC1IF ((uint32_t)1u << 1)

#define I2C1_BASE 0x40005400u
#define I2C_CR1 REG32(I2C1_BASE + 0x00u)
#define I2C_CR2 REG32(I2C1_BASE + 0x04u)
#define I2C_OAR1 REG32(I2C1_BASE + 0x08u)
#define I2C_TIMINGR REG32(I2C1_BASE + 0x10u)
#define I2C_TIMEOUTR REG32(I2C1_BASE + 0x14u)
#define I2C_ISR REG32(I2C1_BASE + 0x18u)
#define I2C_ICR REG32(I2C1_BASE + 0x1Cu)
#define I2C_RXDR REG32(I2C1_BASE + 0x24u)
#define I2C_TXDR REG32(I2C1_BASE + 0x28u)
#define I2C_CR1_PE ((uint32_t)1u << 0)
#define I2C_CR1_TXIE ((uint32_t)1u << 1)
#define I2C_CR1_ADDRIE ((uint32_t)1u << 3)
#define I2C_CR1_NACKIE ((uint32_t)1u << 4)
#define I2C_CR1_STOPIE ((uint32_t)1u << 5)
#define I2C_CR1_TCIE ((uint32_t)1u << 6) /* TCR interrupt in slave byte control */
#define I2C_CR1_ERRIE ((uint32_t)1u << 7)
#define I2C_CR1_SBC ((uint32_t)1u << 16)
#define I2C_CR1_GCEN ((uint32_t)1u << 19)
#define I2C_CR2_NBYTES_1 ((uint32_t)1u << 16)
#define I2C_CR2_NBYTES_MASK ((uint32_t)0xFFu << 16)
#define I2C_CR2_RELOAD ((uint32_t)1u << 24)
#define I2C_CR2_NACK ((uint32_t)1u << 15)
#define I2C_OAR1_EN ((uint32_t)1u << 15)
#define I2C_ISR_TXE ((uint32_t)1u << 0)
#define I2C_ISR_TXIS ((uint32_t)1u << 1)
#define I2C_ISR_ADDR ((uint32_t)1u << 3)
#define I2C_ISR_NACKF ((uint32_t)1u << 4)
#define I2C_ISR_STOPF ((uint32_t)1u << 5)
#define I2C_ISR_TCR ((uint32_t)1u << 7)
#define I2C_ISR_BERR ((uint32_t)1u << 8)
#define I2C_ISR_ARLO ((uint32_t)1u << 9)
#define I2C_ISR_OVR ((uint32_t)1u << 10)
#define I2C_ISR_TIMEOUT ((uint32_t)1u << 12)
#define I2C_ISR_DIR ((uint32_t)1u << 16)
#define I2C_ISR_ADDCODE_SHIFT 17u
#define I2C_ICR_ALL 0x3F38u /* ADDRCF NACKCF STOPCF BERRCF ARLOCF OVRCF PECCF TIMOUTCF ALERTCF */
#define I2C_TIMEOUTR_STUCK (((uint32_t)1u << 15) | 1094u) /* TIMOUTEN, SCL low > ~35 ms (TIMEOUTA at 48 MHz / 2048) */

#define IRQ_TIM2 15u
#define IRQ_I2C1 23u
#define NVIC_ISER REG32(0xE000E100u)
#define NVIC_IPR(n) REG32(0xE000E400u + 4u * ((n) / 4u))
#define IRQ_PRIORITY 0x80u /* the same for both: they must not preempt each other */

/* Mark pins: PA0..PA2, one per urb_node_mark_t (board-specific). */
#define MARK_PIN(m) ((uint32_t)1u << (unsigned)(m))

/* ----- HAL functions ----- */

static uint32_t cm0_now(void *ctx)
{
    (void)ctx;
    return TIM2_CNT;
}

static void cm0_set_compare(void *ctx, uint32_t at)
{
    (void)ctx;
    TIM2_CCR1 = at;                /* the library keeps `at` at least 1 us ahead */
    TIM2_SR = ~TIM_SR_CC1IF;       /* rc_w0: clear a stale match */
    TIM2_DIER |= TIM_DIER_CC1IE;
}

static void cm0_set_address(void *ctx, uint8_t address)
{
    (void)ctx;
    I2C_CR1 &= ~I2C_CR1_PE;
    I2C_OAR1 = 0u;
    I2C_OAR1 = I2C_OAR1_EN | ((uint32_t)address << 1);
    I2C_CR1 |= I2C_CR1_PE; /* from here the node answers: interrupts enabled in init */
}

static void cm0_mark(void *ctx, urb_node_mark_t mark)
{
    (void)ctx;
    GPIO_BSRR(GPIOA_BASE) = MARK_PIN(mark);         /* a short pulse: two stores, no read-modify-write */
    GPIO_BSRR(GPIOA_BASE) = MARK_PIN(mark) << 16;
}

static void nvic_enable(uint32_t irq)
{
    uint32_t const shift = 8u * (irq % 4u);
    NVIC_IPR(irq) = (NVIC_IPR(irq) & ~((uint32_t)0xFFu << shift)) | ((uint32_t)IRQ_PRIORITY << shift);
    NVIC_ISER = (uint32_t)1u << irq;
}

void urb_hal_cm0_init(urb_hal_cm0_t *port)
{
    port->hal.ctx = port;
    port->hal.now = cm0_now;
    port->hal.set_compare = cm0_set_compare;
    port->hal.sync_capture = NULL; /* no capture on the address match here: t_d read in the ISR */
    port->hal.set_address = cm0_set_address;
    port->hal.mark = cm0_mark;
    port->hal.identify = NULL;
    port->node = NULL;

    /* VENDOR: clocks (the core already runs at 48 MHz from the PLL, set up by the board) */
    RCC_IOPENR |= RCC_IOPENR_GPIOA | RCC_IOPENR_GPIOB;
    RCC_APBENR1 |= RCC_APBENR1_TIM2 | RCC_APBENR1_I2C1;

    /* VENDOR: PA0..PA2 outputs (marks); PB6/PB7 = I2C1 SCL/SDA, alternate function 6, open drain */
    GPIO_MODER(GPIOA_BASE) = (GPIO_MODER(GPIOA_BASE) & ~0x3Fu) | 0x15u;
    GPIO_MODER(GPIOB_BASE) = (GPIO_MODER(GPIOB_BASE) & ~((uint32_t)0xFu << 12)) | ((uint32_t)0xAu << 12);
    GPIO_OTYPER(GPIOB_BASE) |= ((uint32_t)1u << 6) | ((uint32_t)1u << 7);
    GPIO_AFRL(GPIOB_BASE) = (GPIO_AFRL(GPIOB_BASE) & ~((uint32_t)0xFFu << 24)) | ((uint32_t)0x66u << 24);

    /* TIM2: free-running 32-bit counter at the core clock; CC1 = heartbeat compare */
    TIM2_PSC = 0u;
    TIM2_ARR = 0xFFFFFFFFu;
    TIM2_CR1 = TIM_CR1_CEN;

    /* I2C1 slave: 400 kb/s timing (VENDOR value for 48 MHz), slave byte control so that every
     * received byte can be ACKed or NACKed by software, general call on, SCL-low timeout. */
    I2C_TIMINGR = 0x00601A5Bu;
    I2C_TIMEOUTR = I2C_TIMEOUTR_STUCK;
    I2C_CR1 = I2C_CR1_SBC | I2C_CR1_GCEN | I2C_CR1_ADDRIE | I2C_CR1_TXIE | I2C_CR1_NACKIE | I2C_CR1_STOPIE |
              I2C_CR1_TCIE | I2C_CR1_ERRIE; /* PE is set by set_address */

    nvic_enable(IRQ_TIM2);
    nvic_enable(IRQ_I2C1);
}

void urb_hal_cm0_attach(urb_hal_cm0_t *port, urb_node_t *node)
{
    port->node = node;
}

void urb_hal_cm0_timer_irq(urb_hal_cm0_t *port)
{
    if ((TIM2_SR & TIM_SR_CC1IF) != 0u) {
        TIM2_SR = ~TIM_SR_CC1IF;
        TIM2_DIER &= ~TIM_DIER_CC1IE; /* re-armed by set_compare */
        urb_node_timer_event(port->node);
    }
}

/* Releases the stretched clock for the next received byte, ACKing or NACKing this one. */
static void rx_reload(uint16_t verdict)
{
    uint32_t cr2 = (I2C_CR2 & ~I2C_CR2_NBYTES_MASK) | I2C_CR2_NBYTES_1 | I2C_CR2_RELOAD;
    if (verdict != URB_I2C_ACK) {
        cr2 |= I2C_CR2_NACK;
    }
    I2C_CR2 = cr2;
}

void urb_hal_cm0_i2c_irq(urb_hal_cm0_t *port)
{
    urb_node_t *node = port->node;
    uint32_t const isr = I2C_ISR;
    if ((isr & (I2C_ISR_BERR | I2C_ISR_ARLO | I2C_ISR_OVR)) != 0u) {
        I2C_ICR = I2C_ICR_ALL;
        (void)urb_node_i2c_event(node, URB_I2C_BUS_ERROR, 0u);
        return;
    }
    if ((isr & I2C_ISR_TIMEOUT) != 0u) {
        I2C_ICR = I2C_ICR_ALL;
        (void)urb_node_i2c_event(node, URB_I2C_STUCK, 0u);
        return;
    }
    if ((isr & I2C_ISR_ADDR) != 0u) {
        uint32_t const code = (isr >> I2C_ISR_ADDCODE_SHIFT) & 0x7Fu;
        uint16_t verdict;
        if ((isr & I2C_ISR_DIR) != 0u) {
            verdict = urb_node_i2c_event(node, URB_I2C_ADDR_READ, 0u);
            I2C_ISR = I2C_ISR_TXE; /* flush a byte left from an aborted read */
        } else {
            verdict = urb_node_i2c_event(node, (code == 0u) ? URB_I2C_GENERAL_CALL : URB_I2C_ADDR_WRITE, 0u);
            rx_reload(URB_I2C_ACK); /* one byte at a time, ACK decided per byte */
        }
        (void)verdict;            /* the address is always ACKed by the peripheral */
        I2C_ICR = (uint32_t)1u << 3;        /* ADDRCF: release the clock */
    }
    if ((isr & I2C_ISR_TCR) != 0u) {
        uint8_t const byte = (uint8_t)I2C_RXDR;
        rx_reload(urb_node_i2c_event(node, URB_I2C_RX_BYTE, byte));
    }
    if ((isr & I2C_ISR_TXIS) != 0u) {
        I2C_TXDR = (uint32_t)urb_node_i2c_event(node, URB_I2C_TX_BYTE, 0u) & 0xFFu;
    }
    if ((isr & I2C_ISR_NACKF) != 0u) {
        I2C_ICR = (uint32_t)1u << 4;
        (void)urb_node_i2c_event(node, URB_I2C_TX_NACK, 0u);
    }
    if ((isr & I2C_ISR_STOPF) != 0u) {
        I2C_ICR = (uint32_t)1u << 5;
        (void)urb_node_i2c_event(node, URB_I2C_STOP, 0u);
    }
}

void urb_hal_cm0_sleep(const urb_node_t *node)
{
    __asm__ __volatile__("cpsid i" ::: "memory");
    if (!urb_node_has_work(node)) {
        __asm__ __volatile__("wfi" ::: "memory"); /* a pending interrupt wakes it even while masked */
    }
    __asm__ __volatile__("cpsie i" ::: "memory");
}
