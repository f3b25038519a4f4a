/*
 * Fake I2C bus and nodes (see bridge_fake_i2c.h). The slave side follows the downlink contract of
 * urb_downlink.h so that the bridge can be tested without the node library.
 */
#include "bridge_fake_i2c.h"

#include <string.h>

#include "urb_core.h"
#include "urb_runtime.h"

#define TARGET_NONE (-1)
#define TARGET_GENERAL_CALL (-2)

static urb_fake_i2c_t *bus_of(void *ctx)
{
    return (urb_fake_i2c_t *)ctx;
}

static uint32_t bus_now(const urb_fake_i2c_t *bus)
{
    return bus->now(bus->now_ctx);
}

static void schedule(urb_fake_i2c_t *bus, uint8_t ev, uint8_t byte, uint32_t after_us)
{
    bus->ev_pending = true;
    bus->ev = ev;
    bus->ev_byte = byte;
    bus->ev_due = bus_now(bus) + after_us;
}

static bool sda_held(const urb_fake_i2c_t *bus)
{
    for (uint8_t i = 0u; i < URB_FAKE_MAX_NODES; i++) {
        const urb_fake_node_t *n = &bus->nodes[i];
        if (n->used && n->present && (n->hold_sda != 0u)) {
            return true;
        }
    }
    return false;
}

static bool scl_held(const urb_fake_i2c_t *bus)
{
    for (uint8_t i = 0u; i < URB_FAKE_MAX_NODES; i++) {
        const urb_fake_node_t *n = &bus->nodes[i];
        if (n->used && n->present && n->hold_scl) {
            return true;
        }
    }
    return false;
}

uint8_t urb_fake_i2c_lines(const urb_fake_i2c_t *bus)
{
    uint8_t lines = URB_I2C_SCL | URB_I2C_SDA;
    if (scl_held(bus) || (bus->stretching && bus->ev_pending) ||
        (bus->bitbang && ((bus->driven & URB_I2C_SCL) == 0u))) {
        lines = (uint8_t)(lines & ~URB_I2C_SCL);
    }
    if (sda_held(bus) || (bus->bitbang && ((bus->driven & URB_I2C_SDA) == 0u))) {
        lines = (uint8_t)(lines & ~URB_I2C_SDA);
    }
    return lines;
}

/* The frame a node sends for its selected outbox: data, then the check over (select|0x80, data). */
static uint8_t read_byte(const urb_fake_node_t *n, uint8_t pos)
{
    uint8_t const m = (uint8_t)(n->sel & 7u);
    uint8_t const s = n->out_size[m];
    if (pos < s) {
        uint8_t v = n->outbox[m][pos];
        if ((pos == 0u) && n->corrupt_read) {
            v = (uint8_t)(v ^ 1u);
        }
        return v;
    }
    uint8_t const select = (uint8_t)(m | 0x80u);
    uint32_t const check = urb_link_check(&select, 1u, n->outbox[m], s);
    uint8_t const w = (uint8_t)urb_link_check_size(1u + (size_t)s);
    if (pos < (uint8_t)(s + w)) {
        return (uint8_t)((check >> (8u * (uint8_t)(pos - s))) & 0xFFu);
    }
    return 0xFFu; /* past the frame: the released bus reads high */
}

/* End of a write transfer (STOP or repeated START): an inbox write that did not get its check
 * accepted is discarded (MailboxInbox.tla: IsrWriteAbort). */
static void end_transfer(urb_fake_i2c_t *bus)
{
    if ((bus->target >= 0) && !bus->reading && (bus->wpos >= 2u) && ((bus->wbuf[0] & 0x80u) == 0u)) {
        urb_fake_node_t *n = &bus->nodes[bus->target];
        uint8_t const m = (uint8_t)(bus->wbuf[0] & 7u);
        uint8_t const s = n->in_size[m];
        uint8_t const w = (uint8_t)urb_link_check_size(1u + (size_t)s);
        if (bus->wpos != (uint8_t)(1u + s + w)) {
            n->aborted_writes++;
        }
    }
    bus->target = TARGET_NONE;
    bus->addressed = false;
    bus->reading = false;
    bus->lost = false;
    bus->wpos = 0u;
    bus->rpos = 0u;
}

