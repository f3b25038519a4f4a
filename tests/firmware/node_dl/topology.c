/* Three in-memory topologies: topology.h. */
#include "topology.h"

#include <string.h>

#include "urb_core.h"

#define I2C_BYTE_US 23u  /* one byte and its acknowledge at 400 kb/s */
#define I2C_START_US 3u
#define RS485_BAUD 1000000u
#define CAN_KBPS 1000u

/* The node application, the same on every downlink: firmware/apps/echo (outbox 1 = inbox 1). */
#define APP_CLASS 0x42u
#define APP_FINGERPRINT 0x00C0FFEEu
#define APP_BOX 1u
#define APP_BOX_SIZE 8u

/* ===== Node port: timer and clock ============================================================= */

static uint32_t node_now(void *ctx)
{
    return ((topo_node_t const *)ctx)->topo->now;
}

static void node_set_compare(void *ctx, uint32_t at)
{
    topo_node_t *n = (topo_node_t *)ctx;
    n->compare = at;
    n->compare_armed = true;
}

static void node_set_address(void *ctx, uint8_t address)
{
    (void)ctx; /* I2C: the bus looks the address up in the node's configuration; CAN/RS485: the slave has it */
    (void)address;
}

/* The bridge receives byte/frame payload `b`: flipped when it is the one the test named. */
static uint8_t to_bridge(topo_t *t, uint8_t b)
{
    if (t->fault.corrupt_rx == 0u) {
        return b;
    }
    t->fault.corrupt_rx--;
    if (t->fault.corrupt_rx != 0u) {
        return b;
    }
    t->injected++;
    return (uint8_t)(b ^ 0x04u);
}

/* ===== I2C: byte-level bus between the master's HAL and urb_node_i2c_event ===================== */

static void i2c_complete(topo_t *t, uint8_t ev, uint8_t byte, uint32_t us)
{
    t->i2c_pending = true;
    t->i2c_ev = ev;
    t->i2c_byte = byte;
    t->i2c_due = t->now + us;
}

static uint16_t i2c_to_nodes(topo_t *t, urb_i2c_event_t ev, uint8_t byte)
{
    uint16_t r = URB_I2C_NACK;
    for (uint8_t i = 0u; i < TOPO_NODES; i++) {
        if ((t->i2c_target == -2) || (t->i2c_target == (int8_t)i)) {
            uint16_t const a = urb_node_i2c_event(&t->nodes[i].node, ev, byte);
            if ((ev == URB_I2C_TX_BYTE) || (a == URB_I2C_ACK)) {
                r = a;
            }
        }
    }
    return r;
}

static void i2c_start(void *ctx)
{
    topo_t *t = (topo_t *)ctx;
    t->i2c_expect_address = true;
    i2c_complete(t, URB_I2C_EV_START, 0u, I2C_START_US);
}

static void i2c_write(void *ctx, uint8_t byte)
{
    topo_t *t = (topo_t *)ctx;
    uint16_t ack = URB_I2C_NACK;
    if (t->i2c_expect_address) {
        t->i2c_expect_address = false;
        uint8_t const a = (uint8_t)(byte >> 1);
        bool const rd = (byte & 1u) != 0u;
        if ((a == 0u) && !rd) {
            t->i2c_target = -2;
            ack = i2c_to_nodes(t, URB_I2C_GENERAL_CALL, 0u);
        } else {
            int8_t const prev = t->i2c_target;
            t->i2c_target = -1;
            for (uint8_t i = 0u; i < TOPO_NODES; i++) {
                if ((t->nodes[i].cfg.i2c_address == a) && !t->fault.mute[i]) {
                    t->i2c_target = (int8_t)i;
                }
            }
            if ((prev >= 0) && (prev != t->i2c_target)) { /* a repeated START to another node: STOP for the first */
                (void)urb_node_i2c_event(&t->nodes[prev].node, URB_I2C_STOP, 0u);
            }
            if (t->i2c_target >= 0) {
                ack = i2c_to_nodes(t, rd ? URB_I2C_ADDR_READ : URB_I2C_ADDR_WRITE, 0u);
            }
        }
    } else if (t->i2c_target != -1) {
        ack = i2c_to_nodes(t, URB_I2C_RX_BYTE, byte);
    }
    i2c_complete(t, (ack == URB_I2C_ACK) ? URB_I2C_EV_ACK : URB_I2C_EV_NACK, 0u, I2C_BYTE_US);
}

