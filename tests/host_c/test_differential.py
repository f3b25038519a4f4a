"""Differential test: the C protocol core (host/c/core, through tests/host_c/core_shim.c and ctypes)
against the Python reference (host/urb/managers/rs232_core.py, usb_core.py).

Hypothesis draws one trace per example, step by step from the reference's state: submissions of
reads and writes (long answer times too), time steps from 0 to 600 ms, sending, responses to
requests in flight (any status, any data; some with a flipped bit, cut short, split in chunks or
buried in garbage; on USB batched with a good or bad header), garbage, polls, a lost uplink, a
reset, a draining close, a hand-over and a window change. Both cores get exactly the same calls;
after every step everything the caller can observe must be equal: the frames sent, each completion
(which request, flags, status, sequence number, data, the submission, sending and completion
times, the lost reason) in order, the next deadline, the counters and the lost reason.

`test_the_comparison_catches_a_difference` shows the comparison can fail: a C core configured with
a timeout one nanosecond longer is caught by its deadline, then by its completions.
"""

from __future__ import annotations

import ctypes
import random
from collections import Counter
from dataclasses import dataclass
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hostc_build import build
from urb.managers.base import NS_PER_MS, Transfer
from urb.managers.rs232_core import PLACEHOLDER_NS, SCAN_ANSWER_NS, Rs232Core
from urb.managers.usb_core import UsbCore
from urb_msgs.urb_core import UplinkResponse, UsbBatchHeader

NO_TIME = -(2**63)
NEVER = 2**63 - 1
RS232, USB = 1, 2
STEPS = 70
TIME_STEPS = [NS_PER_MS, 0, 1, 1000, 100_000, NS_PER_MS, 5 * NS_PER_MS, 19 * NS_PER_MS, 21 * NS_PER_MS,
              2 * NS_PER_MS, 49 * NS_PER_MS, 60 * NS_PER_MS, 120 * NS_PER_MS, 350 * NS_PER_MS, 600 * NS_PER_MS]


@dataclass(frozen=True)
class Config:
    kind: int
    window: int
    timeout_ns: int
    lost_after_ns: int = 500 * NS_PER_MS
    lost_after_timeouts: int = 8
    placeholder_ns: int = PLACEHOLDER_NS
    resync_gap_ns: int = 20 * NS_PER_MS
    max_batch: int = 14
    batch_bytes: int = 512


def load_shim() -> ctypes.CDLL:
    lib = ctypes.CDLL(str(build("build/host_c/libcoreshim.so")))
    ll, i, p = ctypes.c_longlong, ctypes.c_int, ctypes.c_void_p
    buf = ctypes.c_char_p
    sig: dict[str, tuple[Any, list[Any]]] = {
        "shim_new": (p, [i, i, ll, ll, i, ll, ll, i, i]),
        "shim_free": (None, [p]),
        "shim_submit": (i, [p, i, i, i, i, i, buf, ll, ll]),
        "shim_receive": (i, [p, buf, i, ll]),
        "shim_poll": (i, [p, ll]),
        "shim_frames": (i, [p, ll, buf, i]),
        "shim_take": (i, [p, ctypes.POINTER(ll), buf, buf, i]),
        "shim_next_deadline": (ll, [p]),
        "shim_link_lost": (None, [p, ll, buf]),
        "shim_reset": (None, [p, ll]),
        "shim_start_drain": (ll, [p, ll]),
        "shim_drained": (i, [p]),
        "shim_hand_over": (None, [p, ll]),
        "shim_busy_until": (ll, [p]),
        "shim_set_window": (i, [p, i]),
        "shim_stats": (None, [p, ctypes.POINTER(ll)]),
        "shim_lost_reason": (ctypes.c_char_p, [p]),
    }
    for name, (res, args) in sig.items():
        fn = getattr(lib, name)
        fn.restype, fn.argtypes = res, args
    return lib


LIB: ctypes.CDLL | None = None


def lib() -> ctypes.CDLL:
    global LIB
    if LIB is None:
        LIB = load_shim()
    return LIB


Completion = tuple[int, int, int, int, int, int, int, bytes, str]

SEEN: Counter[str] = Counter()
"""What the Hypothesis traces reached (test_the_traces_reach_every_outcome checks it)."""


