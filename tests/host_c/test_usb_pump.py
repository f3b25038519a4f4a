"""USBManager on the C core's pump (the uplink's I/O on a C thread, urb.managers._native_pump.c)
against USBManager on the Python frame and reader threads (usb.USE_PUMP off), on the same script.

The same script of requests (discovery, reads and writes of three motor drivers and an IMU, host
refusals) runs against the same bridge model behind a SOCK_SEQPACKET pair, once on each runtime;
everything a caller observes that does not depend on the wall clock must be equal: per request,
the address, mailbox, direction, flags, bridge status, data, sequence number (the pump writes it
to the Python transfer when it hands the batch back), and that it was sent before it completed;
then the manager's counters. A bridge unplugged mid-run must be found lost on both with the same
reason (the failed write's errno text), and so must a descriptor closed under the manager (the pump
at once, by POLLNVAL; the threads at their next write). The pump's hand-over record is checked
against the Python library's reader of it.

Seeded bugs: the extension compiled with a pump that never writes what it sent back to the Python
transfers, with one that words a failed write's reason differently, and with one that ignores a
closed descriptor, must each fail the comparison (`test_a_seeded_bug_in_the_pump_is_caught`); `test_the_scripts_reach_the_pump` is the
witness that the pump ran (no Python I/O thread, completions handed back in batches).
"""

from __future__ import annotations

import errno
import os
import socket
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "tests" / "host"))

from bridge_proc import serve_usb_transfers  # noqa: E402
from native_support import build_native_mutant, reads_carry_every_seq, sensorhex_cycle  # noqa: E402
from urb.api import NodeRequest, URBInterface  # noqa: E402
from urb.errors import ErrorFlag  # noqa: E402
from urb.managers import BridgeModel, CharDeviceTransport, USBManager, fake_node, native, usb  # noqa: E402
from urb.managers.handover import PortHandover  # noqa: E402
from urb.managers.usb_core import FRAME_NS, UsbCore  # noqa: E402
from urb_msgs import sensorhex as sx  # noqa: E402

NODES = ["MotorDriver:0@16", "MotorDriver:1@17", "MotorDriver:2@18", "Imu:0@48"]
Observed = tuple[Any, ...]


@pytest.fixture(scope="module", autouse=True)
def c_core_in_use() -> None:
    if native.BACKEND != "c":
        pytest.fail(f"the Python library runs its Python cores ({native.REASON}): build urb.managers._native with "
                    "`make host-c-py` (make test-py does) and do not set URB_PURE_PYTHON")


class Bridge:
    """The bridge model at the far end of a SOCK_SEQPACKET pair, served by a thread."""

    def __init__(self) -> None:
        self.host_sock, self.dev_sock = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        model = BridgeModel(dict(fake_node(s) for s in NODES), fifo_depth=15)
        self.thread = threading.Thread(target=serve_usb_transfers, args=(self.dev_sock, model), daemon=True)
        self.thread.start()

    def unplug(self) -> None:
        self.dev_sock.shutdown(socket.SHUT_RDWR)
        self.dev_sock.close()

    def close(self) -> None:
        self.host_sock.close()
        self.thread.join(2.0)


def observe(r: NodeRequest) -> Observed:
    t = r._transfer
    assert t is not None and t.done
    sent_first = t.sent_ns is not None and t.completed_ns is not None and t.sent_ns <= t.completed_ns
    return (t.address, t.mailbox, t.read, t.flags, t.status, t.response, t.seq, sent_first or t.seq == -1)


