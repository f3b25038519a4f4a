/* Helpers of the host library's cmocka tests: see host_test.h. */
#include "host_test.h"

#include <poll.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "urb_core.h"
#include "urb_sensorhex.h"

void pool_init(pool_t *p)
{
    memset(p, 0, sizeof *p);
}

static void check_one(pool_t *p, urb_transfer_t *t)
{
    assert_true((t >= &p->t[0]) && (t < &p->t[POOL])); /* only what was submitted comes back */
    size_t const i = (size_t)(t - p->t);
    p->done[i]++;
    assert_int_equal(p->done[i], 1); /* exactly once */
    assert_int_equal(t->state, URB_XFER_DONE);
    assert_true((t->flags & (t->flags - 1u)) == 0u); /* at most one flag */
    if (p->count < POOL * 4u) {
        p->order[p->count] = t;
    }
    p->count++;
}

size_t pool_take(pool_t *p, urb_core_t *core)
{
    size_t n = 0u;
    urb_transfer_t *t;
    while ((t = urb_core_take_completed(core)) != NULL) {
        check_one(p, t);
        n++;
    }
    return n;
}

void pool_record(urb_transfer_t *t, void *pool)
{
    check_one((pool_t *)pool, t);
}

void pool_all_once(const pool_t *p, size_t n)
{
    for (size_t i = 0u; i < n; i++) {
        assert_int_equal(p->done[i], 1);
    }
}

urb_transfer_t *pool_nth(const pool_t *p, size_t k)
{
    assert_true(k < p->count);
    return p->order[k];
}

urb_transfer_t *submit_read(pool_t *p, size_t i, urb_core_t *core, uint8_t length, urb_ns_t now)
{
    urb_transfer_t *t = &p->t[i];
    assert_int_equal(urb_transfer_read(t, 8u, 1u, length), URB_HOST_OK);
    assert_int_equal(urb_core_submit(core, t, now), URB_HOST_OK);
    return t;
}

size_t response(uint8_t *buf, const urb_transfer_t *t, uint8_t status, uint8_t fill)
{
    urb_uplink_response_t r;
    memset(&r, 0, sizeof r);
    r.seq = (uint8_t)t->seq;
    r.status = status;
    if (t->read && (status == 0u)) {
        memset(r.data, fill, t->length);
        r.data_len = t->length;
    }
    int32_t const n = urb_uplink_response_encode(&r, buf, URB_RESPONSE_MAX);
    assert_true(n > 0);
    return (size_t)n;
}

size_t send_all(urb_core_t *core, urb_ns_t now)
{
    uint8_t frame[URB_REQUEST_MAX];
    size_t n = 0u;
    while (urb_core_next_frame(core, now, frame, sizeof frame) > 0) {
        n++;
    }
    return n;
}

/* ----- the rig link ---------------------------------------------------------------------------- */

void rig_link_init(rig_link_t *l, bool usb, const urb_core_config_t *cfg)
{
    memset(l, 0, sizeof *l);
    urb_bridge_config_t bc;
    urb_bridge_default_config(&bc);
    assert_int_equal(urb_hosted_rig_init(&l->rig, &bc, NULL), 0);
    l->rig.step_us = 5u;
    l->usb = usb;
    assert_int_equal(urb_core_init(&l->core, usb ? URB_LINK_USB : URB_LINK_RS232, cfg), URB_HOST_OK);
}

urb_fake_node_t *rig_add(rig_link_t *l, uint8_t address, uint8_t class_id, uint8_t index)
{
    urb_fake_node_t *n = urb_fake_i2c_add(&l->rig.bus, address, class_id, index);
    assert_non_null(n);
    const urb_node_type_t *type = urb_schema_find_class(urb_schema_default(), class_id);
    if (type != NULL) {
        n->fingerprint = type->fingerprint;
        memcpy(n->in_size, type->inbox_sizes, 8u);
        memcpy(n->out_size, type->outbox_sizes, 8u);
    }
    urb_fake_node_identify(n);
    return n;
}

urb_ns_t rig_now(const rig_link_t *l)
{
    return (urb_ns_t)l->rig.hal.now * URB_NS_PER_US;
}

