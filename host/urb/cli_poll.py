"""`urb monitor` and `urb log`: read outboxes periodically, show or record every response.

A bridge that goes away (BRIDGE_LOST: its port failed, or it stopped answering for
`lost_after`) is said once on stderr. Without --reconnect its mailboxes are no longer read and
the command stops when no bridge is left; with it (the default of `urb monitor`) the bridge is
reopened and rediscovered in the background, after 0.25 s and then at doubling intervals up to
4 s, and reading resumes when it answers again, with a line saying so.
"""

from __future__ import annotations

import argparse
import csv
import importlib
import importlib.util
import math
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

from rich.live import Live
from rich.table import Table

from urb_msgs import Message

from .api import NodeAccessor, NodeRequest, URBInterface
from .cli_args import NodeSpec, UsageError, check_node_mailboxes, check_ports, mailbox_number, parse_mailbox, parse_node
from .cli_common import (
    EXIT_FAIL,
    EXIT_OK,
    connected,
    console,
    discovery_timeout_s,
    field_names,
    find,
    flatten,
    fmt_value,
    guarded,
    went_away,
)
from .errors import ErrorFlag, PortError, URBError
from .managers.base import BusManager


@dataclass
class Channel:
    """One (node, outbox) being polled, with its statistics."""

    node: NodeAccessor
    box: int
    cls: type[Message]
    name: str
    """How the node is shown: its class and index, and its address when it was given by one."""
    current: NodeRequest | None = None
    """The read in flight (None: none)."""
    ok: int = 0
    skipped: int = 0
    errors: dict[str, int] = field(default_factory=dict)
    latencies: list[int] = field(default_factory=list)
    last: list[tuple[str, Any, str | None]] = field(default_factory=list)
    first_ns: int | None = None
    last_ns: int | None = None
    last_flags: ErrorFlag | None = None
    """Outcome of the latest completed read (None before the first)."""

    @property
    def pending(self) -> bool:
        return self.current is not None

    @property
    def label(self) -> str:
        return f"{self.name}/{self.box}"

    @property
    def bridge(self) -> str:
        return self.node.manager.name

    def latency_ms(self) -> tuple[float, float, float]:
        lat = sorted(self.latencies[-5000:])
        if not lat:
            return (math.nan, math.nan, math.nan)
        return (sum(lat) / len(lat) / 1e6, lat[min(len(lat) - 1, int(len(lat) * 0.99))] / 1e6, lat[-1] / 1e6)

    def rate(self) -> float:
        if self.first_ns is None or self.last_ns is None or self.last_ns <= self.first_ns:
            return 0.0
        return (self.ok - 1) / ((self.last_ns - self.first_ns) / 1e9) if self.ok > 1 else 0.0


def parse_targets(args: argparse.Namespace) -> tuple[list[NodeSpec], list[int | str]]:
    """--node and --mailbox, checked before any port is opened (UsageError when wrong)."""
    check_ports(args.ports)
    specs = [parse_node(text, args.ports) for text in args.node]
    boxes = [parse_mailbox(text) for text in args.mailbox]
    for spec in specs:
        check_node_mailboxes(spec, boxes, "outbox")
    return specs, boxes


def channels_for(urb: URBInterface, specs: list[NodeSpec], boxes: list[int | str]) -> list[Channel]:
    """A channel for every outbox to read: the given ones (or every outbox but 0) of the given
    nodes (or of every usable node)."""
    targets: list[tuple[NodeAccessor, str]] = [
        (acc, acc.label if spec.address is None else f"{acc.label}@{acc.address}")
        for spec in specs for acc in [find(urb, spec)]] if specs else [
        (acc, acc.label) for r in urb.nodes() if r.usable for acc in [urb.find_node(r.class_id, r.index)]]
    if not targets:
        raise URBError("no usable node to poll: `urb scan PORT` shows the nodes and why any is flagged; "
                       "a flagged node can be given by its bus address (--node PORT@ADDR)")
    out: list[Channel] = []
    for acc, name in targets:
        numbers = [mailbox_number(acc.info, b, "outbox", name) for b in boxes] if boxes else sorted(
            m.number for m in acc.info.mailboxes if m.direction == "outbox" and m.number != 0)
        for n in numbers:
            mb = acc.info.mailbox("outbox", n)
            assert mb is not None
            out.append(Channel(acc, n, mb.message, name))
    if not out:
        raise UsageError("the nodes given have no outbox but 0 (their identification): give --mailbox 0 to read it")
    return out


