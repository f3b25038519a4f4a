"""The simulation's evidence records (sim/urb_sim/evidence.py, issue #36): one record per
experiment, an item per acceptance criterion whose verdict follows the check, none from a build
with a seeded bug, and programs started from a sanitized run without the sanitizer runtimes."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from urb_report.records import read_record
from urb_sim import evidence
from urb_sim.experiments import RAN_TO_COMPLETION, Result
from urb_sim.runner import EXPERIMENTS


def _results() -> list[Result]:
    ok = Result("faults", "t", "p", deviations=["faults: something the paper claims"])
    ok.check("i2c_bit_errors: accounted", "each request once", "3 callbacks for 3 requests", True)
    ok.check("mutant rejected: a lost callback and a doubled one", "rejected", "rejected", True)
    bad = Result("fig16", "t", "p")
    bad.check("bounded by three frames", "<= 3.176 ms", "3.300 ms", False)
    crashed = Result("table1", "t", "p")
    crashed.check(RAN_TO_COMPLETION, "no exception", "ZeroDivisionError: division by zero", False)
    return [ok, bad, crashed]


def test_one_record_per_experiment_with_the_checks_verdicts(tmp_path: Path,
                                                            monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("URBSIM_MUTANT", raising=False)
    paths = evidence.write(_results(), seed=7, quick=False, out=tmp_path / "report", evidence_dir=tmp_path)
    assert [p.name for p in paths] == ["sim-faults.json", "sim-fig16.json", "sim-table1.json"]
    faults, fig16, table1 = (read_record(p) for p in paths)
    assert [(i.id, i.kind, i.verdict) for i in faults.items] == [
        ("sim:faults/i2c_bit_errors-accounted", "criterion", "pass"),
        ("sim:faults/mutant-rejected-a-lost-callback-and-a-doubled-one", "mutant", "pass")]
    assert faults.items[0].rerun == "urb sim sensorhex --seed 7 --only faults"
    assert faults.items[0].source == "sim/urb_sim/experiments/faults.py"
    assert faults.config["deviations_from_paper"] == ["faults: something the paper claims"]
    assert faults.provenance["seed"] == 7
    [(verdict, measured)] = [(i.verdict, i.measured) for i in fig16.items]
    assert (verdict, measured) == ("fail", "3.300 ms")
    assert [(i.id, i.verdict) for i in table1.items] == [("sim:table1/ran-to-completion", "error")]
    assert "TLC" not in faults.tools


def test_every_experiment_has_its_source_file() -> None:
    for key in EXPERIMENTS:
        assert (evidence.build.REPO / evidence.source_of(key)).is_file(), key


def test_a_seeded_bug_build_writes_no_record(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("URBSIM_MUTANT", "LOG_WRAP")
    assert evidence.write(_results(), seed=1, quick=True, out=tmp_path, evidence_dir=tmp_path) == []
    assert not list(tmp_path.glob("*.json"))


def test_a_sanitized_run_names_its_build_and_how_to_run_it_again(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("URBSIM_SANITIZE", "1")
    monkeypatch.delenv("URBSIM_MUTANT", raising=False)
    assert evidence.rerun("faults", seed=1, quick=True).startswith(
        'URBSIM_SANITIZE=1 LD_PRELOAD="$(python3 -m urb_sim.build --preload)" ')
    assert "-fsanitize=address,undefined" in evidence.tools(["faults"])["simulation library flags"]


def test_programs_started_for_the_record_do_not_get_the_sanitizer_preload(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("LD_PRELOAD", "/nonexistent/libasan.so")
    with evidence.unpreloaded():
        assert "LD_PRELOAD" not in os.environ
    assert os.environ["LD_PRELOAD"] == "/nonexistent/libasan.so"


def test_criterion_ids_are_stable_slugs() -> None:
    assert evidence.item_id("fig20", "500 Hz: every request answered") == "sim:fig20/500-hz-every-request-answered"
    assert evidence.item_id("table1", "Fig. 11 vs Fig. 12") == "sim:table1/fig-11-vs-fig-12"
