#!/usr/bin/env python3
"""A CAN hub for hosted URB programs: one python-can bus shared by processes over a Unix socket.

This machine kind's kernel has no SocketCAN (no vcan), and python-can's `virtual` interface
connects buses inside one process only. The hub is that one process: hosted programs (the C
bridge and nodes built for the host, or Python test code) connect to its Unix socket and exchange
classic CAN frames; the hub forwards every frame a client sends to every other client and onto
its python-can bus, and every frame from that bus to every client.

    .venv/bin/python tools/can_hub.py --socket build/can.sock                 # virtual bus (default)
    .venv/bin/python tools/can_hub.py --socket build/can.sock --interface socketcan --channel can0

`--interface socketcan` puts the hosted programs on a real CAN bus (set the bit rate with
`ip link set can0 up type can bitrate 1000000` first: SocketCAN owns it); `virtual` (the default)
lets Python code in this process, or a test that imports `CanHub`, see and inject the traffic on
channel `--channel` (default "urb").

Wire format on the socket (SOCK_SEQPACKET, one frame per message, 13 bytes): identifier as a
32-bit little-endian word (bit 31 set: 29-bit identifier), data length 0..8, then 8 data bytes
(unused ones zero). A message of another size or with a bad length or identifier is reported on
stderr and dropped; the client stays connected and nothing else is lost.

The hub orders frames by arrival: it models no arbitration, bit timing or errors (the simulation
does, sim/); it is for running the same programs over a CAN downlink, not for timing them.
"""

from __future__ import annotations

import argparse
import os
import selectors
import socket
import struct
import sys
from dataclasses import dataclass, field
from pathlib import Path

import can

RECORD = struct.Struct("<IB8s")
EXTENDED = 0x8000_0000
MAX_STD_ID = 0x7FF
MAX_EXT_ID = 0x1FFF_FFFF


@dataclass(frozen=True)
class Frame:
    """A classic CAN frame as the hub forwards it."""

    can_id: int
    data: bytes
    extended: bool = False

    def pack(self) -> bytes:
        """The frame's 13-byte record."""
        word = self.can_id | (EXTENDED if self.extended else 0)
        return RECORD.pack(word, len(self.data), self.data.ljust(8, b"\0"))


def unpack(record: bytes) -> Frame:
    """The frame in a 13-byte record; ValueError saying what is wrong with any other record."""
    if len(record) != RECORD.size:
        raise ValueError(f"a record is {RECORD.size} bytes, this one {len(record)}")
    word, length, data = RECORD.unpack(record)
    extended = bool(word & EXTENDED)
    can_id = word & ~EXTENDED
    if length > 8:
        raise ValueError(f"data length {length} is over 8 (classic CAN)")
    if can_id > (MAX_EXT_ID if extended else MAX_STD_ID):
        raise ValueError(f"identifier 0x{can_id:x} does not fit {'29' if extended else '11'} bits")
    return Frame(can_id, bytes(data[:length]), extended)


@dataclass
class HubStats:
    """What the hub forwarded and dropped."""

    from_clients: int = 0
    from_bus: int = 0
    bad_records: int = 0
    clients_seen: int = 0


@dataclass
class CanHub:
    """The hub: a listening Unix socket and a python-can bus. Call serve_once() in a loop."""

    socket_path: Path
    interface: str = "virtual"
    channel: str = "urb"
    stats: HubStats = field(default_factory=HubStats)

    def __post_init__(self) -> None:
        self.bus = can.Bus(interface=self.interface, channel=self.channel, receive_own_messages=False)
        if self.socket_path.exists():
            self.socket_path.unlink()
        self.listener = socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        self.listener.bind(str(self.socket_path))
        self.listener.listen(16)
        self.listener.setblocking(False)
        self.selector = selectors.DefaultSelector()
        self.selector.register(self.listener, selectors.EVENT_READ)
        self.clients: list[socket.socket] = []

    def _to_clients(self, record: bytes, sender: socket.socket | None) -> None:
        for c in list(self.clients):
            if c is sender:
                continue
            try:
                c.send(record)
            except (BlockingIOError, ConnectionError):
                self._drop(c)  # a client that cannot keep up or went away leaves the bus

    def _drop(self, c: socket.socket) -> None:
        if c in self.clients:
            self.clients.remove(c)
            self.selector.unregister(c)
            c.close()

    def _from_client(self, c: socket.socket) -> None:
        try:
            record = c.recv(64)
        except (BlockingIOError, ConnectionError):
            record = b""
        if not record:
            self._drop(c)
            return
        try:
            frame = unpack(record)
        except ValueError as e:
            self.stats.bad_records += 1
            print(f"can_hub: dropped a record from client {c.fileno()}: {e}; "
                  f"send {RECORD.size}-byte records (tools/can_hub.py)", file=sys.stderr)
            return
        self.stats.from_clients += 1
        self._to_clients(frame.pack(), c)
        self.bus.send(can.Message(arbitration_id=frame.can_id, data=frame.data, is_extended_id=frame.extended))

    def serve_once(self, timeout_s: float = 0.001) -> None:
        """Accepts clients, forwards what they sent, then what the bus received; waits at most
        timeout_s for a client to send."""
        for key, _ in self.selector.select(timeout_s):
            if key.fileobj is self.listener:
                c, _addr = self.listener.accept()
                c.setblocking(False)
                self.clients.append(c)
                self.selector.register(c, selectors.EVENT_READ)
                self.stats.clients_seen += 1
            else:
                sock = key.fileobj
                assert isinstance(sock, socket.socket)
                self._from_client(sock)
        while (msg := self.bus.recv(timeout=0)) is not None:
            if msg.is_error_frame or msg.is_remote_frame or msg.is_fd:
                continue  # URB uses classic data frames only
            self.stats.from_bus += 1
            self._to_clients(Frame(msg.arbitration_id, bytes(msg.data), msg.is_extended_id).pack(), None)

    def close(self) -> None:
        """Closes the clients, the socket (removing its path) and the bus."""
        for c in list(self.clients):
            self._drop(c)
        self.selector.close()
        self.listener.close()
        if self.socket_path.exists():
            self.socket_path.unlink()
        self.bus.shutdown()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--socket", type=Path, required=True, help="Unix socket path the hosted programs connect to")
    ap.add_argument("--interface", default="virtual", choices=["virtual", "socketcan"],
                    help="python-can interface: virtual (default, in this process) or socketcan (real hardware)")
    ap.add_argument("--channel", default=None, help="python-can channel (default: urb for virtual, can0 for socketcan)")
    args = ap.parse_args(argv)
    channel = args.channel or ("urb" if args.interface == "virtual" else "can0")
    try:
        hub = CanHub(args.socket, args.interface, channel)
    except (OSError, can.CanError) as e:
        print(f"can_hub: cannot open {args.interface} channel {channel} or socket {args.socket}: {e}", file=sys.stderr)
        return 1
    print(f"can_hub: {args.interface}:{channel} on {args.socket} (pid {os.getpid()})", flush=True)
    try:
        while True:
            hub.serve_once(0.01)
    except KeyboardInterrupt:
        pass
    finally:
        hub.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
