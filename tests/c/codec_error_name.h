/* The name of a codec error code (URB_ERR_SHORT is "short", ...) as the C test programs print it.
 *
 * Header only, for two builds: the codec driver (tests/c/codec_driver.c, host compilers with stdio
 * and sanitizers) and the QEMU test program (tests/qemu/qemu_main.c, Cortex-M0, no stdio, which adds
 * -Itests/c). One list, so a code added to the runtime is named in both or in neither. */

#ifndef CODEC_ERROR_NAME_H
#define CODEC_ERROR_NAME_H

#include <stddef.h>
#include <stdint.h>

#include "urb_runtime.h"

/* The error's name; NULL for anything else: a byte count, or a code this runtime does not define. */
static inline const char *codec_error_name(int32_t rc)
{
    switch (rc) {
    case URB_ERR_SHORT: return "short";
    case URB_ERR_LONG: return "long";
    case URB_ERR_CHECKSUM: return "checksum";
    case URB_ERR_RANGE: return "range";
    case URB_ERR_CAPACITY: return "capacity";
    case URB_ERR_ARGUMENT: return "argument";
    default: return NULL;
    }
}

#endif /* CODEC_ERROR_NAME_H */
