"""tools/rs485_hub.py: a half-duplex RS485 line between processes, in line time.

Python stations on the hub's socket (as the hosted bridge and nodes would be) check what the
firmware relies on: every station, the driver included, receives each character at its end with
that time stamp; a driver's characters are back to back (no silence inside a frame); the first
one starts after the driver-enable delay; a wake-up comes at the time asked and the line time
never advances while a station has not acknowledged (a slow station cannot break a silence);
two drivers at once are garbage for everyone; a frame started less than t3.5 after the line's last
character is counted; bad stations are told why and dropped. Seeded hub bugs (no echo to the
driver, a gap between characters, the last driver wins a collision, the silence measured from a
character's start, time advancing without acknowledgements) are each shown to fail the check; the
witness is the hub's counters and the events seen.
"""

from __future__ import annotations

import socket
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
import tempfile

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "tools"))
import rs485_hub as hub_mod  # noqa: E402
from rs485_hub import DRIVE, HELLO, MESSAGE, RX, SLOT, STATUS, WAKE, Char, Rs485Hub, Station, garbage  # noqa: E402


class NoEcho(Rs485Hub):
    """Seeded bug: the driver does not hear its own character (the bridge's echo check goes blind)."""

    def _send(self, st: Station, flags: int, byte: int = 0) -> None:
        if flags & SLOT:
            flags &= ~RX
        super()._send(st, flags, byte)


class GapBetweenChars(Rs485Hub):
    """Seeded bug: a driver's next character starts two characters after its last one ended."""

    ends: dict[int, int] = {}

    def _start_char(self, st: Station, byte: int, start: int) -> None:
        if self.ends.get(id(st)) == start:
            start += 2 * self.char_us
        super()._start_char(st, byte, start)
        self.ends[id(st)] = start + self.char_us


class LastDriverWins(Rs485Hub):
    """Seeded bug: overlapping characters reach the stations as the later one (no collision seen)."""

    def _line_value(self, ending: list[Char]) -> int:
        return ending[-1].byte


class SilenceFromCharStart(Rs485Hub):
    """Seeded bug: the silence before a frame is measured from the last character's start."""

    def _step(self, at: int) -> None:
        super()._step(at)
        if self.last_end == at:
            self.last_end = at - self.char_us


class NoWaitForAck(Rs485Hub):
    """Seeded bug: the line time advances while a station has not acknowledged."""

    def serve_once(self, timeout_s: float = 0.01) -> None:
        self._poll_sockets(0.0)
        nxt = self.next_event()
        if nxt is not None:
            self._step(nxt)


@dataclass
class Event:
    flags: int
    byte: int
    time: int


@dataclass
class Sta:
    """A Python station: sends `script` when told to start, acknowledges every event."""

    sock: socket.socket
    script: list[int] = field(default_factory=list)
    events: list[Event] = field(default_factory=list)
    seq: int = 0
    now: int = 0
    ack_events: bool = True
    wake: int | None = None
    start_on_rx: list[int] = field(default_factory=list)  # drive these when the first byte is heard

    def send(self, flags: int, byte: int = 0, value: int = 0) -> None:
        self.sock.send(MESSAGE.pack(flags, byte, self.seq, value))

    def status(self, drive: int | None) -> None:
        flags = STATUS | (DRIVE if drive is not None else 0) | (WAKE if self.wake is not None else 0)
        self.send(flags, drive or 0, self.wake or 0)

    def start(self, script: list[int]) -> None:
        """Starts driving now (spontaneously, as the bridge after a host command)."""
        self.script = list(script)
        self.status(self.script.pop(0))

    def handle(self) -> None:
        while True:
            try:
                raw = self.sock.recv(64)
            except BlockingIOError:
                return
            if not raw:
                return
            flags, byte, seq, t = MESSAGE.unpack(raw)
            self.seq, self.now = seq, t
            if self.wake is not None and t >= self.wake:
                self.wake = None
            self.events.append(Event(flags, byte, t))
            if not self.ack_events:
                continue
            drive = self.script.pop(0) if flags & SLOT and self.script else None
            if flags & RX and self.start_on_rx:
                drive, *self.script = self.start_on_rx
                self.start_on_rx = []
            self.status(drive)

    def received(self) -> list[tuple[int, int]]:
        return [(e.byte, e.time) for e in self.events if e.flags & RX]


