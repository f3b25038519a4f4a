/*
 * fw_budgets.h: cycle budgets of the firmware paths under proof, derived from the bus timing and
 * the 1-ms cycle on the reference core (Cortex-M0+ at 48 MHz). The firmware proofs assert their
 * cost counter (urb_proof_cost, proofs/bmc/include/urb_verify.h) against these; the comments below
 * explain each one and tools/proofs.py prints them next to the proved worst cases
 * (build/proofs/summary.md).
 *
 * Every number is a macro of the timing it comes from, so a different clock or bus rate changes
 * the budgets, not the proofs. Half of a period is the rule for interrupt paths (the other half
 * is for interrupt entry/exit, the other interrupts of equal priority and the main loop).
 */
#ifndef FW_BUDGETS_H
#define FW_BUDGETS_H

#define FW_CPU_HZ 48000000u /* reference core: Cortex-M0+ at 48 MHz */
#define FW_CYCLES_PER_US (FW_CPU_HZ / 1000000u)

/* I2C fast mode: 400 kb/s, 9 bit times per byte (8 data + ACK) = 22.5 us = 1080 cycles. */
#define FW_I2C_BIT_RATE 400000u
#define FW_I2C_BYTE_CYCLES ((FW_CPU_HZ / FW_I2C_BIT_RATE) * 9u)
/* An I2C byte event (node slave or bridge master) must finish well within one byte time. */
#define FW_I2C_EVENT_BUDGET (FW_I2C_BYTE_CYCLES / 2u)

/* The node's heartbeat timer interrupt runs at the I2C interrupt's priority: together with one I2C
 * byte event it must fit in one byte time, so it gets the other half. */
#define FW_TIMER_EVENT_BUDGET (FW_I2C_BYTE_CYCLES / 2u)

/* RS232 at 115200 Bd, 10 bit times per byte (start, 8 data, stop) = 86.8 us = 4166 cycles. */
#define FW_UART_BAUD 115200u
#define FW_UART_BYTE_CYCLES ((FW_CPU_HZ / FW_UART_BAUD) * 10u)
#define FW_UART_EVENT_BUDGET (FW_UART_BYTE_CYCLES / 2u)

/* The 1-ms cycle: the heartbeat / SYNC period and the USB frame. */
#define FW_CYCLE_US 1000u
#define FW_CYCLE_CYCLES (FW_CYCLE_US * FW_CYCLES_PER_US)

/* Main-loop paths. A mailbox lock or release is a few loads and stores; budget: one I2C byte time,
 * so an application update (which locks and releases a few mailboxes) stays far inside the cycle. */
#define FW_APP_BUDGET FW_I2C_BYTE_CYCLES

/* Bridge main loop, per RS232 byte drained from the ring: the line delivers one byte per
 * FW_UART_BYTE_CYCLES, so parsing must keep up with half of it (the other half: serving and
 * emitting). */
#define FW_RS232_BYTE_BUDGET (FW_UART_BYTE_CYCLES / 2u)

/* Bridge main loop, per USB OUT transfer: the whole transfer is admitted within half a 1-ms frame. */
#define FW_USB_TRANSFER_BUDGET (FW_CYCLE_CYCLES / 2u)

/* Node main loop: one urb_node_poll without the application's hooks (an inbox-0 command, the fault
 * delivery, the identification refresh) within a tenth of the cycle. */
#define FW_POLL_BUDGET (FW_CYCLE_CYCLES / 10u)

/* Bridge request FIFO: admitting one request (the decoder's check included) within half of the
 * shortest request's line time (a 4-byte read request: 4 UART byte times). */
#define FW_ADMIT_BUDGET ((4u * FW_UART_BYTE_CYCLES) / 2u)

/* Bridge downlink master: begin() (computes the write check over up to 33 bytes) and one poll()
 * (verifies a read check) within one I2C byte time each, so the bus never idles on the CPU. */
#define FW_MASTER_CALL_BUDGET FW_I2C_BYTE_CYCLES

/* ----- Node proofs (proofs/bmc/fw_node_*) ----- */

/* Node main loop, one inbox-0 command (lock, decode, release, dispatch; the application's hooks
 * are the application's time, not counted). It shares FW_POLL_BUDGET with the fault delivery, the
 * update bookkeeping and the identification refresh (which encodes 25 bytes, the largest part):
 * a quarter of it (1200 cycles = 25 us, about one I2C byte time), so a command that arrives
 * just before a heartbeat delays that heartbeat's app_update by about one downlink byte. */
#define FW_COMMAND_BUDGET (FW_POLL_BUDGET / 4u)

/* A HAL call from the library (now(), set_compare(), mark(), identify()): BLX through the hal
 * table, one peripheral register access and the return, counted where a proof stubs the HAL. */
#define FW_HAL_CALL_CYCLES 16u

/* Software division on Cortex-M0+ (no divide instruction): libgcc's __aeabi_uidiv for ARMv6-M
 * runs up to 32 shift-compare-subtract steps of about 4 cycles plus call overhead. */
#define FW_UDIV_CYCLES 160u

/* The PLL update (urb_pll_sync: eqs. 1-2, one software division) runs inside the I2C event of a
 * SYNC's counter byte, the last byte of the broadcast. The node's next byte event needing an answer
 * is at the earliest the address byte of the next transaction, after STOP and START: one byte time
 * later. So the update may take one I2C byte time on top of the byte's own event budget (the slave
 * peripheral stretches SCL if it is ever exceeded: the bus slows, no data is lost). */
