"""Proof view of urb_can_slave_t (fw_can_slave): the queued frame and the refusal byte moved out
of the struct, as stubs/can_master_view.py does for the master (which says why: ESBMC 8.4 updates a
struct reached through a pointer byte by byte as a whole when an array inside it is stored at a
variable index, and the segmenter writes a frame's tail at its byte count).

In a prepared copy only: urb_can_slave.h loses the members `frame` and `answer`, declared instead
as the globals urb_view_slave_frame and urb_view_slave_answer[1] (the harness defines them: one
slave, so one set), and urb_can_slave.c names them for `s->frame` and `s->answer`. Each rewrite is
found by its exact text; anything else is an error (a view never goes stale silently), and a use of
a removed member left over fails to compile.

    python3 can_slave_view.py PREPARED/firmware
"""

from __future__ import annotations

import sys
from pathlib import Path

import member_view

MEMBERS = ("    urb_can_frame_t frame;", "    uint8_t answer[1];     /* a write's refusal byte */")
INCLUDE = '#include "urb_dl_slave.h"\n'
DECLARATIONS = (
    "/* proof view (proofs/bmc/stubs/can_slave_view.py): the slave's frame and refusal byte */\n"
    "extern urb_can_frame_t urb_view_slave_frame;\n"
    "extern uint8_t urb_view_slave_answer[1];\n"
)
MOVED = (("s->frame", "urb_view_slave_frame"), ("s->answer", "urb_view_slave_answer"))


def stale(what: str) -> SystemExit:
    return SystemExit(f"can_slave_view.py: {what}: update the view to the slave's current code")


def view_header(text: str) -> str:
    return member_view.remove_members(text, MEMBERS, INCLUDE, DECLARATIONS, "urb_can_slave.h", stale)


def view_source(text: str) -> str:
    return member_view.rename_members(text, MOVED, "urb_can_slave.c", stale)


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print("usage: can_slave_view.py PREPARED/firmware", file=sys.stderr)
        return 2
    root = Path(argv[1])
    member_view.rewrite_once(((root / "include" / "urb_can_slave.h", view_header),
                              (root / "downlink" / "can" / "urb_can_slave.c", view_source)),
                             lambda text: "urb_view_slave_" in text)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
