"""The URB host API: every node looks directly attached, whichever bridge it sits behind
(paper Sec. IV-C, Fig. 5).

    urb = URBInterface.instance()
    urb.add_bus_manager(RS232Manager("/dev/ttyS0"))         # opens, discovers the downlink
    motor = urb.find_node("MotorDriver", 0)                  # a NodeAccessor

    def on_feedback(req: NodeRequest) -> None:
        if req.ok:
            fb = req.message(MotorFeedback)                  # decoded, typed
        else:
            print(req.flags.describe(), req.error)           # e.g. NO_NODE, UPLINK_TIMEOUT

    req = motor.new_request().read(1).set_callback(on_feedback)
    motor.submit_request(req)                                # callback on the dispatcher thread

Blocking conveniences for scripts (`motor.read_message(MotorFeedback)`, `motor.write(1, cmd)`)
raise `RequestFailed`; asyncio ones (`await motor.aread(1)`) likewise. Nothing is retransmitted.
Every request carries its timestamps (`submitted_ns`, `sent_ns`, `completed_ns`, `callback_ns`)
in the manager's clock, so latency is measurable from the API (paper Figs. 15, 16).
"""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import ClassVar

import urb_msgs
from urb_msgs import DecodeError, Message, NodeInfo
from urb_msgs.urb_core import (
    BRIDGE,
    BRIDGE_ADDRESS,
    BridgeCommand,
    BridgeInfo,
    BridgeOpcode,
    BridgeScan,
    Identification,
)

from .errors import (
    DuplicateNodeError,
    ErrorFlag,
    FingerprintMismatchError,
    NoBridgeError,
    NodeNotFoundError,
    RequestFailed,
    UnknownClassError,
    hint,
)
from .managers.base import BusManager, Transfer, decode_message, encode_message
from .managers.rs232_core import SCAN_ANSWER_NS
from .raw_node import raw_node_info
from .request import Callback, M, NodeRequest

DUPLICATE = "DUPLICATE"
MISMATCH = "MISMATCH"
UNKNOWN_CLASS = "UNKNOWN_CLASS"


# --------------------------------------------------------------------------------------------
# Discovery table rows
# --------------------------------------------------------------------------------------------

@dataclass(eq=False)
class NodeRecord:
    """One row of the system table: one node that answered on one (bridge, address)."""

    bridge: BusManager
    address: int
    ident: Identification
    info: NodeInfo | None
    """The schema's node type for its class (None: class unknown to this host)."""
    flags: set[str] = field(default_factory=set)
    active: bool = True
    """False once a rediscovery no longer found it: requests complete UNKNOWN_NODE."""

    @property
    def class_id(self) -> int:
        return self.ident.class_id

    @property
    def index(self) -> int:
        return self.ident.index

    @property
    def name(self) -> str:
        return self.info.name if self.info is not None else f"class 0x{self.ident.class_id:02x}"

    @property
    def fingerprint(self) -> int:
        return self.ident.fingerprint

    @property
    def expected_fingerprint(self) -> int | None:
        return self.info.fingerprint if self.info is not None else None

    @property
    def firmware(self) -> str:
        return f"{self.ident.fw_major}.{self.ident.fw_minor}.{self.ident.fw_patch}"

    @property
    def usable(self) -> bool:
        return self.active and not self.flags

    @property
    def label(self) -> str:
        return f"{self.name}:{self.index}"

    @property
    def location(self) -> str:
        return f"{self.bridge.name} address {self.address}"


@dataclass
class BridgeReport:
    """What discovery found on one bridge."""

    manager: BusManager
    info: BridgeInfo | None = None
    present: list[int] = field(default_factory=list)
    records: list[NodeRecord] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)
    error: str | None = None
    """Set when discovery failed as a whole (no bridge answering, bridge lost)."""



# --------------------------------------------------------------------------------------------
# NodeAccessor
# --------------------------------------------------------------------------------------------

