"""Bandwidth limits: the highest loop rate and payload each uplink sustains without missed
deadlines.

Part 1, uplink capacity: one probe node on one bridge; the 1-kHz host loop submits k reads of a
p-byte outbox per tick. A load is SUSTAINED when every request completes OK and the latency stays
within 1 ms of the payload's unloaded latency (k = 1) without growing from the first half of the
run to the second (no backlog). For each uplink and payload the largest sustained k (reads per
millisecond) is found by bisection over 1..15 (15 = the host window, Bridge.tla's HostWindow).

Part 2, the SensoRHex motor workload: m = 1..3 motor driver nodes on one USB bridge, each read
(MotorFeedback) and commanded (MotorCommand) once per loop period, at 1 kHz and 500 Hz, with the
same deadline rule. The downlink's occupancy per cycle is reported next to it.

Part 3, where the time goes: a bus trace of the 3-motor workload split into wire time, START/STOP,
clock stretching, the bridge's turnaround and bus-free time per transaction kind (i2c_breakdown.csv),
checked against the busy time of part 2, with what each saving the protocol permits would give.
"""

from __future__ import annotations

import json
import statistics
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

from urb.managers.base import encode_message
from urb_msgs.sensorhex import MotorCommand, MotorConfig, MotorFeedback

from .. import profiles
from ..chost import CHost
from ..native import App, Trace
from ..system import NS_PER_MS, Loop, System
from . import Progress, Result, no_progress, pyplot, write_csv
from .control import ENABLE, _enable, other_host, resolve_host
from .usb_bound import three_frames_ms

USB_FRAME_MS = 1.0


class Answered(Protocol):
    """What _judge needs of a request: a NodeRequest, or an Answer of the C host's records."""

    @property
    def ok(self) -> bool: ...

    @property
    def latency_ns(self) -> int | None: ...


@dataclass(frozen=True)
class Answer:
    """A request of the C host (urb_sim.chost.Request) as _judge sees it."""

    ok: bool
    latency_ns: int | None


def _answers(chost: CHost, read_only: bool) -> list[Answer]:
    """The C host's requests in submission order (its reads only when `read_only`), as NodeRequests'
    ok and latency (submission to completion: to the callback, which runs at the same instant)."""
    return [Answer(r.done_ns is not None and r.flags == 0, None if r.done_ns is None else r.done_ns - r.submitted_ns)
            for r in chost.requests() if r.read or not read_only]


def _judge(reqs: Sequence[Answered], base_max: float | None, frame_ms: float = 0.0) -> tuple[bool, float, float]:
    """(sustained, mean ms, max ms) of a run's requests. `frame_ms`: how far apart two requests'
    latencies may be without a backlog (USB: a frame, where the frames start right at the write
    thread's wake-up and each request makes its frame or waits for the next by the jitter)."""
    ok = [r for r in reqs if r.ok and r.latency_ns is not None]
    if len(ok) != len(reqs) or not ok:
        return False, float("nan"), float("nan")
    lat = [r.latency_ns / 1e6 for r in ok if r.latency_ns is not None]
    half = len(lat) // 2
    grows = max(lat[half:]) > max(lat[:half]) + frame_ms + 0.2
    within = base_max is None or max(lat) <= base_max + 1.0
    return (not grows) and within, statistics.mean(lat), max(lat)


def probe_load(uplink: str, payload: int, per_tick: int, ms: int, seed: int,
               host: str = "python") -> tuple[list[Answered], float]:
    """`per_tick` reads of the probe per 1-ms tick for `ms` ticks, on the Python or the C host library:
    the requests in submission order and the downlink's busy share."""
    s = System(seed=seed, probe_out=payload)
    b = s.bridge(uplink)
    s.node(b, App.PROBE, 0x10, 0)
    s.start()
    if host == "c":
        busy0, t0 = s.world.stat("i2c.busy_ns", b), s.world.now
        chost = CHost(s)
        for _ in range(per_tick):
            chost.read(b, 0x10, 1, payload, 1)
        chost.loop(NS_PER_MS, ms, 0)
        chost.advance_to(s.world.now + (ms + 300) * NS_PER_MS)
        busy = (s.world.stat("i2c.busy_ns", b) - busy0) / max(1, s.world.now - t0 - 300 * NS_PER_MS)
        answers: list[Answered] = list(_answers(chost, read_only=True))
        chost.close()
        s.close()
        return answers, busy
    node = s.urb.find_node(0x7E, 0)
    reqs: list[Answered] = []

    def tick() -> None:
        for _ in range(per_tick):
            r = node.new_request().read(1, payload)
            reqs.append(r)
            node.submit_request(r)

    busy0, t0 = s.world.stat("i2c.busy_ns", b), s.world.now
    Loop(s.host, NS_PER_MS, tick, count=ms)
    s.host.advance((ms + 300) * NS_PER_MS)
    busy = (s.world.stat("i2c.busy_ns", b) - busy0) / max(1, s.world.now - t0 - 300 * NS_PER_MS)
    s.close()
    return reqs, busy


