"""Proof view for fw_bridge_rs232_parser and fw_bridge_usb_parser: removes from a prepared copy of
firmware/include/urb_bridge.h the urb_bridge_t members that firmware/bridge/bridge_uplink.c never
names, so ESBMC does not copy them at every assignment to the bridge. Each removed span is found by
its first and last line; a span that no longer matches is an error (the view never goes stale
silently), and a member the uplink code does name fails its compilation instead of vanishing.
"""

from __future__ import annotations

import sys
from pathlib import Path

# (first line, line after the span): member groups of urb_bridge_t the uplink code never names.
SPANS: tuple[tuple[str, str], ...] = (
    ("    urb_downlink_t dl;", "    /* UART receive ring: written by urb_bridge_uart_rx (ISR), read by poll. */"),
    ("    /* Heartbeat: ticks counted by the ISR, SYNCs sent counted by poll. */", "    /* Frame assemblers. */"),
    ("    /* Response ring (arrival order) and data slots (a FIFO inside it). */",
     "    /* USB: responses of the current frame, and of the previous one awaiting the IN transfer. */"),
)


def slim(text: str) -> str:
    for first, after in SPANS:
        start = text.find(first + "\n")
        end = text.find(after + "\n", start)
        if start < 0 or end < 0:
            raise SystemExit(f"fw_bridge_uplink_slim.py: {first.strip()!r} ... {after.strip()!r} not found in "
                             "urb_bridge.h: update SPANS to the struct's current members")
        text = text[:start] + text[end:]
    return text


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print("usage: fw_bridge_uplink_slim.py PREPARED/firmware/include/urb_bridge.h", file=sys.stderr)
        return 2
    path = Path(argv[1])
    text = path.read_text(encoding="utf-8")
    if "urb_downlink_t dl;" in text:  # prepare copies afresh; a second run on a slimmed copy is a no-op
        path.write_text(slim(text), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
