/*
 * Shared pieces of the uplink model tests (test_uplink_model.c: RS232; test_usb_model.c: USB and
 * the transmit ring): seeded random inputs, request framing as the schema states it, and the
 * comparison of what the bridge admitted with what a model admitted. Written for the mutation review
 * of the "uplink parsers" component (tests/mutation/README.md).
 */
#ifndef URB_BRIDGE_TEST_UPLINK_MODEL_H
#define URB_BRIDGE_TEST_UPLINK_MODEL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "bridge_hosted.h"
#include "urb_bridge.h"

#define MODEL_FRAMES 64u
#define IMPOSSIBLE (-1) /* request_len(): no request starts with these bytes */

/** The next number of the xorshift32 sequence in *s (the same seed gives the same inputs). */
uint32_t rnd(uint32_t *s);

/** A number in 0 .. n - 1. */
uint32_t below(uint32_t *s, uint32_t n);

/** The length of the request whose first n bytes are f[0..n): 0 while more bytes are needed to tell,
 *  IMPOSSIBLE for a write announcing more than 32 bytes (urb_core.h: a read is 4 bytes; a write is 3
 *  header bytes, its payload and the link check over them). */
int request_len(const uint8_t *f, size_t n);

/** True when the frame f[0..n) passes its check (it is then admitted, as a request or BAD_REQUEST). */
bool passes_check(const uint8_t *f, size_t n);

/** Requests a model admitted since the last comparison. */
typedef struct {
    uint8_t bytes[MODEL_FRAMES][URB_BRIDGE_FRAME_MAX];
    uint8_t len[MODEL_FRAMES];
    unsigned n;
} admitted_t;

/** Appends the frame f[0..n) to *a. */
void admit_frame(admitted_t *a, const uint8_t *f, size_t n);

/** Asserts that the bridge admitted exactly a's requests, in order, from `uplink`, then empties
 *  both (the bridge's queue too, so that it never answers BUSY for lack of serving). */
void expect_admitted(urb_bridge_t *b, admitted_t *a, uint8_t uplink);

/** A well-formed read or write to a node at 8..119; a 32-byte write when `longest`. Returns its length. */
size_t good_frame(uint32_t *s, uint8_t *f, bool longest);

/** A frame with a valid check over random header bytes: a request, or one breaking a schema rule. */
size_t sealed_frame(uint32_t *s, uint8_t *f);

/** A piece of a stream: a request, a sealed frame, a damaged or cut request, garbage, or the header
 *  of a write announcing more than 32 bytes. Returns its length (at most 37). */
size_t stream_piece(uint32_t *s, uint8_t *f);

/** Asserts the bridge's uplink counters equal *want (and no response slot overflowed). */
void expect_stats(const urb_bridge_t *b, const urb_bridge_stats_t *want);

/** A bridge on the rig's downlink initialised over random memory, with `hal`, `baud` and
 *  `idle_gap_us`, no heartbeat and no scan at start. Free it with free(). */
urb_bridge_t *bridge_over_garbage(uint32_t *s, urb_hosted_rig_t *r, const urb_bridge_hal_t *hal, uint32_t baud,
                                  uint32_t idle_gap_us);

#endif
