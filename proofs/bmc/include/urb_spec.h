/*
 * urb_spec.h: reference definitions the codec harnesses compare the generated C against.
 *
 * Written from spec/schema/README.md, not from the generated code, and deliberately in another
 * shape: bits are read and written one at a time (wire rule 1: bit k lives in bit k % 8 of byte
 * k / 8), and the CRC is the bit-serial LFSR (one message bit per step, MSB first) instead of the
 * byte-wise shift-and-xor loop of urb_runtime.c. These functions are not instrumented for cost.
 */
#ifndef URB_SPEC_H
#define URB_SPEC_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/** Bit k of a frame, LSB-first. */
static inline uint32_t spec_bit(const uint8_t *buf, size_t k)
{
    return ((uint32_t)buf[k / 8u] >> (k % 8u)) & 1u;
}

/* The bit loops below are written out (32 guarded steps) instead of `for` loops, so they need no
 * unwinding: the proof's --unwind bound then follows the frame length alone. */
#define SPEC_STEP4_(S, b) S(b) S((b) + 1u) S((b) + 2u) S((b) + 3u)
#define SPEC_STEP32_(S) SPEC_STEP4_(S, 0u) SPEC_STEP4_(S, 4u) SPEC_STEP4_(S, 8u) SPEC_STEP4_(S, 12u) \
    SPEC_STEP4_(S, 16u) SPEC_STEP4_(S, 20u) SPEC_STEP4_(S, 24u) SPEC_STEP4_(S, 28u)

/** The `width` (1..32) bits at bit `offset`, as an unsigned number, one bit at a time. */
static inline uint32_t spec_bits(const uint8_t *buf, size_t offset, unsigned width)
{
    uint32_t value = 0u;
#define SPEC_GET_(i) if ((i) < width) { value |= spec_bit(buf, offset + (i)) << (i); }
    SPEC_STEP32_(SPEC_GET_)
#undef SPEC_GET_
    return value;
}

/** Writes the low `width` (1..32) bits of `value` at bit `offset`, one bit at a time. */
static inline void spec_put_bits(uint8_t *buf, size_t offset, unsigned width, uint32_t value)
{
#define SPEC_PUT_(i)                                                                               \
    if ((i) < width) {                                                                             \
        size_t const k = offset + (i);                                                             \
        uint8_t const m = (uint8_t)(1u << (k % 8u));                                               \
        buf[k / 8u] = (((value >> (i)) & 1u) != 0u) ? (uint8_t)(buf[k / 8u] | m)                   \
                                                    : (uint8_t)(buf[k / 8u] & (uint8_t)~m);        \
    }
    SPEC_STEP32_(SPEC_PUT_)
#undef SPEC_PUT_
}

/** Low `width` (1..32) bits set. */
static inline uint32_t spec_mask(unsigned width)
{
    return (width >= 32u) ? 0xFFFFFFFFu : ((1u << width) - 1u);
}

/** buf[at .. at + size - 1] as a little-endian number (wire rule 2). */
static inline uint32_t spec_le(const uint8_t *buf, size_t at, unsigned size)
{
    uint32_t value = 0u;
    for (unsigned i = 0u; i < size; i++) {
        value += (uint32_t)buf[at + i] * (1u << (8u * i)); /* no shifts of the value: another shape */
    }
    return value;
}

/** The two's complement value of the low `width` (2..32) bits of `raw`. */
static inline int64_t spec_signed(uint32_t raw, unsigned width)
{
    int64_t const v = (int64_t)(raw & spec_mask(width));
    int64_t const half = (int64_t)1 << (width - 1u);
    return (v >= half) ? v - 2 * half : v;
}

/**
 * Feeds one byte into an MSB-first CRC register of `width` (8..32) bits with generator `poly`,
 * as the bit-serial LFSR: for each message bit, MSB first, the feedback is the register's top bit
 * xor the message bit; the register shifts left and takes the polynomial when the feedback is 1.
 */
static inline uint32_t spec_crc_byte(unsigned width, uint32_t poly, uint32_t reg, uint8_t byte)
{
    uint32_t const mask = spec_mask(width);
    for (unsigned i = 0u; i < 8u; i++) {
        uint32_t const in = ((uint32_t)byte >> (7u - i)) & 1u;
        uint32_t const feedback = ((reg >> (width - 1u)) & 1u) ^ in;
        reg = (reg << 1) & mask;
        if (feedback != 0u) {
            reg ^= poly;
        }
    }
    return reg & mask;
}

/** The register after feeding prefix[0 .. plen - 1] then data[0 .. len - 1] from `init`. */
static inline uint32_t spec_crc(unsigned width, uint32_t poly, uint32_t init, const uint8_t *prefix, size_t plen,
                                const uint8_t *data, size_t len)
{
    uint32_t reg = init;
    for (size_t i = 0u; i < plen; i++) {
        reg = spec_crc_byte(width, poly, reg, prefix[i]);
    }
    for (size_t i = 0u; i < len; i++) {
        reg = spec_crc_byte(width, poly, reg, data[i]);
    }
    return reg;
}

#endif /* URB_SPEC_H */