def join(path: Path, baud: int = 1_000_000) -> Sta:
    s = socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET)
    s.connect(str(path))
    s.setblocking(False)
    st = Sta(s)
    st.send(HELLO, 0, baud)
    return st


def run(hub: Rs485Hub, stations: list[Sta], rounds: int = 300) -> None:
    for _ in range(rounds):
        hub.serve_once(0.0005)
        for s in stations:
            s.handle()


@pytest.fixture
def sock() -> Iterator[Path]:
    with tempfile.TemporaryDirectory(prefix="urb485") as d:  # a Unix socket path has at most 107 bytes
        yield Path(d) / "line.sock"


def three(hub_class: type[Rs485Hub], sock: Path, **kw: int | float) -> tuple[Rs485Hub, list[Sta]]:
    hub = hub_class(sock, **kw)  # type: ignore[arg-type]
    stations = [join(sock) for _ in range(3)]
    run(hub, stations, 30)
    assert len(hub.stations) == 3 and all(s.events and s.events[0].flags == hub_mod.WELCOME for s in stations)
    return hub, stations


def frame_check(hub_class: type[Rs485Hub], sock: Path) -> None:
    """Station 0 sends three bytes: everyone receives them back to back, the driver as its echo."""
    hub, (a, b, c) = three(hub_class, sock)
    try:
        t0 = a.now
        a.start([0x01, 0x02, 0x03])
        run(hub, [a, b, c])
        want = [(0x01, t0 + 10), (0x02, t0 + 20), (0x03, t0 + 30)]
        assert b.received() == want and c.received() == want
        assert a.received() == want  # the echo
        assert [e.time for e in a.events if e.flags & SLOT] == [t0 + 10, t0 + 20, t0 + 30]
        assert hub.stats.chars == 3 and hub.stats.garbled == 0  # witness
    finally:
        hub.close()


def test_a_frame_reaches_every_station_back_to_back(sock: Path) -> None:
    frame_check(Rs485Hub, sock)


@pytest.mark.parametrize("mutant", [NoEcho, GapBetweenChars])
def test_seeded_delivery_bugs_are_caught(sock: Path, mutant: type[Rs485Hub]) -> None:
    with pytest.raises(AssertionError):
        frame_check(mutant, sock)


def test_driver_enable_delays_the_first_character_only(sock: Path) -> None:
    hub, (a, b, _c) = three(Rs485Hub, sock, driver_enable_us=7)
    try:
        t0 = a.now
        a.start([0x10, 0x11])
        run(hub, [a, b, _c])
        assert b.received() == [(0x10, t0 + 17), (0x11, t0 + 27)]
    finally:
        hub.close()


def wake_check(hub_class: type[Rs485Hub], sock: Path) -> None:
    """A wake-up comes at the time asked; the line waits for a station that has not acknowledged."""
    hub, (a, b, c) = three(hub_class, sock)
    try:
        t0 = a.now
        b.wake = t0 + 35  # as a node asks for the end of a frame's silence
        b.status(None)
        c.ack_events = False  # c is descheduled: it will not acknowledge
        a.start([0x20, 0x21])
        run(hub, [a, b, c], 100)
        assert [e.time for e in a.events[1:]] == [t0 + 10]  # the line stopped at the first character
        assert hub.now == t0 + 10
        c.ack_events = True
        c.status(None)  # c catches up
        run(hub, [a, b, c])
        assert b.received() == [(0x20, t0 + 10), (0x21, t0 + 20)]
        assert [e.time for e in b.events if not e.flags & RX][-1] == t0 + 35  # woken at its time
        assert hub.now == t0 + 35
    finally:
        hub.close()


def test_wake_ups_and_acknowledgements_keep_line_time(sock: Path) -> None:
    wake_check(Rs485Hub, sock)


def test_seeded_time_bug_is_caught(sock: Path) -> None:
    with pytest.raises(AssertionError):
        wake_check(NoWaitForAck, sock)


