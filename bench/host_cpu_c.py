#!/usr/bin/env python3
"""CPU cost of the SensoRHex load through the native host library (host/c), and its projection for
a 500-MHz Geode-class core (issue #38).

The load (bench/host_cpu_c.c): two USB bridges with three motor drivers each, every motor read and
commanded every millisecond, three sensors read at 100 Hz over RS232: 12.3 requests per ms, in real
time for --seconds. The bridges are the bridge firmware compiled for the host, in other processes:
the USB ones behind SOCK_SEQPACKET pairs (bench/host_cpu_c_bridges.c; one write = one bulk-OUT, one
read = one bulk-IN, as a kernel driver's character device), the RS232 one the hosted bridge program on
a pty. What is measured is the host process's CPU time (getrusage: the library, its system calls and
the control loop), per request completed, and that times 12.3 requests per ms as a share of one core
(the share over the run's wall time too: lower when other jobs stall the run below the load's rate).
The load runs in the two patterns a 1-kHz control program can use (urb_loop.h), each printed as a row:
cyclic, the goal's row (the program sleeps until its 1-ms tick with urb_sleep_until, calls
urb_loop_service, which reads everything that came during the period without waiting, and submits: one
wake-up per tick, the EtherCAT master's pattern; what a fixed-period control program uses, since it
only reads its responses at the tick anyway), and event-driven (it waits in urb_loop_run_once until
input, the library's deadline or its tick: a wake-up for every IN transfer and RS232 response, the
callbacks up to a period earlier). A third run has the event-driven program ppoll the loop's
descriptor and call urb_loop_run_once(0), as a program with descriptors of its own would. The
wake-ups per ms (voluntary context switches) are counted, and the floor is measured for each pattern:
the same program's loop with no bridge, woken as often by its own timeout and doing nothing else.

Then the same program under valgrind's callgrind, for --cg-seconds of load and for none, gives the
user-space instructions per request (the difference, so start-up cancels), and under strace -c the
system calls per request, for each pattern. This VM has no hardware counters (perf counts no instructions) and its
getrusage splits user and system time unreliably, so the kernel's instructions are estimated: KERNEL_INSTR_PER_CALL (4000) per system call, about what a read, write or epoll_wait on a
socket or pty costs in a current Linux kernel (0.5 to 2 us on a 2-4 GHz core). The projection for a
500-MHz Geode-class core is (user instructions + system calls x 4000) per second of the load / (500
MHz x IPC), at IPC 1 (Geode LX's best case for integer code) and 0.5.

Next to it, the Python library on the same load, from bench/host_cpu.py's numbers (`make bench`
runs that first, twice): on its Python reference cores (build/bench/host_cpu.json) and on the C core
through urb.managers._native (build/bench/host_cpu_native.json; issue #38's goal: at most 10 % of
one core): CPU per request and share of a core, and the ratios. Then the whole load run from one
Python program on the C core (bench/host_cpu_sensorhex.py's build/bench/host_cpu_sensorhex.json: both
APIs, threaded and cyclic runtime, on these same bridges), each row next to the goal and to the C
library's cyclic row.

    python3 bench/host_cpu_c.py [--seconds 5] [--cg-seconds 2] [--python-json PATH] [--sensorhex-json PATH]

Prints a table with ratios; never fails on timing (it fails, saying why, when it cannot measure).
Numbers also go to build/bench/host_cpu_c.json.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import shutil
import socket
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "build" / "bench"
HOST = REPO / "build" / "host_c" / "bench" / "host_cpu_c"
BRIDGES = REPO / "build" / "host_c" / "bench" / "host_cpu_c_bridges"
HOSTED = REPO / "build" / "firmware" / "urb-bridge-hosted"
GOAL_SHARE = 0.02           # issue #38: at most 2 % of one core of this machine
GOAL_SHARE_PY_ON_C = 0.10   # issue #38: the Python API on the C core, at most 10 %
GEODE_HZ = 500e6
KERNEL_INSTR_PER_CALL = 4000
PER_MS = 12.3


def make(*targets: str) -> None:
    proc = subprocess.run(["make", "-s", *targets], cwd=REPO, capture_output=True, text=True)
    if proc.returncode != 0:
        sys.exit(f"host_cpu_c: cannot build {' '.join(targets)}:\n{proc.stdout[-2000:]}{proc.stderr[-3000:]}")


CYCLIC, EVENT, POLL = "cyclic", "", "poll"  # the host program's patterns (bench/host_cpu_c.c)


def run_floor(seconds: float, wakes_per_ms: float, mode: str = "") -> dict[str, Any]:
    """The host program's loop with no bridge, woken `wakes_per_ms` times per ms (by its own timeout,
    or in the cyclic pattern by urb_sleep_until, then urb_loop_service) and doing nothing else: what
    the wake-ups alone cost on this machine."""
    period_ns = int(1e6 / max(wakes_per_ms, 0.1))
    proc = subprocess.run([str(HOST), "floor", str(seconds), str(period_ns)] + ([CYCLIC] if mode == CYCLIC else []),
                          capture_output=True, text=True,
                          timeout=seconds * 20 + 60)
    if proc.returncode != 0:
        sys.exit(f"host_cpu_c: the floor run failed (exit {proc.returncode}):\n{proc.stderr[-3000:]}")
    result: dict[str, Any] = json.loads(proc.stdout.strip().splitlines()[-1])
    return result


def run_load(seconds: float, prefix: list[str], slow: bool = False, mode: str = CYCLIC) -> dict[str, Any]:
    """One run of the load: bridges up, the host program (maybe under `prefix`), its JSON. `mode`: CYCLIC
    (urb_loop_service once per tick), EVENT (waits in urb_loop_run_once) or POLL (ppolls the loop's
    descriptor, then urb_loop_run_once(0))."""
    with tempfile.TemporaryDirectory() as tmp:
        link = Path(tmp) / "pty"
        rs232 = subprocess.Popen([str(HOSTED), "--node", "battery,0,0x30", "--node", "imu,0,0x31", "--node", "ir,0,0x32",
                                  "--link", str(link), "--seconds", "3600"], stdout=subprocess.PIPE, text=True)
        pairs = [socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET) for _ in range(2)]
        for host_end, _ in pairs:
            host_end.setblocking(False)
        bridge_fds = [b.fileno() for _, b in pairs]
        host_fds = [h.fileno() for h, _ in pairs]
        bridges = subprocess.Popen([str(BRIDGES), *map(str, bridge_fds)], pass_fds=bridge_fds, stdout=subprocess.PIPE,
                                   text=True)
        for _, b in pairs:
            b.close()
        try:
            assert rs232.stdout is not None and bridges.stdout is not None
            rs232.stdout.readline()
            bridges.stdout.readline()  # "ready"
            env = dict(os.environ, URB_STATE_DIR=tmp)
            proc = subprocess.run([*prefix, str(HOST), *map(str, host_fds), str(link), str(seconds)] + (["slow"] if slow else [])
                                  + ([mode] if mode else []),
                                  pass_fds=host_fds,
                                  capture_output=True, text=True, env=env, timeout=seconds * 200 + 120)
        finally:
            for h, _ in pairs:
                h.close()
            bridges.wait(10)
            rs232.terminate()
            rs232.wait(10)
        if proc.returncode != 0:
            sys.exit(f"host_cpu_c: the load run failed (exit {proc.returncode}):\n{proc.stderr[-3000:]}")
        result: dict[str, Any] = json.loads(proc.stdout.strip().splitlines()[-1])
        result["stderr"] = proc.stderr
        return result


def callgrind_ir(seconds: float, mode: str) -> tuple[int, int]:
    """(instructions, requests completed) of the host program under callgrind."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "cg.out"
        res = run_load(seconds, ["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}"], slow=True, mode=mode)
        return callgrind_total(res["stderr"], out, "host_cpu_c"), int(res["ok"]) + int(res["failed"])


