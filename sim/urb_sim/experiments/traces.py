"""Trace validation: TLC checks traces logged by the simulation against every module of spec/tla/
(sim/tla/TraceBridge.tla, TraceOutbox.tla, TraceInbox.tla, TraceUsbUplink.tla, TraceDiscovery.tla,
sim/urb_sim/tracecheck.py).

Checks: a fault-free bridge trace of each uplink is a behaviour of Bridge.tla; three mutated
traces (a changed status, a dropped response, two responses swapped) are not (the check is not
vacuous); a node's outbox trace from power-on (application releases, the interrupt's reads byte by
byte, every byte naming the write it came from) is a behaviour of MailboxOutbox.tla, and the same
trace with one byte from an older write is not; a node's inbox trace from power-on under I2C bit
errors (the interrupt's write begins, stores, commits and aborts; the application's locks, reads and
releases) is a behaviour of MailboxInbox.tla and contains aborted writes, while the same trace with a
torn read (one byte of a lock from an older write) or with an aborted write made visible (the next
lock hands out the buffer the aborted write was filling) is not; a USB bridge trace under I2C bit
errors is a behaviour of Bridge.tla with every downlink fault, and holds some of them
(CHECKSUM answers at least); the host library's view of a USB uplink (submissions, the bulk-OUT
batch of every frame, the responses of every bulk-IN transfer, the callbacks, each in its 1-ms
frame) is a behaviour of UsbUplink.tla with every callback within three frames of its submission,
while the same trace with a batch's responses one frame late, two requests of a batch swapped or two
callbacks swapped is not; at the motor load of one USB bridge in Fig. 20 (three reads and three
writes per batch) the downlink outlasts the frame and the trace is rejected at the first bulk-IN
transfer that carries only part of a batch (a measured limit of UsbUplink.tla's premise, not a
bug), and over several phases of the USB frames against the OS tick TLC accepts exactly the traces
whose callbacks all come within 3 host frames (the premise that the tick is the frame); the host
library's discovery of two bridges (a node powered off before it, a duplicate, a foreign layout, a
node powered off after it and read again) is a behaviour of Discovery.tla, while the same trace with
a scan naming another identity, a duplicate flagged on one row only or two duplicates merged into
one row is not. Every mutated trace must be rejected where its mutation is: TLC matches every event
before the first mutated one.

Which traces depend on the host library: all of them, through the requests it makes the bridge
serve. The bridge traces and the mailbox (outbox, inbox) traces are the world's (the firmware's
events), so with `host="c"` (`urb sim sensorhex --host c`) they are recorded on the C host library
(urb_sim.chost) and recorded again on the Python one, and must be the same byte for byte (criterion
"host libraries agree"; the same traces, so the same TLC verdicts). The others stay on the Python
host library: the USB uplink traces are the Python library's own view (UsbCore.trace, which the C
core does not log), and the discovery trace is the Python library's discovery (every experiment
discovers through it before a hand-over to the C host).
"""

from __future__ import annotations

import copy
import time
from dataclasses import replace
from collections.abc import Callable, Sequence
from pathlib import Path

from urb.api import DUPLICATE, MISMATCH
from urb.managers.usb_core import UsbCore

from ..chost import CHost
from ..native import App, Trace
from ..system import NS_PER_MS, Loop, System
from ..probe import PROBE_CLASS, probe_fingerprint
from ..tracecheck import (DISCOVERY_ADDRESSES, STATUS, USB_MAX_LATENCY, DiscoveryEvent, DiscoveryTrace, Event, Ident,
                          TableRow, TraceCheckError, TraceJob, TraceResult, UsbEvent, bridge_job, bridge_trace,
                          check_jobs, discovery_job, inbox_job, inbox_trace, outbox_job, outbox_trace, usb_job,
                          usb_trace)
from . import Progress, Result, no_progress, write_csv
from .control import other_host, resolve_host

PRESENT = {0x10: {1: 6}, 0x11: {1: 6}}

FAULTS = ["TIMEOUT", "CHECKSUM", "BUS_STUCK", "NODE_BUSY", "NO_NODE"]  #: Bridge.tla DownlinkFaults
BER = 3e-3  #: I2C bit error rate of the fault trace: about one request in four fails


def run_c_host(s: System, chost: CHost, cycles: int, tail_ms: int) -> None:
    """The C host's loop for `cycles` 1-ms periods (tick k is the loop's period k), `tail_ms` more for
    the last answers, then its close."""
    chost.loop(NS_PER_MS, cycles, 0)
    chost.advance_to(s.world.now + (cycles + tail_ms) * NS_PER_MS)
    chost.close()


