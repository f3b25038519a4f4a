/* Eva entry: the RS485 downlink's master (urb_rs485_master.c: begin and poll through its
 * urb_downlink_t, the UART interrupt's rx and tx_next) and slave (urb_rs485_slave.c: rx, poll and
 * tx_next), over the frame receiver (urb_rs485_frame.c), called in any order with arbitrary
 * transactions, bytes and times, at any bit rate of the documented range. The two run on separate
 * HALs and hear arbitrary bytes (not each other's), so every line history is covered: the
 * master's echo, a node's answer, collisions, babble and silences of any length. */
#include "eva_dl_env.h"
#include "urb_rs485_master.h"
#include "urb_rs485_slave.h"

static void eva_rs485_tx_start(void *ctx)
{
    (void)ctx;
}

static void eva_rs485_tx_abort(void *ctx)
{
    (void)ctx;
}

static void eva_rs485_wake_at(void *ctx, uint32_t at_us)
{
    (void)ctx;
    (void)at_us;
}

static void eva_rs485_lock(void *ctx, bool locked)
{
    (void)ctx;
    (void)locked;
}

static urb_rs485_hal_t eva_rs485_master_hal;
static urb_rs485_hal_t eva_rs485_slave_hal;
static urb_rs485_master_t eva_rs485_master;
static urb_rs485_slave_t eva_rs485_slave;
static urb_downlink_t eva_rs485_dl;

static void eva_rs485_hal(urb_rs485_hal_t *h)
{
    h->ctx = NULL;
    h->tx_start = eva_rs485_tx_start;
    h->tx_abort = eva_rs485_tx_abort;
    h->wake_at = eva_rs485_wake_at; /* optional for the master, required by the slave */
    h->lock = (Frama_C_nondet(0, 1) != 0) ? eva_rs485_lock : NULL; /* optional */
}

static uint32_t eva_any_time(void)
{
    return Frama_C_unsigned_int_interval(0u, 0xFFFFFFFFu);
}

int eva_main(void)
{
    /* urb_rs485.h: 115200 .. 1000000 Bd, 0 taken as 115200 */
    uint32_t const baud = (Frama_C_nondet(0, 1) != 0) ? 0u : Frama_C_unsigned_int_interval(115200u, 1000000u);
    urb_rs485_timing_t tm;
    urb_rs485_timing(&tm, baud);
    eva_rs485_hal(&eva_rs485_master_hal);
    eva_rs485_hal(&eva_rs485_slave_hal);
    urb_rs485_master_init(&eva_rs485_master, &eva_rs485_master_hal, baud, eva_any_time());
    urb_rs485_master_downlink(&eva_rs485_master, &eva_rs485_dl);
    eva_dl_mailbox_start();
    if (!urb_rs485_slave_init(&eva_rs485_slave, &eva_rs485_slave_hal, &eva_dl_mb,
                              Frama_C_unsigned_char_interval(1u, URB_RS485_LAST_ADDRESS), &tm, eva_any_time())) {
        return 1;
    }
    while (Frama_C_nondet(0, 1) != 0) {
        uint8_t byte;
        switch (Frama_C_interval(0, 10)) {
        case 0:
            (void)eva_dl_begin(&eva_rs485_dl, URB_DL_READ);
            break;
        case 1:
            (void)eva_dl_begin(&eva_rs485_dl, URB_DL_WRITE);
            break;
        case 2:
            (void)eva_dl_begin(&eva_rs485_dl, URB_DL_SYNC);
            break;
        case 3:
            (void)eva_dl_begin(&eva_rs485_dl, URB_DL_CLEAR);
            break;
        case 4:
            (void)eva_dl_begin(&eva_rs485_dl, URB_DL_PROBE);
            break;
        case 5:
            (void)eva_rs485_dl.poll(eva_rs485_dl.ctx, eva_any_time());
            break;
        case 6:
            urb_rs485_master_rx(&eva_rs485_master, Frama_C_unsigned_char_interval(0u, 255u), eva_any_time());
            break;
        case 7:
            (void)urb_rs485_master_tx_next(&eva_rs485_master, &byte);
            break;
        case 8:
            urb_rs485_slave_rx(&eva_rs485_slave, Frama_C_unsigned_char_interval(0u, 255u), eva_any_time());
            break;
        case 9:
            urb_rs485_slave_poll(&eva_rs485_slave, eva_any_time());
            break;
        default:
            (void)urb_rs485_slave_tx_next(&eva_rs485_slave, &byte);
            break;
        }
    }
    return 0;
}
