/*
 * URB codec benchmark, C side. Built and run by bench/codec_bench.py (`make bench`); see
 * bench/README.md for what each case measures and how to read the ratios.
 *
 * Every case is one encode + decode round trip. Most carry a 6-byte, three-16-bit-field message:
 *
 *   memcpy        the limit: memcpy of a 6-byte struct into a buffer and back (no checks)
 *   urb_payload   urb_motor_feedback_encode + urb_motor_feedback_decode (gen/c), 6 bytes
 *   memcpy4       the limit for MotorStatus: memcpy of a 4-byte struct into a buffer and back
 *   urb_status    urb_motor_status_encode + urb_motor_status_decode: 4 bytes, an i16, a 2-bit enum,
 *                 three 1-bit bools, 3 reserved bits and a u8 (the sub-byte fields of issue #38)
 *   hand_status_bare, hand_status_checked  MotorStatus by hand in this file, inlined: the floor of
 *                 this wire layout without checks, and with the generated codec's checks
 *   urb_read_request urb_uplink_read_request_encode + _decode: 4 bytes, a fixed bit, a u7 address,
 *                 a u3 mailbox, a reserved bit, a u4 sequence number, a u8 length, CRC-8
 *   urb_frame     the URB link frame a host reads: MotorFeedback encoded into an UplinkResponse,
 *                 urb_uplink_response_encode (CRC-8), urb_uplink_response_decode (CRC check),
 *                 urb_motor_feedback_decode of its data: 8 bytes on the wire
 *   mavlink_frame mavlink_msg_power_status_pack (CRC-16 with CRC_EXTRA) + mavlink_msg_to_send_buffer,
 *                 then mavlink_parse_char over every byte (CRC check) + mavlink_msg_power_status_decode:
 *                 18 bytes on the wire (MAVLink v2, unsigned)
 *
 * Keeping the compiler honest: the inputs cycle through a 256-entry table, an empty asm statement with
 * a "memory" clobber after each encode forces the bytes to be stored and re-read by the decoder,
 * and the decoded fields are summed into a result written to a volatile sink. Each case is a
 * noinline function, which is also what callgrind's --toggle-collect selects.
 *
 * Usage:
 *   codec_bench time TARGET_SECONDS REPEATS   one JSON line per case: best and worst ns per round trip
 *   codec_bench count CASE N                  run N round trips of CASE (for callgrind)
 *   codec_bench vectors                       hex of the frames for the reference values
 *   codec_bench cases                         the case names
 *
 * URB_HAVE_C_CODECS=0 builds the MAVLink and memcpy cases only (before gen/c exists).
 */
#define _POSIX_C_SOURCE 199309L

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#ifndef URB_HAVE_C_CODECS
#define URB_HAVE_C_CODECS 1
#endif

#if URB_HAVE_C_CODECS
#include "urb_sensorhex.h"
#include "urb_core.h"
#endif

#include "common/mavlink.h"

/* Reference values: MotorFeedback and POWER_STATUS carry the same three 16-bit numbers. */
#define REF_A 1000u
#define REF_B (-1500)
#define REF_C 12000

static volatile uint64_t sink;
static uint64_t errors;

/* Make the compiler assume *p is read and any memory written: the encoded bytes must exist. */
static inline void clobber(const void *p) { __asm__ volatile("" : : "r"(p) : "memory"); }

typedef uint64_t (*case_fn)(uint64_t n);

/* ---- the limit: memcpy ------------------------------------------------------------------ */

typedef struct {
    uint16_t a;
    int16_t b;
    int16_t c;
} plain_t; /* three 16-bit fields: 6 bytes, no padding, same layout as the wire on little-endian */

/* Inputs come from a table filled at start-up, so no case pays for building its input from narrow
 * stores just before reading it back (a store-forwarding stall that would blur the memcpy limit). */
#define NINPUTS 256u
static plain_t inputs[NINPUTS];

