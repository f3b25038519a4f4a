/*
 * Size probe for `make size-node`: compiled for the target, its two objects' sizes (read with nm)
 * are sizeof(urb_node_t) and the part of it that is mailbox-0 buffers.
 */
#include <stdint.h>

#include "urb_node.h"

urb_node_t urb_probe_node;
uint8_t urb_probe_mb0[sizeof(((urb_node_t *)0)->mb0)];