def run_python_host(s: System, tick: Callable[[], None], cycles: int, tail_ms: int) -> None:
    """`tick` on the Python host every millisecond for `cycles` ticks, then `tail_ms` more."""
    Loop(s.host, NS_PER_MS, tick, count=cycles)
    s.host.advance((cycles + tail_ms) * NS_PER_MS)


def bridge_trace_name(uplink: str, ber: float = 0.0) -> str:
    return f"trace_{uplink}{'_ber' if ber else ''}.ndjson"


def record(uplink: str, seed: int, cycles: int, out: Path, ber: float = 0.0, host: str = "python",
           name: str | None = None) -> list[Event]:
    """Log a bridge trace: two probe nodes, reads of both and a write every third cycle at 1 kHz,
    on the Python or the C host library (`host`, control.HOSTS), into out/`name` (default
    bridge_trace_name)."""
    s = System(seed=seed, probe_out=6, probe_in=6)
    b = s.bridge(uplink)
    for i in range(2):
        s.node(b, App.PROBE, 0x10 + i, i)
    s.start()  # discovery done, nothing outstanding: the trace starts from Bridge.tla's Init
    acc = [s.urb.find_node(0x7E, i) for i in range(2)]
    path = out / (name or bridge_trace_name(uplink, ber))
    s.world.trace(path, Trace.BRIDGE | Trace.FAULT)
    if ber:
        s.world.i2c_ber(b, ber)
    if host == "c":
        chost = CHost(s)  # tick k of the loop below is the C loop's period k
        if uplink == "usb":
            chost.read(b, 0x10, 1, 6, 1)
            chost.read(b, 0x11, 1, 6, 1)
        else:
            chost.first(chost.read(b, 0x11, 1, 6, 2), 1)
            chost.read(b, 0x10, 1, 6, 2)
        chost.write(b, 0x10, 1, b"abcdef", 3)
        run_c_host(s, chost, cycles, 300)
        s.world.flush_trace()
        events = bridge_trace(path, f"{uplink}{b}")
        s.close()
        return events
    k = [0]

    def tick() -> None:
        k[0] += 1
        if uplink == "usb":
            for a in acc:
                a.submit_request(a.new_request().read(1, 6))
        else:
            a = acc[k[0] % 2]
            a.submit_request(a.new_request().read(1, 6))
        if k[0] % 3 == 0:
            acc[0].submit_request(acc[0].new_request().write(1, b"abcdef"))

    run_python_host(s, tick, cycles, 300)
    s.world.flush_trace()
    events = bridge_trace(path, f"{uplink}{b}")
    s.close()
    return events


OUTBOX_TRACE = "trace_outbox.ndjson"


def record_outbox(seed: int, cycles: int, out: Path, host: str = "python",
                  name: str = OUTBOX_TRACE) -> list[dict[str, int | str]]:
    """Log outbox 1 of a probe node from power-on while the host (the Python or the C host library)
    reads it at 1 kHz over USB, into out/`name`."""
    s = System(seed=seed, probe_out=6, params={"probe.fill_counter": 1.0})
    b = s.bridge("usb")
    s.node(b, App.PROBE, 0x10, 0)
    path = out / name
    s.world.trace(path, Trace.MAILBOX)  # from power-on: the trace starts in MailboxOutbox.tla's Init
    s.start()
    if host == "c":
        chost = CHost(s)
        chost.read(b, 0x10, 1, 6, 1)
        run_c_host(s, chost, cycles, 20)
    else:
        node = s.urb.find_node(0x7E, 0)

        def tick() -> None:
            node.submit_request(node.new_request().read(1, 6))

        run_python_host(s, tick, cycles, 20)
    s.world.flush_trace()
    events = outbox_trace(path, f"usb{b}/n16")
    s.close()
    return events


INBOX_SIZE = 4
INBOX_WRITES = 200  #: writes (one per millisecond) in the inbox trace
INBOX_BER = 2e-3  # about one write in ten fails its check: the trace holds aborted writes


INBOX_TRACE = "trace_inbox.ndjson"


def record_inbox(seed: int, cycles: int, out: Path, host: str = "python",
                 name: str = INBOX_TRACE) -> list[dict[str, int | str]]:
    """Log inbox 1 of a probe node from power-on while the host (the Python or the C host library)
    writes it every millisecond over USB, write k filled with k's low byte, the downlink flipping
    bits at INBOX_BER so that some writes abort; into out/`name`."""
    s = System(seed=seed, probe_out=6, probe_in=INBOX_SIZE)
    b = s.bridge("usb")
    s.node(b, App.PROBE, 0x10, 0)
    path = out / name
    s.world.trace(path, Trace.MAILBOX | Trace.FAULT)  # from power-on: MailboxInbox.tla's Init
    s.start()
    s.world.i2c_ber(b, INBOX_BER)
    if host == "c":
        chost = CHost(s)
        chost.counter(chost.write(b, 0x10, 1, bytes(INBOX_SIZE), 1))
        run_c_host(s, chost, cycles, 20)
    else:
        node = s.urb.find_node(0x7E, 0)
        k = [0]

        def tick() -> None:
            k[0] += 1
            node.submit_request(node.new_request().write(1, bytes([k[0] & 0xFF]) * INBOX_SIZE))

        run_python_host(s, tick, cycles, 20)
    s.world.flush_trace()
    events = inbox_trace(path, f"usb{b}/n16")
    s.close()
    return events


