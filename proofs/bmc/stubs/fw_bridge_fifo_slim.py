"""Proof view for fw_bridge_fifo: removes from a prepared copy of firmware/include/urb_bridge.h the
urb_bridge_t byte arrays that firmware/bridge/bridge.c never names (the UART rings, the USB batch
buffers, the RS232 assembler's bytes), so that ESBMC's accesses at a variable index inside the
bridge (a slot, a ring entry, node_of[a]) work on a 440-byte object instead of a 784-byte one.
Each removed member is found by its exact declaration line; a line that no longer matches is an
error (the view never goes stale silently), and if bridge.c ever names a removed member, the
proof fails to compile instead of proving less.
"""

from __future__ import annotations

import sys
from pathlib import Path

# Declaration lines (stripped) of the members removed; each must occur exactly once.
MEMBERS: tuple[str, ...] = (
    "volatile uint16_t rx_ring[URB_BRIDGE_RX_RING]; /* byte | URB_BRIDGE_RX_GAP */",
    "volatile uint8_t tx_ring[URB_BRIDGE_TX_RING];",
    "uint8_t usb_buf[2][URB_BRIDGE_USB_BUF];",
    "uint8_t buf[URB_BRIDGE_PARSE_BUF];",
)


def slim(text: str) -> str:
    lines = text.split("\n")
    for member in MEMBERS:
        hits = [i for i, line in enumerate(lines) if line.strip() == member]
        if len(hits) != 1:
            raise SystemExit(f"fw_bridge_fifo_slim.py: {member!r} found {len(hits)} times in urb_bridge.h "
                             "(expected once): update MEMBERS to the struct's current members")
        del lines[hits[0]]
    return "\n".join(lines)


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print("usage: fw_bridge_fifo_slim.py PREPARED/firmware/include/urb_bridge.h", file=sys.stderr)
        return 2
    path = Path(argv[1])
    text = path.read_text(encoding="utf-8")
    if "tx_ring[URB_BRIDGE_TX_RING]" in text:  # prepare copies afresh; a second run on a slimmed copy is a no-op
        path.write_text(slim(text), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
