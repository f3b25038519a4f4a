/* Eva entry: the CAN downlink's master (urb_can_master.c: begin and poll through its
 * urb_downlink_t, the interrupt side's rx and tx_done) and slave (urb_can_slave.c: rx, tx_done and
 * the controller's state), over the transfer layer (urb_can_transfer.c), called in any order with
 * arbitrary transactions, frames (any identifier, any length byte, any data), times and controller
 * answers (a transmit slot free or not, any controller state). The two run on separate HALs: each
 * sees arbitrary frames, not the other's, so every bus history is covered. */
#include "eva_dl_env.h"
#include "urb_can_master.h"
#include "urb_can_slave.h"

/* The controller: a transmit slot is free or not (arbitrary), any state. */
static bool eva_can_tx(void *ctx, const urb_can_frame_t *frame)
{
    (void)ctx;
    (void)frame;
    return Frama_C_nondet(0, 1) != 0;
}

static void eva_can_tx_abort(void *ctx)
{
    (void)ctx;
}

static uint8_t eva_can_state(void *ctx)
{
    (void)ctx;
    return Frama_C_unsigned_char_interval(0u, (uint8_t)URB_CAN_BUS_OFF);
}

static void eva_can_recover(void *ctx)
{
    (void)ctx;
}

static void eva_can_lock(void *ctx, bool locked)
{
    (void)ctx;
    (void)locked;
}

static urb_can_hal_t eva_can_master_hal;
static urb_can_hal_t eva_can_slave_hal;
static urb_can_master_t eva_can_master;
static urb_can_slave_t eva_can_slave;
static urb_downlink_t eva_can_dl;
static urb_can_frame_t eva_can_frame;

static void eva_can_hal(urb_can_hal_t *h)
{
    h->ctx = NULL;
    h->tx = eva_can_tx;
    h->tx_abort = eva_can_tx_abort;
    h->state = eva_can_state;
    h->recover = eva_can_recover;
    h->lock = (Frama_C_nondet(0, 1) != 0) ? eva_can_lock : NULL; /* optional */
}

/* An arbitrary received frame: any standard identifier, any length byte (both ends check it
 * against 1..8 before reading the tail), any data. */
static const urb_can_frame_t *eva_can_any_frame(void)
{
    eva_can_frame.id = Frama_C_unsigned_short_interval(0u, 0x7FFu);
    eva_can_frame.len = Frama_C_unsigned_char_interval(0u, 255u);
    Frama_C_make_unknown((char *)eva_can_frame.data, sizeof eva_can_frame.data);
    return &eva_can_frame;
}

/* Keeping the states apart. Eva's intervals would join, at the main loop's head, the transfer a
 * master of one kind is sending with another kind's (a WRITE's payload of up to 32 bytes with a
 * SYNC's one byte in the master, so that a SYNC's frame would read 32 bytes of a 1-byte array),
 * and the slave's answers (an outbox of up to 32 bytes, its one-byte refusal, none). The `split`
 * annotations at the loop head keep one state per master transaction kind and "sending or not"
 * and per buffer the slave's answer reads; and since Eva analyses a call with the join of the states
 * reaching its call site, each entry point is called from one call site per such state (the
 * macros below: the same call, one copy per case). The keys are the values themselves (a split on
 * `phase == PH_SEND` would not do: the interval of the other phases, 0..4, cannot drop the 1, so
 * the "not sending" states would leak into the "sending" partition). None of this changes what runs. */
#define EVA_CAN_PH_SEND 1u/* urb_can_master.c PH_SEND: the request's frames are being sent */

#define EVA_BY_PHASE(stmt)                                                                         \
    do {                                                                                          \
        if (eva_can_master.phase == EVA_CAN_PH_SEND) {                                            \
            stmt;                                                                                 \
        } else {                                                                                  \
            stmt;                                                                                 \
        }                                                                                         \
    } while (0)

