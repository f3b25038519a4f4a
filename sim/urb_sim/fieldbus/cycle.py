"""One downlink transaction at a time, as a bridge's master runs them, on CAN, RS485 and I2C.

`CanDownlink` and `Rs485Downlink` run URB's transactions on the bit-timed models with the
firmware's frames (`cores`); `I2cDownlink` gives the same transactions' durations from the I2C
simulation's measured costs (sim/README.md, Findings: 42 bytes of wire time, START/STOP, clock
stretching, the bridge's turnaround and bus-free time per cycle of three motors), with no
variation: it is the reference column, not a new I2C model.
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field

from . import can, cores, rs485

#: the firmware's constants (urb_can_master.c): the longest transaction in bit times, the node's allowance
CAN_LONGEST_BITS, CAN_NODE_LATENCY_US, CAN_MIN_TIMEOUT_US = 740, 500, 2000


def can_timeout_us(bitrate: int) -> int:
    """urb_can_master_timeout_us: twice the longest transaction plus the node's 500 us, at least 2 ms."""
    kbps = bitrate // 1000
    bus = (2 * CAN_LONGEST_BITS * 1000 - 1) // kbps + 1
    return max(CAN_MIN_TIMEOUT_US, bus + CAN_NODE_LATENCY_US)


@dataclass(frozen=True)
class Txn:
    """A transaction: write inbox `mailbox` (read False) with `payload`, or read outbox `mailbox`
    whose answer is `payload`."""

    address: int
    mailbox: int
    read: bool
    payload: bytes


@dataclass
class Done:
    """A transaction's outcome: the status the master reports and when (us from 0)."""

    status: str
    start_us: float
    done_us: float


@dataclass
class CanDownlink:
    """A bridge and nodes 1..n on one CAN bus."""

    bitrate: int
    rng: random.Random
    addresses: tuple[int, ...]
    ber: float = 0.0
    #: per node address: the probability that a frame it sends is disturbed (a faulty transceiver)
    tx_fault: dict[int, float] = field(default_factory=dict)
    node_latency_us: tuple[float, float] = (2.0, 10.0)
    bridge_latency_us: tuple[float, float] = (1.0, 3.0)
    statuses: dict[str, int] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.bus = can.CanBus(self.bitrate, self.rng, ber=self.ber)
        self.bridge = self.bus.attach("bridge")
        self.nodes = {a: self.bus.attach(f"node{a}", self.tx_fault.get(a, 0.0)) for a in self.addresses}
        self.tids: dict[tuple[int, int], int] = {}
        self.timeout_us = can_timeout_us(self.bitrate)

    def now_us(self) -> float:
        return self.bus.ns(self.bus.now) / 1000.0

    def _us(self, bits: int) -> float:
        return self.bus.ns(bits) / 1000.0

    def _run(self, tag: object, count: int, deadline_bits: int) -> tuple[list[bytes], int | None]:
        """Run the bus until `count` frames tagged `tag` went through or until the deadline: (the data
        of the frames through, end of the last one in bits)."""
        got: list[bytes] = []
        end = None
        while len(got) < count and self.bus.now < deadline_bits:
            d = self.bus.step(deadline_bits)
            if d is not None and d.ok and d.frame.tag == tag:
                got.append(d.frame.data)
                end = d.end
        return got, end

    def sync(self, t_us: float, counter: int) -> float | None:
        """Send SYNC (identifier 0) at t_us; the instant (us) of its start of frame, which every node
        time-stamps, or None when it did not go through."""
        self.bus.run_until(self.bus.bit_at(int(t_us * 1000)))
        frame = can.Frame(cores.SYNC_ID, cores.can_sync(counter, counter & 31), "bridge", ("sync", counter))
        if not self.bus.send(frame, int(t_us * 1000)):
            return None
        deadline = self.bus.now + self.bus.bit_at(self.timeout_us * 1000)
        got, _ = self._run(("sync", counter), 1, deadline)
        if not got:
            return None
        start = next(d.start for d in reversed(self.bus.log) if d.ok and d.frame.tag == ("sync", counter))
        return self._us(start)

    def transact(self, t_us: float, txn: Txn) -> Done:
        start = max(t_us, self.now_us()) + self.rng.uniform(*self.bridge_latency_us)
        self.bus.run_until(self.bus.bit_at(int(start * 1000)))
        deadline = self.bus.bit_at(int((start + self.timeout_us) * 1000))
        if self.bridge.state == can.BUS_OFF:
            return self._done("BUS_STUCK", start, start)
        session = txn.mailbox + (8 if txn.read else 0)
        tid = self.tids.get((txn.address, session), 0)
        self.tids[(txn.address, session)] = (tid + 1) & 31
        request = b"" if txn.read else txn.payload
        req_id = cores.can_id(txn.address, txn.mailbox, txn.read, cores.REQUEST)
        frames = cores.can_transfer(request, tid)
        tag = ("req", txn.address, session, tid)
        for data in frames:
            self.bus.send(can.Frame(req_id, data, "bridge", tag), int(start * 1000))
        got, req_end = self._run(tag, len(frames), deadline)
        if len(got) < len(frames) or req_end is None:
            self.bridge.queue.clear()
            status = "BUS_STUCK" if self.bridge.state == can.BUS_OFF else "TIMEOUT"
            return self._done(status, start, self._us(deadline))
        node = self.nodes.get(txn.address)
        if node is None or node.state == can.BUS_OFF or reassembled(got) != (request, tid):
            self.bus.run_until(deadline)
            return self._done("NO_NODE", start, self._us(deadline))
        answer = txn.payload if txn.read else b""
        ans_id = cores.can_id(txn.address, txn.mailbox, txn.read, cores.RESPONSE)
        ans_frames = cores.can_transfer(answer, tid)
        ans_tag = ("ans", txn.address, session, tid)
        t_ans = self._us(req_end - can.INTERMISSION_BITS) + self.rng.uniform(*self.node_latency_us)
        for data in ans_frames:
            self.bus.send(can.Frame(ans_id, data, node.name, ans_tag), int(t_ans * 1000))
        got, ans_end = self._run(ans_tag, len(ans_frames), deadline)
        if len(got) < len(ans_frames) or ans_end is None:
            node.queue.clear()
            return self._done("NO_NODE" if not got else "TIMEOUT", start, self._us(deadline))
        if reassembled(got) != (answer, tid):
            return self._done("CHECKSUM", start, self._us(ans_end - can.INTERMISSION_BITS))
        # the bridge's receive interrupt: at the end of the answer's end of frame
        return self._done("OK", start, self._us(ans_end - can.INTERMISSION_BITS))

    def _done(self, status: str, start: float, end: float) -> Done:
        self.statuses[status] = self.statuses.get(status, 0) + 1
        return Done(status, start, end)


