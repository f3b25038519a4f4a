/*
 * urb-bridge-hosted: the bridge firmware on a POSIX host, its RS232 uplink on a pseudo-terminal,
 * its downlink an in-process simulated I2C bus with fake nodes (firmware/hal/hosted/), or with
 * --downlink can the CAN hub of tools/can_hub.py with urb-node-hosted processes (firmware/hal/hosted/hosted_can.c),
 * or with --downlink rs485 the RS485 line of tools/rs485_hub.py with urb-node-hosted-rs485 processes
 * (firmware/hal/hosted/hosted_rs485.c).
 *
 * For host-library tests over a real serial port API (pyserial): open the printed pty path at any
 * baud rate and talk URB. The first line on stdout is "pty: PATH". Run with --help for options.
 */
#include <errno.h>
#include <fcntl.h>
#include <sys/select.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include "bridge_hosted.h"
#include "hosted_can.h"
#include "hosted_rs485.h"
#include "urb_bridge.h"
#include "urb_core.h"
#include "urb_sensorhex.h"

#define MAX_NODES 16

static volatile sig_atomic_t g_stop = 0;

static void on_signal(int sig)
{
    (void)sig;
    g_stop = 1;
}

static void usage(FILE *out)
{
    fprintf(out,
            "usage: urb-bridge-hosted [options]\n"
            "\n"
            "Runs the URB bridge firmware with its RS232 uplink on a pseudo-terminal and its I2C downlink\n"
            "simulated in-process with fake nodes. Prints \"pty: PATH\" as the first line on stdout; open\n"
            "PATH with any serial API (pyserial: serial.Serial(PATH)) and speak the URB uplink protocol.\n"
            "\n"
            "options:\n"
            "  --node KIND,INDEX,ADDR[,KEY=VALUE...]\n"
            "                    attach a fake node (repeat for more, at most %d). KIND is a SensoRHex node\n"
            "                    (motor, battery, imu, ir: class, mailbox sizes and fingerprint from the\n"
            "                    schema) or a class number (e.g. 0x42: generic node with in1=4, out1=4).\n"
            "                    INDEX 0..63, ADDR 0x08..0x77. KEYs: inN=SIZE, outN=SIZE (N 1..7, SIZE 0..32),\n"
            "                    fp=HEX (fingerprint: 1 to 8 hex digits, 0x optional, e.g. fp=00c0ffee),\n"
            "                    echo=0|1 (default 1: a write to inbox N is copied to outbox N when their\n"
            "                    sizes match), absent=1 (wired but not answering).\n"
            "                    Outboxes start zeroed; outbox 0 holds the node's identification.\n"
            "                    e.g. --node motor,0,0x20 --node motor,1,0x21 --node 0x42,3,0x30,in1=8,out1=8\n"
            "  --fifo N          request FIFO depth, 1..16 (default 16)\n"
            "  --heartbeat US    SYNC period in microseconds, 0 = off (default 1000)\n"
            "  --baud N          RS232 bit rate for the idle-gap rule (default 115200)\n"
            "  --i2c-khz N       simulated I2C bit rate (default 400)\n"
            "  --no-scan         do not scan the downlink at start (the host sends SCAN)\n"
            "  --link PATH       also make PATH a symbolic link to the pty (removed at exit)\n"
            "  --seconds N       exit after N seconds (default: run until SIGINT or SIGTERM)\n"
            "  --downlink i2c|can|rs485  the downlink (default i2c: the in-process fake nodes of --node)\n"
            "  --can-hub PATH    with --downlink can: the CAN hub at PATH (tools/can_hub.py; python-can's virtual\n"
            "                    bus by default, --interface socketcan for a real one) with the nodes in other\n"
            "                    processes (urb-node-hosted --can-hub PATH --node ...); no --node here\n"
            "  --can-timeout-us N CAN transaction timeout (default 20000: hosted nodes are processes)\n"
            "  --rs485-hub PATH  with --downlink rs485: the RS485 line at PATH (tools/rs485_hub.py, which keeps\n"
            "                    the line's time: the RS485 master's silences and timeouts are in it) with the\n"
            "                    nodes in other processes (urb-node-hosted-rs485 --rs485-hub PATH --node ...)\n"
            "  --rs485-baud N    the line's bit rate, the hub's --baud (default 1000000)\n"
            "  --verbose         print bridge counters on stderr at exit\n"
            "  --help            this text\n",
            MAX_NODES);
}