class Reconnector:
    """Reopens and rediscovers one lost bridge on its own thread: first after FIRST_WAIT_S, then
    after twice the previous wait, at most MAX_WAIT_S, until it answers or `stop()`."""

    FIRST_WAIT_S = 0.25
    MAX_WAIT_S = 4.0

    def __init__(self, manager: BusManager, reconnect: Callable[[BusManager], object]) -> None:
        self.manager = manager
        self.started = time.monotonic()
        self.attempts = 0
        self.back_after_s: float | None = None
        """Seconds from the loss to the bridge answering again (None: not back)."""
        self.last_error = ""
        self._reconnect = reconnect
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._run, name=f"urb-reconnect {manager.name}", daemon=True)
        self.thread.start()

    def _run(self) -> None:
        wait = self.FIRST_WAIT_S
        while not self._stop.wait(wait):
            self.attempts += 1
            try:
                self._reconnect(self.manager)
            except URBError as exc:  # a PortError's detail: without the advice meant for a library caller
                self.last_error = exc.detail if isinstance(exc, PortError) else str(exc)
                wait = min(2 * wait, self.MAX_WAIT_S)
                continue
            self.back_after_s = time.monotonic() - self.started
            return

    def stop(self) -> None:
        """No further attempt; waits for the one under way (bounded by the discovery timeout)."""
        self._stop.set()
        self.thread.join()


