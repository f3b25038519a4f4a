/*
 * Unit tests for the generated C codecs: the paths codec_driver cannot reach because it only
 * encodes structs that came out of a decoder (invalid members, NULL pointers, invalid implicit
 * members), plus the runtime helpers. The codec table of gen/c/test/urb_test_support.c reaches
 * every codec for the argument checks. Prints one line per failure and exits non-zero on any.
 * Built with sanitizers by tests/test_c_codecs.py.
 */

#include <stdio.h>
#include <string.h>

#include "urb_core.h"
#include "urb_runtime.h"
#include "urb_sensorhex.h"
#include "urb_test_support.h"

static int failures;

#define CHECK(cond)                                                                  \
    do {                                                                             \
        if (!(cond)) {                                                               \
            printf("FAIL %s:%d: %s\n", __FILE__, __LINE__, #cond);                   \
            failures++;                                                              \
        }                                                                            \
    } while (0)

static void test_bits(void)
{
    uint8_t buf[6] = {0};
    urb_put_bits(buf, 5u, 13u, 0x1ABCu); /* straddles three bytes */
    CHECK(urb_get_bits(buf, 5u, 13u) == 0x1ABCu);
    CHECK(buf[0] == 0x80u && buf[1] == 0x57u && buf[2] == 0x03u);
    urb_put_bits(buf, 8u, 32u, 0xDEADBEEFu);
    CHECK(urb_get_bits(buf, 8u, 32u) == 0xDEADBEEFu);
    CHECK(buf[0] == 0x80u); /* bits outside the field are kept */
    urb_put_bits(buf, 0u, 3u, 0xFFFFFFFFu); /* only the low `width` bits are written */
    CHECK(buf[0] == 0x87u);
    CHECK(urb_sign_extend(0x7FFu, 12u) == 2047);
    CHECK(urb_sign_extend(0x800u, 12u) == -2048);
    CHECK(urb_sign_extend(0xFFFu, 12u) == -1);
    CHECK(urb_sign_extend(0x80000000u, 32u) == INT32_MIN);
    CHECK(urb_sign_extend(0x7FFFFFFFu, 32u) == INT32_MAX);
    CHECK(urb_sign_extend(0x2u, 2u) == -2);
}

static void test_checks(void)
{
    static const uint8_t digits[] = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};
    CHECK(urb_crc8_link_check_final(urb_crc8_link_check(digits, 9u, URB_CRC8_LINK_CHECK_INIT)) == 0xDFu);
    CHECK(urb_crc16_link_check_final(urb_crc16_link_check(digits, 9u, URB_CRC16_LINK_CHECK_INIT)) == 0x29B1u);
    /* The tier follows the covered length, prefix included. */
    CHECK(urb_link_check(NULL, 0u, digits, 9u) == 0xDFu);
    CHECK(urb_link_check_size(14u) == 1u && urb_link_check_size(15u) == 2u);
    /* Tail payloads: every frame length maps to the one payload length that produces it, or to an error. */
    for (uint8_t implicit = 0u; implicit < 3u; implicit++) {
        for (uint8_t fixed = 0u; fixed < 4u; fixed++) {
            for (size_t length = 0u; length < 60u; length++) {
                int32_t expected = -1;
                for (size_t p = 0u; p < 60u; p++) {
                    if (fixed + p + urb_link_check_size(implicit + fixed + p) == length) {
                        expected = (int32_t)p;
                    }
                }
                int32_t const got = urb_link_check_payload_len(length, implicit, fixed);
                if (expected >= 0) {
                    CHECK(got == expected);
                } else {
                    CHECK(got == (length < fixed + 1u ? URB_ERR_SHORT : URB_ERR_LONG));
                }
            }
        }
    }
    CHECK(urb_link_check_payload_len((size_t)1 << 20, 0u, 0u) == URB_ERR_LONG);
}

