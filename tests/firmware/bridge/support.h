/*
 * Shared helpers of the bridge tests: a hosted rig per test, request encoders, and a reader of the
 * response stream the bridge sent on an uplink.
 */
#ifndef URB_BRIDGE_TEST_SUPPORT_H
#define URB_BRIDGE_TEST_SUPPORT_H

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "bridge_hosted.h"
#include "urb_bridge.h"
#include "urb_core.h"

#define BYTE_US 87u /* one UART byte at 115200 Bd */

/** A rig with `fifo_depth` slots and heartbeat `hb_us` (0 = off), no nodes yet, not yet run. */
urb_hosted_rig_t *rig_new(uint8_t fifo_depth, uint16_t hb_us);

/** Frees a rig made by rig_new(). */
void rig_free(urb_hosted_rig_t *r);

/** Adds a node with outbox 1 of `out1` bytes and inbox 1 of `in1` bytes, echoing inbox 1 to outbox 1. */
urb_fake_node_t *add_node(urb_hosted_rig_t *r, uint8_t address, uint8_t class_id, uint8_t index, uint8_t in1,
                          uint8_t out1);

/** Runs the initial scan to its end (asserts it ends). */
void rig_start(urb_hosted_rig_t *r);

/** Encodes a read request; returns its length (4). */
size_t enc_read(uint8_t *buf, uint8_t address, uint8_t mailbox, uint8_t seq, uint8_t length);

/** Encodes a write request of `length` bytes of `data`; returns its length. */
size_t enc_write(uint8_t *buf, uint8_t address, uint8_t mailbox, uint8_t seq, uint8_t length, const uint8_t *data);

/** Sends a frame on RS232 back to back, then lets the line go idle (a gap of 1 ms). */
void send_frame(urb_hosted_rig_t *r, const uint8_t *frame, size_t n);

/** A reader of a response stream: position in the captured bytes. */
typedef struct {
    const uint8_t *bytes;
    size_t len;
    size_t pos;
} stream_t;

/** The RS232 stream the rig captured. */
stream_t rs232_stream(const urb_hosted_rig_t *r);

/** Takes the next response from *s and asserts its seq and status; `read_len` > 0 for an OK read
 *  (its data is copied to `data` when not NULL). */
void expect_response(stream_t *s, uint8_t seq, uint8_t status, uint8_t read_len, uint8_t *data);

/** Asserts that *s holds no more bytes. */
void expect_end(const stream_t *s);

/** Builds a USB batch (header frame + the given frames); returns its length. */
size_t usb_batch(uint8_t *out, uint16_t frame, const uint8_t *const *frames, const size_t *lens, uint8_t count);

/** Test groups, one per source file (main.c runs them all). */
int run_rs232_tests(void);
int run_fifo_tests(void);
int run_downlink_tests(void);
int run_usb_tests(void);
int run_sync_tests(void);
int run_discovery_tests(void);
int run_edges_tests(void);
int run_mutation_kill_tests(void);
int run_master_trace_tests(void);
int run_uplink_model_tests(void);
int run_usb_model_tests(void);
int run_fifo_model_tests(void);

#endif
