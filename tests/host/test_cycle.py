"""urb.cycle.Cycle (a control tick's requests submitted together) on both protocol cores.

The same scripts (virtual time: SimManager over the loopback RS232 line and USB pipe, with lost
requests, a corrupt response, an absent node, a node no longer discovered, a size the schema does
not give, a pulled cable and a close) run through the cycle API on the Python reference core (its
items submitted one by one) and on the C core (`_native_cycle.c`: one `_cycle_submit` per tick),
and through the per-request API (`NodeRequest`) on the reference core: everything a caller observes
per item (flags, bridge status, data, sequence number, sending and completion times, lost reason)
must be equal, and so must the manager's and the nodes' counters. A real-time run (USBManager over
a SOCK_SEQPACKET pair: the C core's pump, whose dispatcher a polled cycle does not wake) is compared
the same way. Seeded bugs of `_native_cycle.c` must each fail the comparison
(`test_a_seeded_bug_in_the_cycle_state_is_caught`); the witness that the C path ran is the group
kind each test asserts.
"""

from __future__ import annotations

import os
import socket
import sys
import threading
from pathlib import Path
from typing import Any

import pytest

from urb.api import URBInterface
from urb.cycle import Cycle, CycleBusy, CycleItem
from urb.errors import ErrorFlag
from urb.managers import (
    BridgeModel,
    CharDeviceTransport,
    LoopbackByteTransport,
    LoopbackFrameTransport,
    SimManager,
    USBManager,
    VirtualClock,
    fake_node,
    native,
    rs232_core,
    usb_core,
)
from urb.managers.base import BLOCKING_IN_CALLBACK, NS_PER_MS
from urb_msgs import sensorhex as sx

REPO = Path(__file__).resolve().parents[2]
NODES = ["MotorDriver:0@16", "MotorDriver:1@17", "MotorDriver:2@18", "Imu:0@48"]
CORES = ["python", "c"]
Observed = tuple[Any, ...]


def new_core(kind: str, core: str, module: Any = None) -> Any:
    """The protocol core `core` ("python": the reference, "c": the C core, or `module`'s C core: a
    seeded bug's) for a SimManager of `kind`."""
    if core == "python":
        return rs232_core.Rs232Core() if kind == "rs232" else usb_core.UsbCore()
    if native.BACKEND != "c":
        pytest.fail(f"the C core is not in use ({native.REASON}): build it with `make host-c-py`")
    if module is None:
        return native.NativeRs232Core() if kind == "rs232" else native.NativeUsbCore()
    ref = rs232_core.Rs232Core if kind == "rs232" else usb_core.UsbCore
    init = native.NativeRs232Core.__init__ if kind == "rs232" else native.NativeUsbCore.__init__
    mutant_cls = type("MutantCore", (module.Core, ref), {})
    obj = mutant_cls.__new__(mutant_cls)
    init(obj)
    return obj


def sim(kind: str, core: str, module: Any = None, clock: VirtualClock | None = None,
        urb: URBInterface | None = None) -> tuple[URBInterface, SimManager, Any, BridgeModel]:
    clock = clock or VirtualClock()
    bridge = BridgeModel(dict(fake_node(s) for s in NODES), timed_downlink=True)
    transport = LoopbackByteTransport(clock, bridge) if kind == "rs232" else LoopbackFrameTransport(clock, bridge)
    m = SimManager(clock, transport, name=f"sim-{kind}")
    if kind == "rs232":
        m._rs232_core = new_core(kind, core, module)
    else:
        m._usb_core = new_core(kind, core, module)
    urb = urb or URBInterface()
    urb.add_bus_manager(m)
    return urb, m, transport, bridge


def observe(item: CycleItem) -> Observed:
    return (item.node.label, item.mailbox, item.is_read, item.flags, item.status, item.data, item.seq,
            item.sent_ns, item.completed_ns, item.error)


def observe_request(req: Any) -> Observed:
    t = req._transfer
    return (req.node.label, req.mailbox, req.is_read, req.flags, req.status, req.data, t.seq, t.sent_ns,
            t.completed_ns, req.error)