static void test_arguments(void)
{
    urb_uplink_read_request_t msg = {0};
    uint8_t buf[8] = {0};
    CHECK(urb_uplink_read_request_encode(NULL, buf, sizeof buf) == URB_ERR_ARGUMENT);
    CHECK(urb_uplink_read_request_encode(&msg, NULL, sizeof buf) == URB_ERR_ARGUMENT);
    CHECK(urb_uplink_read_request_decode(NULL, buf, 4u) == URB_ERR_ARGUMENT);
    CHECK(urb_uplink_read_request_decode(&msg, NULL, 4u) == URB_ERR_ARGUMENT);
}

/* Every codec refuses a NULL message and a NULL buffer, each on its own (both conditions of its
 * argument check decide: MC/DC), before it reads or writes anything. */
static void test_arguments_every_codec(void)
{
    static union {
        uint64_t align;
        uint8_t bytes[512];
    } msg;
    uint8_t buf[64];
    memset(buf, 0x5A, sizeof buf);
    CHECK(urb_test_message_count > 0u);
    for (size_t i = 0u; i < urb_test_message_count; i++) {
        const urb_test_message_t *t = &urb_test_messages[i];
        CHECK(t->struct_size <= sizeof msg.bytes);
        CHECK(t->encode(NULL, buf, sizeof buf) == URB_ERR_ARGUMENT);
        CHECK(t->encode(msg.bytes, NULL, sizeof buf) == URB_ERR_ARGUMENT);
        CHECK(t->decode(NULL, buf, t->max_size) == URB_ERR_ARGUMENT);
        CHECK(t->decode(msg.bytes, NULL, t->max_size) == URB_ERR_ARGUMENT);
    }
    for (size_t k = 0u; k < sizeof buf; k++) {
        CHECK(buf[k] == 0x5Au);
    }
}

/* Encoding an invalid struct fails with URB_ERR_RANGE and leaves the buffer untouched. */
static void test_encode_range(void)
{
    uint8_t buf[40];
    memset(buf, 0x5A, sizeof buf);

    urb_uplink_read_request_t req = {.address = 33u, .mailbox = 1u, .seq = 3u, .length = 6u};
    CHECK(urb_uplink_read_request_encode(&req, buf, sizeof buf) == 4);
    req.address = 128u; /* u7 */
    CHECK(urb_uplink_read_request_encode(&req, buf, sizeof buf) == URB_ERR_RANGE);
    req.address = 33u;
    req.length = 0u; /* in 1..32 */
    CHECK(urb_uplink_read_request_encode(&req, buf, sizeof buf) == URB_ERR_RANGE);
    req.length = 33u;
    CHECK(urb_uplink_read_request_encode(&req, buf, sizeof buf) == URB_ERR_RANGE);

    memset(buf, 0x5A, sizeof buf);
    urb_uplink_response_t resp = {.seq = 1u, .status = 9u, .data_len = 0u}; /* 9 is no Status */
    CHECK(urb_uplink_response_encode(&resp, buf, sizeof buf) == URB_ERR_RANGE);
    resp.status = URB_STATUS_OK;
    resp.data_len = 33u; /* bytes[<= 32] */
    CHECK(urb_uplink_response_encode(&resp, buf, sizeof buf) == URB_ERR_RANGE);
    for (size_t k = 0u; k < sizeof buf; k++) {
        CHECK(buf[k] == 0x5Au);
    }

    urb_battery_status_t battery;
    memset(&battery, 0, sizeof battery);
    CHECK(urb_battery_status_encode(&battery, buf, sizeof buf) == URB_BATTERY_STATUS_SIZE);
    battery.packs[2].charge = 101u; /* in 0..100, inside an array of nested messages */
    CHECK(urb_battery_status_encode(&battery, buf, sizeof buf) == URB_ERR_RANGE);

    urb_motor_config_t config;
    memset(&config, 0, sizeof config);
    config.mode = 3u; /* not a MotorMode */
    CHECK(urb_motor_config_encode(&config, buf, sizeof buf) == URB_ERR_RANGE);

    urb_identification_t ident;
    memset(&ident, 0, sizeof ident);
    ident.outbox_sizes[7] = 64u; /* u6 array element */
    CHECK(urb_identification_encode(&ident, buf, sizeof buf) == URB_ERR_RANGE);
}

