"""RS232Manager on the C core's pump (the serial port's I/O on a C thread, urb.managers.
_native_pump_rs232.c) against RS232Manager on the Python reader and writer threads (rs232.USE_PUMP
off), on the same scripts, each against its own fake bridge process on a pty (tests/host/fake_bridge.py).

What a caller observes that does not depend on the wall clock must be equal: per request, the
address, mailbox, direction, flags, bridge status, data, sequence number (the pump writes it to the
Python transfer when it hands the batch back), that it was sent before it completed and whether it
completed within its wait; then the manager's counters (stray bytes, late responses) and lost reason.
The scripts: traffic with bridge-reported errors, a node unplugged, host refusals, corrupted response
bytes (the hunt resynchronises), line noise while idle, a request lost on the line (its timeout), a
`urb.cycle.Cycle` of motor reads and writes (its items go to the C core at once, polled and with a
callback); a bridge process killed with requests in flight (read error or end of input); close while
requests are pending (every request ends in exactly one callback). The port's hand-over record is covered by the
pump and honoured by the next manager on the port; a failed write, a failed read, the end of input and
a port that takes nothing for pyserial's 1-s write timeout are worded as the Python threads word them
(`rs232.describe_io_error` of pyserial's exceptions).

Seeded bugs (`test_a_seeded_bug_in_the_rs232_pump_is_caught`): the extension compiled with an RS232
pump that never writes what it sent back to the Python transfers, one that never applies the core's
timeouts, one that words the loss of the port differently, and one that waits a minute on a port that
takes nothing, must each fail a comparison;
`test_the_scripts_reach_the_rs232_pump` is the witness that the pump ran (no Python I/O thread, the C
thread alive, every 4-bit sequence number handed back).
"""

from __future__ import annotations

import errno
import os
import select
import socket
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
import serial

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "tests" / "host"))

from bridge_proc import BridgeProc, fake_bridge  # noqa: E402,F401 (fixture)
from native_support import build_native_mutant, reads_carry_every_seq, sensorhex_cycle  # noqa: E402
from urb_msgs import sensorhex as sx  # noqa: E402
from urb.api import NodeRequest, URBInterface  # noqa: E402
from urb.cycle import Cycle  # noqa: E402
from urb.errors import ErrorFlag  # noqa: E402
from urb.managers import RS232Manager, native, rs232  # noqa: E402
from urb.managers.base import CLOSED_REASON, Transfer  # noqa: E402
from urb.managers.handover import PortHandover  # noqa: E402
from urb.managers.rs232_core import Rs232Core  # noqa: E402

NODES = ["MotorDriver:0@16", "MotorDriver:1@17", "MotorDriver:2@18", "Imu:0@48"]
TIMEOUT_S, LOST_AFTER_S = 2.0, 5.0
"""The managers' timeouts: long enough that a loaded machine starving the fake bridge process does not
time out a request in one run and not in the other (only the request dropped on the line times out)."""
Observed = tuple[Any, ...]
MakeBridge = Callable[..., BridgeProc]
MakeCore = Callable[[], Rs232Core]


@pytest.fixture(scope="module", autouse=True)
def c_core_in_use() -> None:
    if native.BACKEND != "c":
        pytest.fail(f"the Python library runs its Python cores ({native.REASON}): build urb.managers._native with "
                    "`make host-c-py` (make test-py does) and do not set URB_PURE_PYTHON")


@pytest.fixture
def use_pump() -> Iterator[Callable[[bool], None]]:
    """Sets rs232.USE_PUMP for the managers started next; restored after the test."""
    def choose(on: bool) -> None:
        rs232.USE_PUMP = on

    yield choose
    rs232.USE_PUMP = True


