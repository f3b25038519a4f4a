"""SensoRHex on the CAN and RS485 downlinks (issue #39): the latency, synchronisation and control
experiments repeated on bit-timed bus models with the firmware's frames (urb_sim.fieldbus), and the
three downlinks side by side. The nodes on CAN and RS485 run the node library and the SensoRHex
applications (motor, battery, IMU, IR; the probe for the read latency), the objects the I2C world runs.

`can`: the motor nodes on CAN (1 Mb/s; latency also at 500 and 250 kb/s), the slow sensors (battery,
IMU, IR) on RS485 at 115200 Bd. `rs485`: every node on RS485, the motors at 1 Mb/s, the sensors at
115200 Bd. Each criterion's bound is derived from the bus timing (fieldbus/measure.py). The I2C
column is the I2C simulation's measured costs (42 bytes, START/STOP, stretching per motor cycle):
the real-firmware I2C figures are fig16, table1 and fig18_19's. What is idealised is listed in
`ASSUMPTIONS` and in every result's notes.
"""

from __future__ import annotations

import random
from pathlib import Path

from ..fieldbus import can, cores, cycle, measure, rs485
from . import Progress, Result, no_progress, write_csv

ASSUMPTIONS = [
    "bus models in Python, to the bit (CAN) and to the character (RS485); the bridges' masters are the "
    "firmware's (firmware/downlink), every node runs the node library (firmware/node with urb_node_dl.c on its "
    "downlink's slave) and its SensoRHex application (firmware/apps/sensorhex; the probe of sim_apps.c for the read "
    "latency), all from build/sim/liburbsim.so through ctypes; a node's clock is ideal, ticks of 1 us, and its "
    "main loop takes no time",
    "the motor nodes' encoder is set from the PD loop's plant (fieldbus/plant.py) before each update and the "
    "plant follows the voltage the motor application drives; the battery, IMU and IR nodes read stationary values",
    f"a node answers {measure.ASSUME.node_latency_us[0]:g}-{measure.ASSUME.node_latency_us[1]:g} us after a "
    f"request ends, the bridge begins the next transaction {measure.ASSUME.bridge_latency_us[0]:g}-"
    f"{measure.ASSUME.bridge_latency_us[1]:g} us after one ends (uniform draws)",
    f"SYNC time stamps: nodes anywhere on a {measure.ASSUME.cable_m:g}-m cable at "
    f"{measure.ASSUME.prop_ns_per_m:g} ns/m, transceiver receive delays {measure.ASSUME.rx_delay_ns[0]:g}-"
    f"{measure.ASSUME.rx_delay_ns[1]:g} ns per node, edge detection to 1/{measure.ASSUME.quanta_per_bit} bit, "
    f"a {measure.ASSUME.timer_hz / 1e6:g}-MHz timer; the node's interrupt latency is left out (a hardware "
    "time stamp)",
    "CAN errors are seen by every node; no error in the last bit of end of frame; bus-off drops the pending "
    "frames; RS485 characters 8N1, errors flip one bit of a character",
    "the PD controller runs where the feedback arrives (the uplink is left out); the motor's current "
    "follows its voltage at once (no PWM ripple, no ADC noise)",
    "the I2C column is not simulated here: per-byte and per-operation costs measured by the I2C simulation, "
    "without variation",
]

#: the motor downlink of each variant and the side-by-side columns
MOTOR_BUS = {"can": ("can", 1_000_000), "rs485": ("rs485", 1_000_000)}
COLUMNS = (("I2C 400 kb/s", "i2c", 400_000), ("CAN 1 Mb/s", "can", 1_000_000), ("RS485 1 Mb/s", "rs485", 1_000_000))
LATENCY_RATES = {"can": (1_000_000, 500_000, 250_000), "rs485": (1_000_000, 115_200)}
SENSOR_BAUD = 115_200
#: bit error rate of the runs with errors (a noisy motor amplifier)
NOISY_BER = 1e-4


def can_variant(out: Path, *, quick: bool = False, seed: int = 1, progress: Progress = no_progress) -> Result:
    """Motors on CAN, sensors on RS485."""
    return _variant("can", out, quick=quick, seed=seed, progress=progress)


def rs485_variant(out: Path, *, quick: bool = False, seed: int = 1, progress: Progress = no_progress) -> Result:
    """Every node on RS485."""
    return _variant("rs485", out, quick=quick, seed=seed, progress=progress)


