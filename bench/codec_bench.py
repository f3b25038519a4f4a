#!/usr/bin/env python3
"""URB codec benchmark: generated C and Python codecs next to MAVLink's and next to the limits.

Run by `make bench`. It prints tables of numbers and ratios and never asserts on timing; it fails
(with a message, not a traceback) only when it cannot measure: no C compiler, no pymavlink, a build
error, or C and Python codecs that disagree on the bytes of the reference frame.

Every measurement is one encode + decode round trip of a 6-byte message of three 16-bit fields:
URB's MotorFeedback (u16, i16, i16) and MAVLink's POWER_STATUS (Vcc, Vservo, flags: three u16).

Python (timeit, best of REPEATS runs of ~TARGET seconds each, per round trip):
  struct limit      struct.Struct('<Hhh').unpack(S.pack(a, b, c))
  URB payload       MotorFeedback.decode(MotorFeedback(...).encode())                     6 bytes
  URB frame         MotorFeedback into UplinkResponse.encode (CRC-8), UplinkResponse.decode
                    (CRC check), MotorFeedback.decode of its data                          8 bytes
  pymavlink frame   mav.decode(bytearray(mav.power_status_encode(...).pack(mav)))        18 bytes
                    (pack: header, payload, CRC-16 with CRC_EXTRA; decode: header, CRC check,
                    unpack, message object; bytearray because decode() appends to a slice)
  pymavlink stream  mav.parse_buffer(frame): the byte-stream parser a receiver uses, then decode()
  pymavlink, pure-Python CRC: the frame row with pymavlink's fastcrc (Rust) CRC switched off, since
                    URB's Python CRC is pure Python
The URB rows run twice: "(accelerated)" on the codec urb_msgs selects (urb_msgs._accel, the
generated C codecs, when `make accel` built it) and "(pure Python)" in a child process with
URB_PURE_PYTHON=1 (the reference codecs; construction pure too). A summary prints the frame round
trip's ratios to pymavlink and struct side by side for both (issue #38: pymavlink / URB >= 10,
URB / struct <= 4).

C (bench/c/codec_bench.c, -O2, clock_gettime(CLOCK_MONOTONIC), best of REPEATS): memcpy limit,
URB payload, URB frame, MAVLink frame (mavlink_msg_power_status_pack + mavlink_msg_to_send_buffer,
mavlink_parse_char over every byte + mavlink_msg_power_status_decode). Built twice, and every C
row measured for both builds: "separate TUs" compiles gen/c/*.c as their own translation units, so
each codec is a call; "LTO" adds -flto to compile and link, as a firmware image that links the
generated codecs into its own code can (the codecs are then inlined where the optimizer chooses). The MAVLink C headers are
generated into build/bench/mavlink by pymavlink's mavgen on every run (not committed). With
valgrind present, callgrind counts instructions per round trip (repeatable, unlike time).

Wire efficiency: payload bytes / wire bytes for 2, 6, 10 and 31-byte payloads, URB frames encoded
by the generated Python codecs, MAVLink v2 computed (10-byte header + payload + 2-byte CRC).

Numbers also go to build/bench/codec_bench.json.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import datetime
import importlib
import json
import os
import platform
import re
import shlex
import shutil
import struct
import subprocess
import sys
import tempfile
import time
import timeit
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table

ROOT = Path(__file__).resolve().parent.parent
BUILD = ROOT / "build" / "bench"
GEN_C = ROOT / "gen" / "c"
C_SOURCE = ROOT / "bench" / "c" / "codec_bench.c"
PAYLOAD_SIZES = (2, 6, 10, 31)
C_FLAGS = ("-O2", "-std=c11", "-Wall", "-Wextra", "-Wno-address-of-packed-member")
# The two C builds: (label, executable name, flags added to C_FLAGS for compiling and linking).
C_BUILDS: tuple[tuple[str, str, tuple[str, ...]], ...] = (
    ("separate TUs", "codec_bench", ()), ("LTO", "codec_bench_lto", ("-flto",)))

# Reference values (input 0 of the C benchmark's input table): the same three 16-bit numbers in
# both protocols; POWER_STATUS has only unsigned fields, so -1500 travels as 64036.
REF_A, REF_B, REF_C = 1000, -1500, 12000


class BenchError(Exception):
    """A reason the benchmark cannot run, printed without a traceback."""


@dataclass
class Timing:
    """Best time of one round trip over several repeats."""

    name: str
    what: str
    wire_bytes: int
    best_ns: float
    worst_ns: float
    iterations: int
    repeats: int
    instructions: float | None = None

    @property
    def spread(self) -> float:
        """(worst - best) / best over the repeats: how noisy the machine was."""
        return (self.worst_ns - self.best_ns) / self.best_ns

    @property
    def per_second(self) -> float:
        return 1e9 / self.best_ns


# ---- machine ------------------------------------------------------------------------------


def first_line(cmd: Sequence[str]) -> str:
    """First output line of a version command, or 'not found'."""
    try:
        out = subprocess.run(list(cmd), capture_output=True, text=True, timeout=20, check=False)
    except (OSError, subprocess.TimeoutExpired):
        return "not found"
    text = (out.stdout or out.stderr).strip()
    return text.splitlines()[0] if text else "not found"


def cpu_model() -> str:
    try:
        text = Path("/proc/cpuinfo").read_text(encoding="utf-8", errors="replace")
    except OSError:
        return platform.processor() or "unknown"
    m = re.search(r"^model name\s*:\s*(.+)$", text, re.MULTILINE)
    return m.group(1).strip() if m else (platform.processor() or "unknown")


def machine_info(cc: list[str], mavlink_common: Any) -> dict[str, str]:
    u = platform.uname()
    fast_crc = getattr(mavlink_common, "mcrf4xx", None) is not None
    return {
        "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        "uname": f"{u.system} {u.node} {u.release} {u.version} {u.machine}",
        "cpu": f"{cpu_model()} ({os.cpu_count()} logical CPUs)",
        "python": f"{platform.python_implementation()} {platform.python_version()}",
        "cc": f"{shlex.join(cc)}: {first_line([*cc, '--version'])}",
        "c_flags": " ".join(C_FLAGS) + "; " + ", ".join(
            f"{label}: {' '.join(extra) or 'no more'}" for label, _exe, extra in C_BUILDS),
        "valgrind": first_line(["valgrind", "--version"]) if shutil.which("valgrind") else "not found",
        "pymavlink": f"{pymavlink_version()} (CRC: {'fastcrc, native' if fast_crc else 'pure Python'})",
    }


def pymavlink_version() -> str:
    try:
        from importlib.metadata import version

        return version("pymavlink")
    except Exception:  # noqa: BLE001 - metadata is informational only
        return "unknown"


# ---- Python -------------------------------------------------------------------------------


def calibrate(timer: timeit.Timer, target: float) -> int:
    """Executions of the timer's statement that take about target seconds."""
    n = 1
    while True:
        t = timer.timeit(n)
        if t >= target / 10:
            return max(1, int(n * target / t))
        n *= 10


