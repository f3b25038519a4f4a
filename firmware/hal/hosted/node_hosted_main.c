/*
 * urb-node-hosted: URB nodes (the node library and the echo application, firmware/apps/echo) as
 * one POSIX process, each on its own connection to the CAN hub (tools/can_hub.py): the node side
 * of the hosted CAN topology. The hosted bridge joins the same hub (urb-bridge-hosted --downlink
 * can), so the host library drives real nodes over a CAN downlink. Run with --help for options.
 * CAN: time is the monotonic clock in microseconds (one node tick per microsecond); a received
 * frame is time-stamped when this process reads it, so SYNC carries the scheduling jitter of the host.
 *
 * Built with URB_NODE_HOSTED_RS485 (make node-hosted URB_DOWNLINK=rs485: urb-node-hosted-rs485) the
 * nodes are stations of the RS485 line of tools/rs485_hub.py instead, each on its own connection
 * (urb-bridge-hosted --downlink rs485 is the bridge on it). RS485: time is the line's (the hub's),
 * one node tick per microsecond: the slave's silences and the application's timer run in it, and
 * the process only reacts to the hub's events.
 */
#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/select.h>
#include <time.h>

#include "echo_app.h"
#include "urb_node.h"

#if defined(URB_NODE_HOSTED_RS485)
#include "rs485_hub_client.h"
#include "urb_node_rs485.h"
#define HUB_OPTION "--rs485-hub"
#define HUB_NAME "RS485 line"
#define HUB_TOOL "tools/rs485_hub.py"
#define FIRST_ADDRESS 1u
#define LAST_ADDRESS URB_RS485_LAST_ADDRESS
typedef struct {
    urb_rs485_hub_client_t hub;
    urb_node_rs485_t rs485;
} port_t;
#else
#include "can_hub_client.h"
#include "urb_node_can.h"
#define HUB_OPTION "--can-hub"
#define HUB_NAME "CAN hub"
#define HUB_TOOL "tools/can_hub.py"
#define FIRST_ADDRESS URB_CAN_FIRST_ADDRESS
#define LAST_ADDRESS URB_CAN_LAST_ADDRESS
typedef struct {
    urb_can_hub_client_t hub;
    urb_node_can_t can;
} port_t;
#endif

#define MAX_NODES 8