class Poller:
    """Submits a read of every channel every 1/rate s (absolute schedule, no resubmission while
    pending) and hands each completed request to `on_result` on the dispatcher.

    A bridge found lost (its manager's `lost_reason`, or a read completed BRIDGE_LOST) is
    reported once on stderr and its channels are no longer read. Without `reconnect`, polling
    ends when no bridge is left; with it, each lost bridge is given to a `Reconnector` and read
    again once it is back. Once `run` has returned, completions are ignored: `on_result` never
    runs again (the requests still in flight complete BRIDGE_LOST when the ports close)."""

    def __init__(self, channels: list[Channel], rate: float, on_result: Callable[[Channel, NodeRequest], None],
                 grace_s: float = 2.0, reconnect: Callable[[BusManager], object] | None = None) -> None:
        if not (math.isfinite(rate) and rate > 0):
            raise URBError("--rate must be a positive number")
        self.channels = channels
        self.period_ns = max(1, int(1e9 / rate))
        self.on_result = on_result
        self.grace_s = grace_s
        self.reconnect = reconnect
        self.lock = threading.RLock()
        self.vanished: set[str] = set()
        self.lost: dict[str, str] = {}
        """Bridges away now (name -> reason), each loss reported once on stderr."""
        self.came_back = 0
        """Losses that ended with the bridge answering again."""
        self.unanswered: list[Channel] = []
        """Channels whose read was still in flight when the poller stopped."""
        self.interrupted = False
        self._found_lost: dict[str, str] = {}
        self._reconnectors: dict[str, Reconnector] = {}
        self._stopped = False
        self._running = False

    def _callback(self, ch: Channel) -> Callable[[NodeRequest], None]:
        def done(req: NodeRequest) -> None:
            with self.lock:  # held through on_result, so that nothing is recorded after stop()
                if self._stopped or req is not ch.current:
                    return  # after the end (BRIDGE_LOST when the port closes), or stale: not recorded
                ch.current = None
                ch.last_flags = req.flags
                if req.ok:
                    ch.ok += 1
                    ch.latencies.append(req.latency_ns or 0)
                    ch.first_ns = ch.first_ns if ch.first_ns is not None else req.completed_ns
                    ch.last_ns = req.completed_ns
                else:
                    name = req.flags.describe()
                    ch.errors[name] = ch.errors.get(name, 0) + 1
                    if req.flags == ErrorFlag.NO_NODE:
                        self.vanished.add(ch.name)
                    if req.flags & ErrorFlag.BRIDGE_LOST:
                        self._found_lost.setdefault(ch.bridge, ch.node.manager.lost_reason or "BRIDGE_LOST")
                self.on_result(ch, req)
        return done

    def _bridge_lost(self, ch: Channel) -> bool:
        """Whether the channel's bridge is known lost (noting a newly lost one); lock held."""
        if ch.bridge in self._found_lost:
            return True
        reason = ch.node.manager.lost_reason
        if reason is not None:
            self._found_lost[ch.bridge] = reason
            return True
        return False

    def tick(self) -> None:
        for ch in self.channels:
            with self.lock:
                if self._bridge_lost(ch):
                    continue
                if ch.pending:
                    ch.skipped += 1
                    continue
                req = ch.node.new_request().read(ch.box).set_callback(self._callback(ch))
                ch.current = req
            ch.node.submit_request(req)

    def _report_lost(self) -> None:
        """Say once on stderr which bridge went away, and why, and what happens now (main thread)."""
        with self.lock:
            for ch in self.channels:
                self._bridge_lost(ch)
            new = [(name, reason) for name, reason in self._found_lost.items() if name not in self.lost]
            self.lost.update(new)
            left = self.bridges_left()  # the lock is reentrant
        for name, reason in new:
            if not self._running:
                then = ""
            elif self.reconnect is not None:
                then = "; reconnecting in the background (Ctrl-C to stop)"
                manager = next(ch.node.manager for ch in self.channels if ch.bridge == name)
                self._reconnectors[name] = Reconnector(manager, self.reconnect)
            elif not left:
                then = "; stopping (no bridge left)"
            else:
                then = "; no longer reading it, the other bridges go on"
            print(f"urb: {went_away(name, reason)}{then}", file=sys.stderr)

    def _report_back(self) -> None:
        """Read again the bridges whose reconnection succeeded, with a line saying so (main thread)."""
        for name, rc in list(self._reconnectors.items()):
            if rc.back_after_s is None:
                continue
            del self._reconnectors[name]
            with self.lock:
                self._found_lost.pop(name, None)
                self.lost.pop(name, None)
                self.came_back += 1
                gone = sorted({ch.name for ch in self.channels if ch.bridge == name and not ch.node.record.active})
            missing = (f"; not found again: {', '.join(gone)} (their reads fail UNKNOWN_NODE until `urb scan` "
                       f"finds them)" if gone else "")
            print(f"urb: the bridge on {name} is back after {rc.back_after_s:.1f} s ({rc.attempts} attempt"
                  f"{'s' if rc.attempts > 1 else ''}); reading it again{missing}", file=sys.stderr)

    def bridges_left(self) -> bool:
        with self.lock:
            return bool({ch.bridge for ch in self.channels} - set(self._found_lost))

    def run(self, duration_s: float | None, idle: Callable[[], None] | None = None) -> None:
        """Poll until `duration_s` passes, Ctrl-C (sets `interrupted`) or, without reconnection,
        no bridge is left; then wait up to `grace_s` for the reads in flight, and stop. A second
        Ctrl-C while waiting stops at once (KeyboardInterrupt propagates)."""
        self._running = True
        try:
            try:
                self._poll(duration_s, idle)
            except KeyboardInterrupt:
                self.interrupted = True
            started = time.monotonic()
            told = False
            while time.monotonic() < started + self.grace_s:
                with self.lock:
                    in_flight = sum(ch.pending for ch in self.channels)
                if not in_flight:
                    break
                if not told and time.monotonic() > started + 0.5:
                    told = True
                    print(f"urb: waiting up to {self.grace_s:g} s for {in_flight} read(s) in flight "
                          f"(Ctrl-C to stop now)", file=sys.stderr)
                time.sleep(0.01)
        finally:
            self._running = False
            self.stop()

    def _poll(self, duration_s: float | None, idle: Callable[[], None] | None) -> None:
        start = time.monotonic_ns()
        end = None if duration_s is None else start + int(duration_s * 1e9)
        k = 0
        while end is None or time.monotonic_ns() < end:
            self._report_lost()
            self._report_back()
            if self.reconnect is None and not self.bridges_left():
                return
            target = start + k * self.period_ns
            now = time.monotonic_ns()
            if target > now:
                time.sleep(min(target - now, 50_000_000) / 1e9)
                if idle is not None:
                    idle()
                continue
            missed = (now - target) // self.period_ns
            k += 1 + int(missed)  # never burst to catch up
            self.tick()
            if idle is not None:
                idle()

    def stop(self) -> None:
        """Record no completion from now on; note the reads still in flight; end reconnection."""
        with self.lock:
            if self._stopped:
                return
            self._stopped = True
            self.unanswered = [ch for ch in self.channels if ch.pending]
        for rc in self._reconnectors.values():
            rc.stop()
        self._report_back()  # an attempt that succeeded while stopping
        self._report_lost()

    def silent_bridges(self) -> list[str]:
        """Bridges not lost whose last read of every mailbox got no response (UPLINK_TIMEOUT, or
        still in flight at the end): a bridge that stopped answering."""
        out: list[str] = []
        with self.lock:
            in_flight = {id(ch) for ch in self.unanswered}
            for name in dict.fromkeys(ch.bridge for ch in self.channels):
                if name in self.lost:
                    continue
                mine = [ch for ch in self.channels if ch.bridge == name]
                if all(id(ch) in in_flight or (ch.last_flags is not None and bool(ch.last_flags & ErrorFlag.UPLINK_TIMEOUT))
                       for ch in mine):
                    out.append(name)
        return out

    def report_end(self, ports: list[str]) -> bool:
        """Explain on stderr what went wrong during the run; True when something did (exit 1).
        Losses were reported when found; a bridge that came back is no failure."""
        for name, rc in self._reconnectors.items():
            last = f"; last attempt: {rc.last_error}" if rc.last_error else ""
            print(f"urb: the bridge on {name} did not come back ({rc.attempts} attempt"
                  f"{'s' if rc.attempts != 1 else ''} to reconnect{last})", file=sys.stderr)
        for label in sorted(self.vanished):
            print(f"urb: node {label} stopped answering (NO_NODE): check its connector and power, then run "
                  f"`urb scan {' '.join(ports)}`", file=sys.stderr)
        silent = self.silent_bridges()
        for name in silent:
            print(f"urb: the bridge on {name} stopped answering: the last read of each of its mailboxes got no "
                  f"response (UPLINK_TIMEOUT); check that it is powered and its cable", file=sys.stderr)
        late = [ch for ch in self.unanswered if ch.bridge not in self.lost]
        if late:
            print(f"urb: {len(late)} read(s) still in flight {self.grace_s:g} s after the end are not recorded: "
                  f"{', '.join(ch.label for ch in late)}", file=sys.stderr)
        return bool(self.lost or self.vanished or silent or late)


