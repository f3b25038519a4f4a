"""The API in virtual time: SimManager over the loopback RS232 line and USB pipe.

Deterministic: a VirtualClock, byte times at 115200 Bd, I2C transaction times at 400 kb/s, so
latencies can be checked against the paper's analysis (Sec. V-B, V-C; Figs. 15, 16) exactly.
"""

from __future__ import annotations

from collections.abc import Callable

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from urb.api import NodeRequest, URBInterface
from urb.errors import ErrorFlag, NodeNotFoundError, UnknownClassError
from urb.managers import (
    BridgeModel,
    Clock,
    LoopbackByteTransport,
    LoopbackFrameTransport,
    SimManager,
    VirtualClock,
    fake_node,
)
from urb.managers.rs232_core import Rs232Core
from urb.managers.usb_core import UsbCore
from urb.managers.base import NS_PER_MS
from urb_msgs import sensorhex as sx

HEX = [f"MotorDriver:{i}@{16 + i}" for i in range(6)] + ["BatteryManager:0@32", "Imu:0@48", "IrDistance:0@49"]


def system(kind: str = "rs232", nodes: list[str] | None = None, **bridge_opts: object) -> tuple[URBInterface, SimManager, VirtualClock, BridgeModel]:
    clock = VirtualClock()
    bridge = BridgeModel(dict(fake_node(s) for s in (nodes or HEX)), timed_downlink=True, **bridge_opts)  # type: ignore[arg-type]
    transport = LoopbackByteTransport(clock, bridge) if kind == "rs232" else LoopbackFrameTransport(clock, bridge)
    m = SimManager(clock, transport, name=f"sim-{kind}")
    urb = URBInterface()
    urb.add_bus_manager(m)
    return urb, m, clock, bridge


# lobster-trace: urb.DSC_008
@pytest.mark.parametrize("kind", ["rs232", "usb"])
def test_discovery_and_typed_access(kind: str) -> None:
    urb, m, clock, _ = system(kind)
    assert [r.label for r in urb.nodes()] == [f"MotorDriver:{i}" for i in range(6)] + ["BatteryManager:0", "Imu:0", "IrDistance:0"]
    motor = urb.find_node(sx.MOTOR_DRIVER, 5)
    motor.write_message(sx.MotorConfig(mode=sx.MotorMode.VOLTAGE, voltage_limit=12000))
    motor.write_message(sx.MotorCommand(voltage=-4200))
    assert motor.read_message(sx.MotorFeedback).voltage == -4200
    assert motor.read_message(sx.MotorStatus).mode == sx.MotorMode.VOLTAGE
    assert urb.find_node(0x20, 0).read_message(sx.BatteryStatus).packs[2].charge == 78
    with pytest.raises(UnknownClassError, match="known: MotorDriver"):
        urb.find_node("Gripper", 0)
    with pytest.raises(NodeNotFoundError):
        urb.find_node("Imu", 1)


# lobster-trace: urb.PKT_005
def test_rs232_round_trip_matches_the_byte_budget() -> None:
    """A 10-byte read: 4 request bytes + I2C transaction + 12 response bytes at 115200 Bd."""
    urb, m, clock, bridge = system("rs232")
    bridge_read = urb.find_node("Imu", 0)
    req = bridge_read.new_request().read(1)  # ImuSample: 14 bytes -> 17-byte response (CRC-16)
    bridge_read.submit_request(req)
    assert req.wait()
    byte_ns = 10 * 1_000_000_000 // 115200
    i2c = (1 + 1 + 1 + 14 + 2) * 9 * 1_000_000 // 400
    assert req.latency_ns == (4 + 17) * byte_ns + i2c


