"""The C host library (host/c/core) on the simulated host CPU, with no Python in the loop (issue #38).

`CHost(system)` takes every bridge of a started, discovered `System` over from its Python
`SimManager`s, at a quiet instant (nothing queued or in flight): one `urb_core_t` per bridge goes on
from the Python core's position (its next sequence number and USB frame counter, its window, the
timers its manager had armed), and from then on sim/world/sim_host_c.c runs the world, the cores
and the application (the PD loop of experiments/control.py, plain periodic reads) in C. SimHost's
and SimManager's scheduling is reproduced step for step, so the C run is the run the Python
library would have made: tests/sim/test_chost.py requires the same requests, outcomes, instants,
commands, true shaft angles and trace.

    s = System(seed=18); b = s.bridge("rs232"); n = s.node(b, App.MOTOR, 0x20, 0); s.start()
    host = CHost(s)
    axis = host.axis(b, n, 0x20, kp=12.0, kd=0.05, amp=4 * math.pi, omega=math.pi)
    host.loop(NS_PER_MS, count=1000, t0_ns=...)
    host.advance_to(s.world.now + 1_050_000_000)
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from ctypes import c_double, c_int32, c_int64, c_uint32
from dataclasses import dataclass
from typing import Any

from urb.managers.base import Transfer
from urb.managers.sim import SimManager

from .native import lib
from .system import System

NO_TIME = -(1 << 63)
CHUNK = 4096


class HandOverError(RuntimeError):
    """The Python host library is not at a quiet instant; the message says what is pending."""


@dataclass(frozen=True)
class Request:
    """One request as it completed: what, when submitted and dispatched (host clock), its flags."""

    bridge: int
    address: int
    mailbox: int
    read: bool
    submitted_ns: int
    done_ns: int | None  #: None: never completed
    flags: int


def position(mgr: SimManager) -> tuple[int, int, int]:
    """(window, next sequence number, next USB frame counter) of `mgr`'s core: the reference core
    keeps them, the C core through the extension counts them (every request it was given went on
    the wire when none failed, so the count of submissions is the count of sequence numbers used;
    HandOverError otherwise)."""
    core: Any = mgr.core
    seq = getattr(core, "_next_seq", None)
    if seq is None:
        if mgr.stats.failed:
            raise HandOverError(f"{mgr.name}: {mgr.stats.failed} request(s) failed before the hand-over, so the C "
                                "core's count of sequence numbers used is unknown (a refused one never went out); "
                                "hand over before any request fails, or run on the Python reference cores "
                                "(URB_HOST_CORE=python)")
        seq = (1 + mgr.stats.submitted) % 16
    frame = getattr(core, "_frame", None)
    if frame is None:
        frame = int(getattr(core, "frames_written", 0)) % 0xFFFF + 1
    return int(core.window), int(seq), int(frame)


def pending_of(system: System, fn: Callable[[], None]) -> tuple[int, bool, int]:
    """(bridge, is a USB frame tick, timer deadline) of a pending SimHost event, which must be one
    of its managers': a frame tick (the bound `_frame_tick`) or a timer (`_arm`'s closure over the
    deadline); HandOverError for anything else (an application's Loop)."""
    for b, mgr in system.managers.items():
        if fn == mgr._frame_tick:
            return b, True, 0
    closure = inspect.getclosurevars(fn).nonlocals if inspect.isfunction(fn) else {}
    for b, mgr in system.managers.items():
        if closure.get("self") is mgr and isinstance(closure.get("deadline"), int):
            return b, False, int(closure["deadline"])
    raise HandOverError(f"the Python host has an application event pending ({fn!r}): stop it before handing the "
                        "bridges to the C host")


class CHost:
    """The C host driving every bridge of a started `System` (see the module's docstring)."""

    def __init__(self, system: System) -> None:
        self.system = system
        self._lib = lib()
        world = system.world
        for b, mgr in system.managers.items():
            if mgr.core.busy() or mgr._pending_cb:
                raise HandOverError(f"{mgr.name}: requests are still queued or in flight; hand over at a quiet "
                                    "instant (advance the host until every request completed)")
        pending = [(t_v, pending_of(system, fn)) for t_v, _, fn in sorted(system.host._events, key=lambda e: e[:2])]
        self._h = self._lib.urbsim_chost_new(world.handle())
        if not self._h:
            raise MemoryError("urbsim_chost_new failed")
        for b, uplink in system.bridges:
            mgr = system.managers[b]
            window, seq, frame = position(mgr)
            if self._lib.urbsim_chost_bridge(self._h, b, int(uplink == "usb"), window, seq, frame) != 0:
                raise ValueError(f"bridge {b}: the C core refused window {window}, sequence {seq}, frame {frame}")
        for t_v, (b, frame, deadline) in pending:  # in the Python host's order: same-instant events keep it
            self._check(self._lib.urbsim_chost_pending(self._h, b, int(frame), deadline, t_v), f"pending event of {b}")
        system.host._events.clear()  # they are the C host's now
        self._axes = 0

    def close(self) -> None:
        if self._h:
            self._lib.urbsim_chost_free(self._h)
            self._h = None

    def __del__(self) -> None:
        if getattr(self, "_h", None):
            self.close()

    def _check(self, rc: int, what: str) -> int:
        if rc < 0:
            raise ValueError(f"{what}: refused by the C host (rc {rc})")
        return rc

    def axis(self, bridge: int, node: int, address: int, *, kp: float, kd: float, amp: float = 0.0,
             omega: float = 0.0, limit: float = 12.0, leg: int | None = None) -> int:
        """A PD axis (control.py's Axis and Pd): reference amp sin(omega t), the true angle sampled
        every period (`samples`); or, with `leg`, gait.py's reference for that leg, a row logged at
        every feedback (`log`). Returns its index."""
        return self._check(self._lib.urbsim_chost_axis(self._h, bridge, node, address, kp, kd, limit, amp, omega,
                                                       -1 if leg is None else leg),
                           f"axis at {address:#x} on bridge {bridge}")

    def log(self, axis: int) -> list[tuple[float, float, float, float, float, float]]:
        """A gait axis's rows: (t s, reference, true shaft, measured V, measured I, true current)."""
        out: list[tuple[float, float, float, float, float, float]] = []
        rows = (c_double * (6 * CHUNK))()
        while True:
            n = self._check(self._lib.urbsim_chost_log(self._h, axis, len(out), rows, CHUNK), "log")
            out.extend((rows[6 * i], rows[6 * i + 1], rows[6 * i + 2], rows[6 * i + 3], rows[6 * i + 4],
                        rows[6 * i + 5]) for i in range(n))
            if n < CHUNK:
                return out

    def read(self, bridge: int, address: int, mailbox: int, length: int, every: int) -> int:
        """A plain read every `every` loop periods; returns its index."""
        return self._check(self._lib.urbsim_chost_read(self._h, bridge, address, mailbox, length, every),
                           f"read of {address:#x}/{mailbox} on bridge {bridge}")

    def write(self, bridge: int, address: int, mailbox: int, data: bytes, every: int) -> int:
        """A plain write of `data` every `every` loop periods; returns its index (plain requests go
        out in the order they were added)."""
        return self._check(self._lib.urbsim_chost_write(self._h, bridge, address, mailbox, data, len(data), every),
                           f"write of {address:#x}/{mailbox} on bridge {bridge}")

    def submit_write(self, bridge: int, address: int, mailbox: int, data: bytes) -> None:
        """Submit one write now (the application's set-up, e.g. a MotorConfig)."""
        self._check(self._lib.urbsim_chost_submit(self._h, bridge, address, mailbox, data, len(data)),
                    f"write to {address:#x}/{mailbox} on bridge {bridge}")

    def loop(self, period_ns: int, count: int, t0_ns: int) -> None:
        """Start the application's thread (control.py's Loop with its tick)."""
        self._check(self._lib.urbsim_chost_loop(self._h, period_ns, count, t0_ns), "loop")

    def advance_to(self, t_v: int) -> None:
        rc = self._lib.urbsim_chost_advance_to(self._h, t_v)
        self.system.world.moved()
        if rc != 0:
            raise RuntimeError(f"the C host failed ({self.stat('errors'):.0f} errors: out of memory, its transfer "
                               "pool exhausted by a loop outrunning its link, or a core refusing a request)")

    def stat(self, name: str) -> float:
        return float(self._lib.urbsim_chost_stat(self._h, name.encode()))

    def samples(self, axis: int) -> list[tuple[int, float, float]]:
        """(t ns since t0, true shaft angle rad, reference rad) at every period, as control.py's truth."""
        out: list[tuple[int, float, float]] = []
        t, p, r = (c_int64 * CHUNK)(), (c_double * CHUNK)(), (c_double * CHUNK)()
        while True:
            n = self._check(self._lib.urbsim_chost_samples(self._h, axis, len(out), t, p, r, CHUNK), "samples")
            out.extend(zip(t[:n], p[:n], r[:n]))
            if n < CHUNK:
                return out

    def commands(self, axis: int) -> list[int]:
        out: list[int] = []
        mv = (c_int32 * CHUNK)()
        while True:
            n = self._check(self._lib.urbsim_chost_commands(self._h, axis, len(out), mv, CHUNK), "commands")
            out.extend(mv[:n])
            if n < CHUNK:
                return out

    def requests(self) -> list[Request]:
        out: list[Request] = []
        what, sub, done, flags = (c_uint32 * CHUNK)(), (c_int64 * CHUNK)(), (c_int64 * CHUNK)(), (c_uint32 * CHUNK)()
        while True:
            n = self._check(self._lib.urbsim_chost_requests(self._h, len(out), what, sub, done, flags, CHUNK),
                            "requests")
            for i in range(n):
                w = what[i]
                out.append(Request(w >> 24, (w >> 16) & 0xFF, (w >> 8) & 0xFF, bool(w & 1), sub[i],
                                   None if done[i] == NO_TIME else done[i], flags[i]))
            if n < CHUNK:
                return out


def record_python_requests(system: System) -> list[tuple[int, Transfer]]:
    """From now on, every transfer the Python managers of `system` are given, with its bridge, in
    submission order (their outcomes are read once the run is over): the reference run's record."""
    log: list[tuple[int, Transfer]] = []
    for b, mgr in system.managers.items():
        def submit(t: Transfer, b: int = b, inner: Callable[[Transfer], None] = mgr.submit) -> None:
            log.append((b, t))
            inner(t)
        mgr.submit = submit  # type: ignore[method-assign]
    return log


def as_requests(log: list[tuple[int, Transfer]]) -> list[Request]:
    return [Request(b, t.address, t.mailbox, t.read, t.submitted_ns, t.completed_ns if t.done else None, int(t.flags))
            for b, t in log]