def note(done: list[Completion], obs: tuple[Any, ...]) -> None:
    for c in done:
        SEEN[f"flag {c[1]}"] += 1
        if c[7]:
            SEEN["data"] += 1
    if obs[4].startswith(("the bridge sent nothing", "the bridge returned no USB")):
        SEEN["lost: silence"] += 1
    if "in a row" in obs[4]:
        SEEN["lost: timeouts in a row"] += 1
    stray, late, released = obs[3][0], obs[3][1], obs[3][2]
    SEEN["stray"] += stray > 0
    SEEN["late response"] += late > 0
    SEEN["released placeholder"] += released > 0
    SEEN["bad USB header"] += obs[3][9] > 0


class CCore:
    def __init__(self, c: Config) -> None:
        self.kind = c.kind
        self.h = lib().shim_new(c.kind, c.window, c.timeout_ns, c.lost_after_ns, c.lost_after_timeouts,
                                c.placeholder_ns, c.resync_gap_ns, c.max_batch, c.batch_bytes)
        assert self.h, f"shim_new refused {c}"

    def close(self) -> None:
        lib().shim_free(self.h)

    def submit(self, tid: int, addr: int, box: int, read: bool, length: int, data: bytes, within: int, now: int) -> None:
        rc = lib().shim_submit(self.h, tid, addr, box, int(read), length, data, within, now)
        assert rc == 0, f"shim_submit: {rc}"

    def receive(self, data: bytes, now: int) -> None:
        assert lib().shim_receive(self.h, data, len(data), now) == 0

    def poll(self, now: int) -> None:
        assert lib().shim_poll(self.h, now) == 0

    def frames(self, now: int) -> list[bytes] | bytes | None:
        out = ctypes.create_string_buffer(4096)
        n = lib().shim_frames(self.h, now, out, 4096)
        if self.kind == USB:
            return None if n == -1 else out.raw[:n]
        assert n >= 0
        raw, frames, k = out.raw[:n], [], 0
        while k < len(raw):
            frames.append(raw[k + 1:k + 1 + raw[k]])
            k += 1 + raw[k]
        return frames

    def take(self) -> list[Completion]:
        done = []
        rec = (ctypes.c_longlong * 8)()
        resp = ctypes.create_string_buffer(32)
        reason = ctypes.create_string_buffer(128)
        while lib().shim_take(self.h, rec, resp, reason, 128):
            done.append((rec[0], rec[1], rec[2], rec[3], rec[4], rec[5], rec[6], resp.raw[:rec[7]],
                         reason.value.decode()))
        return done

    def observe(self) -> tuple[Any, ...]:
        st8 = (ctypes.c_longlong * 10)()
        lib().shim_stats(self.h, st8)
        stats = list(st8)
        if self.kind == RS232:
            stats[7:] = [0, 0, 0]
        reason = lib().shim_lost_reason(self.h).decode()
        return (lib().shim_next_deadline(self.h), lib().shim_busy_until(self.h), bool(lib().shim_drained(self.h)),
                tuple(stats), reason)

    def link_lost(self, now: int, reason: str) -> None:
        lib().shim_link_lost(self.h, now, reason.encode())

    def reset(self, now: int) -> None:
        lib().shim_reset(self.h, now)

    def start_drain(self, now: int) -> int:
        return int(lib().shim_start_drain(self.h, now))

    def hand_over(self, until: int) -> None:
        lib().shim_hand_over(self.h, until)

    def set_window(self, w: int) -> None:
        assert lib().shim_set_window(self.h, w) == 0


