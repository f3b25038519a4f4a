"""Discovery: the system table's rows (`NodeRecord`), what one bridge's discovery found
(`BridgeReport`), and the discovery itself, a chain of callbacks so that it runs in real time and
in virtual time alike (`URBInterface.add_bus_manager`, `start_discovery`, `reconnect`).

A device on the uplink is believed to be a URB bridge only once its own identification read
(address 0, outbox 0) came back OK and decodes as a `BridgeInfo` that checks
(`bridge_info_problem`). Anything else, whatever the bytes that came back, is reported the same
way: no URB bridge answered. A port that carries noise (a wrong baud rate turns a bridge's answers
into noise) can pass a frame check by chance (a CRC-8 does so once in 256 candidates), so the
outcome of that one read is not evidence enough of a bridge, nor of what is wrong with one.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

from urb_msgs import DecodeError, NodeInfo
from urb_msgs.urb_core import (
    BRIDGE,
    BRIDGE_ADDRESS,
    BridgeCommand,
    BridgeInfo,
    BridgeOpcode,
    BridgeScan,
    Identification,
)

from .errors import ErrorFlag, hint
from .managers.base import BusManager, Transfer, decode_message, encode_message
from .managers.rs232_core import SCAN_ANSWER_NS

DUPLICATE = "DUPLICATE"
MISMATCH = "MISMATCH"
UNKNOWN_CLASS = "UNKNOWN_CLASS"



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
# Discovery (a chain of callbacks, so it runs in real time and in virtual time alike)
# --------------------------------------------------------------------------------------------

class _Discovery:
    """BridgeInfo (address 0, outbox 0), optional SCAN command, BridgeScan (outbox 1), then
    outbox 0 of every present address (Discovery.tla `ScanAddress`: gaps never end a scan)."""

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
