"""Fig. 16's round-trip bound, derived from the model's parameters: the active hardware profile's.

The paper's USB argument (Sec. V-C, Fig. 9) is three 1-ms frames: the request waits for the write
thread's tick, goes out in the next frame's OUT transfer, and its response comes back in the frame
after, when the bridge's response batch swaps at the SOF. That holds only if the bridge has the
response in its batch before that SOF: the frame's downlink work (the SYNC the bridge may send
first, the read with each byte's clock stretching, the select a read of a newly addressed outbox
needs first) must fit in the frame. Whether it does depends on the hardware: how long the node
holds SCL after each byte (interrupt entry, flash wait states, its I2C handler, the edge's delay
through the input path), how fast the bridge turns around.

So the bound is derived here term by term from the same parameters the simulation runs with, as a
worst case (each model jitter at its bound; every handler or masked section of another source that
can fall into the path at most as often as it can occur): the frame work ends at

    request taken + SYNC + read (+ select) + report    after the SOF of the frame its OUT went in,

and a response whose frame work may end after the next SOF (that SOF's flag, which the bridge's
main loop takes before it emits: firmware/hal/cortex-m0plus/bridge_port.c) may go one frame later.
A response late by a frame delays the next frame's SYNC and read: `frames` follows the reads of a
run frame by frame until one fits again. The bound of a read is its frames plus the last frame's
path to the callback (`path`). Each function returns its terms, so the report shows the derivation.

Cross-checked against the simulation's own timing (tests/sim/test_usb_bound.py): every measured
transaction, request and response instant lies within its derived worst case.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

from urb_msgs.urb_core import UplinkReadRequest, UsbBatchHeader

#: A crystal's error is drawn from N(mean, sd): the bound allows this many sd (one in 1.7 million).
CRYSTAL_SDS = 5.0
#: USB full speed: SOF packet, the gap the model puts between packets, a NAKed token's transaction,
#: a token, a handshake, a data packet's fixed part, the largest data packet (sim/core/usb.h, usb.c).
USB_SOF_BITS, USB_GAP_BITS, USB_NAK_BITS = 35, 8, 70
USB_TOKEN_BITS, USB_HANDSHAKE_BITS, USB_DATA_BITS, USB_MAX_PACKET = 35, 19, 35, 64
#: I2C bus free time between a STOP and a START in Fast-mode (UM10204 Table 10; sim/core/i2c.c).
T_BUF_US = {100e3: 4.7, 400e3: 1.3}
#: The SYNC broadcast on the wire: the general-call address, the magic byte and the counter.
SYNC_BYTES = 3


def framed(covered: int) -> int:
    """A frame's length with its check: 1 byte up to 14 covered bytes, else 2 (the wire rule,
    urb_link_check_size; host/urb/managers/base.py response_size)."""
    return covered + (1 if covered <= 14 else 2)


@dataclass(frozen=True)
class Term:
    """One term of a derivation, in microseconds, and where it comes from."""

    what: str
    us: float


@dataclass
class Terms:
    """A sum of terms."""

    terms: list[Term] = field(default_factory=list)

    def add(self, what: str, us: float) -> Terms:
        self.terms.append(Term(what, us))
        return self

    @property
    def us(self) -> float:
        return sum(t.us for t in self.terms)


@dataclass(frozen=True)
class Core:
    """One MCU as the model charges it (sim/world/world.c core_timing and from_flash, sim/core/mcu.c):
    interrupt entry irq_cycles + 2 ws plus up to irq_jitter_cycles + ws, handlers and main-loop work
    x (1 + ws/2), a masked section before WFI (mask_cycles, counted with the wait states), WFI
    wake-up."""

    dev: str
    hz: float
    ws: float
    entry_max: float
    mask: float
    wfi: float
    values: Mapping[str, float]

    @classmethod
    def of(cls, v: Mapping[str, float], dev: str) -> Core:
        ws = v[f"{dev}.flash_ws"]
        entry = math.floor(v[f"{dev}.irq_cycles"]) + math.floor(2 * ws) + math.floor(v[f"{dev}.irq_jitter_cycles"]) \
            + math.floor(ws)
        return cls(dev, v[f"{dev}.cpu_hz"], ws, entry, v[f"{dev}.mask_cycles"], v[f"{dev}.wfi_wake_cycles"], v)

    def us(self, cycles: float) -> float:
        return cycles / self.hz * 1e6

    def code(self, name: str) -> float:
        """A handler's or main-loop step's length in cycles, fetched from flash."""
        return self.values[f"{self.dev}.{name}"] * (1.0 + 0.5 * self.ws)

    @property
    def asleep_entry(self) -> float:
        """An interrupt that finds the core in WFI: wake-up, then the longest entry (cycles)."""
        return self.wfi + self.entry_max


@dataclass(frozen=True)
class Downlink:
    """The I2C downlink's operations as the model times them (sim/core/i2c.c): 9 bit times a byte,
    a written byte completes after its 8th bit, the receivers' clock stretching and the ACK bit; a
    read byte starts when the master issues it and the node has loaded it."""

    t_bit: float
    t_buf: float
    #: how long a node holds SCL after an edge it answers: the edge's delay through its input path
    #: (the falling edge's threshold crossing, glitch filter, synchroniser), wake-up from WFI,
    #: interrupt entry and its I2C handler
    stretch: float
    #: the bridge issues its next operation when its I2C handler starts: wake-up from WFI and entry
    turn: float
    #: the bridge's last completion of a transaction to the main-loop iteration that reports it
    report: float
    #: what the node can add once per transaction: its heartbeat handler, one masked section
    node_once: float
    #: what the bridge can add once per transaction: a USB handler, its heartbeat handler and the
    #: masked sections after the main-loop iterations they wake
    bridge_once: float
    #: a read of n bytes: the wait before each byte
    @property
    def gap(self) -> float:
        return max(self.turn, self.stretch)

    @property
    def write(self) -> float:
        """A written byte, from its start to the master's next operation."""
        return 9 * self.t_bit + self.stretch + self.turn

    @classmethod
    def of(cls, v: Mapping[str, float]) -> Downlink:
        node, bridge = Core.of(v, "node"), Core.of(v, "bridge")
        rate = v["i2c.bitrate"]
        t_buf = 4.7 if rate <= 100e3 else 1.3 if rate <= 400e3 else 0.5
        fall_ns = v["i2c.bus_pf"] * 1e-12 * v["i2c.vdd"] / (v["i2c.sink_ma"] * 1e-3) * 1e9 \
            if v["i2c.bus_pf"] > 0 and v["i2c.sink_ma"] > 0 else 0.0
        sync_ns = v["node.i2c_sync_max_cycles"] / v["node.i2c_clk_hz"] * 1e9 if v["node.i2c_clk_hz"] > 0 else 0.0
        edge_us = ((1.0 - v["node.vth_min"]) * fall_ns + v["node.filter_ns_max"] + sync_ns) / 1000
        return cls(
            t_bit=round(1e9 / rate) / 1000, t_buf=t_buf,
            stretch=edge_us + node.us(node.asleep_entry + node.code("i2c_isr_cycles")),
            turn=bridge.us(bridge.asleep_entry),
            report=bridge.us(bridge.asleep_entry + bridge.code("i2c_isr_cycles") + bridge.code("wake_cycles")),
            node_once=node.us(node.code("timer_isr_cycles") + node.mask),
            bridge_once=bridge.us(bridge.code("usb_isr_cycles") + bridge.code("timer_isr_cycles") + 2 * bridge.mask))


