"""A half-duplex RS485 line polled by a bridge, character by character.

The bridge is the firmware's master (`cores.Rs485Bridge`: `urb_rs485_master.c`) and every node a
URB node (`cores.Rs485Node`: the node library on `urb_rs485_slave.c` and its application), each with
the firmware's receiver
(`urb_rs485_rx_*`) fed with the stop bit's instant of every character: their echo check, silence
rules (a frame ends after t3.5 of silence, a silence over t1.5 inside discards it), NO_NODE
allowance, answers and statuses are the firmware's. What the line adds (sim/README.md, "Downlinks"):

* characters of 10 bits (8N1) back to back from a UART with a FIFO, or with gaps when a node's
  transmit interrupt is late (`gap_us`, drawn per character; a stalled node, `stall_us`, breaks its
  answer);
* the node's answer starts when its receiver ends the request (its deadline), after its interrupt
  latency and its driver-enable time (`turnaround`, drawn per answer), which the bridge allows up to
  `urb_rs485_timing`'s turnaround figure;
* a character is corrupted with probability 1 - (1 - ber)^10, which its frame's check then fails;
* Modbus RTU's fixed silences (1750 / 750 us above 19200 Bd) when `modbus_fixed`, for comparison:
  URB keeps 3.5 / 1.5 characters at every rate (spec/schema/README.md, "RS485 downlink").
"""

from __future__ import annotations

import random
from collections.abc import Callable
from dataclasses import dataclass, field, replace

from . import cores

CHAR_BITS = 10
MODBUS_T35_US, MODBUS_T15_US = 1750, 750
#: a transceiver's driver enable to a valid line, us (min, max); a UART FIFO refilled late, us per character
DRIVER_ENABLE_US, GAP_US = (0.1, 1.0), (0.0, 0.5)


def timing(baud: int, modbus_fixed: bool = False) -> cores.Rs485Timing:
    """The firmware's timing at `baud`; with `modbus_fixed` Modbus RTU's fixed silences above 19200 Bd."""
    t = cores.rs485_timing(baud)
    if modbus_fixed and baud > 19200:
        t = replace(t, t15_us=MODBUS_T15_US, t35_us=MODBUS_T35_US)
    return t


@dataclass
class Outcome:
    """One poll as the bridge saw it: the status it reports (as urb_rs485_master does) and instants (us)."""

    status: str
    start_us: float
    request_end_us: float
    answer_start_us: float | None
    done_us: float


