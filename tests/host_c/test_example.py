"""The C++ example and header against the bridge firmware compiled for the host, over a pty:
pd_control runs the paper's PD loop (at 100 Hz here) and says what it did; hpp_check uses
urb.hpp as a program written only against it would (pools, refusals, callbacks, closing with a
request in flight). Also what pd_control says when no bridge answers."""

from __future__ import annotations

import math
import os
import pty
import re
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest

from hostc_build import REPO, build

HOSTED = REPO / "build" / "firmware" / "urb-bridge-hosted"


@pytest.fixture
def motor_bridge(tmp_path: Path) -> Iterator[Path]:
    """The hosted bridge with a MotorDriver:0 at 0x20, its pty linked at tmp_path/urb."""
    proc = subprocess.run(["make", "-s", "-C", str(REPO), "bridge-hosted"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    link = tmp_path / "urb"
    bridge = subprocess.Popen([str(HOSTED), "--node", "motor,0,0x20", "--link", str(link), "--seconds", "120"],
                              stdout=subprocess.PIPE, text=True)
    try:
        assert bridge.stdout is not None
        assert bridge.stdout.readline().startswith("pty: ")
        yield link
    finally:
        bridge.terminate()
        bridge.wait(10)


def run(argv: list[str], timeout: float = 60) -> subprocess.CompletedProcess[str]:
    return subprocess.run(argv, capture_output=True, text=True, timeout=timeout, cwd=REPO)


def test_pd_control_runs_the_loop_against_the_hosted_bridge(motor_bridge: Path) -> None:
    """The loop at 100 Hz with a 1-s timeout (a 200-ms gap ends a partial response): a shared machine's
    scheduler stalls the bridge process for up to ~120 ms at load average 20-26, which at 1 kHz and the
    default 100-ms timeout and 20-ms gap fails requests correctly and empties the node's pool of 32.
    The 1-kHz load itself is measured, not tested: bench/host_cpu_c.py."""
    exe = build("build/host_c/pd_control")
    out = run([str(exe), str(motor_bridge), "--seconds", "2", "--hz", "100", "--timeout-ms", "1000"])
    text = out.stdout
    assert out.returncode == 0, text + out.stderr
    assert "pd_control: bridge " in text and "MotorDriver:0 at address 32" in text
    assert re.search(r"^pd_control: 200 cycles at 100 Hz \(runOnce\), \d+ late", text, re.M), text
    assert "reads 200 ok 200, commands 200 ok 200, not submitted 0, flags seen OK" in text, text
    m = re.search(r"read latency median (\d+) us", text)
    assert m is not None and int(m.group(1)) < 100_000
    # The fake motor does not move, so the error is the reference and the loop commands
    # Kp * ref + Kd * dref/dt, clamped to 12 V. The derivative term is a difference quotient of the
    # sinusoid (4 pi rad at 0.5 Hz), so at most Kd * 4 pi * pi = 1.97 V either way: near the
    # reference's zero crossings it outweighs Kp * ref and the command's sign is not the
    # reference's (seen: reference -0.2334 rad, command +0.105 V, 6 ms before a crossing).
    last = re.search(r"last position (\S+) rad, reference (\S+) rad, command (\S+) V", text)
    assert last is not None
    pos, ref, cmd = (float(x) for x in last.groups())
    assert pos == 0.0
    kp, kd, slope = 8.0, 0.05, 4 * math.pi * math.pi  # pd_control's defaults; the reference's steepest slope

    def clamp(u: float) -> float:
        return max(-12.0, min(12.0, u))

    rounding = 8.0 * 0.00005 + 0.0005 + 1e-9  # ref printed to 4 decimals, the command to 3
    assert clamp(kp * ref - kd * slope) - rounding <= cmd <= clamp(kp * ref + kd * slope) + rounding, text
    assert "every request succeeded" in text


def test_pd_control_cyclic_sleeps_and_services_each_tick(motor_bridge: Path) -> None:
    """--cyclic: the fixed-period pattern (urb_sleep_until, then service() once per tick): every read
    is called back and every command it writes succeeds, with one wait per tick instead of runOnce's."""
    exe = build("build/host_c/pd_control")
    out = run([str(exe), str(motor_bridge), "--seconds", "2", "--hz", "100", "--timeout-ms", "1000", "--cyclic"])
    text = out.stdout
    assert out.returncode == 0, text + out.stderr
    assert re.search(r"^pd_control: 200 cycles at 100 Hz \(cyclic: sleep, service\), \d+ late", text, re.M), text
    assert "reads 200 ok 200, commands 200 ok 200, not submitted 0, flags seen OK" in text, text
    assert "every request succeeded" in text


def test_pd_control_says_when_no_bridge_answers(tmp_path: Path) -> None:
    exe = build("build/host_c/pd_control")
    master, slave = pty.openpty()  # a port with nothing behind it
    try:
        out = run([str(exe), os.ttyname(slave), "--seconds", "1"])
    finally:
        os.close(slave)
        os.close(master)
    assert out.returncode == 1
    assert "no URB bridge answered on /dev/pts/" in out.stderr
    assert "Check that the baud rate matches" in out.stderr


def test_pd_control_usage_errors_exit_2() -> None:
    exe = build("build/host_c/pd_control")
    assert run([str(exe)]).returncode == 2
    assert run([str(exe), "/dev/null", "--hz"]).returncode == 2
    assert run([str(exe), "/dev/null", "--bogus", "1"]).returncode == 2
    assert run([str(exe), "/dev/null", "--timeout-ms", "0"]).returncode == 2


def test_the_header_as_a_program_uses_it(motor_bridge: Path) -> None:
    exe = build("build/host_c/hpp_check")
    out = run([str(exe), str(motor_bridge)])
    assert out.returncode == 0, out.stdout + out.stderr
    assert "FAILED" not in out.stdout
    m = re.search(r"^(\d+) checks passed, 0 failed$", out.stdout, re.M)
    assert m is not None and int(m.group(1)) >= 23
