/*
 * The USB bridges of bench/host_cpu_c.py: the bridge firmware compiled for the host (its hosted rig,
 * firmware/hal/hosted), one per descriptor given, each the far end of a SOCK_SEQPACKET pair that
 * stands for a kernel driver's character device (write = one bulk-OUT, read = one bulk-IN). Each
 * bridge holds three SensoRHex motor drivers on a 1-MHz I2C bus (Fast-mode Plus: the 400-kb/s bus of
 * the paper carries this load with 5 % to spare, which a model sharing a loaded machine with the
 * host does not keep; the host's work is the same); their virtual clock follows the wall clock. Every OUT
 * transfer is answered with the bridge's previous response buffer (write n, read n-1). A separate
 * process, so the host's CPU time counts the host library only.
 *
 *     host_cpu_c_bridges FD [FD ...]   prints "ready", then runs until every descriptor is closed
 *                                      by the other end
 */
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "bridge_hosted.h"
#include "urb_core.h"
#include "urb_sensorhex.h"

#define MAX_BRIDGES 4

static urb_hosted_rig_t rigs[MAX_BRIDGES]; /* program state: one rig per bridge */

static uint32_t mono_us(void)
{
    struct timespec ts;
    (void)clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint32_t)((uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u);
}

int main(int argc, char **argv)
{
    int const n = argc - 1;
    if ((n < 1) || (n > MAX_BRIDGES)) {
        (void)fprintf(stderr, "usage: host_cpu_c_bridges FD [FD ...] (1..%d)\n", MAX_BRIDGES);
        return 2;
    }
    struct pollfd fds[MAX_BRIDGES];
    for (int b = 0; b < n; b++) {
        fds[b].fd = atoi(argv[b + 1]);
        fds[b].events = POLLIN;
        urb_i2c_master_config_t mcfg;
        urb_i2c_master_default_config(&mcfg);
        mcfg.bitrate_kbps = 1000u;
        mcfg.timeout_us = urb_i2c_master_timeout_us(1000u);
        if (urb_hosted_rig_init(&rigs[b], NULL, &mcfg) != 0) {
            return 1;
        }
        rigs[b].bus.byte_us = 9u; /* 9 bits at 1 MHz, as hosted_main.c's --i2c-khz */
        rigs[b].bus.start_us = 1u;
        rigs[b].step_us = 5u;
        for (uint8_t k = 0u; k < 3u; k++) { /* MotorDriver:(3b + k) at 0x20 + k */
            urb_fake_node_t *node = urb_fake_i2c_add(&rigs[b].bus, (uint8_t)(0x20u + k), URB_NODE_MOTOR_DRIVER_CLASS,
                                                     (uint8_t)(3 * b + k));
            if (node == NULL) {
                return 1;
            }
            node->fingerprint = URB_NODE_MOTOR_DRIVER_FINGERPRINT;
            memcpy(node->in_size, urb_node_motor_driver_inbox_sizes, 8u);
            memcpy(node->out_size, urb_node_motor_driver_outbox_sizes, 8u);
            urb_fake_node_identify(node);
        }
        urb_hosted_rig_run(&rigs[b], 20000u); /* its scan at start */
    }
    (void)printf("ready\n"); /* the host may start: nothing it sends waits on our start-up */
    (void)fflush(stdout);
    uint32_t last = mono_us();
    uint32_t frame = last;
    int open = n;
    while (open > 0) {
        (void)poll(fds, (nfds_t)n, 1);
        uint32_t const now = mono_us();
        uint32_t step = now - last;
        last = now;
        bool const sof = (now - frame >= 1000u);
        if (sof) {
            frame = now;
        }
        for (int b = 0; b < n; b++) {
            if (fds[b].fd < 0) {
                continue;
            }
            urb_hosted_rig_run(&rigs[b], (step > 20000u) ? 20000u : step);
            if (sof) {
                urb_bridge_usb_sof(&rigs[b].bridge);
            }
            if ((fds[b].revents & (POLLIN | POLLHUP | POLLERR)) == 0) {
                continue;
            }
            uint8_t buf[URB_USB_BATCH_MAX_BYTES * 2u];
            ssize_t const got = read(fds[b].fd, buf, sizeof buf);
            if (got <= 0) {
                fds[b].fd = -1; /* the host closed its end */
                open--;
                continue;
            }
            (void)urb_bridge_usb_out(&rigs[b].bridge, buf, (size_t)got);
            size_t const back = urb_bridge_usb_in(&rigs[b].bridge, buf, sizeof buf);
            if (back > 0u) {
                (void)!write(fds[b].fd, buf, back);
            }
        }
    }
    return 0;
}
