"""Hypothesis state-machine tests against the Bridge.tla reference model (bridge_ref.py).

1. `HostCoreVsBridgeTla`: the host's request/response state machine (`Rs232Core`) talks, through
   real frames, to the reference bridge, whose Serve/Emit interleaving Hypothesis chooses; the
   wire may lose request frames, lose response frames, flip a bit, and deliver in arbitrary
   chunks. Checked: the host respects the window (the reference's SubmitAndAdmit guard), every
   request completes exactly once and in request order, an intact response gives exactly the
   reference's status and data, and a lost or corrupted exchange gives UPLINK_TIMEOUT or
   UPLINK_CHECKSUM, never someone else's data. The one exception is the residual of the 8-bit link
   check that spec/schema/README.md states for hunting: after a corruption, a window of received
   bytes that happens to pass the check and echo a pending sequence number is taken as that
   request's response. Such a completion must be exactly a frame that passes the check and was on
   the wire (the host never accepts a failed check, never invents bytes); it is counted as a
   Hypothesis event. (With these tests' outbox contents, small bytes that look like headers, it
   happens about once per few hundred hunts.)
2. `BridgeModelVsBridgeTla`: the Python bridge behind the fake-bridge fixture produces, byte for
   byte, the response stream of the reference for the same requests and downlink outcomes, so
   the tests built on it test against Bridge.tla.
"""

from __future__ import annotations

import sys
from collections import deque
from typing import Any

import pytest

from hypothesis import HealthCheck, Phase, event, settings
from hypothesis import strategies as st
from hypothesis.stateful import (RuleBasedStateMachine, initialize, invariant, precondition, rule,
                                 run_state_machine_as_test)

from bridge_ref import BridgeRef, Req, outbox
from urb.errors import ErrorFlag
from urb.managers import rs232_core
from urb.managers.base import NS_PER_MS, NS_PER_S, Transfer
from urb.managers.loopback import BridgeModel, FakeNode
from urb.managers.rs232_core import Rs232Core
from urb_msgs import NODES, DecodeError
from urb_msgs.urb_core import Status, UplinkReadRequest, UplinkResponse, UplinkWriteRequest

MOTOR = NODES["MotorDriver"]
PRESENT = {8, 9}
ABSENT = 10


def sizes() -> dict[tuple[int, str, int], int]:
    out: dict[tuple[int, str, int], int] = {}
    for addr in PRESENT:
        for mb in MOTOR.mailboxes:
            out[(addr, "read" if mb.direction == "outbox" else "write", mb.number)] = mb.size
    return out


REQS = [
    Req(8, 1, "read", 6), Req(9, 2, "read", 4), Req(8, 0, "read", 25), Req(9, 1, "write", 2, b"\x10\x27"),
    Req(8, 2, "write", 11, bytes(range(11))), Req(8, 1, "read", 5),  # SIZE_MISMATCH
    Req(ABSENT, 1, "read", 6), Req(ABSENT, 1, "write", 2, b"\x00\x01"),  # NO_NODE
]
FAULTS = {"TIMEOUT", "CHECKSUM", "BUS_STUCK", "NODE_BUSY"}


def frame_of(t: Transfer) -> bytes:
    if t.read:
        return UplinkReadRequest(address=t.address, mailbox=t.mailbox, seq=t.seq, length=t.length).encode()
    return UplinkWriteRequest(address=t.address, mailbox=t.mailbox, seq=t.seq, data=t.data).encode()


