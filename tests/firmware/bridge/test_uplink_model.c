/*
 * The RS232 parser (firmware/bridge/bridge_uplink.c) against a reference model written from its
 * documented behaviour (urb_bridge.h, bridge_internal.h; spec/schema/README.md, "RS232
 * resynchronisation"), driven with seeded random inputs and compared call by call: the requests
 * each call admits (in order, with their fields), every counter, the receive ring, the bytes the
 * assembler holds. Each bridge starts over random memory (a restart without zeroing), so every state
 * the initialisation must set is checked too. Written for the mutation review of the "uplink
 * parsers" component (tests/mutation/README.md): each test kills many of its generated mutants. The
 * model is deliberately plain (the held bytes shift to the front, the ring counts without wrapping)
 * so that it shares no index arithmetic with the firmware.
 */
#include <stdlib.h>
#include <string.h>

#include "bridge_internal.h"
#include "support.h"
#include "uplink_model.h"
#include "urb_runtime.h"

#define MODEL_RX_RING 64u

/* ===== The RS232 model ============================================================================ */

typedef struct {
    uint32_t gap_us; /* one byte time and the idle gap: bytes further apart are separated by a gap */
    uint16_t ring[MODEL_RX_RING];
    uint32_t ring_in, ring_out; /* bytes ever stored in and taken from the ring */
    bool overrun, started;
    uint32_t last_us;
    uint8_t held[URB_BRIDGE_FRAME_MAX + URB_BRIDGE_RX_PER_POLL];
    size_t held_len;
    bool flushing;
    urb_bridge_stats_t st;
    admitted_t admitted;
} rs232_model_t;

static void model_drop(rs232_model_t *m, size_t k)
{
    memmove(m->held, m->held + k, m->held_len - k);
    m->held_len -= k;
}

/* urb_bridge_uart_rx: the byte and whether an idle gap (or a lost byte) precedes it. */
static void model_rx(rs232_model_t *m, uint8_t byte, uint32_t t)
{
    uint16_t flag = 0u;
    if (m->started && ((uint32_t)(t - m->last_us) > m->gap_us)) {
        flag = URB_BRIDGE_RX_GAP;
    }
    m->started = true;
    m->last_us = t;
    m->st.rx_bytes++;
    if ((m->ring_in - m->ring_out) >= MODEL_RX_RING) {
        m->overrun = true;
        m->st.rx_overruns++;
        return;
    }
    if (m->overrun) {
        flag = URB_BRIDGE_RX_GAP;
        m->overrun = false;
    }
    m->ring[m->ring_in % MODEL_RX_RING] = (uint16_t)(byte | flag);
    m->ring_in++;
}

/* The held bytes, as far as they can be settled: every complete candidate costs a check (false when
 * none is left); a frame is admitted whole, anything else loses its first byte; an incomplete one
 * waits, unless `ended`: then the bytes are flushed one by one (one gap drop) until none is held. */
static bool model_settle(rs232_model_t *m, unsigned *checks, bool ended)
{
    while (m->held_len > 0u) {
        int const need = request_len(m->held, m->held_len);
        if ((need > 0) && ((size_t)need <= m->held_len)) {
            if (*checks == 0u) {
                return false;
            }
            (*checks)--;
            if (passes_check(m->held, (size_t)need)) {
                admit_frame(&m->admitted, m->held, (size_t)need);
                m->st.frames++;
                model_drop(m, (size_t)need);
                continue;
            }
            m->st.hunt_discards++;
        } else if (m->flushing || (ended && (need != IMPOSSIBLE))) {
            if (!m->flushing) {
                m->st.gap_drops++;
                m->flushing = true;
            }
        } else if (need != IMPOSSIBLE) {
            return true; /* incomplete: wait for more bytes */
        } else {
            m->st.hunt_discards++;
        }
        model_drop(m, 1u);
    }
    m->flushing = false;
    return true;
}