def time_interleaved(stmts: list[tuple[str, dict[str, Any]]], target: float,
                     repeats: int) -> list[tuple[float, float, int]]:
    """Best and worst seconds per execution of each statement, and the executions per repeat.

    The repeats go round the statements in turn, so a burst of load from elsewhere on the machine
    hits every case alike instead of one case's whole series.
    """
    timers = [timeit.Timer(stmt, globals=globs) for stmt, globs in stmts]
    counts = [calibrate(t, target) for t in timers]
    runs: list[list[float]] = [[] for _ in timers]
    for _ in range(repeats):
        for k, timer in enumerate(timers):
            runs[k].append(timer.timeit(counts[k]) / counts[k])
    return [(min(r), max(r), n) for r, n in zip(runs, counts)]


def python_cases(mav_common: Any) -> list[tuple[str, str, int, str, dict[str, Any]]]:
    """(name, what is timed, wire bytes, statement, globals) for every Python case."""
    from urb_msgs.sensorhex import MotorFeedback
    from urb_msgs.urb_core import Status, UplinkResponse

    mav = mav_common.MAVLink(None, srcSystem=1, srcComponent=1) if mav_common is not None else None
    ub = REF_B & 0xFFFF
    g: dict[str, Any] = {
        "S": struct.Struct("<Hhh"),
        "MotorFeedback": MotorFeedback,
        "UplinkResponse": UplinkResponse,
        "Status": Status,
        "mav": mav,
        "a": REF_A,
        "b": REF_B,
        "ub": ub,
        "c": REF_C,
    }
    mav_frame = "mav.decode(bytearray(mav.power_status_encode(a, ub, c).pack(mav)))"
    return [
        ("struct limit", "struct.Struct('<Hhh').unpack(S.pack(a, b, c))", 6, "S.unpack(S.pack(a, b, c))", g),
        (
            "URB payload",
            "MotorFeedback.decode(MotorFeedback(...).encode())",
            6,
            "MotorFeedback.decode(MotorFeedback(encoder=a, current=b, voltage=c).encode())",
            g,
        ),
        (
            "URB frame",
            "MotorFeedback in UplinkResponse: encode + CRC-8, decode + CRC check",
            8,
            "MotorFeedback.decode(UplinkResponse.decode(UplinkResponse(seq=0, status=Status.OK, "
            "data=MotorFeedback(encoder=a, current=b, voltage=c).encode()).encode()).data)",
            g,
        ),
        (
            "pymavlink frame",
            "power_status_encode(...).pack(mav), mav.decode(): CRC-16 both ways",
            18,
            mav_frame,
            g,
        ),
        (
            "pymavlink stream",
            "the same, received with mav.parse_buffer() (the stream parser)",
            18,
            "mav.parse_buffer(mav.power_status_encode(a, ub, c).pack(mav))",
            g,
        ),
    ]


