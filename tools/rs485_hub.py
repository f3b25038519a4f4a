#!/usr/bin/env python3
"""An RS485 line for hosted URB programs: a half-duplex multi-drop bus between processes, in line time.

The RS485 firmware (firmware/downlink/rs485) cuts frames by silences of a few characters: 15 us
inside a frame and 35 us between frames at 1 Mb/s, and a node must begin its answer within 90 us.
Processes on a shared host are descheduled for milliseconds, so no wall-clock line between them
could keep those rules. This hub therefore owns the line's clock: every station (the hosted bridge
and each hosted node, firmware/hal/hosted/rs485_hub_client.c, or Python test code) connects to its
Unix socket, and the hub is a discrete-event simulation of one line whose time is told to the
stations with each event. A station reacts to an event in zero line time and says so (it
acknowledges); the hub advances the line time to the next event only when every station has
acknowledged, so a descheduled station delays the run but never breaks a silence. The line time
never runs ahead of the wall clock (from the hub's start), so periodic timers do not spin.

    .venv/bin/python tools/rs485_hub.py --socket build/rs485.sock [--baud 1000000] [--driver-enable-us 0]

The line: a station that drives puts one character (10 bit times, 8N1) on it at a time; the
character's stop bit is sampled by every station, the driver included (its echo), at the
character's end, and the driver then gets the next transmit slot (back to back: a frame has no gap
unless its driver leaves one). The first character after a station starts driving begins
--driver-enable-us after it asked (its driver-enable delay; the turnaround the bridge allows is
4 characters + 50 us). Two characters that overlap in time (two drivers) reach every station as
garbage: a byte that differs from each of them, so each driver's echo check sees the collision.
The hub counts the frames (bursts) a station starts less than t3.5 (3.5 characters) after the
line's last character ended, or over another's: the firmware's rule is never to (its exit line).

Wire format (SOCK_SEQPACKET, 8-byte messages, little-endian `<BBHI`: flags, byte, sequence, time):
  station -> hub  HELLO (flags 1, time = the station's baud rate): first message; a station at
                  another rate than the line is told so on stderr and disconnected.
                  STATUS (flags 2 | DRIVE 4 | WAKE 8): acknowledges the hub's message `sequence`
                  (the last one it handled); DRIVE: `byte` is its next character (when it got a
                  transmit slot, or to start driving now); no DRIVE after a slot releases the
                  driver; WAKE: wake it at line time `time` (replaces its earlier request).
  hub -> station  WELCOME (flags 1): the line time `time` at which it joined.
                  EVENT (flags 2 | RX 4 | SLOT 8): line time `time`; RX: `byte` was received at
                  `time`; SLOT: its character ended, give the next one. A station's due wake-up
                  comes as an EVENT without RX.
Time is in microseconds modulo 2**32 on the wire (the firmware's uint32_t stamps). A station that
does not acknowledge within --settle-timeout-s of wall time (stopped, hung) is disconnected with a
message on stderr, as is one that closes its socket: the line goes on without it.
"""

from __future__ import annotations

import argparse
import itertools
import os
import selectors
import signal
import socket
import struct
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

MESSAGE = struct.Struct("<BBHI")
HELLO = 0x01
STATUS = 0x02
DRIVE = 0x04
WAKE = 0x08
WELCOME = 0x01
EVENT = 0x02
RX = 0x04
SLOT = 0x08
CHAR_BITS = 10
MOD = 1 << 32


def char_us(baud: int) -> int:
    """One 8N1 character in whole microseconds, rounded up (urb_rs485_timing's char_us)."""
    return (CHAR_BITS * 1_000_000 + baud - 1) // baud


def t35_us(baud: int) -> int:
    """The silence that ends a frame: 3.5 characters (35 bit times) in whole microseconds, rounded
    up (urb_rs485_timing's t35_us)."""
    return (35 * 1_000_000 + baud - 1) // baud


def garbage(driven: list[int]) -> int:
    """What the stations receive when characters `driven` overlap: AND of them (the line's idle
    level is 1), else NOT of their OR, else the lowest byte none of them is; never any of them."""
    anded, ored = 0xFF, 0x00
    for b in driven:
        anded &= b
        ored |= b
    for g in itertools.chain((anded, ~ored & 0xFF), range(256)):
        if g not in driven:
            return g
    raise AssertionError("256 different bytes overlap")  # at most one character per station


@dataclass
class Char:
    """One character on the line: [start, end) in line time."""

    station: Station
    byte: int
    start: int
    end: int
    overlaps: list[Char] = field(default_factory=list)

    def received(self) -> int:
        """The byte the stations sample at its end."""
        if any(o.byte != self.byte or o.start != self.start for o in self.overlaps):
            return garbage([self.byte, *(o.byte for o in self.overlaps)])
        return self.byte


@dataclass(eq=False)
class Station:
    """One connected station."""

    sock: socket.socket
    number: int = 0          # in the order the stations connected, from 1 (for messages)
    joined: bool = False
    seq: int = 0             # last message sent to it
    acked: int = 0           # last message it acknowledged
    sent_at: float = 0.0     # wall time of the oldest unacknowledged message
    wake: int | None = None  # line time it asked to be woken at
    char: Char | None = None  # its character on the line
    slot: bool = False        # it was given a transmit slot and has not answered

    @property
    def settled(self) -> bool:
        return self.acked == self.seq