def _variant(variant: str, out: Path, *, quick: bool, seed: int, progress: Progress) -> Result:
    out.mkdir(parents=True, exist_ok=True)
    kind, rate = MOTOR_BUS[variant]
    what = {"can": "motors on CAN, sensors on RS485", "rs485": "every node on RS485"}[variant]
    res = Result(variant, f"SensoRHex with {what}: latency, synchronisation, control",
                 "The paper's future work (Sec. VII): CAN and RS485 downlinks")
    res.notes += [f"Model: {a}." for a in ASSUMPTIONS]
    payloads = [1, 6, 7, 8, 13, 31] if quick else list(range(1, 32))
    reads = 10 if quick else 100
    seconds = 1.0 if quick else 4.0

    progress(0.0, f"{variant}: latency")
    _latency(res, out, variant, payloads, reads, seed)
    progress(0.3, f"{variant}: SYNC time stamps")
    _sync(res, kind, rate, 200 if quick else 2000, seed)
    progress(0.45, f"{variant}: PD loop")
    runs = _control(res, kind, rate, seconds, seed)
    progress(0.7, f"{variant}: faults")
    if variant == "can":
        _can_faults(res, seed, 300 if quick else 1500)
    else:
        _rs485_faults(res, seed, 300 if quick else 1500)
        rng = random.Random(f"modbus/{seed}")
        fixed = measure.motor_cycles_us(cycle.Rs485Downlink(rate, rng, measure.MOTORS, modbus_fixed=True,
                                                            apps=measure.motors()), 10, rng)
        res.notes.append(f"With Modbus RTU's fixed silences (t3.5 = {rs485.MODBUS_T35_US} us, t1.5 = "
                         f"{rs485.MODBUS_T15_US} us above 19200 Bd) in place of URB's 3.5 and 1.5 characters, one "
                         f"motor cycle at {rate // 1000} kb/s takes {max(fixed):.0f} us: a loop of "
                         f"{1e6 / max(fixed):.0f} Hz at most, against {runs['clean'].hz} Hz.")
    _sensors(res, seed, 20 if quick else 100)
    progress(0.85, f"{variant}: side by side")
    res.tables.append(("Downlinks side by side (three motors per bus, 6-byte feedback, the PD loop on motor 1)",
                       side_by_side(seed, seconds, runs)))
    res.sim_s = seconds * 3
    return res


def _latency(res: Result, out: Path, variant: str, payloads: list[int], reads: int, seed: int) -> None:
    rows: list[measure.LatencyRow] = []
    frames: list[can.Delivery] = []
    kinds = [(MOTOR_BUS[variant][0], r) for r in LATENCY_RATES[variant]]
    for kind, rate in kinds:
        got, seen = measure.latency(kind, rate, payloads, reads, seed)
        rows += got
        frames += seen
    outside = [f"{r.kind} {r.rate} b/s {r.payload} B: {min(r.samples):.1f}-{max(r.samples):.1f} us, "
               f"bounds {r.lo:.1f}-{r.hi:.1f}" for r in rows if not r.within]
    res.check("read latency within derived bounds",
              "every read between the no-stuff and the worst-case bound (CAN: 47 + 8s and 55 + 10s bits per "
              "frame and the node's latency; RS485: characters, t3.5 + one character per frame end)",
              f"{sum(len(r.samples) for r in rows)} reads at {len(kinds)} rates, {len(outside)} outside"
              + (f": {outside[0]}" if outside else ""), not outside)
    for r in rows:
        mean, mx = measure.summary(r.samples)
        res.table.append({"bus": r.kind, "rate b/s": r.rate, "payload B": r.payload, "mean us": round(mean, 1),
                          "max us": round(mx, 1), "bound us": f"{r.lo:.1f}-{r.hi:.1f}"})
    res.files.append(write_csv(out / "read_latency.csv", ["bus", "rate", "payload", "read", "latency_us"],
                               ([r.kind, r.rate, r.payload, i, f"{s:.3f}"] for r in rows
                                for i, s in enumerate(r.samples))))
    if variant == "can":
        over = [d for d in frames if not measure.frame_within_formula(d)]
        stuffed = max((d.stuff_bits for d in frames), default=0)
        res.check("CAN frames within 47+8s..55+10s bits",
                  "stuffed length of each frame sent (its actual bits) within the no-stuff and Davis et al.'s bounds",
                  f"{len(frames)} frames, {len(over)} outside, up to {stuffed} stuff bits in one frame",
                  not over and stuffed > 0 and len(frames) > 0)


def _sync(res: Result, kind: str, rate: int, cycles: int, seed: int) -> None:
    spreads, bound, stamped = measure.sync_spread(kind, rate, cycles, seed)
    mean, mx = measure.summary(spreads)
    res.check("SYNC inter-node difference within bound",
              f"every SYNC time-stamped by the three motor nodes within {bound:.0f} ns of each other (cable, "
              "transceivers, one time quantum, one timer tick), and by each node library",
              f"{len(spreads)} SYNCs of {cycles}: average {mean:.0f} ns, max {mx:.0f} ns; each node library "
              f"stamped at least {stamped}",
              len(spreads) == cycles and mx <= bound and stamped == cycles)