#define EVA_BY_MASTER(stmt)                                                                        \
    do {                                                                                          \
        switch (eva_can_master.op) {                                                              \
        case URB_DL_READ: EVA_BY_PHASE(stmt); break;                                              \
        case URB_DL_WRITE: EVA_BY_PHASE(stmt); break;                                           \
        case URB_DL_SYNC: EVA_BY_PHASE(stmt); break;                                            \
        case URB_DL_CLEAR: EVA_BY_PHASE(stmt); break;                                             \
        default: EVA_BY_PHASE(stmt); break;                                                       \
        }                                                                                         \
    } while (0)

#define EVA_BY_ANSWER(stmt)                                                                        \
    do {                                                                                          \
        if (eva_can_slave.tx.payload == NULL) {                                                   \
            stmt;                                                                                 \
        } else if (eva_can_slave.tx.payload == &eva_can_slave.answer[0]) {                        \
            stmt;                                                                                 \
        } else {                                                                                  \
            stmt;                                                                                 \
        }                                                                                         \
    } while (0)

int eva_main(void)
{
    urb_can_master_config_t cfg;
    urb_can_master_default_config(&cfg);
    cfg.bitrate_kbps = Frama_C_unsigned_short_interval(0u, 0xFFFFu);
    cfg.timeout_us = Frama_C_unsigned_int_interval(0u, 0xFFFFFFFFu);
    cfg.recover_us = Frama_C_unsigned_int_interval(0u, 0xFFFFFFFFu);
    eva_can_hal(&eva_can_master_hal);
    eva_can_hal(&eva_can_slave_hal);
    urb_can_master_init(&eva_can_master, &eva_can_master_hal, &cfg);
    urb_can_master_downlink(&eva_can_master, &eva_can_dl);
    eva_dl_mailbox_start();
    if (!urb_can_slave_init(&eva_can_slave, &eva_can_slave_hal, &eva_dl_mb,
                            Frama_C_unsigned_char_interval(URB_CAN_FIRST_ADDRESS, URB_CAN_LAST_ADDRESS),
                            Frama_C_unsigned_int_interval(0u, 0xFFFFFFFFu))) {
        return 1;
    }
    /* The master and the slave share no state (their own HALs, each hearing arbitrary frames, not the
     * other's; the payload buffer is the master's, the mailboxes the slave's), so running the
     * master's entry points in any order and then the slave's in any order covers every
     * interleaving of the two. (One loop over both would join, at each call, the states the other
     * side's partitions keep apart.) */
    while (Frama_C_nondet(0, 1) != 0) {
        /* Hypothesis (eva_alarms.md, eva_dl_can): while the master sends (PH_SEND, 1) its
         * segmenter holds the transfer the begin() that set PH_SEND started: the SYNC's counter
         * byte, the WRITE's payload (the caller's buffer, at most 32 bytes), nothing for a READ or
         * PROBE. master_begin sets PH_SEND only right after urb_can_tx_init with exactly those
         * arguments, and no other function sets PH_SEND or writes `tx.payload` or `tx.len`
         * (urb_can_tx_next advances only its position, CRC and tail; urb_can_master.c; ESBMC
         * checks the frames sent are the request's, proofs/bmc/fw_can_master). Eva cannot keep it:
         * it joins master_begin's paths at its return (a bus-off path keeps the previous
         * transaction's `tx` with the new kind), so a SYNC's frame would seem to read a WRITE's
         * 32 bytes out of its 1-byte array. */
        /*@ admit eva_can_master.phase == 1 ==>
                  (eva_can_master.op == URB_DL_SYNC ==>
                     eva_can_master.tx.payload == &eva_can_master.sync_payload[0] && eva_can_master.tx.len == 1) &&
                  (eva_can_master.op == URB_DL_WRITE ==>
                     eva_can_master.tx.payload == &eva_dl_data[0] && eva_can_master.tx.len <= 32) &&
                  (eva_can_master.op == URB_DL_READ || eva_can_master.op == URB_DL_PROBE ==>
                     eva_can_master.tx.len == 0); */
        switch (Frama_C_interval(0, 7)) {
        case 0:
            EVA_BY_MASTER((void)eva_dl_begin(&eva_can_dl, URB_DL_READ));
            //@ split eva_can_master.op;
            //@ split eva_can_master.phase;
            break;
        case 1:
            EVA_BY_MASTER((void)eva_dl_begin(&eva_can_dl, URB_DL_WRITE));
            //@ split eva_can_master.op;
            //@ split eva_can_master.phase;
            break;
        case 2:
            EVA_BY_MASTER((void)eva_dl_begin(&eva_can_dl, URB_DL_SYNC));
            //@ split eva_can_master.op;
            //@ split eva_can_master.phase;
            break;
        case 3:
            EVA_BY_MASTER((void)eva_dl_begin(&eva_can_dl, URB_DL_CLEAR));
            //@ split eva_can_master.op;
            //@ split eva_can_master.phase;
            break;
        case 4:
            EVA_BY_MASTER((void)eva_dl_begin(&eva_can_dl, URB_DL_PROBE));
            //@ split eva_can_master.op;
            //@ split eva_can_master.phase;
            break;
        case 5:
            EVA_BY_MASTER((void)eva_can_dl.poll(eva_can_dl.ctx, Frama_C_unsigned_int_interval(0u, 0xFFFFFFFFu)));
            //@ split eva_can_master.op;
            //@ split eva_can_master.phase;
            break;
        case 6:
            EVA_BY_MASTER(urb_can_master_rx(&eva_can_master, eva_can_any_frame()));
            //@ split eva_can_master.op;
            //@ split eva_can_master.phase;
            break;
        default:
            EVA_BY_MASTER(urb_can_master_tx_done(&eva_can_master));
            //@ split eva_can_master.op;
            //@ split eva_can_master.phase;
            break;
        }
    }
    while (Frama_C_nondet(0, 1) != 0) {
        /* Hypothesis (eva_alarms.md, eva_dl_can): the slave's segmenter holds the answer answer()
         * started: no payload and length 0, its one-byte refusal, or an outbox of outbox_size
         * bytes (every stub outbox holds 32, so any length <= 32 is in bounds). answer() is the only
         * writer of `tx.payload` and `tx.len` after init (urb_can_tx_init(NULL, 0) there; tx_next
         * advances only the position, CRC and tail), called with exactly these
         * pairs (urb_can_slave.c: request_done, refuse; ESBMC checks the pairing on the slave's
         * state after every event, proofs/bmc/fw_can_slave "tx state"). Eva joins
         * urb_can_slave_rx's paths at its return and loses which length goes with which buffer. */
        /*@ admit (eva_can_slave.tx.payload == \null ==> eva_can_slave.tx.len == 0) &&
                  (eva_can_slave.tx.payload == &eva_can_slave.answer[0] ==> eva_can_slave.tx.len == 1) &&
                  eva_can_slave.tx.len <= 32; */
        switch (Frama_C_interval(0, 2)) {
        case 0:
            EVA_BY_ANSWER(urb_can_slave_rx(&eva_can_slave, eva_can_any_frame(),
                                           Frama_C_unsigned_int_interval(0u, 0xFFFFFFFFu)));
            //@ split eva_can_slave.tx.payload == \null;
            //@ split eva_can_slave.tx.payload == &eva_can_slave.answer[0];
            break;
        case 1:
            EVA_BY_ANSWER(urb_can_slave_tx_done(&eva_can_slave));
            //@ split eva_can_slave.tx.payload == \null;
            //@ split eva_can_slave.tx.payload == &eva_can_slave.answer[0];
            break;
        default:
            EVA_BY_ANSWER(urb_can_slave_state(&eva_can_slave, Frama_C_unsigned_char_interval(0u, 255u)));
            //@ split eva_can_slave.tx.payload == \null;
            //@ split eva_can_slave.tx.payload == &eva_can_slave.answer[0];
            break;
        }
    }
    return 0;
}
