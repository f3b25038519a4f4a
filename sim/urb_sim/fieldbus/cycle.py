"""One downlink transaction at a time, as a bridge's master runs them, on CAN, RS485 and I2C.

`CanDownlink` and `Rs485Downlink` run URB's transactions on the bit-timed models between the
firmware's masters and real URB nodes (the node library and a SensoRHex application or the probe,
through `cores`); every transaction the master reports OK is checked against the node library's own
buffers (`Mismatch`). `I2cDownlink` gives the same transactions' durations from the I2C
simulation's measured costs (sim/README.md, Findings: 42 bytes of wire time, START/STOP, clock
stretching, the bridge's turnaround and bus-free time per cycle of three motors), with no
variation: it is the reference column, not a new I2C model.
"""

from __future__ import annotations

import random
from collections.abc import Callable
from dataclasses import dataclass, field

from . import can, cores, rs485

#: how often the bridge's main loop polls the master while the bus is idle, us
POLL_US = 5


@dataclass(frozen=True)
class Txn:
    """A transaction: write inbox `mailbox` (read False) with `payload`, or read `len(payload)` bytes
    of outbox `mailbox` (what the node holds; `payload`'s bytes are not used)."""

    address: int
    mailbox: int
    read: bool
    payload: bytes


@dataclass
class Done:
    """A transaction's outcome: the status the master reports, when (us from 0), and a read's data."""

    status: str
    start_us: float
    done_us: float
    data: bytes = b""


#: the probe every node address runs unless told otherwise: 6 bytes in outbox 1, 2 in inbox 1
DEFAULT_APP = cores.App("probe", out_size=6, in_size=2)


def verify(master_data: bytes, txn: Txn, node: cores.DlNode | None, bus: str) -> str | None:
    """What is wrong with a transaction the master reported OK, or None: a read must return the outbox
    buffer the node latched for it, a write must be the inbox the application's next lock sees."""
    if node is None:
        return f"{bus}: OK from address {txn.address}, where no node is"
    if txn.read:
        held = node.last_read(txn.mailbox, len(txn.payload))[0]
        if master_data != held:
            return f"{bus} read of node {txn.address} outbox {txn.mailbox}: bridge got {master_data.hex()}, node sent {held.hex()}"
        return None
    stored = node.inbox(txn.mailbox, len(txn.payload))[0]
    if stored != txn.payload:
        return f"{bus} write to node {txn.address} inbox {txn.mailbox}: {txn.payload.hex()} sent, the application sees {stored.hex()}"
    return None


