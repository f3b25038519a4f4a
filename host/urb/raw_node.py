"""Nodes the host's schema cannot describe, reached by bus address: their mailboxes as raw bytes.

A node whose class no bundled schema declares (a generic node, a prototype), or one built from
another schema (its layout fingerprint differs), still answers its identification with its
mailbox sizes. `raw_node_info` turns that identification into a `NodeInfo` whose every mailbox
holds a `RawMailbox`: the bytes, undecoded, of the size the node reported. The host library
then reads and writes it like any other node (`URBInterface.node_at`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Self

from urb_msgs import FieldInfo, MailboxInfo, Message, NodeInfo, TooLongError, TooShortError
from urb_msgs.urb_core import MAILBOXES, MAX_MAILBOX_SIZE, Identification

RAW_DOC = "not described by the host's schemas: the mailbox's bytes, undecoded"


@dataclass(slots=True)
class RawMailbox(Message):
    """The bytes of one mailbox, undecoded (1 to 32 of them)."""

    data: bytes = b""
    """The mailbox's bytes, as the node stores them"""

    NAME: ClassVar[str] = "RawMailbox"
    DOC: ClassVar[str] = "The bytes of one mailbox, undecoded"
    FINGERPRINT: ClassVar[int] = 0
    LAYOUT: ClassVar[str] = "raw bytes\n"
    MIN_SIZE: ClassVar[int] = 1
    MAX_SIZE: ClassVar[int] = MAX_MAILBOX_SIZE
    FIELDS: ClassVar[tuple[FieldInfo, ...]] = (
        FieldInfo("data", "bytes", "The mailbox's bytes, as the node stores them"),
    )

    def encode(self) -> bytes:
        """The bytes themselves."""
        return bytes(self.data)

    @classmethod
    def decode(cls, data: bytes | bytearray | memoryview) -> Self:
        """Any 1 to 32 bytes; TooShortError or TooLongError otherwise, TypeError for what is
        not bytes-like."""
        if not isinstance(data, (bytes, bytearray, memoryview)):
            raise TypeError(f"{cls.NAME}.decode takes bytes, not {type(data).__name__}")
        raw = bytes(data)
        if len(raw) < cls.MIN_SIZE:
            raise TooShortError(cls.NAME, f"{len(raw)} bytes, a mailbox holds at least {cls.MIN_SIZE}")
        if len(raw) > cls.MAX_SIZE:
            raise TooLongError(cls.NAME, f"{len(raw)} bytes, a mailbox holds at most {cls.MAX_SIZE}")
        return cls(data=raw)


def raw_node_info(ident: Identification, schema_file: str = "") -> NodeInfo:
    """A node type made from what the node says of itself: its class, its layout fingerprint,
    and one `RawMailbox` mailbox for every non-zero size it reports."""
    boxes = tuple(
        MailboxInfo(direction, number, RawMailbox, size, None, RAW_DOC)
        for direction, sizes in (("outbox", ident.outbox_sizes), ("inbox", ident.inbox_sizes))
        for number, size in enumerate(list(sizes)[:MAILBOXES])
        if 0 < size <= MAX_MAILBOX_SIZE)
    return NodeInfo(name=f"class 0x{ident.class_id:02x}", kind="node", class_id=ident.class_id,
                    fingerprint=ident.fingerprint, doc="a node the host's schemas do not describe",
                    schema_file=schema_file, layout="", mailboxes=boxes)


__all__ = ["RawMailbox", "raw_node_info"]