def observe(r: NodeRequest, in_time: bool = True) -> Observed:
    t = r._transfer
    assert t is not None
    sent_first = t.sent_ns is not None and t.completed_ns is not None and t.sent_ns <= t.completed_ns
    return (t.address, t.mailbox, t.read, t.done, t.flags, t.status, t.response, t.seq, sent_first or t.seq == -1,
            in_time)


def open_manager(bp: BridgeProc, core: MakeCore | None, **opts: Any) -> tuple[URBInterface, RS232Manager]:
    """A manager on the bridge's port (its core replaced by `core()`, a seeded bug's, when given), with
    discovery done."""
    urb = URBInterface()
    m = RS232Manager(str(bp.link), **({"timeout_s": TIMEOUT_S, "lost_after_s": LOST_AFTER_S} | opts))
    if core is not None:
        m._core = m._rs = core()
        m._has_completed = getattr(m._core, "_has_completed", None)
    urb.add_bus_manager(m)
    return urb, m


def traffic_script(bp: BridgeProc, core: MakeCore | None = None) -> dict[str, Any]:
    urb, m = open_manager(bp, core)
    try:
        pumped = m._pumped
        motors = [urb.find_node("MotorDriver", i) for i in range(3)]
        observed: list[Observed] = []

        def run(reqs: list[NodeRequest], wait_s: float = 10.0) -> None:
            observed.extend(observe(r, r.wait(wait_s)) for r in reqs)

        for cycle in range(20):  # the SensoRHex motor load, an IMU read and host refusals
            run(sensorhex_cycle(urb, cycle, imu_every=5))
        for status in ("TIMEOUT", "CHECKSUM", "BUS_STUCK"):  # bridge-reported errors
            bp.cmd(f"fault 16 {status}")
            run([motors[0].submit_request(motors[0].new_request().read(1))])
        bp.cmd("unplug 18")  # NO_NODE
        run([node.submit_request(node.new_request().read(1)) for node in motors])
        bp.cmd("plug 18")
        for index in (0, 3, 7):  # a corrupted header, data and check byte: the hunt resynchronises
            bp.cmd(f"corrupt {index} 0x10")
            run([motors[0].submit_request(motors[0].new_request().read(1)) for _ in range(6)])
        bp.cmd("garbage 00ff13a5")  # line noise while nothing is pending
        time.sleep(0.05)
        run([motors[1].submit_request(motors[1].new_request().read(1))])
        bp.cmd("drop 1")  # a request lost on the line: its timeout, the pump's poll
        run([motors[2].submit_request(motors[2].new_request().read(1))], wait_s=4 * TIMEOUT_S)
        run([motors[2].submit_request(motors[2].new_request().read(1)) for _ in range(3)])
        cycle = Cycle()  # urb.cycle: the items go to the C core at once, as a CycleState
        feedback = [cycle.read(node, sx.MotorFeedback) for node in motors]
        command = [cycle.write(node, sx.MotorCommand) for node in motors]
        ticks: list[Cycle] = []
        cycles: list[Observed] = []
        for tick in range(6):
            for k, item in enumerate(command):
                item.set(sx.MotorCommand(voltage=tick * 10 + k))
            cycle.set_callback(ticks.append if tick % 2 else None)  # with a callback, and polled
            assert cycle.submit().wait(10)
            cycles.extend((i.flags, i.status, i.data, i.seq) for i in (*feedback, *command))
        cycles.append(("cycle callbacks", len(ticks)))
        stats = (m.stats.submitted, m.stats.completed, m.stats.failed, m.stats.stray_bytes, m.stats.late_responses)
        return {"requests": observed, "cycles": cycles, "stats": stats, "pumped": pumped, "reason": m.lost_reason}
    finally:
        urb.close()


