/*
 * Test-only shim: the C protocol core behind plain-integer functions, for ctypes
 * (tests/host_c/test_differential.py drives it and the Python core with the same traces).
 * Transfers live in a pool indexed by the test's request id. Not part of the library.
 */
#include <stdlib.h>
#include <string.h>

#include "urb_host_core.h"

#define SHIM_POOL 16384

typedef struct {
    urb_core_t core;
    urb_transfer_t pool[SHIM_POOL];
} shim_t;

shim_t *shim_new(int kind, int window, long long timeout_ns, long long lost_after_ns, int lost_after_timeouts,
                 long long placeholder_ns, long long resync_gap_ns, int max_batch, int batch_bytes);
void shim_free(shim_t *s);
int shim_submit(shim_t *s, int id, int address, int mailbox, int read, int length, const unsigned char *data,
                long long answer_within_ns, long long now);
int shim_receive(shim_t *s, const unsigned char *data, int n, long long now);
int shim_poll(shim_t *s, long long now);
int shim_frames(shim_t *s, long long now, unsigned char *out, int cap);
int shim_take(shim_t *s, long long *rec, unsigned char *response, char *reason, int reason_cap);
long long shim_next_deadline(shim_t *s);
void shim_link_lost(shim_t *s, long long now, const char *reason);
void shim_reset(shim_t *s, long long now);
long long shim_start_drain(shim_t *s, long long now);
int shim_drained(shim_t *s);
void shim_hand_over(shim_t *s, long long until);
long long shim_busy_until(shim_t *s);
int shim_set_window(shim_t *s, int window);
void shim_stats(shim_t *s, long long *out);
const char *shim_lost_reason(shim_t *s);

shim_t *shim_new(int kind, int window, long long timeout_ns, long long lost_after_ns, int lost_after_timeouts,
                 long long placeholder_ns, long long resync_gap_ns, int max_batch, int batch_bytes)
{
    shim_t *s = calloc(1u, sizeof *s);
    if (s == NULL) {
        return NULL;
    }
    urb_core_config_t cfg;
    urb_core_default_config(&cfg, (urb_link_kind_t)kind);
    cfg.window = (uint8_t)window;
    cfg.timeout_ns = timeout_ns;
    cfg.lost_after_ns = lost_after_ns;
    cfg.lost_after_timeouts = (uint32_t)lost_after_timeouts;
    cfg.placeholder_ns = placeholder_ns;
    cfg.resync_gap_ns = resync_gap_ns;
    cfg.max_batch = (uint8_t)max_batch;
    cfg.batch_bytes = (uint16_t)batch_bytes;
    if (urb_core_init(&s->core, (urb_link_kind_t)kind, &cfg) != URB_HOST_OK) {
        free(s);
        return NULL;
    }
    return s;
}

void shim_free(shim_t *s) { free(s); }

int shim_submit(shim_t *s, int id, int address, int mailbox, int read, int length, const unsigned char *data,
                long long answer_within_ns, long long now)
{
    if ((id < 0) || (id >= SHIM_POOL)) {
        return -100;
    }
    urb_transfer_t *t = &s->pool[id];
    int32_t rc = read ? urb_transfer_read(t, (uint8_t)address, (uint8_t)mailbox, (uint8_t)length)
                      : urb_transfer_write(t, (uint8_t)address, (uint8_t)mailbox, data, (uint8_t)length);
    if (rc == URB_HOST_OK) {
        rc = urb_transfer_set_answer_within(t, answer_within_ns);
    }
    return (rc == URB_HOST_OK) ? urb_core_submit(&s->core, t, now) : rc;
}

int shim_receive(shim_t *s, const unsigned char *data, int n, long long now)
{
    return (s->core.kind == URB_LINK_USB) ? urb_core_receive_batch(&s->core, data, (size_t)n, now)
                                          : urb_core_receive(&s->core, data, (size_t)n, now);
}

int shim_poll(shim_t *s, long long now) { return urb_core_poll(&s->core, now); }

/* RS232: every frame that may go now, each preceded by its length byte; USB: the OUT transfer.
 * Returns the bytes written, or -1 when the USB core has nothing to send. */
int shim_frames(shim_t *s, long long now, unsigned char *out, int cap)
{
    if (s->core.kind == URB_LINK_USB) {
        int32_t n = urb_core_frame_out(&s->core, now, out, (size_t)cap);
        return (n == 0) ? -1 : (int)n;
    }
    int total = 0;
    for (;;) {
        unsigned char frame[URB_REQUEST_MAX];
        int32_t n = urb_core_next_frame(&s->core, now, frame, sizeof frame);
        if (n <= 0) {
            return (n < 0) ? (int)n : total;
        }
        if (total + 1 + n > cap) {
            return -2;
        }
        out[total] = (unsigned char)n;
        memcpy(out + total + 1, frame, (size_t)n);
        total += 1 + (int)n;
    }
}

