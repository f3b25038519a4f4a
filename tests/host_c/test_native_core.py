"""The Python library's protocol cores on the C core (urb.managers.native: NativeRs232Core,
NativeUsbCore, the extension urb.managers._native) against the Python reference cores
(Rs232Core, UsbCore), on the traces of test_differential.py.

Hypothesis draws the same traces as the C-against-Python differential test (its `step`: submissions,
time steps, sending, responses intact or mangled, garbage, polls, a lost uplink, a reset, a draining
close, a hand-over, a window change), plus a lost uplink with a long reason. Both cores get the same
calls with their own `Transfer` objects; after every step everything a caller can observe must be
equal: the frames, every transfer not yet taken (complete or not, before `take_completed`), each
completed transfer (which request, every field the cores write: done, flags
and status with their types, data, sequence number, the sending and completion times, the deadline
and lifetime, the lost reason), the next deadline, the counters, the lost reason and, on USB, the
pipeline trace (`UsbCore.trace`).

`test_a_seeded_bug_in_the_binding_is_caught` compiles the extension with a seeded bug (it hands out
the C core's cut lost reason instead of the caller's whole text) and shows the comparison failing;
`test_a_core_configured_differently_is_caught` does the same for a core with a 1-ns longer timeout.
`test_the_traces_reach_every_outcome` is the witness that the traces reach every outcome kind.
"""

from __future__ import annotations

import random
import sys
from collections import Counter
from pathlib import Path
from typing import Any

import pytest
import test_differential as diff
from native_support import build_native_mutant
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from urb.managers import native
from urb.managers.base import NS_PER_MS, Transfer
from urb.managers.rs232_core import Rs232Core

REPO = Path(__file__).resolve().parents[2]
LONG_REASON = "/dev/serial/by-id/usb-FTDI_FT232R_USB_UART_A50285BI-if00-port0: " + "[Errno 5] Input/output error " * 4



@pytest.fixture(scope="module", autouse=True)
def c_core_in_use() -> None:
    if native.BACKEND != "c":
        pytest.fail(f"the Python library runs its Python cores ({native.REASON}): build urb.managers._native with "
                    "`make host-c-py` (make test-py does) and do not set URB_PURE_PYTHON")

SEEN: Counter[str] = Counter()
"""What the traces of this file reached (test_the_traces_reach_every_outcome checks it)."""


class RefSide(diff.PyCore):
    """One side of the comparison: the reference cores, observed through their Transfer objects."""

    def __init__(self, c: diff.Config, core: Any = None) -> None:
        super().__init__(c)
        if core is not None:
            self.core = core
        if c.kind == diff.USB:
            self.core.trace = []  # type: ignore[union-attr]
        self.traced = 0
        self.pending: dict[int, Transfer] = {}

    def receive(self, data: bytes, now: int) -> None:
        if self.kind == diff.USB:
            self.core.receive_batch(data, now)  # type: ignore[union-attr]
        else:
            self.core.receive(data, now)  # type: ignore[union-attr]

    def frames(self, now: int) -> list[bytes] | bytes | None:
        if self.kind == diff.USB:
            return self.core.frame_out(now)  # type: ignore[union-attr]
        return self.core.frames_to_send(now)  # type: ignore[union-attr]

    def submit(self, tid: int, addr: int, box: int, read: bool, length: int, data: bytes, within: int, now: int) -> None:
        t = Transfer(addr, box, read, length, data=b"" if read else data, answer_within_ns=within)
        t.submitted_ns = now
        self.ids[id(t)] = tid
        self.pending[tid] = t
        self.core.submit(t, now)

    def tid(self, t: Transfer) -> int:
        return self.ids[id(t)]

    def take(self) -> list[Any]:  # type: ignore[override]
        done = self.core.take_completed()
        for t in done:
            del self.pending[self.tid(t)]
        return [(self.tid(t), t.done, type(t.flags).__name__, int(t.flags), type(t.status).__name__,
                 -1 if t.status is None else int(t.status), t.seq, t.submitted_ns, t.sent_ns, t.completed_ns,
                 t.response, t.lost_reason, t.due_ns, t.expires_ns) for t in done]

    def untaken(self) -> list[Any]:
        """The transfers submitted and not taken: complete (or not) before take_completed alike."""
        return [(tid, t.done, int(t.flags), t.seq, t.sent_ns) for tid, t in sorted(self.pending.items())]

    def observe(self) -> tuple[Any, ...]:
        c = self.core
        usb = (c.frames_written, c.transfers_in, c.bad_headers) if self.kind == diff.USB else (0, 0, 0)  # type: ignore[union-attr]
        stats = (c.stray_bytes, c.late_responses, c.released_placeholders, c.in_flight, c.placeholders,
                 int(c.busy()), int(c.has_queued)) + usb
        nd, bu = c.next_deadline(), c.busy_until()
        trace: list[Any] = []
        if self.kind == diff.USB:  # the events since the last observation
            events = c.trace or []  # type: ignore[union-attr]
            trace = [(what, now, tuple(self.tid(t) for t in ts)) for what, now, ts in events[self.traced:]]
            self.traced = len(events)
        return (diff.NEVER if nd is None else nd, diff.NO_TIME if bu is None else bu, c.drained(), stats,
                c.lost_reason or "", c.window, trace)


