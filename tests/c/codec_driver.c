/*
 * codec_driver: drives the generated C codecs from another process (tests/test_c_codecs.py, and the
 * Python -> C -> Python round-trip tests), one command per line on stdin, one answer per line on
 * stdout (flushed after every answer).
 *
 * PROTOCOL (stable; extend it, do not change it)
 *
 *   <hex> is a byte string as pairs of hex digits (either case); a lone "-" is the empty string.
 *   <prefix> is the implicit prefix of a message (the bytes its implicit fields would occupy; see
 *   `implicit` in spec/schema/README.md), "-" for messages without implicit fields.
 *
 *   D <Message> <hex>                      decode the frame, then re-encode the decoded struct
 *   I <Message> <prefix> <hex>             as D, for a message with implicit fields: the implicit
 *                                          members are set from <prefix> before decoding
 *   C <Message> <capacity> <prefix> <hex>  decode the frame (it must be valid), then encode the
 *                                          struct into an output buffer of exactly <capacity> bytes
 *   K <crc> <hex>                          CRC tier <crc> (e.g. crc8_link_check) of the bytes:
 *                                          init, every byte, final
 *   L                                      list the message names the driver knows
 *
 *   Answers:
 *   OK <hex> <json>   D and I: the re-encoded frame, then the decoded struct as one line of JSON
 *                     without spaces: schema field names (implicit fields included, counted
 *                     payloads with their length field), ints as numbers, bools as true/false,
 *                     enums as their integer value, byte payloads as hex strings, arrays as lists
 *   OK <hex>          C: the encoded frame
 *   OK <crc>          K: the CRC in hex, width / 4 digits
 *   OK <names...>     L: every message name, space-separated
 *   ERR <error>       the codec returned short, long, checksum, range, capacity or argument
 *                     (for I, also when <prefix> holds no valid implicit value: ERR range)
 *   BAD <reason>      the command itself is malformed (unknown message, bad hex, wrong prefix size)
 *
 * The driver checks the codecs' memory contract on every call and aborts (the test sees a crashed
 * process) when it is broken: input frames and structs live in exact-size heap blocks (so the
 * sanitizers catch any read or write past them), output buffers sit between canary bytes, a
 * failing encode must leave its buffer untouched, decode must return exactly the frame length,
 * encode at most the capacity, and a successfully decoded struct must encode again. Build it with
 * -fsanitize=address,undefined -fno-sanitize-recover=all so undefined behaviour aborts too.
 */

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "codec_error_name.h"
#include "urb_test_support.h"

#define CANARY_SIZE 16u
#define UNTOUCHED 0x5Au /* what an output buffer holds before an encode call */
#define GARBAGE 0xA5u   /* what a struct holds before a decode call */
#define LINE_MAX_CHARS 4096

static void fatal(const char *what, const char *message)
{
    fprintf(stderr, "codec_driver: FATAL: %s: %s\n", message, what);
    fflush(stdout);
    abort();
}

static void *checked_malloc(size_t size)
{
    void *p = malloc(size > 0u ? size : 1u);
    if (p == NULL) {
        fatal("malloc", "out of memory");
    }
    return p;
}

/* ----- hex ----------------------------------------------------------------------------------- */

static int hex_digit(char c)
{
    if (c >= '0' && c <= '9') {
        return c - '0';
    }
    if (c >= 'a' && c <= 'f') {
        return c - 'a' + 10;
    }
    if (c >= 'A' && c <= 'F') {
        return c - 'A' + 10;
    }
    return -1;
}

/* Parses `text` into an exact-size heap block (so reads past the end are caught); false on bad hex. */
static bool parse_hex(const char *text, uint8_t **out, size_t *len)
{
    size_t n = strcmp(text, "-") == 0 ? 0u : strlen(text);
    if (n % 2u != 0u) {
        return false;
    }
    *len = n / 2u;
    *out = malloc(*len);
    if (*out == NULL && *len > 0u) {
        fatal("malloc", "out of memory");
    }
    for (size_t k = 0u; k < *len; k++) {
        int hi = hex_digit(text[2u * k]);
        int lo = hex_digit(text[2u * k + 1u]);
        if (hi < 0 || lo < 0) {
            free(*out);
            return false;
        }
        (*out)[k] = (uint8_t)(hi * 16 + lo);
    }
    return true;
}