def max_reads_per_ms(uplink: str, payload: int, ms: int, seed: int, host: str = "python") -> tuple[int, float, float]:
    """(largest sustained reads per ms, its mean latency, the unloaded max latency)."""
    frame = USB_FRAME_MS if uplink == "usb" else 0.0
    base, _ = probe_load(uplink, payload, 1, ms, seed, host)
    ok1, _, base_max = _judge(base, None, frame)
    if not ok1:
        return 0, float("nan"), base_max
    lo, hi = 1, 15
    best_mean = _judge(base, base_max, frame)[1]
    while lo < hi:
        mid = (lo + hi + 1) // 2
        reqs, _ = probe_load(uplink, payload, mid, ms, seed, host)
        good, mean, _ = _judge(reqs, base_max, frame)
        if good:
            lo, best_mean = mid, mean
        else:
            hi = mid - 1
    return lo, best_mean, base_max


def motor_load(motors: int, rate_hz: int, ms: int, seed: int, host: str = "python") -> tuple[bool, float, float, float]:
    """(sustained, mean ms, max ms, I2C time per loop cycle in us, SYNC broadcasts included) for
    `motors` motor nodes on one USB bridge, each read and commanded once per period, on the Python
    or the C host library."""
    s = System(seed=seed)
    b = s.bridge("usb")
    for i in range(motors):
        s.node(b, App.MOTOR, 0x20 + i, i)
    s.start()
    accs = [s.urb.find_node("MotorDriver", i) for i in range(motors)]
    from .control import Axis, Pd

    chost = CHost(s) if host == "c" else None
    for i, a in enumerate(accs):
        if chost is None:
            _enable(Axis(a, Pd(0.0, 0.0)))
        else:
            chost.submit_write(b, 0x20 + i, a.mailbox_of(MotorConfig, "inbox"), encode_message(ENABLE))
    reads: list[Answered] = []

    def tick() -> None:
        for a in accs:
            r = a.new_request().read_message(MotorFeedback)
            reads.append(r)
            a.submit_request(r)
            a.submit_request(a.new_request().write_message(MotorCommand(voltage=0)))

    period = NS_PER_MS * 1000 // rate_hz
    cycles = ms * rate_hz // 1000
    busy0 = s.world.stat("i2c.busy_ns", b)
    syncs0 = s.world.stat("bridge.syncs", b)
    if chost is None:
        Loop(s.host, period, tick, count=cycles)
        s.host.advance((ms + 300) * NS_PER_MS)
    else:
        for i, a in enumerate(accs):
            chost.read(b, 0x20 + i, a.mailbox_of(MotorFeedback, "outbox"), 6, 1)
            chost.write(b, 0x20 + i, a.mailbox_of(MotorCommand, "inbox"), encode_message(MotorCommand(voltage=0)), 1)
        chost.loop(period, cycles, 0)
        chost.advance_to(s.world.now + (ms + 300) * NS_PER_MS)
        reads = list(_answers(chost, read_only=True))  # the enables are writes: not among them
        chost.close()
    # I2C time the loop's cycles needed, with one SYNC per millisecond of loop time (SYNCs sent
    # while a backlog drains after the loop are not the loop's)
    busy = s.world.stat("i2c.busy_ns", b) - busy0
    syncs = s.world.stat("bridge.syncs", b) - syncs0
    sync_ns = 78_000.0  # one 3-byte SYNC with its START/STOP and stretching, ~78 us in the traces
    per_cycle_us = (busy - max(0.0, syncs - ms) * sync_ns) / cycles / 1000
    s.close()
    # USB: within a frame of three frames and the longest last-frame path (Fig. 16, usb_bound)
    good, mean, mx = _judge(reads, three_frames_ms(profiles.model_values()), USB_FRAME_MS)
    return good, mean, mx, per_cycle_us


