"""close() drains: the late responses of a manager's requests never reach the next manager.

A request carries a 4-bit sequence number and its response carries nothing else to match it by.
A new host process (the `urb` CLI makes one manager per command) numbers its requests from 1
again and knows nothing of the requests the bridge still holds: if the previous manager closed
right after a request timed out, that request's late response would be matched to the new
manager's request with the same number, and its data delivered as OK. So `close()` keeps reading
until nothing is in flight, bounded by the newest request's placeholder lifetime
(host/urb/README.md, "Sequence numbers").

The late response comes from a node stretching the clock (`FakeNode.stretch_ns`) in the Python
bridge model: in virtual time (SimManager, both cores: exact times), and in real time through
the threaded runtime: USBManager over `LoopbackUsbTransport`, and RS232Manager (what the `urb`
CLI uses) over a pty to the fake bridge process.
"""

from __future__ import annotations

from collections.abc import Callable

import pytest

from bridge_proc import BridgeProc, fake_bridge  # noqa: F401 (fixture)

from urb.errors import ErrorFlag
from urb.managers import (
    BridgeModel,
    LoopbackByteTransport,
    LoopbackFrameTransport,
    LoopbackUsbTransport,
    RS232Manager,
    SimManager,
    USBManager,
    VirtualClock,
    fake_node,
)
from urb.managers.base import CLOSED_REASON, NS_PER_MS, BusManager, Transfer
from urb.managers.rs232_core import PLACEHOLDER_NS
from urb_msgs.urb_core import Identification

MS = NS_PER_MS
KINDS = ["rs232", "usb"]
SLOW, FAST = 8, 9
"""Two nodes of the same type (same mailbox sizes): the slow one stretches the clock."""
STRETCH_NS = {"rs232": 150 * MS, "usb": 75 * MS}
"""1.5 times the core's default timeout (100 ms RS232, 50 ms USB): the slow request times out,
and its late response comes before a request sent right after that times out too."""

Sim = tuple[VirtualClock, BridgeModel, LoopbackByteTransport | LoopbackFrameTransport]


def bench(kind: str) -> Sim:
    """A bridge with two motor drivers, SLOW stretching the clock, on a simulated uplink."""
    clock = VirtualClock()
    nodes = dict(fake_node(spec) for spec in (f"MotorDriver:0@{SLOW}", f"MotorDriver:1@{FAST}"))
    nodes[SLOW].stretch_ns = STRETCH_NS[kind]
    bridge = BridgeModel(nodes)
    transport = LoopbackByteTransport(clock, bridge) if kind == "rs232" else LoopbackFrameTransport(clock, bridge)
    return clock, bridge, transport


def sim_manager(sim: Sim) -> SimManager:
    """A new manager on the bench's uplink (what a new process opening the port is)."""
    m = SimManager(sim[0], sim[2])
    m.start()
    return m


def read_ident(m: BusManager, address: int) -> Transfer:
    """Submit a read of the node's identification (outbox 0: same size on every node)."""
    t = Transfer(address=address, mailbox=0, read=True, length=Identification.SIZE)
    m.submit(t)
    return t


def index_of(t: Transfer) -> int:
    """Which node's identification `t` received."""
    assert t.ok and t.response is not None, t
    return Identification.decode(t.response).index


def sent(m: SimManager, t: Transfer) -> int:
    """Run the clock until `t` is on the wire (the USB core sends on the next 1-ms frame)."""
    assert m.wait_until(lambda: t.sent_ns is not None, 0.01)
    assert t.sent_ns is not None
    return t.sent_ns


def silence(sim: Sim) -> None:
    """The bridge stops answering (a cable pulled)."""
    transport = sim[2]
    if isinstance(transport, LoopbackByteTransport):
        transport.unplug()
    else:
        transport.connected = False