static void print_hex(const uint8_t *data, size_t len)
{
    if (len == 0u) {
        fputc('-', stdout);
    }
    for (size_t k = 0u; k < len; k++) {
        printf("%02x", (unsigned)data[k]);
    }
}

/* ----- guarded encode ------------------------------------------------------------------------ */

static uint8_t canary(size_t k)
{
    return (uint8_t)(0xC3u ^ (k * 37u));
}

/* Encodes into a buffer of exactly `capacity` bytes between canaries; checks the output contract.
 * Returns the codec's result; on success the frame is copied to `frame` (max_size bytes). */
static int32_t guarded_encode(const urb_test_message_t *m, const void *msg, size_t capacity, uint8_t *frame)
{
    size_t const total = CANARY_SIZE + capacity + CANARY_SIZE;
    uint8_t *region = checked_malloc(total);
    for (size_t k = 0u; k < total; k++) {
        region[k] = (k < CANARY_SIZE || k >= CANARY_SIZE + capacity) ? canary(k) : UNTOUCHED;
    }
    int32_t const rc = m->encode(msg, region + CANARY_SIZE, capacity);
    for (size_t k = 0u; k < total; k++) {
        if ((k < CANARY_SIZE || k >= CANARY_SIZE + capacity) && region[k] != canary(k)) {
            fatal(m->name, "encode wrote outside its buffer (canary overwritten)");
        }
    }
    if (rc < 0) {
        if (codec_error_name(rc) == NULL) {
            fatal(m->name, "encode returned an unknown error code");
        }
        for (size_t k = 0u; k < capacity; k++) {
            if (region[CANARY_SIZE + k] != UNTOUCHED) {
                fatal(m->name, "encode failed but wrote to its buffer");
            }
        }
    } else if ((size_t)rc > capacity || (size_t)rc > m->max_size) {
        fatal(m->name, "encode returned more bytes than the capacity or the maximum size");
    } else {
        memcpy(frame, region + CANARY_SIZE, (size_t)rc);
    }
    free(region);
    return rc;
}

/* ----- commands ------------------------------------------------------------------------------ */

static const urb_test_message_t *find_message(const char *name)
{
    for (size_t k = 0u; k < urb_test_message_count; k++) {
        if (strcmp(urb_test_messages[k].name, name) == 0) {
            return &urb_test_messages[k];
        }
    }
    return NULL;
}

/* Decodes `frame_hex` (after setting the implicit members from `prefix_hex`) into a fresh struct.
 * Returns the struct, or NULL after printing the answer (ERR or BAD). */
static void *decode_command(const urb_test_message_t *m, const char *prefix_hex, const char *frame_hex)
{
    uint8_t *prefix = NULL;
    uint8_t *frame = NULL;
    size_t prefix_len = 0u;
    size_t frame_len = 0u;
    if (!parse_hex(prefix_hex, &prefix, &prefix_len) || !parse_hex(frame_hex, &frame, &frame_len)) {
        free(prefix);
        puts("BAD hex");
        return NULL;
    }
    void *msg = checked_malloc(m->struct_size);
    memset(msg, GARBAGE, m->struct_size);
    bool ok = false;
    if (prefix_len != m->implicit_size) {
        puts(m->implicit_size > 0u ? "BAD implicit prefix size (use I with the prefix)" : "BAD this message has no implicit prefix");
    } else {
        int32_t rc = m->set_implicit != NULL ? m->set_implicit(msg, prefix) : URB_OK;
        if (rc == URB_OK) {
            rc = m->decode(msg, frame, frame_len);
        }
        if (rc < 0) {
            if (codec_error_name(rc) == NULL) {
                fatal(m->name, "decode returned an unknown error code");
            }
            printf("ERR %s\n", codec_error_name(rc));
        } else if ((size_t)rc != frame_len) {
            fatal(m->name, "decode succeeded but did not return the frame length");
        } else {
            ok = true;
        }
    }
    free(prefix);
    free(frame);
    if (!ok) {
        free(msg);
        return NULL;
    }
    return msg;
}