def sync_terms(d: Downlink) -> Terms:
    """The SYNC, from its START to the next transaction's START."""
    return (Terms().add("SYNC: START and the bridge's turnaround", d.t_bit + d.turn)
            .add(f"SYNC: {SYNC_BYTES} written bytes with the nodes' stretching", SYNC_BYTES * d.write)
            .add("SYNC: STOP and the bus free time, or the main loop's next transaction if later",
                 max(d.turn + d.t_bit + d.t_buf, d.report) - d.turn))


def read_terms(d: Downlink, payload: int, select: bool) -> Terms:
    """A read of `payload` bytes, from its START to the main-loop iteration that puts the response
    in the batch; with `select`, the node's outbox is selected first (the bridge's cache holds
    another: every run's first read of outbox 1, discovery having read outbox 0)."""
    n_rx = payload + framed(1 + payload) - (1 + payload)
    t = Terms().add("read: START and the bridge's turnaround", d.t_bit + d.turn)
    if select:
        t.add("select: address and select byte written, repeated START", 2 * d.write + 1.5 * d.t_bit + d.turn)
    t.add("read: address written, the node loads its first byte", 9 * d.t_bit + d.stretch + d.gap)
    t.add(f"read: {n_rx} bytes ({payload} and the check), each loaded by the node", n_rx * 9 * d.t_bit
          + (n_rx - 1) * d.gap)
    t.add("read: the last byte's handler (STOP) and the main loop that emits the response", d.report)
    return t