# lobster-trace: urb.HOST_006
@pytest.mark.parametrize("kind", KINDS)
def test_late_response_of_a_closed_manager_does_not_reach_the_next_one(kind: str) -> None:
    """The reproducer: the first manager's request times out and it closes; a second manager on
    the same bridge sends its request with the same number while the bridge still holds the
    first one. Without the drain, the second gets the slow node's identification as its own."""
    sim = bench(kind)
    clock = sim[0]
    first = sim_manager(sim)
    old = read_ident(first, SLOW)
    assert first.wait_until(lambda: old.done, 1.0) and old.flags == ErrorFlag.UPLINK_TIMEOUT
    first.close()
    closed_at = clock.now_ns()
    second = sim_manager(sim)  # numbers its requests from 1 again
    new = read_ident(second, FAST)
    assert second.wait_until(lambda: new.done, 1.0)
    assert new.seq == old.seq  # the number that would alias
    assert index_of(new) == 1  # FAST's identification, not SLOW's (index 0)
    assert second.stats.late_responses == 0 and second.stats.stray_bytes == 0
    # the drain ended with the late response (discarded), before the bound
    assert first.stats.late_responses == 1 and first.lost_reason == CLOSED_REASON
    assert old.sent_ns is not None and old.sent_ns + STRETCH_NS[kind] < closed_at < old.sent_ns + PLACEHOLDER_NS


@pytest.mark.parametrize("kind", KINDS)
def test_close_with_nothing_in_flight_does_not_wait(kind: str) -> None:
    sim = bench(kind)
    m = sim_manager(sim)
    t = read_ident(m, FAST)
    assert m.wait_until(lambda: t.done, 1.0) and index_of(t) == 1
    before = sim[0].now_ns()
    m.close()
    assert sim[0].now_ns() == before and m.lost_reason == CLOSED_REASON


@pytest.mark.parametrize("kind", KINDS)
def test_drain_is_bounded_by_the_lifetime_of_the_newest_request(kind: str) -> None:
    """A bridge that never answers: close() returns when the newest request's lifetime is over,
    and its request completes with its usual error (UPLINK_TIMEOUT), not silently. A request
    still queued behind the window is never sent: it completes BRIDGE_LOST at once."""
    sim = bench(kind)
    m = sim_manager(sim)
    m.set_window(2)
    silence(sim)
    first = read_ident(m, FAST)
    sim[0].run_for(10 * MS)
    newest = read_ident(m, FAST)
    queued = read_ident(m, FAST)
    deadline = sent(m, newest) + PLACEHOLDER_NS
    m.close()
    assert sim[0].now_ns() == deadline
    assert first.flags == newest.flags == ErrorFlag.UPLINK_TIMEOUT
    assert queued.flags == ErrorFlag.BRIDGE_LOST and queued.lost_reason == CLOSED_REASON
    assert queued.completed_ns is not None and queued.completed_ns < deadline
    assert m.core.in_flight == 0 and m.lost_reason == CLOSED_REASON


@pytest.mark.parametrize("kind", KINDS)
def test_close_without_drain_does_not_wait(kind: str) -> None:
    sim = bench(kind)
    m = sim_manager(sim)
    t = read_ident(m, SLOW)
    at = sent(m, t)
    m.close(drain=False)
    assert sim[0].now_ns() == at
    assert t.flags == ErrorFlag.BRIDGE_LOST and t.lost_reason == CLOSED_REASON


# lobster-trace: urb.HOST_001
@pytest.mark.parametrize("kind", KINDS)
def test_request_submitted_while_draining_is_refused(kind: str) -> None:
    """A callback run during the drain (here: the slow request's timeout) that submits gets
    BRIDGE_LOST at once: nothing new goes on the wire once close() has begun."""
    sim = bench(kind)
    m = sim_manager(sim)
    late: list[Transfer] = []
    old = Transfer(address=SLOW, mailbox=0, read=True, length=Identification.SIZE,
                   on_done=lambda _: late.append(read_ident(m, FAST)))
    m.submit(old)
    sent(m, old)
    m.close()
    assert old.flags == ErrorFlag.UPLINK_TIMEOUT and m.stats.late_responses == 1
    assert len(late) == 1 and late[0].flags == ErrorFlag.BRIDGE_LOST and late[0].seq == -1


def test_lost_manager_does_not_drain() -> None:
    sim = bench("rs232")
    m = sim_manager(sim)
    t = read_ident(m, SLOW)
    at = sent(m, t)
    m.core.link_lost(at, "test: the port went away")
    m.close()
    assert sim[0].now_ns() == at and t.flags == ErrorFlag.BRIDGE_LOST
    assert m.lost_reason == "test: the port went away"


