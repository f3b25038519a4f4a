/*
 * URB on a Cortex-M0 (ARMv6-M) under QEMU (-M microbit): the generated C codecs and the node
 * library, compiled for the target with the cross build's flags, run on the emulated core. Each
 * check prints one TAP-style line over semihosting ("ok N - ..." / "not ok N - ..." and a "#"
 * diagnostic); the exit status is 0 when every check passed, 1 when one failed, 2 for an unknown
 * group, 3 for a HardFault, 4 for any other exception (startup_microbit.c).
 *
 *   vectors  CRC check values, then every vector of tests/vectors/<file>.json (build/qemu/gen/qt_vectors.c):
 *            a valid one is encoded from the expected struct (byte for byte, within its buffer),
 *            refused by a buffer one byte short, decoded into a garbage-filled struct (every member
 *            compared) and re-encoded; an error vector must decode to its precise error.
 *   node     the SensoRHex motor driver on the node library and the hosted HAL (firmware/hal/hosted:
 *            time is a counter, I2C events are function calls, nothing needs an OS), driven byte by
 *            byte by the cmocka tests' I2C master (tests/firmware/node/node_fixture.c): the
 *            identification read of outbox 0, writes to inboxes 2 and 1, a write with a bad check,
 *            one heartbeat, the read back of outbox 1. Expected bytes come from the Python codecs
 *            (build/qemu/gen/qt_node.h), not from the C code under test.
 *
 * Groups: QEMU's -append text ("vectors", "node"); none runs both. Seeded bugs (mk/qemu.mk runs
 * both and requires the run to fail): -DURB_QEMU_MUTANT_EXPECTED_BYTE flips one bit of one expected
 * frame; -DURB_QEMU_MUTANT_UNALIGNED_LOAD reads the identification's fingerprint with a 32-bit load
 * from an odd address, fine on x86 and Cortex-M3/M4, a HardFault on ARMv6-M.
 */
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "codec_error_name.h"
#include "node_fixture.h"
#include "qt_node.h"
#include "qt_tables.h"
#include "semihost.h"
#include "sensorhex_motor.h"
#include "urb_core.h"
#include "urb_runtime.h"
#include "urb_sensorhex.h"

#define CANARY 16u
#define MAX_FRAME 40u
#define UNTOUCHED 0x5Au /* an output buffer before an encode call */
#define GARBAGE 0xA5u   /* a struct before a decode call */

#if defined(URB_QEMU_MUTANT_EXPECTED_BYTE)
#define BUILD_NAME "mutant EXPECTED_BYTE (one bit of one expected frame flipped)"
#elif defined(URB_QEMU_MUTANT_UNALIGNED_LOAD)
#define BUILD_NAME "mutant UNALIGNED_LOAD (32-bit load from an odd address)"
#else
#define BUILD_NAME "normal"
#endif

static uint32_t checks;
static uint32_t failures;
static sh_line_t desc; /* what the check in progress checks */
static sh_line_t why;  /* why it failed (the first failing step) */
static sh_line_t out;

static void report(bool ok)
{
    checks++;
    if (!ok) {
        failures++;
    }
    sh_str(&out, ok ? "ok " : "not ok ");
    sh_udec(&out, checks);
    sh_str(&out, " - ");
    desc.buf[desc.len] = '\0';
    sh_str(&out, desc.buf);
    sh_flush(&out);
    if (!ok) {
        why.buf[why.len] = '\0';
        sh_str(&out, "#   ");
        sh_str(&out, why.buf);
        sh_flush(&out);
    }
    sh_clear(&desc);
    sh_clear(&why);
}

/* A codec's return value: its error's name, "bytes" for a byte count. */
static const char *rc_name(int32_t rc)
{
    const char *name = codec_error_name(rc);
    return name != NULL ? name : rc >= 0 ? "bytes" : "unknown";
}

/* "<step>: returned <got> (<name>), want <want> (<name>)"; returns false. */
static bool fail_rc(const char *step, int32_t got, int32_t want)
{
    sh_str(&why, step);
    sh_str(&why, ": returned ");
    sh_dec(&why, got);
    sh_str(&why, " (");
    sh_str(&why, rc_name(got));
    sh_str(&why, "), want ");
    sh_dec(&why, want);
    sh_str(&why, " (");
    sh_str(&why, rc_name(want));
    sh_str(&why, ")");
    return false;
}