def interference_terms(d: Downlink) -> Terms:
    """What other sources add to the SYNC and the read together, each as often as it can occur in
    the frame once the request is taken: the node's heartbeat handler and the masked section after
    its update (once a heartbeat), the bridge's USB handler of the IN transfer's end, its heartbeat
    handler and the masked sections after the main-loop iterations they wake."""
    return (Terms().add("the node's heartbeat handler and a masked section", d.node_once)
            .add("the bridge's IN-done USB handler, heartbeat handler and two masked sections", d.bridge_once))


def usb_bits(data_bytes: int) -> int:
    """A bulk transfer of `data_bytes` on the wire, worst-case bit stuffing (one bit per six)."""
    bits, left = 0, data_bytes
    while True:
        n = min(left, USB_MAX_PACKET)
        bits += USB_TOKEN_BITS + USB_GAP_BITS + USB_DATA_BITS + 8 * n + (8 * n) // 6 + USB_GAP_BITS \
            + USB_HANDSHAKE_BITS + USB_GAP_BITS
        left -= n
        if left == 0:
            if n == USB_MAX_PACKET:
                continue  # a zero-length packet ends an exact multiple
            return bits


def request_terms(v: Mapping[str, float]) -> Terms:
    """From the SOF of the frame a request's OUT goes in to the bridge's main loop taking it."""
    bridge = Core.of(v, "bridge")
    wire = USB_SOF_BITS + USB_GAP_BITS + USB_NAK_BITS + usb_bits(UsbBatchHeader.MAX_SIZE + UplinkReadRequest.MAX_SIZE)
    busy = max(bridge.wfi, bridge.code("i2c_isr_cycles") + bridge.mask)
    return (Terms().add("SOF, the driver's pending IN NAKed, the OUT of the request on the wire",
                        wire / v["usb.bitrate"] * 1e6)
            .add("the bridge's USB interrupt: wake-up, or a running handler and a masked section, then entry",
                 bridge.us(busy + bridge.entry_max))
            .add("its USB handler, then the main loop (or the iteration it preempted)",
                 bridge.us(bridge.code("usb_isr_cycles") + max(bridge.code("wake_cycles"),
                                                               bridge.code("poll_cycles")))))


def deadline_us(v: Mapping[str, float]) -> float:
    """After the SOF of a request's frame, the instant the bridge's main loop sees the next SOF's
    flag (the end of its packet): a response emitted later joins the batch after. The frame is the
    host controller's 1 ms, shorter by its crystal's error (CRYSTAL_SDS sd)."""
    return 1000.0 * (1.0 - CRYSTAL_SDS * v["usb.ppm_sd"] * 1e-6) + USB_SOF_BITS / v["usb.bitrate"] * 1e6


def path_terms(v: Mapping[str, float], payload: int) -> Terms:
    """After the three frames, to the callback: the write thread's tick jitter, the last frame on
    the wire up to the end of its IN (the SOF, the IN NAKed while the bridge's main loop arms the
    batch, the next request's OUT, then an IN carrying TWO responses: one late by a frame shares the
    IN with the next), the completion interrupt, the read thread's wake-up and its jitter."""
    response = framed(1 + payload)
    wire = USB_SOF_BITS + USB_GAP_BITS + USB_NAK_BITS + usb_bits(UsbBatchHeader.MAX_SIZE + UplinkReadRequest.MAX_SIZE) \
        + usb_bits(UsbBatchHeader.MAX_SIZE + 2 * response)
    return (Terms().add("the write thread's tick jitter (cpu.timer_jitter_us)", v["cpu.timer_jitter_us"])
            .add(f"the last frame on the wire: SOF, NAKed IN, OUT, IN of two {response}-byte responses",
                 wire / v["usb.bitrate"] * 1e6)
            .add("the completion interrupt (usb.hc_irq_us)", v["usb.hc_irq_us"])
            .add("the read thread's wake-up and jitter (cpu.io_wake_us, cpu.io_jitter_us)",
                 v["cpu.io_wake_us"] + v["cpu.io_jitter_us"]))