#: UsbUplink.tla takes the OS tick to be the USB frame: the traces are recorded with the USB frames
#: starting this long after the tick (usb.phase_us) unless a phase is given, whatever the seed.
USB_TICK_ALIGNED_US = 100
#: The USB frame phases the premise is measured at, us after the OS tick.
USB_PHASES_US = [100, 300, 500, 700, 900, 950, 980, 999]


def record_usb_uplink(seed: int, cycles: int, motor_load: bool = False,
                      phase_us: int = USB_TICK_ALIGNED_US) -> tuple[list[UsbEvent], int, int]:
    """Log the host library's view of a USB uplink (UsbCore.trace) from the end of discovery: the
    events, the host's batch limit and its window. The application reads two probe nodes every millisecond and
    writes one every third; with `motor_load`, it reads (6 bytes) and writes (2 bytes) three nodes
    every other millisecond, as the motor loop of Fig. 20 does on each USB bridge. The USB frames
    start `phase_us` after the OS tick."""
    nodes = 3 if motor_load else 2
    s = System(seed=seed, probe_out=6, probe_in=2 if motor_load else 6, params={"usb.phase_us": float(phase_us)})
    b = s.bridge("usb")
    for i in range(nodes):
        s.node(b, App.PROBE, 0x10 + i, i)
    s.start()  # discovery done, nothing queued or in flight: UsbUplink.tla's Init
    acc = [s.urb.find_node(0x7E, i) for i in range(nodes)]
    core = s.managers[b].core
    assert isinstance(core, UsbCore)
    core.trace = []
    k = [0]

    def tick() -> None:
        k[0] += 1
        if motor_load:
            if k[0] % 2 == 0:
                for a in acc:
                    a.submit_request(a.new_request().read(1, 6))
                    a.submit_request(a.new_request().write(1, b"\x00\x00"))
            return
        for a in acc:
            a.submit_request(a.new_request().read(1, 6))
        if k[0] % 3 == 0:
            acc[0].submit_request(acc[0].new_request().write(1, b"abcdef"))

    Loop(s.host, NS_PER_MS, tick, count=cycles)
    s.host.advance((cycles + 20) * NS_PER_MS)
    events = usb_trace(core.trace)
    s.close()
    return events, core.max_batch, core.window


def record_discovery(seed: int) -> DiscoveryTrace:
    """Discover two bridges through the host library and log it as TraceDiscovery.tla checks it. On
    the USB bridge: probe nodes 0 and 1, and probe 2, powered off before discovery; on the RS232
    bridge: another probe 0 (a DUPLICATE of the first) and a probe 3 built with another layout (a
    MISMATCH). After discovery the host reads probe 1, powers it off and reads it again (NO_NODE)."""
    s = System(seed=seed, probe_out=6)
    usb, rs = s.bridge("usb"), s.bridge("rs232")
    wiring = [(usb, 0x10, 0), (usb, 0x11, 1), (usb, 0x12, 2), (rs, 0x10, 0)]
    ids = [s.node(b, App.PROBE, a, i) for b, a, i in wiring]
    fp = probe_fingerprint(6)
    other_fp = probe_fingerprint(7)
    s.set("probe.fingerprint", other_fp)
    ids.append(s.node(rs, App.PROBE, 0x13, 3))
    wiring.append((rs, 0x13, 3))
    wired = {(b, a): Ident(PROBE_CLASS, i, other_fp if (b, a) == (rs, 0x13) else fp) for b, a, i in wiring}
    s.start(before_discovery=lambda: s.world.node_power(ids[2], False))
    trace = DiscoveryTrace(bridges=[usb, rs], wired=wired, expected={PROBE_CLASS: fp},
                           churn_slots={(usb, 0x12), (usb, 0x11)}, churn=2)
    for b in trace.bridges:
        report = s.reports[b]
        read = {r.address: r for r in report.records}
        for a in range(1, DISCOVERY_ADDRESSES + 1):
            r = read.get(a)
            found = Ident(r.class_id, r.index, r.fingerprint) if r is not None and a in report.present else None
            trace.events.append(DiscoveryEvent("scan", b, a, found))
    bridge_of = {id(m): b for b, m in s.managers.items()}
    trace.events.append(DiscoveryEvent("table", rows=[
        TableRow(bridge_of[id(r.bridge)], r.address, Ident(r.class_id, r.index, r.fingerprint),
                 frozenset(r.flags & {DUPLICATE, MISMATCH})) for r in s.urb.nodes()]))
    node = s.urb.find_node(PROBE_CLASS, 1)
    for power in (True, False):
        s.world.node_power(ids[1], power)
        done: list[str] = []
        node.submit_request(node.new_request().read(1, 6).set_callback(
            lambda r: done.append("OK" if r.ok else r.flags.describe())))
        s.host.run_until(lambda: bool(done), s.host.now_ns() + 100 * NS_PER_MS)
        trace.events.append(DiscoveryEvent("request", usb, 0x11, status=done[0]))
    s.close()
    return trace