def killed_script(bp: BridgeProc, core: MakeCore | None = None) -> dict[str, Any]:
    """The bridge process dies with requests in flight (a stretched node holds them), then more are
    submitted; every request ends in exactly one callback."""
    urb, m = open_manager(bp, core)
    try:
        motor = urb.find_node("MotorDriver", 0)
        calls: list[int] = []
        bp.cmd("stretch 16 5000")

        def submit() -> NodeRequest:
            req = motor.new_request().read(1)
            req.set_callback(lambda r: calls.append(id(r)))
            return motor.submit_request(req)

        pending = [submit() for _ in range(5)]
        time.sleep(0.1)
        bp.kill()
        after = [submit() for _ in range(3)]
        assert all(r.wait(10) for r in pending + after)
        time.sleep(0.05)
        port = str(bp.link)
        lost = [(r.flags, (r._transfer.lost_reason or "").replace(port, "<port>")) for r in pending + after
                if r._transfer is not None]
        once = sorted(calls) == sorted(id(r) for r in pending + after)
        return {"lost": lost, "once": once, "reason": (m.lost_reason or "").replace(port, "<port>"),
                "pumped": m._pumped}
    finally:
        urb.close()


def closed_script(bp: BridgeProc, core: MakeCore | None = None) -> dict[str, Any]:
    """close(drain=False) with requests in flight and queued: each ends in exactly one callback, and so
    does one submitted after the close (inside submit_request)."""
    urb, m = open_manager(bp, core)
    motor = urb.find_node("MotorDriver", 1)
    calls: list[tuple[int, ErrorFlag, str | None]] = []
    bp.cmd("stretch 17 5000")
    reqs = []
    for _ in range(12):  # the window (the bridge's FIFO depth, 8) in flight, the rest queued
        req = motor.new_request().read(1)
        req.set_callback(lambda r: calls.append((id(r), r.flags, r._transfer.lost_reason if r._transfer else None)))
        reqs.append(motor.submit_request(req))
    time.sleep(0.1)
    m.close(drain=False)
    late = motor.new_request().read(1)
    late.set_callback(lambda r: calls.append((id(r), r.flags, r._transfer.lost_reason if r._transfer else None)))
    motor.submit_request(late)
    time.sleep(0.05)
    urb.close()
    by_request = {i: [c for c in calls if c[0] == id(r)] for i, r in enumerate([*reqs, late])}
    return {"calls": {i: [(f, why) for _, f, why in cs] for i, cs in by_request.items()}, "pumped": m._pumped}


SCRIPTS = {"traffic": traffic_script, "killed": killed_script, "closed": closed_script}


def run_both(make: MakeBridge, use_pump: Callable[[bool], None], script: str,
             mutant: MakeCore | None = None) -> tuple[dict[str, Any], dict[str, Any]]:
    """The script on the pump (with `mutant`'s core when given) and on the Python threads, each against
    a bridge process of its own."""
    out = []
    for pump in (True, False):
        use_pump(pump)
        bp = make(nodes=NODES, name=f"ttyPUMP{int(pump)}")
        try:
            out.append(SCRIPTS[script](bp, mutant if pump else None))
        finally:
            bp.close()
    on_pump, on_threads = out
    assert on_pump["pumped"] and not on_threads["pumped"]
    return on_pump, on_threads


# lobster-trace: urb.HOST_002, urb.FLT_006
def test_the_rs232_pump_matches_the_threads(fake_bridge: MakeBridge, use_pump: Callable[[bool], None]) -> None:
    on_pump, on_threads = run_both(fake_bridge, use_pump, "traffic")
    assert on_pump["requests"] == on_threads["requests"], "the requests' outcomes differ"
    assert on_pump["cycles"] == on_threads["cycles"], "the cycle items' outcomes differ"
    assert on_pump["stats"] == on_threads["stats"], "the manager's counters differ"
    assert on_pump["cycles"][-1] == ("cycle callbacks", 3) and {o[0] for o in on_pump["cycles"][:-1]} == {ErrorFlag.NONE}
    assert on_pump["reason"] is None and on_threads["reason"] is None
    flags = {o[4] for o in on_pump["requests"]}
    assert flags == {ErrorFlag.NONE, ErrorFlag.HOST_SIZE_MISMATCH, ErrorFlag.TIMEOUT, ErrorFlag.CHECKSUM,
                     ErrorFlag.BUS_STUCK, ErrorFlag.NO_NODE, ErrorFlag.UPLINK_CHECKSUM, ErrorFlag.UPLINK_TIMEOUT}
    assert on_pump["stats"][3] > 0  # what the script reaches: stray bytes hunted past
    assert all(o[-1] for o in on_pump["requests"])


