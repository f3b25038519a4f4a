"""spec/tla/Bridge.tla transliterated to Python: the reference model for the Hypothesis tests.

One method per TLA+ action (`submit_and_admit`, `serve`, `emit`), with the same guards and the
same updates, and one method per invariant. Two refinements, both needed to run real frames:
`Size` is keyed by direction as well ((addr, op, box): a node's inbox and outbox of one number
differ in size), and `Outbox(addr, box)` is a byte string of the requested length that names
its mailbox (the TLA+ tuple <<addr, box>> padded).
"""

from __future__ import annotations

from dataclasses import dataclass, field

SEQ_MOD = 16
STATUSES = {"OK", "TIMEOUT", "CHECKSUM", "BUSY", "NO_NODE", "SIZE_MISMATCH", "BAD_REQUEST", "BUS_STUCK", "NODE_BUSY"}
DOWNLINK_FAULTS = {"TIMEOUT", "CHECKSUM", "BUS_STUCK", "NODE_BUSY"}
ADMISSION_ERRORS = {"BUSY", "SIZE_MISMATCH", "BAD_REQUEST"}


@dataclass(frozen=True)
class Req:
    addr: int
    box: int
    op: str  # "read" | "write"
    len: int
    data: bytes = b""


def outbox(addr: int, box: int, length: int) -> bytes:
    """Bridge.tla `Outbox(addr, box)`: content that names the mailbox it came from."""
    return (bytes([addr, box]) + bytes(range(2, 32)))[:length]


@dataclass
class Entry:
    id: int
    status: str  # "PENDING" or a status
    data: bytes = b""


@dataclass
class Response:
    id: int
    seq: int
    status: str
    data: bytes


@dataclass
class BridgeRef:
    present: set[int]
    size: dict[tuple[int, str, int], int]
    faults: set[str]
    queue_len: int
    host_window: int
    sent: list[tuple[Req, int]] = field(default_factory=list)
    queue: list[Entry] = field(default_factory=list)
    out: list[Response] = field(default_factory=list)
    applied: set[int] = field(default_factory=set)
    cause: dict[int, str] = field(default_factory=dict)
    full: set[int] = field(default_factory=set)

    def __post_init__(self) -> None:
        assert self.faults <= DOWNLINK_FAULTS
        assert 0 < self.queue_len <= self.host_window < SEQ_MOD

    # -- helpers ------------------------------------------------------------------------------
    def admission_status(self, r: Req) -> str:
        if not 0 <= r.box <= 7 or not 1 <= r.len <= 32:
            return "BAD_REQUEST"
        if r.addr in self.present and r.len != self.size.get((r.addr, r.op, r.box), 0):
            return "SIZE_MISMATCH"
        return "OK"

    def data_slots_used(self) -> int:
        return sum(1 for e in self.queue if e.status not in ADMISSION_ERRORS)

    def req(self, id_: int) -> Req:
        return self.sent[id_ - 1][0]

    # -- actions ------------------------------------------------------------------------------
    def can_submit(self) -> bool:
        """Guard of SubmitAndAdmit (without MaxReq): the host window."""
        return len(self.sent) - len(self.out) < self.host_window

    def submit_and_admit(self, r: Req) -> int:
        assert self.can_submit(), "the host exceeded its window (Bridge.tla SubmitAndAdmit guard)"
        id_ = len(self.sent) + 1
        adm = self.admission_status(r)
        st = adm if adm != "OK" else ("BUSY" if self.data_slots_used() >= self.queue_len else "PENDING")
        self.sent.append((r, id_))
        self.queue.append(Entry(id_, st))
        if st != "PENDING":
            self.cause[id_] = st
        if st == "BUSY":
            self.full.add(id_)
        return id_

    def first_pending(self) -> int | None:
        return next((k for k, e in enumerate(self.queue) if e.status == "PENDING"), None)

    def serve_choices(self) -> list[str]:
        """The outcomes Serve may choose for the oldest pending request."""
        k = self.first_pending()
        if k is None:
            return []
        r = self.req(self.queue[k].id)
        if r.addr not in self.present:
            return ["NO_NODE"]
        return ["OK"] + sorted(self.faults - ({"NODE_BUSY"} if r.op == "read" else set()))

    def serve(self, st: str) -> None:
        k = self.first_pending()
        assert k is not None and st in self.serve_choices()
        id_ = self.queue[k].id
        r = self.req(id_)
        self.queue[k] = Entry(id_, st, outbox(r.addr, r.box, r.len) if st == "OK" and r.op == "read" else b"")
        if st == "OK" and r.op == "write":
            self.applied.add(id_)
        self.cause[id_] = st

    def can_emit(self) -> bool:
        return bool(self.queue) and self.queue[0].status != "PENDING"

    def emit(self) -> Response:
        assert self.can_emit()
        e = self.queue.pop(0)
        resp = Response(e.id, e.id % SEQ_MOD, e.status, e.data)
        self.out.append(resp)
        return resp

    # -- invariants ---------------------------------------------------------------------------
    def check(self) -> None:
        ids_out = [o.id for o in self.out]
        queued = {e.id for e in self.queue}
        assert all(i in ids_out or i in queued for i in range(1, len(self.sent) + 1)), "NoSilentDrop"
        assert len(ids_out) == len(set(ids_out)), "AtMostOneResponse"
        assert ids_out == sorted(ids_out), "ResponsesInRequestOrder"
        for k, o in enumerate(self.out, start=1):
            r = self.req(o.id)
            assert o.seq == k % SEQ_MOD, "ResponseMatchesRequest (seq)"
            want = outbox(r.addr, r.box, r.len) if o.status == "OK" and r.op == "read" else b""
            assert o.data == want, "ResponseMatchesRequest (data)"
            assert o.status == "OK" or o.status == self.cause[o.id], "ErrorNamesCause"
            if r.op == "write":
                if o.status == "OK":
                    assert o.id in self.applied, "WriteStatusTruthful"
                if o.status in {"CHECKSUM", "NODE_BUSY", "NO_NODE"} | ADMISSION_ERRORS:
                    assert o.id not in self.applied, "WriteStatusTruthful"
            if o.status == "BUSY":
                assert o.id in self.full, "BusyOnlyWhenFull"
        assert len(self.queue) <= self.host_window and self.data_slots_used() <= self.queue_len, "BoundedMemory"