class HostCoreVsBridgeTla(RuleBasedStateMachine):
    @initialize(queue_len=st.integers(1, 3), extra=st.integers(0, 3))
    def setup(self, queue_len: int, extra: int) -> None:
        window = queue_len + extra
        self.ref = BridgeRef(set(PRESENT), sizes(), set(FAULTS), queue_len, window)
        # never lost within a trace (at most 60 steps of 12 ms), within the C core's ranges (1 h)
        self.core = Rs232Core(window=window, timeout_ns=10 * NS_PER_MS, resync_gap_ns=NS_PER_MS,
                              lost_after_ns=3600 * NS_PER_S, lost_after_timeouts=10**9)
        self.now = 0
        self.transfers: list[Transfer] = []
        self.lose: dict[int, bool] = {}
        self.fate: dict[int, str] = {}  # transfer index -> intact | lost | corrupt
        self.ref_id: dict[int, int] = {}  # ref id -> transfer index
        self.seq_of: dict[int, int] = {}  # transfer index -> seq on the wire
        self.expect: dict[int, tuple[str, bytes]] = {}
        self.wire = bytearray()
        self.sent_upto = 0
        self.done: list[int] = []
        self.corruptions = 0
        self.received = bytearray()  # every byte delivered to the host

    # -- host side ----------------------------------------------------------------------------
    def _pump(self) -> None:
        for frame in self.core.frames_to_send(self.now):
            i = self.sent_upto
            self.sent_upto += 1
            t = self.transfers[i]
            assert frame == frame_of(t) and t.seq == (i + 1) % 16
            self.seq_of[i] = t.seq
            if self.lose[i]:
                self.fate[i] = "lost"
                continue
            r = Req(t.address, t.mailbox, "read" if t.read else "write", t.length, t.data)
            assert self.ref.can_submit(), "host exceeded the window"
            self.ref_id[self.ref.submit_and_admit(r)] = i
        self._collect()

    def _collect(self) -> None:
        for t in self.core.take_completed():
            i = self.transfers.index(t)
            assert i == len(self.done), f"completion out of order: {i} after {self.done[-3:]}"
            self.done.append(i)
            fate = self.fate.get(i)
            if self._chance_match(t, fate):
                continue
            if fate == "intact":
                status, data = self.expect[i]
                if self.corruptions == 0:
                    assert t.flags == ErrorFlag.from_status(Status[status]), (i, t.flags, status)
                    assert t.response == (data if status == "OK" and t.read else None)
                else:  # hunting after a corruption may (rarely, by design) lose a neighbour
                    assert t.flags in (ErrorFlag.from_status(Status[status]), ErrorFlag.UPLINK_CHECKSUM,
                                       ErrorFlag.UPLINK_TIMEOUT)
                    if t.flags == ErrorFlag.NONE and t.read:
                        assert t.response == data
            else:
                assert fate in ("lost", "corrupt"), (i, fate, t.flags)
                assert t.flags in (ErrorFlag.UPLINK_TIMEOUT, ErrorFlag.UPLINK_CHECKSUM), (i, t.flags)
                assert t.response is None

    def _chance_match(self, t: Transfer, fate: str | None) -> bool:
        """True when t's outcome is a false match of the link check while hunting (see the module
        docstring): after a corruption, not what the bridge answered, yet a frame for t's sequence
        number that passes its check and lies in the received bytes."""
        if self.corruptions == 0 or t.status is None or t.flags & (ErrorFlag.UPLINK_TIMEOUT | ErrorFlag.UPLINK_CHECKSUM):
            return False
        i = self.transfers.index(t)
        if fate == "intact" and (t.status.name, t.response or b"") == (self.expect[i][0],
                                                                       self.expect[i][1] if t.read else b""):
            return False
        frame = UplinkResponse(seq=t.seq, status=t.status, data=t.response or b"").encode()
        assert frame in self.received, (i, t, "accepted bytes that were never received")
        event("link check passed by chance while hunting")
        return True

    @rule(template=st.sampled_from(REQS), lose=st.integers(0, 9).map(lambda x: x == 0))
    def submit(self, template: Req, lose: bool) -> None:
        t = Transfer(template.addr, template.box, template.op == "read", template.len, template.data)
        self.lose[len(self.transfers)] = lose
        self.transfers.append(t)
        self.core.submit(t, self.now)
        self._pump()

    @rule(n=st.integers(1, 40))
    def deliver(self, n: int) -> None:
        chunk = bytes(self.wire[:n])
        del self.wire[:n]
        self.received += chunk
        self.core.receive(chunk, self.now)
        self._pump()

    @precondition(lambda self: not self.wire and not self.ref.queue)
    @rule(dt=st.integers(1, 12 * NS_PER_MS))
    def tick(self, dt: int) -> None:
        """Time passes only when the bridge holds nothing: uplink timeouts then mean loss, as
        configured in practice (host timeout > the bridge's worst case)."""
        self.now += dt
        self.core.poll(self.now)
        self._pump()

    # -- reference bridge ---------------------------------------------------------------------
    @precondition(lambda self: self.ref.first_pending() is not None)
    @rule(choice=st.integers(0, 4))
    def serve(self, choice: int) -> None:
        choices = self.ref.serve_choices()
        self.ref.serve(choices[choice % len(choices)])

    @precondition(lambda self: self.ref.can_emit())
    @rule(drop=st.integers(0, 9), flip=st.integers(0, 9 * 8))
    def emit(self, drop: int, flip: int) -> None:
        resp = self.ref.emit()
        i = self.ref_id[resp.id]
        frame = bytearray(UplinkResponse(seq=self.seq_of[i], status=Status[resp.status], data=resp.data).encode())
        self.expect[i] = (resp.status, resp.data)
        if drop == 0:
            self.fate[i] = "lost"
            return
        if drop == 1 and flip < len(frame) * 8:
            frame[flip // 8] ^= 1 << (flip % 8)
            self.fate[i] = "corrupt"
            self.corruptions += 1
        else:
            self.fate[i] = "intact"
        self.wire += frame

    @invariant()
    def reference_invariants_hold(self) -> None:
        if hasattr(self, "ref"):
            self.ref.check()

    def teardown(self) -> None:
        if not hasattr(self, "ref"):
            return
        for _ in range(1000):  # drain: everything completes, exactly once, in order
            k = self.ref.first_pending()
            if k is not None:
                self.ref.serve("OK" if self.ref.req(self.ref.queue[k].id).addr in PRESENT else "NO_NODE")
            elif self.ref.can_emit():
                self.emit(drop=5, flip=0)
            elif self.wire:
                self.deliver(64)
            elif self.core.busy():
                self.tick(11 * NS_PER_MS)
            else:
                break
        assert self.done == list(range(len(self.transfers)))


TestHostCoreVsBridgeTla = HostCoreVsBridgeTla.TestCase
TestHostCoreVsBridgeTla.settings = settings(max_examples=150, stateful_step_count=60, deadline=None,
                                            suppress_health_check=[HealthCheck.too_slow])


# --------------------------------------------------------------------------------------------

class EchoNode(FakeNode):
    """A motor driver whose outboxes hold Bridge.tla's Outbox(addr, box)."""

    def __init__(self, addr: int) -> None:
        super().__init__(MOTOR, index=addr)
        self.addr = addr

    def read_outbox(self, box: int) -> bytes:
        mb = self.info.mailbox("outbox", box)
        return outbox(self.addr, box, mb.size if mb else 0)


class BridgeModelVsBridgeTla(RuleBasedStateMachine):
    @initialize(queue_len=st.integers(1, 4), extra=st.integers(0, 4))
    def setup(self, queue_len: int, extra: int) -> None:
        window = queue_len + extra
        self.ref = BridgeRef(set(PRESENT), sizes(), set(FAULTS), queue_len, window)
        self.nodes = {a: EchoNode(a) for a in PRESENT}
        self.model = BridgeModel(dict(self.nodes), fifo_depth=queue_len, ring=window)
        self.outcomes: deque[tuple[int, str]] = deque()  # (ref id, outcome) for PENDING requests
        self.seq = 0
        self.seq_of: dict[int, int] = {}
        self.now = 0

    @precondition(lambda self: self.ref.can_submit())
    @rule(template=st.sampled_from(REQS), outcome=st.sampled_from(["OK", "OK", "TIMEOUT", "CHECKSUM", "BUS_STUCK", "NODE_BUSY"]))
    def submit(self, template: Req, outcome: str) -> None:
        self.seq = (self.seq + 1) % 16
        id_ = self.ref.submit_and_admit(template)
        self.seq_of[id_] = self.seq
        if self.ref.queue[-1].status == "PENDING":
            if template.addr not in PRESENT:
                outcome = "NO_NODE"
            elif outcome == "NODE_BUSY" and template.op == "read":
                outcome = "OK"
            self.outcomes.append((id_, outcome))
            if outcome != "NO_NODE":
                self.nodes[template.addr].faults.append(Status[outcome])  # OK: no fault this time
        if template.op == "read":
            frame = UplinkReadRequest(address=template.addr, mailbox=template.box, seq=self.seq, length=template.len).encode()
        else:
            frame = UplinkWriteRequest(address=template.addr, mailbox=template.box, seq=self.seq, data=template.data).encode()
        self.now += 1000
        self.model.receive(frame, self.now)

    @rule()
    def step(self) -> None:
        """The model serves everything and emits; the reference does the same, in order."""
        got = self.model.process(self.now)
        while self.outcomes:
            id_, outcome = self.outcomes.popleft()
            assert self.ref.serve_choices(), "reference has nothing pending"
            self.ref.serve(outcome)
        want = bytearray()
        while self.ref.can_emit():
            r = self.ref.emit()
            want += UplinkResponse(seq=self.seq_of[r.id], status=Status[r.status], data=r.data).encode()
        assert got == bytes(want)
        self.ref.check()
        for node in self.nodes.values():
            assert not node.faults


TestBridgeModelVsBridgeTla = BridgeModelVsBridgeTla.TestCase
TestBridgeModelVsBridgeTla.settings = settings(max_examples=150, stateful_step_count=40, deadline=None)


# -------------------------------------------------------------------------------------------- seeded bugs

class _IgnoresLinkCheck:
    """Seeded bug: the host core takes a response whose link check fails."""

    @staticmethod
    def decode(frame: bytes) -> UplinkResponse:
        try:
            return UplinkResponse.decode(frame)
        except DecodeError:
            return UplinkResponse(seq=frame[0] & 0x0F, status=Status(frame[0] >> 4), data=bytes(frame[1:-1]))


class _WindowPlusOne(Rs232Core):
    """Seeded bug: the host core keeps one request more outstanding than the window allows."""

    def __init__(self, *, window: int = 4, **kwargs: Any) -> None:
        super().__init__(window=window + 1, **kwargs)


def _failures(exc: BaseException) -> list[BaseException]:
    if isinstance(exc, BaseExceptionGroup):
        return [e for sub in exc.exceptions for e in _failures(sub)]
    return [exc]


# lobster-trace: urb.HOST_001
@pytest.mark.parametrize("bug", ["ignores-link-check", "window-plus-one"])
def test_the_state_machine_catches_seeded_host_bugs(bug: str, monkeypatch: pytest.MonkeyPatch) -> None:
    if bug == "ignores-link-check":
        monkeypatch.setattr(rs232_core, "UplinkResponse", _IgnoresLinkCheck)
        monkeypatch.setattr(sys.modules[__name__], "Rs232Core", rs232_core.Rs232Core)  # the bug is the reference's
    else:
        monkeypatch.setattr(sys.modules[__name__], "Rs232Core", _WindowPlusOne)
    with pytest.raises(BaseException) as exc:
        run_state_machine_as_test(HostCoreVsBridgeTla, settings=settings(
            max_examples=400, stateful_step_count=60, deadline=None, database=None, derandomize=True,
            phases=[Phase.generate], suppress_health_check=list(HealthCheck)))  # finding is enough: no shrinking
    assert all(isinstance(e, AssertionError) for e in _failures(exc.value)), exc.value