def check_python_cases(cases: list[tuple[str, str, int, str, dict[str, Any]]]) -> None:
    """Each statement must give back the three numbers it encoded (a mis-set case is no benchmark)."""
    want_urb = (REF_A, REF_B, REF_C)
    want_mav = (REF_A, REF_B & 0xFFFF, REF_C)
    for name, _what, _wire, stmt, globs in cases:
        got: Any = eval(stmt, globs)  # noqa: S307 - our own statements
        if isinstance(got, list):
            got = got[0] if len(got) == 1 else None
        if isinstance(got, tuple):
            values: tuple[int, ...] = got
        elif hasattr(got, "encoder"):
            values = (got.encoder, got.current, got.voltage)
        elif hasattr(got, "Vcc"):
            values = (got.Vcc, got.Vservo, got.flags)
        else:
            raise BenchError(f"Python case {name!r} returned {got!r}")
        want = want_mav if name.startswith("pymavlink") else want_urb
        if values != want:
            raise BenchError(f"Python case {name!r} decoded {values}, expected {want}")


URB_ROWS = ("URB payload", "URB frame")
PURE = " (pure Python)"
ACCEL = " (accelerated)"


def run_python(mav_common: Any, target: float, repeats: int) -> list[Timing]:
    """Every Python case in this process (the URB rows on the codec urb_msgs selected: the
    accelerated one when built), then the URB rows once more in a child process that runs the
    pure-Python codecs (URB_PURE_PYTHON=1: construction, encode and decode all pure)."""
    from urb_msgs import _codec

    cases = python_cases(mav_common)
    check_python_cases(cases)
    # The pymavlink frame round trip once more with its native CRC switched off (URB's Python CRC
    # is pure Python); timed on its own, after the others, since the switch is module-wide.
    _, _, wire, stmt, globs = cases[3]
    stmts = [(c[3], c[4]) for c in cases]
    fast = mav_common.x25crc
    results = time_interleaved(stmts, target, repeats)
    mav_common.x25crc = mav_common._x25crc_slow
    try:
        slow = time_interleaved([(stmt, globs)], target, repeats)[0]
    finally:
        mav_common.x25crc = fast
    suffix = ACCEL if _codec.BACKEND == "accelerated" else PURE
    out = [Timing(name + (suffix if name in URB_ROWS else ""), what, wire_b, best * 1e9, worst * 1e9, n, repeats)
           for (name, what, wire_b, _s, _g), (best, worst, n) in zip(cases, results)]
    out.append(Timing("pymavlink, pure-Python CRC",
                      "pymavlink frame with its fastcrc (Rust) CRC swapped for its Python CRC",
                      wire, slow[0] * 1e9, slow[1] * 1e9, slow[2], repeats))
    if _codec.BACKEND == "accelerated":
        out += run_pure_child(target, repeats)
    return out


def run_pure_child(target: float, repeats: int) -> list[Timing]:
    """The URB rows timed by a child process on the pure-Python codecs."""
    env = {**os.environ, "URB_PURE_PYTHON": "1"}
    done = run([sys.executable, Path(__file__), "--pure-rows", f"--target={target}", f"--repeats={repeats}"],
               "the pure-Python URB rows (child process)", timeout=600, env=env)
    return [Timing(**{**rec, "name": rec["name"] + PURE}) for rec in json.loads(done)]


def pure_rows(target: float, repeats: int) -> int:
    """--pure-rows: time the URB rows in this process, which must run the pure codecs; JSON out."""
    from urb_msgs import _codec

    if _codec.BACKEND != "pure":
        raise BenchError(f"--pure-rows needs the pure-Python codecs (URB_PURE_PYTHON=1); this runs {_codec.BACKEND}")
    cases = [c for c in python_cases(None) if c[0] in URB_ROWS]
    check_python_cases(cases)
    results = time_interleaved([(c[3], c[4]) for c in cases], target, repeats)
    print(json.dumps([{"name": name, "what": what + ", pure-Python codecs (URB_PURE_PYTHON=1)", "wire_bytes": wire,
                       "best_ns": best * 1e9, "worst_ns": worst * 1e9, "iterations": n, "repeats": repeats}
                      for (name, what, wire, _s, _g), (best, worst, n) in zip(cases, results)]))
    return 0