static void i2c_read(void *ctx, bool ack)
{
    topo_t *t = (topo_t *)ctx;
    uint8_t byte = 0xFFu;
    if (t->i2c_target >= 0) {
        byte = (uint8_t)i2c_to_nodes(t, URB_I2C_TX_BYTE, 0u);
        if (!ack) {
            (void)i2c_to_nodes(t, URB_I2C_TX_NACK, 0u);
        }
    }
    i2c_complete(t, URB_I2C_EV_BYTE, to_bridge(t, byte), I2C_BYTE_US);
}

static void i2c_stop(void *ctx)
{
    topo_t *t = (topo_t *)ctx;
    if (t->i2c_target != -1) {
        (void)i2c_to_nodes(t, URB_I2C_STOP, 0u);
    }
    t->i2c_target = -1;
}

static void i2c_abort(void *ctx)
{
    topo_t *t = (topo_t *)ctx;
    t->i2c_pending = false;
    i2c_stop(ctx);
}

static uint8_t i2c_lines(void *ctx)
{
    topo_t *t = (topo_t *)ctx;
    if (t->fault.bus_fault) {
        t->injected++;
        return (uint8_t)URB_I2C_SCL; /* a node holds SDA low */
    }
    return (uint8_t)(URB_I2C_SCL | URB_I2C_SDA);
}

static void i2c_drive(void *ctx, uint8_t lines)
{
    (void)ctx;
    (void)lines;
}

static void i2c_release(void *ctx)
{
    (void)ctx;
}

/* ===== CAN: the arbitrating in-memory bus ==================================================== */

static void can_m_rx(void *o, const urb_can_frame_t *f, uint32_t t)
{
    (void)t;
    topo_t *tp = (topo_t *)o;
    urb_can_frame_t g = *f;
    if (g.len > 0u) {
        g.data[0] = to_bridge(tp, g.data[0]); /* a payload error the controller's CRC missed */
    }
    urb_can_master_rx(&tp->can, &g);
}
static void can_m_txd(void *o)
{
    urb_can_master_tx_done(&((topo_t *)o)->can);
}
static void can_m_state(void *o, uint8_t s)
{
    (void)o;
    (void)s; /* the master reads the controller state in its poll */
}
static void can_s_rx(void *o, const urb_can_frame_t *f, uint32_t t)
{
    topo_node_t *n = (topo_node_t *)o;
    if (!n->topo->fault.mute[n->index]) {
        urb_can_slave_rx(&n->can.slave, f, t);
    }
}
static void can_s_txd(void *o)
{
    urb_can_slave_tx_done(&((topo_node_t *)o)->can.slave);
}
static void can_s_state(void *o, uint8_t s)
{
    urb_can_slave_state(&((topo_node_t *)o)->can.slave, s);
}

/* ===== RS485: a half-duplex line, every end hears every character (its own: the echo) ======== */

static void rs485_m_start(void *ctx)
{
    topo_t *t = (topo_t *)ctx;
    t->rs485_driving = true;
    t->rs485_m_pos = 0u;
}
static void rs485_m_abort(void *ctx)
{
    ((topo_t *)ctx)->rs485_driving = false;
}
static void rs485_s_start(void *ctx)
{
    ((topo_node_t *)ctx)->rs485_driving = true;
}
static void rs485_s_abort(void *ctx)
{
    ((topo_node_t *)ctx)->rs485_driving = false;
}
static void rs485_wake(void *ctx, uint32_t at)
{
    (void)ctx;
    (void)at; /* topo_advance polls every microsecond */
}

