"""The measurements of the downlink comparison (experiments/downlinks.py): read latency against its
bounds, SYNC time stamps, the motor cycle and the PD loop on it, and the fault scenarios.

Every bound is derived from the bus timing: CAN frames from Davis et al.'s 55 + 10 s and the
no-stuff 47 + 8 s (the firmware's `urb_can_frame_bits_max/min`), RS485 from `urb_rs485_timing`
(character, t3.5) and the line's stated latencies, I2C from its per-byte and per-operation costs.
"""

from __future__ import annotations

import math
import random
import statistics
import struct
from dataclasses import dataclass, field

from . import can, cores, cycle, plant, rs485

MOTORS = (1, 2, 3)
#: the slow sensors of SensoRHex's RS232 bridge, (address, application, outbox 1 bytes: sensorhex.urbs's
#: BatteryStatus, ImuSample, IrRange)
SENSORS = ((10, "battery", 19), (11, "imu", 14), (12, "ir", 4))
#: the motor driver's mailboxes (sensorhex.urbs MotorDriver): inbox 1 MotorCommand, inbox 2 MotorConfig,
#: outbox 1 MotorFeedback
COMMAND_BOX, CONFIG_BOX, FEEDBACK_BOX = 1, 2, 1
COMMAND_BYTES, FEEDBACK_BYTES = 2, 6
#: MotorConfig.mode VOLTAGE: the armature voltage follows inbox 1 (the CPU closes the loop)
MODE_VOLTAGE = 1
#: encoder counts per motor revolution of the SensoRHex hip motor (sim/core/motor.c's default)
COUNTS_PER_REV = 2000
LOOP_RATES_HZ = (1000, 500, 250, 100, 50)
#: the RS485 receivers take whole-microsecond stamps (uint32_t us): two frame ends round by up to 1 us each
STAMP_ROUNDING_US = 2.0
#: a receiver starts by waiting for t3.5 of silence (at 115200 Bd 391 us): reads are timed after it
STARTUP_US = 1000.0


@dataclass(frozen=True)
class Assumptions:
    """The idealised parts of the model, each a stated value (sim/README.md, "Downlinks")."""

    node_latency_us: tuple[float, float] = (2.0, 10.0)     # a node's receive interrupt to its answer queued
    bridge_latency_us: tuple[float, float] = (1.0, 3.0)    # the bridge's main loop to the next request
    cable_m: float = 2.0                                   # bus length; nodes anywhere on it
    prop_ns_per_m: float = 5.0                             # twisted pair, about 0.67 c
    rx_delay_ns: tuple[float, float] = (50.0, 125.0)       # a transceiver's bus-to-RXD delay, per node
    quanta_per_bit: int = 16                               # CAN bit timing / UART oversampling
    timer_hz: float = 48e6                                 # the node's time-stamp timer


ASSUME = Assumptions()


def motor_config(mode: int = MODE_VOLTAGE, voltage_limit_mv: int = 12000) -> bytes:
    """A MotorConfig message (mode, kp, kd, target, voltage limit; little-endian as gen/c encodes it)."""
    return struct.pack("<BHHiH", mode, 0, 0, 0, voltage_limit_mv)


def motor_command(volts: float) -> bytes:
    """A MotorCommand message: the armature voltage in mV."""
    return struct.pack("<h", max(-32768, min(32767, round(volts * 1000.0))))


def motors(heartbeat_us: int = 0) -> dict[int, cores.App]:
    """The three motor driver nodes, their heartbeat the loop's period when given."""
    return {a: cores.App("motor", heartbeat_us=heartbeat_us) for a in MOTORS}


def downlink(kind: str, rate: int, rng: random.Random, addresses: tuple[int, ...], ber: float = 0.0,
             tx_fault: dict[int, float] | None = None,
             apps: dict[int, cores.App] | None = None) -> cycle.CanDownlink | cycle.Rs485Downlink | cycle.I2cDownlink:
    """The downlink `kind` at `rate` with nodes at `addresses` running `apps` (default: motor drivers)."""
    apps = apps if apps is not None else motors()
    if kind == "can":
        return cycle.CanDownlink(rate, rng, addresses, ber=ber, tx_fault=tx_fault or {},
                                 node_latency_us=ASSUME.node_latency_us, bridge_latency_us=ASSUME.bridge_latency_us,
                                 apps=apps)
    if kind == "rs485":
        d = cycle.Rs485Downlink(rate, rng, addresses, ber=ber, bridge_latency_us=ASSUME.bridge_latency_us, apps=apps)
        d.line.node_latency_us = ASSUME.node_latency_us
        return d
    return cycle.I2cDownlink(rate)