static void command_decode(const urb_test_message_t *m, const char *prefix_hex, const char *frame_hex)
{
    void *msg = decode_command(m, prefix_hex, frame_hex);
    if (msg == NULL) {
        return;
    }
    uint8_t *frame = checked_malloc(m->max_size);
    int32_t const rc = guarded_encode(m, msg, m->max_size, frame);
    if (rc < 0) {
        fatal(m->name, "a successfully decoded struct does not encode again");
    }
    fputs("OK ", stdout);
    print_hex(frame, (size_t)rc);
    fputc(' ', stdout);
    m->print(stdout, msg);
    fputc('\n', stdout);
    free(frame);
    free(msg);
}

static void command_capacity(const urb_test_message_t *m, const char *capacity_text, const char *prefix_hex,
                             const char *frame_hex)
{
    char *end = NULL;
    unsigned long const capacity = strtoul(capacity_text, &end, 10);
    if (*capacity_text == '\0' || *end != '\0' || capacity > 4096u) {
        puts("BAD capacity");
        return;
    }
    void *msg = decode_command(m, prefix_hex, frame_hex);
    if (msg == NULL) {
        return;
    }
    uint8_t *frame = checked_malloc(m->max_size);
    int32_t const rc = guarded_encode(m, msg, (size_t)capacity, frame);
    if (rc < 0) {
        printf("ERR %s\n", codec_error_name(rc));
    } else {
        fputs("OK ", stdout);
        print_hex(frame, (size_t)rc);
        fputc('\n', stdout);
    }
    free(frame);
    free(msg);
}

static void command_crc(const char *name, const char *data_hex)
{
    const urb_test_crc_t *crc = NULL;
    for (size_t k = 0u; k < urb_test_crc_count; k++) {
        if (strcmp(urb_test_crcs[k].name, name) == 0) {
            crc = &urb_test_crcs[k];
        }
    }
    uint8_t *data = NULL;
    size_t len = 0u;
    if (crc == NULL) {
        puts("BAD unknown crc");
        return;
    }
    if (!parse_hex(data_hex, &data, &len)) {
        puts("BAD hex");
        return;
    }
    uint32_t const whole = crc->compute(data, len, false);
    if (crc->compute(data, len, true) != whole) {
        fatal(name, "byte-wise CRC differs from the buffer CRC");
    }
    printf("OK %0*lx\n", (int)(crc->width / 4u), (unsigned long)whole);
    free(data);
}

static void command_list(void)
{
    fputs("OK", stdout);
    for (size_t k = 0u; k < urb_test_message_count; k++) {
        printf(" %s", urb_test_messages[k].name);
    }
    fputc('\n', stdout);
}

static void run(char *line)
{
    char *argv[6];
    int argc = 0;
    for (char *tok = strtok(line, " \t\r\n"); tok != NULL; tok = strtok(NULL, " \t\r\n")) {
        if (argc == 6) {
            puts("BAD too many arguments");
            return;
        }
        argv[argc++] = tok;
    }
    if (argc == 0) {
        puts("BAD empty line");
        return;
    }
    if (strcmp(argv[0], "L") == 0 && argc == 1) {
        command_list();
        return;
    }
    if (strcmp(argv[0], "K") == 0 && argc == 3) {
        command_crc(argv[1], argv[2]);
        return;
    }
    const urb_test_message_t *m = argc > 1 ? find_message(argv[1]) : NULL;
    if (m == NULL) {
        puts(argc > 1 ? "BAD unknown message" : "BAD usage");
    } else if (strcmp(argv[0], "D") == 0 && argc == 3) {
        command_decode(m, "-", argv[2]);
    } else if (strcmp(argv[0], "I") == 0 && argc == 4) {
        command_decode(m, argv[2], argv[3]);
    } else if (strcmp(argv[0], "C") == 0 && argc == 5) {
        command_capacity(m, argv[2], argv[3], argv[4]);
    } else {
        puts("BAD usage");
    }
}

int main(void)
{
    static char line[LINE_MAX_CHARS];
    while (fgets(line, sizeof line, stdin) != NULL) {
        if (strchr(line, '\n') == NULL && !feof(stdin)) {
            puts("BAD line too long");
            int c;
            while ((c = getchar()) != EOF && c != '\n') {
            }
        } else {
            run(line);
        }
        fflush(stdout);
    }
    return 0;
}