@dataclass(frozen=True)
class Bound:
    """Fig. 16's bound for one payload under one set of parameters."""

    payload: int
    #: frames each read of a run may take, from its first (index 0) on; the last value holds for all after
    frames: tuple[int, ...]
    path: Terms
    request: Terms
    sync: Terms
    interference: Terms
    cold: Terms
    warm: Terms
    deadline: float

    def frames_of(self, index: int) -> int:
        return self.frames[min(index, len(self.frames) - 1)]

    def ms(self, index: int) -> float:
        """The bound of the run's read `index`, in ms."""
        return self.frames_of(index) + self.path.us / 1000

    @property
    def warm_end(self) -> float:
        """When a warm read's response is in the batch at the latest, after its frame's SOF (us)."""
        return self.request.us + self.sync.us + self.interference.us + self.warm.us

    @property
    def cold_end(self) -> float:
        """As warm_end, for the run's first read (the select written first)."""
        return self.request.us + self.sync.us + self.interference.us + self.cold.us


def bound(v: Mapping[str, float], payload: int) -> Bound:
    """Fig. 16's bound for reads of `payload` bytes under the parameter values `v` (every parameter:
    profiles.model_values)."""
    d = Downlink.of(v)
    req, sync, other = request_terms(v), sync_terms(d), interference_terms(d)
    cold, warm = read_terms(d, payload, True), read_terms(d, payload, False)
    deadline = deadline_us(v)
    frames: list[int] = []
    busy_until = 0.0  # after the SOF: when the downlink is free of the previous frame's late read
    for work in [cold] + [warm] * 8:
        end = max(req.us, busy_until) + sync.us + other.us + work.us
        late = math.ceil((end - deadline) / 1000.0) if end > deadline else 0
        frames.append(3 + late)
        busy_until = end - 1000.0 if late else 0.0  # the next request's frame starts 1 ms later
        if not late and len(frames) > 1:
            break
    return Bound(payload, tuple(frames), path_terms(v, payload), req, sync, other, cold, warm, deadline)


#: The longest payload (an uplink response carries at most 32 data bytes; Fig. 16 goes to 31).
LONGEST_PAYLOAD = 31


def three_frames_ms(v: Mapping[str, float], payload: int = LONGEST_PAYLOAD) -> float:
    """Three frames and the last frame's path to the callback (path_terms), in ms: the round trip of
    a response that is in the batch its frame closes."""
    return 3.0 + path_terms(v, payload).us / 1000


def stretch_budget_us(v: Mapping[str, float], payload: int, select: bool) -> float:
    """The longest clock stretching per byte (Downlink.stretch, us) with which the worst case of a
    `payload`-byte read still has its response in the batch before the next SOF, everything else as
    in `v`: what the paper's three frames need from a node's I2C input path, interrupt entry and
    handler. Negative when even a node that never stretches would not make it."""
    b = bound(v, payload)
    d = Downlink.of(v)
    end = b.cold_end if select else b.warm_end
    n_rx = framed(1 + payload) - 1
    # bytes whose stretching is on the path: the SYNC's, the select's, the read address, then a
    # wait for every data byte (the node loads each one; the bridge's turnaround is shorter)
    stretched = SYNC_BYTES + (2 if select else 0) + 1 + n_rx
    return d.stretch + (b.deadline - end) / stretched


def handler_budget_cycles(v: Mapping[str, float], payload: int, select: bool) -> float:
    """stretch_budget_us as the node's I2C handler length (node.i2c_isr_cycles, before the flash
    wait states' factor), the rest of the stretching (edge, wake-up, entry) as in `v`."""
    d, node = Downlink.of(v), Core.of(v, "node")
    rest = d.stretch - node.us(node.code("i2c_isr_cycles"))
    return (stretch_budget_us(v, payload, select) - rest) * node.hz / 1e6 / (1.0 + 0.5 * node.ws)
