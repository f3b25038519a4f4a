/* trace.c: NDJSON trace lines with a running FNV-1a hash. See trace.h. */
#include "trace.h"

#include <string.h>

void urbsim_trace_init(urbsim_trace_t *tr)
{
    tr->file = NULL;
    tr->mask = 0;
    tr->hash = 0xCBF29CE484222325ull;
    tr->lines = 0;
}

static const char *cat_name(uint32_t cat)
{
    switch (cat) {
    case URBSIM_TR_BUS: return "bus";
    case URBSIM_TR_FRAME: return "frame";
    case URBSIM_TR_BRIDGE: return "bridge";
    case URBSIM_TR_MAILBOX: return "mailbox";
    case URBSIM_TR_FAULT: return "fault";
    case URBSIM_TR_SYNC: return "sync";
    case URBSIM_TR_HOST: return "host";
    default: return "other";
    }
}

void urbsim_trace(urbsim_trace_t *tr, uint32_t cat, urbsim_ns_t now, const char *dev, const char *ev,
                  const char *rest, ...)
{
    if (!(tr->mask & cat)) {
        return;
    }
    char line[1100];
    int n = snprintf(line, 1024, "{\"t\":%llu,\"cat\":\"%s\",\"dev\":\"%s\",\"ev\":\"%s\"",
                     (unsigned long long)now, cat_name(cat), dev, ev);
    if (n < 0) {
        return;
    }
    size_t len = (size_t)n < 1024u ? (size_t)n : 1023u;
    if (rest && *rest) {
        va_list ap;
        va_start(ap, rest);
        int m = vsnprintf(line + len, 1024u - len, rest, ap);
        va_end(ap);
        if (m > 0) {
            len += (size_t)m < 1024u - len ? (size_t)m : 1023u - len;
        }
    }
    line[len++] = '}';
    line[len++] = '\n';
    for (size_t i = 0; i < len; i++) {
        tr->hash = (tr->hash ^ (uint8_t)line[i]) * 0x100000001B3ull;
    }
    tr->lines++;
    if (tr->file) {
        fwrite(line, 1, len, tr->file);
    }
}

void urbsim_hex(char *out, const uint8_t *data, size_t n)
{
    static const char digits[] = "0123456789abcdef";
    for (size_t i = 0; i < n; i++) {
        out[2 * i] = digits[data[i] >> 4];
        out[2 * i + 1] = digits[data[i] & 15u];
    }
    out[2 * n] = '\0';
}