def run_script(pump: bool, core: UsbCore | None = None, unplug: bool = False) -> dict[str, Any]:
    """The script on one runtime (the pump when `pump`); `core` replaces the manager's core (a
    seeded bug's). Returns what a caller observes."""
    far = Bridge()
    usb.USE_PUMP = pump
    urb = URBInterface()
    try:
        # Long timeouts: the bridge model is a thread of this process, which a loaded machine starves;
        # the loss below comes from the failed write, at once.
        m = USBManager(CharDeviceTransport(fd=os.dup(far.host_sock.fileno())), timeout_s=10.0, lost_after_s=30.0,
                       name="usb-script")
        if core is not None:
            m._core = m._usb = core
            m._has_completed = getattr(core, "_has_completed", None)
        urb.add_bus_manager(m)
        pumped = m._pumped
        motors = [urb.find_node("MotorDriver", i) for i in range(3)]
        reqs: list[NodeRequest] = []
        for cycle in range(40):  # 40 ms of the SensoRHex motor load, plus an IMU read and refusals
            reqs += sensorhex_cycle(urb, cycle, imu_every=10)
            time.sleep(0.001)
        assert all(r.wait(30) for r in reqs)
        lost: list[Observed] = []
        if unplug:
            far.unplug()
            after = [motors[0].submit_request(motors[0].new_request().read_message(sx.MotorFeedback))
                     for _ in range(3)]
            assert all(r.wait(30) for r in after)
            lost = [(r.flags, r._transfer.lost_reason if r._transfer else None) for r in after]
        stats = (m.stats.submitted, m.stats.completed, m.stats.failed, m.stats.stray_bytes, m.stats.late_responses)
        return {"requests": [observe(r) for r in reqs], "stats": stats, "lost": lost, "pumped": pumped,
                "reason": m.lost_reason}
    finally:
        usb.USE_PUMP = True
        urb.close()
        far.close()


def test_the_pump_matches_the_threads() -> None:
    on_pump, on_threads = run_script(True), run_script(False)
    assert on_pump["pumped"] and not on_threads["pumped"]
    assert on_pump["requests"] == on_threads["requests"], "the requests' outcomes differ"
    assert on_pump["stats"] == on_threads["stats"], "the manager's counters differ"
    flags = {o[3] for o in on_pump["requests"]}
    assert flags == {ErrorFlag.NONE, ErrorFlag.HOST_SIZE_MISMATCH}  # what the script reaches


def test_an_unplugged_bridge_is_lost_alike() -> None:
    on_pump, on_threads = run_script(True, unplug=True), run_script(False, unplug=True)
    assert on_pump["lost"] == on_threads["lost"], "the loss differs"
    assert on_pump["reason"] == on_threads["reason"]
    assert all(f == ErrorFlag.BRIDGE_LOST for f, _ in on_pump["lost"])
    assert on_pump["reason"] is not None and "usb-script: [Errno" in on_pump["reason"]


def test_the_scripts_reach_the_pump() -> None:
    """Witness: on the pump no Python I/O thread runs, the C thread does, and the transfers it sent
    got their sequence numbers when the dispatcher handed their batch back."""
    before = set(threading.enumerate())
    far = Bridge()
    urb = URBInterface()
    try:
        m = USBManager(CharDeviceTransport(fd=os.dup(far.host_sock.fileno())), timeout_s=10.0, lost_after_s=30.0,
                       name="usb-witness")
        urb.add_bus_manager(m)
        assert m._pumped and m._usb._pump_running()  # type: ignore[attr-defined]
        ours = [t.name for t in threading.enumerate() if t not in before]
        assert [n for n in ours if n.startswith("urb-")] == ["urb-dispatch usb-witness"]
        reads_carry_every_seq(urb)
    finally:
        urb.close()
        far.close()
    assert not m._usb._pump_running()  # type: ignore[attr-defined]


def test_the_pump_covers_the_handover_record(tmp_path: Path) -> None:
    """Before a write the pump makes the port's record cover the requests in flight, in the format
    the Python library reads (PortHandover.predecessor_until)."""
    far = Bridge()
    core = native.new_usb_core(timeout_ns=10**9)
    port = str(tmp_path / "urb-usb7")
    record = PortHandover(port, tmp_path)
    assert not record.path.exists()
    core._pump_start(far.host_sock.fileno(), "usb7", FRAME_NS, port, str(tmp_path))  # type: ignore[attr-defined]
    try:
        from urb.managers.base import Transfer

        core.submit(Transfer(address=16, mailbox=1, read=True, length=6), time.monotonic_ns())
        deadline = time.monotonic() + 10
        while not record.path.exists() and time.monotonic() < deadline:
            time.sleep(0.005)
        now = time.monotonic_ns()
        until = record.predecessor_until(now)
        assert until is not None and until > now
    finally:
        core._pump_stop()  # type: ignore[attr-defined]
        far.close()


CLOSED_FD = 900
"""The number the closed-descriptor script gives the manager's descriptor: far above those the test
process holds, so that nothing opened meanwhile takes the closed number over."""