class NodeAccessor:
    """Access to one discovered node, as if directly attached (whatever bridge it is behind)."""

    def __init__(self, interface: URBInterface, record: NodeRecord, info: NodeInfo | None = None) -> None:
        """`info`: the layout to use instead of the schema's (`raw_node.raw_node_info`, for a node
        reached by its address whose layout the schema does not describe)."""
        layout = info if info is not None else record.info
        if layout is None:
            raise UnknownClassError(f"{record.name} is not declared in the host's schema")
        self.interface = interface
        self.record = record
        self.info: NodeInfo = layout
        self.own_layout = info is not None
        """The mailboxes are the node's own report (raw bytes), not the schema's layout."""
        self._default_callback: Callback | None = None
        self._stats_lock = threading.Lock()
        self.completed = 0
        self.failed = 0
        self._boxes: dict[tuple[type[Message], str], int] = {}
        """`mailbox_of`'s answers (asked for every request built with read_message/write_message)."""
        self._sizes: dict[tuple[bool, int], int] = {(m.direction == "outbox", m.number): m.size
                                                     for m in layout.mailboxes}
        """(is a read, mailbox) -> the layout's size, looked up for every request (`schema_size`)."""

    @property
    def manager(self) -> BusManager:
        return self.record.bridge

    @property
    def address(self) -> int:
        return self.record.address

    @property
    def label(self) -> str:
        return self.record.label

    def new_request(self) -> NodeRequest:
        return NodeRequest(self)

    def set_callback(self, fn: Callback | None) -> None:
        """Default callback for requests that have none of their own."""
        self._default_callback = fn

    def schema_size(self, read: bool, mbox: int) -> int | None:
        """The size of outbox (`read`) or inbox `mbox` in this node's layout, None when it has none."""
        return self._sizes.get((read, mbox))

    def mailbox_of(self, cls: type[Message], direction: str) -> int:
        """The number of the `direction` mailbox holding `cls` in the schema."""
        known = self._boxes.get((cls, direction))
        if known is not None:
            return known
        boxes = [m.number for m in self.info.mailboxes if m.direction == direction and m.message is cls]
        if len(boxes) != 1:
            have = ", ".join(f"{m.direction} {m.number} {m.message.NAME}" for m in self.info.mailboxes)
            what = "no" if not boxes else "more than one"
            raise ValueError(f"{self.info.name} has {what} {direction} of type {cls.NAME}; pass mbox= explicitly ({have})")
        self._boxes[(cls, direction)] = boxes[0]
        return boxes[0]

    def submit_request(self, req: NodeRequest) -> NodeRequest:
        """Send the request; its callback runs once it completes. Returns the request."""
        if req.node is not self:
            raise ValueError("the request belongs to another node; make it with this node's new_request()")
        rec = self.record
        t = req._make_transfer(rec.address)
        # the host's refusals, in this order (urb.cycle's items apply the same rules)
        if not rec.active:
            rec.bridge.reject(t, ErrorFlag.UNKNOWN_NODE)
        elif rec.flags and MISMATCH in rec.flags and not self.own_layout:
            rec.bridge.reject(t, ErrorFlag.FINGERPRINT_MISMATCH)
        elif self._sizes.get((t.read, t.mailbox)) != t.length:  # None: no such mailbox
            rec.bridge.reject(t, ErrorFlag.HOST_SIZE_MISMATCH)
        else:
            rec.bridge.submit(t)
        return req

    def _note(self, ok: bool) -> None:
        """A request of this node completed (`ok`: without error)."""
        with self._stats_lock:
            self.completed += 1
            if not ok:
                self.failed += 1

    # -- blocking conveniences ----------------------------------------------------------------
    def request(self, req: NodeRequest, timeout_s: float = 1.0) -> NodeRequest:
        """Submit and wait; raises `RequestFailed` unless it succeeded."""
        self.submit_request(req)
        if not req.wait(timeout_s):
            raise RequestFailed(f"{self.label}: no completion within {timeout_s} s "
                                f"(the manager is not running?)", ErrorFlag.UPLINK_TIMEOUT)
        return req.raise_for_error()

    def read(self, mbox: int, timeout_s: float = 1.0) -> Message:
        """Read outbox `mbox` and decode it with the schema's message."""
        msg: Message = self.request(self.new_request().read(mbox), timeout_s).message()
        return msg

    def read_raw(self, mbox: int, size: int | None = None, timeout_s: float = 1.0) -> bytes:
        data = self.request(self.new_request().read(mbox, size), timeout_s).data
        assert data is not None
        return data

    def read_message(self, cls: type[M], mbox: int | None = None, timeout_s: float = 1.0) -> M:
        """Read the outbox holding `cls` and return it, typed."""
        out: M = self.request(self.new_request().read_message(cls, mbox), timeout_s).message(cls)
        return out

    def write(self, mbox: int, data: bytes | Message, timeout_s: float = 1.0) -> None:
        """Write inbox `mbox`; raises `RequestFailed` unless the node stored it."""
        self.request(self.new_request().write(mbox, data), timeout_s)

    def write_message(self, msg: Message, mbox: int | None = None, timeout_s: float = 1.0) -> None:
        self.request(self.new_request().write_message(msg, mbox), timeout_s)

    # -- asyncio conveniences -----------------------------------------------------------------
    async def asubmit(self, req: NodeRequest) -> NodeRequest:
        """Submit and await completion (any outcome); the request's own callback (or the node's
        default one) still runs first. The awaiter gets the request even when that callback
        raises; the exception is reported like any callback's (on stderr, by the dispatcher)."""
        loop = asyncio.get_running_loop()
        fut: asyncio.Future[NodeRequest] = loop.create_future()
        user_cb = req._callback or self._default_callback

        def resolve(r: NodeRequest) -> None:
            if not fut.done():
                fut.set_result(r)

        def done(r: NodeRequest) -> None:
            try:
                if user_cb is not None:
                    user_cb(r)
            finally:
                try:
                    loop.call_soon_threadsafe(resolve, r)
                except RuntimeError:  # the loop is closed: nobody awaits any more
                    pass

        req.set_callback(done)
        self.submit_request(req)
        return await fut

    async def aread(self, mbox: int) -> Message:
        req = (await self.asubmit(self.new_request().read(mbox))).raise_for_error()
        msg: Message = req.message()
        return msg

    async def aread_message(self, cls: type[M], mbox: int | None = None) -> M:
        req = (await self.asubmit(self.new_request().read_message(cls, mbox))).raise_for_error()
        out: M = req.message(cls)
        return out

    async def awrite(self, mbox: int, data: bytes | Message) -> None:
        (await self.asubmit(self.new_request().write(mbox, data))).raise_for_error()

    def __repr__(self) -> str:
        return f"<NodeAccessor {self.label} at {self.record.location}>"