/* urbb_uart_parse: at most URB_BRIDGE_RX_PER_POLL ring bytes and `checks` checks. */
static void model_parse(rs232_model_t *m, uint32_t now, unsigned checks)
{
    for (unsigned taken = 0u;; taken++) {
        bool const more = (taken < URB_BRIDGE_RX_PER_POLL) && (m->ring_out != m->ring_in);
        bool ended;
        if (more) {
            ended = (m->ring[m->ring_out % MODEL_RX_RING] & URB_BRIDGE_RX_GAP) != 0u;
        } else {
            uint32_t const idle = now - m->last_us;
            ended = (taken < URB_BRIDGE_RX_PER_POLL) && (idle > m->gap_us) && (idle < 0x80000000u);
        }
        if (!model_settle(m, &checks, ended)) {
            m->st.hunt_yields++;
            return;
        }
        if (!more) {
            return;
        }
        m->held[m->held_len++] = (uint8_t)(m->ring[m->ring_out % MODEL_RX_RING] & 0xFFu);
        m->ring_out++;
    }
}


/* The bridge's receive ring, assembler and counters are the model's. */
static void expect_rs232(urb_bridge_t *b, rs232_model_t *m)
{
    expect_stats(b, &m->st);
    uint8_t const queued = (uint8_t)(b->rx_head - b->rx_tail);
    assert_int_equal(queued, m->ring_in - m->ring_out);
    for (uint8_t k = 0u; k < queued; k++) {
        assert_int_equal(b->rx_ring[(uint8_t)(b->rx_tail + k) % URB_BRIDGE_RX_RING],
                         m->ring[(m->ring_out + k) % MODEL_RX_RING]);
    }
    assert_int_equal(b->rx_overrun != 0u, m->overrun);
    assert_int_equal(b->rs232.len, m->held_len);
    assert_true((size_t)b->rs232.start + b->rs232.len <= URB_BRIDGE_PARSE_BUF);
    assert_memory_equal(&b->rs232.buf[b->rs232.start], m->held, m->held_len);
    if (m->held_len > 0u) { /* with nothing held the flag is dead: the next hunt clears it before use */
        assert_int_equal(b->rs232.flushing, m->flushing);
    }
    expect_admitted(b, &m->admitted, URBB_UPLINK_RS232);
}


/* The time of a poll after the last byte at `last`: at it, inside the gap, at its edge, past it,
 * before it (the interrupt stored a byte after the poll read the clock) or half the clock away. */
static uint32_t poll_time(uint32_t *s, uint32_t last, uint32_t gap)
{
    switch (below(s, 8u)) {
    case 0u:
        return last + gap;
    case 1u:
        return last + gap + 1u;
    case 2u:
        return last + gap + 1u + below(s, 3000u);
    case 3u:
        return last - 1u - below(s, 300u);
    case 4u:
        return last + ((below(s, 2u) == 0u) ? 0x7FFFFFFFu : 0x80000000u);
    default:
        return last + below(s, gap + 1u);
    }
}

/* The distance to the next byte: back to back mostly, else anywhere up to the gap, at its edge,
 * just past it or far past it. */
static uint32_t byte_spacing(uint32_t *s, uint32_t byte_us, uint32_t gap)
{
    switch (below(s, 12u)) {
    case 0u:
        return gap;
    case 1u:
        return gap + 1u;
    case 2u:
        return gap + 1u + below(s, 100000u);
    case 3u:
        return byte_us + below(s, gap - byte_us + 1u);
    default:
        return byte_us;
    }
}

static unsigned poll_budget(uint32_t *s)
{
    uint32_t const k = below(s, 8u);
    return (k < 6u) ? k : ((k == 6u) ? URB_BRIDGE_HUNT_CHECKS : 255u);
}

static const uint32_t BAUDS[4] = {115200u, 9600u, 1000000u, 460800u};
static const uint32_t IDLE_GAPS[3] = {0u, 40u, 1500u};

/* RS232: random streams of requests, damaged requests and garbage, at random times, polled at random
 * times with random budgets (bursts without polls overrun the ring), compared with the model after
 * every received byte and every poll, then drained at the end. */