/* Parses a decimal number, or a hexadecimal one after 0x (a leading 0 is not octal: 010 is ten). */
static int parse_uint(const char *s, unsigned long max, unsigned long *out)
{
    if ((s[0] < '0') || (s[0] > '9')) {
        return -1; /* strtoul would take a sign or leading spaces */
    }
    int const base = ((s[0] == '0') && ((s[1] == 'x') || (s[1] == 'X'))) ? 16 : 10;
    char *end = NULL;
    errno = 0;
    unsigned long v = strtoul(s, &end, base);
    if ((errno != 0) || (end == s) || (*end != '\0') || (v > max)) {
        return -1;
    }
    *out = v;
    return 0;
}

/* Parses 1..8 hexadecimal digits, with or without a 0x prefix (no sign, no spaces). */
static int parse_hex32(const char *s, uint32_t *out)
{
    if ((s[0] == '0') && ((s[1] == 'x') || (s[1] == 'X'))) {
        s += 2;
    }
    uint32_t v = 0;
    size_t n = 0;
    for (; s[n] != '\0'; n++) {
        char const c = s[n];
        uint32_t d;
        if ((c >= '0') && (c <= '9')) {
            d = (uint32_t)(c - '0');
        } else if ((c >= 'a') && (c <= 'f')) {
            d = (uint32_t)(c - 'a') + 10u;
        } else if ((c >= 'A') && (c <= 'F')) {
            d = (uint32_t)(c - 'A') + 10u;
        } else {
            return -1;
        }
        if (n >= 8) {
            return -1;
        }
        v = (v << 4) | d;
    }
    if (n == 0) {
        return -1;
    }
    *out = v;
    return 0;
}

typedef struct {
    const char *name;
    uint8_t class_id;
    uint32_t fingerprint;
    const uint8_t *in;
    const uint8_t *out;
} preset_t;

static const preset_t PRESETS[] = {
    {"motor", URB_NODE_MOTOR_DRIVER_CLASS, URB_NODE_MOTOR_DRIVER_FINGERPRINT, urb_node_motor_driver_inbox_sizes,
     urb_node_motor_driver_outbox_sizes},
    {"battery", URB_NODE_BATTERY_MANAGER_CLASS, URB_NODE_BATTERY_MANAGER_FINGERPRINT,
     urb_node_battery_manager_inbox_sizes, urb_node_battery_manager_outbox_sizes},
    {"imu", URB_NODE_IMU_CLASS, URB_NODE_IMU_FINGERPRINT, urb_node_imu_inbox_sizes, urb_node_imu_outbox_sizes},
    {"ir", URB_NODE_IR_DISTANCE_CLASS, URB_NODE_IR_DISTANCE_FINGERPRINT, urb_node_ir_distance_inbox_sizes,
     urb_node_ir_distance_outbox_sizes},
};