def _control(res: Result, kind: str, rate: int, seconds: float, seed: int) -> dict[str, measure.LoopRun]:
    clean = measure.pd_loop(kind, rate, seconds, seed)
    noisy = measure.pd_loop(kind, rate, seconds, seed, ber=NOISY_BER)
    ideal = measure.pd_loop(kind, rate, seconds, seed, ideal=True)
    period = 1e6 / clean.hz
    worst = max(clean.cycles_us)
    res.check("motor cycle within worst-case bound and period",
              f"every cycle (SYNC, 3 command writes, 3 feedback reads) within {clean.bound_us:.0f} us, the bound "
              f"from the frame formulas; the loop runs at the highest rate that holds it: {clean.hz} Hz "
              f"({period:.0f} us)",
              f"{len(clean.cycles_us)} cycles, mean {measure.summary(clean.cycles_us)[0]:.0f} us, max {worst:.0f} us",
              worst <= clean.bound_us <= period)
    two = sum(1 for d in clean.delays if d == 2)
    two_noisy = sum(1 for d in noisy.delays if d == 2)
    res.check("sensor-to-actuator delay two periods",
              "every command applied two node periods after the sample it came from (one to read, one to "
              f"write); with a bit error rate of {NOISY_BER:g}, at least 99 %",
              f"{two} of {len(clean.delays)}; with errors {two_noisy} of {len(noisy.delays)} "
              f"({noisy.bus_errors} frames hit by errors, statuses {noisy.statuses})",
              two == len(clean.delays) > 0 and two_noisy >= 0.99 * len(noisy.delays))
    states = {a: st for run in (clean, noisy) for a, st in run.sync_states.items()}
    res.check("motor node heartbeats locked to SYNC",
              "at the end of the clean and the noisy run, every motor node's heartbeat PLL (urb_pll.c) is locked to "
              "the bridge's SYNC",
              f"clean {clean.sync_states}, with errors {noisy.sync_states}",
              bool(states) and set(clean.sync_states.values()) == set(noisy.sync_states.values()) == {"locked"})
    wrong = clean.mismatches + noisy.mismatches
    res.check("transactions carry the node library's mailboxes",
              "every read the master reports OK returned the outbox buffer the node library latched for it, every "
              "write reported OK is what the application's next inbox lock sees",
              f"{clean.verified + noisy.verified} OK transactions checked, {len(wrong)} wrong"
              + (f": {wrong[0]}" if wrong else ""),
              not wrong and clean.verified > 0 and noisy.verified > 0)
    res.check("PD tracking as with instant downlink",
              f"tracking RMS of the 0.5-Hz sinusoid at most 1.05 x the same loop's with instant transactions "
              f"({ideal.rms_rad:.4f} rad)",
              f"{clean.rms_rad:.4f} rad; with errors {noisy.rms_rad:.4f} rad",
              clean.rms_rad <= 1.05 * ideal.rms_rad and noisy.rms_rad <= 1.05 * ideal.rms_rad)
    return {"clean": clean, "noisy": noisy}


def _can_faults(res: Result, seed: int, cycles: int) -> None:
    """A motor node whose transceiver disturbs 60 % of its frames: it must reach bus-off and
    recover (ISO 11898-1), its failures must reach the bridge as I2C's flags, the others go on."""
    d = cycle.CanDownlink(1_000_000, random.Random(f"canfault/{seed}"), measure.MOTORS, tx_fault={2: 0.6},
                          node_latency_us=measure.ASSUME.node_latency_us, apps=measure.motors())
    other = {"OK": 0}
    faulty: dict[str, int] = {}
    for k in range(cycles):
        for a in measure.MOTORS:
            st = d.transact(k * 1000.0, cycle.Txn(a, measure.FEEDBACK_BOX, True, bytes(measure.FEEDBACK_BYTES))).status
            book = faulty if a == 2 else other
            book[st] = book.get(st, 0) + 1
    node = d.nodes[2]
    res.check("faulty node bus-off and recovery",
              "node 2 (60 % of its frames disturbed): bus-off (TEC > 255) and back to error-active after 128 x 11 "
              "recessive bits, at least once each; its failed reads NO_NODE or TIMEOUT only; nodes 1 and 3 all OK",
              f"bus-off {node.bus_off_count} times, recovered {node.recoveries}; node 2 {faulty}; nodes 1, 3 {other}",
              node.bus_off_count > 0 and node.recoveries > 0 and set(faulty) <= {"OK", "NO_NODE", "TIMEOUT"}
              and set(other) == {"OK"})