def callgrind_total(stderr: str, out: Path, who: str) -> int:
    """The instructions callgrind counted in a run: from its summary on stderr, else from its output
    file; exits naming `who` when neither has one."""
    m = re.search(r"Collected : (\d+)", stderr)
    if m is None:
        text = out.read_text(encoding="utf-8", errors="replace")
        m = re.search(r"^summary: (\d+)", text, re.M) or re.search(r"^totals: (\d+)", text, re.M)
    if m is None:
        sys.exit(f"{who}: callgrind gave no instruction count")
    return int(m.group(1))


def syscalls_per_request(seconds: float, mode: str) -> tuple[float, dict[str, float]]:
    """System calls of the host program per request completed, in all and per call name (strace -c)."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "strace.txt"
        base = run_load(0, ["strace", "-c", "-f", "-o", str(Path(tmp) / "base.txt")], mode=mode)
        res = run_load(seconds, ["strace", "-c", "-f", "-o", str(out)], mode=mode)
        del base

        def calls(path: Path) -> dict[str, int]:
            counts: dict[str, int] = {}
            for line in path.read_text(encoding="utf-8").splitlines():
                f = line.split()
                if len(f) >= 5 and f[0].replace(".", "").isdigit() and f[3].isdigit() and f[-1] != "total":
                    counts[f[-1]] = int(f[3])
            return counts

        load, start = calls(out), calls(Path(tmp) / "base.txt")
        diff = {k: v - start.get(k, 0) for k, v in load.items() if v - start.get(k, 0) > 0}
        n = int(res["ok"]) + int(res["failed"])
        return sum(diff.values()) / max(1, n), {k: v / max(1, n) for k, v in diff.items()}


def python_numbers(path: Path) -> dict[str, float] | None:
    """The Python library's SensoRHex numbers from bench/host_cpu.py's JSON, or None without it."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        return {"share": float(data["sensorhex_core_share"]),
                "usb_us": float(data["usb_sensorhex"]["us_per_request"]),
                "rs232_us": float(data["rs232_pty"]["us_per_request"]),
                "usb_core_us": float(data["usb_core_us"]), "rs232_core_us": float(data["rs232_core_us"]),
                "quick": float(bool(data.get("quick", False))),
                "cycle_share": float(data.get("sensorhex_cycle_share", 0.0))}
    except (OSError, ValueError, KeyError, TypeError):
        return None