# ----- bounds ------------------------------------------------------------------------------------

def can_transfer_bits(payload: int, worst: bool) -> int:
    """Bit times of a transfer's frames (the last one without its intermission)."""
    frames = cores.can_transfer(bytes(payload), 0)
    f = cores.frame_bits_max if worst else cores.frame_bits_min
    return sum(f(len(d)) for d in frames) - can.INTERMISSION_BITS


def read_bounds_us(kind: str, rate: int, payload: int) -> tuple[float, float]:
    """(fastest, slowest) a read of `payload` bytes can take, from the bridge's begin to its answer,
    on an idle bus without errors."""
    lat_lo, lat_hi = ASSUME.node_latency_us
    if kind == "can":
        bit = 1e6 / rate
        lo = (cores.frame_bits_min(1) + can_transfer_bits(payload, False)) * bit + lat_lo
        hi = (cores.frame_bits_max(1) + can_transfer_bits(payload, True)) * bit + lat_hi
        return lo, hi
    if kind == "rs485":
        t = rs485.timing(rate)
        ch = rs485.CHAR_BITS * 1e6 / rate
        req, ans = len(cores.rs485_request(1, 0, True)), len(cores.rs485_response(0, 0, bytes(payload)))
        # each frame ends for its receiver one character + t3.5 after its last stop bit (stamps in whole us)
        lo = (req + ans) * ch + 2 * (ch + t.t35_us) + lat_lo + rs485.DRIVER_ENABLE_US[0] - STAMP_ROUNDING_US
        hi = ((req + ans) * ch + 2 * (ch + t.t35_us) + lat_hi + rs485.DRIVER_ENABLE_US[1]
              + rs485.GAP_US[1] * (ans - 1) + STAMP_ROUNDING_US)
        return lo, hi
    d = cycle.I2cDownlink(rate)
    dur = d.transact(0.0, cycle.Txn(1, 1, True, bytes(payload)))
    return dur.done_us - dur.start_us, dur.done_us - dur.start_us


def cycle_bound_us(kind: str, rate: int) -> float:
    """Worst case of one motor cycle: SYNC and, per motor, the command write and the feedback read,
    with the bridge's and the nodes' latencies at their maxima."""
    n = len(MOTORS)
    bridge_hi = ASSUME.bridge_latency_us[1]
    if kind == "can":
        bit = 1e6 / rate
        sync = cores.frame_bits_max(2)
        write = can_transfer_bits(COMMAND_BYTES, True) + can.INTERMISSION_BITS + cores.frame_bits_max(1)
        read = cores.frame_bits_max(1) + can_transfer_bits(FEEDBACK_BYTES, True) + can.INTERMISSION_BITS
        return (sync + n * (write + read)) * bit + 2 * n * (ASSUME.node_latency_us[1] + bridge_hi)
    if kind == "rs485":
        _, read_hi = read_bounds_us("rs485", rate, FEEDBACK_BYTES)
        t = rs485.timing(rate)
        ch = rs485.CHAR_BITS * 1e6 / rate
        req, ans = len(cores.rs485_request(1, 0, False, bytes(COMMAND_BYTES))), len(cores.rs485_response(0, 0))
        write_hi = ((req + ans) * ch + 2 * (ch + t.t35_us) + ASSUME.node_latency_us[1] + rs485.DRIVER_ENABLE_US[1]
                    + rs485.GAP_US[1] * (ans - 1) + STAMP_ROUNDING_US)
        sync_us = len(cores.rs485_sync(0)) * ch + ch + t.t35_us + STAMP_ROUNDING_US
        return sync_us + n * (write_hi + read_hi) + 2 * n * bridge_hi
    d = cycle.I2cDownlink(rate)
    d.sync(0.0, 0)
    for a in MOTORS:
        d.transact(0.0, cycle.Txn(a, 0, False, bytes(COMMAND_BYTES)))
        d.transact(0.0, cycle.Txn(a, 1, True, bytes(FEEDBACK_BYTES)))
    return d.now_us()


