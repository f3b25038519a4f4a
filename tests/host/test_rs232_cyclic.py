"""RS232Manager's cyclic runtime (`cyclic=True`): no thread of the library; frames are written on
the submitting thread, and `service()` reads what the port received, applies the deadlines, writes
what a freed window lets go and runs the callbacks (host/urb/README.md, "The cyclic runtime").

On both cores (the C core through its Python methods, and the Python reference core), against the
fake bridge process on a pseudo-terminal (tests/host/fake_bridge.py).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import pytest

from cyclic_ticks import os_threads, service_until, tick
from bridge_proc import BridgeProc, fake_bridge  # noqa: F401 (fixture)
from urb.api import NodeRequest, URBInterface
from urb.errors import ErrorFlag
from urb.managers import RS232Manager, native, rs232
from urb.managers.rs232_core import Rs232Core as ReferenceRs232Core  # not the name conftest swaps (URB_TEST_CORES=c)
from urb_msgs import sensorhex as sx

NODES = ["MotorDriver:0@16", "MotorDriver:1@17", "Imu:0@48"]


@pytest.fixture(params=["c", "python"])
def core(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    name = str(request.param)
    if name == "c" and native.BACKEND != "c":
        pytest.fail(f"the C core is not in use ({native.REASON}): `make host-c-py` builds it")
    if name == "python":
        monkeypatch.setattr(rs232, "new_rs232_core", lambda **kw: ReferenceRs232Core(**kw))
    return name


# lobster-trace: urb.HOST_005
def test_no_thread_and_callbacks_in_order_inside_service(core: str, fake_bridge: Callable[..., BridgeProc]) -> None:
    bp = fake_bridge(nodes=NODES)
    before = os_threads()
    urb = URBInterface()
    m = RS232Manager(str(bp.link), timeout_s=1.0, lost_after_s=3.0, cyclic=True)
    try:
        urb.add_bus_manager(m)  # discovery services the manager while it waits
        assert os_threads() <= before and m.cyclic and not m._pump_on
        assert (type(m._rs) is ReferenceRs232Core) == (core == "python")
        motors = [urb.find_node("MotorDriver", i) for i in range(2)]
        motors[0].write_message(sx.MotorCommand(voltage=1234))
        assert motors[0].read_message(sx.MotorFeedback).voltage == 1234
        inside = [False]
        seen: list[tuple[NodeRequest, bool]] = []
        reqs = []
        for k in range(20):
            for node in motors:
                reqs.append(node.submit_request(node.new_request().read(1).set_callback(
                    lambda r: seen.append((r, inside[0])))))
            assert not any(r.done for r in reqs[-2:])
            inside[0] = True
            tick(urb, 2)
            inside[0] = False
        inside[0] = True
        service_until(urb, lambda: all(r.done for r in reqs))
        assert [r for r, _ in seen] == reqs and all(flag for _, flag in seen)
        assert all(r.ok for r in reqs), [r.error for r in reqs if not r.ok]
        assert reqs[0].message().voltage == 1234
    finally:
        urb.close()
    assert not m._serviced


def test_a_killed_bridge_is_lost_inside_service_and_close_drains(core: str,
                                                                 fake_bridge: Callable[..., BridgeProc]) -> None:
    bp = fake_bridge(nodes=NODES)
    urb = URBInterface()
    m = RS232Manager(str(bp.link), timeout_s=0.2, lost_after_s=0.5, cyclic=True)
    order: list[str] = []
    try:
        urb.add_bus_manager(m)
        imu = urb.find_node("Imu", 0)
        m.add_lost_listener(lambda mgr, why: order.append("lost"))
        pending = [imu.submit_request(imu.new_request().read(1)) for _ in range(3)]
        urb.close()  # drains: services until answered
        assert all(r.ok for r in pending)
        m.start()
        first = imu.submit_request(imu.new_request().read(1))
        service_until(urb, lambda: first.done)
        assert first.ok
        bp.kill()
        reqs: list[NodeRequest] = []
        end = time.monotonic() + 10
        while m.lost_reason is None:
            assert time.monotonic() < end, "the killed bridge was never declared lost"
            reqs.append(imu.submit_request(imu.new_request().read(1).set_callback(lambda r: order.append("cb"))))
            tick(urb, 5)
        service_until(urb, lambda: all(r.done for r in reqs))
        assert ErrorFlag.BRIDGE_LOST in {r.flags for r in reqs}
        assert {r.flags for r in reqs} <= {ErrorFlag.BRIDGE_LOST, ErrorFlag.UPLINK_TIMEOUT}
        assert order.count("lost") == 1
        assert threading.current_thread() is threading.main_thread()
    finally:
        urb.close()