def reassembled(frames: list[bytes]) -> tuple[bytes, int] | None:
    """The payload and transfer id the firmware's reassembler makes of a session's frames, or None
    when they do not complete one transfer."""
    rx = cores.CanReassembler()
    results = [rx.frame(f) for f in frames]
    if results[-1:] != [cores.RX_DONE] or any(r != cores.RX_MORE for r in results[:-1]):
        return None
    return rx.payload(), rx.tid()


@dataclass
class Rs485Downlink:
    """A bridge and nodes on one RS485 line."""

    baud: int
    rng: random.Random
    addresses: tuple[int, ...]
    ber: float = 0.0
    bridge_latency_us: tuple[float, float] = (1.0, 3.0)
    #: Modbus RTU's fixed silences above 19200 Bd (rs485.timing), for comparison
    modbus_fixed: bool = False
    statuses: dict[str, int] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.line = rs485.Rs485Line(self.baud, self.rng, ber=self.ber, modbus_fixed=self.modbus_fixed)
        self.node_rx = {a: cores.Rs485Receiver(self.line.tm, 0) for a in self.addresses}

    def now_us(self) -> float:
        return self.line.now_us

    def sync(self, t_us: float, counter: int) -> float:
        """Broadcast SYNC at t_us; the first byte's stop bit, which every node time-stamps."""
        self.line.now_us = max(self.line.now_us, t_us)
        first, _ = self.line.broadcast(cores.rs485_sync(counter), list(self.node_rx.values()))
        return first

    def transact(self, t_us: float, txn: Txn) -> Done:
        self.line.now_us = max(t_us, self.line.now_us) + self.rng.uniform(*self.bridge_latency_us)
        request = cores.rs485_request(txn.address, txn.mailbox, txn.read, b"" if txn.read else txn.payload)
        answer = cores.rs485_response(0, txn.mailbox, txn.payload if txn.read else b"")
        o = self.line.poll(request, answer, self.node_rx[txn.address])
        self.statuses[o.status] = self.statuses.get(o.status, 0) + 1
        return Done(o.status, o.start_us, o.done_us)


#: I2C costs per cycle of three motors measured by the I2C simulation (sim/README.md, Findings;
#: bandwidth/i2c_breakdown.csv): START + STOP 5 us, the bridge's turnaround 2.8 us and the bus-free
#: time 1.3 us per operation, clock stretching 1.45 us per byte (61 us over 42 bytes)
I2C_OP_US, I2C_STRETCH_US = 5.0 + 2.8 + 1.3, 1.45


@dataclass
class I2cDownlink:
    """I2C at `bitrate`: a write is address, select, data, check; a read address, data, check
    (3 x (5 + 8) bytes + a 3-byte SYNC: the 42 bytes of the I2C simulation's motor cycle)."""

    bitrate: int = 400_000
    now: float = 0.0

    def now_us(self) -> float:
        return self.now

    def _op(self, t_us: float, nbytes: int) -> tuple[float, float]:
        start = max(t_us, self.now)
        self.now = start + I2C_OP_US + nbytes * (9e6 / self.bitrate + I2C_STRETCH_US)
        return start, self.now

    def sync(self, t_us: float, counter: int) -> float:
        start, _ = self._op(t_us, 3)
        return start

    def transact(self, t_us: float, txn: Txn) -> Done:
        start, end = self._op(t_us, len(txn.payload) + (2 if txn.read else 3))
        return Done("OK", start, end)