/* rec: id, flags, status, seq, submitted, sent, completed, response_len; returns 1, or 0 when none. */
int shim_take(shim_t *s, long long *rec, unsigned char *response, char *reason, int reason_cap)
{
    urb_transfer_t *t = urb_core_take_completed(&s->core);
    if (t == NULL) {
        return 0;
    }
    rec[0] = (long long)(t - s->pool);
    rec[1] = (long long)t->flags;
    rec[2] = t->status;
    rec[3] = t->seq;
    rec[4] = t->submitted_ns;
    rec[5] = t->sent_ns;
    rec[6] = t->completed_ns;
    rec[7] = t->response_len;
    memcpy(response, t->response, t->response_len);
    strncpy(reason, t->lost_reason, (size_t)reason_cap - 1u);
    reason[reason_cap - 1] = '\0';
    return 1;
}

long long shim_next_deadline(shim_t *s) { return urb_core_next_deadline(&s->core); }
void shim_link_lost(shim_t *s, long long now, const char *reason) { urb_core_link_lost(&s->core, now, reason); }
void shim_reset(shim_t *s, long long now) { urb_core_reset(&s->core, now); }
long long shim_start_drain(shim_t *s, long long now) { return urb_core_start_drain(&s->core, now); }
int shim_drained(shim_t *s) { return urb_core_drained(&s->core); }
void shim_hand_over(shim_t *s, long long until) { urb_core_hand_over(&s->core, until); }
long long shim_busy_until(shim_t *s) { return urb_core_busy_until(&s->core); }
int shim_set_window(shim_t *s, int window) { return urb_core_set_window(&s->core, (uint8_t)window); }

/* out: stray, late, released, in_flight, placeholders, busy, has_queued, frames_written, transfers_in, bad_headers */
void shim_stats(shim_t *s, long long *out)
{
    out[0] = (long long)s->core.m.stray_bytes;
    out[1] = (long long)s->core.m.late_responses;
    out[2] = (long long)s->core.m.released_placeholders;
    out[3] = urb_core_in_flight(&s->core);
    out[4] = urb_core_placeholders(&s->core);
    out[5] = urb_core_busy(&s->core);
    out[6] = urb_core_has_queued(&s->core);
    out[7] = (long long)s->core.frames_written;
    out[8] = (long long)s->core.transfers_in;
    out[9] = (long long)s->core.bad_headers;
}

const char *shim_lost_reason(shim_t *s)
{
    const char *r = urb_core_lost_reason(&s->core);
    return (r == NULL) ? "" : r;
}

/* ----- the hand-over record, for the interoperability test with handover.py ----------------------- */

#include "urb_port.h"

long long shim_now(void);
int shim_handover_path(const char *port, const char *dir, char *out, int cap);
long long shim_handover_until(const char *port, const char *dir, long long now);
int shim_handover_cover(const char *port, const char *dir, long long until, long long now);
int shim_handover_settle(const char *port, const char *dir, long long until, long long now);

long long shim_now(void) { return urb_now_ns(); }

static urb_handover_t shim_record; /* test shim only: one record at a time */

int shim_handover_path(const char *port, const char *dir, char *out, int cap)
{
    int32_t const rc = urb_handover_init(&shim_record, port, dir);
    if (rc == URB_HOST_OK) {
        strncpy(out, shim_record.path, (size_t)cap - 1u);
        out[cap - 1] = '\0';
    }
    return rc;
}

long long shim_handover_until(const char *port, const char *dir, long long now)
{
    return (urb_handover_init(&shim_record, port, dir) == URB_HOST_OK) ? urb_handover_predecessor_until(&shim_record, now)
                                                                      : -1;
}

int shim_handover_cover(const char *port, const char *dir, long long until, long long now)
{
    int32_t const rc = urb_handover_init(&shim_record, port, dir);
    return (rc == URB_HOST_OK) ? urb_handover_cover(&shim_record, until, now) : rc;
}

int shim_handover_settle(const char *port, const char *dir, long long until, long long now)
{
    int32_t const rc = urb_handover_init(&shim_record, port, dir);
    return (rc == URB_HOST_OK) ? urb_handover_settle(&shim_record, until, now) : rc;
}
