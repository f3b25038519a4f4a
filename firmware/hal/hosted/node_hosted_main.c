/*
 * urb-node-hosted: URB nodes (the node library and the echo application, firmware/apps/echo) as
 * one POSIX process, each on its own connection to the CAN hub (tools/can_hub.py): the node side
 * of the hosted CAN topology. The hosted bridge joins the same hub (urb-bridge-hosted --downlink
 * can), so the host library drives real nodes over a CAN downlink. Run with --help for options.
 *
 * Time is the monotonic clock in microseconds (one node tick per microsecond); a received frame is
 * time-stamped when this process reads it, so SYNC carries the scheduling jitter of the host.
 */
#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/select.h>
#include <time.h>

#include "can_hub_client.h"
#include "echo_app.h"
#include "urb_node.h"
#include "urb_node_can.h"

#define MAX_NODES 8

typedef struct {
    urb_node_t node;
    urb_node_hal_t hal;
    urb_node_config_t cfg;
    echo_app_t app;
    uint8_t storage[2u * 7u * 32u * 2u];
    urb_can_hub_client_t hub;
    urb_node_can_t can;
    uint32_t compare;
    int armed;
} hosted_node_t;

static volatile sig_atomic_t g_stop = 0;

static void on_signal(int sig)
{
    (void)sig;
    g_stop = 1;
}

static uint32_t mono_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint32_t)((uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u);
}

static uint32_t n_now(void *ctx)
{
    (void)ctx;
    return mono_us();
}

static void n_set_compare(void *ctx, uint32_t at)
{
    hosted_node_t *n = (hosted_node_t *)ctx;
    n->compare = at;
    n->armed = 1;
}

static void n_set_address(void *ctx, uint8_t address)
{
    (void)ctx; /* the CAN slave filters on the address it was attached with */
    (void)address;
}

static void on_rx(void *owner, const urb_can_frame_t *f)
{
    urb_can_slave_rx(&((hosted_node_t *)owner)->can.slave, f, mono_us());
}

static void on_tx_done(void *owner)
{
    urb_can_slave_tx_done(&((hosted_node_t *)owner)->can.slave);
}

static void usage(FILE *out)
{
    fprintf(out,
            "usage: urb-node-hosted --can-hub PATH --node CLASS,INDEX,ADDR[,inN=SIZE,outN=SIZE,fp=HEX...] [--seconds N]\n"
            "\n"
            "Runs URB nodes (the node library with the echo application: outbox N is a copy of inbox N\n"
            "when both have the same size) on the CAN hub at PATH (tools/can_hub.py). CLASS 0..255,\n"
            "INDEX 0..63, ADDR 1..63 (CAN node addresses); N 1..7, SIZE 1..32; fp: 1 to 8 hex digits.\n"
            "Repeat --node for more nodes (at most %d). Prints \"nodes: N\" when they are on the bus.\n",
            MAX_NODES);
}

/* Parses "CLASS,INDEX,ADDR[,KEY=VALUE...]" into *n; prints why not and returns -1. */
static int parse_node(hosted_node_t *n, const char *spec)
{
    char buf[256];
    if (strlen(spec) >= sizeof buf) {
        fprintf(stderr, "--node %s: too long\n", spec);
        return -1;
    }
    strcpy(buf, spec);
    unsigned long v[3];
    char *save = NULL;
    char *tok = strtok_r(buf, ",", &save);
    for (int k = 0; k < 3; k++) {
        char *end = NULL;
        if (tok == NULL) {
            fprintf(stderr, "--node %s: give CLASS,INDEX,ADDR\n", spec);
            return -1;
        }
        errno = 0;
        v[k] = strtoul(tok, &end, 0);
        if ((errno != 0) || (*end != '\0')) {
            fprintf(stderr, "--node %s: '%s' is not a number\n", spec, tok);
            return -1;
        }
        tok = strtok_r(NULL, ",", &save);
    }
    if ((v[0] > 255u) || (v[1] > 63u) || (v[2] < URB_CAN_FIRST_ADDRESS) || (v[2] > URB_CAN_LAST_ADDRESS)) {
        fprintf(stderr, "--node %s: CLASS 0..255, INDEX 0..63, ADDR %u..%u\n", spec, URB_CAN_FIRST_ADDRESS,
                URB_CAN_LAST_ADDRESS);
        return -1;
    }
    n->app.class_id = (uint8_t)v[0];
    n->app.index = (uint8_t)v[1];
    urb_node_config_default(&n->cfg);
    n->cfg.i2c_address = (uint8_t)v[2];
    n->cfg.ticks_per_us = 1u;
    for (; tok != NULL; tok = strtok_r(NULL, ",", &save)) {
        unsigned m = 0, size = 0;
        char extra;
        if ((sscanf(tok, "in%u=%u%c", &m, &size, &extra) == 2) && (m >= 1u) && (m <= 7u) && (size >= 1u) && (size <= 32u)) {
            n->app.in_size[m] = (uint8_t)size;
        } else if ((sscanf(tok, "out%u=%u%c", &m, &size, &extra) == 2) && (m >= 1u) && (m <= 7u) && (size >= 1u) &&
                   (size <= 32u)) {
            n->app.out_size[m] = (uint8_t)size;
        } else if (strncmp(tok, "fp=", 3) == 0) {
            char *end = NULL;
            errno = 0;
            unsigned long const fp = strtoul(tok + 3, &end, 16);
            if ((errno != 0) || (*end != '\0') || (fp > 0xFFFFFFFFul)) {
                fprintf(stderr, "--node %s: fp=%s is not 1 to 8 hex digits\n", spec, tok + 3);
                return -1;
            }
            n->app.fingerprint = (uint32_t)fp;
        } else {
            fprintf(stderr, "--node %s: '%s' is not inN=SIZE, outN=SIZE or fp=HEX (N 1..7, SIZE 1..32)\n", spec, tok);
            return -1;
        }
    }
    return 0;
}