/* Each member check of each encoder, one at a time: the valid message encodes, the message with that
 * one member out of its range (or not a member of its enum) is refused with URB_ERR_RANGE and nothing
 * is written. Together with test_encode_range this reaches every check, and each condition of a
 * two-sided range on its own (MC/DC). */
static uint8_t range_buf[64];

static bool range_refused(int32_t rc)
{
    bool untouched = true;
    for (size_t k = 0u; k < sizeof range_buf; k++) {
        untouched = untouched && (range_buf[k] == 0x5Au);
    }
    return (rc == URB_ERR_RANGE) && untouched;
}

#define ENCODES(fn, m) (memset(range_buf, 0x5A, sizeof range_buf), fn(&(m), range_buf, sizeof range_buf) > 0)
#define REFUSED(fn, m) (memset(range_buf, 0x5A, sizeof range_buf), range_refused(fn(&(m), range_buf, sizeof range_buf)))

static void test_encode_range_every_member(void)
{
    memset(range_buf, 0x5A, sizeof range_buf);
    urb_uplink_read_request_t rr = {.address = 1u, .mailbox = 1u, .seq = 1u, .length = 1u};
    CHECK(ENCODES(urb_uplink_read_request_encode, rr));
    rr.mailbox = 8u;
    CHECK(REFUSED(urb_uplink_read_request_encode, rr));
    rr.mailbox = 7u;
    rr.seq = 16u;
    CHECK(REFUSED(urb_uplink_read_request_encode, rr));

    urb_uplink_write_request_t wr;
    memset(&wr, 0, sizeof wr);
    wr.length = 32u;
    CHECK(ENCODES(urb_uplink_write_request_encode, wr));
    wr.address = 128u;
    CHECK(REFUSED(urb_uplink_write_request_encode, wr));
    wr.address = 0u;
    wr.mailbox = 8u;
    CHECK(REFUSED(urb_uplink_write_request_encode, wr));
    wr.mailbox = 0u;
    wr.seq = 16u;
    CHECK(REFUSED(urb_uplink_write_request_encode, wr));
    wr.seq = 0u;
    wr.length = 0u;
    CHECK(REFUSED(urb_uplink_write_request_encode, wr));
    wr.length = 33u;
    CHECK(REFUSED(urb_uplink_write_request_encode, wr));

    urb_uplink_response_t resp;
    memset(&resp, 0, sizeof resp);
    CHECK(ENCODES(urb_uplink_response_encode, resp));
    resp.seq = 16u;
    CHECK(REFUSED(urb_uplink_response_encode, resp));

    urb_usb_batch_header_t hdr = {.frame = 1u, .count = 128u};
    CHECK(ENCODES(urb_usb_batch_header_encode, hdr));
    hdr.count = 129u;
    CHECK(REFUSED(urb_usb_batch_header_encode, hdr));

    urb_mailbox_select_t sel = {.mailbox = 7u, .read = true};
    CHECK(ENCODES(urb_mailbox_select_encode, sel));
    sel.mailbox = 8u;
    CHECK(REFUSED(urb_mailbox_select_encode, sel));

    urb_downlink_write_t dw;
    memset(&dw, 0, sizeof dw);
    dw.data_len = 32u;
    CHECK(ENCODES(urb_downlink_write_encode, dw));
    dw.select.mailbox = 8u;
    CHECK(REFUSED(urb_downlink_write_encode, dw));
    dw.select.mailbox = 1u;
    dw.data_len = 33u;
    CHECK(REFUSED(urb_downlink_write_encode, dw));

    urb_downlink_read_select_t rs = {.select = {.mailbox = 1u, .read = true}};
    CHECK(ENCODES(urb_downlink_read_select_encode, rs));
    rs.select.mailbox = 8u;
    CHECK(REFUSED(urb_downlink_read_select_encode, rs));

    urb_downlink_read_response_t rresp;
    memset(&rresp, 0, sizeof rresp);
    rresp.select.read = true;
    rresp.data_len = 1u;
    CHECK(ENCODES(urb_downlink_read_response_encode, rresp));
    rresp.select.mailbox = 8u;
    CHECK(REFUSED(urb_downlink_read_response_encode, rresp));
    rresp.select.mailbox = 1u;
    rresp.data_len = 33u;
    CHECK(REFUSED(urb_downlink_read_response_encode, rresp));

    urb_identification_t id;
    memset(&id, 0, sizeof id);
    CHECK(ENCODES(urb_identification_encode, id));
    id.index = 64u;
    CHECK(REFUSED(urb_identification_encode, id));
    id.index = 0u;
    id.inbox_sizes[3] = 64u;
    CHECK(REFUSED(urb_identification_encode, id));

    urb_command_t cmd;
    memset(&cmd, 0, sizeof cmd);
    cmd.opcode = (uint8_t)URB_COMMAND_CODE_SIGNAL;
    CHECK(ENCODES(urb_command_encode, cmd));
    cmd.opcode = 0xFFu;
    CHECK(REFUSED(urb_command_encode, cmd));

    urb_bridge_info_t info;
    memset(&info, 0, sizeof info);
    info.downlink = (uint8_t)URB_DOWNLINK_KIND_I2C;
    CHECK(ENCODES(urb_bridge_info_encode, info));
    info.downlink = 0xFFu;
    CHECK(REFUSED(urb_bridge_info_encode, info));

    urb_bridge_command_t bc;
    memset(&bc, 0, sizeof bc);
    bc.opcode = (uint8_t)URB_BRIDGE_OPCODE_SCAN;
    CHECK(ENCODES(urb_bridge_command_encode, bc));
    bc.opcode = 0xFFu;
    CHECK(REFUSED(urb_bridge_command_encode, bc));

    urb_motor_status_t ms;
    memset(&ms, 0, sizeof ms);
    ms.mode = (uint8_t)URB_MOTOR_MODE_LOCAL_PD;
    CHECK(ENCODES(urb_motor_status_encode, ms));
    ms.mode = 0xFFu;
    CHECK(REFUSED(urb_motor_status_encode, ms));

    urb_battery_pack_t pack;
    memset(&pack, 0, sizeof pack);
    pack.charge = 100u;
    CHECK(ENCODES(urb_battery_pack_encode, pack));
    pack.charge = 101u;
    CHECK(REFUSED(urb_battery_pack_encode, pack));
}