def run_script(kind: str, api: str, core: str, module: Any = None) -> dict[str, Any]:
    """The fault script, through `api` ("cycle" or "request") on `core`. Returns what a caller sees."""
    urb, m, transport, bridge = sim(kind, core, module)
    clock = m.clock
    assert isinstance(clock, VirtualClock)
    motors = [urb.find_node("MotorDriver", i) for i in range(3)]
    imu = urb.find_node("Imu", 0)
    ticks: list[list[Observed]] = []
    callbacks: list[int] = []
    cycle = Cycle()
    spec: list[tuple[Any, str, Any]] = []
    for node in motors:
        spec.append((node, "read", sx.MotorFeedback))
        spec.append((node, "write", sx.MotorCommand))
    spec.append((imu, "read", sx.ImuSample))
    spec.append((imu, "raw", 3))  # outbox 1 holds 14 bytes: HOST_SIZE_MISMATCH every tick
    items: list[CycleItem] = []
    for node, what, arg in spec:
        if what == "read":
            items.append(cycle.read(node, arg))
        elif what == "write":
            items.append(cycle.write(node, arg))
        else:
            items.append(cycle.read(node, 1, size=arg))
    cycle.set_callback(lambda c: callbacks.append(m.now_ns()))
    for tick in range(14):
        if tick == 3 and kind == "rs232":
            transport.drop_requests(2)        # UPLINK_TIMEOUT
        if tick == 4 and kind == "rs232":
            transport.corrupt_response(1)     # UPLINK_CHECKSUM (or a timeout: the core decides)
        bridge.nodes[17].present = tick not in (5, 6)   # NO_NODE
        motors[2].record.active = tick != 7              # UNKNOWN_NODE, never sent
        if tick == 10 and kind == "rs232":
            transport.unplug()                # timeouts, then BRIDGE_LOST
        if tick == 12:
            m.close()                         # BRIDGE_LOST (closed by the application)
        payloads = [sx.MotorCommand(voltage=100 * tick + k) for k in range(3)]
        if api == "cycle":
            for k, item in enumerate(i for i in items if not i.is_read):
                item.set(payloads[k])
            cycle.submit()
            assert cycle.wait(2.0), f"tick {tick}: the cycle did not complete"
            assert cycle.done and not cycle.in_flight
            ticks.append([observe(i) for i in items])
        else:
            reqs = []
            k = 0
            for node, what, arg in spec:
                r = node.new_request()
                if what == "read":
                    r.read_message(arg)
                elif what == "write":
                    r.write_message(payloads[k])
                    k += 1
                else:
                    r.read(1, size=arg)
                reqs.append(node.submit_request(r))
            assert all(r.wait(2.0) for r in reqs)
            ticks.append([observe_request(r) for r in reqs])
        clock.run_for(5 * NS_PER_MS)
    stats = (m.stats.submitted, m.stats.completed, m.stats.failed)
    nodes = [(n.completed, n.failed) for n in [*motors, imu]]
    groups = [type(g).__name__ for g in cycle._groups]
    return {"ticks": ticks, "stats": stats, "nodes": nodes, "groups": groups, "callbacks": callbacks}