# --------------------------------------------------------------------------------------------
# Discovery (a chain of callbacks, so it runs in real time and in virtual time alike)
# --------------------------------------------------------------------------------------------

class _Discovery:
    """BridgeInfo (address 0, outbox 0), optional SCAN command, BridgeScan (outbox 1), then
    outbox 0 of every present address (Discovery.tla `ScanAddress`: gaps never end a scan).

    A device on the uplink is believed to be a URB bridge only once its identification read
    came back OK and decodes as a BridgeInfo that checks (`believed_bridge`). Anything else,
    whatever bytes came back, is reported in the same words (`no_bridge_answered`): a port that
    carries noise (a wrong baud rate turns a bridge's answers into noise) passes a frame check by
    chance (a CRC-8 once in 256 candidates), so the outcome of that one read is no evidence of a
    bridge, nor of what is wrong with one."""

    def __init__(self, manager: BusManager, schema: Mapping[int, NodeInfo], rescan: bool,
                 on_done: Callable[[BridgeReport], None]) -> None:
        self.m = manager
        self.schema = schema
        self.rescan = rescan
        self.on_done = on_done
        self.report = BridgeReport(manager)
        self._outstanding = 0
        self._finished = False

    def start(self) -> None:
        self._send(0, 0, True, BRIDGE.sizes("outbox")[0], self._got_info)

    def _send(self, addr: int, box: int, read: bool, length: int, cb: Callable[[Transfer], None],
              data: bytes = b"", answer_within_ns: int = 0) -> None:
        self._outstanding += 1

        def done(t: Transfer) -> None:
            self._outstanding -= 1
            cb(t)
            self._maybe_finish()

        self.m.submit(Transfer(addr, box, read, length, data=data, on_done=done, answer_within_ns=answer_within_ns))

    def _fail(self, text: str) -> None:
        if self.report.error is None:
            self.report.error = text

    def _got_info(self, t: Transfer) -> None:
        """The bridge's own identification: the only evidence that a URB bridge is there."""
        info = believed_bridge(t)
        if info is None:
            self._fail(no_bridge_answered(self.m))
            return
        self.report.info = info
        self.m.set_window(min(info.fifo_depth, 15))
        if self.rescan:
            cmd = encode_message(BridgeCommand(opcode=BridgeOpcode.SCAN))
            # answered when the scan is over; the scan-map read behind it waits for it
            self._send(BRIDGE_ADDRESS, 0, False, len(cmd), self._got_scan_ack, data=cmd,
                       answer_within_ns=SCAN_ANSWER_NS)
        self._send(BRIDGE_ADDRESS, 1, True, BRIDGE.sizes("outbox")[1], self._got_scan)

    def _got_scan_ack(self, t: Transfer) -> None:
        if not t.ok:
            self.report.problems.append(f"the bridge did not accept SCAN ({t.flags.describe()}); using its last scan")

    def _got_scan(self, t: Transfer) -> None:
        if not t.ok or t.response is None:
            self._fail(f"reading the scan map of {self.m.name} failed: {t.flags.describe()}: {hint(t.flags)}")
            return
        scan = decode_message(BridgeScan, t.response)
        self.report.present = [a for a in range(1, 128) if scan.present[a]]
        for addr in self.report.present:
            self._send(addr, 0, True, Identification.SIZE, self._ident_callback(addr))

    def _ident_callback(self, addr: int) -> Callable[[Transfer], None]:
        return lambda t: self._got_ident(addr, t)

    IDENT_RETRIES = 2
    """A present address whose identification read fails with a transient downlink status is
    read again (a rescan of that address, Discovery.tla's remedy); application requests are never
    retransmitted."""

    # lobster-trace: urb.DSC_002, urb.DSC_003
    def _got_ident(self, addr: int, t: Transfer, attempt: int = 0) -> None:
        transient = ErrorFlag.TIMEOUT | ErrorFlag.CHECKSUM | ErrorFlag.BUS_STUCK | ErrorFlag.BUSY | ErrorFlag.UPLINK_CHECKSUM
        if not t.ok and t.flags & transient and attempt < self.IDENT_RETRIES:
            self._send(addr, 0, True, Identification.SIZE, lambda tr: self._got_ident(addr, tr, attempt + 1))
            return
        if not t.ok or t.response is None:
            self.report.problems.append(
                f"{self.m.name} address {addr}: identification read failed ({t.flags.describe()}: {hint(t.flags)}); "
                f"rescan when the node is back")
            return
        try:
            ident = decode_message(Identification, t.response)
        except DecodeError as exc:
            self.report.problems.append(f"{self.m.name} address {addr}: identification does not decode ({exc})")
            return
        rec = NodeRecord(self.m, addr, ident, self.schema.get(ident.class_id))
        if rec.info is None:
            rec.flags.add(UNKNOWN_CLASS)
        elif ident.fingerprint != rec.info.fingerprint:
            rec.flags.add(MISMATCH)
        elif list(ident.inbox_sizes) != rec.info.sizes("inbox") or list(ident.outbox_sizes) != rec.info.sizes("outbox"):
            rec.flags.add(MISMATCH)
            self.report.problems.append(f"{rec.label} at {rec.location}: fingerprint matches but mailbox sizes differ")
        self.report.records.append(rec)

    def _maybe_finish(self) -> None:
        if self._outstanding == 0 and not self._finished:
            self._finished = True
            self.report.records.sort(key=lambda r: r.address)
            self.on_done(self.report)




