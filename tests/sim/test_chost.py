"""The C host library on the simulated CPU (sim/world/sim_host_c.c, urb_sim.chost) against the
Python host library, the reference (urb_sim.hostcompare says what must be equal and why).

Each seeded bug of the C driver, built into its own library (URBSIM_MUTANT), must make the
comparison fail: a completion the driver never dispatches (CHOST_DROP_COMPLETION) and a
proportional gain 25 % high (CHOST_WRONG_GAIN)."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from urb_sim.chost import CHost, HandOverError
from urb_sim.hostcompare import compare
from urb_sim.native import App
from urb_sim.system import NS_PER_MS, System

SECONDS = 1.1  # the lag and RMS fit start after the first second


@pytest.mark.parametrize("uplink", ["rs232", "usb"])
def test_the_c_host_makes_the_python_hosts_run(uplink: str) -> None:
    a = compare(uplink, 18, SECONDS, 12.0, 0.05)
    assert a.agrees, a.differences
    # witnesses: the loop ran on both, every request completed once and OK, the PD moved the leg
    assert len(a.c.requests) == 2 * int(SECONDS * 1000) == len(a.python.requests)
    assert a.c.flag_counts() == {0: len(a.c.requests)}
    assert len(a.c.commands) == int(SECONDS * 1000) and len(set(a.c.commands)) > 100
    assert max(abs(p) for _, p, _ in a.c.truth) > 1.0
    assert a.c.rms_rad == a.python.rms_rad and a.c.lag_ms == a.python.lag_ms


def test_a_different_gain_is_a_different_run() -> None:
    """Witness that the comparison looks at what the gains change (a wrong gain is caught)."""
    from urb_sim.hostcompare import compare_runs, run

    a = compare_runs(run("python", "rs232", 18, SECONDS, 12.0, 0.05), run("c", "rs232", 18, SECONDS, 15.0, 0.05))
    assert not a.agrees
    assert any(d.startswith("command") for d in a.differences)
    assert any(d.startswith("trace hash") for d in a.differences)


def test_hand_over_refuses_a_busy_host() -> None:
    s = System(seed=3)
    b = s.bridge("rs232")
    s.node(b, App.MOTOR, 0x20, 0)
    s.start()
    node = s.urb.find_node("MotorDriver", 0)
    node.submit_request(node.new_request().read(1))
    with pytest.raises(HandOverError, match="still queued or in flight"):
        CHost(s)
    s.host.advance(5 * NS_PER_MS)
    host = CHost(s)  # quiet now
    with pytest.raises(ValueError, match="refused"):
        host.axis(b, 99, 0x20, kp=1.0, kd=0.0, amp=1.0, omega=math.pi)  # no node 99
    host.close()
    s.close()


def comparison_in_a_new_process(mutant: str) -> tuple[bool, list[str]]:
    env = {k: v for k, v in os.environ.items() if k not in ("URBSIM_MUTANT", "URBSIM_SANITIZE")}
    env["URBSIM_MUTANT"] = mutant
    proc = subprocess.run([sys.executable, __file__], capture_output=True, text=True, env=env, timeout=600,
                          cwd=Path(__file__).resolve().parents[2])
    assert proc.returncode == 0, proc.stderr
    agrees, differences = json.loads(proc.stdout)
    return bool(agrees), list(differences)


# lobster-trace: urb.HOST_001
def test_a_dropped_completion_is_caught() -> None:
    agrees, differences = comparison_in_a_new_process("CHOST_DROP_COMPLETION")
    assert not agrees
    assert "c: 1 request(s) never completed" in differences


def test_a_wrong_gain_in_the_c_application_is_caught() -> None:
    agrees, differences = comparison_in_a_new_process("CHOST_WRONG_GAIN")
    assert not agrees
    assert any(d.startswith("command") for d in differences)


def test_fig18_19_on_the_c_host(tmp_path: Path) -> None:
    """`urb sim sensorhex --host c --only fig18_19`: the grid on the C host, every criterion met, and
    each uplink's kept gain agreeing with the Python host library's run."""
    from urb_sim.experiments import control

    res = control.figs18_19(tmp_path, quick=True, host="c")
    assert res.passed, [(c.name, c.measured) for c in res.checks if not c.passed]
    agree = [c for c in res.checks if c.name.endswith("host libraries agree")]
    assert len(agree) == 2 and all(c.passed and "requests" in c.measured for c in agree)
    assert "(on the C host library)" in res.title


def test_fig20_on_the_c_host(tmp_path: Path) -> None:
    """The SensoRHex topology on the C host: six legs on two USB bridges, the three slow nodes read
    every 10 ms over RS232; the chosen gains' run agrees with the Python host library's."""
    from urb_sim.experiments import gait

    res = gait.fig20(tmp_path, quick=True, host="c")
    assert res.passed, [(c.name, c.measured) for c in res.checks if not c.passed]
    [agree] = [c for c in res.checks if c.name == "host libraries agree"]
    assert agree.passed and agree.measured.endswith("equal")


# lobster-trace: urb.HOST_001
def test_the_gait_at_1_khz_agrees_while_its_queues_grow() -> None:
    """At 1 kHz the USB downlinks cannot keep up and the requests queue for milliseconds (Fig. 20's
    finding): the C host must still make the Python host's run, latency for latency."""
    from urb_sim.experiments import gait

    py, c = (gait.run_gait(20, 1000, 0.6, 8.0, 0.05, host=h) for h in ("python", "c"))
    assert gait.gait_differences(py, c) == []
    assert max(c.latency_ms) > 3.0 and len(c.slow_latency_ms) == 3 * 60  # the queues grew; the sensors were read
    assert gait.gait_differences(py, gait.run_gait(20, 1000, 0.6, 8.5, 0.05, host="c")) != []