def stats_table(channels: list[Channel], title: str) -> Table:
    table = Table(title=title, show_edge=False, header_style="bold", title_justify="left")
    for col in ("node/outbox", "message", "values", "rate Hz", "mean ms", "p99 ms", "max ms", "ok", "errors", "skipped"):
        table.add_column(col, justify="right" if col not in ("node/outbox", "message", "values", "errors") else "left")
    for ch in channels:
        mean, p99, mx = ch.latency_ms()
        vals = " ".join(f"{n}={fmt_value(v)}{unit or ''}" for n, v, unit in ch.last[:6])
        if len(ch.last) > 6:
            vals += " ..."
        errs = " ".join(f"{k}:{v}" for k, v in sorted(ch.errors.items()))
        table.add_row(ch.label, ch.cls.NAME, vals, f"{ch.rate():.1f}", _ms(mean), _ms(p99), _ms(mx), str(ch.ok),
                      f"[red]{errs}[/]" if errs else "", str(ch.skipped))
    return table


def _ms(v: float) -> str:
    return "-" if math.isnan(v) else f"{v:.2f}"


def reconnector(urb: URBInterface, args: argparse.Namespace) -> Callable[[BusManager], object] | None:
    """What reconnects a lost bridge with --reconnect (None without it)."""
    if not args.reconnect:
        return None
    return lambda manager: urb.reconnect(manager, timeout_s=discovery_timeout_s(args))