# lobster-trace: urb.LAT_003
@settings(max_examples=30, deadline=None)
@given(per_frame=st.lists(st.integers(0, 20), min_size=1, max_size=12))
def test_usb_latency_is_at_most_three_frames_within_the_budget(per_frame: list[int]) -> None:
    """UsbUplink.tla: every callback within 3 frames of its submission (StrictLatency) when the
    submissions fit the budget, and otherwise every request still completes, matched to its own
    response (NothingLost, ResponsesMatched). The budget: at most MaxBatch per frame, and, since
    a batch holds its window slots until its responses arrive one frame later, at most `window`
    (<= 15, Bridge.tla HostWindow < SeqMod) in any two consecutive frames."""
    urb, m, clock, _ = system("usb", ["MotorDriver:0@16", "MotorDriver:1@17"], fifo_depth=15)
    motors = [urb.find_node("MotorDriver", i) for i in range(2)]
    core = m.core
    assert isinstance(core, UsbCore) and core.window == 15
    clock.run_for(5 * NS_PER_MS)
    start = (clock.now_ns() // NS_PER_MS + 1) * NS_PER_MS + NS_PER_MS // 3
    reqs: list[tuple[int, NodeRequest]] = []
    for frame, n in enumerate(per_frame):
        def burst(n: int = n, frame: int = frame) -> None:
            for k in range(n):
                node = motors[k % 2]
                reqs.append((frame, node.submit_request(node.new_request().read(1))))
        clock.call_at(start + frame * NS_PER_MS, burst)
    clock.run_for(len(per_frame) * NS_PER_MS + 100 * NS_PER_MS)
    within = all(n <= core.max_batch for n in per_frame) and all(
        a + b <= core.window for a, b in zip(per_frame, per_frame[1:] + [0]))
    assert len(reqs) == sum(per_frame)
    for frame, req in reqs:
        assert req.ok and req.message(sx.MotorFeedback) is not None
        touched = (req.callback_ns or 0) // NS_PER_MS - (req.submitted_ns or 0) // NS_PER_MS + 1
        if within:
            assert touched <= 3, (frame, touched)


# lobster-trace: urb.LAT_003
def test_usb_latency_is_three_ms_in_steady_state() -> None:
    urb, m, clock, _ = system("usb")
    motor = urb.find_node("MotorDriver", 0)
    lat: list[int] = []

    def submit() -> None:
        motor.submit_request(motor.new_request().read(1).set_callback(lambda r: lat.append(r.latency_ns or 0)))

    for k in range(100):
        clock.call_at(clock.now_ns() + k * NS_PER_MS + 300_000, submit)
    clock.run_for(200 * NS_PER_MS)
    assert len(lat) == 100 and max(lat) <= 3 * NS_PER_MS and min(lat) >= NS_PER_MS


# lobster-trace: urb.DSC_006
def test_node_vanishes_then_rediscovery_marks_it_unknown() -> None:
    urb, m, clock, bridge = system("rs232")
    imu = urb.find_node("Imu", 0)
    bridge.nodes[48].present = False
    req = imu.submit_request(imu.new_request().read(1))
    assert req.wait() and req.flags == ErrorFlag.NO_NODE  # Discovery.tla VanishedGetNoNode
    assert any(r.label == "Imu:0" for r in urb.nodes())  # the row stays until rediscovery
    urb.reconnect(m)
    assert not any(r.label == "Imu:0" for r in urb.nodes())
    req = imu.submit_request(imu.new_request().read(1))
    assert req.wait() and req.flags == ErrorFlag.UNKNOWN_NODE
    motor = urb.find_node("MotorDriver", 0)
    assert motor.read_message(sx.MotorFeedback) is not None


# lobster-trace: urb.DSC_003
def test_node_reflashed_with_another_schema_is_refused_without_traffic() -> None:
    urb, m, clock, bridge = system("rs232")
    ir = urb.find_node("IrDistance", 0)
    bridge.nodes[49].fingerprint = 0xABCDEF01
    urb.reconnect(m)
    sent_before = bridge.stats.requests
    req = ir.submit_request(ir.new_request().read(1))
    assert req.wait() and req.flags == ErrorFlag.FINGERPRINT_MISMATCH
    assert bridge.stats.requests == sent_before and "another schema" in (req.error or "")


def test_unknown_class_is_listed_but_never_handed_out() -> None:
    from urb_msgs import NodeInfo

    from urb.managers.loopback import FakeNode
    from urb_msgs import MailboxInfo
    from urb_msgs.urb_core import Command, Identification

    gripper = NodeInfo("Gripper", "node", 0x77, 0x11111111, "", "spec/schema/other.urbs", "", (
        MailboxInfo("outbox", 0, Identification, 25, None, ""), MailboxInfo("inbox", 0, Command, 6, None, "")))

    clock = VirtualClock()
    bridge = BridgeModel({5: FakeNode(gripper, 0)})
    urb = URBInterface()
    urb.add_bus_manager(SimManager(clock, LoopbackByteTransport(clock, bridge)))
    (row,) = urb.nodes()
    assert row.name == "class 0x77" and "UNKNOWN_CLASS" in row.flags
    with pytest.raises(UnknownClassError):
        urb.find_node(0x77, 0)


def test_bridge_busy_answers_reach_callbacks_when_the_fifo_is_small() -> None:
    urb, m, clock, bridge = system("rs232", fifo_depth=1, ring=15, bitrate_kbps=50)  # slow downlink
    m.set_window(6)  # more than the bridge's FIFO: the excess is answered BUSY, in order
    motor = urb.find_node("MotorDriver", 0)
    order: list[int] = []
    reqs = []
    for k in range(6):
        req = motor.new_request().read(1)
        req.set_callback(lambda r, k=k: order.append(k))
        reqs.append(motor.submit_request(req))
    clock.run_for(50 * NS_PER_MS)
    flags = [r.flags for r in reqs]
    assert flags[0] == ErrorFlag.NONE and ErrorFlag.BUSY in flags
    assert all(f in (ErrorFlag.NONE, ErrorFlag.BUSY) for f in flags)
    assert order == list(range(6))  # every callback once, in submission order


# lobster-trace: urb.FLT_005
def test_lost_line_is_detected_and_reconnect_recovers() -> None:
    urb, m, clock, bridge = system("rs232")
    assert isinstance(m.transport, LoopbackByteTransport)
    lost: list[str] = []
    urb.on_bridge_lost = lambda mgr, why: lost.append(why)
    motor = urb.find_node("MotorDriver", 1)
    m.transport.unplug()
    def submit() -> None:
        motor.submit_request(motor.new_request().read(1))

    for k in range(1000):
        clock.call_at(clock.now_ns() + k * NS_PER_MS, submit)
    clock.run_for(1100 * NS_PER_MS)
    assert m.lost_reason is not None and len(lost) == 1
    m.transport.plug()
    urb.reconnect(m)
    assert motor.read_message(sx.MotorFeedback) is not None


def test_discovery_in_an_event_loop_without_blocking() -> None:
    """The simulation's clock need not be drivable: start_discovery reports through a callback."""

    class EventOnlyClock:
        def __init__(self) -> None:
            self.inner = VirtualClock()

        def now_ns(self) -> int:
            return self.inner.now_ns()

        def call_at(self, when_ns: int, fn: Callable[[], None]) -> None:
            self.inner.call_at(when_ns, fn)

    clock = EventOnlyClock()
    assert isinstance(clock, Clock)
    bridge = BridgeModel(dict(fake_node(s) for s in HEX[:2]))
    m = SimManager(clock, LoopbackByteTransport(clock, bridge))
    urb = URBInterface()
    reports: list[object] = []
    urb.start_discovery(m, reports.append)
    while clock.inner.step():
        pass
    assert len(reports) == 1 and [r.label for r in urb.nodes()] == ["MotorDriver:0", "MotorDriver:1"]
    with pytest.raises(RuntimeError, match="use callbacks"):
        urb.find_node("MotorDriver", 0).read(1)


def test_bridge_node_gives_the_bridge_mailboxes() -> None:
    from urb_msgs import urb_core as core

    urb, m, clock, bridge = system("rs232", HEX[:2])
    b = urb.bridge_node(m)
    assert b.address == 0 and b.label == "Bridge:0"
    assert b.read_message(core.BridgeInfo).fifo_depth == 8
    bridge.nodes[17].present = False
    b.write_message(core.BridgeCommand(opcode=core.BridgeOpcode.SCAN))
    scan = b.read_message(core.BridgeScan)
    assert scan.present[16] and not scan.present[17]
    b.write_message(core.BridgeCommand(opcode=core.BridgeOpcode.SET_HEARTBEAT, value=500))
    assert b.read_message(core.BridgeInfo).heartbeat_us == 500


# lobster-trace: urb.DSC_007
def test_discovery_reads_a_failed_identification_again_but_not_forever() -> None:
    from urb_msgs.urb_core import Status

    clock = VirtualClock()
    bridge = BridgeModel(dict(fake_node(s) for s in HEX[:3]))
    bridge.nodes[16].faults.extend([Status.TIMEOUT, Status.CHECKSUM])  # two transient failures: found
    bridge.nodes[17].faults.extend([Status.TIMEOUT] * 3)  # three: reported, not found
    urb = URBInterface()
    report = urb.add_bus_manager(SimManager(clock, LoopbackByteTransport(clock, bridge)))
    assert [r.address for r in report.records] == [16, 18]
    assert len(report.problems) == 1 and "address 17: identification read failed (TIMEOUT" in report.problems[0]


# -- bridge-lost rule, loss notification, blocking in callbacks, stats (review findings 6, 9, 10, 13) --

def _reads(motor: object, n: int, out: list[ErrorFlag]) -> None:
    from urb.api import NodeAccessor

    assert isinstance(motor, NodeAccessor)
    for _ in range(n):
        motor.submit_request(motor.new_request().read(1).set_callback(lambda r: out.append(r.flags)))


def test_a_short_glitch_times_requests_out_but_the_bridge_stays_usable() -> None:
    """8 request frames lost in ~3 ms with 8 reads outstanding: all 8 time out together, one
    `timeout` after they were sent, far less than `lost_after` of silence: not a lost bridge."""
    urb, m, clock, bridge = system("rs232", HEX[:2], fifo_depth=8)
    assert isinstance(m.transport, LoopbackByteTransport) and isinstance(m.core, Rs232Core)
    assert m.core.window == 8 and m.core.timeout_ns < m.core.lost_after_ns
    lost: list[str] = []
    urb.on_bridge_lost = lambda mgr, why: lost.append(why)
    motor = urb.find_node("MotorDriver", 0)
    m.transport.drop_requests(8)
    flags: list[ErrorFlag] = []
    _reads(motor, 8, flags)
    clock.run_for(150 * NS_PER_MS)
    assert flags == [ErrorFlag.UPLINK_TIMEOUT] * 8
    assert m.lost_reason is None and lost == []
    assert motor.read_message(sx.MotorFeedback) is not None  # the line is fine again


# lobster-trace: urb.FLT_004
def test_a_dead_bridge_is_lost_after_lost_after_of_silence_and_reported_at_once() -> None:
    """Bursts of 8 reads every 200 ms to a bridge that stopped answering: each burst times out
    (UPLINK_TIMEOUT) but keeps its sequence numbers (placeholders, 300 ms), so the next burst
    waits behind a full window; the bridge is declared lost `lost_after` (500 ms) without a byte
    (requests outstanding all that time), and on_bridge_lost runs then, not when a later request
    fails."""
    urb, m, clock, bridge = system("rs232", HEX[:2], fifo_depth=8)
    assert isinstance(m.transport, LoopbackByteTransport)
    motor = urb.find_node("MotorDriver", 0)
    last = motor.request(motor.new_request().read(1))
    last_rx = last.completed_ns
    assert last_rx is not None
    lost: list[tuple[int, str]] = []
    urb.on_bridge_lost = lambda mgr, why: lost.append((clock.now_ns(), why))
    m.transport.unplug()
    flags: list[ErrorFlag] = []
    start = clock.now_ns()
    for k in range(3):  # bursts at +0, +200, +400 ms; nothing is submitted afterwards
        clock.call_at(start + k * 200 * NS_PER_MS, lambda: _reads(motor, 8, flags))
    clock.run_for(2000 * NS_PER_MS)
    assert m.lost_reason is not None and len(lost) == 1
    at, why = lost[0]
    timeout_ns, lost_after_ns = m.core.timeout_ns, m.core.lost_after_ns
    assert lost_after_ns <= at - last_rx <= lost_after_ns + timeout_ns
    assert "sent nothing" in why
    # bursts 1 and 2 went out when burst 0's and 1's placeholders expired; burst 2 was queued at the loss
    assert flags == [ErrorFlag.UPLINK_TIMEOUT] * 16 + [ErrorFlag.BRIDGE_LOST] * 8
    req = motor.submit_request(motor.new_request().read(1))
    assert req.wait() and req.flags == ErrorFlag.BRIDGE_LOST and len(lost) == 1


def test_a_blocking_call_inside_a_sim_callback_raises_like_the_real_time_managers() -> None:
    urb, m, clock, _ = system("rs232", HEX[:2])
    motor = urb.find_node("MotorDriver", 0)
    out: list[tuple[str, str, int]] = []

    def cb(req: NodeRequest) -> None:
        t0 = clock.now_ns()
        try:
            motor.read(1)
        except Exception as exc:  # noqa: BLE001 (the type is what is checked)
            out.append((type(exc).__name__, str(exc), clock.now_ns() - t0))

    motor.submit_request(motor.new_request().read(1).set_callback(cb))
    clock.run_for(5 * NS_PER_MS)
    assert len(out) == 1
    kind, text, spent = out[0]
    assert kind == "RuntimeError" and "blocking URB call inside a callback" in text
    assert spent == 0  # no simulated time was run from inside the callback
    assert motor.read_message(sx.MotorFeedback) is not None


def test_refused_requests_count_in_sim_stats_like_the_real_time_managers() -> None:
    urb, m, clock, _ = system("rs232", HEX[:2])
    motor = urb.find_node("MotorDriver", 0)
    before = (m.stats.submitted, m.stats.completed, m.stats.failed)
    req = motor.submit_request(motor.new_request().read(1, size=3))
    assert req.wait() and req.flags == ErrorFlag.HOST_SIZE_MISMATCH
    assert (m.stats.submitted, m.stats.completed, m.stats.failed) == (before[0] + 1, before[1] + 1, before[2] + 1)


# lobster-trace: urb.PKT_003
def test_read_size_outside_1_to_32_is_rejected_with_its_message() -> None:
    urb, m, clock, _ = system("rs232", HEX[:2])
    motor = urb.find_node("MotorDriver", 0)
    for size in (0, -1, 33):
        with pytest.raises(ValueError, match=r"1\.\.32 bytes"):
            motor.new_request().read(1, size=size)
    missing = motor.submit_request(motor.new_request().read(7))  # not in the schema: refused on the host
    assert missing.wait() and missing.flags == ErrorFlag.HOST_SIZE_MISMATCH