static bool fail_bytes(const char *step, const uint8_t *got, const uint8_t *want, size_t len)
{
    sh_str(&why, step);
    sh_str(&why, ": got ");
    sh_bytes(&why, got, len);
    sh_str(&why, " want ");
    sh_bytes(&why, want, len);
    return false;
}

static bool fail_text(const char *step, const char *text)
{
    sh_str(&why, step);
    sh_str(&why, ": ");
    sh_str(&why, text);
    return false;
}

/* ===== Codec vectors ============================================================================ */

static uint8_t region[CANARY + MAX_FRAME + CANARY]; /* output buffer between canaries */
static uint8_t frame[MAX_FRAME];                    /* the vector's frame, in RAM */

static uint8_t canary(size_t k)
{
    return (uint8_t)(0xC3u ^ (k * 37u));
}

static void fill_region(size_t capacity)
{
    for (size_t k = 0u; k < sizeof region; k++) {
        region[k] = (k < CANARY || k >= CANARY + capacity) ? canary(k) : UNTOUCHED;
    }
}

static bool canaries_intact(size_t capacity)
{
    for (size_t k = 0u; k < sizeof region; k++) {
        if ((k < CANARY || k >= CANARY + capacity) && region[k] != canary(k)) {
            return false;
        }
    }
    return true;
}

/* Encodes *msg into a buffer of max_size bytes; it must give exactly frame[0 .. len - 1]. */
static bool encode_gives_frame(const char *step, const qt_message_t *m, const void *msg, size_t len)
{
    fill_region(m->max_size);
    int32_t const rc = m->encode(msg, region + CANARY, m->max_size);
    if (!canaries_intact(m->max_size)) {
        return fail_text(step, "wrote outside its buffer");
    }
    if (rc != (int32_t)len) {
        return fail_rc(step, rc, (int32_t)len);
    }
    if (memcmp(region + CANARY, frame, len) != 0) {
        return fail_bytes(step, region + CANARY, frame, len);
    }
    return true;
}

static bool valid_vector(const qt_vector_t *v)
{
    const qt_message_t *m = v->message;
    if (v->length > MAX_FRAME || v->length > m->max_size || m->struct_size > qt_scratch_size) {
        return fail_text("table", "frame or struct larger than the test's buffers");
    }
    /* encode from the expected struct (built from the vector's fields, not by a decoder) */
    if (!encode_gives_frame("encode", m, v->fields, v->length)) {
        return false;
    }
    /* a buffer one byte short: CAPACITY and nothing written */
    if (v->length > 0u) {
        size_t const capacity = v->length - 1u;
        fill_region(capacity);
        int32_t const rc = m->encode(v->fields, region + CANARY, capacity);
        if (rc != URB_ERR_CAPACITY) {
            return fail_rc("encode, buffer 1 byte short", rc, URB_ERR_CAPACITY);
        }
        for (size_t k = 0u; k < capacity; k++) {
            if (region[CANARY + k] != UNTOUCHED || !canaries_intact(capacity)) {
                return fail_text("encode, buffer 1 byte short", "failed but wrote to its buffer");
            }
        }
    }
    /* decode into a garbage-filled struct (implicit members set first, as the schema requires) */
    memset(qt_scratch, GARBAGE, qt_scratch_size);
    if (m->set_implicit != NULL) {
        m->set_implicit(qt_scratch, v->fields);
    }
    int32_t const rc = m->decode(qt_scratch, frame, v->length);
    if (rc != (int32_t)v->length) {
        return fail_rc("decode", rc, (int32_t)v->length);
    }
    const char *member = m->compare(qt_scratch, v->fields);
    if (member != NULL) {
        sh_str(&why, "decode: member ");
        sh_str(&why, member);
        return fail_text("", "differs from the vector's fields");
    }
    /* and the decoded struct encodes back to the same frame */
    return encode_gives_frame("re-encode", m, qt_scratch, v->length);
}

static bool error_vector(const qt_vector_t *v)
{
    const qt_message_t *m = v->message;
    if (v->length > MAX_FRAME || m->struct_size > qt_scratch_size) {
        return fail_text("table", "frame or struct larger than the test's buffers");
    }
    memset(qt_scratch, GARBAGE, qt_scratch_size);
    if (m->set_implicit != NULL && v->fields != NULL) {
        m->set_implicit(qt_scratch, v->fields);
    }
    int32_t const rc = m->decode(qt_scratch, frame, v->length);
    return rc == v->error ? true : fail_rc("decode", rc, v->error);
}