# lobster-trace: urb.HOST_001
@pytest.mark.parametrize("kind", ["rs232", "usb"])
def test_cycles_give_the_per_request_outcomes_on_both_cores(kind: str) -> None:
    on_python = run_script(kind, "cycle", "python")
    on_c = run_script(kind, "cycle", "c")
    per_request = run_script(kind, "request", "python")
    assert on_python["groups"] == ["_PythonGroup"] and on_c["groups"] == ["_NativeGroup"]  # both paths ran
    for tick, (a, b, r) in enumerate(zip(on_python["ticks"], on_c["ticks"], per_request["ticks"])):
        assert a == b, f"tick {tick}: the cores' outcomes differ"
        assert a == r, f"tick {tick}: the cycle's outcomes differ from the per-request API's"
    assert on_python["stats"] == on_c["stats"] == per_request["stats"]
    assert on_python["nodes"] == on_c["nodes"] == per_request["nodes"]
    assert on_python["callbacks"] == on_c["callbacks"] and len(on_c["callbacks"]) == 14
    # what the script reaches (the witnesses that the comparisons compare something)
    flags = {o[3] for t in on_c["ticks"] for o in t}
    wanted = {ErrorFlag.NONE, ErrorFlag.NO_NODE, ErrorFlag.UNKNOWN_NODE, ErrorFlag.HOST_SIZE_MISMATCH,
              ErrorFlag.BRIDGE_LOST}
    if kind == "rs232":
        wanted |= {ErrorFlag.UPLINK_TIMEOUT, ErrorFlag.UPLINK_CHECKSUM}
    assert wanted <= flags, f"never reached: {wanted - flags}"
    reason = "sent nothing for 500 ms" if kind == "rs232" else "closed by the application"  # the cable, the close
    assert all(reason in o[9] for o in on_c["ticks"][12][:7])


@pytest.mark.parametrize("core", CORES)
def test_a_cycle_in_flight_is_not_submitted_again_and_loses_nothing(core: str) -> None:
    urb, m, _, _ = sim("usb", core)
    motor = urb.find_node("MotorDriver", 0)
    cycle = Cycle().set_callback(lambda c: None)
    cycle.write(motor, sx.MotorCommand, sx.MotorCommand(voltage=7))  # before the read: the read sees it
    fb = cycle.read(motor, sx.MotorFeedback)
    before = m.stats.submitted
    cycle.submit()
    with pytest.raises(CycleBusy, match="still in flight .2 of 2 items pending"):
        cycle.submit()
    with pytest.raises(CycleBusy, match="mode changes"):
        cycle.set_callback(None)
    assert cycle.wait() and cycle.ok and fb.message().voltage == 7
    assert m.stats.submitted - before == 2 and m.stats.completed >= 2


@pytest.mark.parametrize("core", CORES)
def test_polled_cycles_complete_on_poll_wait_or_the_next_submit(core: str) -> None:
    urb, m, _, _ = sim("usb", core)
    clock = m.clock
    assert isinstance(clock, VirtualClock)
    motor = urb.find_node("MotorDriver", 1)
    cycle = Cycle()
    cmd = cycle.write(motor, sx.MotorCommand, sx.MotorCommand(voltage=3))
    fb = cycle.read(motor, sx.MotorFeedback)
    assert not cycle.poll()  # never submitted
    cycle.submit()
    assert not cycle.poll() and cycle.in_flight
    clock.run_for(5 * NS_PER_MS)
    assert cycle.poll() and cycle.done and cycle.ok and motor.completed >= 2
    cmd.set(sx.MotorCommand(voltage=9))
    cycle.submit()
    clock.run_for(5 * NS_PER_MS)
    cycle.submit()  # the previous submission is finished by this one's poll
    assert cycle.submissions == 3
    assert cycle.wait() and fb.message(sx.MotorFeedback).voltage == 9


@pytest.mark.parametrize("core", CORES)
def test_a_callback_may_submit_its_cycle_again(core: str) -> None:
    urb, m, _, _ = sim("rs232", core)
    motor = urb.find_node("MotorDriver", 2)
    seen: list[int] = []
    cycle = Cycle()
    fb = cycle.read(motor, sx.MotorFeedback)

    def again(c: Cycle) -> None:
        seen.append(fb.seq)
        with pytest.raises(RuntimeError, match="deadlock"):
            c.wait()  # blocking inside a callback
        if len(seen) < 3:
            c.submit()

    cycle.set_callback(again).submit()
    assert m.clock.run_until(lambda: cycle.done, 10**9)  # type: ignore[attr-defined]
    assert len(seen) == 3 and len(set(seen)) == 3 and cycle.submissions == 3 and not cycle.in_flight
    assert BLOCKING_IN_CALLBACK.startswith("a blocking URB call")