static void rs485_tick(topo_t *t)
{
    if (t->rs485_pending && ((int32_t)(t->now - t->rs485_busy_until) >= 0)) {
        t->rs485_pending = false;
        urb_rs485_master_rx(&t->rs485, t->rs485_from_node ? to_bridge(t, t->rs485_byte) : t->rs485_byte, t->now);
        for (uint8_t i = 0u; i < TOPO_NODES; i++) {
            if (!t->fault.mute[i]) {
                urb_rs485_slave_rx(&t->nodes[i].rs485.slave, t->rs485_byte, t->now);
            }
        }
    }
    for (uint8_t i = 0u; i < TOPO_NODES; i++) {
        urb_rs485_slave_poll(&t->nodes[i].rs485.slave, t->now);
    }
    if (t->rs485_pending) {
        return;
    }
    uint8_t line = 0xFFu;
    bool any = false;
    bool from_node = false;
    uint8_t b;
    if (t->rs485_driving) {
        if (urb_rs485_master_tx_next(&t->rs485, &b)) {
            line &= b;
            any = true;
            if (t->rs485_m_pos == 0u) {
                t->rs485_m_first = b;
            }
            t->rs485_m_pos++;
            if ((t->fault.collide != 0u) && ((t->rs485_m_first & 0x7Fu) != 0u) && (t->rs485_m_pos == t->fault.collide)) {
                t->fault.collide = 0u;
                line ^= 0x24u; /* another driver on the line at the same time garbles the character */
                t->injected++;
            }
        } else {
            t->rs485_driving = false;
        }
    }
    if (t->fault.bus_fault) {
        line &= 0x5Au; /* the babbler */
        any = true;
        t->injected++;
    }
    for (uint8_t i = 0u; i < TOPO_NODES; i++) {
        topo_node_t *n = &t->nodes[i];
        if (n->rs485_driving) {
            if (urb_rs485_slave_tx_next(&n->rs485.slave, &b)) {
                line &= b; /* two drivers at once: the dominant zeros win */
                any = true;
                from_node = true;
            } else {
                n->rs485_driving = false;
            }
        }
    }
    if (any) {
        t->rs485_pending = true;
        t->rs485_byte = line;
        t->rs485_from_node = from_node;
        t->rs485_busy_until = t->now + t->rs485_tm.char_us;
    }
}

/* ===== Set-up and time ======================================================================== */

static bool node_init(topo_t *t, uint8_t i)
{
    topo_node_t *n = &t->nodes[i];
    n->topo = t;
    n->index = i;
    urb_node_config_default(&n->cfg);
    n->cfg.i2c_address = (uint8_t)(TOPO_FIRST_ADDRESS + i);
    n->cfg.ticks_per_us = 1u;
    n->cfg.sync_enabled = 1u;
    n->hal.ctx = n;
    n->hal.now = node_now;
    n->hal.set_compare = node_set_compare;
    n->hal.set_address = node_set_address;
    n->app.class_id = APP_CLASS;
    n->app.index = i;
    n->app.fingerprint = APP_FINGERPRINT;
    n->app.in_size[APP_BOX] = APP_BOX_SIZE;
    n->app.out_size[APP_BOX] = APP_BOX_SIZE;
    if (urb_node_init(&n->node, &n->hal, &echo_app_hooks, &n->app, &n->cfg, n->storage, (uint16_t)sizeof n->storage) !=
        URB_NODE_OK) {
        return false;
    }
    if (t->kind == TOPO_CAN) {
        return can_bus_attach(&t->can_bus, &n->can_port, 3u, n, can_s_rx, can_s_txd, can_s_state) &&
               urb_node_can_attach(&n->can, &n->node, &n->cfg, &n->can_port.hal, CAN_KBPS);
    }
    if (t->kind == TOPO_RS485) {
        n->rs485_hal.ctx = n;
        n->rs485_hal.tx_start = rs485_s_start;
        n->rs485_hal.tx_abort = rs485_s_abort;
        n->rs485_hal.wake_at = rs485_wake;
        return urb_node_rs485_attach(&n->rs485, &n->node, &n->cfg, &n->rs485_hal, RS485_BAUD, t->now);
    }
    return true;
}