def loop_rate(kind: str, rate: int) -> int:
    """The highest loop rate whose period holds the worst-case motor cycle."""
    bound = cycle_bound_us(kind, rate)
    for hz in LOOP_RATES_HZ:
        if bound <= 1e6 / hz:
            return hz
    return LOOP_RATES_HZ[-1]


# ----- latency -----------------------------------------------------------------------------------

@dataclass
class LatencyRow:
    kind: str
    rate: int
    payload: int
    samples: list[float]
    lo: float
    hi: float

    @property
    def within(self) -> bool:
        return all(self.lo - 1e-6 <= s <= self.hi + 1e-6 for s in self.samples)


def frame_within_formula(d: can.Delivery) -> bool:
    """A frame that went through took between 47 + 8s and 55 + 10s bit times on the bus."""
    n = len(d.frame.data)
    return cores.frame_bits_min(n) <= d.end - d.start <= cores.frame_bits_max(n)


def latency(kind: str, rate: int, payloads: list[int], reads: int,
            seed: int) -> tuple[list[LatencyRow], list[can.Delivery]]:
    """`reads` reads of each payload from node 1 on an otherwise idle bus, a probe with an outbox 1 of
    that size (the simulation's probe, as in fig16: an update counter, then a pattern) beside motors
    2 and 3; and every CAN frame that went through."""
    rng = random.Random(f"latency/{kind}/{rate}/{seed}")
    rows = []
    frames: list[can.Delivery] = []
    for p in payloads:
        d = downlink(kind, rate, rng, MOTORS, apps={**motors(), 1: cores.App("probe", out_size=p)})
        samples = []
        for _ in range(reads):
            t = max(d.now_us() + 200.0 + rng.uniform(0.0, 1000.0), STARTUP_US)  # any phase of the probe's updates
            done = d.transact(t, cycle.Txn(1, 1, True, bytes(p)))
            if done.status != "OK":
                raise RuntimeError(f"{kind} read failed without an injected fault: {done.status}")
            samples.append(done.done_us - done.start_us)
        if not isinstance(d, cycle.I2cDownlink) and d.mismatches:
            raise RuntimeError(f"{kind} read returned other data than the node library latched: {d.mismatches[0]}")
        lo, hi = read_bounds_us(kind, rate, p)
        rows.append(LatencyRow(kind, rate, p, samples, lo, hi))
        if isinstance(d, cycle.CanDownlink):
            frames += [x for x in d.bus.log if x.ok]
    return rows, frames


# ----- SYNC time stamps --------------------------------------------------------------------------

def sync_spread(kind: str, rate: int, cycles: int, seed: int) -> tuple[list[float], float, int]:
    """Per SYNC, the largest difference (ns) between the motor nodes' time stamps of it; the bound
    the bus timing gives: propagation over the cable, the transceivers' spread, one time quantum
    of edge detection and one timer tick; and the fewest SYNCs a motor node's library time-stamped
    (its own stamps are whole microseconds: the spread is the model's, at the timer's resolution)."""
    rng = random.Random(f"sync/{kind}/{rate}/{seed}")
    d = downlink(kind, rate, rng, MOTORS)
    place = {a: rng.uniform(0.0, ASSUME.cable_m) * ASSUME.prop_ns_per_m for a in MOTORS}
    rx = {a: rng.uniform(*ASSUME.rx_delay_ns) for a in MOTORS}
    tick = 1e9 / ASSUME.timer_hz
    phase = {a: rng.uniform(0.0, tick) for a in MOTORS}
    quantum = 1e9 / rate / ASSUME.quanta_per_bit
    spreads = []
    for k in range(cycles):
        t = d.sync(k * 1000.0, k & 0xFF)
        if t is None:
            continue
        stamps = []
        for a in MOTORS:
            seen = t * 1000.0 + place[a] + rx[a] + rng.uniform(0.0, quantum)
            stamps.append(math.floor((seen - phase[a]) / tick) * tick)
        spreads.append(max(stamps) - min(stamps))
    bound = (ASSUME.cable_m * ASSUME.prop_ns_per_m + (ASSUME.rx_delay_ns[1] - ASSUME.rx_delay_ns[0])
             + quantum + tick)
    nodes = [d.node(a) for a in MOTORS] if not isinstance(d, cycle.I2cDownlink) else []
    stamped = min((n.syncs()[0] for n in nodes if n is not None), default=0)
    return spreads, bound, stamped


