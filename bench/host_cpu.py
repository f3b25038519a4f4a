#!/usr/bin/env python3
"""CPU cost of the URB host library per request, and what the SensoRHex load costs a host core.

The paper's robot asks 12.3 requests per millisecond of its host (six motor drivers read and
commanded at 1 kHz over two USB bridges, three sensors read at 100 Hz over RS232). The host library
is Python: this benchmark measures how much of one core that takes, on this machine. It measures
CPU time of the host process only (time.process_time: every thread of the library, the
application's loop and its callbacks), never the bridge's: the bridge runs in another process.

  1. RS232Manager over a pseudo-terminal to the bridge firmware compiled for the host
     (`make bridge-hosted`, two motor nodes on its simulated I2C bus): the window kept full by the
     callbacks (each completion submits the next read), so the host runs as fast as it can.
  2. USBManager over a SOCK_SEQPACKET socket pair (a kernel driver's character device keeps
     transfer boundaries the same way) to the Python bridge model in a child process: one
     SensoRHex USB bridge's load, three MotorFeedback reads and three MotorCommand writes every
     millisecond, for --seconds of wall time.
  2b. The same load through the cycle API (urb.cycle.Cycle): each tick's six requests one cycle,
     submitted at once, polled by the loop (Cycle.poll) or completed with one callback per cycle
     (on the C core one call hands a bridge's items to the core; host/urb/README.md "Control
     cycles"). The projection is printed for both APIs.
  3. The protocol state machines alone (the cores the managers run: Rs232Core and UsbCore, or
     their C counterparts; no threads, no system calls): submit, frame, response, completion.
     What 1 and 2 cost beyond this is the real-time runtime: threads waking each other, the GIL,
     the port's system calls.

Which protocol core the library runs is the library's choice (urb.managers.native): the C core of
host/c when `make host-c-py` built it, the Python reference with URB_HOST_CORE=python (or
URB_PURE_PYTHON=1, which also takes the pure-Python codecs). `make bench` runs this file both ways
(build/bench/host_cpu.json: Python cores; build/bench/host_cpu_native.json: the C core) and
bench/host_cpu_c.py prints them next to the C library.

Prints microseconds of CPU per request for each, the threads' split (from /proc, counted in
clock ticks, so rough), and the projection: the SensoRHex load at 1 kHz as a share of one core of
this machine (two bridges as in 2, plus 300 RS232 requests per second at the cost of 1). A ratio
above 1 means this machine could not run the paper's robot from this library at 1 kHz.
Nothing is asserted: the numbers go to build/bench/host_cpu.json.

    python3 bench/host_cpu.py                  # ~75 s
    python3 bench/host_cpu.py --quick          # ~20 s
    python3 bench/host_cpu.py --rs232-ab       # case 1 on the C core: pump and Python threads alternately
    python3 bench/host_cpu.py --usb-ab         # case 2 likewise
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import platform
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests" / "host"))

from bridge_proc import build_hosted_bridge, serve_usb_transfers  # noqa: E402
from urb.api import NodeAccessor, NodeRequest, URBInterface  # noqa: E402
from urb.cycle import Cycle, CycleItem  # noqa: E402
from urb.managers import BridgeModel, CharDeviceTransport, RS232Manager, USBManager, fake_node  # noqa: E402
from urb.managers.base import NS_PER_MS, Transfer  # noqa: E402
from urb.managers import native, rs232, usb  # noqa: E402
from urb_msgs import _codec  # noqa: E402
from urb_msgs.sensorhex import MotorCommand, MotorFeedback  # noqa: E402
from urb_msgs.urb_core import Status, UplinkResponse, UsbBatchHeader  # noqa: E402

OUT = REPO / "build" / "bench"
SENSORHEX_USB_PER_MS = 6    # per USB bridge: 3 motors, each read and commanded every ms
SENSORHEX_USB_BRIDGES = 2
SENSORHEX_RS232_PER_S = 300  # battery, IMU and IR read at 100 Hz
MOTORS = [f"MotorDriver:{i}@{16 + i}" for i in range(3)]


def thread_split(requests: int) -> dict[str, float]:
    """CPU microseconds per request of each live thread of this process (user + system), from
    /proc: counted in clock ticks, so rough for short runs. Python threads by their name, the
    others (the C core's pump: urb-pump) by their kernel name."""
    tick = os.sysconf("SC_CLK_TCK")
    out: dict[str, float] = {}
    names = {th.native_id: th.name.split(" ")[0] for th in threading.enumerate()}
    for task in Path("/proc/self/task").iterdir():
        try:
            stat = (task / "stat").read_text()
        except OSError:
            continue
        comm, fields = stat.split("(", 1)[1].rsplit(")", 1)[0], stat.rsplit(")", 1)[1].split()
        name = names.get(int(task.name)) or comm
        out[name] = out.get(name, 0.0) + (int(fields[11]) + int(fields[12])) * 1e6 / tick / max(1, requests)
    return out


def rs232_pty(requests: int) -> dict[str, Any]:
    """Case 1: the window kept full over a pty to the hosted bridge firmware."""
    link = OUT / "host_cpu-pty"
    OUT.mkdir(parents=True, exist_ok=True)
    proc = subprocess.Popen([str(build_hosted_bridge()), "--node", "motor,0,0x10", "--node", "motor,1,0x11",
                             "--link", str(link), "--seconds", "600"], stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None
        proc.stdout.readline()  # "pty: ..." once the link exists
        urb = URBInterface()
        m = RS232Manager(str(link), window=15, timeout_s=1.0)
        urb.add_bus_manager(m)
        motors = [urb.find_node("MotorDriver", i) for i in range(2)]
        window = m._rs.window  # after discovery: the bridge FIFO depth, at most 15
        freed = threading.Semaphore(0)
        failed = [0]

        def done(r: NodeRequest) -> None:
            failed[0] += not r.ok
            freed.release()

        before = thread_split(1)
        cpu0, wall0 = time.process_time(), time.perf_counter()
        for i in range(requests):
            if i >= window:
                freed.acquire()
            node = motors[i % 2]
            node.submit_request(node.new_request().read_message(MotorFeedback).set_callback(done))
        for _ in range(min(window, requests)):
            freed.acquire()
        cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
        after = thread_split(1)
        urb.close()
    finally:
        proc.terminate()
        proc.wait(5)
    split = {k: (after.get(k, 0.0) - before.get(k, 0.0)) / requests for k in after}
    return {"requests": requests, "failed": failed[0], "cpu_s": cpu, "wall_s": wall,
            "us_per_request": cpu * 1e6 / requests, "requests_per_s": requests / wall, "threads_us": split}


def _bridge_child(sock: socket.socket) -> None:
    """The USB bridge end in a child process, until the host closes its end."""
    serve_usb_transfers(sock, BridgeModel(dict(fake_node(s) for s in MOTORS), fifo_depth=15))
    os._exit(0)


@contextlib.contextmanager
def usb_motor_bridge(cyclic: bool = False) -> Iterator[tuple[URBInterface, list[NodeAccessor]]]:
    """One SensoRHex USB bridge with its three motors in a child process, and the host's
    interface to it; on exit the interface closes and the child sees the end of its socket.
    `cyclic`: the manager is made with cyclic=True (no thread; the loop calls `urb.service()`)."""
    host_sock, dev_sock = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
    pid = os.fork()
    if pid == 0:
        host_sock.close()
        _bridge_child(dev_sock)
    dev_sock.close()
    fd = os.dup(host_sock.fileno())
    host_sock.close()
    urb = URBInterface()
    try:
        urb.add_bus_manager(USBManager(CharDeviceTransport(fd=fd), timeout_s=1.0, name="usb", cyclic=cyclic))
        yield urb, [urb.find_node("MotorDriver", i) for i in range(3)]
    finally:
        urb.close()
        os.close(fd)
        os.waitpid(pid, 0)


def every_ms(seconds: float) -> Iterator[None]:
    """Yields once per millisecond of real time for `seconds`, sleeping to each tick (a tick
    already past is not waited for: the loop catches up)."""
    tick = time.monotonic_ns()
    end = tick + int(seconds * 1e9)
    while tick < end:
        tick += NS_PER_MS
        delay = tick - time.monotonic_ns()
        if delay > 0:
            time.sleep(delay / 1e9)
        yield


def usb_sensorhex(seconds: float, cyclic: bool = False) -> dict[str, Any]:
    """Case 2: one SensoRHex USB bridge's motor load in real time. `cyclic`: the cyclic runtime
    (no thread: the loop calls `urb.service()` at each tick, and the callbacks run in it)."""
    with usb_motor_bridge(cyclic) as (urb, motors):
        count, failed = [0], [0]

        def done(r: NodeRequest) -> None:
            count[0] += 1
            failed[0] += not r.ok

        before = thread_split(1)
        sent = 0
        cpu0, wall0 = time.process_time(), time.perf_counter()
        for _ in every_ms(seconds):
            if cyclic:
                urb.service()
            for node in motors:
                node.submit_request(node.new_request().read_message(MotorFeedback).set_callback(done))
                node.submit_request(node.new_request().write_message(MotorCommand(voltage=1)).set_callback(done))
                sent += 2
        deadline = time.monotonic() + 2.0
        while count[0] < sent and time.monotonic() < deadline:
            time.sleep(0.001)
            if cyclic:
                urb.service()
        cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
        after = thread_split(1)
    split = {k: (after.get(k, 0.0) - before.get(k, 0.0)) / max(1, count[0]) for k in after}
    return {"requests": sent, "completed": count[0], "failed": failed[0], "cpu_s": cpu, "wall_s": wall,
            "us_per_request": cpu * 1e6 / max(1, count[0]), "core_share": cpu / wall, "threads_us": split}


CYCLE_RING = 8
"""Cycles the cycle-API case rotates through: a USB request completes 2 to 3 frames after its
submission (more when other jobs delay the threads), so the cycle of a tick is still in flight at
the next tick's start."""


def usb_sensorhex_cycle(seconds: float, polled: bool = True, cyclic: bool = False) -> dict[str, Any]:
    """Case 2 through the cycle API (urb.cycle.Cycle): the same load, each tick's six requests one
    cycle (three MotorFeedback reads, three MotorCommand writes given new messages every tick),
    submitted at once; CYCLE_RING cycles in rotation. `polled`: the loop looks at a cycle's
    outcome when it comes round again (`Cycle.poll`, no dispatcher wake-up); else one callback
    per cycle on the dispatcher. A cycle still in flight when it comes round is an overrun: that
    tick submits nothing (counted). `cyclic`: the cyclic runtime, `urb.service()` at each tick
    before the cycle is looked at."""
    with usb_motor_bridge(cyclic) as (urb, motors):
        count, failed, overruns = [0], [0], [0]

        def done(c: Cycle) -> None:
            count[0] += 6
            failed[0] += c.failed

        ring: list[tuple[Cycle, list[CycleItem]]] = []
        for _ in range(CYCLE_RING):
            cycle = Cycle().set_callback(None if polled else done)
            for node in motors:
                cycle.read(node, MotorFeedback)
            ring.append((cycle, [cycle.write(node, MotorCommand) for node in motors]))
        before = thread_split(1)
        sent = ticks = 0
        cpu0, wall0 = time.process_time(), time.perf_counter()
        for _ in every_ms(seconds):
            if cyclic:
                urb.service()
            cycle, commands = ring[ticks % CYCLE_RING]
            ticks += 1
            if polled and cycle.in_flight and cycle.poll():
                done(cycle)
            if cycle.in_flight:
                overruns[0] += 1
                continue
            for item in commands:
                item.set(MotorCommand(voltage=1))
            cycle.submit()
            sent += 6
        deadline = time.monotonic() + 2.0
        while count[0] < sent and time.monotonic() < deadline:
            time.sleep(0.001)
            if cyclic:
                urb.service()
            for cycle, _ in ring if polled else ():
                if cycle.in_flight and cycle.poll():
                    done(cycle)
        cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
        after = thread_split(1)
        native_cycles = all(type(g).__name__ == "_NativeGroup" for c, _ in ring for g in c._groups)
    split = {k: (after.get(k, 0.0) - before.get(k, 0.0)) / max(1, count[0]) for k in after}
    return {"requests": sent, "completed": count[0], "failed": failed[0], "overruns": overruns[0], "cpu_s": cpu,
            "wall_s": wall, "us_per_request": cpu * 1e6 / max(1, count[0]), "core_share": cpu / wall,
            "threads_us": split, "cycles_in_c": native_cycles}


def rs232_core_only(requests: int) -> float:
    """Case 3, RS232: CPU microseconds per request of the RS232 core alone (responses prepared
    beforehand, so only the host's work is timed)."""
    responses = [UplinkResponse(seq=s, status=Status.OK, data=bytes(6)).encode() for s in range(16)]
    core = native.new_rs232_core(window=15)
    now, sent = 0, []
    cpu0 = time.process_time()
    for i in range(requests):
        core.submit(Transfer(address=0x10, mailbox=1, read=True, length=6), now)
        sent += core.frames_to_send(now)
        if len(sent) == 15 or i == requests - 1:
            for frame in sent:
                now += 200_000
                core.receive(responses[frame[1] >> 4], now)
                core.poll(now)
                core.take_completed()
            sent = []
    return (time.process_time() - cpu0) * 1e6 / requests


def usb_core_only(requests: int) -> float:
    """Case 3, USB: CPU microseconds per request of the USB core alone, 6 requests per 1-ms frame
    (responses prepared beforehand)."""
    responses = [UplinkResponse(seq=s, status=Status.OK, data=bytes(6)).encode() for s in range(16)]
    headers = [UsbBatchHeader(frame=1, count=n).encode() for n in range(16)]
    core = native.new_usb_core(max_batch=14)
    header = UsbBatchHeader.MAX_SIZE
    now, done = 0, 0
    cpu0 = time.process_time()
    while done < requests:
        for k in range(SENSORHEX_USB_PER_MS):
            core.submit(Transfer(address=0x10 + k % 3, mailbox=1, read=True, length=6), now)
        now += NS_PER_MS
        core.poll(now)
        out = core.frame_out(now)
        if out is not None:
            seqs = [out[i + 1] >> 4 for i in range(header, len(out), 4)]  # UplinkReadRequest.seq
            core.receive_batch(headers[len(seqs)] + b"".join(responses[s] for s in seqs), now)
        done += len(core.take_completed())
    return (time.process_time() - cpu0) * 1e6 / done


def runtimes_ab(manager: Any, case: Callable[[], dict[str, Any]], repeats: int) -> dict[str, Any]:
    """A case on the C core with the uplink's I/O on the core's pump (a C thread, completions in
    batches) and on the Python threads (`manager.USE_PUMP` off: the rs232 or usb module),
    alternately, so that both see the same load from other jobs; the cheapest run of each."""
    runs: dict[str, list[dict[str, Any]]] = {"pump": [], "threads": []}
    try:
        for _ in range(repeats):
            for label, on in (("pump", True), ("threads", False)):
                manager.USE_PUMP = on
                runs[label].append(case())
    finally:
        manager.USE_PUMP = True
    best = {k: min(v, key=lambda r: float(r["us_per_request"])) for k, v in runs.items()}
    return {"pump": best["pump"], "threads": best["threads"],
            "pump_over_threads": best["pump"]["us_per_request"] / best["threads"]["us_per_request"]}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="shorter runs (rougher numbers)")
    ap.add_argument("--repeats", type=int, default=3, metavar="N",
                    help="runs of each case; the cheapest is reported (default 3: other jobs on the machine "
                         "only ever add CPU time)")
    ap.add_argument("--json", type=Path, default=OUT / "host_cpu.json", help="where the numbers go")
    ap.add_argument("--usb-ab", action="store_true",
                    help="only case 2 on the C core, the pump and the Python threads alternately (best of --repeats)")
    ap.add_argument("--rs232-ab", action="store_true",
                    help="only case 1 on the C core, the pump and the Python threads alternately (best of --repeats)")
    args = ap.parse_args(argv)
    n, secs = (4000, 1.5) if args.quick else (20000, 5.0)

    print(f"Host library CPU per request ({'quick' if args.quick else 'full'} run, best of {args.repeats}; CPU time "
          f"of the host process, Python {sys.version.split()[0]}, load average {os.getloadavg()[0]:.1f} on "
          f"{os.cpu_count()} CPUs; protocol core: {native.BACKEND} ({native.REASON}), codecs: {_codec.BACKEND}):")
    if args.repeats < 1:
        ap.error("--repeats must be 1 or more")
    runs = range(args.repeats)
    if args.usb_ab or args.rs232_ab:
        if native.BACKEND != "c":
            ap.error(f"--usb-ab and --rs232-ab compare the runtimes on the C core, which is not in use ({native.REASON})")
        uplink = "USB" if args.usb_ab else "RS232"
        ab = (runtimes_ab(usb, lambda: usb_sensorhex(secs), args.repeats) if args.usb_ab
              else runtimes_ab(rs232, lambda: rs232_pty(n), args.repeats))
        for label in ("pump", "threads"):
            r = ab[label]
            split = ", ".join(f"{k} {v:.1f}" for k, v in sorted(r["threads_us"].items(), key=lambda kv: -kv[1])
                              if v >= 0.05)
            print(f"  {uplink} on the C core, I/O on the {label:7s}: {r['us_per_request']:6.1f} us per request "
                  f"({r.get('completed', r['requests'])} of {r['requests']} completed, {r['failed']} failed); "
                  f"threads: {split}")
        print(f"  pump / threads: {ab['pump_over_threads']:.3f}")
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(ab | {"load_average": os.getloadavg()[0], "repeats": args.repeats}, indent=2)
                             + "\n")
        print(f"written {args.json}")
        return 0
    core_rs = min(rs232_core_only(n) for _ in runs)
    core_usb = min(usb_core_only(n) for _ in runs)
    rs = min((rs232_pty(n) for _ in runs), key=lambda r: float(r["us_per_request"]))
    usb = min((usb_sensorhex(secs) for _ in runs), key=lambda r: float(r["us_per_request"]))
    cyc_poll = min((usb_sensorhex_cycle(secs) for _ in runs), key=lambda r: float(r["us_per_request"]))
    cyc_cb = min((usb_sensorhex_cycle(secs, polled=False) for _ in runs), key=lambda r: float(r["us_per_request"]))
    print(f"  RS232, pty to the hosted bridge firmware, window 15 : {rs['us_per_request']:6.1f} us "
          f"({rs['requests']} reads, {rs['failed']} failed, {rs['requests_per_s']:.0f} per s)")
    print(f"  USB, SensoRHex bridge load (6 per ms), seqpacket    : {usb['us_per_request']:6.1f} us "
          f"({usb['completed']} of {usb['requests']} completed, {usb['failed']} failed, "
          f"{usb['core_share'] * 100:.0f} % of one core)")
    for label, r in (("polled (Cycle.poll)      ", cyc_poll), ("one callback per cycle   ", cyc_cb)):
        print(f"  USB, same load, cycle API, {label}: {r['us_per_request']:6.1f} us "
              f"({r['completed']} of {r['requests']} completed, {r['failed']} failed, {r['overruns']} ticks skipped: "
              f"cycle still in flight; items submitted {'in C' if r['cycles_in_c'] else 'one by one'})")
    print(f"  protocol state machine alone ({native.BACKEND} core): RS232 {core_rs:.1f} us, USB {core_usb:.1f} us "
          f"(the rest is the runtime: threads, GIL, system calls)")
    for label, r in (("RS232", rs), ("USB", usb), ("USB cycle polled", cyc_poll), ("USB cycle callback", cyc_cb)):
        split = ", ".join(f"{k} {v:.1f}" for k, v in sorted(r["threads_us"].items(), key=lambda kv: -kv[1]) if v >= 0.05)
        print(f"  {label} threads, us per request (clock ticks, rough): {split}")
    load = (SENSORHEX_USB_BRIDGES * SENSORHEX_USB_PER_MS * 1000 * usb["us_per_request"]
            + SENSORHEX_RS232_PER_S * rs["us_per_request"]) / 1e6
    per_s = SENSORHEX_USB_BRIDGES * SENSORHEX_USB_PER_MS * 1000 + SENSORHEX_RS232_PER_S
    print(f"\nSensoRHex at 1 kHz ({per_s} requests per s): {load:.2f} of one core of this machine "
          f"({'fits' if load < 1 else 'does NOT fit'} one core; the GIL keeps the library on one)")
    cycle_load = {k: (SENSORHEX_USB_BRIDGES * SENSORHEX_USB_PER_MS * 1000 * r["us_per_request"]
                      + SENSORHEX_RS232_PER_S * rs["us_per_request"]) / 1e6 for k, r in (("polled", cyc_poll),
                                                                                        ("callback", cyc_cb))}
    print(f"  | API for the USB motors | us per USB request | share of one core (SensoRHex, RS232 per request) |")
    print(f"  |---|---:|---:|")
    print(f"  | per request (NodeRequest) | {usb['us_per_request']:.1f} | {load * 100:.1f} % |")
    print(f"  | cycle, polled | {cyc_poll['us_per_request']:.1f} | {cycle_load['polled'] * 100:.1f} % |")
    print(f"  | cycle, one callback per cycle | {cyc_cb['us_per_request']:.1f} | {cycle_load['callback'] * 100:.1f} % |")
    results = {"rs232_pty": rs, "usb_sensorhex": usb, "rs232_core_us": core_rs, "usb_core_us": core_usb,
               "sensorhex_core_share": load, "usb_cycle_polled": cyc_poll, "usb_cycle_callback": cyc_cb,
               "sensorhex_cycle_share": cycle_load["polled"], "sensorhex_cycle_callback_share": cycle_load["callback"], "core": native.BACKEND, "codecs": _codec.BACKEND, "quick": args.quick, "repeats": args.repeats,
               "python": sys.version.split()[0], "machine": platform.processor() or platform.machine(),
               "cpus": os.cpu_count(), "load_average": os.getloadavg()[0]}
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(results, indent=2) + "\n")
    print(f"written {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
