"""Error flags and exceptions of the URB host library.

Two kinds of failure, kept apart on purpose:

* A *request* that fails is not an exception: its callback runs with `NodeRequest.flags` set to
  one `ErrorFlag` (the bridge's `Status` when the bridge answered, or a host-side flag when it
  did not). Callbacks check the flags and decide; URB never retransmits (paper, Sec. IV-C).
* A *setup* problem (no such port, no bridge answering, a node built from another schema, a node
  that was never discovered) raises a `URBError` subclass whose message says what happened and
  what to do next. The blocking conveniences (`NodeAccessor.read()` ...) raise `RequestFailed`.
"""

from __future__ import annotations

import enum

from urb_msgs.urb_core import Status


class ErrorFlag(enum.IntFlag):
    """Why a request failed; 0 (`ErrorFlag.NONE`) when it succeeded.

    The low bits mirror the bridge's `Status` codes one to one (bit ``1 << (status - 1)``); the
    high bits are decided on the host. A completed request has at most one bit set; the type is a
    flag so that callbacks can test groups (``req.flags & ErrorFlag.LINK``).
    """

    NONE = 0
    # --- answered by the bridge (urb_core.Status) ---
    TIMEOUT = 1 << 0
    """Bridge: the node did not complete the downlink transaction in time."""
    CHECKSUM = 1 << 1
    """Bridge: a downlink frame failed its check."""
    BUSY = 1 << 2
    """Bridge: its request FIFO was full; the request was not executed."""
    NO_NODE = 1 << 3
    """Bridge: no node acknowledged the address (unplugged, powered off)."""
    SIZE_MISMATCH = 1 << 4
    """Bridge: the length differs from the size the node reported."""
    BAD_REQUEST = 1 << 5
    """Bridge: mailbox, length or address out of range."""
    BUS_STUCK = 1 << 6
    """Bridge: the downlink was stuck and was cleared; the request was not executed."""
    NODE_BUSY = 1 << 7
    """Bridge: both buffers of the inbox were in use; the write was refused."""
    # --- decided on the host ---
    UPLINK_CHECKSUM = 1 << 8
    """Host: the response arrived corrupted (failed its check) and was discarded."""
    UPLINK_TIMEOUT = 1 << 9
    """Host: no response arrived (the request or its response was lost on the uplink)."""
    BRIDGE_LOST = 1 << 10
    """Host: the bridge went away (port closed, device unplugged, silent) or its manager was closed;
    see `BusManager.reconnect`. `NodeRequest.error` names the manager's reason."""
    UNKNOWN_NODE = 1 << 11
    """Host: the node is not in the discovery table (any more); nothing was sent."""
    HOST_SIZE_MISMATCH = 1 << 12
    """Host: the mailbox does not exist or has another size in the schema; nothing was sent."""
    FINGERPRINT_MISMATCH = 1 << 13
    """Host: the node was built from another schema; nothing was sent."""

    # groups (not outcomes)
    BRIDGE = TIMEOUT | CHECKSUM | BUSY | NO_NODE | SIZE_MISMATCH | BAD_REQUEST | BUS_STUCK | NODE_BUSY
    """Any error the bridge reported."""
    LINK = UPLINK_CHECKSUM | UPLINK_TIMEOUT | BRIDGE_LOST
    """Any uplink failure seen by the host."""
    REFUSED = UNKNOWN_NODE | HOST_SIZE_MISMATCH | FINGERPRINT_MISMATCH
    """Refused by the host before anything was sent."""
    WRITE_UNKNOWN = TIMEOUT | BUS_STUCK | LINK
    """After these, a write may or may not have been stored (Bridge.tla, WriteStatusTruthful)."""

    @classmethod
    def from_status(cls, status: Status) -> ErrorFlag:
        """The flag for a bridge status (`NONE` for OK)."""
        return cls.NONE if status == Status.OK else cls(1 << (int(status) - 1))

    def describe(self) -> str:
        """Human-readable names, e.g. ``NO_NODE`` or ``OK``."""
        if self == ErrorFlag.NONE:
            return "OK"
        return "|".join(m.name or "?" for m in ErrorFlag if m.value and m.value & (m.value - 1) == 0 and self & m)


HINTS: dict[ErrorFlag, str] = {
    ErrorFlag.TIMEOUT: "the node did not answer on its downlink in time; it may be overloaded or resetting",
    ErrorFlag.CHECKSUM: "a downlink frame was corrupted; check the node's bus wiring and pull-ups",
    ErrorFlag.BUSY: "the bridge FIFO was full; submit fewer requests at once",
    ErrorFlag.NO_NODE: "the node no longer acknowledges its address; check its connector and power, then rescan",
    ErrorFlag.SIZE_MISMATCH: "the bridge knows another size for this mailbox; rescan (the node may have been replaced)",
    ErrorFlag.BAD_REQUEST: "the bridge rejected the request header (mailbox or length out of range)",
    ErrorFlag.BUS_STUCK: "the downlink was stuck and has been cleared; the request was not executed",
    ErrorFlag.NODE_BUSY: "the node's inbox was busy (the application holds it); try again next cycle",
    ErrorFlag.UPLINK_CHECKSUM: "the response was corrupted on the uplink; check the cable and baud rate",
    ErrorFlag.UPLINK_TIMEOUT: "no response arrived; the request or response was lost on the uplink",
    ErrorFlag.BRIDGE_LOST: "the bridge went away (or its manager was closed); reconnect it and call reconnect() "
                           "(CLI: run the command again)",
    ErrorFlag.UNKNOWN_NODE: "the node is not in the discovery table; run discovery again",
    ErrorFlag.HOST_SIZE_MISMATCH: "the mailbox has another size (or does not exist) in the schema",
    ErrorFlag.FINGERPRINT_MISMATCH: "the node was built from another schema; rebuild its firmware or the host",
}


def hint(flags: ErrorFlag) -> str:
    """What a flag means and what to do about it."""
    for flag, text in HINTS.items():
        if flag in flags:
            return text
    return "the request succeeded" if flags == ErrorFlag.NONE else "unknown error"


class URBError(Exception):
    """Base of every exception the host library raises for an expected failure."""


class PortError(URBError):
    """The serial port (or other transport) could not be opened or used."""

    def __init__(self, message: str, detail: str | None = None) -> None:
        super().__init__(message)
        self.detail = detail if detail is not None else message
        """What went wrong with the port, without the advice to the library's caller."""


class NoBridgeError(URBError):
    """Nothing answered on the uplink like a URB bridge."""


class BridgeLostError(URBError):
    """The bridge went away while in use."""


class DiscoveryError(URBError):
    """Discovery could not complete."""


class NodeNotFoundError(URBError):
    """No discovered node has the requested class and index."""


class DuplicateNodeError(URBError):
    """Two or more discovered nodes have the same class and index (Discovery.tla: never merged)."""


class FingerprintMismatchError(URBError):
    """The node's layout fingerprint differs from the host's schema."""

    def __init__(self, message: str, *, node_fingerprint: int, schema_fingerprint: int, schema_file: str) -> None:
        super().__init__(message)
        self.node_fingerprint = node_fingerprint
        self.schema_fingerprint = schema_fingerprint
        self.schema_file = schema_file


class UnknownClassError(URBError):
    """A node reported a class the host's schema does not declare."""


class RequestFailed(URBError):
    """A blocking request completed with error flags (raised by the blocking conveniences)."""

    def __init__(self, message: str, flags: ErrorFlag) -> None:
        super().__init__(message)
        self.flags = flags
