"""The experiment runner: progress reaches the caller from worker processes, and an experiment that
raises (in a worker or in this process) is reported as an ERROR while the others still run."""

from __future__ import annotations

import functools
import json
import os
import signal
import subprocess
import struct
import sys
import threading
from pathlib import Path
from typing import Any

import pytest

from urb_sim import runner
from urb_sim.experiments import RAN_TO_COMPLETION, Result
from urb_sim.report import write_report
from urb_sim.runner import EXPERIMENTS, experiment, run_experiments


def test_worker_progress_reaches_the_caller(tmp_path: Path) -> None:
    seen: list[tuple[float, str]] = []
    results = run_experiments(["faults", "fig16"], tmp_path, quick=True, seed=3, jobs=2,
                              progress=lambda frac, msg: seen.append((frac, msg)))
    assert [r.key for r in results] == ["faults", "fig16"]
    assert all(r.passed for r in results)
    assert seen[-1][0] == pytest.approx(1.0)
    assert any(0.0 < frac < 1.0 for frac, _ in seen)  # reports from inside the experiments
    assert {msg for _, msg in seen} >= {"faults: PASS", "fig16: PASS"}


def test_an_experiment_that_raises_in_a_worker_is_an_error_and_the_others_finish(tmp_path: Path) -> None:
    seen: list[str] = []
    results = run_experiments(["fig16", "no_such_experiment", "faults"], tmp_path, quick=True, seed=1, jobs=2,
                              progress=lambda frac, msg: seen.append(msg))
    assert [r.key for r in results] == ["fig16", "no_such_experiment", "faults"]
    assert [r.verdict for r in results] == ["PASS", "ERROR", "PASS"]
    _assert_error_reported(results[1], tmp_path, "KeyError", "no_such_experiment")
    assert "no_such_experiment: ERROR" in seen


def test_an_experiment_that_raises_in_this_process_is_an_error(tmp_path: Path,
                                                               monkeypatch: pytest.MonkeyPatch) -> None:
    def broken(out: Path, **_: object) -> Result:
        raise ZeroDivisionError("a seeded bug")

    real = runner.experiment
    monkeypatch.setattr(runner, "experiment", lambda key: broken if key == "fig15" else real(key))
    results = run_experiments(["fig15", "faults"], tmp_path, quick=True, seed=1, jobs=1,
                              progress=lambda frac, msg: None)
    assert [r.verdict for r in results] == ["ERROR", "PASS"]
    _assert_error_reported(results[0], tmp_path, "ZeroDivisionError", "a seeded bug")


def test_an_error_is_in_the_report(tmp_path: Path) -> None:
    res = runner.crashed("fig20", tmp_path, RuntimeError("boom"))
    write_report(tmp_path, [res], seed=1, quick=True, overrides={}, wall_s=0.0)
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["passed"] is False
    assert summary["experiments"][0]["verdict"] == "ERROR"
    assert summary["experiments"][0]["files"] == ["fig20/error.txt"]
    page = (tmp_path / "index.html").read_text()
    assert "RuntimeError: boom" in page and "href='fig20/error.txt'" in page


def test_a_failed_criterion_is_a_fail_not_an_error() -> None:
    res = Result("fig15", "t", "p")
    res.check("latency", "< 2 ms", "3 ms", False)
    assert res.verdict == "FAIL"
    res.checks[0].passed = True
    assert res.verdict == "PASS"


def _assert_error_reported(res: Result, out: Path, exc_type: str, text: str) -> None:
    assert not res.passed
    [check] = res.checks
    assert check.name == RAN_TO_COMPLETION and not check.passed
    assert check.measured.startswith(exc_type) and text in check.measured
    trace = (out / res.key / "error.txt").read_text()
    assert exc_type in trace and text in trace
    assert res.files == [out / res.key / "error.txt"]


def test_every_experiment_has_a_cost_and_a_function() -> None:
    assert all(cost > 0 for cost in EXPERIMENTS.values())
    assert all(callable(experiment(key)) for key in EXPERIMENTS)


