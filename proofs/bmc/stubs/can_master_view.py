"""Proof view of urb_can_master_t (fw_can_master): the transfer-id table shrunk to the one node
address the harness talks to, and the master's arrays and frame moved out of the struct.

Why: ESBMC 8.4 turns a store at a variable index into an array inside a struct reached through a
pointer into a byte-level update of the WHOLE struct (as for urb_bridge_t, stubs/bridge_view.py).
The master's 64 x 16 table of next transfer ids (1 KiB) made every fast item run out of its 4 GiB
(proofs/README.md, "Downlink proofs"); with the table shrunk to 16 bytes but still inside the
struct, PART=2,OP=0,STEPS=3 still ran Boolector out of memory (3728 VCCs, 106 s of CPU), since a
store at the session index (or into the refusal byte at the reassembler's count) made the whole
master one bit-vector, so that even `m->op` was no longer a constant. In a prepared copy only:

  urb_can_master.h  the members next_tid, refusal, sync_payload and frame are removed; they become
                    the globals urb_view_next_tid[1][16] (the row of `urb_view_tid_address`, which
                    the harness defines and sets to its node's address before init),
                    urb_view_refusal[1], urb_view_sync_payload[1] and urb_view_frame (the frame
                    being queued, which the segmenter writes at its byte count), which the harness
                    defines: one master, so one set;
  urb_can_master.c  `m->refusal`, `m->sync_payload` and `m->frame` name the globals; every index X of the
                    table's first dimension becomes X - urb_view_tid_address, so that address is
                    row 0 and ANY other address is an index outside the table, which ESBMC's bounds
                    check fails (the view cannot hide an access to another row: such a proof
                    fails); init's loop over the 64 addresses runs over that address only (it writes
                    the whole shrunk table, as the original the whole table).

Each rewrite is found by its exact text or by the known index expressions; anything else is an
error (a view never goes stale silently), and a use of a removed member left over fails to compile.

    python3 can_master_view.py PREPARED/firmware
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import member_view

# the members removed from the struct (each line exactly once)
MEMBERS = ("    uint8_t next_tid[URB_CAN_LAST_ADDRESS + 1u][16];", "    uint8_t sync_payload[1];",
           "    uint8_t refusal[1];", "    urb_can_frame_t frame;")
INCLUDE = '#include "urb_downlink.h"\n'
DECLARATIONS = (
    "/* proof view (proofs/bmc/stubs/can_master_view.py): the one node address the table holds */\n"
    "extern uint8_t urb_view_tid_address;\n"
    "extern uint8_t urb_view_next_tid[1][16];\n"
    "extern uint8_t urb_view_refusal[1];\n"
    "extern uint8_t urb_view_sync_payload[1];\n"
    "extern urb_can_frame_t urb_view_frame;\n"
    "#define URB_VIEW_TID_ROW(a) ((int)(a) - (int)urb_view_tid_address)\n"
)
INIT_LOOP = "for (uint8_t a = 0u; a <= URB_CAN_LAST_ADDRESS; a++) {"
INIT_LOOP_VIEW = "for (uint8_t a = urb_view_tid_address; a == urb_view_tid_address; a++) {"
# The first-dimension index expressions urb_can_master.c uses today (init, next_tid(), begin()).
KNOWN_INDEXES = frozenset({"a", "address & URB_CAN_LAST_ADDRESS", "m->address"})
INDEX_RE = re.compile(r"m->next_tid\[([^\]]+)\]\[")
MOVED = (("m->refusal", "urb_view_refusal"), ("m->sync_payload", "urb_view_sync_payload"), ("m->frame", "urb_view_frame"))
MARKER = "URB_VIEW_TID_ROW"


def stale(what: str) -> SystemExit:
    return SystemExit(f"can_master_view.py: {what}: update the view to the master's current code")


def view_header(text: str) -> str:
    return member_view.remove_members(text, MEMBERS, INCLUDE, DECLARATIONS, "urb_can_master.h", stale)


def view_source(text: str) -> str:
    if text.count(INIT_LOOP) != 1:
        raise stale(f"init's loop {INIT_LOOP!r} not found once in urb_can_master.c")
    indexes = INDEX_RE.findall(text)
    unknown = sorted(set(indexes) - KNOWN_INDEXES)
    if unknown or not indexes:
        raise stale(f"next_tid indexed by {unknown or 'nothing'} in urb_can_master.c")
    text = member_view.rename_members(text, MOVED, "urb_can_master.c", stale)
    text = text.replace(INIT_LOOP, INIT_LOOP_VIEW)
    return INDEX_RE.sub(lambda m: f"urb_view_next_tid[{MARKER}({m.group(1)})][", text)


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print("usage: can_master_view.py PREPARED/firmware", file=sys.stderr)
        return 2
    root = Path(argv[1])
    header = root / "include" / "urb_can_master.h"
    source = root / "downlink" / "can" / "urb_can_master.c"
    member_view.rewrite_once(((header, view_header), (source, view_source)),
                             lambda text: MARKER in text or "urb_view_tid_address" in text)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
