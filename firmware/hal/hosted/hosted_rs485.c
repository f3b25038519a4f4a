/* The hosted bridge's RS485 downlink: hosted_rs485.h. */
#include "hosted_rs485.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <sys/select.h>
#include <time.h>
#include <unistd.h>

#include "bridge_hosted.h"
#include "rs485_hub_client.h"
#include "urb_rs485_master.h"

/* The bridge, its master and its station; program state of the one bridge of this process. */
typedef struct {
    urb_hosted_hal_t hal;
    urb_rs485_hub_client_t client;
    urb_rs485_master_t master;
    urb_downlink_t master_dl; /* the master's own downlink, in line time */
    urb_downlink_t dl;        /* what the bridge drives: the master's, given the line time */
    urb_bridge_t bridge;
    uint32_t t0;
    uint32_t char_us; /* one character at the line's rate */
    uint32_t hb_next; /* line time of the next heartbeat (SYNC) */
    bool hb_armed;
} hosted_rs485_t;

static uint32_t wall_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint32_t)((uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u);
}

/* The bridge core passes its wall time; the master needs the line's. */
static bool line_begin(void *ctx, const urb_downlink_txn_t *txn, uint32_t now_us)
{
    hosted_rs485_t *h = (hosted_rs485_t *)ctx;
    (void)now_us;
    return h->master_dl.begin(h->master_dl.ctx, txn, h->client.now);
}

static int8_t line_poll(void *ctx, uint32_t now_us)
{
    hosted_rs485_t *h = (hosted_rs485_t *)ctx;
    (void)now_us;
    return h->master_dl.poll(h->master_dl.ctx, h->client.now);
}

/* The heartbeat runs in line time too: SYNC every period of the line, however fast the hub can
 * run it (a wall-clock heartbeat would fill a line that runs slower than real time with SYNCs). */
static void heartbeat(hosted_rs485_t *h)
{
    uint32_t const period = h->hal.hb_period;
    uint32_t const now = h->client.now;
    if (period == 0u) {
        h->hb_armed = false;
        return;
    }
    if (!h->hb_armed) {
        h->hb_armed = true;
        h->hb_next = now + period;
    }
    if ((int32_t)(now - h->hb_next) >= 0) {
        h->hb_next += period;
        if ((int32_t)(now - h->hb_next) > 0) {
            h->hb_next = now + period; /* no burst of SYNCs after a jump of the line time */
        }
        urb_bridge_heartbeat(&h->bridge);
    }
}

static void on_rx(void *owner, uint8_t byte, uint32_t t)
{
    urb_rs485_master_rx(&((hosted_rs485_t *)owner)->master, byte, t);
}

static void on_tick(void *owner, uint32_t now)
{
    hosted_rs485_t *h = (hosted_rs485_t *)owner;
    (void)now;
    h->hal.now = wall_us() - h->t0;
    heartbeat(h);
    urb_bridge_poll(&h->bridge); /* the outcome, and the next transaction, at this line time */
}

static bool on_tx_next(void *owner, uint8_t *byte)
{
    return urb_rs485_master_tx_next(&((hosted_rs485_t *)owner)->master, byte);
}

/* While a transaction runs the master polls its silences and timeouts every character; else the
 * next heartbeat. */
static bool on_timer(void *owner, uint32_t *at)
{
    hosted_rs485_t *h = (hosted_rs485_t *)owner;
    *at = h->hb_next;
    if (urb_rs485_master_busy(&h->master)) {
        *at = h->client.now + h->char_us;
    }
    return urb_rs485_master_busy(&h->master) || h->hb_armed;
}

static const urb_rs485_hub_owner_t OWNER = {on_rx, on_tick, on_tx_next, on_timer};

int urb_hosted_rs485_run(const urb_bridge_config_t *cfg, int pty, const char *hub, uint32_t baud,
                         unsigned long seconds, volatile sig_atomic_t *stop, bool verbose)
{
    static hosted_rs485_t h;
    if (!urb_rs485_hub_connect(&h.client, hub, baud)) {
        int const e = errno;
        fprintf(stderr, "cannot join the RS485 line at %s at %u Bd: %s (%s)\n", hub, (unsigned)baud, strerror(e),
                urb_rs485_hub_advice(e));
        return 1;
    }
    urb_hosted_hal_init(&h.hal);
    urb_rs485_timing_t tm;
    urb_rs485_timing(&tm, baud);
    h.char_us = tm.char_us;
    urb_rs485_master_init(&h.master, &h.client.hal, baud, h.client.now);
    urb_rs485_master_downlink(&h.master, &h.master_dl);
    h.dl = h.master_dl;
    h.dl.ctx = &h;
    h.dl.begin = line_begin;
    h.dl.poll = line_poll;
    h.t0 = wall_us();
    h.hal.now = 0u;
    if (urb_bridge_init(&h.bridge, cfg, &h.hal.hal, &h.dl) != URB_OK) {
        fprintf(stderr, "bridge configuration refused\n");
        return 2;
    }
    int rc = 0;
    while (!*stop) {
        h.hal.now = wall_us() - h.t0;
        if ((seconds != 0u) && (h.hal.now >= seconds * 1000000u)) {
            break;
        }
        heartbeat(&h);
        if (!urb_rs485_hub_service(&h.client, &h, &OWNER)) {
            fprintf(stderr, "the RS485 hub closed the connection (%s): exiting\n", strerror(errno));
            rc = 1;
            break;
        }
        uint8_t in[256];
        ssize_t const got = read(pty, in, sizeof in);
        for (ssize_t k = 0; k < got; k++) {
            urb_bridge_uart_rx(&h.bridge, in[k], h.hal.now);
        }
        urb_bridge_poll(&h.bridge);
        if (!urb_rs485_hub_flush(&h.client, &h, &OWNER)) {
            fprintf(stderr, "the RS485 hub closed the connection: exiting\n");
            rc = 1;
            break;
        }
        uint8_t out[256];
        size_t n = 0u;
        while ((n < sizeof out) && urb_bridge_uart_tx_pop(&h.bridge, &out[n])) {
            n++;
        }
        for (size_t put = 0u; put < n;) {
            ssize_t const w = write(pty, out + put, n - put);
            if (w > 0) {
                put += (size_t)w;
            }
        }
        /* sleep until a byte from the host or an event from the line (the heartbeat is one) */
        uint32_t const wait_us = urb_bridge_idle(&h.bridge) ? 1000u : 100u;
        fd_set rd;
        FD_ZERO(&rd);
        FD_SET(pty, &rd);
        FD_SET(h.client.fd, &rd);
        struct timeval tv = {0, (suseconds_t)wait_us};
        (void)select(((pty > h.client.fd) ? pty : h.client.fd) + 1, &rd, NULL, NULL, &tv);
    }
    if (verbose) {
        const urb_bridge_stats_t *s = urb_bridge_stats(&h.bridge);
        urb_rs485_master_stats_t ms;
        urb_rs485_master_stats(&h.master, &ms);
        fprintf(stderr,
                "bridge (RS485): %u frames, %u responses, %u syncs (%u missed), %u scans; line: %u sent, %u received, "
                "%u collisions, %u silences, %u bad answers\n",
                s->frames, s->responses, s->syncs, s->syncs_missed, s->scans, h.client.sent, h.client.received,
                ms.collisions, ms.silences, ms.bad);
    }
    urb_rs485_hub_close(&h.client);
    return rc;
}