static void op_start(void *ctx)
{
    urb_fake_i2c_t *bus = bus_of(ctx);
    bus->starts++;
    if ((urb_fake_i2c_lines(bus) & (URB_I2C_SCL | URB_I2C_SDA)) != (URB_I2C_SCL | URB_I2C_SDA)) {
        schedule(bus, (uint8_t)URB_I2C_EV_ERROR, 0u, bus->start_us); /* cannot make a START */
        return;
    }
    end_transfer(bus);
    schedule(bus, (uint8_t)URB_I2C_EV_START, 0u, bus->start_us);
}

/* A node answers one write byte: true = ACK. */
static bool node_write(urb_fake_i2c_t *bus, urb_fake_node_t *n, uint8_t byte)
{
    uint8_t const p = bus->wpos; /* 0 = select */
    if ((n->nack_at >= 1) && ((int16_t)(p + 1u) == n->nack_at)) {
        if (n->nack_once) {
            n->nack_at = URB_FAKE_NO_NACK;
        }
        return false;
    }
    if (p < sizeof bus->wbuf) {
        bus->wbuf[p] = byte;
    }
    if (p == 0u) {
        uint8_t const m = (uint8_t)(byte & 7u);
        if ((byte & 0x78u) != 0u) {
            return false; /* reserved bits */
        }
        if ((byte & 0x80u) != 0u) {
            if (n->out_size[m] == 0u) {
                return false;
            }
            n->sel = m; /* DownlinkReadSelect: kept until the next select */
            n->selects++;
            if (n->reset_after_select) {
                n->reset_after_select = false;
                urb_fake_node_reset(n);
            }
            return true;
        }
        return n->in_size[m] != 0u;
    }
    if ((bus->wbuf[0] & 0x80u) != 0u) {
        return false; /* nothing follows a read-select */
    }
    uint8_t const m = (uint8_t)(bus->wbuf[0] & 7u);
    uint8_t const s = n->in_size[m];
    uint8_t const w = (uint8_t)urb_link_check_size(1u + (size_t)s);
    uint8_t const k = (uint8_t)(p - 1u); /* data index */
    if ((k == 0u) && n->inbox_busy) {
        return false; /* MailboxInbox.tla: IsrWriteBegin finds the other buffer locked */
    }
    if (k < s) {
        return true;
    }
    if (k < (uint8_t)(s + w - 1u)) {
        return true; /* first check byte of two */
    }
    if (k == (uint8_t)(s + w - 1u)) {
        uint32_t const want = urb_link_check(NULL, 0u, bus->wbuf, 1u + (size_t)s);
        uint32_t got = bus->wbuf[1u + s];
        if (w == 2u) {
            got |= (uint32_t)bus->wbuf[2u + s] << 8;
        }
        if (got != want) {
            return false; /* MailboxInbox.tla: IsrWriteAbort */
        }
        memcpy(n->inbox[m], &bus->wbuf[1], s); /* MailboxInbox.tla: IsrWriteCommit */
        n->writes[m]++;
        if (n->echo && (m >= 1u) && (n->out_size[m] == s)) {
            memcpy(n->outbox[m], n->inbox[m], s);
        }
        return true;
    }
    return false; /* longer than the inbox */
}