static void run_vectors(void)
{
    /* CRC check values ("123456789"), buffer-wise and byte by byte */
    static const uint8_t check_input[9] = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};
    uint8_t c8 = URB_CRC8_LINK_CHECK_INIT;
    uint16_t c16 = URB_CRC16_LINK_CHECK_INIT;
    for (size_t k = 0u; k < sizeof check_input; k++) {
        c8 = urb_crc8_link_check_byte(c8, check_input[k]);
        c16 = urb_crc16_link_check_byte(c16, check_input[k]);
    }
    uint8_t const b8 = urb_crc8_link_check_final(urb_crc8_link_check(check_input, 9u, URB_CRC8_LINK_CHECK_INIT));
    uint16_t const b16 = urb_crc16_link_check_final(urb_crc16_link_check(check_input, 9u, URB_CRC16_LINK_CHECK_INIT));
    sh_str(&desc, "crc: CRC-8/AUTOSAR 0xdf and CRC-16/IBM-3740 0x29b1 of \"123456789\", buffer-wise and byte-wise");
    bool ok = b8 == 0xDFu && urb_crc8_link_check_final(c8) == 0xDFu && b16 == 0x29B1u &&
              urb_crc16_link_check_final(c16) == 0x29B1u;
    if (!ok) {
        sh_str(&why, "got crc8 ");
        sh_hex(&why, b8, 2u);
        sh_str(&why, " / ");
        sh_hex(&why, urb_crc8_link_check_final(c8), 2u);
        sh_str(&why, ", crc16 ");
        sh_hex(&why, b16, 4u);
        sh_str(&why, " / ");
        sh_hex(&why, urb_crc16_link_check_final(c16), 4u);
    }
    report(ok);

#if defined(URB_QEMU_MUTANT_EXPECTED_BYTE)
    bool mutated = false;
#endif
    for (size_t i = 0u; i < qt_vector_count; i++) {
        const qt_vector_t *v = &qt_vectors[i];
        size_t const n = v->length <= MAX_FRAME ? v->length : MAX_FRAME;
        memcpy(frame, v->frame, n);
#if defined(URB_QEMU_MUTANT_EXPECTED_BYTE)
        /* the seeded bug: one bit of byte 10 of the first valid frame longer than 16 bytes */
        if (!mutated && v->error == 0 && n > 16u) {
            frame[10] ^= 0x10u;
            mutated = true;
        }
#endif
        sh_str(&desc, "vector ");
        sh_str(&desc, v->source);
        sh_str(&desc, " ");
        sh_str(&desc, v->message->name);
        sh_str(&desc, " ");
        sh_bytes(&desc, frame, n < 12u ? n : 12u);
        sh_str(&desc, n > 12u ? "..: " : ": ");
        if (v->error == 0) {
            sh_str(&desc, "encode, short buffer, decode, members, re-encode");
            report(valid_vector(v));
        } else {
            sh_str(&desc, "decode gives ");
            sh_str(&desc, rc_name(v->error));
            report(error_vector(v));
        }
    }
}

/* ===== Node smoke test ========================================================================== */

static fake_motor_t fm;
static const sensorhex_motor_io_t motor_io = FAKE_MOTOR_IO(&fm);

static sensorhex_motor_t motor;
static urb_node_t node;
static urb_hal_hosted_t port;
static urb_node_config_t cfg;
static uint8_t storage[SENSORHEX_MOTOR_STORAGE];
static union {
    uint32_t word; /* 4-byte aligned, so bytes + 3 is not */
    uint8_t bytes[MAX_FRAME];
} rx;

#if defined(URB_QEMU_MUTANT_UNALIGNED_LOAD)
/* The seeded bug: a "fast" little-endian load through a uint32_t pointer, a classic port from a
 * desktop or a Cortex-M3/M4 (both allow unaligned LDR). ARMv6-M does not: HardFault. noipa keeps
 * gcc from seeing the misaligned address and splitting the load into byte loads. */
__attribute__((noipa)) static uint32_t le32_at(const uint8_t *p)
{
    return *(const uint32_t *)(const void *)p;
}
#else
static uint32_t le32_at(const uint8_t *p)
{
    return urb_get_le(p, 0u, 4u); /* byte by byte: no alignment needs */
}
#endif

