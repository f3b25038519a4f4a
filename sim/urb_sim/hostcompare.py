"""The reference comparison of the two host libraries in the simulation (issue #38): one PD run
(experiments/control.py, pd_tracking) at one seed on the Python host library and on the C host
library (urb_sim.chost), compared.

What must be equal, and is (bit for bit, no tolerance):
  * every request of the control loop, in submission order: bridge, address, mailbox, read/write,
    the host-clock instant it was submitted, the instant it completed, its flags; so also the count
    per flag and that each completed exactly once;
  * every command the PD computed (mV, in order) and the true shaft angle and reference sampled at
    every loop period; so also the tracking lag, the RMS error and the experiment's verdicts;
  * the world's trace (its running hash): every event of the firmware, buses and plant, when both
    runs kept it (tests/sim/test_chost.py; fig18_19 does not: tracing costs about half of a C-host
    run's CPU, and the requests' instants and the true angles already show the world's course).
Why nothing may differ: both hosts run the same core (host/c/core; the Python library's own
reference cores are rule-for-rule the same, tests/host_c/test_differential.py), schedule their work
at the same instants in the same order (sim_host_c.c reproduces SimHost and SimManager), and the
simulated host CPU charges no time to host code in either (SimHost runs callbacks in zero virtual
time; so does the C driver): the host CPU model is the OS tick, scheduling and I/O wake-up
latencies, the same for both. A real C host spends less CPU per request than the Python one; the
simulation does not model that cost for either, so it cannot show it.
"""

from __future__ import annotations

import time
from collections import Counter
from dataclasses import dataclass, field

from .chost import Request
from .system import System


@dataclass
class HostRun:
    host: str
    requests: list[Request]
    commands: list[int]
    truth: list[tuple[int, float, float]]
    trace_hash: int | None  #: None: the world's trace was off (it costs ~half a C-host run's CPU)
    lag_ms: float
    rms_rad: float
    fails: int
    cpu_s: float

    def flag_counts(self) -> Counter[int]:
        return Counter(r.flags for r in self.requests if r.done_ns is not None)

    def incomplete(self) -> int:
        return sum(r.done_ns is None for r in self.requests)


@dataclass
class Agreement:
    python: HostRun
    c: HostRun
    differences: list[str] = field(default_factory=list)

    @property
    def agrees(self) -> bool:
        return not self.differences


def host_run(host: str, record: list[Request], commands: list[int], truth: list[tuple[int, float, float]],
             lag: float, rms: float, fails: int, system: System, cpu_s: float, traced: bool) -> HostRun:
    """A finished pd_tracking run (its record kept; its trace hash when `traced`) as a HostRun."""
    return HostRun(host, record, list(commands), truth, system.world.trace_hash if traced else None, lag, rms, fails,
                   cpu_s)


def run(host: str, uplink: str, seed: int, seconds: float, kp: float, kd: float, trace: bool = True) -> HostRun:
    from .experiments.control import pd_tracking  # control.py compares its runs with this module

    record: list[Request] = []
    t0 = time.process_time()
    axis, truth, lag, rms, s = pd_tracking(uplink, seed, seconds, kp, kd, host=host, record=record, trace=trace)
    out = host_run(host, record, axis.commands, truth, lag, rms, axis.fails, s, time.process_time() - t0, trace)
    s.close()
    return out


def first_difference(a: list[object], b: list[object], what: str) -> str | None:
    """Where two sequences first differ, in words; None when equal."""
    for i, (x, y) in enumerate(zip(a, b)):
        if x != y:
            return f"{what} {i}: Python {x}, C {y}"
    if len(a) != len(b):
        return f"{what}: Python has {len(a)}, C {len(b)}"
    return None


def compare_runs(a: HostRun, b: HostRun) -> Agreement:
    """The differences between a run on each host library (in either order)."""
    py, c = (a, b) if a.host == "python" else (b, a)
    agreement = Agreement(py, c)
    for run_ in (py, c):
        if run_.incomplete():
            agreement.differences.append(f"{run_.host}: {run_.incomplete()} request(s) never completed")
    for diff in (first_difference(list(py.requests), list(c.requests), "request"),
                 first_difference(list(py.commands), list(c.commands), "command"),
                 first_difference(list(py.truth), list(c.truth), "sample")):
        if diff is not None:
            agreement.differences.append(diff)
    if py.flag_counts() != c.flag_counts():
        agreement.differences.append(f"count per flag: Python {dict(py.flag_counts())}, C {dict(c.flag_counts())}")
    if py.trace_hash is not None and c.trace_hash is not None and py.trace_hash != c.trace_hash:
        agreement.differences.append(f"trace hash: Python {py.trace_hash:016x}, C {c.trace_hash:016x}")
    return agreement


def compare(uplink: str, seed: int, seconds: float, kp: float, kd: float) -> Agreement:
    """One PD run on each host library, compared (the module's docstring says what must be equal)."""
    return compare_runs(run("python", uplink, seed, seconds, kp, kd), run("c", uplink, seed, seconds, kp, kd))
