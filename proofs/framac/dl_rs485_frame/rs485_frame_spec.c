/*
 * dl_rs485_frame unit: the RS485 frame receiver of firmware/downlink/rs485/urb_rs485_frame.c.
 *
 * One translation unit: the contracts below are declared first (the file's static helpers can only
 * be given a contract inside its own translation unit), then the file itself is included, and
 * Frama-C merges each contract with the function's definition. WP proves every one of them on the
 * bodies (the unit's -wp-fct names them all): nothing here is an assumption, and the firmware file
 * carries no annotation (its bytes, which the BMC proofs also read, stay as they are). The CRC
 * functions are gen/c/urb_runtime.c's, called through their contracts (assigns \nothing), which the
 * gen_runtime unit proves.
 *
 * The receiver invariant urb_rs485_rx_ok: the state is one of SILENT (0), FRAME (1), BROKEN (2);
 * the frame in progress never holds more than URB_RS485_MAX_FRAME (36) bytes, and at least its
 * first while in FRAME; the summary of the last frame holds at most 36 bytes, and it says check_ok
 * only for a length some frame has (a check tier exists). Every entry point keeps it and
 * urb_rs485_rx_init establishes it. The silence rules of urb_rs485.h are postconditions of
 * urb_rs485_rx_byte and urb_rs485_rx_poll (a frame ends only after t3.5 of silence, a silence over
 * t1.5 inside a frame breaks it, a broken frame stays discarded until t3.5), and the check tier by
 * length is urb_rs485_check_len's.
 */
#include "urb_rs485.h"

/*@ predicate urb_rs485_rx_ok(urb_rs485_rx_t *rx) =
      \valid(rx) && rx->state <= 2 && rx->n <= URB_RS485_MAX_FRAME &&
      (rx->state == 1 ==> 1 <= rx->n) &&
      rx->last.n <= URB_RS485_MAX_FRAME &&
      (rx->last.check_ok != 0 ==> 2 <= rx->last.n && rx->last.n != 16);

    // The silence before the end of a character at t (urb_rs485_frame.c's silence_before and
    // silence_until): the time since the last byte's stamp, modulo 2^32, less one character.
    logic integer urb_rs485_gap(integer char_us, integer t_last, integer t) =
      (uint32_t)(t - t_last) > char_us ? (uint32_t)(t - t_last) - char_us : 0;
*/

/*@ requires baud != 0;
    assigns \nothing; */
static uint16_t chars_us(uint32_t baud, uint32_t tenths);

/*@ requires \valid(t);
    assigns *t;
    ensures rate: t->baud == (baud == 0 ? 115200 : baud); */
void urb_rs485_timing(urb_rs485_timing_t *t, uint32_t baud);

/*@ assigns \nothing;
    ensures crc8_tier: 2 <= n <= 15 ==> \result == 1;
    ensures crc16_tier: n >= 17 ==> \result == 2;
    ensures no_frame: (n < 2 || n == 16) ==> \result == 0; */
uint8_t urb_rs485_check_len(uint8_t n);

/*@ requires \valid(rx) && \valid_read(t) && \separated(rx, t);
    assigns *rx;
    ensures init_ok: urb_rs485_rx_ok(rx);
    ensures waits_for_silence: rx->state == 2 && rx->t_last == now; */
void urb_rs485_rx_init(urb_rs485_rx_t *rx, const urb_rs485_timing_t *t, uint32_t now);

/*@ requires \valid_read(rx);
    assigns \nothing;
    ensures \result == urb_rs485_gap(rx->tm.char_us, rx->t_last, t); */
static uint32_t silence_before(const urb_rs485_rx_t *rx, uint32_t t);

/*@ requires \valid_read(rx);
    assigns \nothing;
    ensures \result == urb_rs485_gap(rx->tm.char_us, rx->t_last, now); */
static uint32_t silence_until(const urb_rs485_rx_t *rx, uint32_t now);

/*@ requires \valid_read(rx);
    assigns \nothing;
    ensures \result != 0 <==> urb_rs485_gap(rx->tm.char_us, rx->t_last, now) >= rx->tm.t35_us; */
bool urb_rs485_rx_silent(const urb_rs485_rx_t *rx, uint32_t now);

/*@ requires \valid_read(rx);
    assigns \nothing; */
uint32_t urb_rs485_rx_deadline(const urb_rs485_rx_t *rx);

/*@ requires urb_rs485_rx_ok(rx);
    assigns \nothing;
    ensures \result <= URB_RS485_MAX_FRAME;
    ensures \result == (rx->state == 1 ? rx->n : 0); */
uint8_t urb_rs485_rx_count(const urb_rs485_rx_t *rx);