static void fill_inputs(void) {
    for (uint32_t k = 0; k < NINPUTS; k++) {
        inputs[k].a = (uint16_t)(REF_A + k);
        inputs[k].b = (int16_t)(REF_B - (int32_t)k);
        inputs[k].c = (int16_t)(REF_C + (int32_t)k); /* never zero: MAVLink v2 would trim it */
    }
}

__attribute__((noinline)) static uint64_t case_memcpy(uint64_t n) {
    uint64_t acc = 0;
    uint8_t buf[8];
    for (uint64_t i = 0; i < n; i++) {
        memcpy(buf, &inputs[i % NINPUTS], 6);
        clobber(buf);
        plain_t out;
        memcpy(&out, buf, 6);
        clobber(&out);
        acc += (uint64_t)out.a + (uint64_t)(int64_t)out.b + (uint64_t)(int64_t)out.c;
    }
    return acc;
}

/* The MotorStatus limit: a 4-byte struct of the same shape (i16, flags byte, u8). */
typedef struct {
    int16_t t;
    uint8_t flags;
    uint8_t count;
} plain4_t;
static plain4_t inputs4[NINPUTS];

static void fill_inputs4(void) {
    for (uint32_t k = 0; k < NINPUTS; k++) {
        inputs4[k].t = (int16_t)(REF_B + (int32_t)k);
        inputs4[k].flags = (uint8_t)(k % 3u);
        inputs4[k].count = (uint8_t)k;
    }
}

__attribute__((noinline)) static uint64_t case_memcpy4(uint64_t n) {
    uint64_t acc = 0;
    uint8_t buf[8];
    for (uint64_t i = 0; i < n; i++) {
        memcpy(buf, &inputs4[i % NINPUTS], 4);
        clobber(buf);
        plain4_t out;
        memcpy(&out, buf, 4);
        clobber(&out);
        acc += (uint64_t)(int64_t)out.t + (uint64_t)out.flags + (uint64_t)out.count;
    }
    return acc;
}

/* ---- URB -------------------------------------------------------------------------------- */

#if URB_HAVE_C_CODECS
static urb_motor_feedback_t feedback_inputs[NINPUTS];

static void fill_feedback_inputs(void) {
    for (uint32_t k = 0; k < NINPUTS; k++) {
        memset(&feedback_inputs[k], 0, sizeof feedback_inputs[k]);
        feedback_inputs[k].encoder = inputs[k].a;
        feedback_inputs[k].current = inputs[k].b;
        feedback_inputs[k].voltage = inputs[k].c;
    }
}

__attribute__((noinline)) static uint64_t case_urb_payload(uint64_t n) {
    uint64_t acc = 0, bad = 0;
    uint8_t buf[8];
    for (uint64_t i = 0; i < n; i++) {
        int32_t w = urb_motor_feedback_encode(&feedback_inputs[i % NINPUTS], buf, sizeof buf);
        clobber(buf);
        urb_motor_feedback_t out;
        int32_t r = urb_motor_feedback_decode(&out, buf, (size_t)w);
        bad += (w != 6) | (r < 0);
        acc += (uint64_t)out.encoder + (uint64_t)(int64_t)out.current + (uint64_t)(int64_t)out.voltage;
    }
    errors += bad;
    return acc;
}

static urb_motor_status_t status_inputs[NINPUTS];
static urb_uplink_read_request_t read_inputs[NINPUTS];

static void fill_status_inputs(void) {
    for (uint32_t k = 0; k < NINPUTS; k++) {
        memset(&status_inputs[k], 0, sizeof status_inputs[k]);
        status_inputs[k].case_temp = inputs4[k].t;
        status_inputs[k].mode = (uint8_t)(k % 3u); /* DISABLED, VOLTAGE, LOCAL_PD */
        status_inputs[k].hall = (k & 1u) != 0u;
        status_inputs[k].overcurrent = (k & 2u) != 0u;
        status_inputs[k].overtemp = (k & 4u) != 0u;
        status_inputs[k].missed_commands = inputs4[k].count;
        memset(&read_inputs[k], 0, sizeof read_inputs[k]);
        read_inputs[k].address = (uint8_t)(1u + k % 127u);
        read_inputs[k].mailbox = (uint8_t)(k % 8u);
        read_inputs[k].seq = (uint8_t)(k % 16u);
        read_inputs[k].length = (uint8_t)(1u + k % 32u);
    }
}