/* Reads `n` bytes (data, check, the 0xFF filler) from outbox m; false when the select is NACKed. */
static bool read_outbox(uint8_t m, size_t n)
{
    memset(rx.bytes, 0, sizeof rx.bytes);
    if (!fx_select(&node, m)) {
        return fail_text("select", "NACKed");
    }
    fx_read(&node, rx.bytes, n);
    return true;
}

static bool node_init(void)
{
    memset(&fm, 0, sizeof fm);
    fm.temp = QT_MOTOR_CASE_TEMP;
    sensorhex_motor_config_t mcfg;
    sensorhex_motor_defaults(&mcfg, QT_NODE_INDEX);
    sensorhex_motor_setup(&motor, &motor_io, &mcfg);
    urb_hal_hosted_init(&port, 0u, true);
    urb_node_config_default(&cfg);
    cfg.i2c_address = QT_NODE_ADDRESS;
    sensorhex_motor_node_config(&cfg);
    int const rc = urb_node_init(&node, &port.hal, &sensorhex_motor_hooks, &motor, &cfg, storage, sizeof storage);
    if (rc != URB_NODE_OK) {
        return fail_rc("urb_node_init", rc, URB_NODE_OK);
    }
    if (port.address != QT_NODE_ADDRESS) {
        return fail_text("init", "the HAL's set_address was not called with the configured address");
    }
    if (fm.drives == 0u || fm.drive != 0) {
        return fail_text("app_init", "did not stop the motor");
    }
    return true;
}

static bool node_identification(void)
{
    if (!read_outbox(0u, sizeof qt_ident_read)) {
        return false;
    }
    if (memcmp(rx.bytes, qt_ident_read, sizeof qt_ident_read) != 0) {
        return fail_bytes("read", rx.bytes, qt_ident_read, sizeof qt_ident_read);
    }
    return true;
}

static bool node_identification_fields(void)
{
    urb_identification_t id;
    int32_t const rc = urb_identification_decode(&id, rx.bytes, URB_IDENTIFICATION_SIZE);
    if (rc != (int32_t)URB_IDENTIFICATION_SIZE) {
        return fail_rc("urb_identification_decode", rc, (int32_t)URB_IDENTIFICATION_SIZE);
    }
    uint32_t const fingerprint = le32_at(rx.bytes + 3); /* bytes 3..6; the mutant's unaligned load */
    if (id.class_id != URB_NODE_MOTOR_DRIVER_CLASS || id.index != QT_NODE_INDEX ||
        memcmp(id.inbox_sizes, urb_node_motor_driver_inbox_sizes, URB_MAILBOXES) != 0 ||
        memcmp(id.outbox_sizes, urb_node_motor_driver_outbox_sizes, URB_MAILBOXES) != 0) {
        return fail_text("decoded", "class, index or mailbox sizes differ from urb_sensorhex.h");
    }
    if (id.fingerprint != URB_NODE_MOTOR_DRIVER_FINGERPRINT || fingerprint != URB_NODE_MOTOR_DRIVER_FINGERPRINT) {
        sh_str(&why, "fingerprint: decoded ");
        sh_hex(&why, id.fingerprint, 8u);
        sh_str(&why, ", bytes 3..6 ");
        sh_hex(&why, fingerprint, 8u);
        sh_str(&why, ", want ");
        sh_hex(&why, URB_NODE_MOTOR_DRIVER_FINGERPRINT, 8u);
        return false;
    }
    return true;
}

static bool node_write(const uint8_t *bytes, size_t n, int want_nack)
{
    int const nacked = fx_write_raw(&node, bytes, n, true);
    if (nacked != want_nack) {
        sh_str(&why, "write ");
        sh_bytes(&why, bytes, n);
        sh_str(&why, ": first NACK at byte ");
        sh_dec(&why, nacked);
        sh_str(&why, ", want ");
        sh_dec(&why, want_nack);
        sh_str(&why, " (-1: every byte ACKed)");
        return false;
    }
    return true;
}