@dataclass
class Breakdown:
    """Where the I2C time of one 1-kHz SensoRHex cycle on a USB bridge's downlink goes: per
    transaction kind (SYNC, command write, feedback read) its count per cycle, bytes, wire time
    (9 bit times per byte with its ACK), START + STOP, and the measured rest (clock stretching by
    the nodes' interrupt handlers plus the bridge's turnaround before each operation), then the
    bus-free time between transactions. Measured on the 3-motor workload at 500 Hz (sustained,
    so no backlog distorts it), one SYNC per millisecond counted as the 1-kHz cycle needs."""

    rows: list[dict[str, object]]
    cycle_us: float          # one 1-kHz cycle: mean measured transaction spans + bus-free time
    traced_us: float         # START-to-STOP spans of the window's complete transactions (trace)
    busy_us: float           # the bus's own busy counter over the window (one transaction cut by
                             # the window's start is in it, not in the trace: < 0.2 %)
    stretch_us: float        # of the overhead: clock stretching (the bus's own counter)
    turnaround_us: float     # of the overhead: the bridge issuing the next operation
    bytes_per_cycle: int
    transactions: int
    t_bit_us: float
    t_buf_us: float


def i2c_breakdown(seed: int, cycles: int, out: Path) -> Breakdown:
    """Trace `cycles` 2-ms cycles of 3 motors on one USB bridge at 500 Hz and split the downlink
    time of one motor cycle plus one SYNC (what 1 kHz needs per millisecond) into its parts."""
    s = System(seed=seed)
    b = s.bridge("usb")
    for i in range(3):
        s.node(b, App.MOTOR, 0x20 + i, i)
    s.start()
    accs = [s.urb.find_node("MotorDriver", i) for i in range(3)]
    from .control import Axis, Pd

    for a in accs:
        _enable(Axis(a, Pd(0.0, 0.0)))

    def tick() -> None:
        for a in accs:
            a.submit_request(a.new_request().read_message(MotorFeedback))
            a.submit_request(a.new_request().write_message(MotorCommand(voltage=0)))

    Loop(s.host, 2 * NS_PER_MS, tick)
    s.host.advance(20 * NS_PER_MS)  # steady state
    path = out / "trace_i2c_breakdown.ndjson"
    stretch0, busy0 = s.world.stat("i2c.stretch_ns", b), s.world.stat("i2c.busy_ns", b)
    s.world.trace(path, Trace.BUS)
    s.host.advance(cycles * 2 * NS_PER_MS)
    s.world.flush_trace()
    stretch = s.world.stat("i2c.stretch_ns", b) - stretch0
    busy = s.world.stat("i2c.busy_ns", b) - busy0
    t_bit = 1e9 / s.world.get("i2c.bitrate")
    s.close()
    t_start = t_stop = t_bit  # i2c.h: START 1 t_bit, STOP 1 t_bit, then t_buf before a START
    t_buf = 1300.0
    dev = f"usb{b}/i2c"
    txns: list[tuple[str, int, float]] = []  # (kind, bytes, START-to-STOP span ns)
    begin: float | None = None  # a transaction cut by the window's start is not counted
    nbytes, kind = 0, ""
    with path.open() as f:
        for line in f:
            if '"cat":"bus"' not in line or f'"dev":"{dev}"' not in line:
                continue
            d = json.loads(line)
            if d["ev"] == "start":
                begin, nbytes, kind = d["t"] - t_start, 0, ""  # logged when the START is complete
            elif d["ev"] in ("w", "r"):
                if nbytes == 0:
                    kind = "SYNC" if d["byte"] == 0 else ("read" if d["byte"] & 1 else "write")
                nbytes += 1
            elif d["ev"] == "stop":
                if begin is not None and kind:
                    txns.append((kind, nbytes, d["t"] - begin))
                begin = None
    rows: list[dict[str, object]] = []
    span_sum = 0.0
    nb_cycle = 0.0
    per_cycle = {"SYNC": 1, "write": 3, "read": 3}  # the 1-kHz workload: one SYNC, each motor written and read
    count_cycle = sum(per_cycle.values())
    for k, count in per_cycle.items():
        sel = [(n, sp) for kk, n, sp in txns if kk == k]
        nb = count * statistics.mean(n for n, _ in sel)
        span = count * statistics.mean(sp for _, sp in sel)
        wire = nb * 9 * t_bit
        ss = count * (t_start + t_stop)
        rows.append({"transaction": k, "per 1-ms cycle": count, "bytes": round(nb, 2),
                     "wire us (9 bits/byte)": round(wire / 1e3, 1), "START+STOP us": round(ss / 1e3, 1),
                     "stretch + turnaround us": round((span - wire - ss) / 1e3, 1), "total us": round(span / 1e3, 1)})
        span_sum += span
        nb_cycle += nb
    # clock stretching of the window (the bus's counter), per byte, times the cycle's bytes
    stretch_cycle = stretch / max(1, sum(n for _, n, _ in txns)) * nb_cycle
    free = count_cycle * t_buf
    rows.append({"transaction": "bus free between transactions (t_buf)", "per 1-ms cycle": round(count_cycle, 2),
                 "bytes": "", "wire us (9 bits/byte)": "", "START+STOP us": "", "stretch + turnaround us": "",
                 "total us": round(free / 1e3, 1)})
    total = span_sum + free
    overhead = span_sum - nb_cycle * 9 * t_bit - count_cycle * (t_start + t_stop)
    return Breakdown(rows, total / 1e3, sum(sp for _, _, sp in txns) / 1e3, busy / 1e3, stretch_cycle / 1e3, (overhead - stretch_cycle) / 1e3, round(nb_cycle),
                     count_cycle, t_bit / 1e3, t_buf / 1e3)


