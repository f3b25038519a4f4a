"""USBManager's cyclic runtime (`cyclic=True`): no thread of the library; the application calls
`service()` at its tick, and everything happens inside that call (host/urb/README.md, "The cyclic
runtime").

Each test runs three ways: the C core with its I/O in C (`_pump_open`/`_pump_service`), the C core
with the I/O in Python (`usb.USE_PUMP` off), and the Python reference core. The far end is the
Python bridge model behind a SOCK_SEQPACKET pair (a USB bridge's character device), in a thread.
"""

from __future__ import annotations

import os
import socket
import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest

from cyclic_ticks import os_threads, service_until, tick
from bridge_proc import serve_usb_transfers
from urb.api import NodeAccessor, NodeRequest, URBInterface
from urb.errors import ErrorFlag, RequestFailed
from urb.managers import BridgeModel, CharDeviceTransport, LoopbackUsbTransport, USBManager, fake_node, native, usb
from urb.managers.base import ThreadedManager, Transfer
from urb.managers.usb_core import UsbCore as ReferenceUsbCore  # not the name conftest swaps (URB_TEST_CORES=c)
from urb_msgs import sensorhex as sx

NODES = ["MotorDriver:0@16", "MotorDriver:1@17", "Imu:0@48"]
RUNTIMES = ["c-pump", "c-core-python-io", "python-core"]


def model() -> BridgeModel:
    return BridgeModel(dict(fake_node(s) for s in NODES), fifo_depth=15)