__attribute__((noinline)) static uint64_t case_urb_status(uint64_t n) {
    uint64_t acc = 0, bad = 0;
    uint8_t buf[8];
    for (uint64_t i = 0; i < n; i++) {
        int32_t w = urb_motor_status_encode(&status_inputs[i % NINPUTS], buf, sizeof buf);
        clobber(buf);
        urb_motor_status_t out;
        int32_t r = urb_motor_status_decode(&out, buf, (size_t)w);
        bad += (w != 4) | (r < 0);
        acc += (uint64_t)(int64_t)out.case_temp + (uint64_t)out.mode + (uint64_t)out.hall +
               (uint64_t)out.overcurrent + (uint64_t)out.overtemp + (uint64_t)out.missed_commands;
    }
    errors += bad;
    return acc;
}

/* Hand-written MotorStatus codecs in this translation unit (the compiler sees and inlines them):
 * the floor any codec of this wire layout and this message struct can reach, to tell the cost of the
 * layout itself from the cost of the generated code. "bare" packs and unpacks the seven members and
 * checks nothing; "checked" adds exactly the generated codec's checks (mode is a member of the enum,
 * reserved bits zero, length), minus the NULL and capacity checks the call site makes constant. */
static inline void hand_status_pack(const urb_motor_status_t *m, uint8_t *b) {
    uint16_t const t = (uint16_t)m->case_temp;
    b[0] = (uint8_t)t;
    b[1] = (uint8_t)(t >> 8);
    b[2] = (uint8_t)((unsigned)m->mode | ((unsigned)m->hall << 2) | ((unsigned)m->overcurrent << 3) |
                     ((unsigned)m->overtemp << 4));
    b[3] = m->missed_commands;
}

static inline void hand_status_unpack(urb_motor_status_t *m, const uint8_t *b) {
    m->case_temp = (int16_t)(uint16_t)((unsigned)b[0] | ((unsigned)b[1] << 8));
    m->mode = (uint8_t)(b[2] & 3u);
    m->hall = (b[2] & 4u) != 0u;
    m->overcurrent = (b[2] & 8u) != 0u;
    m->overtemp = (b[2] & 16u) != 0u;
    m->missed_commands = b[3];
}

static inline uint64_t status_sum(const urb_motor_status_t *m) {
    return (uint64_t)(int64_t)m->case_temp + (uint64_t)m->mode + (uint64_t)m->hall +
           (uint64_t)m->overcurrent + (uint64_t)m->overtemp + (uint64_t)m->missed_commands;
}

__attribute__((noinline)) static uint64_t case_hand_status_bare(uint64_t n) {
    uint64_t acc = 0;
    uint8_t buf[8];
    for (uint64_t i = 0; i < n; i++) {
        hand_status_pack(&status_inputs[i % NINPUTS], buf);
        clobber(buf);
        urb_motor_status_t out;
        hand_status_unpack(&out, buf);
        acc += status_sum(&out);
    }
    return acc;
}

__attribute__((noinline)) static uint64_t case_hand_status_checked(uint64_t n) {
    uint64_t acc = 0, bad = 0;
    uint8_t buf[8];
    for (uint64_t i = 0; i < n; i++) {
        const urb_motor_status_t *in = &status_inputs[i % NINPUTS];
        size_t w = 0;
        if (in->mode <= 2u) { /* DISABLED, VOLTAGE, LOCAL_PD */
            hand_status_pack(in, buf);
            w = 4;
        }
        clobber(buf);
        urb_motor_status_t out;
        hand_status_unpack(&out, buf);
        bad += (w != 4) | (out.mode > 2u) | ((buf[2] & 0xE0u) != 0u);
        acc += status_sum(&out);
    }
    errors += bad;
    return acc;
}