def test_the_sequence_position_of_the_c_core_extension() -> None:
    """The extension's core does not expose its next sequence number: it is the count of
    submissions, which holds only while none failed (a refused request never went out)."""
    from types import SimpleNamespace

    from urb_sim.chost import position

    core = SimpleNamespace(window=4, frames_written=3)  # no _next_seq, no _frame: the extension's shape
    clean = SimpleNamespace(core=core, name="rs232-0", stats=SimpleNamespace(submitted=20, failed=0))
    assert position(clean) == (4, 5, 4)  # type: ignore[arg-type]
    refused = SimpleNamespace(core=core, name="rs232-0", stats=SimpleNamespace(submitted=20, failed=1))
    with pytest.raises(HandOverError, match="1 request\\(s\\) failed before the hand-over"):
        position(refused)  # type: ignore[arg-type]


@pytest.mark.parametrize("figure", ["fig15", "fig16"])
def test_latency_figures_on_the_c_host(figure: str, tmp_path: Path) -> None:
    """Figs. 15-16's periodic reads on the C host (right after discovery: over USB the hand-over
    carries the manager's pending frame tick), agreeing with the Python host read for read."""
    from urb_sim.experiments import latency

    res = getattr(latency, figure)(tmp_path, quick=True, host="c")
    assert res.passed, [(c.name, c.measured) for c in res.checks if not c.passed]
    [agree] = [c for c in res.checks if c.name == "host libraries agree"]
    assert agree.passed and agree.measured == "250 reads: equal"


def test_bandwidth_on_the_c_host(tmp_path: Path) -> None:
    """The uplinks' and the motor workloads' limits on the C host (the motors' configuration written
    by the C host right after discovery), the overloaded 3-motor 1-kHz load agreeing with the Python
    host library's."""
    from urb_sim.experiments import bandwidth

    res = bandwidth.bandwidth(tmp_path, quick=True, host="c")
    assert res.passed, [(c.name, c.measured) for c in res.checks if not c.passed]
    [agree] = [c for c in res.checks if c.name == "host libraries agree"]
    assert agree.passed and agree.measured.endswith("equal")
    py, c = (bandwidth.probe_load("usb", 31, 4, 150, 600, host=h) for h in ("python", "c"))
    assert [(r.ok, r.latency_ns) for r in py[0]] == [(r.ok, r.latency_ns) for r in c[0]] and py[1] == c[1]
    assert sum(not r.ok for r in c[0]) > 0  # a load past the limit: its failures agree too


if __name__ == "__main__":
    result = compare("rs232", 18, SECONDS, 12.0, 0.05)
    print(json.dumps([result.agrees, result.differences]))