# ----- the motor cycle and the PD loop ------------------------------------------------------------

@dataclass
class LoopRun:
    kind: str
    rate: int
    hz: int
    cycles_us: list[float]
    delays: list[int]                       # sensor-to-actuator delay per applied command, periods
    rms_rad: float
    statuses: dict[str, int] = field(default_factory=dict)
    bound_us: float = 0.0
    #: CAN frames that ended in an error frame, RS485 characters corrupted
    bus_errors: int = 0
    #: OK transactions checked against the node library's buffers, and those it did not hold
    verified: int = 0
    mismatches: list[str] = field(default_factory=list)
    #: each motor node's heartbeat PLL at the end (cores.SYNC_STATE)
    sync_states: dict[int, str] = field(default_factory=dict)


KP, KD = 5.0, 0.05          # V/rad, V s/rad on the motor angle (Figs. 18-19's tuning range)
AMP, FREQ = 4 * math.pi, 0.5


def encoder_count(theta: float) -> int:
    """The quadrature counter of a motor at angle theta (rad), modulo 65536."""
    return math.floor(theta / (2 * math.pi) * COUNTS_PER_REV) & 0xFFFF


def unwrap(count: int, last: int | None, position: int) -> int:
    """The unwrapped position after a reading `count`, from the previous reading and position."""
    if last is None:
        return count if count < 0x8000 else count - 0x10000
    step = (count - last) & 0xFFFF
    return position + (step if step < 0x8000 else step - 0x10000)


