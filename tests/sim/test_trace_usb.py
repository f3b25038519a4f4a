"""TraceUsbUplink.tla: hand-written USB uplink traces (an accepted one, rejected ones that report their
longest matched prefix), and the host library's own trace in the simulation, accepted as it is and
rejected at its first batch when the host writes its requests newest first (a seeded bug in
UsbCore)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from urb.managers import native
from urb.managers.base import Transfer
from urb.managers.usb_core import UsbCore
from urb_sim.experiments.traces import record_usb_uplink
from urb_sim.tracecheck import UsbEvent, check_usb


pytestmark = pytest.mark.usefixtures("tlc_installed")


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


# lobster-trace: urb.HOST_004
def test_host_library_trace_is_accepted() -> None:
    ev, max_batch, window = record_usb_uplink(7, 20)
    assert sum(1 for e in ev if e.ev == "callback") == 20 * 2 + 20 // 3  # every read and write answered
    r = check_usb(ev, max_batch, window)
    assert r.accepted, r.message


def test_trace_checked_against_the_window_it_was_logged_with() -> None:
    """The window is the host's (UsbCore.window, 15 here), not a constant of the check: the same trace
    checked as if the host kept at most 2 requests in flight is rejected (UsbUplink.tla's UsbWrite
    cannot send past the window)."""
    ev, max_batch, window = record_usb_uplink(7, 20)
    assert window == 15
    assert check_usb(ev, max_batch, window).accepted
    r = check_usb(ev, max_batch, 2)
    assert not r.accepted and r.matched_prefix < len(ev), r.message


@pytest.fixture
def _newest_first(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """Seeded bug: UsbCore buffers each request in front of the others, so a batch goes out newest
    first and the callbacks run out of submission order."""

    def submit_in_front(self: UsbCore, t: Transfer, now: int) -> None:
        self._queued.appendleft(t)
        if self.trace is not None:
            self.trace.append(("submit", now, (t,)))

    monkeypatch.setattr(UsbCore, "submit", submit_in_front)
    monkeypatch.setattr(native, "BACKEND", "python")  # the seeded bug is in the reference core: run it
    yield


@pytest.mark.usefixtures("_newest_first")
def test_host_writing_newest_first_is_rejected() -> None:
    ev, max_batch, window = record_usb_uplink(7, 20)
    r = check_usb(ev, max_batch, window)
    assert not r.accepted
    first_batch = next(k for k, e in enumerate(ev) if e.ev == "write" and len(e.ids) > 1)
    assert ev[first_batch].ids != sorted(ev[first_batch].ids)
    assert r.matched_prefix == first_batch, r.message