# ---- C ------------------------------------------------------------------------------------


def find_compiler() -> list[str]:
    cc = shlex.split(os.environ.get("CC", "cc")) or ["cc"]
    if shutil.which(cc[0]) is None:
        raise BenchError(
            f"no C compiler: `{cc[0]}` is not on PATH. Install one (`make setup` installs gcc/clang "
            "with the rest of the toolchain) or point CC at a compiler, e.g. `CC=clang make bench`."
        )
    return cc


def run(cmd: Sequence[str | Path], what: str, timeout: float = 120, env: dict[str, str] | None = None) -> str:
    """Run a command; stdout on success, BenchError with the tail of its output otherwise."""
    try:
        done = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, timeout=timeout,
                              check=False, env=env)
    except subprocess.TimeoutExpired:
        raise BenchError(f"{what} took more than {timeout:.0f} s") from None
    except OSError as e:
        raise BenchError(f"{what} failed to start: {e}") from None
    if done.returncode != 0:
        tail = "\n".join((done.stderr + done.stdout).strip().splitlines()[-25:])
        raise BenchError(f"{what} failed (exit {done.returncode}):\n{shlex.join(map(str, cmd))}\n{tail}")
    return done.stdout


def generate_mavlink(mavlink_pkg: Any) -> Path:
    """MAVLink v2 C headers for common.xml, generated by pymavlink's mavgen (never committed)."""
    xml = Path(mavlink_pkg.__file__).parent / "dialects" / "v20" / "common.xml"
    if not xml.exists():
        raise BenchError(f"pymavlink's common.xml is missing: {xml}")
    out = BUILD / "mavlink"
    shutil.rmtree(out, ignore_errors=True)
    run([sys.executable, "-m", "pymavlink.tools.mavgen", "--lang=C", "--wire-protocol=2.0",
         f"--output={out}", xml], "mavgen (MAVLink C headers)")
    if not (out / "common" / "mavlink.h").exists():
        raise BenchError(f"mavgen produced no {out / 'common' / 'mavlink.h'}")
    return out


def build_c(cc: list[str], mavlink_dir: Path, name: str, extra: Sequence[str]) -> tuple[Path, bool]:
    """Compile the C benchmark with every gen/c/*.c into build/bench/<name>, with `extra` flags added
    for compiling and linking; False when the URB C codecs are not there."""
    have_urb = (GEN_C / "urb_sensorhex.h").exists() and (GEN_C / "urb_core.h").exists()
    sources = sorted(GEN_C.glob("*.c")) if have_urb else []
    exe = BUILD / name
    cmd: list[str | Path] = [*cc, *C_FLAGS, *extra, f"-DURB_HAVE_C_CODECS={int(have_urb)}",
                             "-I", GEN_C, "-I", mavlink_dir, C_SOURCE, *sources, "-o", exe]
    run(cmd, f"compiling bench/c/codec_bench.c ({' '.join(extra) or 'separate translation units'})")
    return exe, have_urb


def check_vectors(exe: Path, have_urb: bool, mav_common: Any) -> None:
    """The C codecs must put the same bytes on the wire as the Python ones for input 0."""
    from urb_msgs.sensorhex import MotorFeedback
    from urb_msgs.urb_core import Status, UplinkResponse

    payload = MotorFeedback(encoder=REF_A, current=REF_B, voltage=REF_C).encode()
    mav = mav_common.MAVLink(None, srcSystem=1, srcComponent=1)
    want = {
        "mavlink_frame": mav.power_status_encode(REF_A, REF_B & 0xFFFF, REF_C).pack(mav).hex(),
    }
    if have_urb:
        want["urb_frame"] = UplinkResponse(seq=0, status=Status.OK, data=payload).encode().hex()
    got = dict(line.partition(" ")[::2] for line in run([exe, "vectors"], "C reference frames").splitlines())
    for name, hexbytes in want.items():
        if got.get(name) != hexbytes:
            raise BenchError(f"C and Python disagree on the {name} bytes for the reference values: "
                             f"C {got.get(name)}, Python {hexbytes}")