__attribute__((noinline)) static uint64_t case_urb_read_request(uint64_t n) {
    uint64_t acc = 0, bad = 0;
    uint8_t buf[8];
    for (uint64_t i = 0; i < n; i++) {
        int32_t w = urb_uplink_read_request_encode(&read_inputs[i % NINPUTS], buf, sizeof buf);
        clobber(buf);
        urb_uplink_read_request_t out;
        int32_t r = urb_uplink_read_request_decode(&out, buf, (size_t)w);
        bad += (w != 4) | (r < 0);
        acc += (uint64_t)out.address + (uint64_t)out.mailbox + (uint64_t)out.seq + (uint64_t)out.length;
    }
    errors += bad;
    return acc;
}

static inline int32_t urb_frame_encode(uint64_t i, uint8_t *wire, size_t capacity) {
    urb_uplink_response_t rsp;
    memset(&rsp, 0, sizeof rsp);
    rsp.seq = (uint8_t)(i & 0xfu);
    rsp.status = URB_STATUS_OK;
    int32_t p = urb_motor_feedback_encode(&feedback_inputs[i % NINPUTS], rsp.data, sizeof rsp.data);
    rsp.data_len = (uint8_t)p;
    int32_t w = urb_uplink_response_encode(&rsp, wire, capacity);
    return p == 6 ? w : -1;
}

__attribute__((noinline)) static uint64_t case_urb_frame(uint64_t n) {
    uint64_t acc = 0, bad = 0;
    uint8_t wire[40];
    for (uint64_t i = 0; i < n; i++) {
        int32_t w = urb_frame_encode(i, wire, sizeof wire);
        clobber(wire);
        urb_uplink_response_t rx;
        int32_t r = urb_uplink_response_decode(&rx, wire, (size_t)w);
        urb_motor_feedback_t out;
        int32_t r2 = urb_motor_feedback_decode(&out, rx.data, rx.data_len);
        bad += (w != 8) | (r < 0) | (r2 < 0);
        acc += (uint64_t)rx.seq + (uint64_t)out.encoder + (uint64_t)(int64_t)out.current +
               (uint64_t)(int64_t)out.voltage;
    }
    errors += bad;
    return acc;
}
#endif

/* ---- MAVLink v2 (headers generated by pymavlink's mavgen at benchmark time) ------------- */

static uint16_t mavlink_frame_encode(uint64_t i, uint8_t *wire) {
    mavlink_message_t msg;
    /* flags stays non-zero so MAVLink v2 does not trim the payload: all 6 bytes are sent. */
    const plain_t *in = &inputs[i % NINPUTS];
    mavlink_msg_power_status_pack(1, 1, &msg, in->a, (uint16_t)in->b, (uint16_t)in->c);
    return mavlink_msg_to_send_buffer(wire, &msg);
}

__attribute__((noinline)) static uint64_t case_mavlink_frame(uint64_t n) {
    uint64_t acc = 0, bad = 0;
    uint8_t wire[MAVLINK_MAX_PACKET_LEN];
    for (uint64_t i = 0; i < n; i++) {
        uint16_t len = mavlink_frame_encode(i, wire);
        clobber(wire);
        mavlink_message_t rx;
        mavlink_status_t status;
        int got = 0;
        for (uint16_t k = 0; k < len; k++) {
            if (mavlink_parse_char(MAVLINK_COMM_0, wire[k], &rx, &status)) {
                mavlink_power_status_t ps;
                mavlink_msg_power_status_decode(&rx, &ps);
                acc += (uint64_t)ps.Vcc + (uint64_t)ps.Vservo + (uint64_t)ps.flags;
                got++;
            }
        }
        bad += (got != 1) | (len != 18);
    }
    errors += bad;
    return acc;
}

/* ---- driver ----------------------------------------------------------------------------- */

static const struct {
    const char *name;
    case_fn fn;
} CASES[] = {
    {"memcpy", case_memcpy},
#if URB_HAVE_C_CODECS
    {"urb_payload", case_urb_payload},
#endif
    {"memcpy4", case_memcpy4},
#if URB_HAVE_C_CODECS
    {"urb_status", case_urb_status},
    {"hand_status_bare", case_hand_status_bare},
    {"hand_status_checked", case_hand_status_checked},
    {"urb_read_request", case_urb_read_request},
    {"urb_frame", case_urb_frame},
#endif
    {"mavlink_frame", case_mavlink_frame},
};
#define NCASES (sizeof CASES / sizeof CASES[0])