def native_side(c: diff.Config) -> RefSide:
    if c.kind == diff.RS232:
        core: Any = native.NativeRs232Core(window=c.window, timeout_ns=c.timeout_ns, resync_gap_ns=c.resync_gap_ns,
                                           lost_after_ns=c.lost_after_ns, lost_after_timeouts=c.lost_after_timeouts,
                                           placeholder_ns=c.placeholder_ns)
    else:
        core = native.NativeUsbCore(max_batch=c.max_batch, window=c.window, batch_bytes=c.batch_bytes,
                                    timeout_ns=c.timeout_ns, lost_after_ns=c.lost_after_ns,
                                    lost_after_timeouts=c.lost_after_timeouts, placeholder_ns=c.placeholder_ns)
    return RefSide(c, core)


class Pair(diff.Pair):
    """The reference and the native core, the same calls, compared after each (`diff.step` drives it:
    `py` is the reference, `c` the native core)."""

    def __init__(self, cfg: diff.Config, c_cfg: diff.Config | None = None, make_native: Any = native_side) -> None:
        self.py, self.c = RefSide(cfg), make_native(c_cfg or cfg)  # type: ignore[assignment]
        self.kind = cfg.kind
        self.now = 0
        self.next_id = 0
        self.completions = 0

    def close(self) -> None:
        pass

    def call(self, name: str, *args: Any) -> None:
        a, b = getattr(self.py, name)(*args), getattr(self.c, name)(*args)
        assert a == b, f"{name}{args}: reference {a!r} != native {b!r}"
        untaken_py, untaken_c = self.py.untaken(), self.c.untaken()
        assert untaken_py == untaken_c, f"after {name}{args}: transfers differ before take_completed\n" \
                                        f"reference {untaken_py}\nnative    {untaken_c}"
        SEEN["done before taken"] += any(u[1] for u in untaken_py)
        done_py, done_c = self.py.take(), self.c.take()
        assert done_py == done_c, f"after {name}{args}: completions differ\nreference {done_py}\nnative    {done_c}"
        self.completions += len(done_py)
        obs_py, obs_c = self.py.observe(), self.c.observe()
        assert obs_py == obs_c, f"after {name}{args}: state differs\nreference {obs_py}\nnative    {obs_c}"
        note(name, done_py, obs_py)


def note(name: str, done: list[Any], obs: tuple[Any, ...]) -> None:
    for c in done:
        SEEN[f"flag {c[3]}"] += 1
        SEEN["data"] += c[10] is not None
        SEEN["long lost reason"] += c[11] == LONG_REASON
    SEEN["lost: silence"] += obs[4].startswith(("the bridge sent nothing", "the bridge returned no USB"))
    SEEN["lost: timeouts in a row"] += "in a row" in obs[4]
    stray, late, released = obs[3][0], obs[3][1], obs[3][2]
    SEEN["stray"] += stray > 0
    SEEN["late response"] += late > 0
    SEEN["released placeholder"] += released > 0
    SEEN["bad USB header"] += obs[3][9] > 0
    SEEN["USB trace"] += bool(obs[6])
    SEEN[f"call {name}"] += 1


def step(draw: Any, pair: Pair, rnd: random.Random) -> None:
    if draw(st.integers(0, 40)) == 0:  # a lost uplink whose reason is longer than the C core keeps
        pair.call("link_lost", pair.now, LONG_REASON)
    else:
        diff.step(draw, pair, rnd)