/* Implicit members are the caller's input to decode: invalid ones are an argument error. */
static void test_implicit(void)
{
    static const uint8_t frame[] = {0xe8, 0x03, 0x24, 0xfa, 0xe0, 0x2e, 0x62}; /* tests/vectors/core.json */
    urb_downlink_read_response_t msg;
    memset(&msg, 0, sizeof msg);
    msg.select.mailbox = 1u;
    msg.select.read = true;
    CHECK(urb_downlink_read_response_decode(&msg, frame, sizeof frame) == (int32_t)sizeof frame);
    CHECK(msg.data_len == 6u && msg.data[0] == 0xe8u && msg.select.mailbox == 1u);
    msg.select.mailbox = 2u; /* another selection: the check fails */
    CHECK(urb_downlink_read_response_decode(&msg, frame, sizeof frame) == URB_ERR_CHECKSUM);
    msg.select.mailbox = 8u; /* u3 */
    CHECK(urb_downlink_read_response_decode(&msg, frame, sizeof frame) == URB_ERR_ARGUMENT);
}

/* The schema's rules (`require`): encode refuses a message that breaks one with URB_ERR_RANGE (the
 * buffer untouched), decode refuses such a frame with URB_ERR_RANGE, and a rule over implicit
 * members only is the decoder's argument check (URB_ERR_ARGUMENT, before the frame is read). */