@dataclass
class CanDownlink:
    """A bridge and nodes 1..n on one CAN bus."""

    bitrate: int
    rng: random.Random
    addresses: tuple[int, ...]
    ber: float = 0.0
    #: per node address (0: the bridge): the probability that a frame it sends is disturbed (a faulty transceiver)
    tx_fault: dict[int, float] = field(default_factory=dict)
    node_latency_us: tuple[float, float] = (2.0, 10.0)
    bridge_latency_us: tuple[float, float] = (1.0, 3.0)
    #: what each node address runs (default: DEFAULT_APP)
    apps: dict[int, cores.App] = field(default_factory=dict)
    statuses: dict[str, int] = field(default_factory=dict)
    #: OK transactions whose data the node library does not hold (verify)
    mismatches: list[str] = field(default_factory=list)
    verified: int = 0

    def __post_init__(self) -> None:
        self.bus = can.CanBus(self.bitrate, self.rng, ber=self.ber)
        self.bridge = self.bus.attach("bridge", self.tx_fault.get(0, 0.0))
        self.nodes = {a: self.bus.attach(f"node{a}", self.tx_fault.get(a, 0.0)) for a in self.addresses}
        self.master = cores.CanBridge(self.bitrate)
        self.master_aborts = 0
        self.slaves = {a: cores.CanNode(a, self.bitrate, self.apps.get(a, DEFAULT_APP)) for a in self.addresses}
        self.slave_aborts = {a: 0 for a in self.addresses}

    def node(self, address: int) -> cores.DlNode | None:
        return self.slaves.get(address)

    def now_us(self) -> float:
        return self.bus.ns(self.bus.now) / 1000.0

    def _us(self, bits: int) -> float:
        return self.bus.ns(bits) / 1000.0

    def _feed(self) -> None:
        """Frames the master queued go onto the bus now; its abort empties the controller's queue."""
        if self.master_aborts != self.master.aborts():
            self.bridge.queue.clear()
            self.master_aborts = self.master.aborts()
        while (f := self.master.take()) is not None:
            self.bus.send(can.Frame(f[0], f[1], "bridge", "bridge"), self.bus.ns(self.bus.now))

    def _master(self, begin: Callable[[int], bool]) -> tuple[str, float, int | None]:
        """Run one transaction of the firmware's master to its end, the nodes' slaves answering:
        (status, end in us, the start of its first frame on the bus in bits)."""
        self._states()
        if not begin(int(self.now_us())):
            raise RuntimeError("the CAN master refused a transaction while idle")
        first: int | None = None
        end_us = self.now_us()
        while True:
            self._feed()
            status = self.master.poll(int(self.now_us()))
            if status >= 0:
                return cores.STATUS[status], end_us, first
            d = self.bus.step(self.bus.now + self.bus.bit_at(POLL_US * 1000))
            self._states()
            end_us = self.now_us()
            if d is None or not d.ok:
                continue
            end_us = self._us(d.end - can.INTERMISSION_BITS)
            if d.frame.sender == "bridge":
                first = d.start if first is None else first
                self.master.tx_done()
            else:
                self.master.rx(d.frame.can_id, d.frame.data)
                self.slaves[int(d.frame.sender[4:])].tx_done()
            self._deliver(d)

    def _states(self) -> None:
        """Each controller's fault-confinement state to its core; a core's abort empties its controller."""
        self.master.set_state(self.bridge.state)
        for a, slave in self.slaves.items():
            slave.set_state(self.nodes[a].state)
            self._aborted(a)

    def _aborted(self, address: int) -> None:
        """A slave that aborted its answer since the last look: its controller drops the frames it holds."""
        n = self.slaves[address].aborts()
        if n != self.slave_aborts[address]:
            self.nodes[address].queue.clear()
            self.slave_aborts[address] = n

    def _deliver(self, d: can.Delivery) -> None:
        """Every other node's slave receives the frame (time-stamped at its start of frame) and
        queues what it answers, after the node's latency."""
        at = int(self._us(d.start))
        for a, slave in self.slaves.items():
            if d.frame.sender == self.nodes[a].name or self.nodes[a].state == can.BUS_OFF:
                continue
            slave.rx(d.frame.can_id, d.frame.data, at)
            self._aborted(a)
            t_ans = self._us(d.end - can.INTERMISSION_BITS) + self.rng.uniform(*self.node_latency_us)
            while (f := slave.take()) is not None:
                self.bus.send(can.Frame(f[0], f[1], self.nodes[a].name, "answer"), int(t_ans * 1000))

    def sync(self, t_us: float, counter: int) -> float | None:
        """SYNC (identifier 0) through the master at t_us; the instant (us) of its start of frame, which
        every node time-stamps, or None when it did not go through."""
        self.bus.run_until(self.bus.bit_at(int(t_us * 1000)))
        status, _, first = self._master(lambda now: self.master.begin(cores.OP_SYNC, 0, 0, 0, counter & 0xFF, None,
                                                                      now))
        return self._us(first) if status == "OK" and first is not None else None

    def transact(self, t_us: float, txn: Txn) -> Done:
        start = max(t_us, self.now_us()) + self.rng.uniform(*self.bridge_latency_us)
        self.bus.run_until(self.bus.bit_at(int(start * 1000)))
        op = cores.OP_READ if txn.read else cores.OP_WRITE
        data = None if txn.read else txn.payload
        begin_us = self.now_us()
        status, end_us, _ = self._master(
            lambda now: self.master.begin(op, txn.address, txn.mailbox, len(txn.payload), 0, data, now))
        got = self.master.data(len(txn.payload)) if status == "OK" and txn.read else b""
        if status == "OK":
            self.verified += 1
            wrong = verify(got, txn, self.slaves.get(txn.address), "CAN")
            if wrong is not None:
                self.mismatches.append(wrong)
        self.statuses[status] = self.statuses.get(status, 0) + 1
        return Done(status, begin_us, end_us, got)


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
    #: what each node address runs (default: DEFAULT_APP)
    apps: dict[int, cores.App] = field(default_factory=dict)
    statuses: dict[str, int] = field(default_factory=dict)
    mismatches: list[str] = field(default_factory=list)
    verified: int = 0

    def __post_init__(self) -> None:
        self.line = rs485.Rs485Line(self.baud, self.rng, ber=self.ber, modbus_fixed=self.modbus_fixed)
        self.nodes = {a: self.line.node(a, self.apps.get(a, DEFAULT_APP)) for a in self.addresses}

    def node(self, address: int) -> cores.DlNode | None:
        return self.nodes.get(address)

    def now_us(self) -> float:
        return self.line.now_us

    def sync(self, t_us: float, counter: int) -> float:
        """SYNC through the master at t_us; the first byte's stop bit, which every node time-stamps."""
        self.line.now_us = max(self.line.now_us, t_us)
        return self.line.broadcast(counter, list(self.nodes.values()))

    def transact(self, t_us: float, txn: Txn) -> Done:
        self.line.now_us = max(t_us, self.line.now_us) + self.rng.uniform(*self.bridge_latency_us)
        node = self.nodes.get(txn.address)
        others = [n for a, n in self.nodes.items() if a != txn.address]
        o = self.line.poll(txn.address, txn.mailbox, txn.read, txn.payload, node, others=others)
        got = self.line.read_back(len(txn.payload)) if o.status == "OK" and txn.read else b""
        if o.status == "OK":
            self.verified += 1
            wrong = verify(got, txn, node, "RS485")
            if wrong is not None:
                self.mismatches.append(wrong)
        self.statuses[o.status] = self.statuses.get(o.status, 0) + 1
        return Done(o.status, o.start_us, o.done_us, got)


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