@settings(max_examples=100, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(cfg=diff.configs, seed=st.integers(0, 2**32 - 1), data=st.data())
def test_native_core_matches_the_reference(cfg: diff.Config, seed: int, data: st.DataObject) -> None:
    pair = Pair(cfg)
    rnd = random.Random(seed)
    for _ in range(diff.STEPS):
        step(data.draw, pair, rnd)


@pytest.mark.parametrize("kind", [diff.RS232, diff.USB])
def test_timeouts_in_a_row_and_a_long_busy_trace_alike(kind: int) -> None:
    """The directed trace to the 'timeouts in a row' rule, a response with each status, then a
    thousand 1-kHz steps with losses and corruption (test_differential's seeded traces, on this pair)."""
    cfg = diff.Config(kind, 4, 10 * NS_PER_MS, lost_after_ns=200 * NS_PER_MS, lost_after_timeouts=3, placeholder_ns=0)
    pair = Pair(cfg)
    for _ in range(3):
        pair.call("submit", pair.next_id, 0x20, 1, True, 6, b"", 0, pair.now)
        pair.next_id += 1
        pair.call("frames", pair.now)
        pair.now += 111 * NS_PER_MS
        pair.call("poll", pair.now)
    assert "in a row" in pair.py.observe()[4]
    rnd = random.Random(kind)
    pair = Pair(diff.Config(kind, 15, 50 * NS_PER_MS))
    for status in range(9):  # every status the bridge can answer, each to a request in flight
        pair.call("submit", pair.next_id, 0x20, 1, True, 6, b"", 0, pair.now)
        pair.next_id += 1
        pair.call("frames", pair.now)
        t = pair.py.inflight()[-1]
        header = diff.UsbBatchHeader(frame=1, count=1).encode() if kind == diff.USB else b""
        pair.call("receive", header + diff.response_bytes(rnd, t, status), pair.now)
    pair = Pair(diff.Config(kind, 15 if kind == diff.USB else 4, 50 * NS_PER_MS if kind == diff.USB else 100 * NS_PER_MS))
    for _ in range(1000):
        for _ in range(rnd.randrange(0, 4)):
            pair.call("submit", pair.next_id, 0x20, 1, True, 6, b"", 0, pair.now)
            pair.next_id += 1
        pair.call("frames", pair.now)
        inflight = [t for t in pair.py.inflight() if not t.done]
        if inflight and rnd.random() < 0.9:
            frames = [diff.response_bytes(rnd, t, 0) for t in inflight[:rnd.randrange(1, len(inflight) + 1)]]
            if rnd.random() < 0.05:
                frames = frames[1:]
            stream = b"".join(frames)
            if kind == diff.USB:
                stream = diff.UsbBatchHeader(frame=1, count=len(frames)).encode() + stream
            pair.call("receive", stream, pair.now)
        pair.now += NS_PER_MS
        pair.call("poll", pair.now)
    assert pair.completions > 700


def test_the_traces_reach_every_outcome() -> None:
    """Witness that the traces above reach what they compare (it runs after them: pytest keeps a
    file's order, with or without xdist's --dist loadfile)."""
    assert SEEN, "run the whole file: this test reads what the traces above reached"
    flags = {f"flag {1 << k}" for k in range(11)} | {"flag 0"}
    calls = {f"call {n}" for n in ("submit", "receive", "poll", "frames", "link_lost", "reset", "start_drain",
                                   "hand_over", "set_window")}
    wanted = flags | calls | {"lost: silence", "lost: timeouts in a row", "data", "stray", "late response",
                              "released placeholder", "bad USB header", "USB trace", "long lost reason",
                              "done before taken"}
    assert wanted <= set(SEEN), f"never reached: {sorted(wanted - set(SEEN))}"


def test_a_core_configured_differently_is_caught() -> None:
    """A native core whose timeout is 1 ns longer than the reference's is caught: first by its
    deadline, then by its transfer not timed out yet."""
    pair = Pair(diff.Config(diff.RS232, 4, 100 * NS_PER_MS), diff.Config(diff.RS232, 4, 100 * NS_PER_MS + 1))
    pair.call("submit", 0, 8, 1, True, 6, b"", 0, 0)
    with pytest.raises(AssertionError, match="state differs"):
        pair.call("frames", 0)
    with pytest.raises(AssertionError, match="transfers differ before take_completed"):
        pair.call("poll", 100 * NS_PER_MS)


SEEDED_BUG = ("PyObject *reason = native_reason_text(self, t->lost_reason);",
              'PyObject *reason = PyUnicode_DecodeUTF8(t->lost_reason, (Py_ssize_t)strlen(t->lost_reason), "replace");')
"""The binding hands out the C core's cut lost reason instead of the caller's whole text."""


def build_mutant(tmp: Path) -> Any:
    """The extension compiled from _native_xfer.c with SEEDED_BUG, loaded as its own module."""
    return build_native_mutant(tmp, "_native_xfer.c", *SEEDED_BUG, optimise=True)


def test_a_seeded_bug_in_the_binding_is_caught(tmp_path: Path) -> None:
    mutant = build_mutant(tmp_path)

    class MutantRs232Core(mutant.Core):  # type: ignore[misc,name-defined]
        SILENCE = Rs232Core.SILENCE

        def __init__(self, c: diff.Config) -> None:
            self.window = c.window
            self._setup(diff.RS232, c.window, c.timeout_ns, c.lost_after_ns, c.lost_after_timeouts, c.placeholder_ns,
                        c.resync_gap_ns, c.max_batch, c.batch_bytes, native._STATUS_OF, native._FLAG_OF)

    cfg = diff.Config(diff.RS232, 4, 100 * NS_PER_MS)
    pair = Pair(cfg, make_native=lambda c: RefSide(c, MutantRs232Core(c)))
    pair.call("submit", 0, 8, 1, True, 6, b"", 0, 0)
    pair.call("frames", 0)
    with pytest.raises(AssertionError, match="completions differ"):
        pair.call("link_lost", 1, LONG_REASON)


def test_every_public_member_is_the_c_cores() -> None:
    """NativeRs232Core and NativeUsbCore subclass the reference cores (isinstance, typing) with the
    C core's type first: every public method and counter of the reference must be overridden, or a
    call would reach the reference's code without its state. Seeded: a member the C type lacks is
    reported."""
    def missing(native_cls: type, ref: type) -> set[str]:
        public = {n for k in ref.__mro__[:-1] for n in vars(k) if not n.startswith("_")}
        return {n for n in public if n != "SILENCE" and not any(n in vars(k) for k in native_cls.__mro__
                                                                 if not issubclass(ref, k))}

    assert missing(native.NativeRs232Core, Rs232Core) == set()
    assert missing(native.NativeUsbCore, native.UsbCore) == set()

    class Lacking(Rs232Core):
        def resend_everything(self) -> None:
            """A public method the C core does not have."""

    assert missing(native.NativeRs232Core, Lacking) == {"resend_everything"}


def test_the_choice_of_core(monkeypatch: pytest.MonkeyPatch) -> None:
    """URB_PURE_PYTHON and URB_HOST_CORE choose as host/urb/README.md says; a module built from other
    sources is refused, saying how to rebuild it."""
    for var in ("URB_PURE_PYTHON", "URB_HOST_CORE"):
        monkeypatch.delenv(var, raising=False)
    module, why = native._selection()
    assert module is not None and why == "built from these sources"
    monkeypatch.setenv("URB_PURE_PYTHON", "1")
    assert native._selection() == (None, "URB_PURE_PYTHON=1")
    monkeypatch.setenv("URB_HOST_CORE", "c")
    assert native._selection()[0] is module  # the cores alone, whatever the codecs run
    monkeypatch.setenv("URB_HOST_CORE", "python")
    assert native._selection() == (None, "URB_HOST_CORE=python")
    monkeypatch.setenv("URB_HOST_CORE", "fast")
    with pytest.raises(ImportError, match="URB_HOST_CORE='fast': use python"):
        native._selection()
    monkeypatch.delenv("URB_HOST_CORE")
    monkeypatch.delenv("URB_PURE_PYTHON")
    monkeypatch.setattr(native, "source_fingerprint", lambda: "0" * 16)
    module, why = native._selection()
    assert module is None and "built from other sources" in why and "make host-c-py" in why
    monkeypatch.setenv("URB_PURE_PYTHON", "0")
    with pytest.raises(ImportError, match="asks for the C protocol core, but the extension .* was built from other"):
        native._selection()


def test_the_managers_run_the_c_core_and_fall_back_on_settings_it_refuses() -> None:
    assert isinstance(native.new_rs232_core(), native.NativeRs232Core)
    assert isinstance(native.new_usb_core(max_batch=7), native.NativeUsbCore)
    slow = native.new_rs232_core(lost_after_ns=2 * 3600 * 10**9)  # above the C core's range of 1 h
    assert type(slow) is Rs232Core
    with pytest.raises(ValueError, match="C core does not take these settings"):
        native.NativeRs232Core(lost_after_ns=2 * 3600 * 10**9)
    with pytest.raises(ValueError, match="window = 16: must be 1..15 so the 4-bit sequence number cannot alias"):
        native.new_rs232_core(window=16)  # the reference's message
    with pytest.raises(ValueError, match="max_batch = 0: must be 1..15"):
        native.new_usb_core(max_batch=0)