def pd_loop(kind: str, rate: int, seconds: float, seed: int, ber: float = 0.0, hz: int | None = None,
            ideal: bool = False) -> LoopRun:
    """The hip PD loop of Figs. 18-19 on motor 1, with motors 2 and 3 sharing the bus, at `hz` (default:
    the highest rate the worst-case cycle fits). Every period: SYNC, then per motor its command write
    (MotorCommand, inbox 1) and its feedback read (MotorFeedback, outbox 1). On CAN and RS485 the motor
    nodes run the node library and the SensoRHex motor application in VOLTAGE mode (a MotorConfig write
    first), their heartbeat locked to the SYNC: at each update the application samples the encoder
    (set from the plant's angle), publishes the feedback and applies the newest command; the
    controller (at the bridge, the uplink left out) decodes the encoder from the feedback read in one
    period and writes in the next: two periods of sensor-to-actuator delay when every cycle fits.
    The I2C column (durations only) and `ideal` (every transaction instant) apply the newest command
    at the next period's start instead; the delay is still two periods."""
    rng = random.Random(f"loop/{kind}/{rate}/{seed}")
    hz = hz or loop_rate(kind, rate)
    period = 1e6 / hz
    d = downlink(kind, rate, rng, MOTORS, ber=ber, apps=motors(round(period)))
    motor = plant.Motor()
    run = LoopRun(kind, rate, hz, [], [], 0.0, bound_us=cycle_bound_us(kind, rate))
    node = None if ideal or isinstance(d, cycle.I2cDownlink) else d.node(1)
    if node is not None:  # period 0: every motor into VOLTAGE mode
        for a in MOTORS:
            d.transact(0.0, cycle.Txn(a, CONFIG_BOX, False, motor_config()))
    written: tuple[float, int] | None = None         # motor 1's newest command written: (volts, from sample k)
    inbox: tuple[float, int, float] | None = None    # without a node: (volts, from sample k, arrived at us)
    to_write: tuple[float, int] | None = None        # the controller's newest command, not yet written
    drives = 0
    last_count: int | None = None
    position = 0
    prev_err: float | None = None
    sq, n_err = 0.0, 0
    for k in range(int(seconds * hz)):
        t0 = (k + 1) * period
        motor.advance(t0 / 1e6)
        if node is None and inbox is not None and inbox[2] < t0:  # the update: the newest command
            motor.drive(inbox[0])
            run.delays.append(k - inbox[1])
            inbox = None
        theta = motor.theta
        if node is not None:
            node.motor_sample(encoder_count(theta), 0, round(motor.volts * 1000.0))
        if k > hz // 2:
            sq += (theta - AMP * math.sin(2 * math.pi * FREQ * t0 / 1e6)) ** 2
            n_err += 1
        sample: float | None = theta
        if ideal:
            if to_write is not None:
                inbox = (to_write[0], to_write[1], t0)
        else:
            begin = max(t0, d.now_us())
            d.sync(begin, k & 0xFF)
            if node is not None:
                drives = _applied(node, motor, drives, written, k, run)
            for a in MOTORS:
                if a != 1:
                    d.transact(t0, cycle.Txn(a, COMMAND_BOX, False, motor_command(rng.uniform(-1.0, 1.0))))
                elif to_write is not None:  # without a sample the controller holds its command: no write
                    w = d.transact(t0, cycle.Txn(a, COMMAND_BOX, False, motor_command(to_write[0])))
                    if w.status == "OK":
                        written = to_write
                        inbox = (to_write[0], to_write[1], w.done_us)
                r = d.transact(t0, cycle.Txn(a, FEEDBACK_BOX, True, bytes(FEEDBACK_BYTES)))
                if a == 1:
                    sample = None
                    if r.status == "OK" and node is not None:
                        position = unwrap(struct.unpack_from("<H", r.data)[0], last_count, position)
                        last_count = struct.unpack_from("<H", r.data)[0]
                        sample = (position + 0.5) * 2 * math.pi / COUNTS_PER_REV
                    elif r.status == "OK":
                        sample = theta
            run.cycles_us.append(d.now_us() - begin)
        to_write = None
        if sample is not None:
            err = sample - AMP * math.sin(2 * math.pi * FREQ * t0 / 1e6)
            de = 0.0 if prev_err is None else (err - prev_err) / (period / 1e6)
            prev_err = err
            to_write = (-(KP * err + KD * de), k)
    run.rms_rad = math.sqrt(sq / max(1, n_err))
    if isinstance(d, cycle.CanDownlink):
        run.bus_errors = d.bus.errors
    if isinstance(d, cycle.Rs485Downlink):
        run.bus_errors = d.line.corrupted
    if not isinstance(d, cycle.I2cDownlink):
        run.statuses = dict(d.statuses)
        run.verified, run.mismatches = d.verified, list(d.mismatches)
        run.sync_states = {a: n.sync_state() for a in MOTORS if (n := d.node(a)) is not None}
    return run


def _applied(node: cores.DlNode, motor: plant.Motor, drives: int, written: tuple[float, int] | None, k: int,
             run: LoopRun) -> int:
    """After period k's SYNC: the motor application's update of this period has run; the plant follows
    what it drove, and an update that took a new command records that command's delay."""
    n, mv, fresh, _ = node.motor_drive()
    if n != drives:
        motor.drive(mv / 1000.0)
        if fresh and written is not None:
            run.delays.append(k - written[1])
    return n


def motor_cycles_us(d: cycle.CanDownlink | cycle.Rs485Downlink | cycle.I2cDownlink, cycles: int,
                    rng: random.Random) -> list[float]:
    """Durations of `cycles` motor cycles (SYNC, then per motor its command write and feedback read)
    run back to back."""
    out = []
    for k in range(cycles):
        begin = d.now_us()
        d.sync(begin, k & 0xFF)
        for a in MOTORS:
            d.transact(begin, cycle.Txn(a, COMMAND_BOX, False, motor_command(rng.uniform(-1.0, 1.0))))
            d.transact(begin, cycle.Txn(a, FEEDBACK_BOX, True, bytes(FEEDBACK_BYTES)))
        out.append(d.now_us() - begin)
    return out


def summary(values: list[float]) -> tuple[float, float]:
    return (statistics.fmean(values), max(values)) if values else (math.nan, math.nan)
