#include "support.h"

#include <stdlib.h>
#include <string.h>

#include "urb_runtime.h"

urb_hosted_rig_t *rig_new(uint8_t fifo_depth, uint16_t hb_us)
{
    urb_hosted_rig_t *r = calloc(1u, sizeof *r);
    assert_non_null(r);
    urb_bridge_config_t cfg;
    urb_bridge_default_config(&cfg);
    cfg.fifo_depth = fifo_depth;
    cfg.heartbeat_us = hb_us;
    assert_int_equal(urb_hosted_rig_init(r, &cfg, NULL), URB_OK);
    return r;
}

void rig_free(urb_hosted_rig_t *r)
{
    free(r);
}

urb_fake_node_t *add_node(urb_hosted_rig_t *r, uint8_t address, uint8_t class_id, uint8_t index, uint8_t in1,
                          uint8_t out1)
{
    urb_fake_node_t *n = urb_fake_i2c_add(&r->bus, address, class_id, index);
    assert_non_null(n);
    n->in_size[1] = in1;
    n->out_size[1] = out1;
    n->echo = true;
    for (uint8_t i = 0u; i < out1; i++) {
        n->outbox[1][i] = (uint8_t)(address + i);
    }
    urb_fake_node_identify(n);
    return n;
}

void rig_start(urb_hosted_rig_t *r)
{
    assert_true(urb_hosted_rig_settle(r, 200000u));
    assert_false(r->bridge.scanning);
}

size_t enc_read(uint8_t *buf, uint8_t address, uint8_t mailbox, uint8_t seq, uint8_t length)
{
    urb_uplink_read_request_t q = {address, mailbox, seq, length};
    int32_t n = urb_uplink_read_request_encode(&q, buf, 4u);
    assert_true(n == 4);
    return (size_t)n;
}

size_t enc_write(uint8_t *buf, uint8_t address, uint8_t mailbox, uint8_t seq, uint8_t length, const uint8_t *data)
{
    urb_uplink_write_request_t q;
    memset(&q, 0, sizeof q);
    q.address = address;
    q.mailbox = mailbox;
    q.seq = seq;
    q.length = length;
    if (data != NULL) {
        memcpy(q.data, data, length);
    }
    int32_t n = urb_uplink_write_request_encode(&q, buf, 37u);
    assert_true(n > 0);
    return (size_t)n;
}

void send_frame(urb_hosted_rig_t *r, const uint8_t *frame, size_t n)
{
    urb_hosted_rig_uart_send(r, frame, n, BYTE_US);
    urb_hosted_rig_run(r, 1000u);
}

stream_t rs232_stream(const urb_hosted_rig_t *r)
{
    stream_t s = {r->hal.tx, r->hal.tx_len, 0u};
    return s;
}

void expect_response(stream_t *s, uint8_t seq, uint8_t status, uint8_t read_len, uint8_t *data)
{
    assert_true(s->pos < s->len);
    size_t n = 2u;
    if ((status == URB_STATUS_OK) && (read_len > 0u)) {
        n = 1u + read_len + urb_link_check_size(1u + (size_t)read_len);
    }
    assert_true(s->pos + n <= s->len);
    urb_uplink_response_t r;
    int32_t rc = urb_uplink_response_decode(&r, s->bytes + s->pos, n);
    if (rc < 0) {
        print_error("response at %zu does not decode (%d), first byte 0x%02x\n", s->pos, (int)rc, s->bytes[s->pos]);
    }
    assert_int_equal(rc, (int32_t)n);
    if ((r.seq != seq) || (r.status != status)) {
        print_error("response at %zu: seq %u status %u, expected seq %u status %u\n", s->pos, r.seq, r.status, seq,
                    status);
    }
    assert_int_equal(r.seq, seq);
    assert_int_equal(r.status, status);
    assert_int_equal(r.data_len, (n > 2u) ? read_len : 0u);
    if (data != NULL) {
        memcpy(data, r.data, r.data_len);
    }
    s->pos += n;
}

void expect_end(const stream_t *s)
{
    if (s->pos != s->len) {
        print_error("%zu unexpected bytes after the last expected response\n", s->len - s->pos);
    }
    assert_int_equal(s->pos, s->len);
}

size_t usb_batch(uint8_t *out, uint16_t frame, const uint8_t *const *frames, const size_t *lens, uint8_t count)
{
    urb_usb_batch_header_t h = {frame, count};
    assert_int_equal(urb_usb_batch_header_encode(&h, out, 4u), 4);
    size_t n = 4u;
    for (uint8_t i = 0u; i < count; i++) {
        memcpy(out + n, frames[i], lens[i]);
        n += lens[i];
    }
    return n;
}