# lobster-trace: urb.FLT_004, urb.HOST_001
def test_a_killed_bridge_is_lost_alike(fake_bridge: MakeBridge, use_pump: Callable[[bool], None]) -> None:
    on_pump, on_threads = run_both(fake_bridge, use_pump, "killed")
    assert on_pump["lost"] == on_threads["lost"] and on_pump["reason"] == on_threads["reason"]
    assert on_pump["once"] and on_threads["once"]
    unplugged = "<port>: I/O error: the device was unplugged, or the bridge process ended"
    assert on_pump["reason"] == unplugged
    assert on_pump["lost"] == [(ErrorFlag.BRIDGE_LOST, unplugged)] * 8


# lobster-trace: urb.HOST_001
def test_close_with_requests_pending_ends_each_once(fake_bridge: MakeBridge, use_pump: Callable[[bool], None]) -> None:
    on_pump, on_threads = run_both(fake_bridge, use_pump, "closed")
    assert on_pump["calls"] == on_threads["calls"]
    assert all(calls == [(ErrorFlag.BRIDGE_LOST, CLOSED_REASON)] for calls in on_pump["calls"].values())
    assert len(on_pump["calls"]) == 13


def test_the_scripts_reach_the_rs232_pump(fake_bridge: MakeBridge) -> None:
    """Witness: on the pump no Python I/O thread runs, the C thread does, and the transfers it sent got
    their sequence numbers when the dispatcher handed their batch back."""
    before = set(threading.enumerate())
    bp = fake_bridge(nodes=NODES, name="ttyWITNESS")
    urb, m = open_manager(bp, None)
    try:
        assert m._pumped and m._rs._pump_running()  # type: ignore[attr-defined]
        ours = [t.name for t in threading.enumerate() if t not in before]
        assert [n for n in ours if n.startswith("urb-")] == [f"urb-dispatch {bp.link}"]
        comms = {(task / "comm").read_text().strip() for task in Path("/proc/self/task").iterdir()}
        assert "urb-pump" in comms
        reads_carry_every_seq(urb)
    finally:
        urb.close()
    assert not m._rs._pump_running()  # type: ignore[attr-defined]


# lobster-trace: urb.HOST_006
def test_the_rs232_pump_covers_and_honours_the_handover_record(fake_bridge: MakeBridge) -> None:
    """The pump makes the port's record cover the requests in flight before it writes them (on the
    pump, the Python threads' `_note_sending` does not run); a manager that ends without a draining
    close leaves the record, and the next manager on the port sends nothing before its instant."""
    bp = fake_bridge(nodes=NODES, name="ttyHANDOVER")
    record = PortHandover(str(bp.link))
    assert not record.path.exists()
    urb, m = open_manager(bp, None)
    assert m._pumped
    covered = record.predecessor_until(time.monotonic_ns())  # discovery's requests went out: the pump wrote it
    assert covered is not None and covered > time.monotonic_ns()
    motor = urb.find_node("MotorDriver", 0)
    bp.cmd("stretch 16 500")  # answered within its lifetime, after the close
    held = motor.submit_request(motor.new_request().read(1))
    time.sleep(0.05)
    m.close(drain=False)
    urb.close()
    assert held.done and held.flags == ErrorFlag.BRIDGE_LOST
    bp.cmd("stretch 16 0")
    until = record.predecessor_until(time.monotonic_ns())
    assert until is not None and until > time.monotonic_ns()
    urb2, m2 = open_manager(bp, None)  # discovery's requests wait for the hand-over's instant
    try:
        assert m2._pumped and time.monotonic_ns() >= until
        again = urb2.find_node("MotorDriver", 0)
        req = again.submit_request(again.new_request().read(1))
        assert req.wait(10) and req.ok
    finally:
        urb2.close()