/*@ requires urb_rs485_rx_ok(rx) && rx->state == 1;
    assigns rx->last, rx->state, rx->n;
    ensures closed_ok: urb_rs485_rx_ok(rx);
    ensures closed: rx->state == 0 && rx->n == 0;
    ensures summary: rx->last.n == \old(rx->n) && rx->last.head[0] == \old(rx->head[0]) &&
                     rx->last.head[1] == \old(rx->head[1]) && rx->last.t_first == \old(rx->t_first) &&
                     rx->last.t_last == \old(rx->t_last); */
static void close_frame(urb_rs485_rx_t *rx);

/*@ requires \valid(rx);
    assigns rx->crc16, rx->crc8, rx->hold[0 .. 1], rx->head[0 .. 1], rx->n, rx->t_first, rx->state;
    ensures started: rx->state == 1 && rx->n == 1 && rx->head[0] == byte && rx->t_first == t; */
static void start_frame(urb_rs485_rx_t *rx, uint8_t byte, uint32_t t);

/*@ requires urb_rs485_rx_ok(rx);
    assigns rx->last, rx->state, rx->n;
    ensures poll_ok: urb_rs485_rx_ok(rx);
    ensures events: \result == 0 || \result == URB_RS485_EV_END;
    ensures ends_after_t35: \result == URB_RS485_EV_END <==>
              (\old(rx->state) == 1 && urb_rs485_gap(\old(rx->tm.char_us), \old(rx->t_last), now) >= \old(rx->tm.t35_us));
    ensures ended: \result == URB_RS485_EV_END ==> rx->last.n == \old(rx->n);
    ensures silence_clears_broken: urb_rs485_gap(\old(rx->tm.char_us), \old(rx->t_last), now) >= \old(rx->tm.t35_us) ==> rx->state == 0;
    ensures too_early_nothing: urb_rs485_gap(\old(rx->tm.char_us), \old(rx->t_last), now) < \old(rx->tm.t35_us) ==>
              rx->state == \old(rx->state) && rx->n == \old(rx->n); */
uint8_t urb_rs485_rx_poll(urb_rs485_rx_t *rx, uint32_t now);

/*@ requires urb_rs485_rx_ok(rx);
    assigns rx->t_last, rx->t_first, rx->crc16, rx->crc8, rx->hold[0 .. 1], rx->head[0 .. 1], rx->n,
            rx->state, rx->last, rx->broken, rx->too_long;
    ensures byte_ok: urb_rs485_rx_ok(rx);
    ensures stamped: rx->t_last == t;
    ensures events: \result == (URB_RS485_EV_END | URB_RS485_EV_START) || \result == URB_RS485_EV_START ||
              \result == URB_RS485_EV_BYTE || \result == URB_RS485_EV_BROKEN;
    ensures frame_ends_after_t35: \result == (URB_RS485_EV_END | URB_RS485_EV_START) <==>
              (\old(rx->state) == 1 && urb_rs485_gap(\old(rx->tm.char_us), \old(rx->t_last), t) >= \old(rx->tm.t35_us));
    ensures ended: \result == (URB_RS485_EV_END | URB_RS485_EV_START) ==> rx->last.n == \old(rx->n);
    ensures starts_after_t35: urb_rs485_gap(\old(rx->tm.char_us), \old(rx->t_last), t) >= \old(rx->tm.t35_us) ==>
              (\result == (URB_RS485_EV_END | URB_RS485_EV_START) || \result == URB_RS485_EV_START) &&
              rx->state == 1 && rx->n == 1 && rx->head[0] == byte;
    ensures broken_stays: \old(rx->state) == 2 && urb_rs485_gap(\old(rx->tm.char_us), \old(rx->t_last), t) < \old(rx->tm.t35_us) ==>
              \result == URB_RS485_EV_BROKEN && rx->state == 2;
    ensures gap_breaks: \old(rx->state) == 1 && urb_rs485_gap(\old(rx->tm.char_us), \old(rx->t_last), t) < \old(rx->tm.t35_us) &&
              urb_rs485_gap(\old(rx->tm.char_us), \old(rx->t_last), t) > \old(rx->tm.t15_us) ==>
              \result == URB_RS485_EV_BROKEN && rx->state == 2;
    ensures byte_taken: \result == URB_RS485_EV_BYTE ==>
              \old(rx->state) == 1 && rx->state == 1 && rx->n == \old(rx->n) + 1 &&
              urb_rs485_gap(\old(rx->tm.char_us), \old(rx->t_last), t) <= \old(rx->tm.t15_us); */
uint8_t urb_rs485_rx_byte(urb_rs485_rx_t *rx, uint8_t byte, uint32_t t);

#include "urb_rs485_frame.c"