C_WHAT = {
    "memcpy": ("memcpy limit", "memcpy of a 6-byte struct into a buffer and back (no checks)", 6),
    "urb_payload": ("URB payload", "urb_motor_feedback_encode + _decode", 6),
    "memcpy4": ("memcpy limit, 4 B", "memcpy of a 4-byte struct into a buffer and back (MotorStatus's limit)", 4),
    "urb_status": ("URB MotorStatus", "urb_motor_status_encode + _decode: i16, 2-bit enum, three bools, u8", 4),
    "hand_status_bare": ("hand MotorStatus, bare", "MotorStatus packed and unpacked by hand, inlined, "
                         "no checks: the floor of its wire layout", 4),
    "hand_status_checked": ("hand MotorStatus, checked", "the bare row plus the generated codec's checks "
                            "(enum member, reserved bits, length)", 4),
    "urb_read_request": ("URB read request", "urb_uplink_read_request_encode + _decode: sub-byte fields, CRC-8",
                         4),
    "urb_frame": ("URB frame", "urb_uplink_response_encode/_decode (CRC-8) around "
                  "urb_motor_feedback_encode/_decode", 8),
    "mavlink_frame": ("MAVLink frame", "mavlink_msg_power_status_pack + _to_send_buffer, "
                      "mavlink_parse_char per byte + _decode", 18),
}


def run_c(exe: Path, target: float, repeats: int) -> list[Timing]:
    out = []
    for line in run([exe, "time", f"{target}", f"{repeats}"], "C benchmark").splitlines():
        rec = json.loads(line)
        name, what, wire = C_WHAT[rec["case"]]
        t = Timing(name, what, wire, float(rec["best_ns"]), float(rec["worst_ns"]), int(rec["iterations"]),
                   int(rec["repeats"]))
        out.append(t)
    return out


def run_c_alternating(exes: list[tuple[str, tuple[str, ...], Path]], target: float,
                      repeats: int) -> list[tuple[str, tuple[str, ...], list[Timing]]]:
    """Every build measured `repeats` times, the builds taking turns (A, B, A, B, ...) so that a change
    of the machine's load hits both alike; per case the best and worst of the turns."""
    turns: list[list[list[Timing]]] = [[] for _ in exes]
    for _ in range(repeats):
        for i, (_label, _extra, exe) in enumerate(exes):
            turns[i].append(run_c(exe, target, 1))
    out = []
    for (label, extra, _exe), runs in zip(exes, turns):
        rows = []
        for same_case in zip(*runs):
            first = same_case[0]
            rows.append(Timing(first.name, first.what, first.wire_bytes, min(t.best_ns for t in same_case),
                               max(t.worst_ns for t in same_case), first.iterations, len(same_case)))
        out.append((label, extra, rows))
    return out


C_CASE_OF = {display: case for case, (display, _what, _wire) in C_WHAT.items()}


def callgrind_total(exe: Path, case: str, n: int, tmp: Path) -> int:
    """Instructions executed inside case_<case> over n round trips."""
    outfile = tmp / f"callgrind.{case}.{n}"
    run(["valgrind", "--tool=callgrind", f"--toggle-collect=case_{case}", f"--callgrind-out-file={outfile}",
         exe, "count", case, str(n)], f"callgrind on {case}")
    text = outfile.read_text(encoding="utf-8", errors="replace")
    m = re.search(r"^(?:summary|totals):\s*(\d+)", text, re.MULTILINE)
    if not m:
        raise BenchError(f"no instruction total in {outfile}")
    return int(m.group(1))


def run_callgrind(exe: Path, timings: list[Timing]) -> None:
    """Instructions per round trip, from two run lengths so start-up costs cancel out."""
    n1, n2 = 1000, 3000
    cases = [C_CASE_OF[t.name] for t in timings]
    with tempfile.TemporaryDirectory(prefix="urb-callgrind-") as d:
        tmp = Path(d)
        jobs = [(c, n) for c in cases for n in (n1, n2)]
        with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, min(4, os.cpu_count() or 1))) as pool:
            totals = dict(zip(jobs, pool.map(lambda j: callgrind_total(exe, j[0], j[1], tmp), jobs)))
    for t in timings:
        c = C_CASE_OF[t.name]
        t.instructions = (totals[(c, n2)] - totals[(c, n1)]) / (n2 - n1)


# ---- wire efficiency ----------------------------------------------------------------------