int main(int argc, char **argv)
{
    static hosted_node_t nodes[MAX_NODES]; /* program state, not library state */
    const char *hub = NULL;
    unsigned long seconds = 0;
    int count = 0;
    for (int i = 1; i < argc; i++) {
        const char *o = argv[i];
        const char *v = (i + 1 < argc) ? argv[i + 1] : NULL;
        if ((strcmp(o, "--help") == 0) || (strcmp(o, "-h") == 0)) {
            usage(stdout);
            return 0;
        }
        if (v == NULL) {
            fprintf(stderr, "%s: missing value (or unknown option); see --help\n", o);
            return 2;
        }
        i++;
        if (strcmp(o, "--can-hub") == 0) {
            hub = v;
        } else if (strcmp(o, "--seconds") == 0) {
            seconds = strtoul(v, NULL, 10);
        } else if ((strcmp(o, "--node") == 0) && (count < MAX_NODES)) {
            if (parse_node(&nodes[count], v) != 0) {
                return 2;
            }
            count++;
        } else {
            fprintf(stderr, "%s %s: unknown option, or more than %d nodes; see --help\n", o, v, MAX_NODES);
            return 2;
        }
    }
    if ((hub == NULL) || (count == 0)) {
        fprintf(stderr, "give --can-hub PATH and at least one --node; see --help\n");
        return 2;
    }
    for (int k = 0; k < count; k++) {
        hosted_node_t *n = &nodes[k];
        n->hal.ctx = n;
        n->hal.now = n_now;
        n->hal.set_compare = n_set_compare;
        n->hal.set_address = n_set_address;
        if (!urb_can_hub_connect(&n->hub, hub)) {
            fprintf(stderr, "cannot connect to the CAN hub at %s: %s (start tools/can_hub.py --socket %s first)\n", hub,
                    strerror(errno), hub);
            return 1;
        }
        int const rc = urb_node_init(&n->node, &n->hal, &echo_app_hooks, &n->app, &n->cfg, n->storage,
                                     (uint16_t)sizeof n->storage);
        if ((rc != URB_NODE_OK) || !urb_node_can_attach(&n->can, &n->node, &n->cfg, &n->hub.hal, 1000u)) {
            fprintf(stderr, "node %d: the node library refused its set-up (%d): check the mailbox sizes\n", k, rc);
            return 2;
        }
    }
    signal(SIGINT, on_signal);
    signal(SIGTERM, on_signal);
    printf("nodes: %d\n", count);
    fflush(stdout);
    uint32_t const t0 = mono_us();
    while (!g_stop) {
        uint32_t const now = mono_us();
        if ((seconds != 0u) && ((uint32_t)(now - t0) >= seconds * 1000000u)) {
            break;
        }
        fd_set rd;
        FD_ZERO(&rd);
        int maxfd = 0;
        uint32_t wait_us = 1000u;
        for (int k = 0; k < count; k++) {
            hosted_node_t *n = &nodes[k];
            if (!urb_can_hub_poll(&n->hub, n, on_rx, on_tx_done)) {
                fprintf(stderr, "the CAN hub closed the connection: exiting\n");
                return 1;
            }
            if (n->armed && ((int32_t)(mono_us() - n->compare) >= 0)) {
                n->armed = 0;
                urb_node_timer_event(&n->node);
            }
            while (urb_node_has_work(&n->node)) {
                (void)urb_node_poll(&n->node);
            }
            if (n->armed) {
                int32_t const d = (int32_t)(n->compare - mono_us());
                uint32_t const w = (d > 0) ? (uint32_t)d : 0u;
                wait_us = (w < wait_us) ? w : wait_us;
            }
            FD_SET(n->hub.fd, &rd);
            maxfd = (n->hub.fd > maxfd) ? n->hub.fd : maxfd;
        }
        struct timeval tv = {0, (suseconds_t)wait_us};
        (void)select(maxfd + 1, &rd, NULL, NULL, &tv);
    }
    for (int k = 0; k < count; k++) {
        urb_can_hub_close(&nodes[k].hub);
    }
    return 0;
}