def collision_check(hub_class: type[Rs485Hub], sock: Path) -> None:
    """Two drivers at once: everyone, both drivers included, receives a byte neither sent."""
    hub, (a, b, c) = three(hub_class, sock)
    try:
        t0 = a.now
        a.start([0x55])
        b.start([0x0F])
        run(hub, [a, b, c])
        got = {s.received()[0] for s in (a, b, c)}
        assert len(got) == 1
        byte, t = got.pop()
        assert t == t0 + 10 and byte not in (0x55, 0x0F)
        assert hub.stats.garbled >= 1  # witness
    finally:
        hub.close()


def test_collision_is_garbage_for_everyone(sock: Path) -> None:
    collision_check(Rs485Hub, sock)


def test_seeded_collision_bug_is_caught(sock: Path) -> None:
    with pytest.raises(AssertionError):
        collision_check(LastDriverWins, sock)


def test_a_start_inside_a_character_garbles_both(sock: Path) -> None:
    hub, (a, b, c) = three(Rs485Hub, sock, driver_enable_us=4)
    try:
        t0 = a.now
        b.start_on_rx = [0x31]  # b talks as soon as it hears a's first byte: 4 us into a's second
        a.start([0x30, 0x31])
        run(hub, [a, b, c])
        got = c.received()
        assert got[0] == (0x30, t0 + 14)  # a alone: [t0+4, t0+14)
        assert [t for _v, t in got[1:]] == [t0 + 24, t0 + 28]  # a's [t0+14, t0+24), b's [t0+18, t0+28)
        assert all(v != 0x31 for v, _t in got[1:])  # the same byte, shifted: garbage
    finally:
        hub.close()


def test_garbage_never_equals_a_driven_byte() -> None:
    for x in range(256):
        for y in range(256):
            if x != y:
                assert garbage([x, y]) not in (x, y)
    assert Char.__name__ == "Char"  # the model's character type is what the hub exports


def test_bad_stations_are_told_and_dropped(sock: Path, capsys: pytest.CaptureFixture[str]) -> None:
    hub = Rs485Hub(sock, settle_timeout_s=0.2)
    try:
        slow = join(sock, 115_200)
        short = join(sock)
        good = join(sock)
        run(hub, [slow, short, good], 20)
        short.sock.send(b"\x02\x00")
        run(hub, [slow, short, good], 20)
        err = capsys.readouterr().err
        assert "it runs at 115200 Bd, the line at 1000000 Bd" in err
        assert "a message is 8 bytes, it sent 2" in err
        assert hub.stations and len(hub.stations) == 1  # witness: the good one stays
        stopped = join(sock)
        run(hub, [good, stopped], 20)
        stopped.ack_events = False
        good.start([0x42])
        deadline = time.monotonic() + 5.0
        while len(hub.stations) > 1 and time.monotonic() < deadline:
            run(hub, [good, stopped], 10)
        assert "no acknowledgement within 0.2 s" in capsys.readouterr().err
        run(hub, [good])
        assert good.received() == [(0x42, good.received()[0][1])]  # the line went on without it
    finally:
        hub.close()


def silence_check(hub_class: type[Rs485Hub], sock: Path) -> None:
    """b answers a's frame 30 us after its end (under t3.5 = 35 us at 1 Mb/s), c 35 us after b's."""
    hub, (a, b, c) = three(hub_class, sock)
    try:
        t0 = a.now
        a.start([0x01, 0x02])  # ends at t0 + 20
        run(hub, [a, b, c], 60)
        b.wake = t0 + 50
        b.status(None)
        run(hub, [a, b, c], 60)
        assert b.now == t0 + 50
        b.start([0x81])  # [t0+50, t0+60): 30 us after a's last character
        run(hub, [a, b, c], 60)
        c.wake = t0 + 95
        c.status(None)
        run(hub, [a, b, c], 60)
        c.start([0x02])  # [t0+95, ...): 35 us after b's character
        run(hub, [a, b, c])
        assert [t for _v, t in a.received()] == [t0 + 10, t0 + 20, t0 + 60, t0 + 105]  # witness: all went out
        assert (hub.stats.frames, hub.stats.early_starts) == (3, 1)
    finally:
        hub.close()


def test_a_frame_started_within_t35_is_counted(sock: Path) -> None:
    silence_check(Rs485Hub, sock)


def test_seeded_silence_bug_is_caught(sock: Path) -> None:
    with pytest.raises(AssertionError):
        silence_check(SilenceFromCharStart, sock)
