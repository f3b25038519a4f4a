#!/usr/bin/env python3
"""The whole SensoRHex load from the Python API in one process, measured as a share of one core.

bench/host_cpu.py measures one USB bridge and projects the robot from it. This one runs the robot:
two USB bridges with three motor drivers each (every motor's MotorFeedback read and MotorCommand
written every millisecond: 12 requests per ms) and an RS232 bridge with the battery manager, the
IMU and the IR distance node read at 100 Hz (300 requests per s), all from one Python program, and
reads its CPU time (time.process_time: every thread of the library, the loop, the callbacks)
against the wall clock. The bridges run in other processes and are not counted: the USB ones are
the Python bridge model behind SOCK_SEQPACKET pairs (a kernel driver's character device keeps
transfer boundaries the same way), the RS232 one the bridge firmware compiled for the host
(`make bridge-hosted`) on a pseudo-terminal.

Four programs, each the same load:

  API         how the motors are driven
  per-request new_request ... submit_request, one callback per request (the paper's API)
  cycle       urb.cycle.Cycle: the tick's 12 motor requests built once, submitted at once, polled
              (Cycle.poll) when the cycle comes round again

  runtime     who does the I/O
  threaded    the managers' own threads (on the C core: the pump's C thread and a dispatcher)
  cyclic      every manager made with cyclic=True: no thread of the library; the loop sleeps to
              each 1-ms tick and calls urb.service(), which reads, sends what is due and runs the
              callbacks (host/urb/README.md, "The cyclic runtime").

The sensors are read through the per-request API in all four. The goal of issue #38 is 10 % of one
core from the Python API on the C core; the share is CPU per request x 12.3 requests per ms, as
bench/host_cpu_c.py measures the C library, and the ratio printed is share / 10 %. Nothing is
asserted: the numbers go to build/bench/host_cpu_sensorhex.json. Best of --repeats (other jobs on
the machine only ever add CPU time). Run it on a quiet machine: at load 2 on 2 cores the figures
rise by a third or more.

Then the projection for a 500-MHz Geode-class core of the two cyclic programs, as bench/host_cpu_c.py
projects the C library: user instructions per request from callgrind, system calls per request from
strace -c -f (each the difference of a run with load and one without, so start-up cancels; at a
20-ms tick, since valgrind runs Python some 50 times slower: the work per tick is the same),
(instructions + 4000 per system call) x 12.3 requests per ms / (500 MHz x IPC), at IPC 1 and 0.5.

    python3 bench/host_cpu_sensorhex.py                 # 4 programs x 3 runs x 5 s, then the projection
    python3 bench/host_cpu_sensorhex.py --seconds 2 --repeats 1 --cg-seconds 0
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(REPO / "tests" / "host"))
sys.path.insert(0, str(HERE))  # bench/host_cpu_c.py

from bridge_proc import build_hosted_bridge  # noqa: E402
from host_cpu_c import GEODE_HZ, KERNEL_INSTR_PER_CALL, callgrind_total  # noqa: E402  (the C library's projection)
from urb.api import NodeAccessor, NodeRequest, URBInterface  # noqa: E402
from urb.cycle import Cycle, CycleItem  # noqa: E402
from urb.managers import CharDeviceTransport, RS232Manager, USBManager, native  # noqa: E402
from urb.managers.base import NS_PER_MS  # noqa: E402
from urb_msgs import _codec  # noqa: E402
from urb_msgs.sensorhex import MotorCommand, MotorFeedback  # noqa: E402

OUT = REPO / "build" / "bench"
GOAL = 0.10
PER_MS = 12.3
"""SensoRHex's requests per millisecond: the goal's measure is CPU per request times this rate, as
bench/host_cpu_c.py measures the C library (the run's own CPU over wall time is printed too: lower
when the loop skipped ticks, higher when the end's wait for the last answers was long)."""
CYCLE_RING = 8
"""Cycles in rotation: a USB request completes 2-3 frames after its submission, so the cycle of a
tick is still in flight at the next tick; a tick whose cycle has not come back skips (counted)."""
SENSORS = [("BatteryManager", "battery,0,0x30"), ("Imu", "imu,0,0x31"), ("IrDistance", "ir,0,0x32")]
USB_BRIDGES = REPO / "build" / "host_c" / "bench" / "host_cpu_c_bridges"
TRACE_PERIOD_MS = 20
"""The tick of the runs under callgrind and strace: valgrind runs Python some 50 times slower, so a
1-ms tick cannot be kept; each tick does the same work (12 motor requests, the sensors every 10th),
so the instructions per request are those of the 1-ms program."""

"""The bridge firmware compiled for the host, one per SOCK_SEQPACKET pair, three motor drivers each
(bench/host_cpu_c_bridges.c, `make host-c-bench`)."""


@contextlib.contextmanager
def bridges() -> Iterator[tuple[list[int], Path]]:
    """The robot's three bridges, the same programs bench/host_cpu_c.py runs the C library against:
    (the host ends of the two USB bridges' SOCK_SEQPACKET pairs, the RS232 bridge's pty link)."""
    build = subprocess.run(["make", "--no-print-directory", "-C", str(REPO), "host-c-bench", "bridge-hosted"],
                           capture_output=True, text=True)
    if build.returncode != 0:
        sys.exit(f"host_cpu_sensorhex: cannot build the bridges:\n{build.stdout[-2000:]}{build.stderr[-3000:]}")
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["URB_STATE_DIR"] = tmp  # the RS232 manager's hand-over record, not the user's
        link = Path(tmp) / "pty"
        argv = [str(build_hosted_bridge())]
        for _, spec in SENSORS:
            argv += ["--node", spec]
        rs232 = subprocess.Popen(argv + ["--link", str(link), "--seconds", "3600"], stdout=subprocess.PIPE, text=True)
        pairs = [socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET) for _ in range(2)]
        bridge_fds = [b.fileno() for _, b in pairs]
        usb = subprocess.Popen([str(USB_BRIDGES), *map(str, bridge_fds)], pass_fds=bridge_fds, stdout=subprocess.PIPE,
                               text=True)
        for _, b in pairs:
            b.close()
        try:
            assert rs232.stdout is not None and usb.stdout is not None
            rs232.stdout.readline()  # "pty: ..." once the link exists
            usb.stdout.readline()  # "ready"
            yield [host_end.fileno() for host_end, _ in pairs], link
        finally:
            for host_end, _ in pairs:
                host_end.close()
            usb.wait(10)
            rs232.terminate()
            rs232.wait(10)


