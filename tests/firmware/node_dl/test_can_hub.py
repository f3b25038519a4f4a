"""tools/can_hub.py: hosted programs on one python-can bus through the hub's Unix socket.

Two clients (as the hosted bridge and a hosted node would be) and a python-can `virtual` bus in
this process (as Python test code or, with --interface socketcan, a real bus): every frame reaches
every other party exactly once and in order, never its sender; a bad record is reported and
dropped without losing the next frame. Seeded bugs (a hub that does not put client frames on the
bus, one that echoes frames to their sender) are shown to fail the same check; the witness is the
hub's counters.
"""

from __future__ import annotations

import socket
import sys
from collections.abc import Iterator
from pathlib import Path

import can
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "tools"))
from can_hub import RECORD, CanHub, Frame, unpack  # noqa: E402


class NoBusForward(CanHub):
    """Seeded bug: client frames reach the other clients but not the python-can bus."""

    def _from_client(self, c: socket.socket) -> None:
        send = self.bus.send
        self.bus.send = lambda *a, **k: None  # type: ignore[method-assign]
        try:
            super()._from_client(c)
        finally:
            self.bus.send = send  # type: ignore[method-assign]


class EchoToSender(CanHub):
    """Seeded bug: a client gets its own frames back (a CAN controller does not receive them)."""

    def _to_clients(self, record: bytes, sender: socket.socket | None) -> None:
        super()._to_clients(record, None)


def client(path: Path) -> socket.socket:
    s = socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET)
    s.connect(str(path))
    s.settimeout(0.5)
    return s


def pump(hub: CanHub, n: int = 20) -> None:
    for _ in range(n):
        hub.serve_once(0.001)


def pending(s: socket.socket) -> list[Frame]:
    got = []
    s.settimeout(0.0)
    try:
        while True:
            got.append(unpack(s.recv(64)))
    except BlockingIOError:
        pass
    s.settimeout(0.5)
    return got


def exchange(hub_class: type[CanHub], tmp_path: Path, channel: str) -> None:
    """The hub contract; raises AssertionError when the hub breaks it."""
    hub = hub_class(tmp_path / "can.sock", "virtual", channel)
    probe = can.Bus(interface="virtual", channel=channel)
    try:
        a, b = client(hub.socket_path), client(hub.socket_path)
        pump(hub)
        assert hub.stats.clients_seen == 2
        requests = [Frame(0x123, bytes([1, 2, 3])), Frame(0x124, b""), Frame(0x1ABCDE, bytes(range(8)), True)]
        for f in requests:
            a.send(f.pack())
        pump(hub)
        assert pending(b) == requests, "the other client gets every frame, in order"
        assert pending(a) == [], "the sender never gets its own frames"
        seen = []
        while (m := probe.recv(timeout=0.05)) is not None:
            seen.append(Frame(m.arbitration_id, bytes(m.data), m.is_extended_id))
        assert seen == requests, "the python-can bus gets every client frame"
        probe.send(can.Message(arbitration_id=0x7FF, data=b"\x55", is_extended_id=False))
        pump(hub)
        assert pending(a) == [Frame(0x7FF, b"\x55")] and pending(b) == [Frame(0x7FF, b"\x55")]
        a.send(b"\x01\x02")  # not a record
        a.send(RECORD.pack(0x10, 9, bytes(8)))  # length over 8
        a.send(Frame(0x10, b"\x99").pack())
        pump(hub)
        assert hub.stats.bad_records == 2
        assert pending(b) == [Frame(0x10, b"\x99")], "a bad record loses nothing else"
        assert hub.stats.from_clients == 4 and hub.stats.from_bus == 1  # witness: both directions ran
        a.close()
        b.close()
    finally:
        probe.shutdown()
        hub.close()


@pytest.fixture
def short_tmp() -> Iterator[Path]:
    """A short directory: a Unix socket path has at most 107 bytes."""
    import tempfile

    with tempfile.TemporaryDirectory(prefix="canhub") as d:
        yield Path(d)


def test_hub_forwards_both_ways(short_tmp: Path) -> None:
    exchange(CanHub, short_tmp, "urb-hub-test")


@pytest.mark.parametrize("mutant", [NoBusForward, EchoToSender])
def test_seeded_hub_bugs_are_caught(short_tmp: Path, mutant: type[CanHub]) -> None:
    with pytest.raises(AssertionError):
        exchange(mutant, short_tmp, f"urb-hub-{mutant.__name__}")


def test_bad_records_say_what_is_wrong() -> None:
    with pytest.raises(ValueError, match="13 bytes"):
        unpack(b"\x00")
    with pytest.raises(ValueError, match="11 bits"):
        unpack(RECORD.pack(0x800, 0, bytes(8)))
    assert unpack(Frame(0x1FFFFFFF, b"\x01", True).pack()) == Frame(0x1FFFFFFF, b"\x01", True)