static void op_write(void *ctx, uint8_t byte)
{
    urb_fake_i2c_t *bus = bus_of(ctx);
    if (bus->lost) {
        return; /* a mute node: the event never comes */
    }
    uint32_t delay = bus->byte_us;
    bool ack = false;
    if (!bus->addressed) {
        bus->addressed = true;
        uint8_t const a = (uint8_t)(byte >> 1);
        bus->reading = (byte & 1u) != 0u;
        bus->wpos = 0u;
        bus->rpos = 0u;
        bus->target = TARGET_NONE;
        if ((a == 0u) && !bus->reading) {
            bus->target = TARGET_GENERAL_CALL;
            for (uint8_t i = 0u; i < URB_FAKE_MAX_NODES; i++) {
                ack = ack || (bus->nodes[i].used && bus->nodes[i].present);
            }
        } else {
            for (uint8_t i = 0u; i < URB_FAKE_MAX_NODES; i++) {
                urb_fake_node_t *n = &bus->nodes[i];
                if (n->used && n->present && (n->address == a)) {
                    bus->target = (int8_t)i;
                    ack = n->nack_at != 0;
                    if (!ack && n->nack_once) {
                        n->nack_at = URB_FAKE_NO_NACK;
                    }
                    bus->lost = ack && n->mute; /* from the next operation on, nothing answers */
                }
            }
            if ((bus->target >= 0) && bus->reading) {
                bus->nodes[bus->target].reads++;
            }
        }
    } else if (bus->target == TARGET_GENERAL_CALL) {
        if (bus->wpos == 1u) {
            for (uint8_t i = 0u; i < URB_FAKE_MAX_NODES; i++) {
                urb_fake_node_t *n = &bus->nodes[i];
                if (n->used && n->present && (bus->wbuf[0] == URB_SYNC_MAGIC)) {
                    n->syncs++;
                    n->last_sync = byte;
                    n->last_sync_us = bus_now(bus);
                }
            }
            bus->general_calls++;
        }
        if (bus->wpos < sizeof bus->wbuf) {
            bus->wbuf[bus->wpos] = byte;
        }
        bus->wpos++;
        ack = true;
    } else if ((bus->target >= 0) && !bus->reading) {
        urb_fake_node_t *n = &bus->nodes[bus->target];
        ack = node_write(bus, n, byte);
        bus->wpos++;
        if (n->stretch_us > 0u) {
            delay = n->stretch_us;
            bus->stretching = true;
        }
    } else {
        ack = false;
    }
    schedule(bus, ack ? (uint8_t)URB_I2C_EV_ACK : (uint8_t)URB_I2C_EV_NACK, 0u, delay);
}

static void op_read(void *ctx, bool ack)
{
    urb_fake_i2c_t *bus = bus_of(ctx);
    (void)ack; /* the node stops after a NACK, at the STOP */
    if (bus->lost) {
        return;
    }
    uint8_t v = 0xFFu;
    if ((bus->target >= 0) && bus->reading) {
        urb_fake_node_t *n = &bus->nodes[bus->target];
        v = read_byte(n, bus->rpos);
        if (n->stretch_us > 0u) {
            bus->stretching = true;
            schedule(bus, (uint8_t)URB_I2C_EV_BYTE, v, n->stretch_us);
            bus->rpos++;
            return;
        }
    }
    bus->rpos++;
    schedule(bus, (uint8_t)URB_I2C_EV_BYTE, v, bus->byte_us);
}

static void op_stop(void *ctx)
{
    urb_fake_i2c_t *bus = bus_of(ctx);
    bus->stops++;
    end_transfer(bus);
}

static void op_abort(void *ctx)
{
    urb_fake_i2c_t *bus = bus_of(ctx);
    bus->aborts++;
    bus->ev_pending = false;
    end_transfer(bus);
}

static uint8_t op_lines(void *ctx)
{
    return urb_fake_i2c_lines(bus_of(ctx));
}

