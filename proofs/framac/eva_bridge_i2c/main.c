/* Eva entry: the I2C master's event handler (urb_i2c_master_event, interrupt) under any sequence of
 * bus events, bytes, line levels and times, with arbitrary transactions begun and polled through
 * the downlink interface the bridge uses (urb_downlink.h: `data` holds the payload of a READ or
 * WRITE, up to 32 bytes; the other kinds carry none). */
#include "eva_bridge_env.h"

static uint8_t eva_data[32];

/* Begins a transaction of kind `op` with arbitrary fields; each kind from its own call site.
 * Returns what begin() returned (unit.json splits the states on it). */
static bool eva_begin(uint8_t op)
{
    urb_downlink_txn_t t;
    t.op = op;
    t.address = Frama_C_unsigned_char_interval(0u, 255u);
    t.mailbox = Frama_C_unsigned_char_interval(0u, 255u);
    t.counter = Frama_C_unsigned_char_interval(0u, 255u);
    t.reselect = Frama_C_nondet(0, 1) != 0;
    if ((op == URB_DL_READ) || (op == URB_DL_WRITE)) {
        t.length = Frama_C_unsigned_char_interval(0u, 255u); /* the master clamps it to 32 */
        t.data = eva_data;
        Frama_C_make_unknown((char *)eva_data, sizeof eva_data);
    } else {
        t.length = 0u; /* no payload: the bridge passes 0 and no buffer */
        t.data = NULL;
    }
    return eva_dl.begin(eva_dl.ctx, &t, Frama_C_unsigned_int_interval(0u, 0xFFFFFFFFu));
}

int eva_main(void)
{
    eva_master_start();
    while (Frama_C_nondet(0, 1) != 0) {
        //@ split eva_master.op;
        switch (Frama_C_interval(0, 6)) {
        case 0:
            (void)eva_begin(URB_DL_READ);
            //@ split eva_master.op;
            break;
        case 1:
            (void)eva_begin(URB_DL_WRITE);
            //@ split eva_master.op;
            break;
        case 2:
            (void)eva_begin(URB_DL_SYNC);
            //@ split eva_master.op;
            break;
        case 3:
            (void)eva_begin(URB_DL_CLEAR);
            //@ split eva_master.op;
            break;
        case 4:
            (void)eva_begin(URB_DL_PROBE);
            //@ split eva_master.op;
            break;
        case 5:
            EVA_BY_OP(eva_i2c_event());
            break;
        default:
            EVA_BY_OP((void)eva_dl.poll(eva_dl.ctx, Frama_C_unsigned_int_interval(0u, 0xFFFFFFFFu)));
            break;
        }
    }
    return 0;
}