def whole_load_rows(path: Path) -> list[dict[str, Any]] | None:
    """bench/host_cpu_sensorhex.py's rows (the whole load from one Python program), or None."""
    try:
        rows = json.loads(path.read_text(encoding="utf-8"))["rows"]
        return [{"api": str(r["api"]), "runtime": str(r["runtime"]), "us_per_request": float(r["us_per_request"]),
                 "share_at_12300": float(r["share_at_12300"])} for r in rows]
    except (OSError, ValueError, KeyError, TypeError):
        return None


def whole_load_projections(path: Path) -> list[dict[str, Any]]:
    """bench/host_cpu_sensorhex.py's 500-MHz projections of the cyclic Python programs ([] without)."""
    try:
        return list(json.loads(path.read_text(encoding="utf-8")).get("projections", []))
    except (OSError, ValueError, TypeError, AttributeError):
        return []


def side_by_side(py: dict[str, float], on_c: dict[str, float] | None, c_share: float, c_us: float) -> None:
    """The C library and the Python API on the C core (`on_c`, when measured) next to the Python
    library on its Python cores on the SensoRHex load, as ratios to it."""
    per_s = PER_MS * 1000
    py_us = py["share"] * 1e6 / per_s  # CPU per request over the SensoRHex mix (USB and RS232)
    print("SensoRHex load, C library next to the Python library (bench/host_cpu.py"
          f"{', its quick run' if py['quick'] else ''}; Python: per-request costs measured on one USB "
          "bridge's load and on RS232, scaled to the whole load; C: the whole load measured)")
    print()
    if on_c is None:
        print("| measure | Python library | C library | C / Python |")
        print("|---|---:|---:|---:|")
        print(f"| CPU per request over the SensoRHex mix | {py_us:.1f} us | {c_us:.2f} us | {c_us / py_us:.3f} |")
        print(f"| share of one core of this machine at 12.3 requests/ms | {py['share'] * 100:.1f} % | "
              f"{c_share * 100:.2f} % | {c_share / py['share']:.3f} |")
        print(f"| Python / C (times less CPU in C) | | | {py['share'] / c_share:.0f} x |")
        return
    on_c_us = on_c["share"] * 1e6 / per_s
    print("| measure | Python library, Python core | Python API on the C core | C library | "
          "on C core / Python | C / Python |")
    print("|---|---:|---:|---:|---:|---:|")
    print(f"| CPU per request over the SensoRHex mix | {py_us:.1f} us | {on_c_us:.1f} us | {c_us:.2f} us | "
          f"{on_c_us / py_us:.3f} | {c_us / py_us:.3f} |")
    print(f"| share of one core of this machine at 12.3 requests/ms | {py['share'] * 100:.1f} % | "
          f"{on_c['share'] * 100:.1f} % | {c_share * 100:.2f} % | {on_c['share'] / py['share']:.3f} | "
          f"{c_share / py['share']:.3f} |")
    print(f"| protocol core alone, us per request, USB / RS232 | {py['usb_core_us']:.1f} / {py['rs232_core_us']:.1f} | "
          f"{on_c['usb_core_us']:.1f} / {on_c['rs232_core_us']:.1f} | | "
          f"{on_c['usb_core_us'] / py['usb_core_us']:.3f} / {on_c['rs232_core_us'] / py['rs232_core_us']:.3f} | |")
    print(f"| Python API on the C core: share of one core / goal ({GOAL_SHARE_PY_ON_C * 100:.0f} %) | | "
          f"{on_c['share'] / GOAL_SHARE_PY_ON_C:.2f} | | | |")
    if py["cycle_share"] and on_c["cycle_share"]:  # the USB motors through urb.cycle.Cycle (polled)
        print(f"| share of one core, USB motors through the cycle API (polled) | {py['cycle_share'] * 100:.1f} % | "
              f"{on_c['cycle_share'] * 100:.1f} % | | {on_c['cycle_share'] / py['cycle_share']:.3f} | |")
        print(f"| cycle API on the C core: share of one core / goal ({GOAL_SHARE_PY_ON_C * 100:.0f} %) | | "
              f"{on_c['cycle_share'] / GOAL_SHARE_PY_ON_C:.2f} | | | |")