def wire_efficiency() -> list[dict[str, int]]:
    from urb_msgs.urb_core import (
        DownlinkReadResponse,
        MailboxSelect,
        Status,
        UplinkResponse,
        UplinkWriteRequest,
    )

    rows = []
    for n in PAYLOAD_SIZES:
        data = bytes(n)
        rows.append({
            "payload": n,
            "urb_read_response": len(UplinkResponse(seq=0, status=Status.OK, data=data).encode()),
            "urb_i2c_read": 1 + len(DownlinkReadResponse(select=MailboxSelect(mailbox=1, read=True),
                                                         data=data).encode()),
            "urb_write_request": len(UplinkWriteRequest(address=1, mailbox=1, seq=0, data=data).encode()),
            "mavlink_v2": 10 + n + 2,
            "mavlink_v2_signed": 10 + n + 2 + 13,
        })
    return rows


# ---- output -------------------------------------------------------------------------------


def fmt_ns(ns: float) -> str:
    return f"{ns:,.1f}" if ns < 100 else f"{ns:,.0f}"


def fmt_rate(per_s: float) -> str:
    return f"{per_s / 1e6:,.2f} M" if per_s >= 1e6 else f"{per_s / 1e3:,.0f} k"


def ratio_table(title: str, rows: list[Timing], limit: Timing, ref: Timing | None, ref_label: str,
                with_instructions: bool) -> Table:
    table = Table(title=title, title_justify="left")
    table.add_column("case")
    table.add_column("wire B", justify="right")
    table.add_column("ns", justify="right")
    table.add_column("round trips/s", justify="right")
    table.add_column("spread", justify="right")
    table.add_column("t / limit", justify="right")
    table.add_column(f"t / {ref_label}", justify="right")
    if with_instructions:
        table.add_column("instr.", justify="right")
        table.add_column(f"instr. / {ref_label}", justify="right")
    for t in rows:
        cells = [t.name, str(t.wire_bytes), fmt_ns(t.best_ns), fmt_rate(t.per_second), f"{t.spread:.0%}",
                 f"{t.best_ns / limit.best_ns:.2f}", f"{t.best_ns / ref.best_ns:.2f}" if ref else "-"]
        if with_instructions:
            ir = t.instructions
            ref_ir = ref.instructions if ref else None
            cells.append(f"{ir:,.0f}" if ir is not None else "-")
            cells.append(f"{ir / ref_ir:.2f}" if ir is not None and ref_ir else "-")
        table.add_row(*cells)
    return table


def codec_summary(console: Console, by: dict[str, Timing]) -> None:
    """The Python frame round trip against issue #38's goals: at least 10x faster than pymavlink's
    frame, within 4x of struct; and what the accelerated codecs gain over the pure ones."""
    struct_t, mav = by["struct limit"], by["pymavlink frame"]
    console.print("  Python frame round trip, side by side (goal of issue #38: pymavlink / URB >= 10, URB / struct <= 4):",
                  highlight=False)
    for suffix in (ACCEL, PURE):
        frame = by.get("URB frame" + suffix)
        payload = by.get("URB payload" + suffix)
        if frame is None or payload is None:
            continue
        console.print(f"    URB frame{suffix:<16} {fmt_ns(frame.best_ns):>8} ns   pymavlink / URB {mav.best_ns / frame.best_ns:6.2f}"
                      f"   URB / struct {frame.best_ns / struct_t.best_ns:6.2f}   (payload: URB / struct "
                      f"{payload.best_ns / struct_t.best_ns:.2f})", highlight=False, markup=False)
    a, p = by.get("URB frame" + ACCEL), by.get("URB frame" + PURE)
    if a is not None and p is not None:
        pa, pp = by["URB payload" + ACCEL], by["URB payload" + PURE]
        console.print(f"    accelerated / pure-Python time: frame {a.best_ns / p.best_ns:.2f}, payload "
                      f"{pa.best_ns / pp.best_ns:.2f}", highlight=False, markup=False)
    else:
        from urb_msgs import _codec

        console.print(f"    no accelerated row: urb_msgs runs the pure-Python codecs ({_codec.REASON})",
                      highlight=False, markup=False)


def legend(console: Console, rows: list[Timing]) -> None:
    width = max(len(t.name) for t in rows)
    for t in rows:
        console.print(f"  {t.name:<{width}}  {t.what}", highlight=False, markup=False)


def wire_table(rows: list[dict[str, int]]) -> Table:
    table = Table(title="Wire efficiency: payload bytes / wire bytes (wire bytes in brackets)",
                  title_justify="left")
    table.add_column("payload B", justify="right")
    for label in ("URB RS232/USB read response", "URB I2C read (address byte + data + check)",
                  "URB write request", "MAVLink v2", "MAVLink v2 signed"):
        table.add_column(label, justify="right", overflow="fold", max_width=22)
    for r in rows:
        n = r["payload"]
        cells = [str(n)]
        for key in ("urb_read_response", "urb_i2c_read", "urb_write_request", "mavlink_v2",
                    "mavlink_v2_signed"):
            cells.append(f"{n / r[key]:.0%} ({r[key]})")
        table.add_row(*cells)
    return table


