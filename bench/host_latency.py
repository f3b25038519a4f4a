#!/usr/bin/env python3
"""API-level round-trip latency of the URB host library versus payload size (paper Figs. 15, 16).

For every payload size the SensoRHex schema offers (4..25 bytes: IrRange, MotorFeedback,
BridgeInfo, ImuSample, BridgeScan, BatteryStatus, Identification), 1000 periodic reads at 1 kHz
(as in the paper) go through `NodeAccessor.submit_request`, and the latency from submission to
callback invocation is taken from the request's own timestamps. Three columns per size:

* **pty**: RS232Manager over pyserial to a bridge process on a pseudo-terminal (the Python fake
  bridge, or with --hosted the bridge firmware compiled for the host). A pty moves bytes at memory
  speed, so this is the host software's share: threads, parsing, dispatch, scheduling.
* **115200 Bd model**: the same API in virtual time (SimManager, LoopbackByteTransport at
  115200 Bd 8N1, I2C at 400 kb/s): what the wire adds on a real UART, exact and deterministic;
  once with one request at a time, once at the loop rate (where long responses saturate the line).
* **USB model**: SimManager over the 1-ms batched USB pipe (write n / read n-1): the paper's
  constant 2..3 ms.

Prints a table and writes a histogram and a latency-versus-size plot to build/bench/.
This is a benchmark, not a test: nothing is asserted.

    python3 bench/host_latency.py [--count 1000] [--rate 1000] [--hosted]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests" / "host"))

from bridge_proc import FAKE_BRIDGE, SENSORHEX, BridgeProc  # noqa: E402
from urb.api import NodeAccessor, NodeRequest, URBInterface  # noqa: E402
from urb.managers import (  # noqa: E402
    BridgeModel,
    LoopbackByteTransport,
    LoopbackFrameTransport,
    RS232Manager,
    SimManager,
    VirtualClock,
    fake_node,
)
from urb.managers.base import NS_PER_MS  # noqa: E402

HOSTED = REPO / "build" / "firmware" / "urb-bridge-hosted"
OUT = REPO / "build" / "bench"

# (label, node name or "Bridge", index, outbox) -> payload size from the schema
TARGETS = [("IrRange", "IrDistance", 1), ("MotorFeedback", "MotorDriver", 1), ("BridgeInfo", "Bridge", 0),
           ("ImuSample", "Imu", 1), ("BridgeScan", "Bridge", 1), ("BatteryStatus", "BatteryManager", 1),
           ("Identification", "MotorDriver", 0)]


@dataclass
class Series:
    label: str
    size: int
    lat_us: list[float]

    def stats(self) -> tuple[float, float, float, float]:
        v = sorted(self.lat_us)
        if not v:
            return (float("nan"),) * 4
        return statistics.fmean(v), v[len(v) // 2], v[min(len(v) - 1, int(len(v) * 0.99))], v[-1]


def accessor(urb: URBInterface, m: object, node: str) -> NodeAccessor:
    return urb.bridge_node(m) if node == "Bridge" else urb.find_node(node, 0)  # type: ignore[arg-type]


def run_realtime(urb: URBInterface, m: RS232Manager, count: int, rate: float) -> list[Series]:
    out = []
    for label, node, box in TARGETS:
        acc = accessor(urb, m, node)
        size = acc.new_request().read(box).size
        lat: list[float] = []
        lock = threading.Lock()

        def cb(r: NodeRequest) -> None:
            if r.ok and r.latency_ns is not None:
                with lock:
                    lat.append(r.latency_ns / 1e3)

        period = int(1e9 / rate)
        start = time.monotonic_ns()
        reqs = []
        for k in range(count):
            while (d := start + k * period - time.monotonic_ns()) > 0:
                time.sleep(d / 1e9)
            reqs.append(acc.submit_request(acc.new_request().read(box).set_callback(cb)))
        for r in reqs:
            r.wait(2.0)
        failed = sum(1 for r in reqs if not r.ok)
        if failed:
            print(f"  {label}: {failed} of {count} requests failed", file=sys.stderr)
        out.append(Series(label, size, lat))
    return out


def run_virtual(kind: str, count: int, rate: float) -> list[Series]:
    clock = VirtualClock()
    model = BridgeModel(dict(fake_node(s.replace("0x", "")) for s in SENSORHEX), timed_downlink=True)
    transport = LoopbackByteTransport(clock, model) if kind == "rs232" else LoopbackFrameTransport(clock, model)
    m = SimManager(clock, transport, name=f"sim-{kind}")
    urb = URBInterface()
    urb.add_bus_manager(m)
    out = []
    period = int(1e9 / rate)
    for label, node, box in TARGETS:
        acc = accessor(urb, m, node)
        size = acc.new_request().read(box).size
        lat: list[float] = []

        def submit(acc: NodeAccessor = acc, box: int = box, lat: list[float] = lat) -> None:
            acc.submit_request(acc.new_request().read(box).set_callback(lambda r: lat.append((r.latency_ns or 0) / 1e3)))

        t0 = clock.now_ns() + NS_PER_MS
        for k in range(count):
            phase = (k * 7919) % 1000 * 1000  # spread submissions over the 1-ms frame
            clock.call_at(t0 + k * period + phase, submit)
        clock.run_for(count * period)
        clock.run_until(lambda: len(lat) == count, clock.now_ns() + 600 * 1_000_000_000)  # drain the backlog
        out.append(Series(label, size, lat))
    return out


def start_bridge(hosted: bool, tmp: Path) -> BridgeProc:
    if hosted:
        if not HOSTED.exists():
            r = subprocess.run(["make", "-C", str(REPO), "bridge-hosted"], capture_output=True, text=True)
            if r.returncode != 0 or not HOSTED.exists():
                sys.exit(f"host_latency: cannot build {HOSTED.relative_to(REPO)} (make bridge-hosted):\n{r.stderr[-2000:]}")
        from bridge_proc import hosted_argv

        argv = hosted_argv(SENSORHEX)
    else:
        argv = [sys.executable, str(FAKE_BRIDGE)] + [a for s in SENSORHEX for a in ("--node", s)]
    return BridgeProc(argv, tmp / "ttyBENCH").start()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--count", type=int, default=1000, help="reads per payload size (default 1000)")
    ap.add_argument("--rate", type=float, default=1000.0, help="loop frequency in Hz (default 1000)")
    ap.add_argument("--hosted", action="store_true", help="use the bridge firmware compiled for the host")
    args = ap.parse_args()

    with tempfile.TemporaryDirectory() as tmpdir:
        bp = start_bridge(args.hosted, Path(tmpdir))
        urb = URBInterface()
        m = RS232Manager(str(bp.link), timeout_s=1.0, lost_after_s=5.0)
        try:
            urb.add_bus_manager(m)
            pty = run_realtime(urb, m, args.count, args.rate)
        finally:
            urb.close()
            bp.close()
    wire = run_virtual("rs232", args.count, args.rate)
    isolated = run_virtual("rs232", 20, 50.0)  # one request at a time: no queueing on the line
    usb = run_virtual("usb", args.count, args.rate)

    bridge_name = "hosted bridge firmware" if args.hosted else "Python fake bridge"
    load = os.getloadavg()[0]
    print(f"API round-trip latency (submission -> callback), {args.count} reads at {args.rate:g} Hz per size")
    print(f"pty: RS232Manager + pyserial to the {bridge_name} (load average {load:.1f} on {os.cpu_count()} CPUs)\n")
    print(f"{'message':<15} {'bytes':>5} {'resp':>4} | {'pty mean':>8} {'median':>7} {'p99':>7} {'max':>7} | "
          f"{'115200 Bd':>9} {'at rate':>8} | {'USB mean':>8} {'max':>6}   (us)")
    for p, i, w, u in zip(pty, isolated, wire, usb):
        resp = 1 + p.size + (1 if 1 + p.size <= 14 else 2)
        pm, pmed, p99, pmax = p.stats()
        um, _, _, umax = u.stats()
        print(f"{p.label:<15} {p.size:>5} {resp:>4} | {pm:>8.0f} {pmed:>7.0f} {p99:>7.0f} {pmax:>7.0f} | "
              f"{i.stats()[0]:>9.0f} {w.stats()[0]:>8.0f} | {um:>8.0f} {umax:>6.0f}")
    byte_us = 10 / 115200 * 1e6
    print(f"\n115200 Bd: one request alone, (4 request + resp) x {byte_us:.1f} us + the I2C transaction at 400 kb/s"
          f"\n(virtual time); 'at rate': the same at {args.rate:g} Hz, where the response line saturates once a response"
          f"\ntakes longer than the period ({1e6 / args.rate / byte_us:.2f} bytes per period at 8N1) and requests queue.")

    OUT.mkdir(parents=True, exist_ok=True)
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed: no plot written")
        return 0
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(13, 4.8))
    for s in pty:
        ax1.hist(s.lat_us, bins=80, range=(0, max(1.0, sorted(s.lat_us)[int(len(s.lat_us) * 0.995)] if s.lat_us else 1)),
                 histtype="step", label=f"{s.label} ({s.size} B)")
    ax1.set_xlabel("latency, submission to callback (us)")
    ax1.set_ylabel("requests")
    ax1.set_title(f"RS232Manager over a pty ({bridge_name})")
    ax1.legend(fontsize=8)
    sizes = [s.size for s in pty]
    ax2.plot(sizes, [s.stats()[0] / 1e3 for s in pty], "o-", label="pty: mean")
    ax2.plot(sizes, [s.stats()[2] / 1e3 for s in pty], "o:", label="pty: p99")
    ax2.plot(sizes, [s.stats()[0] / 1e3 for s in isolated], "s-", label="115200 Bd model, one at a time")
    ax2.plot(sizes, [s.stats()[0] / 1e3 for s in usb], "^-", label="USB model: mean (virtual time)")
    ax2.plot(sizes, [s.stats()[3] / 1e3 for s in usb], "^:", label="USB model: max")
    ax2.set_xlabel("payload (bytes)")
    ax2.set_ylabel("latency (ms)")
    ax2.set_title("Latency versus payload (cf. paper Figs. 15, 16)")
    ax2.legend(fontsize=8)
    ax2.grid(alpha=0.3)
    fig.tight_layout()
    png = OUT / "host_latency.png"
    fig.savefig(png, dpi=120)
    print(f"\nwrote {png.relative_to(REPO)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