def breakdown_note(bd: Breakdown) -> str:
    """The finding, with the numbers of `bd` and what each protocol-permitted saving would give."""
    per_byte = (bd.stretch_us + bd.turnaround_us) / bd.bytes_per_cycle
    wire = bd.bytes_per_cycle * 9 * bd.t_bit_us
    restart = 3 * (bd.t_bit_us + bd.t_buf_us + bd.t_bit_us - 1.5 * bd.t_bit_us)
    sync = next(float(str(r["total us"])) for r in bd.rows if r["transaction"] == "SYNC") + bd.t_buf_us
    framing = 3 * 3 * 9 * bd.t_bit_us  # per motor: write select + write check + read check
    small = 3 * (9 * bd.t_bit_us + per_byte)  # one feedback byte less per motor
    return (
        f"Where the 1-kHz cycle goes (3 motors on one USB bridge, 400 kb/s): {bd.transactions} transactions, "
        f"{bd.bytes_per_cycle} bytes = {wire:.1f} us of wire time alone (3 x (5-byte command write + 8-byte "
        f"feedback read) + a 3-byte SYNC, 9 bit times per byte with its ACK), {bd.transactions} x START+STOP = "
        f"{bd.transactions * 2 * bd.t_bit_us:.1f} us, clock stretching by the nodes' I2C interrupt (latency + "
        f"handler) {bd.stretch_us:.1f} us, the bridge's turnaround before each operation {bd.turnaround_us:.1f} us "
        f"({per_byte:.2f} us per byte together), bus-free time {bd.transactions * bd.t_buf_us:.1f} us: "
        f"{bd.cycle_us:.1f} us per 1000-us cycle. Savings the downlink protocol permits without changing "
        f"MailboxInbox/MailboxOutbox or the paper's payloads (6-byte feedback, 2-byte command): a write and the read "
        f"of the same node in one transaction with a repeated START saves {restart:.1f} us; a SYNC only every "
        f"other millisecond (the nodes' PLL measures the period across counter gaps) saves {sync / 2:.1f} us on average ({sync:.1f} us in the cycles without it). Together "
        f"{bd.cycle_us - restart - sync:.1f} us in the best cycle and {bd.cycle_us - restart - sync / 2:.1f} us on "
        f"average: over budget. A 5-byte feedback (12-bit current and voltage) would save another {small:.1f} us "
        f"but departs from the paper's 6-byte payload, and even all three together need "
        f"{bd.cycle_us - restart - small:.1f} us in the cycles that carry a SYNC, a "
        f"{1000 - (bd.cycle_us - restart - small):.0f}-us margin for the bridge's USB handling and queueing. No "
        f"honest fix within the paper's payloads exists, so the gait stays at "
        f"500 Hz (1 kHz is reported). The integrity bytes URB adds per motor (write select + link check, read "
        f"check: 3 bytes) cost {framing:.1f} us per cycle, which is the paper's margin: its 1-kHz six-leg figure "
        f"implies a leaner downlink framing than URB's checked one.")