#define FW_PLL_SYNC_BUDGET FW_I2C_BYTE_CYCLES

/* ===== Bridge proofs (proofs/bmc/fw_bridge_*) ============================================== */

/* I2C master begin() and poll(): each runs once or twice per transaction in the main loop (begin
 * computes the write check, the final poll verifies the read check, both over up to 33 bytes), so
 * the bus waits for them between transactions. Two I2C byte times each: at most 4 byte times of
 * idle bus per transaction, against at least 4 bytes on the bus (a SYNC) and 36 for a long read. */
#define FW_BRIDGE_MASTER_CALL_BUDGET (2u * FW_I2C_BYTE_CYCLES)

/* RS232 parsing, amortised per received byte (hunting included): 7/8 of a UART byte time. The
 * worst case is a line of garbage, where every byte completes a 37-byte candidate that fails its
 * check; that produces no requests, so no admission or response work competes with it. A stream
 * of good frames costs far less per byte (one check per frame) and leaves the rest of the byte
 * time to admitting and answering. Over the budget, the 64-byte receive ring would overflow. */
#define FW_BRIDGE_RS232_BYTE_BUDGET ((7u * FW_UART_BYTE_CYCLES) / 8u)

/* RS232 parsing, one poll: half the 1-ms cycle, as for a USB transfer (below), so the main loop is
 * back at the downlink, and at a due SYNC, within half a cycle whatever the line carried. The parser
 * meets it with at most URB_BRIDGE_HUNT_CHECKS frame checks and URB_BRIDGE_RX_PER_POLL ring bytes
 * per poll (fw_bridge_rs232_parser: its linear cost form at those counts); the rest waits. */
#define FW_BRIDGE_RS232_POLL_BUDGET (FW_CYCLE_CYCLES / 2u)

/* USB: one OUT transfer's parsing within half the 1-ms frame (FW_USB_TRANSFER_BUDGET), beyond the
 * decoding of the requests it carries. Decoding a request is admission work, charged to that
 * request (FW_ADMIT_BUDGET each, fw_bridge_fifo) and bounded in number by the host's window; a
 * transfer of 13 valid 32-byte writes decodes for ~35 k cycles by the cost model, so no budget
 * that includes it fits half a frame. What the parser adds (header, one round per frame, and at
 * most one failing candidate, since a transfer is cut at its first bad frame) must fit. */
#define FW_BRIDGE_USB_TRANSFER_BUDGET FW_USB_TRANSFER_BUDGET

/* Request FIFO (fw_bridge_fifo): one admission, one completion, or one response emitted (its
 * encoding, check and queuing on the uplink included; per response when one pass emits several),
 * within a sixth of the 1-ms cycle. Every request goes through each of the three once, so its FIFO
 * work fits in half a cycle even when all three fall into one main-loop pass, and the pass is back
 * at the downlink and a due SYNC within the cycle (the other half: one poll's parsing,
 * FW_BRIDGE_RS232_POLL_BUDGET). That also keeps up with the slowest uplink (a 4-byte read request
 * takes 4 x 4160 cycles at 115200 Bd) and with I2C: the costliest response to emit, a 32-byte
 * read's, comes from a transaction of at least 37 I2C byte times (~40 000 cycles). */
#define FW_BRIDGE_FIFO_OP_BUDGET (FW_CYCLE_CYCLES / 6u)

/* ===== Downlink proofs (proofs/bmc/fw_can_*, fw_rs485_*; issue #39) ========================= */

/* CAN at 1 Mb/s: the shortest URB frame (one data byte, the tail; no stuff bit) is 47 + 8 = 55 bit
 * times = 55 us = 2640 cycles, the least time between two frame interrupts. A frame's handling
 * (urb_can_tx_next building the next frame, urb_can_rx_frame taking one) gets half of it, as every
 * interrupt path. (A frame of 8 data bytes takes up to 135 bit times: 135 us; the short frames set
 * the budget.) */
#define FW_CAN_BIT_RATE 1000000u
#define FW_CAN_SHORTEST_FRAME_BITS 55u
#define FW_CAN_FRAME_BUDGET (((FW_CPU_HZ / FW_CAN_BIT_RATE) * FW_CAN_SHORTEST_FRAME_BITS) / 2u)

/* RS485 at 1 Mb/s: one character (8N1) is 10 bit times = 10 us = 480 cycles. A received byte's
 * handling (urb_rs485_rx_byte: both CRC tiers advance, two bytes behind the line) costs up to ~370
 * cycles by the model, so it does NOT fit half a character at 1 Mb/s (it does at 500 kBd, where a
 * character is 960 cycles). The budget is the whole character: at 1 Mb/s the port must take bytes
 * from the UART's receive FIFO (the STM32G0 USART holds 8) so that the interrupt's entry and the
 * other interrupts do not lose a byte (fw_rs485_frame proves the cycles; the README says it). */
#define FW_RS485_BAUD 1000000u
#define FW_RS485_BYTE_CYCLES ((FW_CPU_HZ / FW_RS485_BAUD) * 10u)
#define FW_RS485_BYTE_BUDGET FW_RS485_BYTE_CYCLES

#endif /* FW_BUDGETS_H */