@pytest.mark.parametrize("core", CORES)
def test_bad_use_is_refused_with_what_to_do_and_submits_nothing(core: str) -> None:
    urb, m, _, _ = sim("usb", core)
    motor, imu = urb.find_node("MotorDriver", 0), urb.find_node("Imu", 0)
    with pytest.raises(ValueError, match="no items"):
        Cycle().submit()
    cycle = Cycle()
    with pytest.raises(ValueError, match="pass mbox= explicitly"):
        cycle.read(motor, sx.ImuSample)
    with pytest.raises(ValueError, match="numbered 0..7"):
        cycle.read(motor, 9)
    with pytest.raises(ValueError, match="1..32"):
        cycle.read(motor, 1, size=40)
    with pytest.raises(ValueError, match="give its size"):
        cycle.write(imu, 6)
    cmd = cycle.write(motor, sx.MotorCommand)
    fb = cycle.read(motor, sx.MotorFeedback)
    with pytest.raises(RuntimeError, match="never submitted"):
        _ = fb.flags
    with pytest.raises(RuntimeError, match="never submitted"):
        cycle.wait()
    before = m.stats.submitted
    with pytest.raises(ValueError, match="without data.*item.set"):
        cycle.submit()
    assert m.stats.submitted == before and cycle.submissions == 0
    with pytest.raises(ValueError, match="takes no data|a read takes no data"):
        fb.set(b"\x00" * 6)
    cmd.set(sx.MotorCommand(voltage=5))
    with pytest.raises(ValueError, match="3 data bytes, this item writes 2 .its previous data stay"):
        cmd.set(b"abc")
    cycle.submit()
    with pytest.raises(RuntimeError, match="fixed by its first submission"):
        cycle.read(motor, sx.MotorStatus)
    assert cycle.wait() and cycle.raise_for_error().ok
    assert fb.message().voltage == 5  # the payload before the refused one


@pytest.mark.parametrize("core", CORES)
def test_a_cycle_over_two_bridges_completes_once(core: str) -> None:
    clock = VirtualClock()
    urb, usb_m, _, _ = sim("usb", core, clock=clock)
    far, rs_m, _, _ = sim("rs232", core, clock=clock)
    near, away = urb.find_node("MotorDriver", 0), far.find_node("MotorDriver", 1)
    done: list[int] = []
    cycle = Cycle().set_callback(lambda c: done.append(c.failed))
    a, b = cycle.read(near, sx.MotorFeedback), cycle.read(away, sx.MotorFeedback)
    for _ in range(3):
        cycle.submit()
        assert cycle.wait()
    assert done == [0, 0, 0] and a.ok and b.ok and len(cycle._groups) == 2
    rs_m.close()
    cycle.submit()  # the closed bridge's item completes at once, the other one later: one callback
    assert cycle.wait() and done[-1] == 1 and b.flags == ErrorFlag.BRIDGE_LOST and a.ok
    assert [i.node.label for i in cycle.failures()] == ["MotorDriver:1"]
    with pytest.raises(Exception, match="1 of 2 cycle items failed; first: MotorDriver:1 outbox 1: BRIDGE_LOST"):
        cycle.raise_for_error()


# --------------------------------------------------------------------------------------------
# Real time: USBManager on the C core's pump (and the Python threads with the Python core)
# --------------------------------------------------------------------------------------------

