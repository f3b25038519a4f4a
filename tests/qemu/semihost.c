/*
 * ARM semihosting (see semihost.h). Operations from the ARM "Semihosting for AArch32 and AArch64"
 * specification; on ARMv6-M/ARMv7-M the trap is BKPT 0xAB with the operation in r0, its argument
 * (a pointer to a parameter block) in r1 and the result in r0.
 */
#include "semihost.h"

#define SYS_WRITE0 0x04u
#define SYS_GET_CMDLINE 0x15u
#define SYS_EXIT_EXTENDED 0x20u
#define ADP_STOPPED_APPLICATION_EXIT 0x20026u

static uint32_t semihost(uint32_t op, const void *arg)
{
    register uint32_t r0 __asm__("r0") = op;
    register const void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xab" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

void sh_write0(const char *text)
{
    (void)semihost(SYS_WRITE0, text);
}

void sh_exit(uint32_t status)
{
    /* SYS_EXIT_EXTENDED carries the status (plain SYS_EXIT on AArch32 only says success or not) */
    uint32_t const block[2] = {ADP_STOPPED_APPLICATION_EXIT, status};
    (void)semihost(SYS_EXIT_EXTENDED, block);
    for (;;) { /* not reached under QEMU; a debugger would stop here */
    }
}

bool sh_cmdline(char *buf, size_t size)
{
    uint32_t block[2] = {(uint32_t)(uintptr_t)buf, (uint32_t)size};
    if (size == 0u || semihost(SYS_GET_CMDLINE, block) != 0u) {
        return false;
    }
    buf[size - 1u] = '\0';
    return true;
}

/* ----- line formatter ------------------------------------------------------------------------ */

static void put(sh_line_t *line, char c)
{
    if (line->len + 1u < sizeof line->buf) {
        line->buf[line->len++] = c;
    }
}

void sh_clear(sh_line_t *line)
{
    line->len = 0u;
}

void sh_str(sh_line_t *line, const char *text)
{
    /* bound: the line buffer (put drops what does not fit) or the string's end */
    for (; *text != '\0' && line->len + 1u < sizeof line->buf; text++) {
        put(line, *text);
    }
}

void sh_udec(sh_line_t *line, uint32_t value)
{
    char digits[10];
    unsigned n = 0u;
    do { /* bound: 10 digits */
        digits[n++] = (char)('0' + (char)(value % 10u));
        value /= 10u;
    } while (value != 0u);
    while (n > 0u) {
        put(line, digits[--n]);
    }
}

void sh_dec(sh_line_t *line, int32_t value)
{
    if (value < 0) {
        put(line, '-');
        sh_udec(line, (uint32_t)0u - (uint32_t)value);
    } else {
        sh_udec(line, (uint32_t)value);
    }
}

static char hex_digit(uint32_t nibble)
{
    return "0123456789abcdef"[nibble & 0xFu];
}

void sh_hex(sh_line_t *line, uint32_t value, unsigned digits)
{
    sh_str(line, "0x");
    for (unsigned k = digits; k > 0u; k--) { /* bound: digits <= 8 */
        put(line, hex_digit(value >> (4u * (k - 1u))));
    }
}

void sh_bytes(sh_line_t *line, const uint8_t *data, size_t len)
{
    if (len == 0u) {
        put(line, '-');
    }
    for (size_t k = 0u; k < len; k++) { /* bound: len (frames <= 40 bytes) */
        put(line, hex_digit((uint32_t)data[k] >> 4u));
        put(line, hex_digit(data[k]));
    }
}

void sh_flush(sh_line_t *line)
{
    if (line->len + 1u >= sizeof line->buf) { /* truncated: say so */
        line->len = sizeof line->buf - 5u;
        sh_str(line, "...");
    }
    line->buf[line->len++] = '\n';
    line->buf[line->len] = '\0';
    sh_write0(line->buf);
    line->len = 0u;
}
