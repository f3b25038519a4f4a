/* native_host.h: the native host traffic model (see native_host.c). */
#ifndef URBSIM_NATIVE_HOST_H
#define URBSIM_NATIVE_HOST_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define NH_MAX_REQS 32u
#define NH_WINDOW 15u /* the 4-bit sequence number: at most 15 requests in flight (Bridge.tla) */

typedef struct {
    uint8_t address, mailbox, length;
    bool read;
    uint32_t every;   /* in loop cycles */
} nh_req_t;

typedef struct {
    uint8_t seq, length;
    bool read;
    uint64_t submitted;
} nh_pending_t;

typedef struct {
    int bridge;
    int usb;
    uint32_t period;        /* loop period in OS ticks */
    uint64_t tick, cycle;
    uint32_t seq;
    uint16_t frame;
    nh_req_t reqs[NH_MAX_REQS];
    uint32_t n_reqs;
    nh_pending_t pend[NH_WINDOW];
    uint32_t pend_head, pend_len;
    uint8_t rx[128];
    size_t rx_len;
    uint8_t held[512];      /* USB: the batch prepared at the previous tick, written at this one */
    size_t held_len;
    /* statistics */
    uint64_t sent, ok, failed, timeouts, skipped, resyncs;
    uint64_t lat_sum, lat_max, lat_min;
} nh_bridge_t;

void nh_init(nh_bridge_t *h, int bridge, int usb, uint32_t period_ticks);
int nh_add(nh_bridge_t *h, uint8_t address, uint8_t mailbox, bool read, uint8_t length, uint32_t every);
/** One OS tick: the frames to send now (RS232: frames back to back, their ends in frame_ends;
 *  USB: one batch with its header). Returns the byte count (0: nothing this tick). As with the
 *  host library, requests submitted at a tick go out at once over RS232 (the write thread is
 *  woken) and with the next tick's batch over USB (the write thread runs once per frame). */
size_t nh_cycle(nh_bridge_t *h, uint64_t now, uint8_t *out, size_t cap, size_t *frame_ends, uint32_t *n_frames);
/** Bytes from the bridge (RS232) or one IN batch (USB) reached the host at `now`. */
void nh_receive(nh_bridge_t *h, const uint8_t *data, size_t n, uint64_t now);
/** Requests pending longer than `timeout` ns fail. */
void nh_timeouts(nh_bridge_t *h, uint64_t now, uint64_t timeout);

#endif /* URBSIM_NATIVE_HOST_H */