def closed_script(pump: bool, core: UsbCore | None = None) -> dict[str, Any]:
    """The manager's descriptor is closed under it while it is idle (POLLNVAL for a poller), then a
    read is submitted. Returns whether the pump's thread ended by itself before that read (None on
    the Python threads, which find the loss at their next write), the read's flags and lost reason,
    and the manager's lost reason."""
    far = Bridge()
    usb.USE_PUMP = pump
    urb = URBInterface()
    try:
        fd = os.dup2(far.host_sock.fileno(), CLOSED_FD)
        m = USBManager(CharDeviceTransport(fd=fd), timeout_s=10.0, lost_after_s=30.0, name="usb-closed")
        if core is not None:
            m._core = m._usb = core
            m._has_completed = getattr(core, "_has_completed", None)
        urb.add_bus_manager(m)
        motor = urb.find_node("MotorDriver", 0)
        first = motor.submit_request(motor.new_request().read_message(sx.MotorFeedback))
        assert first.wait(30) and first.ok  # witness: the descriptor carried traffic before it was closed
        os.close(fd)
        ended_alone = None
        if pump:
            deadline = time.monotonic() + 5
            while m._usb._pump_running() and time.monotonic() < deadline:  # type: ignore[attr-defined]
                time.sleep(0.005)
            ended_alone = not m._usb._pump_running()  # type: ignore[attr-defined]
        after = motor.submit_request(motor.new_request().read_message(sx.MotorFeedback))
        assert after.wait(30)
        t = after._transfer
        return {"ended_alone": ended_alone, "flags": after.flags, "lost": t.lost_reason if t else None,
                "reason": m.lost_reason}
    finally:
        usb.USE_PUMP = True
        urb.close()
        far.close()


def closed_lost(ended_alone: bool | None) -> dict[str, Any]:
    """What closed_script must return: the read and the manager lost with the reason the Python
    writer thread gives when its write fails on the closed descriptor (EBADF)."""
    reason = f"usb-closed: [Errno {errno.EBADF}] {os.strerror(errno.EBADF)}"
    return {"ended_alone": ended_alone, "flags": ErrorFlag.BRIDGE_LOST, "lost": reason, "reason": reason}


def test_a_closed_descriptor_is_lost_alike() -> None:
    """A descriptor closed under the pump (POLLNVAL) ends its thread at once, the bridge lost with
    the reason the Python threads give at their next write."""
    assert closed_script(False) == closed_lost(None)
    assert closed_script(True) == closed_lost(True)


PUMP_MUTANTS = {
    "pump-forgets-sent": ("    x->sent_unmarked = true;\n", "\n"),
    "pump-reason-text": ('native_pump_lost(self, "[Errno %d] %s", code, strerror(code))',
                         'native_pump_lost(self, "%s", strerror(code))'),
    "pump-ignores-closed": ("    if ((revents & POLLNVAL) == 0) {\n", "    if ((revents & 0) == 0) {\n"),
}
"""Seeded bugs of _native_pump.c: what it sent never reaches the Python transfer; a failed write's
reason worded otherwise than the Python runtime words it; a closed descriptor ignored (the thread
spins on POLLNVAL until a write fails)."""


def build_pump_mutant(tmp: Path, name: str) -> Any:
    """The extension compiled with the seeded bug `name` in _native_pump.c, loaded as its own module."""
    return build_native_mutant(tmp, "_native_pump.c", *PUMP_MUTANTS[name])


def mutant_core(module: Any) -> Callable[[], UsbCore]:
    class MutantUsbCore(module.Core, UsbCore):  # type: ignore[misc,name-defined]
        pass

    def make() -> UsbCore:
        core = MutantUsbCore.__new__(MutantUsbCore)
        native.NativeUsbCore.__init__(core, timeout_ns=10 * 10**9, lost_after_ns=30 * 10**9)  # type: ignore[arg-type]
        return core

    return make


@pytest.mark.parametrize("name", sorted(PUMP_MUTANTS))
def test_a_seeded_bug_in_the_pump_is_caught(tmp_path: Path, name: str) -> None:
    make = mutant_core(build_pump_mutant(tmp_path, name))
    if name == "pump-ignores-closed":
        assert closed_script(True, core=make()) != closed_lost(True)
        return
    unplug = name == "pump-reason-text"
    on_threads = run_script(False, unplug=unplug)
    on_mutant = run_script(True, core=make(), unplug=unplug)
    assert on_mutant["pumped"]
    assert (on_mutant["requests"], on_mutant["lost"]) != (on_threads["requests"], on_threads["lost"])
