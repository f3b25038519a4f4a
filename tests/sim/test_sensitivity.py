"""The sensitivity study (urb_sim.sensitivity; issue #40): a smoke run of one point through the same
runner as the experiments, and the summary's reading of where the PLL stops meeting the paper's
Table I, on rows made here (one value that misses it must be named, and the last one that meets it)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from urb.cli import main
from urb_sim import runner, sensitivity
from urb_sim.experiments import Result


def test_one_point_measures_table1_latency_and_lag(tmp_path: Path) -> None:
    key = sensitivity.point_key("timer", 1)  # 4 MHz in the quick grid, from the default profile
    res = runner.run_one(key, tmp_path, quick=True, seed=1, progress=lambda frac, msg: None)
    assert res.verdict == "PASS", res.checks
    [row] = res.table
    assert row["params"] == "node.ticks_per_us=4"
    for name in ("internode_us average", "jitter_us worst cycle", "convergence_ms max of runs", "rs232 latency max ms",
                 "usb latency mean ms", "usb PD lag ms", "usb PD delay median ms"):
        assert isinstance(row[name], float) and row[name] == row[name], name
    assert 0 < row["internode_us average"] < 1 and 1.9 < row["usb latency mean ms"] < 3.2
    assert (tmp_path / key / "point.csv").exists()


def _row(factor: str, value: float, internode: float) -> dict[str, Any]:
    row: dict[str, Any] = {"factor": factor, "value": value, "unit": "x", "params": ""}
    for metric, figure in (("convergence_ms", 50.0), ("internode_us", internode), ("jitter_us", 0.1)):
        row[f"{metric} average"] = figure
        row[f"{metric} max of runs"] = figure * 1.2
        row[f"{metric} worst cycle"] = figure * 2
    for name in ("rs232 latency mean ms", "rs232 latency max ms", "usb latency mean ms", "usb latency max ms",
                 "usb PD lag ms", "usb PD delay median ms"):
        row[name] = 1.0
    row["meets Table I"] = sensitivity.meets(row)
    return row


def _results(rows: list[dict[str, Any]]) -> list[Result]:
    return [Result(f"sens:{r['factor']}={i}", "t", "p", table=[r]) for i, r in enumerate(rows)]


def test_the_summary_names_where_the_paper_stops_being_met(tmp_path: Path) -> None:
    # timer resolution gets worse as it falls: 48 and 4 MHz meet 0.19 us, 1 MHz does not
    rows = [_row("timer", 48.0, 0.05), _row("timer", 1.0, 0.4), _row("timer", 4.0, 0.12)]
    files, table, notes = sensitivity.summarize(_results(rows), tmp_path, "a profile")
    assert [n for n in notes] == ["node heartbeat timer resolution: the PLL stops meeting the paper's Table I at 1 MHz; "
                                  "met up to 4 MHz (there: internode_us 0.4 / 0.48 (paper 0.19 / 0.56))."]
    assert (tmp_path / "sensitivity_timer.png") in files and len(table) == 3


def test_the_summary_says_when_every_value_meets_the_paper(tmp_path: Path) -> None:
    rows = [_row("bus", 50.0, 0.05), _row("bus", 400.0, 0.1)]
    _, _, notes = sensitivity.summarize(_results(rows), tmp_path, "a profile")
    assert notes == ["downlink bus capacitance (pull-up for a 300-ns rise): the paper's Table I is met at every value "
                     "tried (50 to 400 pF)."]


def test_points_are_named_by_factor_and_index() -> None:
    assert sensitivity.keys(["crystal"], quick=True) == ["sens:crystal=0", "sens:crystal=1", "sens:crystal=2"]
    factor, index = sensitivity.parse_key("sens:bus=2@paper")
    assert (factor.id, index) == ("bus", 2)
    with pytest.raises(ValueError, match="not a sensitivity point"):
        sensitivity.parse_key("sens:voltage=1")
    with pytest.raises(ValueError, match="unknown factor\\(s\\) voltage"):
        sensitivity.keys(["voltage"], quick=False)


def test_an_unknown_factor_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "sensitivity", "--only", "voltage"]) == 2
    assert "unknown factor(s) voltage; choose from irq_jitter, timer, crystal, bus, heartbeat" in capsys.readouterr().err


def test_points_have_no_evidence_record(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The points are measurements, not acceptance criteria: `urb sim sensorhex --sensitivity` writes
    records for the experiments only."""
    from urb_sim import evidence

    monkeypatch.delenv("URBSIM_MUTANT", raising=False)
    point = Result("sens:timer=0", "Sensitivity", "p")
    point.check("measured", "every figure", "0 missing", True)
    fig16 = Result("fig16", "Fig. 16", "p")
    fig16.check("constant", "spread <= 0.1 ms", "21 us", True)
    paths = evidence.write([point, fig16], seed=1, quick=True, out=tmp_path, evidence_dir=tmp_path / "evidence")
    assert [p.name for p in paths] == ["sim-fig16.json"]