class PyCore:
    def __init__(self, c: Config) -> None:
        self.kind = c.kind
        self.core: Rs232Core | UsbCore
        if c.kind == RS232:
            self.core = Rs232Core(window=c.window, timeout_ns=c.timeout_ns, resync_gap_ns=c.resync_gap_ns,
                                  lost_after_ns=c.lost_after_ns, lost_after_timeouts=c.lost_after_timeouts,
                                  placeholder_ns=c.placeholder_ns)
        else:
            self.core = UsbCore(max_batch=c.max_batch, window=c.window, batch_bytes=c.batch_bytes,
                                timeout_ns=c.timeout_ns, lost_after_ns=c.lost_after_ns,
                                lost_after_timeouts=c.lost_after_timeouts, placeholder_ns=c.placeholder_ns)
        self.ids: dict[int, int] = {}  # id(Transfer) -> test id

    def submit(self, tid: int, addr: int, box: int, read: bool, length: int, data: bytes, within: int, now: int) -> None:
        t = Transfer(addr, box, read, length, data=b"" if read else data, answer_within_ns=within)
        t.submitted_ns = now
        self.ids[id(t)] = tid
        self.core.submit(t, now)

    def receive(self, data: bytes, now: int) -> None:
        if isinstance(self.core, UsbCore):
            self.core.receive_batch(data, now)
        else:
            self.core.receive(data, now)

    def poll(self, now: int) -> None:
        self.core.poll(now)

    def frames(self, now: int) -> list[bytes] | bytes | None:
        if isinstance(self.core, UsbCore):
            return self.core.frame_out(now)
        return self.core.frames_to_send(now)

    def take(self) -> list[Completion]:
        return [(self.ids[id(t)], int(t.flags), -1 if t.status is None else int(t.status), t.seq, t.submitted_ns,
                 NO_TIME if t.sent_ns is None else t.sent_ns, t.completed_ns or 0, t.response or b"",
                 t.lost_reason or "") for t in self.core.take_completed()]

    def observe(self) -> tuple[Any, ...]:
        c = self.core
        nd = c.next_deadline()
        bu = c.busy_until()
        usb = (c.frames_written, c.transfers_in, c.bad_headers) if isinstance(c, UsbCore) else (0, 0, 0)
        stats = (c.stray_bytes, c.late_responses, c.released_placeholders, c.in_flight, c.placeholders,
                 int(c.busy()), int(c.has_queued)) + usb
        return (NEVER if nd is None else nd, NO_TIME if bu is None else bu, c.drained(), stats,
                c.lost_reason or "")

    def link_lost(self, now: int, reason: str) -> None:
        self.core.link_lost(now, reason)

    def reset(self, now: int) -> None:
        self.core.reset(now)

    def start_drain(self, now: int) -> int:
        r = self.core.start_drain(now)
        return NO_TIME if r is None else r

    def hand_over(self, until: int) -> None:
        self.core.hand_over(until)

    def set_window(self, w: int) -> None:
        self.core.set_window(w)

    def inflight(self) -> list[Transfer]:
        return list(self.core._m.inflight)


class Pair:
    """Both cores, the same calls, compared after each."""

    def __init__(self, cfg: Config, c_cfg: Config | None = None) -> None:
        self.py, self.c = PyCore(cfg), CCore(c_cfg or cfg)
        self.kind = cfg.kind
        self.now = 0
        self.next_id = 0
        self.completions = 0

    def close(self) -> None:
        self.c.close()

    def call(self, name: str, *args: Any) -> None:
        a, b = getattr(self.py, name)(*args), getattr(self.c, name)(*args)
        assert a == b, f"{name}{args}: Python {a!r} != C {b!r}"
        done_py, done_c = self.py.take(), self.c.take()
        assert done_py == done_c, f"after {name}{args}: completions differ\nPython {done_py}\nC      {done_c}"
        self.completions += len(done_py)
        note(done_py, self.py.observe())
        obs_py, obs_c = self.py.observe(), self.c.observe()
        assert obs_py == obs_c, f"after {name}{args}: state differs\nPython {obs_py}\nC      {obs_c}"


def response_bytes(rnd: random.Random, t: Transfer, status: int) -> bytes:
    data = bytes(rnd.randrange(256) for _ in range(t.length)) if t.read and status == 0 else b""
    return UplinkResponse(seq=t.seq, status=status, data=data).encode()