def discovery_phantom(t: DiscoveryTrace) -> DiscoveryTrace:
    """Seeded bug: a scan reports an identity other than the one of the node wired there."""
    m = copy.deepcopy(t)
    k = next(k for k, e in enumerate(m.events) if e.ev == "scan" and e.found is not None)
    found = m.events[k].found
    assert found is not None
    m.events[k].found = replace(found, index=found.index + 10)
    return m


def discovery_duplicate_unflagged(t: DiscoveryTrace) -> DiscoveryTrace:
    """Seeded bug: only one of two rows with the same class and index is flagged DUPLICATE."""
    m = copy.deepcopy(t)
    table = next(e for e in m.events if e.ev == "table")
    k = next(k for k, r in enumerate(table.rows) if DUPLICATE in r.flags)
    table.rows[k] = replace(table.rows[k], flags=table.rows[k].flags - {DUPLICATE})
    return m


def discovery_merged(t: DiscoveryTrace) -> DiscoveryTrace:
    """Seeded bug: two rows with the same class and index are merged into one."""
    m = copy.deepcopy(t)
    table = next(e for e in m.events if e.ev == "table")
    dups = [k for k, r in enumerate(table.rows) if DUPLICATE in r.flags]
    table.rows[dups[0]] = replace(table.rows[dups[0]], flags=table.rows[dups[0]].flags - {DUPLICATE})
    del table.rows[dups[1]]
    return m