def realtime(core: str, polled: bool) -> dict[str, Any]:
    sys.path.insert(0, str(REPO / "tests" / "host"))
    from bridge_proc import serve_usb_transfers

    host_sock, dev_sock = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
    model = BridgeModel(dict(fake_node(s) for s in NODES), fifo_depth=15)
    serving = threading.Thread(target=serve_usb_transfers, args=(dev_sock, model), daemon=True)
    serving.start()
    urb = URBInterface()
    fd = os.dup(host_sock.fileno())  # the transport's: given by descriptor, it is the caller's to close
    try:
        m = USBManager(CharDeviceTransport(fd=fd), timeout_s=10.0, lost_after_s=30.0, name="usb-cycle")
        if core == "python":
            m._core = m._usb = usb_core.UsbCore(timeout_ns=10 * 10**9, lost_after_ns=30 * 10**9)
            m._has_completed = None
        urb.add_bus_manager(m)
        motors = [urb.find_node("MotorDriver", i) for i in range(3)]
        ring = []
        for _ in range(4):
            c = Cycle().set_callback(None if polled else (lambda c: None))
            for node in motors:
                c.read(node, sx.MotorFeedback)
                c.write(node, sx.MotorCommand)
            ring.append(c)
        seen: list[list[Observed]] = []
        for tick in range(40):
            c = ring[tick % 4]
            if c.submissions:
                assert c.wait(30)
                seen.append([observe(i)[:7] for i in c.items])
            for k, item in enumerate(i for i in c.items if not i.is_read):
                item.set(sx.MotorCommand(voltage=tick + k))
            c.submit()
        for c in ring:
            assert c.wait(30)
        return {"seen": seen, "pumped": m._pumped, "groups": {type(g).__name__ for c in ring for g in c._groups},
                "stats": (m.stats.submitted, m.stats.completed, m.stats.failed)}
    finally:
        urb.close()
        os.close(fd)
        host_sock.close()  # the bridge's end sees the end of the stream and its thread returns
        serving.join(2.0)
        dev_sock.close()


@pytest.mark.parametrize("polled", [True, False], ids=["polled", "callback"])
def test_real_time_cycles_on_the_pump_match_the_python_core(polled: bool) -> None:
    on_c, on_python = realtime("c", polled), realtime("python", polled)
    assert on_c["pumped"] and on_c["groups"] == {"_NativeGroup"}
    assert not on_python["pumped"] and on_python["groups"] == {"_PythonGroup"}
    assert on_c["stats"] == on_python["stats"] and on_c["stats"][2] == 0
    # sequence numbers follow the batching, which real time decides: compare the rest
    strip = [[o[:6] for o in tick] for tick in on_c["seen"]]
    assert strip == [[o[:6] for o in tick] for tick in on_python["seen"]]
    assert all(o[3] == ErrorFlag.NONE for tick in on_c["seen"] for o in tick) and len(on_c["seen"]) == 36


# --------------------------------------------------------------------------------------------
# Seeded bugs of _native_cycle.c
# --------------------------------------------------------------------------------------------

CYCLE_MUTANTS = {
    "cycle-forgets-seq": ("    it->seq = t->seq;\n", "    it->seq = -1;\n"),
    "cycle-refusal-untimed": ("            it->completed_ns = now;\n", "\n"),
    "cycle-lost-reason-cut": ("        PyObject *reason = native_reason_text(core, t->lost_reason);",
                              '        PyObject *reason = native_reason_text(core, "bridge lost");'),
}
"""Seeded bugs: an item's sequence number not kept; a refused item without its completion time;
the lost reason not the manager's."""


def build_cycle_mutant(tmp: Path, name: str) -> Any:
    """The extension compiled with the seeded bug `name` in _native_cycle.c, loaded as its own module."""
    sys.path.insert(0, str(REPO / "tests" / "host_c"))
    try:
        from native_support import build_native_mutant
    finally:
        sys.path.pop(0)
    return build_native_mutant(tmp, "_native_cycle.c", *CYCLE_MUTANTS[name])


@pytest.mark.parametrize("name", sorted(CYCLE_MUTANTS))
def test_a_seeded_bug_in_the_cycle_state_is_caught(tmp_path: Path, name: str) -> None:
    module = build_cycle_mutant(tmp_path, name)
    reference = run_script("rs232", "cycle", "python")
    mutant = run_script("rs232", "cycle", "c", module=module)
    assert mutant["groups"] == ["_NativeGroup"]  # the mutant's cycle state ran
    assert mutant["ticks"] != reference["ticks"]