def mangle(draw: Any, rnd: random.Random, frame: bytes) -> bytes:
    how = draw(st.sampled_from(["intact"] * 6 + ["flip", "cut", "garbage-before", "garbage-after"]))
    if how == "flip":
        b = bytearray(frame)
        k = rnd.randrange(len(b) * 8)
        b[k // 8] ^= 1 << (k % 8)
        return bytes(b)
    if how == "cut":
        return frame[:rnd.randrange(len(frame))]
    garbage = bytes(rnd.randrange(256) for _ in range(rnd.randrange(1, 6)))
    return garbage + frame if how == "garbage-before" else frame + garbage


def step(draw: Any, pair: Pair, rnd: random.Random) -> None:
    what = draw(st.sampled_from(["respond", "send", "submit", "time", "poll", "submit", "respond", "send", "time",
                                 "respond", "rare"]))
    if what == "rare":  # these end or restart a core's traffic: rarely, or the traces are mostly lost cores
        what = draw(st.sampled_from(["garbage", "garbage", "window", "handover", "reset", "lost", "drain"]))
    if what == "submit":
        read = draw(st.booleans())
        length = draw(st.sampled_from([1, 2, 6, 11, 13, 14, 25, 32]))
        within = draw(st.sampled_from([0] * 12 + [200 * NS_PER_MS, SCAN_ANSWER_NS]))
        data = bytes(rnd.randrange(256) for _ in range(length))
        pair.call("submit", pair.next_id, rnd.randrange(128), rnd.randrange(8), read, length, data, within, pair.now)
        pair.next_id += 1
    elif what == "time":
        pair.now += draw(st.sampled_from(TIME_STEPS))
    elif what == "send":
        pair.call("frames", pair.now)
    elif what == "poll":
        pair.call("poll", pair.now)
    elif what == "garbage":
        pair.call("receive", bytes(rnd.randrange(256) for _ in range(rnd.randrange(1, 40))), pair.now)
    elif what == "respond":
        inflight = pair.py.inflight()
        if not inflight:
            return
        first = draw(st.integers(0, len(inflight) - 1))
        chosen = inflight[first:first + draw(st.integers(1, 3))]
        stream = b"".join(mangle(draw, rnd, response_bytes(rnd, t, draw(st.sampled_from([0] * 5 + list(range(1, 9))))))
                          for t in chosen)
        if pair.kind == USB:
            bad = draw(st.sampled_from([False] * 9 + [True]))
            header = UsbBatchHeader(frame=rnd.randrange(65536), count=len(chosen)).encode()
            if bad:
                header = bytes([header[0], header[1], header[2], header[3] ^ 0x55])
            pair.call("receive", header + stream, pair.now)
        else:
            cut = sorted(rnd.sample(range(1, len(stream)), min(len(stream) - 1, draw(st.integers(0, 3))))) \
                if len(stream) > 1 else []
            for a, b in zip([0] + cut, cut + [len(stream)]):
                pair.call("receive", stream[a:b], pair.now)
                pair.now += draw(st.sampled_from([0, 0, 1000, 2 * NS_PER_MS]))
    elif what == "lost":
        pair.call("link_lost", pair.now, "test: I/O error")
    elif what == "reset":
        pair.call("reset", pair.now)
    elif what == "drain":
        pair.call("start_drain", pair.now)
    elif what == "handover":
        pair.call("hand_over", pair.now + draw(st.sampled_from([0, 3 * NS_PER_MS, 300 * NS_PER_MS])))
    elif what == "window":
        pair.call("set_window", draw(st.integers(1, 15)))


configs = st.builds(
    Config,
    kind=st.sampled_from([RS232, USB]),
    window=st.integers(1, 15),
    timeout_ns=st.sampled_from([10 * NS_PER_MS, 50 * NS_PER_MS, 100 * NS_PER_MS, 400 * NS_PER_MS]),
    lost_after_ns=st.sampled_from([200 * NS_PER_MS, 500 * NS_PER_MS]),
    lost_after_timeouts=st.sampled_from([1, 3, 8]),
    placeholder_ns=st.sampled_from([0, 30 * NS_PER_MS, PLACEHOLDER_NS]),
    resync_gap_ns=st.sampled_from([NS_PER_MS, 20 * NS_PER_MS]),
    max_batch=st.integers(1, 15),
    batch_bytes=st.sampled_from([41, 100, 512]),
)


@settings(max_examples=400, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(cfg=configs, seed=st.integers(0, 2**32 - 1), data=st.data())
def test_c_core_matches_the_python_core(cfg: Config, seed: int, data: st.DataObject) -> None:
    pair = Pair(cfg)
    rnd = random.Random(seed)
    try:
        for _ in range(STEPS):
            step(data.draw, pair, rnd)
    finally:
        pair.close()


@pytest.mark.parametrize("kind", [RS232, USB])
def test_timeouts_in_a_row_lose_the_bridge_alike(kind: int) -> None:
    """A directed trace to the second lost-bridge rule (Hypothesis' 400 examples may or may not draw
    it): sparse requests, one at a time, never answered; the third timeout comes after more than
    `lost_after_ns` of silence, and nothing was outstanding all that time (not the silence rule)."""
    cfg = Config(kind, 4, 10 * NS_PER_MS, lost_after_ns=200 * NS_PER_MS, lost_after_timeouts=3, placeholder_ns=0)
    pair = Pair(cfg)
    try:
        for _ in range(3):
            assert pair.py.observe()[4] == ""
            pair.call("submit", pair.next_id, 0x20, 1, True, 6, b"", 0, pair.now)
            pair.next_id += 1
            pair.call("frames", pair.now)
            pair.now += 11 * NS_PER_MS
            pair.call("poll", pair.now)
            pair.now += 100 * NS_PER_MS
            pair.call("poll", pair.now)
        assert "in a row" in pair.py.observe()[4] and "lost: timeouts in a row" in SEEN
    finally:
        pair.close()


def test_the_traces_reach_every_outcome() -> None:
    """Witness that the Hypothesis traces above reach what they claim to compare (it runs after
    them: pytest keeps a file's order, with or without xdist's --dist loadfile)."""
    assert SEEN, "run the whole file: this test reads what test_c_core_matches_the_python_core reached"
    flags = {f"flag {1 << k}" for k in range(11)} | {"flag 0"}
    wanted = flags | {"lost: silence", "lost: timeouts in a row", "data", "stray", "late response",
                      "released placeholder", "bad USB header"}
    assert wanted <= set(SEEN), f"never reached: {sorted(wanted - set(SEEN))}"


@pytest.mark.parametrize("kind", [RS232, USB])
def test_a_long_busy_trace_completes_every_request_alike(kind: int) -> None:
    """Thousands of steps at 1 kHz with losses and corruption (a seeded trace, not Hypothesis)."""
    rnd = random.Random(kind)
    cfg = Config(kind, 15 if kind == USB else 4, 50 * NS_PER_MS if kind == USB else 100 * NS_PER_MS)
    pair = Pair(cfg)
    try:
        for _ in range(3000):
            for _ in range(rnd.randrange(0, 4)):
                pair.call("submit", pair.next_id, 0x20, 1, True, 6, b"", 0, pair.now)
                pair.next_id += 1
            pair.call("frames", pair.now)
            inflight = [t for t in pair.py.inflight() if not t.done]
            if inflight and rnd.random() < 0.9:
                frames = [response_bytes(rnd, t, 0) for t in inflight[:rnd.randrange(1, len(inflight) + 1)]]
                if rnd.random() < 0.05:
                    b = bytearray(frames[0])
                    b[rnd.randrange(len(b))] ^= 0x10
                    frames[0] = bytes(b)
                if rnd.random() < 0.05:
                    frames = frames[1:]
                stream = b"".join(frames)
                if kind == USB:
                    stream = UsbBatchHeader(frame=1, count=len(frames)).encode() + stream
                pair.call("receive", stream, pair.now)
            pair.now += NS_PER_MS
            pair.call("poll", pair.now)
        assert pair.completions > 2000
    finally:
        pair.close()


def test_the_comparison_catches_a_difference() -> None:
    """A C core whose timeout is 1 ns longer than the reference's must be caught: the comparison
    is able to fail."""
    cfg = Config(RS232, 4, 100 * NS_PER_MS)
    pair = Pair(cfg, Config(RS232, 4, 100 * NS_PER_MS + 1))
    try:
        pair.call("submit", 0, 8, 1, True, 6, b"", 0, 0)
        with pytest.raises(AssertionError, match="state differs"):  # its deadline is 1 ns later
            pair.call("frames", 0)
        with pytest.raises(AssertionError, match="completions differ"):  # and it has not timed out yet
            pair.call("poll", 100 * NS_PER_MS)
    finally:
        pair.close()
