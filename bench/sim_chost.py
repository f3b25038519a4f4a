#!/usr/bin/env python3
"""Simulated seconds per CPU second of the PD control loops on the C host library in the
simulation (sim/world/sim_host_c.c, urb_sim.chost) against the Python host library (SimManager),
the same loop at the same seed (issue #38).

Workloads (the start-up and discovery, through the Python library in both, are not timed):
  pd-rs232, pd-usb  fig18_19's loop: one motor driver read and commanded every 1-ms tick
  legs6             six motor drivers on two USB bridges read and commanded every 2-ms tick (fig20's rate)

A/B alternating (python, c, python, c, ...), best of --repeat; the load average is printed with the
numbers, as CPU time per simulated second is inflated by other jobs. Each pair is also checked to
agree (the commands and true shaft angles equal; with --trace the trace hash too): a speed-up that changed the run
would not count.

    python3 bench/sim_chost.py [--seconds 6] [--repeat 3] [--only pd-rs232,legs6]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(REPO / "sim"), str(REPO / "host")]

from urb_sim.experiments.control import Axis, Pd, _control, _control_c, _enable  # noqa: E402
from urb_sim.native import App  # noqa: E402
from urb_sim.system import NS_PER_MS, System  # noqa: E402

WORKLOADS = {"pd-rs232": (["rs232"], 1, NS_PER_MS), "pd-usb": (["usb"], 1, NS_PER_MS),
             "legs6": (["usb", "usb"], 3, 2 * NS_PER_MS)}


def one(workload: str, host: str, seed: int, seconds: float, trace: bool = False) -> tuple[float, tuple[object, ...]]:
    """CPU seconds of the control phase, and what must agree between the hosts."""
    uplinks, per_bridge, period = WORKLOADS[workload]
    s = System(seed=seed, params={"motor.leg_gravity": 0.0})
    places = []
    for up in uplinks:
        b = s.bridge(up)
        for i in range(per_bridge):
            places.append((b, s.node(b, App.MOTOR, 0x20 + i, len(places)), 0x20 + i))
    if trace:
        s.world.trace(None)  # the hash only, but every line is still formatted: ~half a C-host run's CPU
    s.start()
    axes = [Axis(s.urb.find_node("MotorDriver", k), Pd(12.0, 0.05)) for k in range(len(places))]
    for a in axes:
        _enable(a)
    s.host.advance(5 * NS_PER_MS)
    sines = [(4 * math.pi, 2 * math.pi * (0.5 + 0.1 * k)) for k in range(len(axes))]
    truth: list[list[tuple[int, float, float]]] = [[] for _ in axes]
    marks: list[list[tuple[int, int, int]]] = [[] for _ in axes]
    t0 = time.process_time()
    if host == "c":
        _control_c(s, axes, places, sines, seconds, truth, marks, period).close()
    else:
        refs = [(lambda t, a=amp, w=omega: a * math.sin(w * t * 1e-9)) for amp, omega in sines]
        _control(s, axes, list(refs), seconds, [0], truth, [m for _, m, _ in places], marks, period)
    cpu = time.process_time() - t0
    fails = sum(a.fails for a in axes)
    if fails:
        raise SystemExit(f"{workload} on {host}: {fails} failed feedback reads: the workload overloads its links")
    same = (s.world.trace_hash, tuple(tuple(a.commands) for a in axes), tuple(tuple(t) for t in truth))
    s.close()
    return cpu, same


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=6.0, help="simulated seconds of control per run (default 6)")
    ap.add_argument("--repeat", type=int, default=3, help="A/B pairs per workload (default 3)")
    ap.add_argument("--seed", type=int, default=18)
    ap.add_argument("--only", default=",".join(WORKLOADS), help="comma-separated workloads")
    ap.add_argument("--trace", action="store_true", help="keep the world's trace hash (and compare it), as the "
                    "agreement test does; off by default, as in the experiments")
    args = ap.parse_args()
    print(f"load average at start: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    for w in args.only.split(","):
        best = {"python": math.inf, "c": math.inf}
        for _ in range(args.repeat):
            runs = {h: one(w, h, args.seed, args.seconds, args.trace) for h in ("python", "c")}
            if runs["python"][1] != runs["c"][1]:
                print(f"{w}: the two hosts' runs differ (trace, commands or truth): not a measurement")
                return 1
            for h in best:
                best[h] = min(best[h], runs[h][0])
        py, c = args.seconds / best["python"], args.seconds / best["c"]
        print(f"{w:<9} python {py:7.1f} sim s/CPU s   c {c:7.1f} sim s/CPU s   c/python {c / py:5.1f}x   "
              f"(best of {args.repeat}, agree: yes; load {os.getloadavg()[0]:.2f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