def _segfault_in(victim: str) -> Any:
    """A worker body that dies of SIGSEGV (as a memory error in the firmware under test would) when
    it runs `victim`, and runs any other experiment normally."""
    return functools.partial(_worker_or_segfault, victim)


def _worker_or_segfault(victim: str, index: int, key: str, out: Path, quick: bool, seed: int, reports: Any) -> None:
    if key == victim:
        with runner.crash_log(out, key):  # as _worker runs every experiment
            _firmware_under_test_crashes()
    runner._worker(index, key, out, quick, seed, reports)


def _firmware_under_test_crashes() -> None:
    os.kill(os.getpid(), signal.SIGSEGV)


def test_a_worker_that_dies_is_an_error_and_the_others_finish(tmp_path: Path) -> None:
    seen: list[str] = []
    results = runner._parallel(["fig16", "faults", "fig15"], tmp_path, quick=True, seed=1, jobs=2,
                               progress=lambda frac, msg: seen.append(msg), target=_segfault_in("faults"))
    assert [r.verdict for r in results] == ["PASS", "ERROR", "PASS"]
    _assert_error_reported(results[1], tmp_path, "WorkerDied", "signal 11 (SIGSEGV)")
    # where it died, from the worker's crash log
    assert "_firmware_under_test_crashes" in (tmp_path / "faults" / "error.txt").read_text()
    assert not (tmp_path / "fig16" / runner.CRASH_LOG).exists()  # a worker that lived leaves none
    assert seen.count("faults: ERROR") == 1


def test_a_worker_that_dies_while_reporting_is_an_error_and_the_others_finish(tmp_path: Path) -> None:
    """The victim dies in the middle of sending a report. Its incomplete report must neither stall
    the run nor hold up the other workers' reports (a shared queue's lock once did: the run hung)."""
    results: list[Result] = []
    run = threading.Thread(target=lambda: results.extend(runner._parallel(
        ["fig16", "faults", "fig15"], tmp_path, quick=True, seed=1, jobs=2, progress=lambda frac, msg: None,
        target=functools.partial(_worker_or_death_while_reporting, "faults"))), daemon=True)
    run.start()
    run.join(timeout=120)
    assert not run.is_alive(), "the runner hung after a worker died while it was sending a report"
    assert [r.verdict for r in results] == ["PASS", "ERROR", "PASS"]
    _assert_error_reported(results[1], tmp_path, "WorkerDied", "signal 9 (SIGKILL)")


def _worker_or_death_while_reporting(victim: str, index: int, key: str, out: Path, quick: bool, seed: int,
                                     reports: Any) -> None:
    if key == victim:
        # the start of a 1-MiB report in the pipe's framing (a 4-byte length, then the bytes): the
        # worker is killed after its first kilobyte
        os.write(reports.fileno(), struct.pack("!i", 1 << 20) + b"x" * 1024)
        os.kill(os.getpid(), signal.SIGKILL)
    runner._worker(index, key, out, quick, seed, reports)


SERIAL_CRASH = """
import os, signal, sys
from pathlib import Path
from urb_sim import runner

def firmware_under_test_crashes(out, **_):
    os.kill(os.getpid(), signal.SIGSEGV)

runner.experiment = lambda key: firmware_under_test_crashes
runner.run_experiments(["fig15"], Path(sys.argv[1]), quick=True, seed=1, jobs=1, progress=lambda f, m: None)
"""


def test_a_crash_with_one_job_prints_where_it_happened(tmp_path: Path) -> None:
    """With --jobs 1 the experiment runs in this process, so a SIGSEGV ends the run: it must say where."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONFAULTHANDLER"}
    proc = subprocess.run([sys.executable, "-c", SERIAL_CRASH, str(tmp_path)], capture_output=True, text=True,
                          env=env, cwd=Path(runner.__file__).parents[1], timeout=60)
    assert proc.returncode == -signal.SIGSEGV
    assert "Segmentation fault" in proc.stderr
    assert "firmware_under_test_crashes" in proc.stderr
