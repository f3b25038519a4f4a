/*
 * libFuzzer target: every generated C decoder on arbitrary bytes (tests/fuzz/README.md).
 *
 * Input: byte 0 picks the message (modulo the codec table of gen/c/test), then the implicit prefix
 * bytes when the message has one, then the frame. The frame is copied into a heap block of exactly
 * its length and the struct lives in a heap block of exactly its size, so AddressSanitizer reports
 * any read past the frame or write past the struct. When the decoder accepts the frame, the
 * encoder must reproduce it byte for byte (a decoder accepts only canonical frames), must refuse a
 * buffer one byte short, and decoding the re-encoded bytes must succeed again. A refusal is a
 * wire error, or the caller error URB_ERR_ARGUMENT for implicit members that break a schema rule,
 * which must not depend on the frame.
 */
/* lobster-trace: urb.MEM_001, urb.PKT_002 (the requirements this fuzz target verifies) */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz_require.h"
#include "urb_test_support.h"

static void check_message(const urb_test_message_t *m, const uint8_t *prefix, const uint8_t *bytes, size_t len)
{
    uint8_t *const frame = malloc(len > 0u ? len : 1u);
    void *const msg = malloc(m->struct_size);
    void *const again = malloc(m->struct_size);
    uint8_t *const out = malloc(m->max_size);
    REQUIRE(frame != NULL && msg != NULL && again != NULL && out != NULL);
    memcpy(frame, bytes, len);
    memset(msg, 0xA5, m->struct_size);
    memset(again, 0x5A, m->struct_size);

    /* Implicit members come from the caller and must be valid (a bool member cannot even hold
     * another value), so a prefix the schema rejects is not a decoder input. */
    if (m->set_implicit != NULL && m->set_implicit(msg, prefix) != URB_OK) {
        free(out);
        free(again);
        free(msg);
        free(frame);
        return;
    }
    if (m->set_implicit != NULL) {
        REQUIRE(m->set_implicit(again, prefix) == URB_OK);
    }
    int32_t const r = m->decode(msg, frame, len);
    if (r >= 0) {
        REQUIRE((size_t)r == len);
        REQUIRE(len <= m->max_size);
        int32_t const n = m->encode(msg, out, m->max_size);
        REQUIRE(n == r);
        REQUIRE(memcmp(out, frame, len) == 0);
        if (len > 0u) {
            REQUIRE(m->encode(msg, out, len - 1u) < 0);
        }
        REQUIRE(m->decode(again, out, (size_t)n) == n);
    } else if (r == URB_ERR_ARGUMENT) {
        /* Implicit members that break a schema rule are the caller's mistake, refused before the
         * frame is looked at (spec/schema/README.md, decode order): so whatever the frame, even
         * none, the answer is the same. */
        REQUIRE(m->set_implicit != NULL);
        REQUIRE(m->decode(again, frame, 0u) == URB_ERR_ARGUMENT);
    } else {
        REQUIRE(r == URB_ERR_SHORT || r == URB_ERR_LONG || r == URB_ERR_CHECKSUM || r == URB_ERR_RANGE);
    }
    free(out);
    free(again);
    free(msg);
    free(frame);
}

static void check_crcs(const uint8_t *bytes, size_t len)
{
    for (size_t i = 0u; i < urb_test_crc_count; i++) {
        REQUIRE(urb_test_crcs[i].compute(bytes, len, true) == urb_test_crcs[i].compute(bytes, len, false));
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size == 0u) {
        return 0;
    }
    const urb_test_message_t *const m = &urb_test_messages[data[0] % urb_test_message_count];
    size_t const head = 1u + m->implicit_size;
    if (size < head) {
        return 0;
    }
    check_message(m, data + 1u, data + head, size - head);
    check_crcs(data + 1u, size - 1u);
    return 0;
}