def measure(seconds: float, mode: str) -> dict[str, Any]:
    """The load in one pattern, and the floor at its rate of wake-ups."""
    res = run_load(seconds, [], mode=mode)
    requests = int(res["ok"]) + int(res["failed"])
    us_per_request = float(res["cpu_s"]) * 1e6 / max(1, requests)
    # the wake-ups while ticking, not those of the settling after the last tick
    wakes_per_ms = float(res["tick_sleeps"]) / max(1.0, float(res["tick_wall_s"]) * 1000)
    floor = run_floor(min(seconds, 2.0), wakes_per_ms, mode)
    return {"run": res, "share": float(res["cpu_s"]) / float(res["wall_s"]),
            "per_s": requests / float(res["wall_s"]), "us_per_request": us_per_request,
            "share_at_12300": us_per_request * PER_MS * 1000 / 1e6,  # what the load costs at its rate
            "wakes_per_ms": wakes_per_ms, "floor": floor,
            "floor_share": float(floor["cpu_s"]) / float(floor["wall_s"])}


def instructions(cg_seconds: float, mode: str) -> dict[str, Any]:
    """User instructions (callgrind) and system calls (strace) per request of one pattern, and the
    projection for a 500-MHz core."""
    ir_load, n_load = callgrind_ir(cg_seconds, mode)
    ir_base, _ = callgrind_ir(0, mode)
    ir_per_request = (ir_load - ir_base) / max(1, n_load)
    calls_per_request, calls = syscalls_per_request(cg_seconds, mode)
    instr_per_s = (ir_per_request + calls_per_request * KERNEL_INSTR_PER_CALL) * PER_MS * 1000
    cg: dict[str, Any] = {"ir_load": ir_load, "ir_base": ir_base, "requests": n_load, "ir_per_request": ir_per_request,
                          "syscalls_per_request": calls_per_request, "syscalls": calls,
                          "instr_per_s_at_12300": instr_per_s}
    for ipc in (1.0, 0.5):
        cg[f"geode_share_ipc{ipc}"] = instr_per_s / (GEODE_HZ * ipc)
    return cg


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=5.0, help="load run in real time (default 5)")
    ap.add_argument("--cg-seconds", type=float, default=2.0, help="load run under callgrind (default 2)")
    ap.add_argument("--python-json", type=Path, default=OUT / "host_cpu.json",
                    help="bench/host_cpu.py's numbers for the side-by-side table (default build/bench/host_cpu.json)")
    ap.add_argument("--native-json", type=Path, default=OUT / "host_cpu_native.json",
                    help="bench/host_cpu.py's numbers on the C core (default build/bench/host_cpu_native.json)")
    ap.add_argument("--sensorhex-json", type=Path, default=OUT / "host_cpu_sensorhex.json",
                    help="bench/host_cpu_sensorhex.py's numbers (default build/bench/host_cpu_sensorhex.json)")
    args = ap.parse_args(argv)
    make("bridge-hosted", "host-c-bench")
    runs = {mode: measure(args.seconds, mode) for mode in (CYCLIC, EVENT)}
    polled = run_load(args.seconds, [], mode=POLL)
    polled_us = float(polled["cpu_s"]) * 1e6 / max(1, int(polled["ok"]) + int(polled["failed"]))
    if shutil.which("valgrind") and shutil.which("strace"):
        for mode, row in runs.items():
            row["callgrind"] = instructions(args.cg_seconds, mode)
    goal, event = runs[CYCLIC], runs[EVENT]
    res = goal["run"]
    rows: dict[str, Any] = {"cyclic": goal, "event": event, "poll_run": polled, "poll_us_per_request": polled_us,
                            "poll_share_at_12300": polled_us * PER_MS * 1000 / 1e6,
                            # the goal's numbers under the keys earlier versions wrote
                            "run": res, "share": goal["share"], "us_per_request": goal["us_per_request"],
                            "share_at_12300": goal["share_at_12300"], "wakes_per_ms": goal["wakes_per_ms"],
                            "floor": goal["floor"], "floor_share": goal["floor_share"],
                            "callgrind": goal.get("callgrind", {})}
    print(f"SensoRHex load through the C host library, {args.seconds:.0f} s real time each "
          f"({platform.machine()}, {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f}; other jobs share "
          "this machine)")
    print()
    print("Two patterns (urb_loop.h): cyclic = sleep to the 1-ms tick (urb_sleep_until), urb_loop_service "
          "(every response of the period, without waiting), submit: one wake-up per tick, what a fixed-period "
          "control program uses (the goal's row); event-driven = wait in urb_loop_run_once until input, a "
          "deadline or the tick: a wake-up per IN transfer and RS232 response, callbacks up to a period earlier.")
    print()
    print("| measure | cyclic (urb_loop_service) | event-driven (urb_loop_run_once) | goal | cyclic: ratio to goal |")
    print("|---|---:|---:|---:|---:|")

    def both(label: str, fmt: Any, goal_text: str = "", ratio: str = "") -> None:
        print(f"| {label} | {fmt(goal)} | {fmt(event)} | {goal_text} | {ratio} |")

    both("requests per ms (12.3 wanted)", lambda r: f"{r['per_s'] / 1000:.2f}", f"{PER_MS}",
         f"{goal['per_s'] / 1000 / PER_MS:.2f}")
    both("requests ok / failed / not submitted",
         lambda r: f"{r['run']['ok']} / {r['run']['failed']} / {r['run']['not_submitted']}", "all ok")
    both("ticks late by more than 0.5 ms", lambda r: f"{r['run']['late_ticks']} of {r['run']['ticks']}")
    both("CPU of one core over the run (user + system)", lambda r: f"{r['share'] * 100:.2f} %")
    both("**CPU per request x 12.3 requests/ms: share of one core**", lambda r: f"{r['share_at_12300'] * 100:.2f} %",
         f"{GOAL_SHARE * 100:.0f} %", f"{goal['share_at_12300'] / GOAL_SHARE:.2f}")
    both("of which system (kernel), over the run",
         lambda r: f"{float(r['run']['sys_s']) / float(r['run']['wall_s']) * 100:.2f} %")
    both("CPU per request", lambda r: f"{r['us_per_request']:.2f} us")
    both("latency, submission to callback, mean / largest: USB (the bridge model's queue: it varies with the "
         "machine's load)", lambda r: f"{float(r['run']['usb_latency_mean_us']) / 1e3:.2f} / "
         f"{float(r['run']['usb_latency_max_us']) / 1e3:.1f} ms")
    both("... RS232", lambda r: f"{float(r['run']['rs232_latency_mean_us']) / 1e3:.2f} / "
         f"{float(r['run']['rs232_latency_max_us']) / 1e3:.1f} ms")
    both("wake-ups per ms while ticking (voluntary context switches)", lambda r: f"{r['wakes_per_ms']:.2f}")
    both("floor: the loop with no bridge woken as often, share of one core",
         lambda r: f"{r['floor_share'] * 100:.2f} % ({float(r['floor']['cpu_s']) * 1e6 / max(1, int(r['floor']['wakes'])):.1f} "
         "us per wake-up)")
    both("the load above that floor, share of one core", lambda r: f"{(r['share_at_12300'] - r['floor_share']) * 100:.2f} %")
    print(f"| event-driven, the program ppolling urb_loop_fd() + run_once(0): share of one core | | "
          f"{rows['poll_share_at_12300'] * 100:.2f} % ({polled_us:.2f} us per request) | | |")
    if goal["per_s"] / 1000 < 0.95 * PER_MS or int(res["not_submitted"]) > 0:
        print("| note: a run did not keep the load's rate (other jobs stalled it): the share over the run "
              "is too low, the share from CPU per request is the one to read | | | | |")
    if "callgrind" in goal:
        both("user instructions per request (callgrind)", lambda r: f"{r['callgrind']['ir_per_request']:.0f}")
        both("system calls per request (strace)", lambda r: f"{r['callgrind']['syscalls_per_request']:.2f} (" + ", ".join(
            f"{k} {v:.2f}" for k, v in sorted(r["callgrind"]["syscalls"].items(), key=lambda kv: -kv[1])[:4]) + ")")
        both(f"instructions per second at 12.3 requests/ms (user + {KERNEL_INSTR_PER_CALL} per call)",
             lambda r: f"{r['callgrind']['instr_per_s_at_12300'] / 1e6:.1f} M")
        for ipc in (1.0, 0.5):
            both(f"projected share of a 500-MHz core at IPC {ipc}",
                 lambda r, ipc=ipc: f"{r['callgrind'][f'geode_share_ipc{ipc}'] * 100:.1f} %", "100 %",
                 f"{goal['callgrind'][f'geode_share_ipc{ipc}']:.2f}")
    else:
        print("| instructions | valgrind or strace not installed: no projection | | | |")
    share_at_rate, us_per_request = goal["share_at_12300"], goal["us_per_request"]
    py = python_numbers(args.python_json)
    on_c = python_numbers(args.native_json)
    rows["python"] = py
    rows["python_on_c_core"] = on_c
    print()
    if py is None:
        print(f"Python library: no numbers in {args.python_json} (run `python3 bench/host_cpu.py` first; "
              "`make bench` does): no side-by-side table")
    else:
        side_by_side(py, on_c, share_at_rate, us_per_request)
    whole = whole_load_rows(args.sensorhex_json)
    rows["python_whole_load"] = whole
    print()
    if whole is None:
        print(f"Python API, whole load: no numbers in {args.sensorhex_json} (run `python3 bench/host_cpu_sensorhex.py` "
              "first; `make bench` does)")
    else:
        print("The whole SensoRHex load from one Python program on the C core (bench/host_cpu_sensorhex.py: the "
              "same bridges and load as the C library above, measured, not scaled), next to the C library's "
              "cyclic row:")
        print()
        print("| program | CPU per request | x 12.3 requests/ms: share of one core | / 10 % goal | / C library |")
        print("|---|---:|---:|---:|---:|")
        for r in whole:
            print(f"| Python, {r['api']} API, {r['runtime']} runtime | {r['us_per_request']:.2f} us | "
                  f"{r['share_at_12300'] * 100:.2f} % | {r['share_at_12300'] / GOAL_SHARE_PY_ON_C:.2f} | "
                  f"{r['us_per_request'] / us_per_request:.1f} |")
        print(f"| C library, cyclic pattern | {us_per_request:.2f} us | {share_at_rate * 100:.2f} % | | 1.0 |")
        projections = whole_load_projections(args.sensorhex_json)
        if projections and goal.get("callgrind"):
            cg = goal["callgrind"]
            print()
            print("Projection for a 500-MHz Geode-class core (user instructions + 4000 per system call, per request, "
                  "x 12.3 requests/ms), the cyclic programs:")
            print()
            print("| program | user instructions per request | system calls per request | IPC 1 | IPC 0.5 |")
            print("|---|---:|---:|---:|---:|")
            for p in projections:
                print(f"| Python, {p['api']} API, cyclic runtime | {p['instructions_per_request']:.0f} | "
                      f"{p['syscalls_per_request']:.2f} | {p['geode_share_ipc1'] * 100:.0f} % | "
                      f"{p['geode_share_ipc0.5'] * 100:.0f} % |")
            print(f"| C library, cyclic pattern | {cg['ir_per_request']:.0f} | {cg['syscalls_per_request']:.2f} | "
                  f"{cg['geode_share_ipc1.0'] * 100:.1f} % | {cg['geode_share_ipc0.5'] * 100:.1f} % |")
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "host_cpu_c.json").write_text(json.dumps(rows, indent=1, default=str) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
