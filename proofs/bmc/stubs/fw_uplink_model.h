/*
 * fw_uplink_model.h: what the uplink parser proofs (fw_bridge_rs232_parser, fw_bridge_usb_parser)
 * know of a request frame, written from the schema and not from the firmware: its length rule and
 * an abstract frame check.
 *
 * The check is abstracted: by data independence a parser must be right for every check function,
 * so the proofs use an arbitrary one (a key per length, fixed per run, folded with the covered
 * bytes) instead of the CRC: cheap for the solver, and a function of the whole candidate, so the
 * reference and the firmware see the same verdict for the same bytes.
 *
 * Include after defining FW_FRAME_WIDTH (the bytes a candidate copy holds) and declaring
 * `static const uint8_t *key;` (one arbitrary key per length: the harness's uninitialised local).
 */
#ifndef FW_UPLINK_MODEL_H
#define FW_UPLINK_MODEL_H

#include <stdbool.h>
#include <stdint.h>

#include "urb_core.h"
#include "urb_verify.h"

/* Returned by fw_request_len for a write whose length field no request can have. */
#define FW_NOT_A_REQUEST 0xFFu

/* Length of the request whose first byte is `first` and whose third (a write's length field) is
 * `length_field`: a read is 4 bytes, a write 3 + its length + 1 or 2 check bytes. */
static uint8_t fw_request_len(uint8_t first, uint8_t length_field)
{
    if ((first & 1u) != 0u) {
        return 4u; /* UplinkReadRequest */
    }
    if (length_field > 32u) {
        return FW_NOT_A_REQUEST;
    }
    return (uint8_t)(3u + length_field + ((3u + length_field <= URB_CRC8_LINK_CHECK_MAX_COVERED) ? 1u : 2u));
}

/* Length of the request starting at bytes[0] when `avail` (at least 1) bytes of it have arrived:
 * 0 when more are needed to tell, FW_NOT_A_REQUEST when no request starts like this. */
static uint8_t fw_request_need(const uint8_t *bytes, uint8_t avail)
{
    URB_ASSERT(avail >= 1u, "a request is measured from a byte that has arrived");
    if ((bytes[0] & 1u) != 0u) {
        return fw_request_len(bytes[0], 0u);
    }
    if (avail < 3u) {
        return 0u;
    }
    return fw_request_len(bytes[0], bytes[2]);
}

/* The strict decoders' verdict on a candidate of `len` bytes (a copy, FW_FRAME_WIDTH wide): the
 * length rule, then the last byte must be the fold of the key with the covered bytes. */
static bool fw_is_frame(const uint8_t *frame, uint8_t len)
{
    uint8_t want;
    if ((frame[0] & 1u) != 0u) {
        want = fw_request_len(frame[0], 0u);
    } else if (len < 3u) {
        return false;
    } else {
        want = fw_request_len(frame[0], frame[2]);
    }
    if (len != want) {
        return false; /* FW_NOT_A_REQUEST is no length */
    }
    uint8_t fold = key[len];
    for (uint8_t k = 0u; k < FW_FRAME_WIDTH; k++) {
        if ((uint8_t)(k + 1u) < len) {
            fold = (uint8_t)(fold ^ frame[k]);
        }
    }
    return frame[len - 1u] == fold;
}

#endif /* FW_UPLINK_MODEL_H */