static bool node_heartbeat(void)
{
    fm.encoder = QT_MOTOR_ENCODER;
    fm.current = QT_MOTOR_CURRENT_MA;
    fm.voltage = QT_MOTOR_VOLTAGE_MV;
    uint32_t const period = (uint32_t)cfg.heartbeat_us * cfg.ticks_per_us;
    uint32_t const beats = urb_hal_hosted_advance(&port, &node, period);
    (void)urb_node_poll(&node);
    if (beats != 1u) {
        sh_str(&why, "heartbeats in one period: ");
        sh_udec(&why, beats);
        return false;
    }
    if (fm.drive != QT_COMMAND_MV) {
        sh_str(&why, "drive ");
        sh_dec(&why, fm.drive);
        sh_str(&why, " mV, want ");
        sh_dec(&why, QT_COMMAND_MV);
        return false;
    }
    if (motor.faults != 1u) {
        sh_str(&why, "app_fault calls ");
        sh_udec(&why, motor.faults);
        return fail_text("", "want 1 (CHECKSUM from the bad write)");
    }
    return true;
}

static bool node_feedback(void)
{
    if (!read_outbox(1u, sizeof qt_feedback_read)) {
        return false;
    }
    if (memcmp(rx.bytes, qt_feedback_read, sizeof qt_feedback_read) != 0) {
        return fail_bytes("read", rx.bytes, qt_feedback_read, sizeof qt_feedback_read);
    }
    return true;
}

static void run_node(void)
{
    sh_str(&desc, "node: urb_node_init of the SensoRHex motor driver at 0x40 on the hosted HAL");
    bool const up = node_init();
    report(up);
    if (!up) {
        return;
    }
    sh_str(&desc, "node: identification read of outbox 0 (select 0x80; 25 data, 2 check, 0xff) = urb_msgs bytes");
    report(node_identification());
    sh_str(&desc, "node: Identification decoded on the M0: class, index, fingerprint (bytes 3..6), sizes");
    report(node_identification_fields());
    sh_str(&desc, "node: MotorConfig (VOLTAGE, 6 V limit) written to inbox 2, every byte ACKed");
    report(node_write(qt_write_config, sizeof qt_write_config, FX_ALL_ACKED));
    sh_str(&desc, "node: MotorCommand 4500 mV written to inbox 1, every byte ACKed");
    report(node_write(qt_write_command, sizeof qt_write_command, FX_ALL_ACKED));
    sh_str(&desc, "node: MotorCommand -9000 mV with a corrupted check byte: NACKed at that byte");
    report(node_write(qt_write_bad_command, sizeof qt_write_bad_command, (int)sizeof qt_write_bad_command - 1));
    sh_str(&desc, "node: one heartbeat: app_update drives 4500 mV (bad write not applied), one CHECKSUM fault");
    report(node_heartbeat());
    sh_str(&desc, "node: read back outbox 1 MotorFeedback (select 0x81; 6 data, 1 check, 0xff) = urb_msgs bytes");
    report(node_feedback());
}

/* ===== main ===================================================================================== */

/* Groups named on the command line (after the kernel's name); none: every group. */
static bool groups(bool *vectors, bool *node_group)
{
    static char cmdline[128];
    *vectors = true;
    *node_group = true;
    if (!sh_cmdline(cmdline, sizeof cmdline)) {
        return true;
    }
    bool any = false;
    bool first = true;
    char *word = cmdline;
    for (;;) { /* bound: the command line's length */
        while (*word == ' ') {
            word++;
        }
        if (*word == '\0') {
            break;
        }
        char *end = word;
        while (*end != '\0' && *end != ' ') {
            end++;
        }
        char const saved = *end;
        *end = '\0';
        if (!first) {
            if (!any) {
                *vectors = false;
                *node_group = false;
                any = true;
            }
            if (strcmp(word, "vectors") == 0) {
                *vectors = true;
            } else if (strcmp(word, "node") == 0) {
                *node_group = true;
            } else {
                sh_str(&out, "unknown group '");
                sh_str(&out, word);
                sh_str(&out, "' (groups: vectors, node)");
                sh_flush(&out);
                return false;
            }
        }
        first = false;
        *end = saved;
        word = end;
    }
    return true;
}

int main(void)
{
    bool vectors = true;
    bool node_group = true;
    if (!groups(&vectors, &node_group)) {
        return 2;
    }
    sh_str(&out, "# URB on Cortex-M0 (ARMv6-M, QEMU -M microbit), build: " BUILD_NAME);
    sh_flush(&out);
    if (vectors) {
        run_vectors();
    }
    if (node_group) {
        run_node();
    }
    sh_str(&out, "# ");
    sh_udec(&out, checks);
    sh_str(&out, " checks, ");
    sh_udec(&out, failures);
    sh_str(&out, " failed");
    sh_flush(&out);
    return failures == 0u && checks > 0u ? 0 : 1;
}