static void test_rules(void)
{
    uint8_t buf[40];
    memset(buf, 0x5A, sizeof buf);
    urb_uplink_response_t resp;
    memset(&resp, 0, sizeof resp);
    resp.seq = 1u;
    resp.status = URB_STATUS_TIMEOUT;
    resp.data_len = 2u; /* require status == OK or len(data) == 0 */
    CHECK(urb_uplink_response_encode(&resp, buf, sizeof buf) == URB_ERR_RANGE);
    for (size_t k = 0u; k < sizeof buf; k++) {
        CHECK(buf[k] == 0x5Au);
    }
    resp.data_len = 0u;
    CHECK(urb_uplink_response_encode(&resp, buf, sizeof buf) == 2);
    resp.status = URB_STATUS_OK;
    resp.data_len = 2u;
    CHECK(urb_uplink_response_encode(&resp, buf, sizeof buf) == 4);
    static const uint8_t timeout_with_data[] = {0x11, 0xab, 0xcd, 0x65}; /* tests/vectors/errors.json */
    CHECK(urb_uplink_response_decode(&resp, timeout_with_data, sizeof timeout_with_data) == URB_ERR_RANGE);

    urb_downlink_write_t write;
    memset(&write, 0, sizeof write);
    write.select.mailbox = 2u;
    write.select.read = true; /* require not select.read */
    write.data_len = 1u;
    CHECK(urb_downlink_write_encode(&write, buf, sizeof buf) == URB_ERR_RANGE);
    write.select.read = false;
    CHECK(urb_downlink_write_encode(&write, buf, sizeof buf) == 3);

    urb_downlink_read_select_t select;
    memset(&select, 0, sizeof select);
    select.select.mailbox = 3u; /* require select.read */
    CHECK(urb_downlink_read_select_encode(&select, buf, sizeof buf) == URB_ERR_RANGE);
    static const uint8_t write_select[] = {0x03};
    CHECK(urb_downlink_read_select_decode(&select, write_select, sizeof write_select) == URB_ERR_RANGE);

    urb_downlink_read_response_t read;
    memset(&read, 0, sizeof read);
    read.select.mailbox = 1u;
    read.select.read = false; /* require select.read, over the implicit member: the caller's mistake */
    CHECK(urb_downlink_read_response_encode(&read, buf, sizeof buf) == URB_ERR_RANGE);
    static const uint8_t valid_for_prefix_01[] = {0xe8, 0x03, 0xb5}; /* tests/vectors/errors.json */
    CHECK(urb_downlink_read_response_decode(&read, valid_for_prefix_01, sizeof valid_for_prefix_01) == URB_ERR_ARGUMENT);
    CHECK(urb_downlink_read_response_decode(&read, valid_for_prefix_01, 0u) == URB_ERR_ARGUMENT); /* before SHORT */
}

static void test_node_tables(void)
{
    CHECK(urb_node_motor_driver_inbox_sizes[URB_NODE_MOTOR_DRIVER_INBOX_MOTOR_CONFIG] == URB_MOTOR_CONFIG_SIZE);
    CHECK(urb_node_motor_driver_outbox_sizes[0] == URB_IDENTIFICATION_SIZE);
    CHECK(URB_NODE_MOTOR_DRIVER_CLASS == URB_MOTOR_CLASS);
}

int main(void)
{
    test_bits();
    test_checks();
    test_arguments();
    test_arguments_every_codec();
    test_encode_range();
    test_encode_range_every_member();
    test_implicit();
    test_rules();
    test_node_tables();
    printf("%s (%d failures)\n", failures == 0 ? "PASS" : "FAIL", failures);
    return failures == 0 ? 0 : 1;
}
