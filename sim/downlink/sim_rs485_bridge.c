/* The bridge side of the RS485 downlink, the firmware's urb_rs485_master, behind a transceiver HAL
 * that the Python line model (sim/urb_sim/fieldbus/rs485.py) drives through ctypes: the model takes
 * the bytes the master hands to its UART, puts them on the line, and reports every byte heard (the
 * echo of its own and the nodes' answers) with its time stamp (sim_port.c). Compiled into
 * build/sim/liburbsim.so. Not firmware: a simulation harness (issue #39). */
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "urb_rs485.h"
#include "urb_rs485_master.h"
#include "sim_downlink.h"

typedef struct {
    sim_rs485_port_t port;
    urb_rs485_master_t master;
    urb_downlink_t dl;
    uint8_t data[32];
} sim_rs485_bridge_t;

/** Bytes to allocate for one bridge (the caller owns the memory). */
size_t sim_rs485_bridge_size(void)
{
    return sizeof(sim_rs485_bridge_t);
}

/** Initialises a bridge at `baud`, its receiver starting at `now_us`. */
void sim_rs485_bridge_init(sim_rs485_bridge_t *b, uint32_t baud, uint32_t now_us)
{
    memset(b, 0, sizeof(*b));
    sim_rs485_port_init(&b->port, false);
    urb_rs485_master_init(&b->master, &b->port.hal, baud, now_us);
    urb_rs485_master_downlink(&b->master, &b->dl);
}

/** Begins a transaction (urb_dl_op_t); a write's `data` is copied. False while one runs. */
bool sim_rs485_bridge_begin(sim_rs485_bridge_t *b, uint8_t op, uint8_t address, uint8_t mailbox, uint8_t length,
                            uint8_t counter, const uint8_t *data, uint32_t now_us)
{
    return sim_downlink_begin(&b->dl, b->data, op, address, mailbox, length, counter, data, now_us);
}

/** The master's poll: URB_DOWNLINK_BUSY, _IDLE or the final urb_status_t. */
int8_t sim_rs485_bridge_poll(sim_rs485_bridge_t *b, uint32_t now_us)
{
    return b->dl.poll(b->dl.ctx, now_us);
}

/** The next byte for the UART while the driver is enabled: true and *byte set, else false (and the
 *  driver is released). */
bool sim_rs485_bridge_tx_next(sim_rs485_bridge_t *b, uint8_t *byte)
{
    if (!b->port.sending) {
        return false;
    }
    if (!urb_rs485_master_tx_next(&b->master, byte)) {
        b->port.sending = false;
        return false;
    }
    return true;
}

/** True while the driver is enabled. */
bool sim_rs485_bridge_sending(const sim_rs485_bridge_t *b)
{
    return b->port.sending;
}

/** A byte heard on the line (stop bit at `t_us`). */
void sim_rs485_bridge_rx(sim_rs485_bridge_t *b, uint8_t byte, uint32_t t_us)
{
    urb_rs485_master_rx(&b->master, byte, t_us);
}

/** The first instant after `now_us` at which a poll may change the master's state without a byte:
 *  the end of the frame on the line (its receiver's deadline), the end of the node's allowance
 *  after the request, or the transaction's timeout (each + 1 us: the master's tests are strict). */
uint32_t sim_rs485_bridge_next_us(const sim_rs485_bridge_t *b, uint32_t now_us)
{
    const urb_rs485_master_t *m = &b->master;
    const urb_rs485_timing_t *tm = &m->rx.tm;
    uint32_t const cands[3] = {urb_rs485_rx_deadline(&m->rx),
                               m->t_sent + (uint32_t)tm->t35_us + tm->turnaround_us + tm->char_us + 1u,
                               m->t0 + m->timeout_us + 1u};
    uint32_t best = now_us + m->timeout_us + 1u;
    for (uint8_t i = 0u; i < 3u; i++) {
        if ((cands[i] > now_us) && (cands[i] < best)) {
            best = cands[i];
        }
    }
    return best;
}

/** The data a read returned. */
const uint8_t *sim_rs485_bridge_data(const sim_rs485_bridge_t *b)
{
    return b->data;
}

/** tx_abort() calls so far (collisions, timeouts while sending). */
uint32_t sim_rs485_bridge_aborts(const sim_rs485_bridge_t *b)
{
    return b->port.aborts;
}

/** Replaces the silences (Modbus RTU's fixed 1750 / 750 us, for comparison) and the timeout that
 *  depends on them, as urb_rs485_master_timeout_us computes it. */
void sim_rs485_bridge_set_silences(sim_rs485_bridge_t *b, uint16_t t15_us, uint16_t t35_us)
{
    urb_rs485_timing_t *tm = &b->master.rx.tm;
    tm->t15_us = t15_us;
    tm->t35_us = t35_us;
    uint32_t const once = (uint32_t)(URB_RS485_MAX_FRAME + URB_RS485_MAX_FRAME - 1u) * tm->char_us +
                          2u * (uint32_t)t35_us + tm->turnaround_us;
    b->master.timeout_us = (2u * once > 2000u) ? 2u * once : 2000u;
}