static void rig_step(rig_link_t *l)
{
    urb_ns_t const now = rig_now(l);
    if (l->dead) { /* frames go nowhere, nothing comes back */
        uint8_t sink[URB_USB_BATCH_MAX];
        if (l->usb) {
            (void)urb_core_frame_out(&l->core, now, sink, sizeof sink);
        } else {
            while (urb_core_next_frame(&l->core, now, sink, sizeof sink) > 0) {
            }
        }
    } else if (l->usb) {
        if (l->rig.hal.now % 1000u == 0u) { /* a 1-ms frame: SOF, the OUT batch, the IN of the previous one */
            urb_bridge_usb_sof(&l->rig.bridge);
            (void)urb_core_poll(&l->core, now);
            uint8_t batch[URB_USB_BATCH_MAX];
            int32_t const n = urb_core_frame_out(&l->core, now, batch, sizeof batch);
            if (n > 0) {
                (void)urb_bridge_usb_out(&l->rig.bridge, batch, (size_t)n);
                uint8_t in[URB_USB_BATCH_MAX];
                size_t const got = urb_bridge_usb_in(&l->rig.bridge, in, sizeof in);
                (void)urb_core_receive_batch(&l->core, in, got, now);
                l->frames++;
            }
        }
    } else {
        uint8_t frame[URB_REQUEST_MAX];
        int32_t n;
        while ((n = urb_core_next_frame(&l->core, now, frame, sizeof frame)) > 0) {
            urb_hosted_rig_uart_send(&l->rig, frame, (size_t)n, 87u); /* back to back at 115200 Bd */
        }
        if (l->rig.hal.tx_len > 0u) {
            (void)urb_core_receive(&l->core, l->rig.hal.tx, l->rig.hal.tx_len, rig_now(l));
            l->rig.hal.tx_len = 0u;
        }
    }
    (void)urb_core_poll(&l->core, rig_now(l));
    (void)urb_core_dispatch(&l->core, rig_now(l));
}

void rig_run(rig_link_t *l, uint32_t us)
{
    uint32_t const end = l->rig.hal.now + us;
    while ((int32_t)(end - l->rig.hal.now) > 0) {
        rig_step(l);
        urb_hosted_rig_run(&l->rig, l->rig.step_us);
    }
    rig_step(l);
}

/* ----- a bridge on a descriptor, in real time ------------------------------------------------------- */

static uint32_t mono_us(void)
{
    struct timespec ts;
    (void)clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint32_t)((uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u);
}

static void *bridge_main(void *arg)
{
    bridge_thread_t *b = arg;
    uint32_t last = mono_us();
    uint32_t frame_us = last;
    while (!b->stop) {
        struct pollfd p = {b->fd, POLLIN, 0};
        (void)poll(&p, 1, 1);
        uint32_t const now = mono_us();
        uint32_t step = now - last;
        urb_hosted_rig_run(&b->rig, (step > 50000u) ? 50000u : step); /* the virtual clock follows */
        last = now;
        uint8_t buf[URB_USB_BATCH_MAX * 2u];
        if (b->usb) {
            if (now - frame_us >= 1000u) {
                urb_bridge_usb_sof(&b->rig.bridge);
                frame_us = now;
            }
            ssize_t const got = read(b->fd, buf, sizeof buf);
            if (got > 0) {
                (void)urb_bridge_usb_out(&b->rig.bridge, buf, (size_t)got);
                size_t const n = urb_bridge_usb_in(&b->rig.bridge, buf, sizeof buf);
                if (n > 0u) { /* the previous buffer: write n, read n-1 (none before the first) */
                    (void)!write(b->fd, buf, n);
                }
            }
        } else {
            ssize_t const got = read(b->fd, buf, sizeof buf);
            for (ssize_t i = 0; i < got; i++) {
                urb_bridge_uart_rx(&b->rig.bridge, buf[i], b->rig.hal.now);
            }
            urb_hosted_rig_run(&b->rig, 1u);
            if (b->rig.hal.tx_len > 0u) {
                (void)!write(b->fd, b->rig.hal.tx, b->rig.hal.tx_len);
                b->rig.hal.tx_len = 0u;
            }
        }
    }
    return NULL;
}

void bridge_thread_start(bridge_thread_t *b, int fd, bool usb)
{
    memset(b, 0, sizeof *b);
    assert_int_equal(urb_hosted_rig_init(&b->rig, NULL, NULL), 0);
    b->rig.step_us = 5u;
    b->fd = fd;
    b->usb = usb;
    for (uint8_t k = 0u; k < 2u; k++) {
        urb_fake_node_t *n = urb_fake_i2c_add(&b->rig.bus, (uint8_t)(0x20u + k), URB_NODE_MOTOR_DRIVER_CLASS, k);
        assert_non_null(n);
        n->fingerprint = URB_NODE_MOTOR_DRIVER_FINGERPRINT;
        memcpy(n->in_size, urb_node_motor_driver_inbox_sizes, 8u);
        memcpy(n->out_size, urb_node_motor_driver_outbox_sizes, 8u);
        urb_fake_node_identify(n);
    }
    urb_hosted_rig_run(&b->rig, 20000u);
    assert_int_equal(pthread_create(&b->thread, NULL, bridge_main, b), 0);
}

void bridge_thread_stop(bridge_thread_t *b)
{
    b->stop = true;
    (void)pthread_join(b->thread, NULL);
}
