/* The hosted bridge's CAN downlink: hosted_can.h. */
#include "hosted_can.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <sys/select.h>
#include <time.h>
#include <unistd.h>

#include "bridge_hosted.h"
#include "can_hub_client.h"
#include "urb_can_master.h"

static uint32_t wall_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint32_t)((uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u);
}

static void m_rx(void *owner, const urb_can_frame_t *f)
{
    urb_can_master_rx((urb_can_master_t *)owner, f);
}

static void m_tx_done(void *owner)
{
    urb_can_master_tx_done((urb_can_master_t *)owner);
}

int urb_hosted_can_run(const urb_bridge_config_t *cfg, int pty, const char *hub, uint32_t timeout_us,
                       unsigned long seconds, volatile sig_atomic_t *stop, bool verbose)
{
    /* program state of the one bridge of this process */
    static urb_hosted_hal_t hal;
    static urb_can_hub_client_t client;
    static urb_can_master_t master;
    static urb_downlink_t dl;
    static urb_bridge_t bridge;
    if (!urb_can_hub_connect(&client, hub)) {
        fprintf(stderr, "cannot connect to the CAN hub at %s: %s (start tools/can_hub.py --socket %s first)\n", hub,
                strerror(errno), hub);
        return 1;
    }
    urb_hosted_hal_init(&hal);
    urb_can_master_config_t mc;
    urb_can_master_default_config(&mc);
    mc.timeout_us = timeout_us;
    urb_can_master_init(&master, &client.hal, &mc);
    urb_can_master_downlink(&master, &dl);
    uint32_t const t0 = wall_us();
    hal.now = 0u;
    if (urb_bridge_init(&bridge, cfg, &hal.hal, &dl) != URB_OK) {
        fprintf(stderr, "bridge configuration refused\n");
        return 2;
    }
    int rc = 0;
    while (!*stop) {
        hal.now = wall_us() - t0;
        if ((seconds != 0u) && (hal.now >= seconds * 1000000u)) {
            break;
        }
        if ((hal.hb_period != 0u) && ((int32_t)(hal.now - hal.hb_next) >= 0)) {
            hal.hb_next += hal.hb_period;
            if ((int32_t)(hal.now - hal.hb_next) > 0) {
                hal.hb_next = hal.now + hal.hb_period; /* descheduled: no burst of SYNCs afterwards */
            }
            urb_bridge_heartbeat(&bridge);
        }
        if (!urb_can_hub_poll(&client, &master, m_rx, m_tx_done)) {
            fprintf(stderr, "the CAN hub closed the connection: exiting\n");
            rc = 1;
            break;
        }
        uint8_t in[256];
        ssize_t const got = read(pty, in, sizeof in);
        for (ssize_t k = 0; k < got; k++) {
            urb_bridge_uart_rx(&bridge, in[k], hal.now);
        }
        urb_bridge_poll(&bridge);
        uint8_t out[256];
        size_t n = 0u;
        while ((n < sizeof out) && urb_bridge_uart_tx_pop(&bridge, &out[n])) {
            n++;
        }
        for (size_t put = 0u; put < n;) {
            ssize_t const w = write(pty, out + put, n - put);
            if (w > 0) {
                put += (size_t)w;
            }
        }
        /* sleep until a byte, a frame or the next heartbeat; short while a transaction runs */
        uint32_t wait_us = urb_bridge_idle(&bridge) ? 1000u : 100u;
        if (hal.hb_period != 0u) {
            int32_t const d = (int32_t)(hal.hb_next - (wall_us() - t0));
            uint32_t const w = (d > 0) ? (uint32_t)d : 0u;
            wait_us = (w < wait_us) ? w : wait_us;
        }
        fd_set rd;
        FD_ZERO(&rd);
        FD_SET(pty, &rd);
        FD_SET(client.fd, &rd);
        struct timeval tv = {0, (suseconds_t)wait_us};
        (void)select(((pty > client.fd) ? pty : client.fd) + 1, &rd, NULL, NULL, &tv);
    }
    if (verbose) {
        const urb_bridge_stats_t *s = urb_bridge_stats(&bridge);
        fprintf(stderr, "bridge (CAN): %u frames, %u responses, %u syncs (%u missed), %u scans; hub: %u sent, %u received\n",
                s->frames, s->responses, s->syncs, s->syncs_missed, s->scans, client.sent, client.received);
    }
    urb_can_hub_close(&client);
    return rc;
}
