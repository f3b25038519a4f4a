"""A bridge and its nodes in Python: the test double behind the loopback transports, the pty
fake bridge (tests/host/fake_bridge.py) and the examples. It is NOT the bridge firmware; it
follows spec/tla/Bridge.tla action by action and speaks the exact wire format, so the host
library can be tested end to end before (and besides) the hosted firmware.

`BridgeModel` is sans-IO like the host cores: feed it request bytes (RS232) or batches (USB)
with timestamps, ask it for response bytes. Fault injection: `FakeNode.present` (unplug),
`FakeNode.faults` (downlink outcomes for the next transactions), `FakeNode.inbox_locked`
(NODE_BUSY).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

from urb_msgs import NODES, DecodeError, Message, NodeInfo, OutOfRangeError
from urb_msgs import sensorhex as sx
from urb_msgs import urb_core as core
from urb_msgs.urb_core import Status

from .base import decode_message, encode_message

_BRIDGE = core.BRIDGE
BYTE_BITS_I2C = 9  # 8 data bits and the ACK bit


# --------------------------------------------------------------------------------------------
# Fake nodes (SensoRHex apps reduced to plausible, deterministic outbox contents)
# --------------------------------------------------------------------------------------------

class FakeNode:
    """A node on the fake downlink: identification from the schema, outboxes from a tiny plant
    model, inboxes that store what the bridge writes."""

    def __init__(self, info: NodeInfo, index: int, *, fingerprint: int | None = None,
                 fw: tuple[int, int, int] = (1, 0, 0)) -> None:
        self.info = info
        self.index = index
        self.fingerprint = info.fingerprint if fingerprint is None else fingerprint
        self.fw = fw
        self.present = True
        self.faults: deque[Status] = deque()
        """Outcomes forced on the next downlink transactions, one per transaction (TIMEOUT,
        CHECKSUM, BUS_STUCK, NODE_BUSY; OK = no fault for that one)."""
        self.vanish_after: int | None = None
        """When set, the node answers this many more transactions, then stops acknowledging."""
        self.inbox_locked = False
        """While True every write is NACKed: the bridge answers NODE_BUSY."""
        self.stretch_ns = 0
        """Clock stretching: every transaction with this node holds the downlink this much longer
        (on either uplink, timed downlink or not), so the bridge answers it, and the requests
        queued behind it, late."""
        self.inboxes: dict[int, bytes] = {}
        self.reads = 0
        self.writes = 0
        self._tick = 0

    def identification(self) -> core.Identification:
        return core.Identification(
            class_id=self.info.class_id, index=self.index, fingerprint=self.fingerprint,
            fw_major=self.fw[0], fw_minor=self.fw[1], fw_patch=self.fw[2],
            inbox_sizes=self.info.sizes("inbox"), outbox_sizes=self.info.sizes("outbox"),
            synced=True, acq_time=120,
        )

    def read_outbox(self, box: int) -> bytes:
        """Contents of outbox `box` (the application refreshes it every heartbeat)."""
        self.reads += 1
        self._tick += 1
        if box == 0:
            return self.identification().encode()
        mb = self.info.mailbox("outbox", box)
        if mb is None:
            return b""
        return encode_message(self._sample(mb.message))

    def write_inbox(self, box: int, data: bytes) -> None:
        self.writes += 1
        self.inboxes[box] = bytes(data)

    def _inbox(self, box: int, cls: type[Message]) -> Message | None:
        raw = self.inboxes.get(box)
        if raw is None:
            return None
        try:
            return decode_message(cls, raw)
        except DecodeError:
            return None

    def _sample(self, cls: type[Message]) -> Message:
        t = self._tick
        if cls is sx.MotorFeedback:
            cmd = self._inbox(1, sx.MotorCommand)
            volts = cmd.voltage if isinstance(cmd, sx.MotorCommand) else 0
            return sx.MotorFeedback(encoder=(t * 7 + volts) & 0xFFFF, current=max(-32768, min(32767, volts // 2)), voltage=volts)
        if cls is sx.MotorStatus:
            cfg = self._inbox(2, sx.MotorConfig)
            mode = cfg.mode if isinstance(cfg, sx.MotorConfig) else sx.MotorMode.DISABLED
            return sx.MotorStatus(case_temp=2500 + t % 50, mode=mode, hall=t % 2 == 0, missed_commands=min(255, t // 10))
        if cls is sx.BatteryStatus:
            packs = [sx.BatteryPack(voltage=11100 + 10 * i, current=1500 + i, charge=80 - i, present=True, temp=25 + i) for i in range(3)]
            return sx.BatteryStatus(packs=packs, low=False, charging=False)
        if cls is sx.ImuSample:
            wob = int(50 * math.sin(t / 10))
            return sx.ImuSample(accel=[wob, -wob, 9810], gyro=[1, 2, 3], temp=31, sample=t & 0xFF)
        if cls is sx.IrRange:
            return sx.IrRange(distance=500 + t % 100, strength=200, valid=True)
        return cls()


def fake_node(spec: str) -> tuple[int, FakeNode]:
    """A node from `NAME:INDEX@ADDRESS[!fp=HEX][!fw=A.B.C]`, e.g. ``MotorDriver:0@8``."""
    head, *opts = spec.split("!")
    try:
        name_index, addr = head.split("@")
        name, index = name_index.split(":")
        info = next(n for key, n in NODES.items() if key.lower() == name.lower())
        node = FakeNode(info, int(index, 0))
        for opt in opts:
            key, value = opt.split("=")
            if key == "fp":
                node.fingerprint = int(value, 16)
            elif key == "fw":
                a, b, c = (int(x) for x in value.split("."))
                node.fw = (a, b, c)
            else:
                raise ValueError(key)
        return int(addr, 0), node
    except (ValueError, StopIteration):
        names = ", ".join(n for n, i in NODES.items() if i.kind == "node")
        raise ValueError(f"bad node spec {spec!r}: use NAME:INDEX@ADDRESS[!fp=HEX][!fw=A.B.C], NAME one of {names}") from None


# --------------------------------------------------------------------------------------------
# The bridge: Bridge.tla's SubmitAndAdmit, Serve, Emit
# --------------------------------------------------------------------------------------------

@dataclass
class _Request:
    address: int
    mailbox: int
    read: bool
    length: int
    seq: int
    data: bytes = b""


@dataclass
class _Entry:
    """One slot of the response ring (Bridge.tla `queue`)."""

    req: _Request
    status: Status | None  # None = PENDING
    data: bytes = b""
    arrival_ns: int = 0
    ready_ns: int = 0  # when its downlink transaction ends (timed downlink)
    started: bool = False
    admission: bool = False  # decided at admission: holds no data slot


@dataclass
class BridgeStats:
    requests: int = 0
    responses: int = 0
    dropped_bytes: int = 0
    """Bytes discarded by the request parser (hunting, idle gap)."""
    busy: int = 0
    overflow: int = 0
    """Requests beyond the response ring (the host ignored its window)."""
    by_status: dict[str, int] = field(default_factory=dict)


class BridgeModel:
    """A bridge with fake nodes behind it, speaking the uplink wire format (RS232 and USB)."""

    def __init__(self, nodes: dict[int, FakeNode] | None = None, *, fifo_depth: int = 8, ring: int = 15,
                 bitrate_kbps: int = 400, heartbeat_us: int = 1000, fw: tuple[int, int, int] = (0, 1, 0),
                 idle_gap_ns: int = 174_000, timed_downlink: bool = False, scan_ns: int = 0) -> None:
        """`fifo_depth`: data slots (QueueLen); `ring`: response slots (HostWindow);
        `timed_downlink`: a transaction takes its I2C time at `bitrate_kbps` (else instantaneous);
        `idle_gap_ns`: a partial request frame is dropped after this much silence; `scan_ns`: how
        long a SCAN command holds the downlink (answered when the scan is over, as the firmware)."""
        self.scan_ns = scan_ns
        self.nodes: dict[int, FakeNode] = dict(nodes or {})
        self.fifo_depth = fifo_depth
        self.ring = ring
        self.bitrate_kbps = bitrate_kbps
        self.heartbeat_us = heartbeat_us
        self.fw = fw
        self.idle_gap_ns = idle_gap_ns
        self.timed_downlink = timed_downlink
        self.stats = BridgeStats()
        self._rx = bytearray()
        self._last_rx_ns: int | None = None
        self._queue: deque[_Entry] = deque()
        self._busy_until = 0
        self._sizes: dict[int, tuple[list[int], list[int]]] = {}
        self._present_map: list[bool] = [False] * 128
        self._usb_prev: bytes | None = None
        self._usb_cur: bytes | None = None
        self.scan()

    # -- downlink -----------------------------------------------------------------------------
    def scan(self) -> None:
        """Probe addresses 1..127 and learn the sizes of every node that answers (outbox 0)."""
        self._present_map = [False] * 128
        self._sizes.clear()
        for addr, node in self.nodes.items():
            if node.present and 1 <= addr <= 127:
                self._present_map[addr] = True
                ident = node.identification()
                self._sizes[addr] = (list(ident.inbox_sizes), list(ident.outbox_sizes))

    def _mailbox_size(self, addr: int, read: bool, box: int) -> int | None:
        if addr == core.BRIDGE_ADDRESS:
            return _BRIDGE.sizes("outbox" if read else "inbox")[box]
        sizes = self._sizes.get(addr)
        if sizes is None:
            return None
        return sizes[1][box] if read else sizes[0][box]

    def _duration_ns(self, r: _Request) -> int:
        """How long the transaction holds the downlink: its bit time (timed downlink) plus the
        node's clock stretching."""
        if r.address == core.BRIDGE_ADDRESS and not r.read and r.mailbox == 0:
            try:
                if core.BridgeCommand.decode(r.data).opcode == core.BridgeOpcode.SCAN:
                    return self.scan_ns
            except DecodeError:
                pass
        node = self.nodes.get(r.address)
        return self._bits_ns(r) + (node.stretch_ns if node is not None and node.present else 0)

    def _bits_ns(self, r: _Request) -> int:
        if not self.timed_downlink or r.address == core.BRIDGE_ADDRESS:
            return 0
        frame = 1 + 1 + 1 + r.length + (1 if r.length < 14 else 2) if r.read else 1 + 1 + r.length + 1
        return frame * BYTE_BITS_I2C * 1_000_000 // self.bitrate_kbps

    # -- SubmitAndAdmit -----------------------------------------------------------------------
    def _admit(self, r: _Request, now: int, bad: bool = False) -> None:
        self.stats.requests += 1
        data_slots = sum(1 for e in self._queue if not e.admission)
        size = self._mailbox_size(r.address, r.read, r.mailbox)
        status: Status | None
        if bad or not 1 <= r.length <= 32:
            status = Status.BAD_REQUEST
        elif size is not None and r.length != size:
            status = Status.SIZE_MISMATCH
        elif len(self._queue) >= self.ring:
            self.stats.overflow += 1
            status = Status.BUSY
        elif data_slots >= self.fifo_depth:
            status = Status.BUSY
        else:
            status = None
        if status == Status.BUSY:
            self.stats.busy += 1
        self._queue.append(_Entry(r, status, admission=status is not None, arrival_ns=now))

    # -- Serve --------------------------------------------------------------------------------
    def _serve(self, now: int) -> None:
        """Run downlink transactions for pending requests, oldest first, until `now`."""
        for e in self._queue:
            if e.status is not None:
                continue
            if not e.started:
                e.started = True
                e.ready_ns = max(self._busy_until, e.arrival_ns) + self._duration_ns(e.req)
                self._busy_until = e.ready_ns
            if e.ready_ns > now:
                return  # transaction in progress
            e.status, e.data = self._transact(e.req)

    def _transact(self, r: _Request) -> tuple[Status, bytes]:
        if r.address == core.BRIDGE_ADDRESS:
            return self._bridge_mailbox(r)
        node = self.nodes.get(r.address)
        if node is not None and node.vanish_after is not None:
            if node.vanish_after <= 0:
                node.present, node.vanish_after = False, None
            else:
                node.vanish_after -= 1
        if node is None or not node.present:
            return Status.NO_NODE, b""
        if node.faults:
            fault = node.faults.popleft()
            if fault != Status.OK and not (fault == Status.NODE_BUSY and r.read):
                return fault, b""
        if r.read:
            data = node.read_outbox(r.mailbox)
            return (Status.OK, data) if len(data) == r.length else (Status.SIZE_MISMATCH, b"")
        if node.inbox_locked:
            return Status.NODE_BUSY, b""
        node.write_inbox(r.mailbox, r.data)
        return Status.OK, b""

    def _bridge_mailbox(self, r: _Request) -> tuple[Status, bytes]:
        if r.read and r.mailbox == 0:
            return Status.OK, core.BridgeInfo(
                downlink=core.DownlinkKind.I2C, bitrate_kbps=self.bitrate_kbps, fifo_depth=self.fifo_depth,
                heartbeat_us=self.heartbeat_us, fw_major=self.fw[0], fw_minor=self.fw[1], fw_patch=self.fw[2]).encode()
        if r.read and r.mailbox == 1:
            return Status.OK, core.BridgeScan(present=list(self._present_map)).encode()
        if not r.read and r.mailbox == 0:
            try:
                cmd = core.BridgeCommand.decode(r.data)
            except DecodeError:
                return Status.BAD_REQUEST, b""
            if cmd.opcode == core.BridgeOpcode.SCAN:
                self.scan()
            elif cmd.opcode == core.BridgeOpcode.SET_HEARTBEAT:
                self.heartbeat_us = cmd.value
            return Status.OK, b""
        return Status.BAD_REQUEST, b""

    # -- Emit ---------------------------------------------------------------------------------
    def _emit(self) -> bytes:
        out = bytearray()
        while self._queue and self._queue[0].status is not None:
            e = self._queue.popleft()
            status = e.status
            assert status is not None
            data = e.data if status == Status.OK and e.req.read else b""
            out += core.UplinkResponse(seq=e.req.seq, status=status, data=data).encode()
            self.stats.responses += 1
            self.stats.by_status[status.name] = self.stats.by_status.get(status.name, 0) + 1
        return bytes(out)

    # -- RS232 uplink -------------------------------------------------------------------------
    def receive(self, data: bytes, now: int) -> None:
        """Request bytes from the RS232 uplink; frames are admitted as soon as complete."""
        if self._rx and self._last_rx_ns is not None and now - self._last_rx_ns > self.idle_gap_ns:
            self.stats.dropped_bytes += len(self._rx)  # idle gap: drop the partial frame
            self._rx.clear()
        self._last_rx_ns = now
        self._rx += data
        self._parse(now)

    def _parse(self, now: int) -> None:
        rx = self._rx
        while len(rx) >= 3:
            read = bool(rx[0] & 1)
            length = rx[2]
            if read:
                n = 4
            elif 1 <= length <= 32:
                covered = 3 + length
                n = covered + (1 if covered <= 14 else 2)
            else:
                self._drop(1)  # a write whose length cannot frame it: hunt on
                continue
            if len(rx) < n:
                return
            frame = bytes(rx[:n])
            try:
                if read:
                    rq = core.UplinkReadRequest.decode(frame)
                    r = _Request(rq.address, rq.mailbox, True, rq.length, rq.seq)
                else:
                    wq = core.UplinkWriteRequest.decode(frame)
                    r = _Request(wq.address, wq.mailbox, False, len(wq.data), wq.seq, bytes(wq.data))
            except OutOfRangeError:
                # the check passed: a real request with a bad header, answered BAD_REQUEST
                del rx[:n]
                self._admit(_Request(rx_addr(frame), frame[1] & 7, read, 1, frame[1] >> 4), now, bad=True)
                continue
            except DecodeError:
                self._drop(1)
                continue
            del rx[:n]
            self._admit(r, now)

    def _drop(self, n: int) -> None:
        del self._rx[:n]
        self.stats.dropped_bytes += n

    def process(self, now: int) -> bytes:
        """Serve what the downlink can by `now` and return the responses ready to leave."""
        self._serve(now)
        return self._emit()

    def next_event_ns(self) -> int | None:
        """When a transaction in progress completes (timed downlink), else None."""
        for e in self._queue:
            if e.status is None:
                return e.ready_ns if e.started else 0
        return None

    # -- USB uplink ---------------------------------------------------------------------------
    def usb_out(self, data: bytes, now: int) -> None:
        """A bulk-OUT transfer (batch n): run it and fill the current response buffer; the
        previous buffer (batch n-1) is what the next bulk-IN returns."""
        self._usb_prev, self._usb_cur = self._usb_cur, None
        try:
            header = core.UsbBatchHeader.decode(data[:4])
        except DecodeError:
            self.stats.dropped_bytes += len(data)
            return
        body = bytearray(data[4:])
        count = 0
        while count < header.count and len(body) >= 3:
            read = bool(body[0] & 1)
            n = 4 if read else 3 + body[2] + (1 if 3 + body[2] <= 14 else 2)
            try:
                if read:
                    rq = core.UplinkReadRequest.decode(bytes(body[:n]))
                    self._admit(_Request(rq.address, rq.mailbox, True, rq.length, rq.seq), now)
                else:
                    wq = core.UplinkWriteRequest.decode(bytes(body[:n]))
                    self._admit(_Request(wq.address, wq.mailbox, False, len(wq.data), wq.seq, bytes(wq.data)), now)
            except DecodeError:
                self.stats.dropped_bytes += len(body)
                break  # a corrupt request inside a transfer: the rest cannot be framed
            del body[:n]
            count += 1
        saved, self.timed_downlink = self.timed_downlink, False  # premise: a batch fits one frame
        responses = self.process(now)
        self.timed_downlink = saved
        self._usb_cur = core.UsbBatchHeader(frame=header.frame, count=count).encode() + responses

    def usb_in(self) -> bytes | None:
        """A bulk-IN transfer: the previous response buffer (None before the first batch)."""
        out, self._usb_prev = self._usb_prev, None
        return out


def rx_addr(frame: bytes) -> int:
    return frame[0] >> 1
