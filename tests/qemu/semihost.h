/*
 * ARM semihosting for the Cortex-M0 test program (BKPT 0xAB; QEMU with -semihosting-config
 * enable=on,target=native), and a small line formatter: no stdio, no heap.
 */
#ifndef SEMIHOST_H
#define SEMIHOST_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/** Writes a NUL-terminated string to the host's console (SYS_WRITE0). */
void sh_write0(const char *text);

/** Ends the emulation with `status` as QEMU's exit status (SYS_EXIT_EXTENDED, ApplicationExit). */
void sh_exit(uint32_t status) __attribute__((noreturn));

/** The command line (SYS_GET_CMDLINE: QEMU passes "<kernel> <-append text>"); false on failure. */
bool sh_cmdline(char *buf, size_t size);

/** A line of text under construction; appends past the end are dropped (the line ends in "..."). */
typedef struct {
    char buf[200];
    size_t len;
} sh_line_t;

void sh_clear(sh_line_t *line);
void sh_str(sh_line_t *line, const char *text);
void sh_dec(sh_line_t *line, int32_t value);
void sh_udec(sh_line_t *line, uint32_t value);
/** "0x" then `digits` hex digits. */
void sh_hex(sh_line_t *line, uint32_t value, unsigned digits);
/** Bytes as pairs of hex digits ("-" for none). */
void sh_bytes(sh_line_t *line, const uint8_t *data, size_t len);
/** Writes the line and a newline to the console, then clears it. */
void sh_flush(sh_line_t *line);

#endif /* SEMIHOST_H */
