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

#define EVA_BY_OP(stmt)                                                                            \
    do {                                                                                          \
        switch (eva_rs485_master.op) {                                                            \
        case URB_DL_READ: stmt; break;                                                            \
        case URB_DL_WRITE: stmt; break;                                                           \
        case URB_DL_SYNC: stmt; break;                                                            \
        case URB_DL_CLEAR: stmt; break;                                                           \
        default: stmt; break;                                                                     \
        }                                                                                         \
    } while (0)

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
    /* The master and the slave share no state (their own HALs, each hearing arbitrary bytes, not the
     * other's; the payload buffer is the master's, the mailboxes the slave's), so running the
     * master's entry points in any order and then the slave's in any order covers every
     * interleaving of the two. The `split`s keep one state per master transaction kind and phase
     * and per slave answer length (Eva would otherwise join a READ's 32-byte destination with a
     * PROBE's none, and a 32-byte answer with an empty one); EVA_BY_OP gives each kind its own
     * call site, since Eva analyses a call with the join of the states reaching it. */
    while (Frama_C_nondet(0, 1) != 0) {
        uint8_t byte;
        switch (Frama_C_interval(0, 7)) {
        case 0:
            EVA_BY_OP((void)eva_dl_begin(&eva_rs485_dl, URB_DL_READ));
            //@ split eva_rs485_master.op;
            //@ split eva_rs485_master.phase;
            break;
        case 1:
            EVA_BY_OP((void)eva_dl_begin(&eva_rs485_dl, URB_DL_WRITE));
            //@ split eva_rs485_master.op;
            //@ split eva_rs485_master.phase;
            break;
        case 2:
            EVA_BY_OP((void)eva_dl_begin(&eva_rs485_dl, URB_DL_SYNC));
            //@ split eva_rs485_master.op;
            //@ split eva_rs485_master.phase;
            break;
        case 3:
            EVA_BY_OP((void)eva_dl_begin(&eva_rs485_dl, URB_DL_CLEAR));
            //@ split eva_rs485_master.op;
            //@ split eva_rs485_master.phase;
            break;
        case 4:
            EVA_BY_OP((void)eva_dl_begin(&eva_rs485_dl, URB_DL_PROBE));
            //@ split eva_rs485_master.op;
            //@ split eva_rs485_master.phase;
            break;
        case 5:
            EVA_BY_OP((void)eva_rs485_dl.poll(eva_rs485_dl.ctx, eva_any_time()));
            //@ split eva_rs485_master.op;
            //@ split eva_rs485_master.phase;
            break;
        case 6:
            EVA_BY_OP(urb_rs485_master_rx(&eva_rs485_master, Frama_C_unsigned_char_interval(0u, 255u), eva_any_time()));
            //@ split eva_rs485_master.op;
            //@ split eva_rs485_master.phase;
            break;
        default:
            EVA_BY_OP((void)urb_rs485_master_tx_next(&eva_rs485_master, &byte));
            //@ split eva_rs485_master.op;
            //@ split eva_rs485_master.phase;
            break;
        }
    }
    while (Frama_C_nondet(0, 1) != 0) {
        uint8_t byte;
        /* Hypothesis (eva_alarms.md, eva_dl_rs485): the answer the slave sends is the one answer()
         * started: header, tx_len data bytes (none without a buffer), and the link check of the
         * 1 + tx_len covered bytes (one byte up to 13 covered, else two), tx_pos bytes of it pulled;
         * or nothing (tx_total 0). answer() is the only writer of tx_len, tx_data and a non-zero
         * tx_total, with tx_pos 0; tx_next and drop_answer reset tx_total and tx_pos together, and
         * tx_next advances tx_pos only below tx_total (urb_rs485_slave.c; ESBMC checks the answer's
         * bytes, proofs/bmc/fw_rs485_slave). Eva joins the paths of poll and rx at their return and
         * loses which total goes with which length. */
        /*@ admit eva_rs485_slave.tx_len <= 32 &&
                  (eva_rs485_slave.tx_data == \null ==> eva_rs485_slave.tx_len == 0) &&
                  (eva_rs485_slave.tx_total == 0 ||
                   eva_rs485_slave.tx_total == 1 + eva_rs485_slave.tx_len + (1 + eva_rs485_slave.tx_len <= 13 ? 1 : 2)) &&
                  (eva_rs485_slave.tx_total == 0 ==> eva_rs485_slave.tx_pos == 0) &&
                  (eva_rs485_slave.tx_total != 0 ==> eva_rs485_slave.tx_pos < eva_rs485_slave.tx_total); */
        switch (Frama_C_interval(0, 2)) {
        case 0:
            urb_rs485_slave_rx(&eva_rs485_slave, Frama_C_unsigned_char_interval(0u, 255u), eva_any_time());
            //@ split eva_rs485_slave.tx_len;
            break;
        case 1:
            urb_rs485_slave_poll(&eva_rs485_slave, eva_any_time());
            //@ split eva_rs485_slave.tx_len;
            break;
        default:
            (void)urb_rs485_slave_tx_next(&eva_rs485_slave, &byte);
            //@ split eva_rs485_slave.tx_len;
            break;
        }
    }
    return 0;
}