typedef struct {
    urb_node_t node;
    urb_node_hal_t hal;
    urb_node_config_t cfg;
    echo_app_t app;
    uint8_t storage[2u * 7u * 32u * 2u];
    port_t port;
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

static void n_set_compare(void *ctx, uint32_t at)
{
    hosted_node_t *n = (hosted_node_t *)ctx;
    n->compare = at;
    n->armed = 1;
}

static void n_set_address(void *ctx, uint8_t address)
{
    (void)ctx; /* the CAN or RS485 slave filters on the address it was attached with */
    (void)address;
}

/* Runs the node's timer event when it is due at `now`, then its main loop's work. */
static void node_run(hosted_node_t *n, uint32_t now)
{
    if (n->armed && ((int32_t)(now - n->compare) >= 0)) {
        n->armed = 0;
        urb_node_timer_event(&n->node);
    }
    while (urb_node_has_work(&n->node)) {
        (void)urb_node_poll(&n->node);
    }
}

#if defined(URB_NODE_HOSTED_RS485)
/* ----- the RS485 port: the slave is a station of the hub, in the line's time ----------------- */
static uint32_t n_now(void *ctx)
{
    return ((hosted_node_t *)ctx)->port.hub.now;
}

static void on_rx(void *owner, uint8_t byte, uint32_t t)
{
    urb_rs485_slave_rx(&((hosted_node_t *)owner)->port.rs485.slave, byte, t);
}

static void on_tick(void *owner, uint32_t now)
{
    hosted_node_t *n = (hosted_node_t *)owner;
    urb_rs485_slave_poll(&n->port.rs485.slave, now); /* a no-op before the silence deadline */
    node_run(n, now);
}

static bool on_tx_next(void *owner, uint8_t *byte)
{
    return urb_rs485_slave_tx_next(&((hosted_node_t *)owner)->port.rs485.slave, byte);
}

static bool on_timer(void *owner, uint32_t *at)
{
    hosted_node_t *n = (hosted_node_t *)owner;
    *at = n->compare;
    return n->armed != 0;
}

static const urb_rs485_hub_owner_t OWNER = {on_rx, on_tick, on_tx_next, on_timer};

static bool port_connect(hosted_node_t *n, const char *hub, uint32_t baud)
{
    return urb_rs485_hub_connect(&n->port.hub, hub, baud);
}

static const char *port_advice(int err)
{
    return urb_rs485_hub_advice(err);
}

static bool port_attach(hosted_node_t *n, uint32_t baud)
{
    return urb_node_rs485_attach(&n->port.rs485, &n->node, &n->cfg, &n->port.hub.hal, baud, n->port.hub.now) &&
           urb_rs485_hub_flush(&n->port.hub, n, &OWNER); /* acknowledges the welcome */
}

/* Handles the hub's events; the hub wakes the node for its timer, so *wait_us stays. */
static bool port_service(hosted_node_t *n, uint32_t *wait_us)
{
    (void)wait_us;
    return urb_rs485_hub_service(&n->port.hub, n, &OWNER);
}

static int port_fd(const hosted_node_t *n)
{
    return n->port.hub.fd;
}

static void port_close(hosted_node_t *n)
{
    urb_rs485_hub_close(&n->port.hub);
}
#else
/* ----- the CAN port: the slave on a hub connection, in the host's monotonic time ------------- */
static uint32_t n_now(void *ctx)
{
    (void)ctx;
    return mono_us();
}

static void on_rx(void *owner, const urb_can_frame_t *f)
{
    urb_can_slave_rx(&((hosted_node_t *)owner)->port.can.slave, f, mono_us());
}

static void on_tx_done(void *owner)
{
    urb_can_slave_tx_done(&((hosted_node_t *)owner)->port.can.slave);
}

static bool port_connect(hosted_node_t *n, const char *hub, uint32_t baud)
{
    (void)baud;
    return urb_can_hub_connect(&n->port.hub, hub);
}

static const char *port_advice(int err)
{
    (void)err;
    return "start tools/can_hub.py --socket PATH first, and give every program that PATH";
}

static bool port_attach(hosted_node_t *n, uint32_t baud)
{
    (void)baud;
    return urb_node_can_attach(&n->port.can, &n->node, &n->cfg, &n->port.hub.hal, 1000u);
}

/* Handles the hub's frames and the node's timer; lowers *wait_us to the timer's due time. */
static bool port_service(hosted_node_t *n, uint32_t *wait_us)
{
    if (!urb_can_hub_poll(&n->port.hub, n, on_rx, on_tx_done)) {
        return false;
    }
    node_run(n, mono_us());
    if (n->armed) {
        int32_t const d = (int32_t)(n->compare - mono_us());
        uint32_t const w = (d > 0) ? (uint32_t)d : 0u;
        *wait_us = (w < *wait_us) ? w : *wait_us;
    }
    return true;
}

static int port_fd(const hosted_node_t *n)
{
    return n->port.hub.fd;
}

static void port_close(hosted_node_t *n)
{
    urb_can_hub_close(&n->port.hub);
}
#endif

static void usage(FILE *out)
{
    fprintf(out,
            "usage: %s " HUB_OPTION " PATH --node CLASS,INDEX,ADDR[,inN=SIZE,outN=SIZE,fp=HEX...] [--seconds N]"
#if defined(URB_NODE_HOSTED_RS485)
            " [--baud N]"
#endif
            "\n\n"
            "Runs URB nodes (the node library with the echo application: outbox N is a copy of inbox N\n"
            "when both have the same size) on the " HUB_NAME " at PATH (" HUB_TOOL "). CLASS 0..255,\n"
            "INDEX 0..63, ADDR %u..%u (node addresses); N 1..7, SIZE 1..32; fp: 1 to 8 hex digits.\n"
            "Repeat --node for more nodes (at most %d). Prints \"nodes: N\" when they are on the bus.\n"
#if defined(URB_NODE_HOSTED_RS485)
            "--baud N: the line's bit rate, the hub's --baud (default 1000000).\n"
#endif
            ,
#if defined(URB_NODE_HOSTED_RS485)
            "urb-node-hosted-rs485",
#else
            "urb-node-hosted",
#endif
            (unsigned)FIRST_ADDRESS, (unsigned)LAST_ADDRESS, MAX_NODES);
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
    if ((v[0] > 255u) || (v[1] > 63u) || (v[2] < FIRST_ADDRESS) || (v[2] > LAST_ADDRESS)) {
        fprintf(stderr, "--node %s: CLASS 0..255, INDEX 0..63, ADDR %u..%u\n", spec, (unsigned)FIRST_ADDRESS,
                (unsigned)LAST_ADDRESS);
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
    unsigned long baud = 1000000;
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
        if (strcmp(o, HUB_OPTION) == 0) {
            hub = v;
#if defined(URB_NODE_HOSTED_RS485)
        } else if (strcmp(o, "--baud") == 0) {
            char *end = NULL;
            baud = strtoul(v, &end, 10);
            if ((*end != '\0') || (baud < 1200u) || (baud > 4000000u)) {
                fprintf(stderr, "--baud %s: give the line's rate, 1200..4000000\n", v);
                return 2;
            }
#endif
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
        fprintf(stderr, "give " HUB_OPTION " PATH and at least one --node; see --help\n");
        return 2;
    }
    for (int k = 0; k < count; k++) {
        hosted_node_t *n = &nodes[k];
        n->hal.ctx = n;
        n->hal.now = n_now;
        n->hal.set_compare = n_set_compare;
        n->hal.set_address = n_set_address;
        if (!port_connect(n, hub, (uint32_t)baud)) {
            int const e = errno;
            fprintf(stderr, "cannot connect to the " HUB_NAME " at %s: %s (%s)\n", hub, strerror(e), port_advice(e));
            return 1;
        }
        int const rc = urb_node_init(&n->node, &n->hal, &echo_app_hooks, &n->app, &n->cfg, n->storage,
                                     (uint16_t)sizeof n->storage);
        if ((rc != URB_NODE_OK) || !port_attach(n, (uint32_t)baud)) {
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
            if (!port_service(n, &wait_us)) {
                fprintf(stderr, "the " HUB_NAME " closed the connection: exiting\n");
                return 1;
            }
            FD_SET(port_fd(n), &rd);
            maxfd = (port_fd(n) > maxfd) ? port_fd(n) : maxfd;
        }
        struct timeval tv = {0, (suseconds_t)wait_us};
        (void)select(maxfd + 1, &rd, NULL, NULL, &tv);
    }
    for (int k = 0; k < count; k++) {
        port_close(&nodes[k]);
    }
    return 0;
}
