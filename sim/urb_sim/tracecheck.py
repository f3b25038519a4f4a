"""TLA+ trace validation: TLC checks traces logged by the simulation against spec/tla/Bridge.tla,
spec/tla/MailboxOutbox.tla, spec/tla/MailboxInbox.tla, spec/tla/UsbUplink.tla and
spec/tla/Discovery.tla.

The simulation logs what a protocol analyser on a bridge's uplink would see (trace category
"bridge", sim/README.md): request frames reaching the firmware ("req") and response frames leaving
it ("resp"). `bridge_trace()` extracts one bridge's events from an NDJSON trace; `bridge_job()`
turns them into the constants of sim/tla/TraceBridge.tla, and `check_jobs()` has TLC check them and
reports whether the trace is a behaviour of the specification, and if not, the longest prefix that
is (`check_bridge()` does both for one trace).

`check_jobs()` checks all the traces of one specification in one TLC run: a generated module
instantiates sim/tla/<spec>.tla once per trace, with that trace's constants, and its initial state
picks the trace (variable t), so that the traces' state spaces are disjoint and explored side by
side. Each new state prints its trace and how many events it has matched (invariant Visited): a
trace's verdict, matched prefix and state count are read from its own lines, the same as a run of
its own gives (TLC checks invariants once per new state, and tests/sim/test_trace_batch.py compares
both on the traces of `urb sim sensorhex`).

The trace's sequence numbers are renumbered from the first logged request (Bridge.tla numbers
requests from 1); the host must have numbered them consecutively, which the check therefore
also verifies.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from urb.managers.base import NS_PER_MS, Transfer
from urb.managers.usb_core import UsbTraceEvent

from .tracebatch import TraceCheckError, TraceJob, TraceResult, check_jobs, find_tlc

__all__ = ["TraceCheckError", "TraceJob", "TraceResult", "check_jobs", "find_tlc"]

STATUS = {0: "OK", 1: "TIMEOUT", 2: "CHECKSUM", 3: "BUSY", 4: "NO_NODE", 5: "SIZE_MISMATCH", 6: "BAD_REQUEST",
          7: "BUS_STUCK", 8: "NODE_BUSY"}


@dataclass
class Event:
    ev: str
    addr: int = 0
    box: int = 0
    op: str = ""
    length: int = 0
    seq: int = 0
    status: int = 0


def bridge_trace(path: Path, device: str) -> list[Event]:
    """The "req"/"resp" events of bridge `device` (e.g. "rs232-0" is named "rs2320") in order."""
    out: list[Event] = []
    with path.open() as f:
        for line in f:
            if '"cat":"bridge"' not in line:
                continue
            d = json.loads(line)
            if d["dev"] != device:
                continue
            if d["ev"] == "req":
                out.append(Event("req", d["addr"], d["box"], d["op"], d["len"], d["seq"]))
            elif d["ev"] == "resp":
                out.append(Event("resp", seq=d["seq"], status=d["status"]))
    return out


def _tla_trace(items: Iterable[str]) -> str:
    return "<<" + ",\n    ".join(items) + ">>"


def bridge_job(events: list[Event], present: dict[int, dict[int, int]], *, faults: Iterable[str] = (),
               queue_len: int = 15, host_window: int = 15, name: str = "") -> TraceJob:
    """A bridge trace as sim/tla/TraceBridge.tla checks it against Bridge.tla (check_bridge)."""
    reqs = [e for e in events if e.ev == "req"]
    first = reqs[0].seq if reqs else 0

    def rec(e: Event) -> str:
        return f'[addr |-> {e.addr}, box |-> {e.box}, op |-> "{e.op}", len |-> {e.length}]'

    items = []
    for e in events:
        if e.ev == "req":
            items.append(f'[ev |-> "req", req |-> {rec(e)}]')
        else:
            items.append(f'[ev |-> "resp", seq |-> {(e.seq - first + 1) % 16}, status |-> "{STATUS.get(e.status, "?")}"]')
    return TraceJob("TraceBridge", {
        "Present": f"{{{', '.join(str(a) for a in sorted(present))}}}",
        "Size": _size_fn(present),
        "Requests": "{" + ", ".join(sorted({rec(e) for e in reqs})) + "}",
        "Faults": "{" + ", ".join(f'"{f}"' for f in sorted(faults)) + "}",
        "QueueLen": str(queue_len),
        "HostWindow": str(host_window),
        "MaxReq": str(len(reqs)),
        "SeqMod": "16",
        "UplinkLoss": "FALSE",
        "Trace": _tla_trace(items),
    }, events, name)


def _fn(m: dict[int, int]) -> str:
    return "[tBox \\in 0..7 |-> CASE " + " [] ".join(f"tBox = {k} -> {v}" for k, v in sorted(m.items())) + " [] OTHER -> 0]"


def _size_fn(present: dict[int, dict[int, int]]) -> str:
    return "[tAddr \\in {" + ", ".join(str(a) for a in sorted(present)) + "} |-> CASE " + " [] ".join(
        f"tAddr = {a} -> {_fn(present[a])}" for a in sorted(present)) + "]"


def check_bridge(events: list[Event], present: dict[int, dict[int, int]], *, faults: Iterable[str] = (),
                 queue_len: int = 15, host_window: int = 15) -> TraceResult:
    """Check a bridge trace against Bridge.tla in one TLC run; a rejected trace comes with the longest
    prefix a behaviour matched (TraceBridge.tla's MatchedSoFar).

    `present`: node address -> {mailbox: size} as learnt at discovery (one size per mailbox for
    both directions, as Bridge.tla's Size)."""
    return check_jobs([bridge_job(events, present, faults=faults, queue_len=queue_len, host_window=host_window)])[0]


# --------------------------------------------------------------------------- outbox traces


def outbox_trace(path: Path, device: str) -> list[dict[str, int | str]]:
    """The outbox-1 events of probe node `device` (e.g. "usb0/n16"), as TraceOutbox events: each
    byte's tag is the index of the release whose update counter it carries (0: setup zeros)."""
    raw: list[dict[str, int | str]] = []
    with path.open() as f:
        for line in f:
            if '"cat":"mailbox"' not in line:
                continue
            d = json.loads(line)
            if d["dev"] == device:
                raw.append(d)
    out: list[dict[str, int | str]] = []
    latest: dict[int, int] = {0: 0}  # counter low byte -> index of the latest release carrying it
    releases = 0
    for d in raw:
        ev = str(d["ev"])
        if ev == "release":
            releases += 1
            latest[int(d["counter"]) & 0xFF] = releases
            out.append({"ev": "release"})
        elif ev == "byte":
            out.append({"ev": "byte", "tag": latest.get(int(d["value"]), -1)})
        elif ev in ("begin", "end"):
            out.append({"ev": ev})
    return out


def outbox_job(events: list[dict[str, int | str]], size: int, name: str = "") -> TraceJob:
    """An outbox trace as sim/tla/TraceOutbox.tla checks it against MailboxOutbox.tla (check_outbox)."""
    items = []
    for e in events:
        if e["ev"] == "byte":
            items.append(f'[ev |-> "byte", tag |-> {e["tag"]}]')
        else:
            items.append(f'[ev |-> "{e["ev"]}"]')
    writes = max(1, sum(1 for e in events if e["ev"] == "release"))
    return TraceJob("TraceOutbox", {"MsgLen": str(size), "MaxWrites": str(writes), "Trace": _tla_trace(items)},
                    events, name)


def check_outbox(events: list[dict[str, int | str]], size: int) -> TraceResult:
    """Check an outbox trace against MailboxOutbox.tla in one TLC run (a rejected trace comes with
    the longest prefix a behaviour matched)."""
    return check_jobs([outbox_job(events, size)])[0]


# --------------------------------------------------------------------------- inbox traces

#: URB_INBOX_MAX_RETRY of firmware/node/urb_mailbox.c: lock attempts after the first before BUSY.
INBOX_MAX_RETRY = 2
_INBOX_EVENTS = {"wbegin", "wnack", "wbyte", "commit", "abort", "lock", "busy", "lock_error", "rbyte", "in_release"}


def inbox_trace(path: Path, device: str) -> list[dict[str, int | str]]:
    """The inbox-1 events of probe node `device` (e.g. "usb0/n16"), as TraceInbox events.

    Each byte the application reads is tagged with the write that last stored it at that place of
    that buffer (0: the zeroed setup), from the logged stores: a memory's provenance, which says
    nothing about which buffer the algorithm should have handed out; TLC judges that. A read byte
    whose value differs from the one stored there is tagged -1 (no write produced it)."""
    out: list[dict[str, int | str]] = []
    stored: dict[tuple[int, int], tuple[int, int]] = {}  # (buffer, index) -> (value, write)
    writes = 0
    filling = -1
    locked = -1
    with path.open() as f:
        for line in f:
            if '"cat":"mailbox"' not in line:
                continue
            d = json.loads(line)
            ev = str(d["ev"])
            if d["dev"] != device or ev not in _INBOX_EVENTS:
                continue
            if ev in ("wbegin", "wnack"):
                writes += 1
                filling = int(d["buf"]) if ev == "wbegin" else -1
                out.append({"ev": ev, "buf": filling} if ev == "wbegin" else {"ev": ev})
            elif ev == "wbyte":
                stored[(filling, int(d["index"]))] = (int(d["value"]), writes)
                out.append({"ev": ev, "index": int(d["index"])})
            elif ev == "lock":
                locked = int(d["buf"])
                out.append({"ev": ev, "buf": locked})
            elif ev == "rbyte":
                k = int(d["index"])
                value, write = stored.get((locked, k), (0, 0))
                out.append({"ev": ev, "index": k, "tag": write if value == int(d["value"]) else -1})
            elif ev == "in_release":
                out.append({"ev": "release"})
            else:
                out.append({"ev": ev})
    return out


def inbox_job(events: list[dict[str, int | str]], size: int, name: str = "") -> TraceJob:
    """An inbox trace (inbox_trace) of a `size`-byte inbox as sim/tla/TraceInbox.tla checks it against
    MailboxInbox.tla (check_inbox)."""
    if size < 2:
        raise ValueError(f"inbox of {size} byte(s): MailboxInbox.tla needs MsgLen >= 2 (a torn read must be "
                         "observable); trace an inbox of 2 bytes or more")
    items = []
    for e in events:
        fields = [f'ev |-> "{e["ev"]}"'] + [f"{k} |-> {v}" for k, v in e.items() if k != "ev"]
        items.append("[" + ", ".join(fields) + "]")
    writes = max(1, sum(1 for e in events if e["ev"] in ("wbegin", "wnack")))
    return TraceJob("TraceInbox", {"MsgLen": str(size), "MaxWrites": str(writes), "MaxRetry": str(INBOX_MAX_RETRY),
                                   "Trace": _tla_trace(items)}, events, name)


def check_inbox(events: list[dict[str, int | str]], size: int) -> TraceResult:
    """Check an inbox trace (inbox_trace) of a `size`-byte inbox against MailboxInbox.tla."""
    return check_jobs([inbox_job(events, size)])[0]


# --------------------------------------------------------------------------- USB uplink traces

#: UsbUplink.tla's MaxLatency: a callback at most this many 1-ms frames after its submission,
#: counting both (paper Sec. V-C: 3 ms).
USB_MAX_LATENCY = 3


@dataclass
class UsbEvent:
    """One TraceUsbUplink event: "submit" (id), "write" (ids), "read" (seqs) or "callback" (id, ok),
    in host frame f."""

    ev: str
    f: int
    id: int = 0
    ids: list[int] = field(default_factory=list)
    seqs: list[int] = field(default_factory=list)
    ok: bool = True

    def tla(self) -> str:
        fields = {"submit": f"id |-> {self.id}", "write": f"ids |-> <<{', '.join(map(str, self.ids))}>>",
                  "read": f"seqs |-> <<{', '.join(map(str, self.seqs))}>>",
                  "callback": f"id |-> {self.id}, ok |-> {'TRUE' if self.ok else 'FALSE'}"}[self.ev]
        return f'[ev |-> "{self.ev}", f |-> {self.f}, {fields}]'


def usb_trace(log: Sequence[UsbTraceEvent], frame_ns: int = NS_PER_MS) -> list[UsbEvent]:
    """TraceUsbUplink events from a UsbCore's trace (`UsbCore.trace`, started with nothing queued or
    in flight): frames counted from the first event's, requests numbered by submission from 1, and
    sequence numbers renumbered so that the first submitted request's is 1, as UsbUplink.tla numbers
    them (id mod 16); the host must have numbered its requests consecutively, which the check
    therefore verifies too."""
    if not log:
        return []
    ids: dict[int, int] = {}
    first_seq: int | None = None
    f0 = log[0][1] // frame_ns
    out: list[UsbEvent] = []

    def seq_of(t: Transfer) -> int:
        nonlocal first_seq
        if first_seq is None:
            first_seq = t.seq
        return (t.seq - first_seq + 1) % 16

    for ev, now, transfers in log:
        f = now // frame_ns - f0
        if ev == "submit":
            ids[id(transfers[0])] = len(ids) + 1
            out.append(UsbEvent(ev, f, id=ids[id(transfers[0])]))
        elif ev == "write":
            for t in transfers:
                seq_of(t)
            out.append(UsbEvent(ev, f, ids=[ids.get(id(t), 0) for t in transfers]))
        elif ev == "read":
            out.append(UsbEvent(ev, f, seqs=[seq_of(t) for t in transfers]))
        else:
            out += [UsbEvent(ev, (t.completed_ns or now) // frame_ns - f0, id=ids.get(id(t), 0), ok=not t.flags)
                    for t in transfers]
    return out


def usb_job(events: list[UsbEvent], max_batch: int, window: int = 15, name: str = "") -> TraceJob:
    """A USB uplink trace (usb_trace) as sim/tla/TraceUsbUplink.tla checks it against UsbUplink.tla
    (check_usb)."""
    submits = max(1, sum(1 for e in events if e.ev == "submit"))
    # the most submissions between two writes (UsbUplink.tla's budget, reset by UsbWrite)
    burst = run = 0
    for e in events:
        run = 0 if e.ev == "write" else run + (e.ev == "submit")
        burst = max(burst, run)
    return TraceJob("TraceUsbUplink", {
        "MaxBatch": str(max_batch), "MaxSubmit": str(max(1, burst)), "MaxReq": str(submits), "Window": str(window),
        "MaxLatency": str(USB_MAX_LATENCY), "SeqMod": "16", "Trace": _tla_trace(e.tla() for e in events),
    }, events, name)


def check_usb(events: list[UsbEvent], max_batch: int, window: int = 15) -> TraceResult:
    """Check a USB uplink trace (usb_trace) of a host writing at most `max_batch` requests per bulk-OUT
    transfer with at most `window` in flight (UsbCore.window) against UsbUplink.tla (a rejected trace
    comes with the longest prefix a behaviour matched)."""
    return check_jobs([usb_job(events, max_batch, window)])[0]


# --------------------------------------------------------------------------- discovery traces

#: Discovery.tla's NAddr: the 7-bit addresses a scan map covers (BridgeScan.present[1..127]).
DISCOVERY_ADDRESSES = 127


@dataclass(frozen=True)
class Ident:
    """What a node reports in outbox 0 and Discovery.tla compares: class, index, layout fingerprint."""

    cls: int
    index: int
    fp: int

    def fields(self) -> str:
        """Its record fields in TLA+ (Discovery.tla's identities and table rows share them)."""
        return f'class |-> {self.cls}, index |-> {self.index}, fp |-> "{self.fp:08x}"'

    def tla(self) -> str:
        return f"[{self.fields()}]"


@dataclass(frozen=True)
class TableRow:
    """A row of the host's system table: where the node answered, what it reported, its flags."""

    bridge: int
    addr: int
    ident: Ident
    flags: frozenset[str]

    def tla(self) -> str:
        flags = ", ".join(f'"{f}"' for f in sorted(self.flags))
        return f"[bridge |-> {self.bridge}, addr |-> {self.addr}, {self.ident.fields()}, flags |-> {{{flags}}}]"


@dataclass
class DiscoveryEvent:
    """One TraceDiscovery event: "scan" (bridge, addr, found: the identity read, None when nothing
    answered), "table" (rows) or "request" (bridge, addr, status "OK" or "NO_NODE")."""

    ev: str
    bridge: int = 0
    addr: int = 0
    found: Ident | None = None
    rows: list[TableRow] = field(default_factory=list)
    status: str = ""

    def tla(self) -> str:
        if self.ev == "scan":
            found = "{}" if self.found is None else f"{{[addr |-> {self.addr}, id |-> {self.found.tla()}]}}"
            return f'[ev |-> "scan", bridge |-> {self.bridge}, addr |-> {self.addr}, found |-> {found}]'
        if self.ev == "table":
            return '[ev |-> "table", rows |-> {' + ", ".join(r.tla() for r in self.rows) + "}]"
        return f'[ev |-> "request", bridge |-> {self.bridge}, addr |-> {self.addr}, status |-> "{self.status}"]'


@dataclass
class DiscoveryTrace:
    """A discovery as TraceDiscovery.tla checks it: the system's wiring (bridge, address) -> identity,
    the fingerprint the host expects per class, the slots whose power the scenario switched and how
    often, and the events."""

    bridges: list[int]
    wired: dict[tuple[int, int], Ident]
    expected: dict[int, int]
    churn_slots: set[tuple[int, int]]
    churn: int
    events: list[DiscoveryEvent] = field(default_factory=list)


def discovery_job(t: DiscoveryTrace, name: str = "") -> TraceJob:
    """A discovery trace as sim/tla/TraceDiscovery.tla checks it against Discovery.tla
    (check_discovery)."""
    wired = " @@ ".join(f"<<{b}, {a}>> :> {i.tla()}" for (b, a), i in sorted(t.wired.items()))
    expected = "[tClass \\in {" + ", ".join(str(c) for c in sorted(t.expected)) + "} |-> CASE " + " [] ".join(
        f'tClass = {c} -> "{fp:08x}"' for c, fp in sorted(t.expected.items())) + "]"
    return TraceJob("TraceDiscovery", {
        "Bridges": f"{{{', '.join(str(b) for b in t.bridges)}}}",
        "NAddr": str(DISCOVERY_ADDRESSES),
        "Idents": "{" + ", ".join(sorted({i.tla() for i in t.wired.values()})) + "}",
        "Expected": expected,
        "MaxChurn": str(t.churn),
        "TChurnSlots": "{" + ", ".join(f"<<{b}, {a}>>" for b, a in sorted(t.churn_slots)) + "}",
        "TWired": wired,
        "Trace": _tla_trace(e.tla() for e in t.events),
    }, t.events, name)


def check_discovery(t: DiscoveryTrace) -> TraceResult:
    """Check a discovery trace against Discovery.tla in one TLC run (a rejected trace comes with the
    longest prefix a behaviour matched)."""
    return check_jobs([discovery_job(t)])[0]
