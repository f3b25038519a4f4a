"""TraceUsbUplink.tla: hand-written USB uplink traces (an accepted one, rejected ones that report their
longest matched prefix), and the host library's own trace in the simulation, accepted as it is and
rejected when the host skips the empty bulk-OUT transfers that fetch its responses (a seeded bug in
UsbCore)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from urb.managers.usb_core import UsbCore
from urb_sim.native import App
from urb_sim.system import NS_PER_MS, Loop, System
from urb_sim.tracecheck import TraceCheckError, UsbEvent, check_usb, find_tlc, usb_trace


@pytest.fixture(scope="module", autouse=True)
def _tlc() -> None:
    try:
        find_tlc()
    except TraceCheckError as exc:  # make check installs both; a bare checkout says what is missing
        pytest.fail(str(exc))


def _pipeline(frames: int) -> list[UsbEvent]:
    """One request submitted per frame, written at the next frame's start, answered in the frame after."""
    ev: list[UsbEvent] = []
    for f in range(frames + 2):
        if 1 <= f <= frames:
            ev.append(UsbEvent("write", f, ids=[f]))
        if f >= 2:
            ev += [UsbEvent("read", f, seqs=[f - 1]), UsbEvent("callback", f, id=f - 1)]
        if f < frames:
            ev.append(UsbEvent("submit", f, id=f + 1))
    return ev


def test_pipelined_trace_is_accepted() -> None:
    trace = _pipeline(4)
    r = check_usb(trace, 14)
    assert r.accepted, r.message
    assert r.matched_prefix == r.events == len(trace)


@pytest.mark.parametrize("at, change", [
    (4, {"seqs": [2]}),    # frame 2's read returns the response of the batch written in frame 2
    (8, {"f": 4}),         # frame 3's read comes a frame late: frame 3 cannot end
    (9, {"id": 3}),        # the callback names another request than the oldest in flight
    (5, {"ok": False}),    # a failed callback: the specification has no failure
])
def test_rejected_trace_reports_its_longest_matched_prefix(at: int, change: dict[str, object]) -> None:
    trace = _pipeline(4)
    for name, value in change.items():
        setattr(trace[at], name, value)
    r = check_usb(trace, 14)
    assert not r.accepted
    assert r.matched_prefix == at, r.message
    assert f"matches up to event {at} of {len(trace)}" in r.message


def _record(cycles: int) -> list[UsbEvent]:
    """The host library's USB uplink trace: two reads submitted every other millisecond."""
    s = System(seed=7, probe_out=6)
    b = s.bridge("usb")
    s.node(b, App.PROBE, 0x10, 0)
    s.start()
    node = s.urb.find_node(0x7E, 0)
    core = s.managers[b].core
    assert isinstance(core, UsbCore)
    core.trace = []
    k = [0]

    def tick() -> None:
        k[0] += 1
        if k[0] % 2:
            for _ in range(2):
                node.submit_request(node.new_request().read(1, 6))

    Loop(s.host, NS_PER_MS, tick, count=cycles)
    s.host.advance((cycles + 60) * NS_PER_MS)
    events = usb_trace(core.trace)
    s.close()
    return events


def test_host_library_trace_is_accepted() -> None:
    ev = _record(20)
    assert sum(1 for e in ev if e.ev == "callback") == 20
    r = check_usb(ev, 14)
    assert r.accepted, r.message


@pytest.fixture
def _skip_empty_writes(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """Seeded bug: the host sends a bulk-OUT transfer only when it has requests to write, so a frame
    with requests in flight and none queued issues no bulk-IN read of their responses."""
    frame_out = UsbCore.frame_out

    def skipping(self: UsbCore, now: int) -> bytes | None:
        return frame_out(self, now) if self._queued else None

    monkeypatch.setattr(UsbCore, "frame_out", skipping)
    yield


@pytest.mark.usefixtures("_skip_empty_writes")
def test_host_skipping_empty_writes_is_rejected() -> None:
    ev = _record(20)
    r = check_usb(ev, 14)
    assert not r.accepted
    # the first frame with requests in flight and none queued has no write, and cannot end
    written = {e.f for e in ev if e.ev == "write"}
    first_silent = next(f for f in range(1, ev[-1].f) if f not in written)
    stuck_at = next(k for k, e in enumerate(ev) if e.f > first_silent)
    assert r.matched_prefix == stuck_at, r.message