/* Parses one --node SPEC into the bus; returns 0 or prints why not and returns -1. */
static int add_node_spec(urb_fake_i2c_t *bus, const char *spec)
{
    char buf[256];
    if (strlen(spec) >= sizeof buf) {
        fprintf(stderr, "--node %s: too long\n", spec);
        return -1;
    }
    strcpy(buf, spec);
    char *save = NULL;
    char *kind = strtok_r(buf, ",", &save);
    char *index = strtok_r(NULL, ",", &save);
    char *addr = strtok_r(NULL, ",", &save);
    unsigned long idx = 0, a = 0, cls = 0;
    if ((kind == NULL) || (index == NULL) || (addr == NULL) || (parse_uint(index, 63, &idx) != 0) ||
        (parse_uint(addr, URB_I2C_LAST_ADDRESS, &a) != 0) || (a < URB_I2C_FIRST_ADDRESS)) {
        fprintf(stderr, "--node %s: expected KIND,INDEX(0..63),ADDR(0x08..0x77)\n", spec);
        return -1;
    }
    const preset_t *preset = NULL;
    for (size_t i = 0; i < sizeof PRESETS / sizeof PRESETS[0]; i++) {
        if (strcmp(kind, PRESETS[i].name) == 0) {
            preset = &PRESETS[i];
        }
    }
    if ((preset == NULL) && (parse_uint(kind, 255, &cls) != 0)) {
        fprintf(stderr, "--node %s: KIND must be motor, battery, imu, ir or a class number\n", spec);
        return -1;
    }
    for (uint8_t i = 0; i < URB_FAKE_MAX_NODES; i++) {
        if (bus->nodes[i].used && (bus->nodes[i].address == a)) {
            fprintf(stderr, "--node %s: address 0x%02lx is taken\n", spec, a);
            return -1;
        }
    }
    urb_fake_node_t *n = urb_fake_i2c_add(bus, (uint8_t)a, preset ? preset->class_id : (uint8_t)cls, (uint8_t)idx);
    if (n == NULL) {
        fprintf(stderr, "--node %s: at most %u nodes\n", spec, URB_FAKE_MAX_NODES);
        return -1;
    }
    n->echo = true;
    if (preset != NULL) {
        n->fingerprint = preset->fingerprint;
        memcpy(n->in_size, preset->in, 8);
        memcpy(n->out_size, preset->out, 8);
    } else {
        n->in_size[1] = 4;
        n->out_size[1] = 4;
    }
    for (char *kv = strtok_r(NULL, ",", &save); kv != NULL; kv = strtok_r(NULL, ",", &save)) {
        char *eq = strchr(kv, '=');
        unsigned long v = 0;
        if ((eq != NULL) && (strncmp(kv, "fp=", 3) == 0)) {
            uint32_t fp = 0;
            if (parse_hex32(eq + 1, &fp) != 0) {
                fprintf(stderr, "--node %s: bad fingerprint '%s': give 1 to 8 hex digits (e.g. fp=00c0ffee or fp=0xdeadbeef)\n",
                        spec, kv);
                return -1;
            }
            n->fingerprint = fp;
            continue;
        }
        if ((eq == NULL) || (parse_uint(eq + 1, 0xFFFFFFFFul, &v) != 0)) {
            fprintf(stderr, "--node %s: bad KEY=VALUE '%s'\n", spec, kv);
            return -1;
        }
        *eq = '\0';
        if (((kv[0] == 'i' && kv[1] == 'n') || (kv[0] == 'o' && kv[1] == 'u' && kv[2] == 't'))) {
            const char *num = (kv[0] == 'i') ? kv + 2 : kv + 3;
            unsigned long m = 0;
            if ((parse_uint(num, 7, &m) != 0) || (m == 0) || (v > 32)) {
                fprintf(stderr, "--node %s: %s: mailbox 1..7, size 0..32\n", spec, kv);
                return -1;
            }
            if (kv[0] == 'i') {
                n->in_size[m] = (uint8_t)v;
            } else {
                n->out_size[m] = (uint8_t)v;
            }
        } else if (strcmp(kv, "echo") == 0) {
            n->echo = v != 0;
        } else if (strcmp(kv, "absent") == 0) {
            n->present = v == 0;
        } else {
            fprintf(stderr, "--node %s: unknown key '%s'\n", spec, kv);
            return -1;
        }
    }
    urb_fake_node_identify(n);
    return 0;
}

static uint64_t mono_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

