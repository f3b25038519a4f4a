/*
 * Error flags: names and hints, the Python library's ErrorFlag.describe() and hint()
 * (host/urb/errors.py), word for word.
 */
#include "urb_flags.h"

#include <stdbool.h>
#include <string.h>

#define FLAG_BITS 14u

static const char *const flag_names[FLAG_BITS] = {
    "TIMEOUT", "CHECKSUM", "BUSY", "NO_NODE", "SIZE_MISMATCH", "BAD_REQUEST", "BUS_STUCK", "NODE_BUSY",
    "UPLINK_CHECKSUM", "UPLINK_TIMEOUT", "BRIDGE_LOST", "UNKNOWN_NODE", "HOST_SIZE_MISMATCH",
    "FINGERPRINT_MISMATCH",
};

static const char *const flag_hints[FLAG_BITS] = {
    "the node did not answer on its downlink in time; it may be overloaded or resetting",
    "a downlink frame was corrupted; check the node's bus wiring and pull-ups",
    "the bridge FIFO was full; submit fewer requests at once",
    "the node no longer acknowledges its address; check its connector and power, then rescan",
    "the bridge knows another size for this mailbox; rescan (the node may have been replaced)",
    "the bridge rejected the request header (mailbox or length out of range)",
    "the downlink was stuck and has been cleared; the request was not executed",
    "the node's inbox was busy (the application holds it); try again next cycle",
    "the response was corrupted on the uplink; check the cable and baud rate",
    "no response arrived; the request or response was lost on the uplink",
    "the bridge went away (or its manager was closed); reconnect it and call reconnect() (CLI: run the command again)",
    "the node is not in the discovery table; run discovery again",
    "the mailbox has another size (or does not exist) in the schema",
    "the node was built from another schema; rebuild its firmware or the host",
};

const char *urb_host_error_name(int32_t code)
{
    switch (code) {
    case URB_HOST_OK: return "OK";
    case URB_HOST_EINVAL: return "EINVAL";
    case URB_HOST_EBUSY: return "EBUSY";
    case URB_HOST_ENOSPC: return "ENOSPC";
    case URB_HOST_EIO: return "EIO";
    case URB_HOST_ESTATE: return "ESTATE";
    case URB_HOST_ENOTFOUND: return "ENOTFOUND";
    default: return "?";
    }
}

urb_flags_t urb_flags_from_status(uint8_t status)
{
    if (status == 0u) {
        return URB_FLAG_NONE;
    }
    if (status > 8u) {
        return URB_FLAG_ALL + 1u;
    }
    return 1u << (status - 1u);
}

const char *urb_flag_name(urb_flags_t flag)
{
    if (flag == URB_FLAG_NONE) {
        return "OK";
    }
    for (uint32_t k = 0u; k < FLAG_BITS; k++) {
        if (flag == (1u << k)) {
            return flag_names[k];
        }
    }
    return NULL;
}

/* Appends "sep" and "name" to out[0 .. *len) when they fit in size bytes with the NUL. */
static bool append_name(char *out, size_t size, size_t *len, const char *sep, const char *name)
{
    size_t const a = strlen(sep);
    size_t const b = strlen(name);
    if (*len + a + b + 1u > size) {
        return false;
    }
    memcpy(out + *len, sep, a);
    memcpy(out + *len + a, name, b);
    *len += a + b;
    out[*len] = '\0';
    return true;
}

int32_t urb_flags_describe(urb_flags_t flags, char *out, size_t size)
{
    if ((out == NULL) || (size == 0u)) {
        return URB_HOST_EINVAL;
    }
    size_t len = 0u;
    out[0] = '\0';
    flags &= URB_FLAG_ALL;
    if (flags == URB_FLAG_NONE) {
        return append_name(out, size, &len, "", "OK") ? (int32_t)len : URB_HOST_ENOSPC;
    }
    for (uint32_t k = 0u; k < FLAG_BITS; k++) {
        if (((flags & (1u << k)) != 0u) && !append_name(out, size, &len, (len > 0u) ? "|" : "", flag_names[k])) {
            return URB_HOST_ENOSPC;
        }
    }
    return (int32_t)len;
}

const char *urb_flags_hint(urb_flags_t flags)
{
    if (flags == URB_FLAG_NONE) {
        return "the request succeeded";
    }
    for (uint32_t k = 0u; k < FLAG_BITS; k++) {
        if ((flags & (1u << k)) != 0u) {
            return flag_hints[k];
        }
    }
    return "unknown error";
}
