"""The experiment runner: progress reaches the caller from worker processes, and an experiment that
fails in a worker stops the run with its exception."""

from __future__ import annotations

from pathlib import Path

import pytest

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


def test_an_experiment_that_raises_in_a_worker_stops_the_run(tmp_path: Path) -> None:
    with pytest.raises(KeyError, match="no_such_experiment"):
        run_experiments(["fig16", "no_such_experiment"], tmp_path, quick=True, seed=1, jobs=2,
                        progress=lambda frac, msg: None)


def test_every_experiment_has_a_cost_and_a_function() -> None:
    assert all(cost > 0 for cost in EXPERIMENTS.values())
    assert all(callable(experiment(key)) for key in EXPERIMENTS)
