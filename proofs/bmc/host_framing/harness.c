/*
 * Proof of the host library's RS232/USB response framing (host/c/core/matcher.c, urbh_frame_at_head:
 * the framing step of urb_matcher_feed), by induction: from an arbitrary matcher within its
 * invariant, with arbitrary bytes held, ONE framing step, and its contract.
 *
 * The invariant it needs: at most URB_MATCHER_SLOTS requests in flight (head, count), their numbers
 * below 16, lengths 1..32; the bytes held lie within rx (rx_start + rx_len <= URB_MATCHER_RX). The
 * held bytes, the ring's numbers, lengths and directions are arbitrary: the whole rx array is
 * arbitrary, the harness constrains only what the invariant says.
 *
 * The contract (h = the first byte held, its number h & 15, its status h >> 4; k = the oldest
 * position in flight with that number, found by the harness's own walk; n = the response size that
 * request and status give: 1 + data (an OK read) + a check of 1 byte, or 2 beyond 14 covered bytes):
 *   NOTHING  exactly when nothing is held
 *   STRAY    the first byte starts no possible response: no request has its number, or its status
 *            is above 8, or all n bytes are held and their check does not hold (what urb_matcher_feed
 *            then drops is this one byte: the hunt moves one byte on)
 *   WAIT     the first byte starts a possible response to position k that is not all held (< n)
 *   WHOLE    all n bytes are held, the check value over the first n - width bytes is the last
 *            `width` bytes (little-endian), and the decoded response is position k's: its number,
 *            the status of h, the data bytes that follow h (an OK read's `length` bytes, else none)
 * A frame is delivered only when its length and check hold; the check is computed at most once and
 * only over a whole candidate; nothing is read outside rx or the candidate (ESBMC's bounds and
 * pointer checks, always on).
 *
 * The check (urb_link_check) is stubbed by an arbitrary value of the check's width
 * (proofs/bmc/stubs/fw_bridge_check.c): the framing never looks inside it, so what holds for every
 * check value holds for the CRC (proved on its own by proofs/bmc/urb_link_check).
 *
 * Bounds (the Makefile): URB_MATCHER_RX = 64 as the library builds it and a ring of 2 (the framing
 * only reads the ring: its walk finds the oldest of the two with the number). The held bytes start
 * at rx_start = URB_START, a constant of the sweep item (0, 29, 63; the Makefile says why and what
 * an arbitrary start cost); rx_len is arbitrary within the buffer. The longest response is 35
 * bytes (an OK read of 32: 1 + 32 + 2): --unwind 36 covers the candidate copy (35 rounds and the
 * exit test), the decoder's data copy (32) and the walk of the ring; unwinding assertions on.
 */
/* lobster-trace: urb.HOST_002 (a response is framed only from whole bytes whose check holds, and its number names the oldest request in flight with it) */
#include "urb_verify.h"

#include "fw_bridge_check.h"
#include "urb_host_core.h"
#include "urb_host_internal.h"
#include "urb_runtime.h"

URB_PROOF_COST_STORAGE;

#define SLOTS URB_MATCHER_SLOTS

#ifndef URB_START
#define URB_START 0
#endif

static uint32_t expected_size(bool read, uint8_t length, uint8_t status)
{
    uint32_t const covered = 1u + ((read && status == 0u) ? length : 0u);
    return covered + ((covered <= 14u) ? 1u : 2u);
}