def bandwidth(out: Path, *, quick: bool = False, seed: int = 600, progress: Progress = no_progress,
              host: str | None = None) -> Result:
    """`host`: the host library the loads run on (control.HOSTS; None: $URB_SIM_HOST, else python);
    the overloaded 3-motor 1-kHz load is repeated on the other one and the two must agree."""
    host = resolve_host(host)
    res = Result("bandwidth", "Bandwidth limits: the highest loop rate and payload each uplink sustains"
                 + (" (on the C host library)" if host == "c" else ""),
                 "RS232: up to 10-byte payloads at 1 kHz; USB: 31-byte payloads at 1 kHz, the I2C downlink and "
                 "the bridge becoming the bottleneck; six motors at 1 kHz through two USB bridges")
    out.mkdir(parents=True, exist_ok=True)
    ms = 150 if quick else 400
    payloads = {"rs232": [1, 6, 9] if quick else [1, 2, 4, 6, 8, 9, 10, 16, 31],
                "usb": [1, 6, 31] if quick else [1, 2, 4, 6, 8, 16, 24, 31]}
    t0 = time.perf_counter()
    rows: list[list[object]] = []
    n_steps = sum(len(v) for v in payloads.values()) + 6
    step = 0
    caps: dict[tuple[str, int], int] = {}
    for uplink, ps in payloads.items():
        for p in ps:
            progress(step / n_steps, f"bandwidth: {uplink}, {p}-byte reads")
            step += 1
            k, mean, base = max_reads_per_ms(uplink, p, ms, seed, host)
            caps[(uplink, p)] = k
            rows.append([uplink, p, k, k * 1000, round(mean, 3), round(base, 3)])
            res.table.append({"uplink": uplink, "payload B": p, "reads per ms sustained": k,
                              "read rate /s": k * 1000, "latency mean ms": round(mean, 3),
                              "unloaded max ms": round(base, 3)})
    res.files.append(write_csv(out / "bandwidth_uplinks.csv", ["uplink", "payload_bytes", "reads_per_ms",
                                                                 "reads_per_s", "latency_mean_ms",
                                                                 "unloaded_max_latency_ms"], rows))
    mrows: list[tuple[int, int, bool, float, float, float]] = []
    motor_ok: dict[tuple[int, int], bool] = {}
    for m in (1, 2, 3):
        for rate in (1000, 500):
            progress(step / n_steps, f"bandwidth: {m} motor(s) per USB bridge at {rate} Hz")
            step += 1
            good, mean, mx, busy = motor_load(m, rate, ms, seed, host)
            motor_ok[(m, rate)] = good
            mrows.append((m, rate, good, round(mean, 3), round(mx, 3), round(busy, 1)))
            if (m, rate) == (3, 1000):  # the overloaded load, its queues growing: the reference run
                other = motor_load(m, rate, ms, seed, other_host(host))
                agree = other == (good, mean, mx, busy)
                res.check("host libraries agree", "the 3-motor 1-kHz load (overloaded) on the Python and on the C "
                          "host library: the same verdict, mean and max read latency and I2C time per cycle",
                          f"{mean:.6f} / {mx:.6f} ms, {busy:.3f} us per cycle: " + ("equal" if agree else
                                                                                  f"the other host: {other}"), agree)
    res.files.append(write_csv(out / "bandwidth_motors.csv", ["motors_per_bridge", "loop_hz", "sustained",
                                                                "read_latency_mean_ms", "read_latency_max_ms",
                                                                "i2c_us_per_cycle"],
                               ((m, r, int(g), a, x, u) for m, r, g, a, x, u in mrows)))
    progress(1.0, "bandwidth: done")
    res.wall_s = time.perf_counter() - t0
    res.sim_s = (sum(len(v) for v in payloads.values()) * 4 + 7) * (ms + 360) / 1000
    usb_limit = three_frames_ms(profiles.model_values()) + 1.0
    res.tables.append((
        "SensoRHex motor workload on one USB bridge: each motor read (MotorFeedback) and commanded (MotorCommand) "
        f"once per loop period. Sustained: every read OK, the max latency at most three frames and the last "
        f"frame's path (Fig. 16, usb_bound) + 1 ms ({usb_limit:.3f} ms) and not growing from the first half of the "
        "run to the second (no backlog); "
        "data: bandwidth_motors.csv",
        [{"motors per bridge": m, "loop rate Hz": rate, "loop period us": round(1e6 / rate),
          "sustained": "yes" if good else "NO", "read latency mean ms": mean, "read latency max ms": mx,
          "I2C us per loop cycle (SYNCs included)": us} for m, rate, good, mean, mx, us in mrows]))
    rs_max = max((p for (u, p), k in caps.items() if u == "rs232" and k >= 1), default=0)
    res.check("RS232 payload at 1 kHz", "the largest sustained payload at one read per ms is >= 9 bytes "
              "(10 in the paper, whose 12-byte response is 4 % over the line)", f"{rs_max} bytes", rs_max >= 9)
    if rs_max < 10:
        res.deviations.append(f"bandwidth: RS232 sustains {rs_max}-byte reads at 1 kHz, not the paper's 10 (a 10-byte "
                              "response is 12 characters, 1.042 ms of line time at 115200 Bd)")
    usb31 = caps.get(("usb", 31), 0)
    res.check("USB 31-byte payload at 1 kHz", "a 31-byte read per ms is sustained", f"{usb31} per ms", usb31 >= 1)
    res.check("motor workload", "two motors per USB bridge at 1 kHz and three at 500 Hz are sustained",
              f"2 @ 1 kHz: {'yes' if motor_ok[(2, 1000)] else 'no'}, 3 @ 500 Hz: {'yes' if motor_ok[(3, 500)] else 'no'}",
              motor_ok[(2, 1000)] and motor_ok[(3, 500)])
    if not motor_ok[(3, 1000)]:
        busy_us = next(us for m, rate, _, _, _, us in mrows if (m, rate) == (3, 1000))
        res.deviations.append(f"bandwidth: three motors per USB bridge at 1 kHz (the paper's six legs on two bridges) "
                              f"are not sustained: their downlink is busy {busy_us:.0f} us of each 1000-us cycle")
    res.notes.append(
        "Three motors per USB bridge at 1 kHz (the paper's Fig. 14 under 1-kHz control): "
        + ("sustained." if motor_ok[(3, 1000)] else
           "NOT sustained: 3 x (5-byte command write + 8-byte feedback read) + a 3-byte SYNC need more than one "
           "millisecond of 400-kb/s I2C once START/STOP, the bus-free time and clock stretching are counted "
           "(see bandwidth_motors.csv for the occupancy)."))
    progress(1.0, "bandwidth: I2C time breakdown of the 1-kHz motor cycle")
    bd = i2c_breakdown(seed, 40 if quick else 150, out)
    res.files.append(write_csv(out / "i2c_breakdown.csv", list(bd.rows[0]), ([r[k] for k in bd.rows[0]] for r in bd.rows)))
    res.check("I2C breakdown accounts for the bus time", "the traced transactions the breakdown is built from "
              "add up to the bus's own busy counter over the same window within 1 %",
              f"{bd.traced_us:.1f} us traced vs {bd.busy_us:.1f} us busy", abs(bd.traced_us - bd.busy_us) <= 0.01 * bd.busy_us)
    res.notes.append(breakdown_note(bd))
    res.files.append(_plot(out / "bandwidth.png", caps, payloads))
    return res


def _plot(path: Path, caps: dict[tuple[str, int], int], payloads: dict[str, list[int]]) -> Path:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 4))
    for uplink, ps in payloads.items():
        ax.plot(ps, [caps[(uplink, p)] for p in ps], "o-", label=uplink.upper())
    ax.set_xlabel("read payload (bytes)")
    ax.set_ylabel("reads per ms sustained")
    ax.set_title("Highest sustained read rate (1-kHz host loop, one node)")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