NOTES = """\
Reading the tables: "t / X" is this row's time divided by X's (below 1: faster than X); the
limits (struct / memcpy) do no range checks and no CRC, so no codec reaches 1. The fair protocol
comparison is frame against frame: URB's 8-byte UplinkResponse (1 header byte, CRC-8) against
MAVLink v2's 18-byte frame (10-byte header, CRC-16 with CRC_EXTRA). URB decodes a frame whose length
the host already knows (the pending request says it); MAVLink C has only a byte-wise stream parser.
URB C codecs: "separate TUs" calls them, "LTO" (-flto) may inline them; MAVLink's are static inline.
Wire efficiency assumes MAVLink v2 unsigned unless marked signed (+13 bytes) and no trimming of
trailing zero payload bytes (v2 trims them, so a real frame can be shorter). The URB read response
also needs its 4-byte read request on the other direction of the link; an I2C read re-sends the
select byte (+1) only when the selected outbox changes. I2C ACK, start and stop bits not counted."""


def status_floor_line(byc: dict[str, Timing]) -> str:
    """How far the 4-byte memcpy limit is from what MotorStatus's wire layout allows at all: the
    hand-written bare and checked codecs over memcpy4, and the generated codec over the checked one."""
    names = ("hand MotorStatus, bare", "hand MotorStatus, checked", "URB MotorStatus", "memcpy limit, 4 B")
    if not all(n in byc for n in names):
        return ""
    bare, checked, urb, limit = (byc[n] for n in names)
    parts = [f"bare/memcpy4 {bare.best_ns / limit.best_ns:.2f}, checked/memcpy4 {checked.best_ns / limit.best_ns:.2f}, "
             f"generated/checked {urb.best_ns / checked.best_ns:.2f} (time)"]
    if all(t.instructions for t in (bare, checked, urb, limit)):
        parts.append(f"{(bare.instructions or 0) / (limit.instructions or 1):.2f}, "
                     f"{(checked.instructions or 0) / (limit.instructions or 1):.2f}, "
                     f"{(urb.instructions or 0) / (checked.instructions or 1):.2f} (instructions)")
    return ", ".join(parts)


def print_report(console: Console, info: dict[str, str], py: list[Timing],
                 c: list[tuple[str, tuple[str, ...], list[Timing]]],
                 have_urb_c: bool, wire: list[dict[str, int]], elapsed: float) -> None:
    console.print("[bold]URB codec benchmark[/bold]  (bench/codec_bench.py: numbers and ratios, no pass/fail)")
    for key in ("date", "uname", "cpu", "python", "cc", "c_flags", "valgrind", "pymavlink"):
        console.print(f"  {key:<9} {info[key]}", highlight=False, markup=False)
    console.print()
    by = {t.name: t for t in py}
    console.print(ratio_table("Python: one encode + decode round trip of a 6-byte message (best of "
                              f"{py[0].repeats})", py, by["struct limit"], by["pymavlink frame"],
                              "pymavlink", False))
    legend(console, py)
    codec_summary(console, by)
    console.print()
    with_ir = False
    for label, extra, rows in c:
        byc = {t.name: t for t in rows}
        with_ir = with_ir or any(t.instructions is not None for t in rows)
        console.print(ratio_table(f"C ({' '.join((*C_FLAGS[:1], *extra))}, {label}): one encode + decode round "
                                  f"trip of a 6-byte message (best of {rows[0].repeats})", rows,
                                  byc["memcpy limit"], byc.get("MAVLink frame"), "MAVLink", with_ir))
    legend(console, c[0][2])
    for label, _extra, rows in c:
        byc = {t.name: t for t in rows}
        if "URB payload" in byc and "URB MotorStatus" in byc:
            pairs = ((byc["URB payload"], byc["memcpy limit"]), (byc["URB MotorStatus"], byc["memcpy limit, 4 B"]))
            ratios = f"MotorFeedback/memcpy {pairs[0][0].best_ns / pairs[0][1].best_ns:.2f}, MotorStatus/memcpy4 " \
                     f"{pairs[1][0].best_ns / pairs[1][1].best_ns:.2f} (time)"
            if all(a.instructions and b.instructions for a, b in pairs):
                ratios += ", " + ", ".join(f"{(a.instructions or 0) / (b.instructions or 1):.2f}"
                                           for a, b in pairs) + " (instructions)"
            console.print(f"  sub-byte fields (issue #38 goal: codec / memcpy <= 2), {label}: {ratios}",
                          highlight=False, markup=False)
        floor_line = status_floor_line(byc)
        if floor_line:
            console.print(f"  MotorStatus floor, {label}: {floor_line}", highlight=False, markup=False)
    if not have_urb_c:
        console.print("[yellow]gen/c has no URB C codecs yet: URB C rows skipped[/yellow]")
    if with_ir:
        console.print("  instr.: instructions per round trip (callgrind), loop and barriers included "
                      "(the memcpy row is mostly those)", highlight=False)
    console.print()
    console.print(wire_table(wire))
    console.print()
    console.print(NOTES, highlight=False, markup=False)
    console.print(f"\n(finished in {elapsed:.1f} s; numbers in {rel(BUILD / 'codec_bench.json')})",
                  highlight=False)


