"""Proof views of urb_bridge_t: remove from a prepared copy of firmware/include/urb_bridge.h the
members that the code under proof never names, so that ESBMC works on a smaller object (it copies
the whole bridge at every assignment to it and resolves an access at a variable index inside it over
the whole struct).

  uplink  (fw_bridge_rs232_parser, fw_bridge_usb_parser): the member groups
          firmware/bridge/bridge_uplink.c never names (downlink, heartbeat, response ring and slots)
  fifo    (fw_bridge_fifo): the byte arrays firmware/bridge/bridge.c never names (UART rings, USB
          batch buffers, the RS232 assembler's bytes): 784 -> 440 bytes

Each removed piece is found by its exact text; text that no longer matches is an error (a view never
goes stale silently), and a removed member that the code does name fails its compilation instead of
proving less.

    python3 bridge_view.py uplink|fifo PREPARED/firmware/include/urb_bridge.h
"""

from __future__ import annotations

import sys
from pathlib import Path

# uplink: (first line, line after the span) of each member group removed.
UPLINK_SPANS: tuple[tuple[str, str], ...] = (
    ("    urb_downlink_t dl;", "    /* UART receive ring: written by urb_bridge_uart_rx (ISR), read by poll. */"),
    ("    /* Heartbeat: ticks counted by the ISR, SYNCs sent counted by poll. */", "    /* Frame assemblers. */"),
    ("    /* Response ring (arrival order) and data slots (a FIFO inside it). */",
     "    /* USB: responses of the current frame, and of the previous one awaiting the IN transfer. */"),
)

# fifo: declaration lines (stripped) of the members removed; each must occur exactly once.
FIFO_MEMBERS: tuple[str, ...] = (
    "volatile uint16_t rx_ring[URB_BRIDGE_RX_RING]; /* byte | URB_BRIDGE_RX_GAP */",
    "volatile uint8_t tx_ring[URB_BRIDGE_TX_RING];",
    "uint8_t usb_buf[2][URB_BRIDGE_USB_BUF];",
    "uint8_t buf[URB_BRIDGE_PARSE_BUF];",
)


def stale(view: str, what: str) -> SystemExit:
    return SystemExit(f"bridge_view.py {view}: {what} in urb_bridge.h: update the view to the struct's current members")


def slim_uplink(text: str) -> str:
    for first, after in UPLINK_SPANS:
        start = text.find(first + "\n")
        end = text.find(after + "\n", start)
        if start < 0 or end < 0:
            raise stale("uplink", f"{first.strip()!r} ... {after.strip()!r} not found")
        text = text[:start] + text[end:]
    return text


def slim_fifo(text: str) -> str:
    lines = text.split("\n")
    for member in FIFO_MEMBERS:
        hits = [i for i, line in enumerate(lines) if line.strip() == member]
        if len(hits) != 1:
            raise stale("fifo", f"{member!r} found {len(hits)} times (expected once)")
        del lines[hits[0]]
    return "\n".join(lines)


# Each view and a member it removes: prepare copies afresh, so a second run on a slimmed copy is a no-op.
VIEWS = {"uplink": (slim_uplink, "urb_downlink_t dl;"), "fifo": (slim_fifo, "tx_ring[URB_BRIDGE_TX_RING]")}


def main(argv: list[str]) -> int:
    if len(argv) != 3 or argv[1] not in VIEWS:
        print(f"usage: bridge_view.py {'|'.join(VIEWS)} PREPARED/firmware/include/urb_bridge.h", file=sys.stderr)
        return 2
    slim, marker = VIEWS[argv[1]]
    path = Path(argv[2])
    text = path.read_text(encoding="utf-8")
    if marker in text:
        path.write_text(slim(text), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