# -- real time: the threaded runtime (USBManager; RS232Manager shares ThreadedManager._drain) ----

def rt_manager(transport: LoopbackUsbTransport, timeout_s: float) -> USBManager:
    # lifetime 0.6 s (lost_after above it) leaves a wide margin around the 0.2-s stretch on a
    # loaded machine
    m = USBManager(transport, timeout_s=timeout_s, placeholder_s=0.6, lost_after_s=1.5)
    m.start()
    return m


def rt_bench() -> LoopbackUsbTransport:
    nodes = dict(fake_node(spec) for spec in (f"MotorDriver:0@{SLOW}", f"MotorDriver:1@{FAST}"))
    nodes[SLOW].stretch_ns = 200 * MS
    return LoopbackUsbTransport(BridgeModel(nodes))


def check_next_manager_gets_its_own_response(opened: Callable[[float], BusManager]) -> None:
    """The first manager's read of the slow node times out and it closes; a second one (another
    command, its own options) reads the fast node with the same sequence number and must get the
    fast node's identification, not the slow node's late one."""
    first = opened(0.1)
    old = read_ident(first, SLOW)
    assert first.wait_until(lambda: old.done, 2.0) and old.flags == ErrorFlag.UPLINK_TIMEOUT
    first.close()
    second = opened(1.0)
    try:
        new = read_ident(second, FAST)
        assert second.wait_until(lambda: new.done, 2.0)
        assert new.seq == old.seq and index_of(new) == 1
    finally:
        second.close()
    assert first.stats.late_responses == 1


def test_real_time_late_response_of_a_closed_manager_does_not_reach_the_next_one() -> None:
    transport = rt_bench()
    check_next_manager_gets_its_own_response(lambda timeout_s: rt_manager(transport, timeout_s=timeout_s))


def test_real_time_close_with_nothing_in_flight_does_not_wait() -> None:
    m = rt_manager(rt_bench(), timeout_s=1.0)
    t = read_ident(m, FAST)
    assert m.wait_until(lambda: t.done, 2.0) and index_of(t) == 1

    def no_wait(timeout: float | None = None) -> bool:
        raise AssertionError("close() waited with nothing in flight")

    m._changed.wait = no_wait  # type: ignore[method-assign]
    m.close()
    assert m.lost_reason == CLOSED_REASON


def test_real_time_drain_is_bounded_and_drain_false_skips_it() -> None:
    """A request the bridge answers only after 200 ms: a draining close waits for it (OK, not
    lost), `close(drain=False)` does not (BRIDGE_LOST)."""
    for drain, flags in ((True, ErrorFlag.NONE), (False, ErrorFlag.BRIDGE_LOST)):
        m = rt_manager(rt_bench(), timeout_s=1.0)
        t = read_ident(m, SLOW)
        assert m.wait_until(lambda: t.sent_ns is not None, 2.0)
        m.close(drain=drain)
        assert t.done and t.flags == flags


def test_real_time_drain_ends_at_the_lifetime_when_the_bridge_never_answers() -> None:
    m = rt_manager(rt_bench(), timeout_s=0.1)
    m.transport.write_batch = lambda data: None  # type: ignore[method-assign]
    t = read_ident(m, FAST)
    assert m.wait_until(lambda: t.sent_ns is not None, 2.0)
    m.close()
    assert t.sent_ns is not None and m.now_ns() >= t.sent_ns + 600 * MS
    assert t.flags == ErrorFlag.UPLINK_TIMEOUT and m.lost_reason == CLOSED_REASON


def test_rs232_pty_late_response_of_a_closed_manager_does_not_reach_the_next_one(
        fake_bridge: Callable[..., BridgeProc]) -> None:
    """The `urb` CLI's case: one RS232Manager per command on the same port, the bridge its own
    process behind a pty."""
    bp = fake_bridge([f"MotorDriver:0@{SLOW}", f"MotorDriver:1@{FAST}"])
    bp.cmd(f"stretch {SLOW} 200")

    def opened(timeout_s: float) -> RS232Manager:
        m = RS232Manager(str(bp.link), timeout_s=timeout_s, placeholder_s=0.6, lost_after_s=1.5)
        m.start()
        return m

    check_next_manager_gets_its_own_response(opened)