static void op_drive(void *ctx, uint8_t lines)
{
    urb_fake_i2c_t *bus = bus_of(ctx);
    bool const rising = bus->bitbang && ((bus->driven & URB_I2C_SCL) == 0u) && ((lines & URB_I2C_SCL) != 0u) &&
                        ((lines & URB_I2C_SDA) != 0u);
    bool const stop = bus->bitbang && ((bus->driven & URB_I2C_SCL) != 0u) && ((lines & URB_I2C_SCL) != 0u) &&
                      ((bus->driven & URB_I2C_SDA) == 0u) && ((lines & URB_I2C_SDA) != 0u);
    if (stop) {
        bus->bitbang_stops++;
    }
    if (!bus->bitbang) {
        bus->ev_pending = false;
        bus->stretching = false;
        end_transfer(bus);
    }
    bus->bitbang = true;
    bus->driven = lines;
    if (rising && !scl_held(bus)) {
        bus->scl_pulses++;
        /* A node stuck in the middle of a byte shifts one bit per clock and lets go of SDA. */
        for (uint8_t i = 0u; i < URB_FAKE_MAX_NODES; i++) {
            urb_fake_node_t *n = &bus->nodes[i];
            if (n->used && (n->hold_sda != 0u) && (n->hold_sda != URB_FAKE_HOLD_FOREVER)) {
                n->hold_sda--;
            }
        }
    }
}

static void op_release(void *ctx)
{
    urb_fake_i2c_t *bus = bus_of(ctx);
    bus->releases++;
    bus->bitbang = false;
    bus->driven = URB_I2C_SCL | URB_I2C_SDA;
    bus->stretching = false;
    bus->ev_pending = false;
    end_transfer(bus);
}

void urb_fake_i2c_init(urb_fake_i2c_t *bus, urb_i2c_master_t *master, uint32_t (*now)(void *ctx), void *now_ctx)
{
    memset(bus, 0, sizeof *bus);
    bus->master = master;
    bus->now = now;
    bus->now_ctx = now_ctx;
    bus->byte_us = 23u;
    bus->start_us = 3u;
    bus->target = TARGET_NONE;
    bus->driven = URB_I2C_SCL | URB_I2C_SDA;
    bus->hal.ctx = bus;
    bus->hal.start = op_start;
    bus->hal.write = op_write;
    bus->hal.read = op_read;
    bus->hal.stop = op_stop;
    bus->hal.abort = op_abort;
    bus->hal.lines = op_lines;
    bus->hal.drive = op_drive;
    bus->hal.release = op_release;
}

void urb_fake_node_identify(urb_fake_node_t *n)
{
    urb_identification_t id;
    memset(&id, 0, sizeof id);
    id.class_id = n->class_id;
    id.index = (uint8_t)(n->index & 0x3Fu);
    id.fingerprint = n->fingerprint;
    id.fw_major = 0u;
    id.fw_minor = 1u;
    id.fw_patch = 0u;
    for (uint8_t i = 0u; i < 8u; i++) {
        id.inbox_sizes[i] = n->in_size[i];
        id.outbox_sizes[i] = n->out_size[i];
    }
    (void)urb_identification_encode(&id, n->outbox[0], sizeof n->outbox[0]);
}

void urb_fake_node_reset(urb_fake_node_t *n)
{
    n->sel = 0u;
}

urb_fake_node_t *urb_fake_i2c_add(urb_fake_i2c_t *bus, uint8_t address, uint8_t class_id, uint8_t index)
{
    for (uint8_t i = 0u; i < URB_FAKE_MAX_NODES; i++) {
        urb_fake_node_t *n = &bus->nodes[i];
        if (!n->used) {
            memset(n, 0, sizeof *n);
            n->used = true;
            n->present = true;
            n->address = address;
            n->class_id = class_id;
            n->index = index;
            n->fingerprint = 0x12345678u;
            n->out_size[0] = (uint8_t)URB_IDENTIFICATION_SIZE;
            n->in_size[0] = (uint8_t)URB_COMMAND_SIZE;
            n->nack_at = URB_FAKE_NO_NACK;
            urb_fake_node_identify(n);
            return n;
        }
    }
    return NULL;
}

bool urb_fake_i2c_step(urb_fake_i2c_t *bus)
{
    if (!bus->ev_pending || ((int32_t)(bus_now(bus) - bus->ev_due) < 0)) {
        return false;
    }
    bus->ev_pending = false;
    bus->stretching = false;
    urb_i2c_master_event(bus->master, (urb_i2c_event_t)bus->ev, bus->ev_byte);
    return true;
}
