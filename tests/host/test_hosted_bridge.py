"""Real-port tests against the bridge firmware compiled for the host (build/firmware/urb-bridge-hosted).

The same scenarios as test_rs232_pty.py, with the real bridge core (firmware/bridge) behind the
pty and its in-process simulated I2C bus with fake nodes. Nothing here is skipped: when the
hosted bridge cannot be built the tests fail with the build's output.

The hosted program has no control channel, so line faults go through `LineTap` (a pty proxy on
the RS232 line), and a node that vanishes is one the restarted bridge no longer has
(`absent=1`, wired but not answering) while the host keeps its table.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from bridge_proc import SENSORHEX, BridgeProc, LineTap, hosted_bridge  # noqa: F401 (fixture)
from urb.api import NodeRequest, URBInterface
from urb.errors import ErrorFlag, FingerprintMismatchError, RequestFailed
from urb.managers import RS232Manager
from urb_msgs import MailboxInfo, NodeInfo, sensorhex as sx, urb_core as core

MANAGER_OPTS = dict(timeout_s=1.0, lost_after_s=3.0)

ECHO_FP = 0x0ECC0042
ECHO = NodeInfo("EchoNode", "node", 0x42, ECHO_FP, "a generic hosted node: inbox 1 is copied to outbox 1",
                "tests/host/test_hosted_bridge.py", "", (
                    MailboxInfo("outbox", 0, core.Identification, 25, None, ""),
                    MailboxInfo("inbox", 0, core.Command, 6, None, ""),
                    MailboxInfo("inbox", 1, sx.MotorFeedback, 6, None, ""),
                    MailboxInfo("outbox", 1, sx.MotorFeedback, 6, None, "")))
ECHO_SPEC = f"0x42,7,0x60,in1=6,out1=6,fp=0x{ECHO_FP:08x}"


def schema() -> list[NodeInfo]:
    from urb_msgs import NODES

    return [n for n in NODES.values() if n.kind == "node"] + [ECHO]


def connect(path: Path) -> tuple[URBInterface, RS232Manager]:
    urb = URBInterface(schema())
    m = RS232Manager(str(path), **MANAGER_OPTS)  # type: ignore[arg-type]
    report = urb.add_bus_manager(m)
    assert report.problems == [], f"the hosted bridge reported downlink problems: {report.problems}"
    return urb, m


@pytest.fixture
def system(hosted_bridge: Callable[..., BridgeProc]) -> Iterator[tuple[URBInterface, RS232Manager, BridgeProc]]:
    bp = hosted_bridge(SENSORHEX + [ECHO_SPEC])
    urb, m = connect(bp.link)
    yield urb, m, bp
    urb.close()


# lobster-trace: urb.DSC_005
def test_discovery_of_every_node_through_the_firmware(system: tuple[URBInterface, RS232Manager, BridgeProc]) -> None:
    urb, m, _ = system
    rows = urb.nodes()
    assert [(r.name, r.index, r.address) for r in rows] == [("MotorDriver", i, 0x10 + i) for i in range(6)] + [
        ("BatteryManager", 0, 32), ("Imu", 0, 48), ("IrDistance", 0, 49), ("EchoNode", 7, 0x60)]
    assert all(r.fingerprint == r.expected_fingerprint and not r.flags for r in rows)
    info = urb.reports[id(m)].info
    assert info is not None and (info.fw_major, info.fw_minor, info.fifo_depth) == (0, 1, 16)
    assert m._core.window == 15  # type: ignore[attr-defined]  # min(fifo_depth, 15)


def test_reads_and_writes_on_every_mailbox(system: tuple[URBInterface, RS232Manager, BridgeProc]) -> None:
    urb, _, _ = system
    for row in urb.nodes():
        node = urb.find_node(row.class_id, row.index)
        for mb in node.info.mailboxes:
            if mb.direction == "outbox":
                msg = node.read(mb.number)
                assert isinstance(msg, mb.message), (row.label, mb.number)
                if mb.number == 0:
                    assert isinstance(msg, core.Identification)
                    assert (msg.class_id, msg.index, msg.fingerprint) == (row.class_id, row.index, row.fingerprint)
                    assert msg.outbox_sizes == node.info.sizes("outbox")
            else:
                node.write(mb.number, mb.message())  # the bridge answers OK only when the node stored it
    echo = urb.find_node("EchoNode", 7)
    sent = sx.MotorFeedback(encoder=4242, current=-17, voltage=1200)
    echo.write_message(sent, mbox=1)
    assert echo.read_message(sx.MotorFeedback) == sent
    bridge = urb.bridge_node(system[1])
    assert bridge.read_message(core.BridgeScan).present[0x60]


# lobster-trace: urb.HOST_005
def test_callbacks_in_order_with_timestamps(system: tuple[URBInterface, RS232Manager, BridgeProc]) -> None:
    urb, _, _ = system
    nodes = [urb.find_node("MotorDriver", i) for i in range(6)] + [urb.find_node("Imu", 0)]
    seen: list[NodeRequest] = []
    lock = threading.Lock()

    def cb(req: NodeRequest) -> None:
        with lock:
            seen.append(req)

    reqs = [nodes[k % 7].submit_request(nodes[k % 7].new_request().read(1).set_callback(cb)) for k in range(300)]
    assert all(r.wait(5.0) for r in reqs)
    assert seen == reqs and all(r.ok for r in reqs), {r.flags.describe() for r in reqs}
    for r in reqs:
        assert r.submitted_ns is not None and r.sent_ns is not None and r.completed_ns is not None
        assert r.callback_ns is not None and r.submitted_ns <= r.sent_ns <= r.completed_ns <= r.callback_ns


# lobster-trace: urb.ERR_001
def test_bridge_admission_errors_reach_the_callback(system: tuple[URBInterface, RS232Manager, BridgeProc]) -> None:
    """SIZE_MISMATCH decided by the firmware from the sizes it learnt at its scan: sent raw."""
    urb, m, _ = system
    from urb.managers.base import Transfer

    done: list[Transfer] = []
    t = Transfer(0x10, 1, True, 5, on_done=done.append)  # the motor's outbox 1 holds 6 bytes
    m.submit(t)
    assert m.wait_until(lambda: bool(done), 2.0)
    assert t.flags == ErrorFlag.SIZE_MISMATCH and t.status == core.Status.SIZE_MISMATCH
    t2 = Transfer(0x70, 1, True, 4, on_done=done.append)  # nobody at 0x70
    m.submit(t2)
    assert m.wait_until(lambda: len(done) == 2, 2.0) and t2.flags == ErrorFlag.NO_NODE


# lobster-trace: urb.FLT_006
def test_corrupted_byte_and_lost_request_on_the_line(hosted_bridge: Callable[..., BridgeProc], tmp_path: Path) -> None:
    bp = hosted_bridge(SENSORHEX)
    tap = LineTap(bp.pty, tmp_path / "ttyTAP")
    urb, m = connect(tap.path)
    try:
        motor = urb.find_node("MotorDriver", 0)
        for index in (0, 3, 7):  # header, data and check byte of the 8-byte response
            tap.corrupt_response(index, 0x10)
            reqs = [motor.submit_request(motor.new_request().read(1))]
            assert reqs[0].wait(3)
            reqs += [motor.submit_request(motor.new_request().read(1)) for _ in range(4)]
            assert all(r.wait(3) for r in reqs)
            assert reqs[0].flags == ErrorFlag.UPLINK_CHECKSUM, index
            assert all(r.ok for r in reqs[1:])
        tap.drop_requests(1)
        lost = motor.submit_request(motor.new_request().read(1))
        assert lost.wait(3) and lost.flags == ErrorFlag.UPLINK_TIMEOUT
        assert motor.read_message(sx.MotorFeedback) is not None and m.lost_reason is None
    finally:
        urb.close()
        tap.close()


def test_bridge_killed_restarted_and_a_node_gone(hosted_bridge: Callable[..., BridgeProc]) -> None:
    nodes = SENSORHEX[:3]
    bp = hosted_bridge(nodes)
    urb, m = connect(bp.link)
    lost_calls: list[str] = []
    urb.on_bridge_lost = lambda mgr, why: lost_calls.append(why)
    try:
        m0, m2 = urb.find_node("MotorDriver", 0), urb.find_node("MotorDriver", 2)
        assert m2.read_message(sx.MotorFeedback) is not None
        bp.kill()
        reqs = [m0.submit_request(m0.new_request().read(1)) for _ in range(4)]
        assert all(r.wait(5) for r in reqs) and all(r.flags == ErrorFlag.BRIDGE_LOST for r in reqs)
        assert m.lost_reason is not None and len(lost_calls) == 1
        t0 = time.monotonic()
        with pytest.raises(RequestFailed) as exc:
            m0.read_message(sx.MotorFeedback)
        # BRIDGE_LOST, not UPLINK_TIMEOUT, and sooner than the uplink timeout
        assert exc.value.flags == ErrorFlag.BRIDGE_LOST and time.monotonic() - t0 < MANAGER_OPTS["timeout_s"]
        # restarted with motor 2 unplugged (wired, not answering): reopen without rediscovery,
        # as the host would mid-run: the bridge answers NO_NODE (Discovery.tla VanishedGetNoNode)
        bp.argv[bp.argv.index("motor,2,18")] = "motor,2,18,absent=1"
        bp.start()
        m.reconnect()
        assert m0.read_message(sx.MotorFeedback) is not None
        gone = m2.submit_request(m2.new_request().read(1))
        assert gone.wait(3) and gone.flags == ErrorFlag.NO_NODE
        # told to recover: rediscovery drops it from the table, its accessor says so
        report = urb.reconnect(m)
        assert [r.address for r in report.records] == [16, 17]
        again = m2.submit_request(m2.new_request().read(1))
        assert again.wait(3) and again.flags == ErrorFlag.UNKNOWN_NODE
        assert m0.read_message(sx.MotorFeedback) is not None
    finally:
        urb.close()


# lobster-trace: urb.DSC_003
def test_fingerprint_mismatch_names_both(hosted_bridge: Callable[..., BridgeProc]) -> None:
    bp = hosted_bridge(["imu,0,0x30,fp=0x12345678", "motor,0,0x10"])
    urb, _ = connect(bp.link)
    try:
        with pytest.raises(FingerprintMismatchError) as exc:
            urb.find_node("Imu", 0)
        assert "0x12345678" in str(exc.value) and "0x6c8913bd" in str(exc.value)
        assert urb.find_node("MotorDriver", 0).read(1) is not None
    finally:
        urb.close()


# lobster-trace: urb.HOST_001, urb.ORD_003
@pytest.mark.slow
def test_10000_requests_at_1khz_without_loss_or_reordering(system: tuple[URBInterface, RS232Manager, BridgeProc]) -> None:
    urb, m, _ = system
    motors = [urb.find_node("MotorDriver", i) for i in range(6)]
    n = 10_000
    order: list[int] = []
    lock = threading.Lock()
    ids: dict[int, int] = {}

    def cb(req: NodeRequest) -> None:
        with lock:
            order.append(ids[id(req)])

    reqs: list[NodeRequest] = []
    start = time.monotonic_ns()
    for k in range(n):
        while (delay := start + k * 1_000_000 - time.monotonic_ns()) > 0:
            time.sleep(delay / 1e9)
        node = motors[k % 6]
        req = node.new_request()
        req.write_message(sx.MotorCommand(voltage=k)) if k % 10 == 9 else req.read(1)
        req.set_callback(cb)
        ids[id(req)] = k
        reqs.append(node.submit_request(req))
    assert m.wait_until(lambda: len(order) == n, 10.0), "callbacks missing"
    assert order == list(range(n)), "callbacks out of order"
    failed = [(k, r.flags.describe()) for k, r in enumerate(reqs) if not r.ok]
    assert failed == [], f"{len(failed)} failed, first: {failed[:5]}"
