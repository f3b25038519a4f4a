"""bench/host_cpu.py keeps working: its quick run completes every request it measures.

The benchmark's numbers are not asserted (timing goals live in benchmarks, not tests); what is
asserted is what makes them meaningful: the RS232 run over the pty to the bridge firmware and the
USB run at one SensoRHex bridge's load complete every request, none failed, and the JSON holds
the projection."""

from __future__ import annotations

import json
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "bench"))

import host_cpu  # noqa: E402
import host_cpu_sensorhex  # noqa: E402


def test_quick_run_completes_every_request(tmp_path: Path) -> None:
    out = tmp_path / "host_cpu.json"
    assert host_cpu.main(["--quick", "--repeats", "1", "--json", str(out)]) == 0
    r = json.loads(out.read_text())
    rs, usb = r["rs232_pty"], r["usb_sensorhex"]
    assert rs["failed"] == 0 and rs["requests"] == 4000
    assert usb["failed"] == 0 and usb["completed"] == usb["requests"] >= 6 * 1000
    assert 0 < r["rs232_core_us"] < rs["us_per_request"]
    assert 0 < r["usb_core_us"] < usb["us_per_request"]
    assert r["sensorhex_core_share"] > 0
    for case in ("usb_cycle_polled", "usb_cycle_callback"):  # the cycle API's rows
        cyc = r[case]
        assert cyc["failed"] == 0 and cyc["completed"] == cyc["requests"] >= 6 * 500
        assert cyc["cycles_in_c"] == (r["core"] == "c")
    assert 0 < r["sensorhex_cycle_share"] < 1


def test_the_whole_sensorhex_load_runs_in_every_program(tmp_path: Path) -> None:
    """bench/host_cpu_sensorhex.py: each of its four programs (per-request and cycle API, threaded
    and cyclic runtime) completes every request it submitted, motors and sensors, without a failure
    (the shares it prints are not checked: timing goals are not tests)."""
    out = tmp_path / "host_cpu_sensorhex.json"
    assert host_cpu_sensorhex.main(["--seconds", "0.5", "--repeats", "1", "--cg-seconds", "0", "--json", str(out)]) == 0
    rows = json.loads(out.read_text())["rows"]
    assert [(r["api"], r["runtime"]) for r in rows] == [("per-request", "threaded"), ("per-request", "cyclic"),
                                                       ("cycle", "threaded"), ("cycle", "cyclic")]
    for r in rows:
        assert r["failed"] == 0 and r["completed"] == r["requests"] >= 12 * 400, r


def test_the_projection_counts_the_cyclic_programs_instructions() -> None:
    """The 500-MHz projection's runs (callgrind and strace, each with load and without) complete
    their requests, and the differences give a positive count per request."""
    p = host_cpu_sensorhex.instructions("cycle", 0.3)
    assert p["requests"] >= 12 * 10 and p["failed"] == 0, p
    assert p["instructions_per_request"] > 0 and p["syscalls_per_request"] > 0 and p["geode_share_ipc1"] > 0