def _rs485_faults(res: Result, seed: int, polls: int) -> None:
    """Character errors and a stalled node on 1-Mb/s RS485."""
    rng = random.Random(f"rs485fault/{seed}")
    line = rs485.Rs485Line(1_000_000, rng, ber=3 * NOISY_BER)
    node_rx = line.node(1, cores.App("motor"))
    statuses: dict[str, int] = {}
    for k in range(polls):
        read = k % 2 == 1
        box = measure.FEEDBACK_BOX if read else measure.COMMAND_BOX
        st = line.poll(1, box, read, bytes(measure.FEEDBACK_BYTES) if read else measure.motor_command(0.5), node_rx).status
        statuses[st] = statuses.get(st, 0) + 1
    stalled = line.poll(1, measure.FEEDBACK_BOX, True, bytes(measure.FEEDBACK_BYTES), node_rx,
                        stall_us=line.tm.t15_us + 5).status
    allowed = {"OK", "CHECKSUM", "TIMEOUT", "NO_NODE"}
    res.check("RS485 errors reported as I2C flags",
              f"with a bit error rate of {3 * NOISY_BER:g}: failed polls CHECKSUM, TIMEOUT or NO_NODE (a corrupted "
              "address reaches nobody) only, some CHECKSUM; an answer stalled for more than t1.5 inside it: TIMEOUT",
              f"{statuses}; stalled answer {stalled}",
              set(statuses) <= allowed and statuses.get("CHECKSUM", 0) > 0 and stalled == "TIMEOUT")


def _sensors(res: Result, seed: int, rounds: int) -> None:
    """The battery, IMU and IR nodes (their SensoRHex applications) read in turn at 115200 Bd, each at 100 Hz."""
    rng = random.Random(f"sensors/{seed}")
    d = cycle.Rs485Downlink(SENSOR_BAUD, rng, tuple(a for a, _, _ in measure.SENSORS),
                            apps={a: cores.App(app) for a, app, _ in measure.SENSORS})
    worst: list[float] = []
    bound = sum(measure.read_bounds_us("rs485", SENSOR_BAUD, n)[1] + measure.ASSUME.bridge_latency_us[1]
                for _, _, n in measure.SENSORS)
    for k in range(rounds):
        t0 = (k + 1) * 10_000.0  # after the line's start-up silence
        begin = max(t0, d.now_us())
        for a, _, n in measure.SENSORS:
            d.transact(t0, cycle.Txn(a, 1, True, bytes(n)))
        worst.append(d.now_us() - begin)
    sizes = ", ".join(f"{app} ({n} B)" for _, app, n in measure.SENSORS)
    res.check("sensor poll fits 100 Hz",
              f"{sizes} read in turn within the derived {bound:.0f} us, under the 10-ms period; each read the "
              "outbox its application published",
              f"{rounds} rounds, max {max(worst):.0f} us, statuses {d.statuses}, {len(d.mismatches)} reads wrong",
              max(worst) <= bound <= 10_000 and set(d.statuses) == {"OK"} and not d.mismatches)


def side_by_side(seed: int, seconds: float, runs: dict[str, measure.LoopRun]) -> list[dict[str, object]]:
    """One row per metric, one column per downlink (each measured the same way)."""
    cols: dict[str, dict[str, str]] = {}
    for name, kind, rate in COLUMNS:
        lat = measure.latency(kind, rate, [measure.FEEDBACK_BYTES], 20, seed)[0][0].samples
        loop = runs["clean"] if runs["clean"].kind == kind else measure.pd_loop(kind, rate, seconds, seed)
        col = {"6-byte read, mean / max (us)": "%.0f / %.0f" % measure.summary(lat),
               "motor cycle, mean / max / bound (us)": "%.0f / %.0f / %.0f" % (*measure.summary(loop.cycles_us),
                                                                              loop.bound_us),
               "loop rate that fits (Hz)": str(loop.hz),
               "sensor-to-actuator delay (ms)": "%.1f" % (max(loop.delays) * 1000 / loop.hz),
               "PD tracking RMS (rad)": "%.4f" % loop.rms_rad}
        if kind != "i2c":
            spreads, _, _ = measure.sync_spread(kind, rate, 200, seed)
            col["SYNC inter-node difference, avg / max (ns)"] = "%.0f / %.0f" % measure.summary(spreads)
        else:
            col["SYNC inter-node difference, avg / max (ns)"] = "see table1 (real firmware)"
        cols[name] = col
    metrics = list(cols[COLUMNS[1][0]])
    return [{"metric": m, **{name: cols[name][m] for name, _, _ in COLUMNS}} for m in metrics]