int main(int argc, char **argv)
{
    static urb_hosted_rig_t rig; /* program state, not library state: one bridge here */
    urb_bridge_config_t cfg;
    urb_i2c_master_config_t mcfg;
    urb_bridge_default_config(&cfg);
    urb_i2c_master_default_config(&mcfg);
    const char *link = NULL;
    unsigned long seconds = 0, khz = 400;
    bool verbose = false;
    const char *specs[MAX_NODES];
    int n_specs = 0;
    bool downlink_can = false;
    bool downlink_rs485 = false;
    const char *rs485_hub = NULL;
    unsigned long rs485_baud = 1000000;
    const char *can_hub = NULL;
    unsigned long can_timeout_us = 20000;

    for (int i = 1; i < argc; i++) {
        const char *o = argv[i];
        const char *v = (i + 1 < argc) ? argv[i + 1] : NULL;
        unsigned long x = 0;
        if ((strcmp(o, "--help") == 0) || (strcmp(o, "-h") == 0)) {
            usage(stdout);
            return 0;
        } else if (strcmp(o, "--verbose") == 0) {
            verbose = true;
        } else if (strcmp(o, "--no-scan") == 0) {
            cfg.scan_at_start = false;
        } else if (v == NULL) {
            fprintf(stderr, "%s: missing value (or unknown option); see --help\n", o);
            return 2;
        } else if (strcmp(o, "--node") == 0) {
            if (n_specs >= MAX_NODES) {
                fprintf(stderr, "at most %d --node options\n", MAX_NODES);
                return 2;
            }
            specs[n_specs++] = v;
            i++;
        } else if (strcmp(o, "--fifo") == 0 && parse_uint(v, URB_BRIDGE_FIFO_MAX, &x) == 0 && x >= 1) {
            cfg.fifo_depth = (uint8_t)x;
            i++;
        } else if (strcmp(o, "--heartbeat") == 0 && parse_uint(v, 65535, &x) == 0) {
            cfg.heartbeat_us = (uint16_t)x;
            i++;
        } else if (strcmp(o, "--baud") == 0 && parse_uint(v, 10000000, &x) == 0 && x >= 300) {
            cfg.baud = (uint32_t)x;
            i++;
        } else if (strcmp(o, "--i2c-khz") == 0 && parse_uint(v, 5000, &khz) == 0 && khz >= 10) {
            i++;
        } else if (strcmp(o, "--downlink") == 0 &&
                   (strcmp(v, "i2c") == 0 || strcmp(v, "can") == 0 || strcmp(v, "rs485") == 0)) {
            downlink_can = strcmp(v, "can") == 0;
            downlink_rs485 = strcmp(v, "rs485") == 0;
            i++;
        } else if (strcmp(o, "--rs485-hub") == 0) {
            rs485_hub = v;
            i++;
        } else if (strcmp(o, "--rs485-baud") == 0 && parse_uint(v, 4000000, &rs485_baud) == 0 && rs485_baud >= 1200) {
            i++;
        } else if (strcmp(o, "--can-hub") == 0) {
            can_hub = v;
            i++;
        } else if (strcmp(o, "--can-timeout-us") == 0 && parse_uint(v, 10000000, &can_timeout_us) == 0) {
            i++;
        } else if (strcmp(o, "--link") == 0) {
            link = v;
            i++;
        } else if (strcmp(o, "--seconds") == 0 && parse_uint(v, 1000000, &seconds) == 0) {
            i++;
        } else {
            fprintf(stderr, "%s %s: unknown option or bad value; see --help\n", o, v);
            return 2;
        }
    }

    if (downlink_can != (can_hub != NULL)) {
        fprintf(stderr, "--downlink can and --can-hub PATH go together; see --help\n");
        return 2;
    }
    if (downlink_rs485 != (rs485_hub != NULL)) {
        fprintf(stderr, "--downlink rs485 and --rs485-hub PATH go together; see --help\n");
        return 2;
    }
    if ((downlink_can || downlink_rs485) && (n_specs > 0)) {
        fprintf(stderr, "--downlink %s takes no --node: the nodes are urb-node-hosted processes on the hub; "
                        "see --help\n", downlink_can ? "can" : "rs485");
        return 2;
    }
    mcfg.bitrate_kbps = (uint16_t)khz;
    mcfg.timeout_us = urb_i2c_master_timeout_us((uint32_t)khz); /* a slower bus needs longer */
    if (urb_hosted_rig_init(&rig, &cfg, &mcfg) != URB_OK) {
        fprintf(stderr, "bridge configuration refused\n");
        return 2;
    }
    /* 9 bits per byte with its ACK; a START or STOP takes about a bit time */
    rig.bus.byte_us = (uint32_t)((9000u + khz - 1u) / khz);
    rig.bus.start_us = (uint32_t)((1000u + khz - 1u) / khz);
    for (int i = 0; i < n_specs; i++) {
        if (add_node_spec(&rig.bus, specs[i]) != 0) {
            return 2;
        }
    }

    int master = posix_openpt(O_RDWR | O_NOCTTY);
    if ((master < 0) || (grantpt(master) != 0) || (unlockpt(master) != 0)) {
        perror("posix_openpt");
        return 1;
    }
    const char *slave_name = ptsname(master);
    if (slave_name == NULL) {
        perror("ptsname");
        return 1;
    }
    char slave_path[256];
    snprintf(slave_path, sizeof slave_path, "%s", slave_name);
    /* Keep a slave descriptor open in raw mode: no echo or line editing before the host sets its
     * own mode, and reads on the master never fail with EIO while the host reopens the port. */
    int slave = open(slave_path, O_RDWR | O_NOCTTY);
    struct termios tio;
    if ((slave < 0) || (tcgetattr(slave, &tio) != 0)) {
        perror("open pty slave");
        return 1;
    }
    cfmakeraw(&tio);
    tcsetattr(slave, TCSANOW, &tio);
    fcntl(master, F_SETFL, fcntl(master, F_GETFL) | O_NONBLOCK);
    if (link != NULL) {
        unlink(link);
        if (symlink(slave_path, link) != 0) {
            perror("--link");
            return 1;
        }
    }
    signal(SIGINT, on_signal);
    signal(SIGTERM, on_signal);
    signal(SIGPIPE, SIG_IGN);
    printf("pty: %s\n", slave_path);
    fflush(stdout);
    if (downlink_can || downlink_rs485) {
        int const rc = downlink_can
                           ? urb_hosted_can_run(&cfg, master, can_hub, (uint32_t)can_timeout_us, seconds, &g_stop, verbose)
                           : urb_hosted_rs485_run(&cfg, master, rs485_hub, (uint32_t)rs485_baud, seconds, &g_stop, verbose);
        if (link != NULL) {
            unlink(link);
        }
        close(slave);
        close(master);
        return rc;
    }

    /* Virtual time: the bridge, its bus and its heartbeat run on a clock that follows the wall
     * clock in steps of at most STEP_US. If the process is descheduled, the clock catches up step
     * by step afterwards, every bus event at its own virtual time, so a transaction never sees a
     * timeout it would not see on a microcontroller (which is never descheduled). */
    enum { STEP_US = 5, MAX_LAG_US = 1000000 };
    uint64_t const t0 = mono_us();
    uint64_t vt = 0;
    while (!g_stop) {
        uint64_t const wall = mono_us() - t0;
        if ((seconds != 0) && (wall >= (uint64_t)seconds * 1000000u)) {
            break;
        }
        if (wall > vt + MAX_LAG_US) {
            vt = wall - MAX_LAG_US; /* stopped for a long time (SIGSTOP, debugger): skip ahead */
        }
        while (vt < wall) {
            uint64_t const step = (wall - vt < STEP_US) ? (wall - vt) : STEP_US;
            vt += step;
            rig.hal.now = (uint32_t)vt;
            urb_hosted_rig_iterate(&rig);
        }
        uint8_t in[256];
        ssize_t got = read(master, in, sizeof in);
        for (ssize_t k = 0; k < got; k++) {
            urb_bridge_uart_rx(&rig.bridge, in[k], rig.hal.now);
        }
        urb_hosted_rig_iterate(&rig);
        if (rig.hal.tx_len > 0) {
            ssize_t put = write(master, rig.hal.tx, rig.hal.tx_len);
            if (put > 0) {
                memmove(rig.hal.tx, rig.hal.tx + put, rig.hal.tx_len - (size_t)put);
                rig.hal.tx_len -= (size_t)put;
            }
        }
        bool const busy = !urb_bridge_idle(&rig.bridge) || rig.bus.ev_pending || (rig.hal.tx_len > 0) || (got > 0);
        if (!busy) {
            /* nothing to do until a byte arrives or the next heartbeat tick (at most 1 ms) */
            uint32_t wait_us = 1000u;
            if ((rig.hal.hb_period != 0u) && ((int32_t)(rig.hal.hb_next - rig.hal.now) < (int32_t)wait_us)) {
                int32_t const d = (int32_t)(rig.hal.hb_next - rig.hal.now);
                wait_us = (d > 0) ? (uint32_t)d : 0u;
            }
            fd_set rd;
            FD_ZERO(&rd);
            FD_SET(master, &rd);
            struct timeval tv = {0, (suseconds_t)wait_us};
            (void)select(master + 1, &rd, NULL, NULL, &tv);
        }
    }
    if (link != NULL) {
        unlink(link);
    }
    if (verbose) {
        const urb_bridge_stats_t *s = urb_bridge_stats(&rig.bridge);
        fprintf(stderr,
                "bridge: %u bytes in, %u frames, %u responses, %u busy, %u hunted, %u partial dropped, "
                "%u syncs (%u missed), %u scans\n",
                s->rx_bytes, s->frames, s->responses, s->busy, s->hunt_discards, s->gap_drops, s->syncs,
                s->syncs_missed, s->scans);
    }
    close(slave);
    close(master);
    return 0;
}