bool topo_init(topo_t *t, topo_kind_t kind)
{
    memset(t, 0, sizeof *t);
    t->kind = kind;
    t->i2c_target = -1;
    if (kind == TOPO_I2C) {
        t->i2c_hal = (urb_i2c_hal_t){t, i2c_start, i2c_write, i2c_read, i2c_stop, i2c_abort, i2c_lines, i2c_drive,
                                     i2c_release};
        urb_i2c_master_config_t mc;
        urb_i2c_master_default_config(&mc);
        urb_i2c_master_init(&t->i2c, &t->i2c_hal, &mc);
        urb_i2c_master_downlink(&t->i2c, &t->dl);
    } else if (kind == TOPO_CAN) {
        can_bus_init(&t->can_bus, (uint16_t)CAN_KBPS);
        urb_can_master_config_t mc;
        urb_can_master_default_config(&mc);
        if (!can_bus_attach(&t->can_bus, &t->can_bport, 3u, t, can_m_rx, can_m_txd, can_m_state)) {
            return false;
        }
        urb_can_master_init(&t->can, &t->can_bport.hal, &mc);
        urb_can_master_downlink(&t->can, &t->dl);
    } else {
        urb_rs485_timing(&t->rs485_tm, RS485_BAUD);
        t->rs485_hal.ctx = t;
        t->rs485_hal.tx_start = rs485_m_start;
        t->rs485_hal.tx_abort = rs485_m_abort;
        t->rs485_hal.wake_at = rs485_wake;
        urb_rs485_master_init(&t->rs485, &t->rs485_hal, RS485_BAUD, t->now);
        urb_rs485_master_downlink(&t->rs485, &t->dl);
    }
    for (uint8_t i = 0u; i < TOPO_NODES; i++) {
        if (!node_init(t, i)) {
            return false;
        }
    }
    return true;
}

void topo_advance(topo_t *t)
{
    if (t->kind == TOPO_CAN) {
        if (t->fault.bus_fault && (t->can_bport.state != URB_CAN_BUS_OFF)) {
            t->can_bport.tec = 256u; /* the bridge's controller went bus-off (a shorted transceiver) */
            t->can_bport.state = URB_CAN_BUS_OFF;
            t->injected++;
        }
        if (t->fault.bus_fault) {
            t->can_bport.recovering = false; /* it cannot recover while the fault lasts */
        } else if ((t->can_bport.state == URB_CAN_BUS_OFF) && !t->can_bport.recovering) {
            t->can_bport.hal.recover(t->can_bport.hal.ctx); /* fault gone: 128 x 11 recessive bits from now */
        }
        t->can_bus.now_us = t->now;
        (void)can_bus_step(&t->can_bus); /* a frame moves the bus clock by its length */
        t->now = ((int32_t)(t->can_bus.now_us - t->now) > 0) ? t->can_bus.now_us : t->now + 1u;
    } else {
        t->now++;
        if (t->kind == TOPO_I2C) {
            if (t->i2c_pending && ((int32_t)(t->now - t->i2c_due) >= 0)) {
                t->i2c_pending = false;
                urb_i2c_master_event(&t->i2c, (urb_i2c_event_t)t->i2c_ev, t->i2c_byte);
            }
        } else {
            rs485_tick(t);
        }
    }
    for (uint8_t i = 0u; i < TOPO_NODES; i++) {
        topo_node_t *n = &t->nodes[i];
        if (n->compare_armed && ((int32_t)(t->now - n->compare) >= 0)) {
            n->compare_armed = false;
            urb_node_timer_event(&n->node);
        }
        if (urb_node_has_work(&n->node)) {
            (void)urb_node_poll(&n->node);
        }
    }
}

void topo_run(topo_t *t, uint32_t us)
{
    uint32_t const end = t->now + us;
    while ((int32_t)(t->now - end) < 0) {
        topo_advance(t);
        (void)t->dl.poll(t->dl.ctx, t->now);
    }
}

int topo_txn(topo_t *t, uint8_t op, uint8_t address, uint8_t mailbox, uint8_t length, uint8_t counter, uint8_t *data)
{
    urb_downlink_txn_t const txn = {op, address, mailbox, length, counter, false, data};
    for (int wait = 0; !t->dl.begin(t->dl.ctx, &txn, t->now); wait++) {
        if (wait > 100000) {
            return -100;
        }
        topo_advance(t);
        (void)t->dl.poll(t->dl.ctx, t->now);
    }
    for (int i = 0; i < 200000; i++) {
        topo_advance(t);
        int8_t const r = t->dl.poll(t->dl.ctx, t->now);
        if (r != URB_DOWNLINK_BUSY) {
            return r;
        }
    }
    return -100;
}
