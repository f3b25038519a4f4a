"""The probe node: a test node with configurable mailbox sizes (firmware/hal/sim/sim_apps.c),
and the host-side schema entry that lets `URBInterface` discover and use it."""

from __future__ import annotations

import hashlib

from urb_msgs import Message, NodeInfo
from urb_msgs._runtime import MailboxInfo
from urb_msgs.urb_core import Command, Identification

PROBE_CLASS = 0x7E


def probe_fingerprint(out_size: int, in_size: int = 0) -> int:
    """A layout fingerprint for a probe with these sizes (any stable value the node reports)."""
    digest = hashlib.sha256(f"probe out={out_size} in={in_size}".encode()).digest()
    return int.from_bytes(digest[:4], "little") & 0x7FFFFFFF  # fits the C side's double exactly


def probe_info(out_size: int, in_size: int = 0) -> NodeInfo:
    """Schema entry for a probe node with outbox 1 of `out_size` bytes (and inbox 1 of `in_size`)."""
    boxes = [
        MailboxInfo("outbox", 0, Identification, Identification.SIZE, None, "Identification (urb_core)"),
        MailboxInfo("inbox", 0, Command, Command.SIZE, None, "Commands (urb_core)"),
        MailboxInfo("outbox", 1, Message, out_size, 1000.0, "Probe data: update counter, then a pattern"),
    ]
    if in_size:
        boxes.append(MailboxInfo("inbox", 1, Message, in_size, 1000.0, "Probe inbox"))
    return NodeInfo(
        name="Probe", kind="node", class_id=PROBE_CLASS, fingerprint=probe_fingerprint(out_size, in_size),
        doc="Simulation test node with configurable mailbox sizes", schema_file="sim/urb_sim/probe.py",
        layout=f"probe out={out_size} in={in_size}", mailboxes=tuple(boxes))