def bridge_info_problem(info: BridgeInfo) -> str:
    """What makes a decoded BridgeInfo impossible for a working bridge ("" when nothing does);
    the decoder has already checked the protocol version and the downlink kind."""
    if info.fifo_depth == 0:
        return "a request FIFO of depth 0"
    if info.bitrate_kbps == 0:
        return "a downlink bit rate of 0 kb/s"
    return ""


def believed_bridge(t: Transfer) -> BridgeInfo | None:
    """The BridgeInfo of a completed identification read, when it came back OK, decodes and
    checks; None otherwise (a failed read, a refusal, bytes that are no BridgeInfo)."""
    if not t.ok or t.response is None:
        return None
    try:
        info = decode_message(BridgeInfo, t.response)
    except DecodeError:
        return None
    return None if bridge_info_problem(info) else info


def no_bridge_answered(manager: BusManager) -> str:
    """Why discovery on `manager` found no bridge, and what to check; the same words whatever
    bytes came back (random bytes pass a frame check now and then, and mean nothing)."""
    if manager.lost_reason is not None:
        heard = manager.lost_reason
    elif manager.stats.stray_bytes:
        heard = (f"{manager.stats.stray_bytes} byte(s) came back, none of them a URB bridge's identification: "
                 f"what a wrong baud rate or another device looks like")
    else:
        heard = "nothing came back"
    return (f"no URB bridge answered on {manager.name} ({heard}). Check that the baud rate matches the bridge "
            f"firmware's, that {manager.name} is the bridge's device, and that the bridge is powered and connected.")