def rel(p: Path) -> str:
    try:
        return str(p.relative_to(ROOT))
    except ValueError:
        return str(p)


# ---- main ---------------------------------------------------------------------------------


def import_pymavlink() -> tuple[Any, Any]:
    try:
        pkg = importlib.import_module("pymavlink")
        common = importlib.import_module("pymavlink.dialects.v20.common")
    except ImportError as e:
        raise BenchError(f"pymavlink is not installed ({e}); `make setup` installs it") from None
    return pkg, common


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    ap.add_argument("--target", type=float, default=0.2, help="seconds per measurement (default 0.2)")
    ap.add_argument("--repeats", type=int, default=5, help="measurements per case, best kept (default 5)")
    ap.add_argument("--no-callgrind", action="store_true", help="skip the callgrind instruction counts")
    ap.add_argument("--json", type=Path, default=BUILD / "codec_bench.json", help="where to write the numbers")
    ap.add_argument("--pure-rows", action="store_true",
                    help="only time the URB Python rows and print them as JSON (the child run with URB_PURE_PYTHON=1)")
    args = ap.parse_args(argv)
    if args.target <= 0 or args.repeats < 1:
        ap.error("--target must be positive and --repeats at least 1")
    if args.pure_rows:
        try:
            return pure_rows(args.target, args.repeats)
        except BenchError as e:
            print(f"codec_bench: error: {e}", file=sys.stderr)
            return 1

    wide = None if sys.stdout.isatty() else 112
    console = Console(width=wide)
    start = time.monotonic()
    try:
        cc = find_compiler()
        mav_pkg, mav_common = import_pymavlink()
        BUILD.mkdir(parents=True, exist_ok=True)
        info = machine_info(cc, mav_common)
        mavlink_dir = generate_mavlink(mav_pkg)
        exes: list[tuple[str, tuple[str, ...], Path]] = []
        for label, name, extra in C_BUILDS:
            exe, have_urb_c = build_c(cc, mavlink_dir, name, extra)
            check_vectors(exe, have_urb_c, mav_common)
            exes.append((label, extra, exe))
        py = run_python(mav_common, args.target, args.repeats)
        c = run_c_alternating(exes, args.target, args.repeats)
        if not args.no_callgrind and shutil.which("valgrind"):
            for (_label, _extra, exe), (_l, _e, rows) in zip(exes, c):
                run_callgrind(exe, rows)
        wire = wire_efficiency()
    except BenchError as e:
        print(f"codec_bench: error: {e}", file=sys.stderr)
        return 1
    elapsed = time.monotonic() - start

    args.json.parent.mkdir(parents=True, exist_ok=True)
    record = {
        "machine": info,
        "target_seconds": args.target,
        "repeats": args.repeats,
        "python": [timing_json(t) for t in py],
        "c": {label: [timing_json(t) for t in rows] for label, _extra, rows in c},
        "urb_c_codecs": have_urb_c,
        "wire_efficiency": [{**r, **{f"{k}_efficiency": round(r["payload"] / v, 4) for k, v in r.items()
                                     if k != "payload"}} for r in wire],
        "elapsed_seconds": round(elapsed, 1),
    }
    args.json.write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")
    print_report(console, info, py, c, have_urb_c, wire, elapsed)
    return 0


def timing_json(t: Timing) -> dict[str, Any]:
    return {
        "case": t.name,
        "what": t.what,
        "wire_bytes": t.wire_bytes,
        "best_ns": round(t.best_ns, 3),
        "worst_ns": round(t.worst_ns, 3),
        "round_trips_per_second": round(t.per_second),
        "iterations": t.iterations,
        "repeats": t.repeats,
        "instructions": None if t.instructions is None else round(t.instructions, 1),
    }


if __name__ == "__main__":
    sys.exit(main())