def test_a_failed_write_a_failed_read_and_the_end_of_input_are_worded_as_the_threads_word_them() -> None:
    """The pump on a socket pair: the far end stops reading (the write fails, EPIPE); closes with a
    request frame unread (the read fails, ECONNRESET); closes (the read sees the end of input). The
    reasons are what `rs232.describe_io_error` makes of the exceptions pyserial and os.read raise."""
    def reason_of(make: Callable[[], BaseException]) -> str:
        try:
            raise make()
        except (OSError, serial.SerialException) as exc:
            return f"far: {rs232.describe_io_error(exc)}"

    def write_failed() -> BaseException:
        try:
            raise OSError(errno.EPIPE, os.strerror(errno.EPIPE))
        except OSError as e:  # pyserial: raise SerialException('write failed: {}'.format(e)) inside the handler
            return serial.SerialException(f"write failed: {e}")

    expected = {
        "write": reason_of(write_failed),
        "read": reason_of(lambda: ConnectionResetError(errno.ECONNRESET, os.strerror(errno.ECONNRESET))),
        "eof": reason_of(lambda: serial.SerialException("device reports readiness to read but returned no data "
                                                        "(device disconnected or multiple access on port?)")),
    }
    for case, reason in expected.items():
        host, far = socket.socketpair(socket.AF_UNIX, socket.SOCK_STREAM)
        core = native.new_rs232_core(timeout_ns=10**10, lost_after_ns=3 * 10**10)
        core._pump_start(host.fileno(), "far", 0, None, None)  # type: ignore[attr-defined]
        try:
            if case == "write":
                far.shutdown(socket.SHUT_RD)
            if case != "eof":
                core.submit(Transfer(address=16, mailbox=1, read=True, length=6), time.monotonic_ns())
                core._pump_notify()  # type: ignore[attr-defined]
            if case == "read":
                assert select.select([far], [], [], 10)[0]  # the frame arrived, left unread
            if case != "write":
                far.close()
            deadline = time.monotonic() + 10
            while core._pump_running() and time.monotonic() < deadline:  # type: ignore[attr-defined]
                time.sleep(0.005)
            assert core.lost_reason == reason, case
        finally:
            core._pump_stop()  # type: ignore[attr-defined]
            host.close()
            far.close()
    assert expected["write"] == f"far: write failed: [Errno {errno.EPIPE}] {os.strerror(errno.EPIPE)}"
    assert expected["read"] == f"far: [Errno {errno.ECONNRESET}] {os.strerror(errno.ECONNRESET)}"


def stalled_port_reason(make_core: Callable[[], Any], wait_s: float) -> str | None:
    """The pump on a socket pair whose far end never reads, with the port's buffer already full: the
    frame of a submitted request cannot go out. What the bridge was declared lost with after `wait_s`
    (None: still running)."""
    host, far = socket.socketpair(socket.AF_UNIX, socket.SOCK_STREAM)
    host.setblocking(False)
    try:
        while True:
            host.send(b"\0" * 4096)
    except BlockingIOError:
        pass
    core = make_core()
    core._pump_start(host.fileno(), "far", 0, None, None)
    try:
        core.submit(Transfer(address=16, mailbox=1, read=True, length=6), time.monotonic_ns())
        core._pump_notify()
        deadline = time.monotonic() + wait_s
        while core._pump_running() and time.monotonic() < deadline:
            time.sleep(0.005)
        return None if core._pump_running() else str(core.lost_reason)
    finally:
        far.close()  # a pump still waiting to write sees the end of the pair and stops
        core._pump_stop()
        host.close()