# --------------------------------------------------------------------------------------------
# URBInterface
# --------------------------------------------------------------------------------------------

class URBInterface:
    """The entry point: register bridges, find nodes. One per process (`instance()`), or
    constructed directly (tests, several simulated systems)."""

    _instance: ClassVar[URBInterface | None] = None
    _instance_lock: ClassVar[threading.Lock] = threading.Lock()

    def __init__(self, schema: Mapping[str, NodeInfo] | Iterable[NodeInfo] | None = None) -> None:
        """`schema`: the node types this host knows (default: every bundled schema, urb_msgs.NODES)."""
        nodes = list(schema.values()) if isinstance(schema, Mapping) else list(schema or urb_msgs.NODES.values())
        self.schema: dict[int, NodeInfo] = {n.class_id: n for n in nodes if n.kind == "node"}
        self.reports: dict[int, BridgeReport] = {}
        self._records: list[NodeRecord] = []
        self._accessors: dict[int | tuple[str, int], NodeAccessor] = {}
        self._lock = threading.RLock()
        self.on_bridge_lost: Callable[[BusManager, str], None] | None = None
        """`fn(manager, reason)`, called when a registered bridge's manager detects that the bridge
        is lost (I/O error, silence, timeouts in a row: host/urb/README.md), whether or not
        requests are pending: once per loss, on that manager's dispatcher (the clock's thread for
        SimManager), before the callbacks of the requests the loss fails. Not for `close()`. A
        blocking call in it raises, like in any callback; reconnect from another thread."""

    @classmethod
    def instance(cls) -> URBInterface:
        """The process-wide interface (the paper's singleton)."""
        with cls._instance_lock:
            if cls._instance is None:
                cls._instance = cls()
            return cls._instance

    # -- bridges ------------------------------------------------------------------------------
    def add_bus_manager(self, manager: BusManager, *, timeout_s: float = 3.0, rescan: bool = True) -> BridgeReport:
        """Register a bridge: start its manager and discover its downlink (blocking).

        Raises `PortError` (cannot open) or `NoBridgeError` (nothing answers; the manager is
        closed again, and may be passed to add_bus_manager once more)."""
        manager.start()
        box: list[BridgeReport] = []
        self.start_discovery(manager, box.append, rescan=rescan)
        if not manager.wait_until(lambda: bool(box), timeout_s):
            manager.close()
            raise NoBridgeError(f"discovery on {manager.name} did not finish within {timeout_s} s: "
                                f"check that the bridge is powered and connected")
        report = box[0]
        if report.error is not None:
            manager.close()  # no threads left behind; add_bus_manager() may be called again
            raise NoBridgeError(report.error)
        return report

    def start_discovery(self, manager: BusManager, on_done: Callable[[BridgeReport], None], *,
                        rescan: bool = True) -> None:
        """Non-blocking discovery for event-driven callers (the simulation): `on_done(report)`
        runs when the bridge's table is complete and merged into the system table."""
        manager.start()

        def finished(report: BridgeReport) -> None:
            if report.error is None:
                self._merge(report)
            on_done(report)

        _Discovery(manager, self.schema, rescan, finished).start()

    def reconnect(self, manager: BusManager, *, timeout_s: float = 3.0, rescan: bool = True) -> BridgeReport:
        """After BRIDGE_LOST: reopen the uplink and rediscover that bridge. Accessors to nodes
        found again keep working; nodes not found again answer UNKNOWN_NODE. Raises `PortError`
        when the uplink cannot be reopened yet (the manager stays lost; try again later) and
        `NoBridgeError` when no bridge answers."""
        manager.reconnect()
        box: list[BridgeReport] = []
        _Discovery(manager, self.schema, rescan, box.append).start()
        if not manager.wait_until(lambda: bool(box), timeout_s):
            raise NoBridgeError(f"no URB bridge answered on {manager.name} within {timeout_s} s after reconnecting")
        if box[0].error is not None:
            raise NoBridgeError(box[0].error)
        self._merge(box[0])
        return box[0]

    def service(self) -> int:
        """The cyclic runtime's step for every registered manager made with `cyclic=True`
        (`ThreadedManager.service`): what arrived, the deadlines, what is due to be sent, then
        their callbacks on the calling thread. Never waits. Returns the callbacks run. Managers
        that run their own threads are left to them. The pattern (host/urb/README.md, "The cyclic
        runtime"): sleep to each 1-ms tick, `service()`, then the control step and its
        submissions, which leave at the next tick's `service()`."""
        ran = 0
        for report in list(self.reports.values()):
            if report.manager.cyclic:
                ran += report.manager.service()
        return ran

    def close(self, *, drain: bool = True) -> None:
        """Close every registered manager (`BusManager.close`: each drains its requests in flight
        first, unless `drain=False`)."""
        for report in list(self.reports.values()):
            report.manager.close(drain=drain)

    def _merge(self, report: BridgeReport) -> None:
        """Replace the bridge's rows, keep accessors of nodes found again, recompute flags."""
        report.manager.add_lost_listener(self._bridge_lost)
        with self._lock:
            key = id(report.manager)
            self.reports[key] = report
            old = [r for r in self._records if r.bridge is report.manager]
            keep = [r for r in self._records if r.bridge is not report.manager]
            new: list[NodeRecord] = []
            for rec in report.records:
                prev = next((o for o in old if o.active and o.class_id == rec.class_id and o.index == rec.index), None)
                if prev is not None:  # same node again (maybe re-flashed): update in place, accessors stay valid
                    old.remove(prev)
                    prev.address, prev.ident, prev.info = rec.address, rec.ident, rec.info
                    prev.flags = set(rec.flags)
                    rec = prev
                new.append(rec)
            for gone in old:
                gone.active = False
            self._records = keep + new
            self._flag_duplicates()

    def _flag_duplicates(self) -> None:
        """Discovery.tla `Flags`: same (class, index) anywhere in the system => DUPLICATE, all rows."""
        counts: dict[tuple[int, int], int] = {}
        for r in self._records:
            counts[(r.class_id, r.index)] = counts.get((r.class_id, r.index), 0) + 1
        for r in self._records:
            if counts[(r.class_id, r.index)] > 1:
                r.flags.add(DUPLICATE)
            else:
                r.flags.discard(DUPLICATE)

    def _bridge_lost(self, manager: BusManager, reason: str) -> None:
        """The manager's lost listener (registered at the first successful discovery)."""
        fn = self.on_bridge_lost
        if fn is not None:
            fn(manager, reason)

    # -- nodes --------------------------------------------------------------------------------
    def nodes(self) -> list[NodeRecord]:
        """Every row of the system table (class, index, bridge, address, fingerprint, firmware,
        flags), in registration then address order; duplicates are separate rows."""
        with self._lock:
            return [r for r in self._records if r.active]

    # lobster-trace: urb.DSC_008
    def find_node(self, cls: int | str | NodeInfo, index: int = 0) -> NodeAccessor:
        """The accessor of the node with class `cls` (class id, schema name or NodeInfo) and
        `index`. Raises `NodeNotFoundError`, `DuplicateNodeError`, `FingerprintMismatchError`
        or `UnknownClassError` with what to do next."""
        class_id, name = self._resolve_class(cls)
        with self._lock:
            rows = [r for r in self._records if r.active and r.class_id == class_id and r.index == index]
            if not rows:
                found = ", ".join(f"{r.label} ({r.location})" for r in self._records if r.active) or "no nodes"
                bridges = ", ".join(rep.manager.name for rep in self.reports.values()) or "no bridges registered"
                raise NodeNotFoundError(
                    f"no {name} with index {index} was discovered (bridges: {bridges}; found: {found}). "
                    f"Check that the node is powered and its index, then rediscover (urb scan PORT).")
            if len(rows) > 1:
                where = "; ".join(r.location for r in rows)
                raise DuplicateNodeError(
                    f"{name}:{index} answers at {len(rows)} places ({where}): two nodes have the same class and "
                    f"index. Give each a distinct index (URB_SetIndex) and rediscover.")
            rec = rows[0]
            if MISMATCH in rec.flags:
                assert rec.info is not None
                raise FingerprintMismatchError(
                    f"{rec.label} at {rec.location} reports layout fingerprint 0x{rec.fingerprint:08x}, but the "
                    f"host's schema {rec.info.schema_file} gives 0x{rec.info.fingerprint:08x}: the node firmware "
                    f"and this host were built from different schemas. Rebuild one of them from the same "
                    f"{rec.info.schema_file} (urb gen), then flash or reinstall.",
                    node_fingerprint=rec.fingerprint, schema_fingerprint=rec.info.fingerprint,
                    schema_file=rec.info.schema_file)
            acc = self._accessors.get(id(rec))
            if acc is None:
                acc = NodeAccessor(self, rec)
                self._accessors[id(rec)] = acc
            return acc

    def node_at(self, manager: BusManager, address: int) -> NodeAccessor:
        """The accessor of the node that answered discovery at downlink `address` of `manager`'s
        bridge (0: the bridge itself, `bridge_node`), whatever its class and flags: the address
        tells duplicates apart. A node whose class and layout fingerprint are the schema's gets the
        schema's layout (typed messages); any other (UNKNOWN_CLASS, MISMATCH) its mailboxes as
        the raw bytes of the sizes it reported (`raw_node.RawMailbox`). Raises
        `NodeNotFoundError` when nothing answered there."""
        if not 0 <= address <= 127:
            raise ValueError(f"address {address}: downlink addresses are 1..127 (0 is the bridge)")
        if address == BRIDGE_ADDRESS:
            return self.bridge_node(manager)
        with self._lock:
            rows = [r for r in self._records if r.active and r.bridge is manager and r.address == address]
            if not rows:
                found = ", ".join(f"{r.address} ({r.label})" for r in self._records
                                  if r.active and r.bridge is manager) or "none"
                raise NodeNotFoundError(
                    f"no node answered at address {address} of {manager.name} (addresses that did: {found}). "
                    f"Check that the node is powered and its address, then rediscover (urb scan PORT).")
            rec = rows[0]
            schema_layout = rec.info is not None and MISMATCH not in rec.flags
            key: int | tuple[str, int] = id(rec) if schema_layout else ("raw", id(rec))
            acc = self._accessors.get(key)
            if acc is None:
                acc = NodeAccessor(self, rec, None if schema_layout else raw_node_info(rec.ident))
                self._accessors[key] = acc
            return acc

    def bridge_node(self, manager: BusManager) -> NodeAccessor:
        """An accessor for the bridge itself (uplink address 0): outbox 0 `BridgeInfo`, outbox 1
        `BridgeScan`, inbox 0 `BridgeCommand` (rescan, heartbeat period, bus clear)."""
        report = self.reports.get(id(manager))
        if report is None or report.info is None:
            raise NodeNotFoundError(f"{manager.name} is not a registered bridge; call add_bus_manager() first")
        info = report.info
        with self._lock:
            key = -id(manager)
            acc = self._accessors.get(key)
            if acc is None:
                ident = Identification(class_id=BRIDGE.class_id, index=0, fingerprint=BRIDGE.fingerprint,
                                       fw_major=info.fw_major, fw_minor=info.fw_minor, fw_patch=info.fw_patch,
                                       inbox_sizes=BRIDGE.sizes("inbox"), outbox_sizes=BRIDGE.sizes("outbox"))
                acc = NodeAccessor(self, NodeRecord(manager, BRIDGE_ADDRESS, ident, BRIDGE))
                self._accessors[key] = acc
            return acc

    def _resolve_class(self, cls: int | str | NodeInfo) -> tuple[int, str]:
        if isinstance(cls, NodeInfo):
            return cls.class_id, cls.name
        if isinstance(cls, int):
            info = self.schema.get(cls)
            if info is None:
                known = ", ".join(f"{i.name} (0x{c:02x})" for c, i in sorted(self.schema.items()))
                raise UnknownClassError(f"class 0x{cls:02x} is not declared in the host's schema; known: {known}")
            return cls, info.name
        for c, info in self.schema.items():
            if info.name.lower() == cls.lower():
                return c, info.name
        known = ", ".join(i.name for i in self.schema.values())
        raise UnknownClassError(f"no node type named {cls!r} in the host's schema; known: {known}")


__all__ = [
    "DUPLICATE",
    "MISMATCH",
    "UNKNOWN_CLASS",
    "BridgeReport",
    "NodeAccessor",
    "NodeRecord",
    "NodeRequest",
    "URBInterface",
]