@dataclass
class HubStats:
    """What the line carried."""

    steps: int = 0
    chars: int = 0
    garbled: int = 0
    frames: int = 0          # bursts of characters a station started
    early_starts: int = 0    # of those, started less than t3.5 after the line's last character ended
    stations_seen: int = 0
    dropped: int = 0
    bad_messages: int = 0


@dataclass
class Rs485Hub:
    """The line: a listening Unix socket and the event loop. Call serve_once() in a loop."""

    socket_path: Path
    baud: int = 1_000_000
    driver_enable_us: int = 0
    settle_timeout_s: float = 10.0
    trace: bool = False
    stats: HubStats = field(default_factory=HubStats)

    def __post_init__(self) -> None:
        if not 1200 <= self.baud <= 4_000_000:
            raise ValueError(f"baud {self.baud} is outside 1200..4000000")
        self.char_us = char_us(self.baud)
        self.t35_us = t35_us(self.baud)
        self.now = 0  # line time, us (not wrapped)
        self.last_end: int | None = None  # end of the line's last character
        self.wall0 = time.monotonic()
        if self.socket_path.exists():
            self.socket_path.unlink()  # left by an earlier hub
        self.listener = socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        self.listener.bind(str(self.socket_path))
        self.listener.listen(16)
        self.listener.setblocking(False)
        self.selector = selectors.DefaultSelector()
        self.selector.register(self.listener, selectors.EVENT_READ)
        self.stations: list[Station] = []
        self.line: list[Char] = []  # characters not yet ended

    def wall_us(self) -> int:
        return int((time.monotonic() - self.wall0) * 1e6)

    # --- stations ---------------------------------------------------------------------------------
    def _send(self, st: Station, flags: int, byte: int = 0) -> None:
        if st.settled:
            st.sent_at = time.monotonic()
        st.seq = (st.seq + 1) & 0xFFFF
        try:
            st.sock.send(MESSAGE.pack(flags, byte, st.seq, self.now % MOD))
        except OSError:
            self._drop(st, "its socket is closed")

    def _drop(self, st: Station, why: str) -> None:
        if st not in self.stations:
            return
        self.stations.remove(st)
        self.selector.unregister(st.sock)
        st.sock.close()
        self.stats.dropped += 1  # a character of its in flight still ends on the line (the shift register)
        print(f"rs485_hub: station {st.number} left the line at {self.now} us: {why}", file=sys.stderr)

    def _start_char(self, st: Station, byte: int, start: int) -> None:
        ch = Char(st, byte, start, start + self.char_us)
        for other in self.line:
            if other.start < ch.end and ch.start < other.end:
                other.overlaps.append(ch)
                ch.overlaps.append(other)
        self.line.append(ch)
        st.char = ch

    def _start_frame(self, st: Station, byte: int, start: int) -> None:
        """A station starts driving: the firmware's rule is a line silent for t3.5 first."""
        self.stats.frames += 1
        if self.line or (self.last_end is not None and start - self.last_end < self.t35_us):
            self.stats.early_starts += 1
        self._start_char(st, byte, start)

    def _message(self, st: Station, raw: bytes) -> None:
        if len(raw) != MESSAGE.size:
            self.stats.bad_messages += 1
            self._drop(st, f"a message is {MESSAGE.size} bytes, it sent {len(raw)} (tools/rs485_hub.py)")
            return
        flags, byte, seq, value = MESSAGE.unpack(raw)
        if flags & HELLO:
            if value != self.baud:
                self._drop(st, f"it runs at {value} Bd, the line at {self.baud} Bd: give every station the hub's --baud "
                               "(urb-node-hosted-rs485 --baud, urb-bridge-hosted --rs485-baud)")
                return
            st.joined = True
            self._send(st, WELCOME)
            return
        if not st.joined or not flags & STATUS:
            self.stats.bad_messages += 1
            self._drop(st, f"message flags 0x{flags:02x} before HELLO or without STATUS")
            return
        st.acked = seq
        answers_slot = st.slot and st.settled
        if answers_slot:
            st.slot = False
        st.wake = None
        if flags & WAKE:
            delta = (value - self.now) % MOD
            st.wake = self.now + (delta if delta < MOD // 2 else 0)  # a time already past: now
        if flags & DRIVE:
            if answers_slot:
                self._start_char(st, byte, self.now)  # back to back with its last character
            elif st.char is None and not st.slot:
                self._start_frame(st, byte, self.now + self.driver_enable_us)
            else:
                self.stats.bad_messages += 1
                self._drop(st, "it drove a character while its last one was on the line")

    def _readable(self, st: Station) -> None:
        try:
            raw = st.sock.recv(64)
        except (BlockingIOError, InterruptedError):
            return
        except OSError as e:
            self._drop(st, str(e))
            return
        if not raw:
            self._drop(st, "it closed its socket")
            return
        self._message(st, raw)

    def _poll_sockets(self, timeout_s: float) -> None:
        for key, _ in self.selector.select(max(timeout_s, 0.0)):
            if key.fileobj is self.listener:
                c, _addr = self.listener.accept()
                c.setblocking(False)
                self.stats.stations_seen += 1
                st = Station(c, self.stats.stations_seen)
                self.stations.append(st)
                self.selector.register(c, selectors.EVENT_READ, st)
            else:
                self._readable(key.data)

    # --- the line's clock -----------------------------------------------------------------------
    def next_event(self) -> int | None:
        """Line time of the next event: a character's end or a wake-up; None when there is none."""
        times = [c.end for c in self.line] + [s.wake for s in self.stations if s.wake is not None]
        return min(times) if times else None

    def _line_value(self, ending: list[Char]) -> int:
        """What the stations sample when characters `ending` end together (one unless they collided)."""
        values = [c.received() for c in ending]
        return values[0] if len(set(values)) == 1 else garbage(values)

    def _step(self, at: int) -> None:
        self.now = at
        self.stats.steps += 1
        ending = [c for c in self.line if c.end == at]
        self.line = [c for c in self.line if c.end != at]
        if ending:
            self.last_end = at
        rx: int | None = None
        if ending:
            self.stats.chars += len(ending)
            rx = self._line_value(ending)
            if rx != ending[0].byte or len(ending) > 1:
                self.stats.garbled += 1
            if self.trace:
                sent = " ".join(f"{c.byte:02x}@{c.station.number}" for c in ending)
                print(f"{at:>10} us  {sent} -> {rx:02x}", file=sys.stderr)
        for st in list(self.stations):
            if not st.joined:
                continue
            flags = EVENT
            slot = st.char is not None and st.char.end == at
            if slot:
                st.char = None
                st.slot = True
                flags |= SLOT
            if rx is not None:
                flags |= RX
            due = st.wake is not None and st.wake <= at
            if due:
                st.wake = None
            if rx is not None or slot or due:
                self._send(st, flags, rx or 0)

    def serve_once(self, timeout_s: float = 0.01) -> None:
        """Takes messages; when every station has acknowledged, advances the line to its next event
        if the wall clock has reached it. Waits at most timeout_s."""
        waiting = [s for s in self.stations if not s.settled]
        if waiting:
            late = [s for s in waiting if time.monotonic() - s.sent_at > self.settle_timeout_s]
            for s in late:
                self._drop(s, f"no acknowledgement within {self.settle_timeout_s} s (stopped or hung)")
            self._poll_sockets(timeout_s if not late else 0.0)
            return
        nxt = self.next_event()
        if nxt is None:
            self._poll_sockets(timeout_s)
            return
        ahead_s = (nxt - self.wall_us()) / 1e6
        if ahead_s > 0:
            self._poll_sockets(min(ahead_s, timeout_s))
            return
        self._poll_sockets(0.0)  # a station may still start driving at this time
        if all(s.settled for s in self.stations) and self.next_event() == nxt:
            self._step(nxt)

    def close(self) -> None:
        """Disconnects the stations and removes the socket."""
        for st in list(self.stations):
            self.stations.remove(st)
            st.sock.close()
        self.selector.close()
        self.listener.close()
        if self.socket_path.exists():
            self.socket_path.unlink()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--socket", type=Path, required=True, help="Unix socket path the hosted programs connect to")
    ap.add_argument("--baud", type=int, default=1_000_000, help="line rate, every station's too (default 1000000)")
    ap.add_argument("--driver-enable-us", type=int, default=0,
                    help="delay from a station's first DRIVE to its character's start (default 0)")
    ap.add_argument("--settle-timeout-s", type=float, default=10.0,
                    help="wall seconds a station may take to acknowledge before it is disconnected (default 10)")
    ap.add_argument("--trace", action="store_true", help="print every character (end time, sent@station -> received) on stderr")
    args = ap.parse_args(argv)
    try:
        hub = Rs485Hub(args.socket, args.baud, args.driver_enable_us, args.settle_timeout_s, args.trace)
    except (OSError, ValueError) as e:
        print(f"rs485_hub: cannot open the line on {args.socket}: {e}", file=sys.stderr)
        return 1
    print(f"rs485_hub: {args.baud} Bd on {args.socket} (pid {os.getpid()})", flush=True)
    signal.signal(signal.SIGTERM, lambda _sig, _frame: sys.exit(0))
    t0, cpu0 = time.monotonic(), time.process_time()
    try:
        while True:
            hub.serve_once(0.05)
    except KeyboardInterrupt:
        pass
    finally:
        hub.close()
        st = hub.stats
        print(f"rs485_hub: line time {hub.now} us in {time.monotonic() - t0:.2f} s ({time.process_time() - cpu0:.2f} s CPU): "
              f"{st.steps} events, {st.chars} characters ({st.garbled} garbled), {st.frames} frames "
              f"({st.early_starts} started within t3.5), {st.stations_seen} stations ({st.dropped} dropped)",
              file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