STALL_WAIT_S = 6.0
"""How long a test waits for the pump to give up on a port that takes nothing: its write timeout (1 s,
pyserial's write_timeout that rs232.open_serial sets), with room for a loaded machine."""


def test_a_port_that_takes_nothing_for_the_write_timeout_loses_the_bridge_as_the_threads_do() -> None:
    """pyserial's Serial.write gives up on a port that takes no byte for its write_timeout with
    SerialTimeoutException('Write timeout'); the pump gives up after the same time with the same words."""
    expected = f"far: {rs232.describe_io_error(serial.SerialTimeoutException('Write timeout'))}"
    start = time.monotonic()
    reason = stalled_port_reason(lambda: native.new_rs232_core(timeout_ns=10**10, lost_after_ns=3 * 10**10),
                                 STALL_WAIT_S)
    assert reason == expected
    assert time.monotonic() - start >= 1.0  # not before the write timeout


PUMP_MUTANTS = {
    "rs232-forgets-sent": ("        native_pump_note_sent(self, head, self->core.m.count - 1u); /* the newest slot */\n",
                           "        (void)head;\n", "traffic"),
    "rs232-no-timeouts": ("    (void)urb_core_poll(&self->core, now);\n", "\n", "traffic"),
    "rs232-unplugged-text": ('#define UNPLUGGED_TEXT "I/O error: the device was unplugged, or the bridge process ended"',
                             '#define UNPLUGGED_TEXT "I/O error"', "killed"),
    "rs232-write-waits-forever": ("#define WRITE_TIMEOUT_NS (1000LL * 1000LL * 1000LL)",
                                  "#define WRITE_TIMEOUT_NS (60LL * 1000LL * 1000LL * 1000LL)", "stalled"),
}
"""Seeded bugs of _native_pump_rs232.c, and the script that must catch each: what it sent never
reaches the Python transfer; the core's timeouts never applied (a request lost on the line completes
only when a later response passes it); the loss of the port worded otherwise than the threads word it."""


def build_pump_mutant(tmp: Path, name: str) -> Any:
    """The extension compiled with the seeded bug `name` in _native_pump_rs232.c, loaded as its own module."""
    old, new, _ = PUMP_MUTANTS[name]
    return build_native_mutant(tmp, "_native_pump_rs232.c", old, new)


def mutant_core(module: Any) -> MakeCore:
    class MutantRs232Core(module.Core, Rs232Core):  # type: ignore[misc,name-defined]
        pass

    def make() -> Rs232Core:
        core = MutantRs232Core.__new__(MutantRs232Core)
        native.NativeRs232Core.__init__(core, timeout_ns=int(TIMEOUT_S * 1e9),  # type: ignore[arg-type]
                                        lost_after_ns=int(LOST_AFTER_S * 1e9))
        return core

    return make


@pytest.mark.parametrize("name", sorted(PUMP_MUTANTS))
def test_a_seeded_bug_in_the_rs232_pump_is_caught(fake_bridge: MakeBridge, use_pump: Callable[[bool], None],
                                                  tmp_path: Path, name: str) -> None:
    make = mutant_core(build_pump_mutant(tmp_path, name))
    script = PUMP_MUTANTS[name][2]
    if script == "stalled":
        assert stalled_port_reason(make, STALL_WAIT_S) is None  # still waiting where the threads gave up
        return
    on_mutant, on_threads = run_both(fake_bridge, use_pump, script, mutant=make)
    if script == "traffic":
        assert (on_mutant["requests"], on_mutant["cycles"], on_mutant["stats"]) != (
            on_threads["requests"], on_threads["cycles"], on_threads["stats"])
    else:
        assert (on_mutant["lost"], on_mutant["reason"]) != (on_threads["lost"], on_threads["reason"])