static void rs232_matches_its_model(void **state)
{
    (void)state;
    uint32_t s = 0x5EED2329u;
    urb_hosted_rig_t *rig = rig_new(16u, 0u);
    unsigned frames = 0u;
    for (unsigned round = 0u; round < 48u; round++) {
        uint32_t const baud = BAUDS[round % 4u];
        uint32_t const idle_gap = IDLE_GAPS[(round / 4u) % 3u];
        uint32_t const byte_us = (10000000u + baud - 1u) / baud;
        rs232_model_t m;
        memset(&m, 0, sizeof m);
        m.gap_us = byte_us + ((idle_gap != 0u) ? idle_gap : (20000000u + baud - 1u) / baud);
        urb_bridge_t *b = bridge_over_garbage(&s, rig, &rig->hal.hal, baud, idle_gap);
        assert_int_equal(b->rx_gap_us, m.gap_us);
        expect_rs232(b, &m);
        uint32_t t = (round % 3u == 0u) ? 0xFFFFFFFFu - below(&s, 20000u) : rnd(&s);
        unsigned const pieces = 20u + below(&s, 30u);
        for (unsigned piece = 0u; piece < pieces; piece++) {
            uint8_t f[40];
            size_t const n = stream_piece(&s, f);
            bool const burst = below(&s, 10u) == 0u; /* no poll: the ring may overrun */
            bool const messy = below(&s, 3u) == 0u;  /* gaps and idle polls inside the piece */
            for (size_t i = 0u; i < n; i++) {
                t += (messy || (i == 0u)) ? byte_spacing(&s, byte_us, m.gap_us) : byte_us;
                urb_bridge_uart_rx(b, f[i], t);
                model_rx(&m, f[i], t);
                expect_rs232(b, &m);
                for (uint32_t polls = burst ? 0u : below(&s, 3u); polls > 0u; polls--) {
                    uint32_t const now = (messy || (i + 1u == n)) ? poll_time(&s, t, m.gap_us) : t;
                    unsigned const checks = poll_budget(&s);
                    urbb_uart_parse(b, now, (uint8_t)checks);
                    model_parse(&m, now, checks);
                    expect_rs232(b, &m);
                }
            }
        }
        for (unsigned i = 0u; (i < 100u) && ((m.held_len > 0u) || (m.ring_in != m.ring_out)); i++) {
            uint32_t const now = t + m.gap_us + 1u; /* idle: a partial frame is flushed */
            urbb_uart_drain(b, now);
            model_parse(&m, now, URB_BRIDGE_HUNT_CHECKS);
            expect_rs232(b, &m);
        }
        frames += m.st.frames;
        free(b);
    }
    print_message("rs232 model: %u frames\n", frames);
    assert_true(frames > 500u); /* the streams reach admission, not only the hunting */
    rig_free(rig);
}

/* RS232: 1 to 70 bytes queued back to back without a poll (requests, then a cut one; past 64 the
 * ring overruns), then polls on an idle line until all is settled: the byte cap per poll meets the
 * idle flush at every position, the longest frames meet the budget, compared after every poll. */
static void rs232_queued_bytes_then_idle_polls(void **state)
{
    (void)state;
    uint32_t s = 0x0DDBA11u;
    urb_hosted_rig_t *rig = rig_new(16u, 0u);
    for (unsigned q = 1u; q <= 70u; q++) {
        for (unsigned variant = 0u; variant < 3u; variant++) {
            rs232_model_t m;
            memset(&m, 0, sizeof m);
            urb_bridge_t *b = bridge_over_garbage(&s, rig, &rig->hal.hal, 115200u, 0u);
            m.gap_us = b->rx_gap_us;
            uint8_t bytes[80];
            size_t n = 0u;
            while (n < q) {
                uint8_t f[40];
                size_t const k = (variant == 2u) ? stream_piece(&s, f) : good_frame(&s, f, variant == 0u);
                size_t const take = (n + k <= q) ? k : q - n;
                memcpy(bytes + n, f, take);
                n += take;
            }
            uint32_t t = rnd(&s);
            for (size_t i = 0u; i < n; i++) {
                t += BYTE_US;
                urb_bridge_uart_rx(b, bytes[i], t);
                model_rx(&m, bytes[i], t);
            }
            expect_rs232(b, &m);
            for (unsigned poll = 0u; (poll < 40u) && ((m.held_len > 0u) || (m.ring_in != m.ring_out)); poll++) {
                uint32_t const now = t + m.gap_us + 1u + poll;
                unsigned const checks = (poll % 2u == 0u) ? URB_BRIDGE_HUNT_CHECKS : 255u;
                urbb_uart_parse(b, now, (uint8_t)checks);
                model_parse(&m, now, checks);
                expect_rs232(b, &m);
            }
            assert_int_equal(m.held_len, 0u);
            assert_int_equal(m.ring_in, m.ring_out);
            free(b);
        }
    }
    rig_free(rig);
}

int run_uplink_model_tests(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(rs232_matches_its_model),
        cmocka_unit_test(rs232_queued_bytes_then_idle_polls),
    };
    return cmocka_run_group_tests_name("bridge_uplink_model", tests, NULL, NULL);
}