void harness(void)
{
    urb_matcher_t m; /* uninitialised: every byte held and every slot field arbitrary */
    URB_ASSUME(m.head < SLOTS && m.count >= 1u && m.count <= SLOTS); /* parse() frames only with a request in flight */
    URB_ASSUME((uint32_t)m.rx_start + m.rx_len <= URB_MATCHER_RX);
    URB_ASSUME(m.rx_start == URB_START);
    for (uint32_t i = 0u; i < SLOTS; i++) {
        m.slot[i].t = NULL; /* the framing never reads them */
        URB_ASSUME(m.slot[i].seq < URB_SEQ_MOD && m.slot[i].length >= 1u && m.slot[i].length <= 32u);
    }
    m.done_head = NULL;
    m.done_tail = NULL;
    uint8_t const rx_start = m.rx_start;
    uint8_t const rx_len = m.rx_len;
    uint8_t const count = m.count;
    uint8_t const head_index = m.head;

    urbh_candidate_t c;
    urbh_frame_t const f = urbh_frame_at_head(&m, &c);

    URB_ASSERT(m.rx_start == rx_start && m.rx_len == rx_len && m.count == count && m.head == head_index,
               "framing: the matcher is unchanged");
    URB_ASSERT((f == URBH_FRAME_NOTHING) == (rx_len == 0u), "framing: NOTHING exactly when no byte is held");
    if (rx_len == 0u) {
        URB_COVER("nothing-held");
        return;
    }
    uint8_t const h = m.rx[rx_start];
    uint8_t const seq = (uint8_t)(h & 0x0Fu);
    uint8_t const status = (uint8_t)(h >> 4);
    uint32_t k = count; /* the oldest position with the number, by a walk to the constant bound */
    for (uint32_t j = 0u; j < SLOTS; j++) {
        if ((j < count) && (k == count) && (m.slot[(head_index + j) % SLOTS].seq == seq)) {
            k = j;
        }
    }
    bool const possible = (k < count) && (status <= 8u);
    if (!possible) {
        URB_ASSERT(f == URBH_FRAME_STRAY && fw_bridge_check_calls == 0u,
                   "hunting: a byte whose number no request has, or whose status is out of range, is stray");
        if (k == count) {
            URB_COVER("stray-unknown-number");
        } else {
            URB_COVER("stray-status-out-of-range");
        }
        return;
    }
    uint32_t const x = (head_index + k) % SLOTS;
    bool const read = m.slot[x].read;
    uint32_t const n = expected_size(read, m.slot[x].length, status);
    uint32_t const width = (n - 1u <= 14u) ? 1u : 2u;
    if (rx_len < n) {
        URB_ASSERT(f == URBH_FRAME_WAIT && c.k == k && c.n == n && fw_bridge_check_calls == 0u,
                   "framing: a possible start with fewer bytes than its response waits");
        URB_COVER("wait");
        if (read && status == 0u && m.slot[x].length == 32u) {
            URB_COVER("wait-for-longest");
        }
        return;
    }
    URB_ASSERT(f == URBH_FRAME_WHOLE || f == URBH_FRAME_STRAY, "framing: a whole candidate is checked");
    URB_ASSERT(c.k == k && c.n == n, "framing: the candidate is the oldest request with the number, sized by it");
    URB_ASSERT(fw_bridge_check_calls == 1u, "framing: the check is computed once, over a whole candidate");
    uint32_t const check = (width == 1u) ? m.rx[rx_start + n - 1u]
                                         : (uint32_t)m.rx[rx_start + n - 2u] | ((uint32_t)m.rx[rx_start + n - 1u] << 8);
    bool const check_holds = (check == fw_bridge_check_last);
    URB_ASSERT((f == URBH_FRAME_WHOLE) == check_holds, "framing: a frame is delivered exactly when its check holds");
    if (f == URBH_FRAME_WHOLE) {
        uint32_t const data_len = n - 1u - width;
        URB_ASSERT(c.resp.seq == seq && c.resp.status == status && c.resp.data_len == data_len &&
                       data_len == ((read && status == 0u) ? m.slot[x].length : 0u),
                   "framing: the response decoded is the candidate's number, status and data length");
        for (uint32_t i = 0u; i < 32u; i++) {
            URB_ASSERT(i >= data_len || c.resp.data[i] == m.rx[rx_start + 1u + i], "framing: the data bytes follow the first byte");
        }
        URB_COVER("whole");
        if (k > 0u) {
            URB_COVER("whole-behind-another");
        }
        if (data_len == 32u) {
            URB_COVER("whole-longest");
            if ((uint32_t)rx_start + n == URB_MATCHER_RX) {
                URB_COVER("whole-longest-at-rx-end");
            }
        }
        if (status != 0u) {
            URB_COVER("whole-error-status");
        }
    } else {
        URB_COVER("stray-bad-check");
    }
}