@guarded
def run_monitor(args: argparse.Namespace) -> int:
    specs, boxes = parse_targets(args)
    with connected(args.ports, args) as urb:
        channels = channels_for(urb, specs, boxes)

        def on_result(ch: Channel, req: NodeRequest) -> None:
            if req.ok:
                try:
                    ch.last = flatten(req.message())
                except URBError:
                    ch.last = [("raw", (req.data or b"").hex(), None)]

        poller = Poller(channels, args.rate, on_result, grace_s=args.timeout + 0.5, reconnect=reconnector(urb, args))
        term = console()
        title = f"urb monitor: {', '.join(args.ports)} at {args.rate:g} Hz per mailbox"

        def final_title() -> str:
            return title + (" (stopped)" if poller.interrupted else "")

        if term.is_terminal:
            with Live(stats_table(channels, title), console=term, refresh_per_second=4, transient=False) as live:
                poller.run(args.duration, idle=lambda: live.update(stats_table(channels, title)))
                live.update(stats_table(channels, final_title()))
        else:
            poller.run(args.duration)
            term.print(stats_table(channels, final_title()))
        return EXIT_FAIL if poller.report_end(args.ports) else EXIT_OK


class _Sink:
    """Row writer: CSV streamed, Parquet collected and written at the end (pyarrow)."""

    def __init__(self, path: Path, columns: list[str]) -> None:
        self.path = path
        self.columns = columns
        self.rows = 0
        self.closed = False
        self.dropped = 0
        """Rows given after close(): not written."""
        self.parquet = path.suffix.lower() in (".parquet", ".pq")
        self._fh: TextIO | None = None
        self._writer: Any = None
        self._buffer: list[dict[str, Any]] = []
        if self.parquet:
            if importlib.util.find_spec("pyarrow") is None:
                raise URBError(f"{path}: writing Parquet needs pyarrow (pip install pyarrow); or give a .csv file")
        else:
            try:
                self._fh = path.open("w", newline="")
            except OSError as exc:
                raise URBError(f"{path}: cannot write the log ({exc.strerror})") from None
            self._writer = csv.DictWriter(self._fh, fieldnames=columns, extrasaction="ignore")
            self._writer.writeheader()

    def write(self, row: dict[str, Any]) -> None:
        if self.closed:
            self.dropped += 1
            return
        self.rows += 1
        if self.parquet:
            self._buffer.append(row)
        else:
            self._writer.writerow(row)

    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        if self._fh is not None:
            self._fh.close()
        if self.parquet:
            pa: Any = importlib.import_module("pyarrow")
            pq: Any = importlib.import_module("pyarrow.parquet")
            table = pa.table({c: [r.get(c) for r in self._buffer] for c in self.columns})
            pq.write_table(table, str(self.path))


@guarded
def run_log(args: argparse.Namespace) -> int:
    specs, boxes = parse_targets(args)
    with connected(args.ports, args) as urb:
        channels = channels_for(urb, specs, boxes)
        fields: list[str] = []
        for ch in channels:
            fields += [n for n in field_names(ch.cls) if n not in fields]
        columns = ["t_submit_ns", "t_complete_ns", "latency_us", "bridge", "address", "node", "mailbox", "message",
                   "status"] + fields
        sink = _Sink(args.output, columns)
        write_lock = threading.Lock()

        def on_result(ch: Channel, req: NodeRequest) -> None:
            row: dict[str, Any] = {
                "t_submit_ns": req.submitted_ns, "t_complete_ns": req.completed_ns,
                "latency_us": round((req.latency_ns or 0) / 1e3, 1), "bridge": ch.node.manager.name,
                "address": ch.node.address, "node": ch.name, "mailbox": ch.box, "message": ch.cls.NAME,
                "status": req.flags.describe()}
            if req.ok:
                try:
                    ch.last = flatten(req.message())
                    row.update({n: v for n, v, _ in ch.last})
                except URBError:
                    row["status"] = "UNDECODABLE"
            with write_lock:
                sink.write(row)

        poller = Poller(channels, args.rate, on_result, grace_s=args.timeout + 0.5, reconnect=reconnector(urb, args))
        try:
            poller.run(args.duration)  # returns after poller.stop(): no row comes in later
        finally:
            with write_lock:
                sink.close()
        stopped = " (stopped)" if poller.interrupted else ""
        console(stderr=True).print(stats_table(channels, f"urb log: {sink.rows} rows to {args.output}{stopped}"))
        return EXIT_FAIL if poller.report_end(args.ports) else EXIT_OK