static double now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

static double run_seconds(case_fn fn, uint64_t n) {
    double t0 = now();
    sink = fn(n);
    return now() - t0;
}

static void hex(const char *name, const uint8_t *b, size_t n) {
    printf("%s ", name);
    for (size_t k = 0; k < n; k++) printf("%02x", b[k]);
    printf("\n");
}

static int usage(void) {
    fprintf(stderr, "usage: codec_bench time SECONDS REPEATS | count CASE N | vectors | cases\n");
    return 2;
}

int main(int argc, char **argv) {
    if (argc < 2) return usage();
    fill_inputs();
    fill_inputs4();
#if URB_HAVE_C_CODECS
    fill_feedback_inputs();
    fill_status_inputs();
#endif
    if (strcmp(argv[1], "cases") == 0) {
        for (size_t c = 0; c < NCASES; c++) printf("%s\n", CASES[c].name);
        return 0;
    }
    if (strcmp(argv[1], "vectors") == 0) {
        /* The frames for input 0 (the reference values; seq 0). */
        uint8_t wire[MAVLINK_MAX_PACKET_LEN];
#if URB_HAVE_C_CODECS
        int32_t w = urb_frame_encode(0, wire, sizeof wire);
        if (w > 0) hex("urb_frame", wire, (size_t)w);
#endif
        uint16_t len = mavlink_frame_encode(0, wire);
        hex("mavlink_frame", wire, len);
        return errors ? 1 : 0;
    }
    if (strcmp(argv[1], "count") == 0 && argc == 4) {
        uint64_t n = strtoull(argv[3], NULL, 10);
        for (size_t c = 0; c < NCASES; c++) {
            if (strcmp(CASES[c].name, argv[2]) == 0) {
                sink = CASES[c].fn(n);
                return errors ? 1 : 0;
            }
        }
        fprintf(stderr, "codec_bench: unknown case %s\n", argv[2]);
        return 2;
    }
    if (strcmp(argv[1], "time") == 0 && argc == 4) {
        double target = strtod(argv[2], NULL);
        int repeats = atoi(argv[3]);
        if (target <= 0.0 || repeats < 1) return usage();
        /* Calibrate every case first: grow n until one run takes a tenth of the target, then
         * scale. The repeats then go round the cases in turn, so a burst of load from elsewhere
         * on the machine hits every case alike instead of one case's whole series. */
        uint64_t n[NCASES];
        double best[NCASES], worst[NCASES];
        for (size_t c = 0; c < NCASES; c++) {
            n[c] = 1000;
            double t = run_seconds(CASES[c].fn, n[c]);
            while (t < target / 10.0) {
                n[c] *= 10;
                t = run_seconds(CASES[c].fn, n[c]);
            }
            n[c] = (uint64_t)((double)n[c] * target / t) + 1;
            best[c] = 1e30;
            worst[c] = 0.0;
        }
        for (int r = 0; r < repeats; r++) {
            for (size_t c = 0; c < NCASES; c++) {
                double s = run_seconds(CASES[c].fn, n[c]);
                if (s < best[c]) best[c] = s;
                if (s > worst[c]) worst[c] = s;
            }
        }
        for (size_t c = 0; c < NCASES; c++) {
            printf("{\"case\": \"%s\", \"iterations\": %llu, \"repeats\": %d, \"best_ns\": %.3f, "
                   "\"worst_ns\": %.3f}\n",
                   CASES[c].name, (unsigned long long)n[c], repeats, best[c] * 1e9 / (double)n[c],
                   worst[c] * 1e9 / (double)n[c]);
        }
        if (errors) {
            fprintf(stderr, "codec_bench: %llu round trips failed to reproduce their input\n",
                    (unsigned long long)errors);
            return 1;
        }
        return 0;
    }
    return usage();
}