@dataclass
class Rs485Line:
    """One RS485 segment: the bridge and its nodes' receivers, the line's time (us, float)."""

    baud: int
    rng: random.Random
    ber: float = 0.0
    modbus_fixed: bool = False
    #: interrupt latency of a node before it enables its driver, us (min, max), drawn per answer
    node_latency_us: tuple[float, float] = (2.0, 10.0)
    #: driver enable (DE) to a valid line, us (min, max): the transceiver's enable time
    driver_enable_us: tuple[float, float] = DRIVER_ENABLE_US
    #: extra gap before each character a node sends, us (min, max): its transmit FIFO is refilled late
    gap_us: tuple[float, float] = GAP_US
    #: a seeded bug for the tests: the node answers as soon as the request's last character is in,
    #: without waiting for t3.5 of silence
    mutant_answer_early: bool = False
    now_us: float = 0.0
    corrupted: int = 0
    statuses: dict[str, int] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.tm = timing(self.baud, self.modbus_fixed)
        self.char_us = CHAR_BITS * 1e6 / self.baud
        self.master = cores.Rs485Bridge(self.baud, 0)
        if self.modbus_fixed:
            self.master.set_silences(self.tm.t15_us, self.tm.t35_us)

    def _corrupt(self, byte: int) -> int:
        p = 1.0 - (1.0 - self.ber) ** CHAR_BITS if self.ber > 0 else 0.0
        if p > 0 and self.rng.random() < p:
            self.corrupted += 1
            return byte ^ (1 << self.rng.randrange(8))
        return byte

    def node(self, address: int, app: cores.App) -> cores.Rs485Node:
        """A node on this line running `app`, with this line's timing, started now."""
        return cores.Rs485Node(address, self.tm, int(self.now_us), app)

    def _transaction(self, begin: Callable[[int], bool], nodes: list[cores.Rs485Node],
                     answering: cores.Rs485Node | None, stall_us: float) -> Outcome:
        """Run one transaction of the firmware's master: its request goes to every node (a disturbed
        character reaches the nodes corrupted, the bridge's echo clean); `answering` (None: nobody)
        answers what its slave decides when its receiver ends the request, after its latency and
        driver enable; its answer goes to the bridge and every other node."""
        start = self.now_us
        if not begin(int(start)):
            raise RuntimeError("the RS485 master refused a transaction while idle")
        t = start
        req_end: float | None = None
        ans_start: float | None = None
        pending: list[tuple[float, int]] = []
        listeners = [n for n in nodes if n is not answering]
        while True:
            request = self.master.take_all()
            if request:
                t_send = t
                for k, byte in enumerate(request):
                    stamp = int(t_send + (k + 1) * self.char_us)
                    self.master.rx(byte, stamp)
                    wire = self._corrupt(byte)
                    for n in nodes:
                        n.byte(wire, stamp)
                req_end = t = t_send + len(request) * self.char_us
                if answering is not None:
                    pending, ans_start = self._answer(answering, req_end, stall_us)
            wake = self.master.next_us(int(t))
            if pending and pending[0][0] <= wake:
                at, byte = pending.pop(0)
                t = at
                self.master.rx(byte, int(at))
                for n in listeners:
                    n.byte(byte, int(at))
                continue
            t = float(wake)
            status = self.master.poll(wake)
            if status >= 0:
                for n in nodes:
                    n.poll(int(t))
                return self._finish(Outcome(cores.STATUS[status], start, req_end or start, ans_start, t))

    def _answer(self, node: cores.Rs485Node, req_end: float,
                stall_us: float) -> tuple[list[tuple[float, int]], float | None]:
        """The node's answer bytes toward the bridge, (instant, byte) each, and when it begins."""
        wake = node.wake_us()
        node.poll(wake)
        answer = node.take_all()
        if not answer:
            return [], None  # the slave does not answer (a broken frame, another address)
        ready = req_end if self.mutant_answer_early else float(wake)
        t = ready + self.rng.uniform(*self.node_latency_us) + self.rng.uniform(*self.driver_enable_us)
        begin = t
        out = []
        for k, byte in enumerate(answer):
            t += (self.rng.uniform(*self.gap_us) if k else 0.0) + (stall_us if k == 1 else 0.0) + self.char_us
            out.append((t, self._corrupt(byte)))
        return out, begin

    def broadcast(self, counter: int, nodes: list[cores.Rs485Node]) -> float:
        """SYNC through the master; the first byte's stop bit, which every node time-stamps."""
        o = self._transaction(lambda now: self.master.begin(cores.OP_SYNC, 0, 0, 0, counter & 0xFF, None, now),
                              nodes, None, 0.0)
        return o.request_end_us - (len(cores.rs485_sync(counter)) - 1) * self.char_us

    def poll(self, address: int, mailbox: int, read: bool, payload: bytes, node: cores.Rs485Node | None,
             stall_us: float = 0.0, others: list[cores.Rs485Node] | None = None) -> Outcome:
        """The master reads `len(payload)` bytes of outbox `mailbox` (what the node holds) or writes
        `payload` into inbox `mailbox` of node `address`, which is `node` (None: nobody there);
        `others` hear the line too. `stall_us` holds the answer before its second character."""
        op = cores.OP_READ if read else cores.OP_WRITE
        everyone = ([node] if node is not None else []) + list(others or [])
        return self._transaction(
            lambda now: self.master.begin(op, address, mailbox, len(payload), 0, None if read else payload, now),
            everyone, node, stall_us)

    def read_back(self, n: int) -> bytes:
        """The data the last read returned."""
        return self.master.data(n)

    def _finish(self, o: Outcome) -> Outcome:
        self.now_us = o.done_us
        self.statuses[o.status] = self.statuses.get(o.status, 0) + 1
        return o