def usb_late_read(events: list[UsbEvent]) -> list[UsbEvent]:
    """Seeded bug: one bulk-IN transfer carrying responses, and its callbacks, one frame later (after
    the next frame's other events)."""
    m = copy.deepcopy(events)
    reads = [k for k, e in enumerate(m) if e.ev == "read" and e.seqs]
    k = reads[len(reads) // 2]
    q = k + 1
    while q < len(m) and m[q].ev == "callback":
        q += 1
    moved, rest = m[k:q], m[q:]
    for e in moved:
        e.f += 1
    later = next((i for i, e in enumerate(rest) if e.f > moved[0].f), len(rest))
    return m[:k] + rest[:later] + moved + rest[later:]


def usb_swapped_batch(events: list[UsbEvent]) -> list[UsbEvent]:
    """Seeded bug: two requests of one bulk-OUT batch in the wrong order."""
    m = copy.deepcopy(events)
    batches = [k for k, e in enumerate(m) if e.ev == "write" and len(e.ids) > 1]
    ids = m[batches[len(batches) // 2]].ids
    ids[0], ids[1] = ids[1], ids[0]
    return m


def usb_swapped_callbacks(events: list[UsbEvent]) -> list[UsbEvent]:
    """Seeded bug: the callbacks of two requests answered in one IN transfer run in the wrong order."""
    m = copy.deepcopy(events)
    pairs = [k for k in range(len(m) - 1) if m[k].ev == m[k + 1].ev == "callback"]
    k = pairs[len(pairs) // 2]
    m[k], m[k + 1] = m[k + 1], m[k]
    return m


def _read_bytes(events: list[dict[str, int | str]], lock: int) -> list[int]:
    """Indices of the "rbyte" events that follow the "lock" at index `lock`."""
    out = []
    k = lock + 1
    while k < len(events) and events[k]["ev"] == "rbyte":
        out.append(k)
        k += 1
    return out


def torn_read(events: list[dict[str, int | str]]) -> list[dict[str, int | str]]:
    """Seeded bug: in one lock of a written message, the last byte read comes from the write before."""
    m = copy.deepcopy(events)
    locks = [k for k, e in enumerate(m) if e["ev"] == "lock" and len(_read_bytes(m, k)) > 1
             and int(m[k + 1]["tag"]) > 0]
    last = _read_bytes(m, locks[len(locks) // 2])[-1]
    m[last]["tag"] = int(m[last]["tag"]) - 1
    return m


def aborted_visible(events: list[dict[str, int | str]]) -> list[dict[str, int | str]]:
    """Seeded bug: the first lock after an aborted write hands out the buffer that write was filling
    (its bytes read as stored there), as a lock that skipped AppLockCheckFront could."""
    m = copy.deepcopy(events)
    writes, filling = 0, -1
    stored: dict[tuple[int, int], int] = {}
    for k, e in enumerate(m):
        if e["ev"] in ("wbegin", "wnack"):
            writes += 1
            filling = int(e["buf"]) if e["ev"] == "wbegin" else -1
        elif e["ev"] == "wbyte":
            stored[(filling, int(e["index"]))] = writes
        elif e["ev"] == "abort" and filling >= 0:
            lock = next((q for q in range(k + 1, len(m)) if m[q]["ev"] == "lock"), None)
            if lock is None or int(m[lock]["buf"]) == filling:
                continue
            m[lock]["buf"] = filling
            for q in _read_bytes(m, lock):
                m[q]["tag"] = stored.get((filling, int(m[q]["index"])), 0)
            return m
    raise ValueError("the trace has no aborted write followed by a lock: record a longer trace")


def first_change(a: Sequence[object], b: Sequence[object]) -> int:
    """Index of the first event where two traces differ (the shorter one's length if one is a prefix)."""
    return next((q for q, (x, y) in enumerate(zip(a, b)) if x != y), min(len(a), len(b)))


def row(uplink: str, trace: str, r: TraceResult) -> list[object]:
    """One line of traces.csv: a TLC run on a trace. Only what the seed decides: TLC's wall time
    (r.seconds) is in the report's table, not here, so that a seed gives the same file byte for byte."""
    return [uplink, trace, r.events, int(r.accepted), r.matched_prefix, r.states]


def check_mutant(res: Result, name: str, required: str, r: TraceResult, mutated: int) -> None:
    """A mutated trace must be rejected, and only where the mutation is: TLC must match every event
    before the first mutated one (a rejection earlier would not be the mutation's doing)."""
    measured = ("ACCEPTED" if r.accepted else
                f"rejected at event {r.matched_prefix + 1}; first mutated event {mutated + 1}")
    res.check(name, f"{required}; the events before the first mutated one match", measured,
              not r.accepted and r.matched_prefix >= mutated)


def host_agreement(host: str, seed: int, cycles: int, out: Path) -> tuple[str, str, str, bool]:
    """The check that the traces recorded on `host` (the bridge and mailbox traces) are the ones the
    other host library makes, byte for byte: (name, required, measured, passed)."""
    other = other_host(host)
    recordings: list[tuple[str, Callable[[str, str], object]]] = [
        (bridge_trace_name("rs232"), lambda h, n: record("rs232", seed, cycles, out, host=h, name=n)),
        (bridge_trace_name("usb"), lambda h, n: record("usb", seed + 1, cycles, out, host=h, name=n)),
        (bridge_trace_name("usb", BER), lambda h, n: record("usb", seed + 9, cycles, out, ber=BER, host=h, name=n)),
        (OUTBOX_TRACE, lambda h, n: record_outbox(seed + 5, outbox_cycles(cycles), out, host=h, name=n)),
        (INBOX_TRACE, lambda h, n: record_inbox(seed + 6, INBOX_WRITES, out, host=h, name=n)),
    ]
    differ = []
    for kept, again in recordings:
        name = kept.replace(".ndjson", f".{other}.ndjson")
        again(other, name)
        if (out / kept).read_bytes() != (out / name).read_bytes():
            differ.append(kept)
        (out / name).unlink()
    return ("host libraries agree", "the bridge, outbox and inbox traces recorded on the Python and on the C host "
            "library: the same, byte for byte (so TLC's verdicts are the same)",
            f"{len(recordings)} traces: " + ("equal" if not differ else "differ: " + ", ".join(differ)), not differ)


def outbox_cycles(cycles: int) -> int:
    """The outbox trace's reads: 60 quick (cycles 40), else 200."""
    return 60 if cycles < 100 else 200


def traces(out: Path, *, quick: bool = False, seed: int = 400, progress: Progress = no_progress,
           host: str | None = None) -> Result:
    """`host`: the host library the bridge and mailbox traces are recorded on (control.HOSTS; None:
    $URB_SIM_HOST, else python); they are recorded again on the other one and must be the same. The
    USB uplink and discovery traces are the Python host library's (module docstring)."""
    host = resolve_host(host)
    res = Result("traces",
                 "Trace validation: bridge, mailbox, USB uplink and discovery traces against spec/tla (TLC)"
                 + (" (bridge and mailbox traces on the C host library)" if host == "c" else ""),
                 "the implementation follows the TLA+ specification action by action (trace validation as in "
                 "the etcd-raft and CCF projects)")
    out.mkdir(parents=True, exist_ok=True)
    cycles = 40 if quick else 150
    t0 = time.perf_counter()
    # Every trace is recorded first, each with what its verdict must be (`judge`); then TLC checks
    # them all in one run (urb_sim.tracebatch), and the checks follow in the order the traces were
    # recorded.
    pending: list[tuple[str, TraceJob, Callable[[TraceResult], object]]] = []

    def check(uplink: str, job: TraceJob, judge: Callable[[TraceResult], object]) -> None:
        pending.append((uplink, job, judge))

    def mutant(name: str, required: str, mutated: int) -> Callable[[TraceResult], object]:
        return lambda r: check_mutant(res, name, required, r, mutated)

    def accepted(name: str, required: str, measured: Callable[[TraceResult], str],
                 also: Callable[[TraceResult], bool] = lambda r: True) -> Callable[[TraceResult], object]:
        return lambda r: res.check(name, required, measured(r), r.accepted and also(r))

    def matched_of(events: int) -> Callable[[TraceResult], str]:
        return lambda r: f"{r.matched_prefix}/{events} events matched, {r.states} states"

    def phase_of(frames: int) -> Callable[[TraceResult], object]:
        return lambda r: verdicts.append((r.accepted, frames))

    for i, uplink in enumerate(["rs232", "usb"]):
        progress(i / 10, f"traces: recording the {uplink} bridge trace")
        ev = record(uplink, seed + i, cycles, out, host=host)
        check(uplink, bridge_job(ev, PRESENT, name="fault-free"),
              accepted(f"{uplink} trace accepted", "TLC finds a behaviour of Bridge.tla matching every logged event "
                       "(every Bridge.tla invariant holds on its states)",
                       matched_of(len(ev))))
        if uplink == "rs232":
            base = ev
    resp = [k for k, e in enumerate(base) if e.ev == "resp"]
    changed = copy.deepcopy(base)
    changed[resp[5]].status = 2
    dropped = [e for k, e in enumerate(base) if k != resp[5]]
    swapped = copy.deepcopy(base)
    a, b = resp[3], resp[4]
    swapped[a], swapped[b] = swapped[b], swapped[a]
    for name, bridge_mutant in [("status changed", changed), ("response dropped", dropped),
                                ("responses swapped", swapped)]:
        check("rs232", bridge_job(bridge_mutant, PRESENT, name=f"mutant: {name}"),
              mutant(f"mutant rejected: {name}", "TLC finds no behaviour matching the mutated trace",
                     first_change(base, bridge_mutant)))
    progress(1 / 10, "traces: recording the outbox trace")
    obox = record_outbox(seed + 5, outbox_cycles(cycles), out, host=host)
    check("usb", outbox_job(obox, 6, name="outbox 1 of a node (MailboxOutbox.tla)"),
          accepted("outbox trace accepted", "TLC finds a behaviour of MailboxOutbox.tla matching every logged "
                   "release and read byte (its invariants hold on the way)",
                   lambda r: f"{len(obox)} events" if r.accepted else r.message))
    older = copy.deepcopy(obox)
    byte_at = [k for k, e in enumerate(older) if e["ev"] == "byte" and int(e["tag"]) > 0]
    k = byte_at[len(byte_at) // 2]
    older[k]["tag"] = int(older[k]["tag"]) - 1
    check("usb", outbox_job(older, 6, name="outbox mutant: a byte from an older write"),
          mutant("outbox mutant rejected: stale byte",
                 "TLC finds no behaviour where a read returns a byte of an older write", k))
    progress(1.5 / 10, "traces: recording the inbox trace")
    # quick or not, 200 writes: in 60, about one seed in twenty has no aborted write followed by
    # a lock of the other buffer, which the "aborted write visible" mutant needs
    ibox = record_inbox(seed + 6, INBOX_WRITES, out, host=host)
    aborts = sum(1 for e in ibox if e["ev"] == "abort")
    check("usb", inbox_job(ibox, INBOX_SIZE, name=f"inbox 1 of a node under I2C bit errors {INBOX_BER:g} "
                                                  "(MailboxInbox.tla)"),
          accepted("inbox trace accepted", "TLC finds a behaviour of MailboxInbox.tla matching every logged write "
                   "begin, store, commit and abort and every lock, read byte and release (its invariants hold on "
                   "the way), with at least one aborted write in the trace",
                   lambda r: f"{len(ibox)} events, {aborts} aborted writes" if r.accepted else r.message,
                   lambda r: aborts >= 1))
    for name, seeded in [("torn read", torn_read(ibox)), ("aborted write visible", aborted_visible(ibox))]:
        check("usb", inbox_job(seeded, INBOX_SIZE, name=f"inbox mutant: {name}"),
              mutant(f"inbox mutant rejected: {name}", "TLC finds no behaviour of MailboxInbox.tla matching it",
                     first_change(ibox, seeded)))
    progress(2 / 10, "traces: recording the trace under I2C bit errors")
    ev = record("usb", seed + 9, cycles, out, ber=BER, host=host)
    statuses = sorted({STATUS.get(e.status, "?") for e in ev if e.ev == "resp"})
    ber_events = len(ev)
    check("usb", bridge_job(ev, PRESENT, faults=FAULTS, name=f"I2C bit errors {BER:g}"),
          accepted("usb trace under I2C bit errors accepted",
                   "TLC finds a behaviour of Bridge.tla, with every downlink fault, matching every logged event; "
                   "the trace holds failed requests",
                   lambda r: f"{matched_of(ber_events)(r)}; statuses {', '.join(statuses)}"
                   if r.accepted else r.message,
                   lambda r: "CHECKSUM" in statuses))
    progress(2.5 / 10, "traces: recording the USB uplink trace (UsbUplink.tla)")
    uev, max_batch, window = record_usb_uplink(seed + 11, cycles)
    callbacks = sum(1 for e in uev if e.ev == "callback")
    check("usb", usb_job(uev, max_batch, window, name="host library's USB uplink (UsbUplink.tla)"),
          accepted("USB uplink trace accepted", "TLC finds a behaviour of UsbUplink.tla matching every submission, "
                   "bulk-OUT batch, bulk-IN transfer and callback in its 1-ms frame (LatencyBound: every callback "
                   "within 3 frames of its submission)",
                   lambda r: f"{len(uev)} events ({callbacks} callbacks), {r.states} states"
                   if r.accepted else r.message, lambda r: callbacks > 0))
    for name, usb_mutant in [("responses one frame late", usb_late_read(uev)),
                             ("batch out of order", usb_swapped_batch(uev)),
                             ("callbacks swapped", usb_swapped_callbacks(uev))]:
        check("usb", usb_job(usb_mutant, max_batch, window, name=f"USB uplink mutant: {name}"),
              mutant(f"USB uplink mutant rejected: {name}", "TLC finds no behaviour of UsbUplink.tla matching it",
                     first_change(uev, usb_mutant)))
    # UsbUplink.tla assumes the OS tick is the USB frame. In the simulation the USB controller's
    # frames have their own phase (usb.phase_us): where they start just before a tick, the
    # responses of a batch reach the host just after the next one, a fourth host frame.
    # Measured, not a bug.
    verdicts: list[tuple[bool, int]] = []
    tried = USB_PHASES_US[::2] if quick else USB_PHASES_US
    for phase in tried:
        pev, phase_batch, phase_window = record_usb_uplink(seed + 20, 20, phase_us=phase)
        submitted = {e.id: e.f for e in pev if e.ev == "submit"}
        frames = max(e.f - submitted[e.id] + 1 for e in pev if e.ev == "callback")
        check("usb", usb_job(pev, phase_batch, phase_window,
                             name=f"host library's USB uplink, USB frames {phase} us after the OS tick: every callback "
                             f"within {frames} host frames of its submission (UsbUplink.tla's premise: "
                             f"{USB_MAX_LATENCY})"),
              phase_of(frames))

    def phases_judged(r: TraceResult) -> None:
        n_accepted = sum(1 for a, _ in verdicts if a)
        phases = ", ".join(f"{ph} us {'accepted' if a else 'rejected'}" for ph, (a, _) in zip(tried, verdicts))
        res.check("USB uplink premise measured over frame phases",
                  "TLC accepts a phase's trace exactly when every callback comes within 3 host frames of its "
                  "submission (UsbUplink.tla's premise: the OS tick is the USB frame); frames starting just after "
                  "the tick are accepted, just before it rejected",
                  f"{phases}: the rejected ones, and only they, have callbacks in a 4th host frame"
                  if all(a == (f <= USB_MAX_LATENCY) for a, f in verdicts) else
                  "verdicts and measured latencies disagree: " + ", ".join(f"{a}/{f}" for a, f in verdicts),
                  0 < n_accepted < len(verdicts) and all(a == (f <= USB_MAX_LATENCY) for a, f in verdicts))

    # UsbUplink.tla assumes a batch fits the downlink in its frame. The motor traffic of one USB
    # bridge (3 reads and 3 writes per batch, ~1.1 ms of I2C) does not: measured, not a bug.
    mev, max_batch, window = record_usb_uplink(seed + 12, 20, motor_load=True)

    def motor_load_judged(r: TraceResult) -> None:
        phases_judged(r)
        stop = mev[r.matched_prefix] if r.matched_prefix < len(mev) else None
        batch = next((len(e.ids) for e in reversed(mev[:r.matched_prefix]) if e.ev == "write" and e.ids), 0)
        res.check("USB uplink premise measured at the motor load",
                  "with 3 reads (6 B) and 3 writes (2 B) per batch the downlink outlasts the frame: TLC rejects the "
                  "trace at a bulk-IN transfer carrying only part of the batch before (UsbUplink.tla's premise "
                  "that a batch fits its frame, so its 3-frame bound, does not hold at this load)",
                  "ACCEPTED" if stop is None else
                  f"rejected at event {r.matched_prefix + 1}: a bulk-IN transfer with {len(stop.seqs)} of the "
                  f"{batch} responses of the batch before", stop is not None and stop.ev == "read"
                  and len(stop.seqs) < batch)

    check("usb", usb_job(mev, max_batch, window,
                         name="USB uplink at the motor load of Fig. 20 (premise: a batch fits its frame)"),
          motor_load_judged)
    progress(3 / 10, "traces: recording the discovery trace (Discovery.tla)")
    disc = record_discovery(seed + 13)
    table = next(e for e in disc.events if e.ev == "table")
    flags = sorted({f for tr in table.rows for f in tr.flags})
    requests = [e.status for e in disc.events if e.ev == "request"]
    check("usb+rs232", discovery_job(disc, name="discovery of two bridges (Discovery.tla)"),
          accepted("discovery trace accepted", "TLC finds a behaviour of Discovery.tla matching the scan of every "
                   "address of both bridges, the host's table with its DUPLICATE and MISMATCH flags and the requests "
                   "after discovery (a node powered off before the scan, one after it: OK, then NO_NODE)",
                   lambda r: f"{len(disc.events)} events, table of {len(table.rows)} rows, flags {', '.join(flags)}, "
                   f"requests {', '.join(requests)}; {r.states} states" if r.accepted else r.message,
                   lambda r: flags == [DUPLICATE, MISMATCH] and requests == ["OK", "NO_NODE"]))
    for name, dmut in [("phantom identity", discovery_phantom(disc)),
                       ("duplicate not flagged", discovery_duplicate_unflagged(disc)),
                       ("duplicates merged", discovery_merged(disc))]:
        check("usb+rs232", discovery_job(dmut, name=f"discovery mutant: {name}"),
              mutant(f"discovery mutant rejected: {name}", "TLC finds no behaviour of Discovery.tla matching it",
                     first_change(disc.events, dmut.events)))

    progress(3.2 / 10, f"traces: the bridge and mailbox traces again, on the {other_host(host)} host library")
    res.check(*host_agreement(host, seed, cycles, out))
    progress(3.5 / 10, f"traces: TLC checks {len(pending)} traces in one run")
    rows: list[list[object]] = []
    tlc_s: list[float] = []  # wall time of each row's TLC run, for the report's table only
    tlc_wall = 0.0
    try:
        results = check_jobs([job for _, job, _ in pending])
    except TraceCheckError as exc:
        res.check("TLC ran every check", "java and tla2tools.jar installed; every TLC run finishes", str(exc), False)
    else:
        for (uplink, job, judge), r in zip(pending, results):
            rows.append(row(uplink, job.name, r))
            tlc_s.append(r.seconds)
            judge(r)
        tlc_wall = sum(r.seconds / r.batch for r in results)
    res.wall_s = time.perf_counter() - t0
    # bridge traces, mailbox traces, the USB uplink trace, its motor-load run, discovery (with settling),
    # the USB frame phases
    res.sim_s = (3 * (cycles + 300 + 90) + (60 if quick else 200) + INBOX_WRITES + 100 + cycles + 110 + 130 + 300
                 + len(USB_PHASES_US[::2] if quick else USB_PHASES_US) * 130) / 1000
    res.files.append(write_csv(out / "traces.csv", ["uplink", "trace", "events", "accepted", "matched_prefix",
                                                    "tlc_states"], rows))
    res.table = [{"uplink": r[0], "trace": r[1], "events": r[2], "accepted": bool(r[3]), "matched": r[4],
                  "TLC states": r[5], "TLC run wall s": round(w, 1)} for r, w in zip(rows, tlc_s)]
    specs = len({job.spec for _, job, _ in pending})
    res.notes.append(f"{len(rows)} traces of {specs} specifications checked in one TLC run (urb_sim/tracebatch.py), "
                     f"{tlc_wall:.1f} s of TLC wall time (a row's \"TLC run wall s\"). Wall times differ from run to "
                     "run: they are in this table only, not in traces.csv nor in the checks' measured values, which a "
                     "seed reproduces byte for byte (a sweep's hash covers the checks).")
    return res