@pytest.fixture(params=RUNTIMES)
def runtime(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """Which core and which I/O path the managers made in the test use."""
    name = str(request.param)
    if name.startswith("c-") and native.BACKEND != "c":
        pytest.fail(f"the C core is not in use ({native.REASON}): `make host-c-py` builds it")
    if name == "python-core":
        monkeypatch.setattr(usb, "new_usb_core", lambda **kw: ReferenceUsbCore(**kw))
    if name == "c-core-python-io":
        monkeypatch.setattr(usb, "USE_PUMP", False)
    return name


class Far:
    """The bridge end of a SOCK_SEQPACKET pair, answering in a thread (`serve_usb_transfers`);
    `silent=True`: it takes every OUT transfer and never answers."""

    def __init__(self, bridge: BridgeModel, silent: bool = False) -> None:
        self.host_sock, self.dev_sock = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        target = self._swallow if silent else serve_usb_transfers
        self.thread = threading.Thread(target=target, args=(self.dev_sock, bridge), daemon=True)
        self.thread.start()

    @staticmethod
    def _swallow(sock: socket.socket, bridge: BridgeModel) -> None:
        while True:
            try:
                if not sock.recv(4096):
                    return
            except OSError:
                return

    def unplug(self) -> None:
        self.dev_sock.shutdown(socket.SHUT_RDWR)
        self.dev_sock.close()


@pytest.fixture
def far() -> Iterator[Far]:
    f = Far(model())
    yield f
    f.host_sock.close()
    f.dev_sock.close()


def manager(f: Far, **kw: Any) -> USBManager:
    settings: dict[str, Any] = {"timeout_s": 1.0, "lost_after_s": 2.0, "name": "cyclic"} | kw
    return USBManager(CharDeviceTransport(fd=os.dup(f.host_sock.fileno())), cyclic=True, **settings)


def uses_runtime(m: USBManager, runtime: str) -> None:
    """The manager really runs the path the test is named after."""
    assert m.cyclic and m._serviced
    assert m._pump_on == (runtime == "c-pump")
    assert (type(m._usb) is ReferenceUsbCore) == (runtime == "python-core")


def exercise(urb: URBInterface, m: USBManager, limit_s: float = 10.0) -> None:
    """40 ticks of the cyclic pattern with reads and writes on two motors, then the checks: one
    callback per request, in submission order, each inside service() on this thread, every one OK
    with the data written, completion times in order."""
    motors = [urb.find_node("MotorDriver", i) for i in range(2)]
    motors[1].write_message(sx.MotorCommand(voltage=4321))  # blocking calls service too
    assert motors[1].read_message(sx.MotorFeedback).voltage == 4321
    in_service = [False]
    seen: list[tuple[NodeRequest, bool, threading.Thread]] = []

    def cb(r: NodeRequest) -> None:
        seen.append((r, in_service[0], threading.current_thread()))

    reqs: list[NodeRequest] = []
    refused: list[NodeRequest] = []
    for k in range(40):
        for node in motors:
            reqs.append(node.submit_request(node.new_request().read_message(sx.MotorFeedback).set_callback(cb)))
        if k % 3 == 0:
            reqs.append(motors[0].submit_request(
                motors[0].new_request().write_message(sx.MotorCommand(voltage=k)).set_callback(cb)))
        if k % 10 == 5:  # refused on the host (HOST_SIZE_MISMATCH): its callback too waits for service()
            refused.append(motors[1].submit_request(motors[1].new_request().read(1, size=2).set_callback(cb)))
            reqs.append(refused[-1])
        in_service[0] = True
        tick(urb)
        in_service[0] = False
    in_service[0] = True
    service_until(urb, lambda: all(r.done for r in reqs), limit_s)
    sent = [r for r in reqs if r not in refused]  # a refusal completes at once, ahead of requests in flight
    assert sorted(map(id, (r for r, _, _ in seen))) == sorted(map(id, reqs)), "not one callback per request"
    assert [r for r, _, _ in seen if r not in refused] == sent, "callbacks out of submission order"
    assert all(inside for _, inside, _ in seen), "a callback ran outside service()"
    assert all(thread is threading.current_thread() for _, _, thread in seen)
    assert len(refused) == 4 and all(r.flags == ErrorFlag.HOST_SIZE_MISMATCH for r in refused)
    assert all(r.ok for r in sent), [r.error for r in sent if not r.ok]
    assert reqs[1].message().voltage == 4321 and m.stats.completed >= len(reqs)  # motors[1]
    late = [r.completed_ns for r in sent]
    assert late == sorted(late)


# lobster-trace: urb.HOST_005
def test_no_thread_runs_and_callbacks_run_inside_service_in_order(runtime: str, far: Far) -> None:
    before = os_threads()
    urb = URBInterface()
    m = manager(far)
    try:
        urb.add_bus_manager(m)  # discovery services the manager itself while it waits
        uses_runtime(m, runtime)
        assert os_threads() <= before  # no new thread: no Python thread, no C pump thread
        exercise(urb, m)
    finally:
        urb.close()
    assert not m._serviced and (not m._pump_on)


def _callbacks_at_submission(self: ThreadedManager) -> None:
    self._drain_completions_inline()  # the closed manager's rule applied while serviced


def _reversed_batch(self: ThreadedManager, batch: list[Any], run: Any = ThreadedManager._run_callbacks) -> int:
    return int(run(self, list(reversed(batch))))


SEEDED_BUGS: dict[str, tuple[str, Any, type[Exception], str]] = {
    "callbacks run at submission": ("_complete_without_dispatcher", _callbacks_at_submission, AssertionError,
                                    "a callback ran outside service()"),
    "a batch's callbacks reversed": ("_run_callbacks", _reversed_batch, AssertionError,
                                     "callbacks out of submission order"),
    "service does no I/O": ("_service_io", lambda self: None, RequestFailed, "no completion within"),
}


@pytest.mark.parametrize("bug", sorted(SEEDED_BUGS))
def test_the_checks_reject_seeded_runtime_bugs(bug: str, far: Far, monkeypatch: pytest.MonkeyPatch) -> None:
    """Each seeded bug in the cyclic runtime (applied after discovery) fails `exercise` on the
    check written for it; the unchanged runtime passes it (the test above)."""
    name, replacement, error, message = SEEDED_BUGS[bug]
    urb = URBInterface()
    m = manager(far)
    try:
        urb.add_bus_manager(m)
        monkeypatch.setattr(USBManager if name == "_service_io" else ThreadedManager, name, replacement)
        with pytest.raises(error, match=message):
            exercise(urb, m, limit_s=1.0)
    finally:
        monkeypatch.undo()
        urb.close()


def test_both_cores_give_the_same_outcomes(runtime: str) -> None:
    """The same script on a fresh bridge gives the same outcome, request by request, on every
    runtime (compared against the reference runtime's record, made in the same test)."""
    def script(m: USBManager) -> list[tuple[str, str, int | None, bytes | None]]:
        urb = URBInterface()
        try:
            urb.add_bus_manager(m)
            motor, imu = urb.find_node("MotorDriver", 0), urb.find_node("Imu", 0)
            reqs = [motor.submit_request(motor.new_request().write_message(sx.MotorCommand(voltage=99))),
                    motor.submit_request(motor.new_request().read_message(sx.MotorFeedback)),
                    motor.submit_request(motor.new_request().read(1, size=3)),  # refused: HOST_SIZE_MISMATCH
                    imu.submit_request(imu.new_request().read_message(sx.ImuSample)),
                    imu.submit_request(imu.new_request().read(7))]  # no such outbox: refused
            service_until(urb, lambda: all(r.done for r in reqs))
            return [(r.flags.describe(), r.status.name if r.status is not None else "-", r.sent_ns and r.sent_ns > 0 and 1,
                     r.data) for r in reqs]
        finally:
            urb.close()

    f = Far(model())
    g = Far(model())
    try:
        got = script(manager(f))
        with pytest.MonkeyPatch.context() as mp:  # the reference: the Python core, I/O in Python
            mp.setattr(usb, "new_usb_core", lambda **kw: ReferenceUsbCore(**kw))
            want = script(manager(g))
    finally:
        for x in (f, g):
            x.host_sock.close()
    assert got == want
    assert [o[0] for o in got] == ["OK", "OK", "HOST_SIZE_MISMATCH", "OK", "HOST_SIZE_MISMATCH"]


def test_blocking_calls_and_service_inside_a_callback_are_refused(runtime: str, far: Far) -> None:
    urb = URBInterface()
    m = manager(far)
    errors: list[str] = []
    try:
        urb.add_bus_manager(m)
        motor = urb.find_node("MotorDriver", 0)

        def cb(r: NodeRequest) -> None:
            for call in (lambda: motor.read(1), urb.service):
                try:
                    call()
                except RuntimeError as exc:
                    errors.append(str(exc))

        req = motor.submit_request(motor.new_request().read(1).set_callback(cb))
        service_until(urb, lambda: req.done)
    finally:
        urb.close()
    assert len(errors) == 2
    assert "would deadlock" in errors[0] and "inside a callback" in errors[1]


def test_a_silent_bridge_times_out_and_an_unplugged_one_is_lost_inside_service(runtime: str) -> None:
    f = Far(model())
    urb = URBInterface()
    m = manager(f, timeout_s=0.05, lost_after_s=0.3)
    try:
        urb.add_bus_manager(m)
        motor = urb.find_node("MotorDriver", 0)
        told: list[tuple[str, bool]] = []
        order: list[str] = []
        m.add_lost_listener(lambda mgr, why: (told.append((why, threading.current_thread() is threading.main_thread())),
                                              order.append("lost")))
        f.unplug()
        reqs: list[NodeRequest] = []
        end = time.monotonic() + 10
        while m.lost_reason is None and time.monotonic() < end:
            reqs.append(motor.submit_request(motor.new_request().read(1).set_callback(lambda r: order.append("cb"))))
            tick(urb, 5)
        service_until(urb, lambda: all(r.done for r in reqs))
        assert m.lost_reason is not None and told and told[0][1]
        # the write to the closed pair fails at once: the bridge is lost at the next boundary
        assert {r.flags for r in reqs} == {ErrorFlag.BRIDGE_LOST} and "Errno" in m.lost_reason
        assert order.count("lost") == 1 and order[0] == "lost"  # the notice before the callbacks
        after = motor.submit_request(motor.new_request().read(1))
        service_until(urb, lambda: after.done)
        assert after.flags == ErrorFlag.BRIDGE_LOST
    finally:
        urb.close()
        f.host_sock.close()


def test_a_bridge_that_never_answers_gives_uplink_timeout_per_request(runtime: str) -> None:
    silent = Far(model(), silent=True)
    m = manager(silent, timeout_s=0.02, lost_after_s=5.0, name="silent")
    m.start()  # no discovery: it would never finish; transfers are submitted to the manager directly
    done: list[Transfer] = []
    try:
        uses_runtime(m, runtime)
        ts = [Transfer(address=16, mailbox=1, read=True, length=6, on_done=done.append) for _ in range(3)]
        for t in ts:
            m.submit(t)
        end = time.monotonic() + 5
        while len(done) < 3:
            assert time.monotonic() < end, "no UPLINK_TIMEOUT while serviced"
            tick(m)
        assert done == ts and [t.flags for t in ts] == [ErrorFlag.UPLINK_TIMEOUT] * 3
        assert all(t.sent_ns is not None for t in ts)
    finally:
        m.close(drain=False)
        silent.host_sock.close()
        silent.dev_sock.close()


def test_close_drains_by_servicing_and_later_requests_fail_at_once(runtime: str, far: Far) -> None:
    urb = URBInterface()
    m = manager(far)
    urb.add_bus_manager(m)
    motor = urb.find_node("MotorDriver", 0)
    reqs = [motor.submit_request(motor.new_request().read(1)) for _ in range(6)]
    tick(urb, 2)  # sent, not all answered yet
    closer = threading.current_thread()
    ran_on: list[threading.Thread] = []
    reqs.append(motor.submit_request(motor.new_request().read(1).set_callback(lambda r: ran_on.append(threading.current_thread()))))
    urb.close()  # drains: services until the requests in flight are answered
    assert all(r.done for r in reqs) and ran_on == [closer]
    assert all(r.ok for r in reqs[:6]), [r.error for r in reqs]
    late = motor.submit_request(motor.new_request().read(1))
    assert late.done and late.flags == ErrorFlag.BRIDGE_LOST  # closed: completes inside submit
    assert urb.service() == 0


def test_reconnect_of_a_cyclic_manager_starts_no_thread(runtime: str, far: Far) -> None:
    before = os_threads()
    urb = URBInterface()
    m = manager(far)
    try:
        urb.add_bus_manager(m)
        urb.reconnect(m)
        assert os_threads() <= before  # no new thread
        motor = urb.find_node("MotorDriver", 0)
        assert motor.read_message(sx.MotorFeedback).voltage == 0
    finally:
        urb.close()


def test_service_of_a_threaded_manager_is_an_error() -> None:
    m = USBManager(LoopbackUsbTransport(model()), timeout_s=1.0)
    with pytest.raises(RuntimeError, match="cyclic=True"):
        m.service()
    urb = URBInterface()
    try:
        urb.add_bus_manager(m)
        assert urb.service() == 0  # threaded managers are left to their threads
    finally:
        urb.close()


@pytest.mark.parametrize("core", ["c", "python"])
def test_a_cyclic_manager_over_a_push_transport(core: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """A transport that pushes its IN transfers (the loopback bridge answers inside the write):
    the cyclic manager sends one batch per boundary and runs the callbacks in service() (the
    I/O path in Python, on either core)."""
    if core == "python":
        monkeypatch.setattr(usb, "new_usb_core", lambda **kw: ReferenceUsbCore(**kw))
    urb = URBInterface()
    m = USBManager(LoopbackUsbTransport(model()), timeout_s=1.0, cyclic=True)
    try:
        urb.add_bus_manager(m)
        assert (type(m._usb) is ReferenceUsbCore) == (core == "python" or native.BACKEND != "c") and not m._pump_on
        node: NodeAccessor = urb.find_node("MotorDriver", 1)
        frames = m._usb.frames_written
        reqs = [node.submit_request(node.new_request().read(1)) for _ in range(10)]
        assert not any(r.done for r in reqs)
        service_until(urb, lambda: all(r.done for r in reqs))
        assert all(r.ok for r in reqs)
        assert m._usb.frames_written - frames <= 4  # batched: 10 requests in a few 1-ms batches
    finally:
        urb.close()


def test_a_descriptor_closed_with_nothing_in_flight_is_a_loss_told_in_service(far: Far) -> None:
    """On the C pump a descriptor closed under the manager is a loss at once, even with nothing in
    flight: service() must hand the lost listeners their notice although no request completed."""
    if native.BACKEND != "c":
        pytest.fail(f"the C core is not in use ({native.REASON}): `make host-c-py` builds it")
    fd = os.dup(far.host_sock.fileno())
    m = USBManager(CharDeviceTransport(fd=fd), timeout_s=1.0, lost_after_s=2.0, name="closed", cyclic=True)
    m.start()
    told: list[str] = []
    m.add_lost_listener(lambda mgr, why: told.append(why))
    try:
        assert m._pump_on
        os.close(fd)
        end = time.monotonic() + 5
        while not told:
            assert time.monotonic() < end, "the loss was never told"
            tick(m)
        assert m.lost_reason is not None and "Errno" in told[0]
    finally:
        m.close(drain=False)