@contextlib.contextmanager
def interface(usb_fds: list[int], link: Path,
              cyclic: bool) -> Iterator[tuple[URBInterface, list[NodeAccessor], list[NodeAccessor]]]:
    """The host's interface to the bridges: (urb, 6 motors, 3 sensors); closed on exit."""
    urb = URBInterface()
    try:
        for k, fd in enumerate(usb_fds):
            urb.add_bus_manager(USBManager(CharDeviceTransport(fd=fd), timeout_s=1.0, name=f"usb{k}", cyclic=cyclic))
        urb.add_bus_manager(RS232Manager(str(link), timeout_s=1.0, cyclic=cyclic))
        yield urb, [urb.find_node("MotorDriver", i) for i in range(6)], [urb.find_node(name, 0) for name, _ in SENSORS]
    finally:
        urb.close()


def every_tick(seconds: float, period_ms: int) -> Iterator[int]:
    """Yields the tick number once per `period_ms` of real time for `seconds`, sleeping to each tick
    on the period's grid (a tick already past is not waited for: the loop catches up)."""
    period = period_ms * NS_PER_MS
    tick = (time.monotonic_ns() // period + 1) * period
    end = tick + int(seconds * 1e9)
    k = 0
    while tick < end:
        delay = tick - time.monotonic_ns()
        if delay > 0:
            time.sleep(delay / 1e9)
        yield k
        k += 1
        tick += period


def run(api: str, cyclic: bool, seconds: float, period_ms: int = 1,
        ends: tuple[list[int], Path] | None = None) -> dict[str, Any]:
    """One program for `seconds`: CPU time of this process over the wall clock. Every tick (1 ms,
    or `period_ms` for the instruction counts: the same work per tick) the 12 motor requests, every
    10th the 3 sensor reads. `ends`: the bridges' host ends (bridges()), else started here."""
    if ends is None:
        with bridges() as started:
            return run(api, cyclic, seconds, period_ms, started)
    with interface(*ends, cyclic) as (urb, motors, sensors):
        count, failed, overruns, sent = [0], [0], [0], [0]

        def done(r: NodeRequest) -> None:
            count[0] += 1
            failed[0] += not r.ok

        ring: list[tuple[Cycle, list[CycleItem]]] = []
        if api == "cycle":
            for _ in range(CYCLE_RING):
                cycle = Cycle()
                for node in motors:
                    cycle.read(node, MotorFeedback)
                ring.append((cycle, [cycle.write(node, MotorCommand) for node in motors]))

        def poll_cycles() -> None:
            for cycle, _ in ring:
                if cycle.in_flight and cycle.poll():
                    count[0] += len(cycle.items)
                    failed[0] += cycle.failed

        cpu0, wall0 = time.process_time(), time.perf_counter()
        for k in every_tick(seconds, period_ms):
            if cyclic:
                urb.service()
            if api == "cycle":
                cycle, commands = ring[k % CYCLE_RING]
                if cycle.in_flight and cycle.poll():
                    count[0] += len(cycle.items)
                    failed[0] += cycle.failed
                if cycle.in_flight:
                    overruns[0] += 1
                else:
                    for item in commands:
                        item.set(MotorCommand(voltage=k & 0x7FFF))
                    cycle.submit()
                    sent[0] += len(cycle.items)
            else:
                for node in motors:
                    node.submit_request(node.new_request().read_message(MotorFeedback).set_callback(done))
                    node.submit_request(node.new_request().write_message(MotorCommand(voltage=k & 0x7FFF))
                                        .set_callback(done))
                sent[0] += 12
            if k % 10 == 0:
                for node in sensors:
                    node.submit_request(node.new_request().read(1).set_callback(done))
                sent[0] += 3
        deadline = time.monotonic() + 3.0
        while count[0] < sent[0] and time.monotonic() < deadline:
            time.sleep(0.001)
            if cyclic:
                urb.service()
            poll_cycles()
        cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
    us = cpu * 1e6 / max(1, count[0])
    return {"api": api, "runtime": "cyclic" if cyclic else "threaded", "requests": sent[0], "completed": count[0],
            "failed": failed[0], "overruns": overruns[0], "cpu_s": cpu, "wall_s": wall,
            "share": cpu / wall if wall > 0 else 0.0, "requests_per_ms": sent[0] / max(1e-9, wall * 1000),
            "us_per_request": us, "share_at_12300": us * PER_MS * 1000 / 1e6}


def traced_run(prefix: list[str], api: str, seconds: float, ends: tuple[list[int], Path]) -> dict[str, Any]:
    """run(api, cyclic) at a TRACE_PERIOD_MS tick in a child process under `prefix` (valgrind,
    strace), on bridges started here (so that neither tool sees them)."""
    fds, link = ends
    argv = [*prefix, sys.executable, str(Path(__file__).resolve()), "--one", api, "--seconds", str(seconds),
            "--fds", ",".join(map(str, fds)), "--link", str(link)]
    proc = subprocess.run(argv, pass_fds=fds, capture_output=True, text=True, timeout=900)
    if proc.returncode != 0:
        sys.exit(f"host_cpu_sensorhex: the traced run failed (exit {proc.returncode}):\n{proc.stderr[-3000:]}")
    out: dict[str, Any] = json.loads(proc.stdout.strip().splitlines()[-1])
    out["stderr"] = proc.stderr
    return out


def instructions(api: str, seconds: float) -> dict[str, float]:
    """The cyclic program's user instructions (callgrind) and system calls (strace -c -f) per request,
    each the difference of a run of `seconds` and one of none (start-up and close cancel), and the
    projection for a 500-MHz core, as bench/host_cpu_c.py projects the C library."""
    with bridges() as ends, tempfile.TemporaryDirectory() as tmp:
        counts = []
        for secs in (seconds, 0.0):
            out = Path(tmp) / f"cg-{secs}"
            r = traced_run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}"], api, secs, ends)
            counts.append((callgrind_total(r["stderr"], out, "host_cpu_sensorhex"), int(r["completed"]), int(r["failed"])))
        calls = []
        for secs in (seconds, 0.0):
            out = Path(tmp) / f"strace-{secs}"
            r = traced_run(["strace", "-c", "-f", "-o", str(out)], api, secs, ends)
            total = next((int(f[3]) for f in (line.split() for line in out.read_text(encoding="utf-8").splitlines())
                          if len(f) >= 4 and f[-1] == "total"), 0)
            calls.append((total, int(r["completed"])))
    requests = counts[0][1] - counts[1][1]
    ir = (counts[0][0] - counts[1][0]) / max(1, requests)
    sc = (calls[0][0] - calls[1][0]) / max(1, calls[0][1] - calls[1][1])
    per_s = (ir + sc * KERNEL_INSTR_PER_CALL) * PER_MS * 1000
    return {"api": api, "requests": requests, "failed": counts[0][2], "instructions_per_request": ir,
            "syscalls_per_request": sc, "geode_share_ipc1": per_s / GEODE_HZ, "geode_share_ipc0.5": per_s / (GEODE_HZ * 0.5)}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=5.0, help="length of each run (default 5)")
    ap.add_argument("--repeats", type=int, default=3, metavar="N", help="runs of each program; the cheapest is kept")
    ap.add_argument("--json", type=Path, default=OUT / "host_cpu_sensorhex.json", help="where the numbers go")
    ap.add_argument("--cg-seconds", type=float, default=4.0,
                    help="load under callgrind and strace for the 500-MHz projection of the cyclic runtime "
                         "(default 4; 0 skips it)")
    ap.add_argument("--one", choices=("per-request", "cycle"), help=argparse.SUPPRESS)  # traced_run's child
    ap.add_argument("--fds", help=argparse.SUPPRESS)
    ap.add_argument("--link", type=Path, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.one:
        ends = ([int(fd) for fd in args.fds.split(",")], args.link)
        print(json.dumps(run(args.one, True, args.seconds, TRACE_PERIOD_MS, ends)))
        return 0
    if args.repeats < 1 or args.seconds <= 0 or args.cg_seconds < 0:
        ap.error("--repeats must be 1 or more, --seconds above 0 and --cg-seconds 0 or more")
    print(f"SensoRHex from the Python API, whole load in one process (best of {args.repeats} x {args.seconds:g} s; "
          f"protocol core: {native.BACKEND}, codecs: {_codec.BACKEND}, load average {os.getloadavg()[0]:.1f} on "
          f"{os.cpu_count()} CPUs)")
    rows = []
    print("| API for the motors | runtime | CPU per request | x 12.3 requests/ms: share of one core | / 10 % goal | "
          "CPU over the run's wall time | requests per ms | completed | failed | ticks skipped |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for api in ("per-request", "cycle"):
        for cyclic in (False, True):
            best = min((run(api, cyclic, args.seconds) for _ in range(args.repeats)),
                       key=lambda r: float(r["us_per_request"]))
            rows.append(best)
            print(f"| {api} | {best['runtime']} | {best['us_per_request']:.2f} us | {best['share_at_12300'] * 100:.2f} % | "
                  f"{best['share_at_12300'] / GOAL:.2f} | {best['share'] * 100:.2f} % | {best['requests_per_ms']:.2f} | "
                  f"{best['completed']} of {best['requests']} | {best['failed']} | {best['overruns']} |", flush=True)
    projections = []
    if args.cg_seconds > 0 and shutil.which("valgrind") and shutil.which("strace"):
        print(f"\nProjection for a 500-MHz Geode-class core, cyclic runtime ((user instructions + system calls x "
              f"{KERNEL_INSTR_PER_CALL}) per request x 12.3 requests/ms / (500 MHz x IPC); instructions by callgrind, "
              f"system calls by strace -c -f, each a {args.cg_seconds:g}-s run at a {TRACE_PERIOD_MS}-ms tick minus one "
              f"of none):")
        print("| API for the motors | user instructions per request | system calls per request | "
              "500 MHz, IPC 1 | IPC 0.5 |")
        print("|---|---:|---:|---:|---:|")
        for api in ("per-request", "cycle"):
            p = instructions(api, args.cg_seconds)
            projections.append(p)
            print(f"| {api} | {p['instructions_per_request']:.0f} | {p['syscalls_per_request']:.2f} | "
                  f"{p['geode_share_ipc1'] * 100:.0f} % | {p['geode_share_ipc0.5'] * 100:.0f} % |", flush=True)
    elif args.cg_seconds > 0:
        print("\nNo projection: valgrind or strace is not installed")
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps({"rows": rows, "projections": projections, "core": native.BACKEND,
                                     "codecs": _codec.BACKEND, "seconds": args.seconds, "repeats": args.repeats,
                                     "load_average": os.getloadavg()[0]}, indent=2) + "\n")
    print(f"written {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
