"""`urb sim sweep`: the experiments over many seeds. Failing seeds are tallied per check, keep their
files and a reproduction command; passing runs leave nothing behind; results do not depend on the
number of worker processes; bad seed lists are refused before anything runs."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from urb.cli import main
from urb_sim import runner
from urb_sim.experiments import SEED_SPAN, Result
from urb_sim.sweep import MAX_SEEDS, format_table, overlap_note, parse_seeds, run_dir, run_sweep

SEED_MAX = 2**63 - 1


def test_seed_lists() -> None:
    assert parse_seeds("7", SEED_MAX) == [7]
    assert parse_seeds("1-3", SEED_MAX) == [1, 2, 3]
    assert parse_seeds(" 5-6, 1 ,6,2-3", SEED_MAX) == [5, 6, 1, 2, 3]  # in the order given, each once
    assert parse_seeds(f"{SEED_MAX}", SEED_MAX) == [SEED_MAX]
    assert parse_seeds("0-63/21", SEED_MAX) == [0, 21, 42, 63]
    assert parse_seeds("5-9/10,6", SEED_MAX) == [5, 6]


def test_seeds_closer_than_the_span_are_noted() -> None:
    assert overlap_note([0, SEED_SPAN, 2 * SEED_SPAN]) is None
    note = overlap_note([40, 0, SEED_SPAN + 1])
    assert note is not None and f"seeds 0 and {SEED_SPAN + 1}" not in note and f"{SEED_SPAN + 1} and 40" in note
    assert f"--seeds 0-{2 * SEED_SPAN}/{SEED_SPAN}" in note


@pytest.mark.parametrize("text, says", [("", "empty item"), ("1,,2", "empty item"), ("x", "not a seed"),
                                        ("1-x", "not a seed"), ("5-3", "from low to high"), ("-1", "not a seed"),
                                        (f"{SEED_MAX + 1}", "seeds go from 0"), ("5/2", "a step follows a range"),
                                        ("1-9/0", "a step follows a range"), ("1-9/x", "not a seed"),
                                        (f"0-{MAX_SEEDS}", "more than")])
def test_bad_seed_lists_say_what_is_wrong(text: str, says: str) -> None:
    with pytest.raises(ValueError, match=says):
        parse_seeds(text, SEED_MAX)


def _fake_experiment(out: Path, *, quick: bool, seed: int, **_: object) -> Result:
    """fig15 stand-in: fails its latency check at seeds 2 and 5, raises at seed 4, writes a file."""
    if seed == 4:
        raise RuntimeError("a seeded bug")
    out.mkdir(parents=True, exist_ok=True)
    (out / "latency.csv").write_text(f"seed,{seed}\n")
    res = Result("fig15", "stand-in", "")
    res.check("answered", "all", "all", True)
    res.check("latency", "<= 2 ms", f"{1.5 + (seed in (2, 5))} ms", seed not in (2, 5))
    res.sim_s = 1.0
    return res


@pytest.fixture
def fake_fig15(monkeypatch: pytest.MonkeyPatch) -> None:
    real = runner.experiment
    monkeypatch.setattr(runner, "experiment", lambda key: _fake_experiment if key == "fig15" else real(key))


@pytest.mark.usefixtures("fake_fig15")
def test_failing_seeds_are_tallied_and_keep_their_files(tmp_path: Path) -> None:
    stale = run_dir(tmp_path, 99) / "fig15"
    stale.mkdir(parents=True)  # an earlier sweep's failure: not this sweep's
    sweep = run_sweep(["fig15"], [1, 2, 3, 4, 5], tmp_path, quick=True, jobs=1, keep=False, progress=lambda f, m: None)
    assert not sweep.passed
    assert [(t.check, t.runs, t.failed_seeds) for t in sweep.tallies] == [
        ("answered", 4, []), ("latency", 4, [2, 5]), ("ran to completion", 1, [4])]
    assert [(k, s, r.verdict) for k, s, r in sweep.failed_runs()] == [
        ("fig15", 2, "FAIL"), ("fig15", 4, "ERROR"), ("fig15", 5, "FAIL")]
    kept = sorted(p.relative_to(tmp_path).as_posix() for p in (tmp_path / "runs").rglob("*") if p.is_file())
    assert kept == ["runs/seed-2/fig15/latency.csv", "runs/seed-4/fig15/error.txt", "runs/seed-5/fig15/latency.csv"]

    with (tmp_path / "checks.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 4 * 2 + 1
    assert [r["seed"] for r in rows if r["passed"] == "0"] == ["2", "4", "5"]
    assert {r["measured"] for r in rows if r["check"] == "latency" and r["passed"] == "0"} == {"2.5 ms"}
    with (tmp_path / "runs.csv").open() as f:
        assert [(r["seed"], r["verdict"]) for r in csv.DictReader(f)] == [
            ("1", "PASS"), ("2", "FAIL"), ("3", "PASS"), ("4", "ERROR"), ("5", "FAIL")]
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["passed"] is False and summary["runs"] == 5 and summary["seeds"] == [1, 2, 3, 4, 5]
    assert summary["failed_runs"][0] == {"experiment": "fig15", "seed": 2, "verdict": "FAIL",
                                         "reproduce": "urb sim sensorhex --seed 2 --only fig15 --compare none --quick"}
    table = format_table(sweep)
    assert table[1].startswith("FAIL  fig15 latency") and "3/5" not in table[1]
    assert "2/4  failed at seed 2, 5" in table[1]
    assert "  ERROR fig15 seed 4: urb sim sensorhex --seed 4 --only fig15 --compare none --quick" in table


@pytest.mark.usefixtures("fake_fig15")
def test_keep_keeps_every_run(tmp_path: Path) -> None:
    sweep = run_sweep(["fig15"], [1, 3], tmp_path, quick=False, jobs=1, keep=True, progress=lambda f, m: None)
    assert sweep.passed
    assert (run_dir(tmp_path, 1) / "fig15" / "latency.csv").is_file()
    assert (run_dir(tmp_path, 3) / "fig15" / "latency.csv").is_file()
    assert sweep.reproduce("fig15", 3) == "urb sim sensorhex --seed 3 --only fig15 --compare none"


@pytest.mark.usefixtures("fake_fig15")
def test_a_clean_sweep_leaves_only_its_tables(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "sweep", "--seeds", "1,3", "--only", "fig15", "--jobs", "1", "--no-progress",
                 "--out", str(tmp_path)]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["checks.csv", "runs.csv", "summary.json"]
    out = capsys.readouterr().out
    assert "PASS  fig15 latency   2/2" in out and "2 runs (1 experiments x 2 seeds), 0 not passed" in out
    assert "not independent samples" in out  # seeds 1 and 3 share worlds


@pytest.mark.usefixtures("fake_fig15")
def test_a_failing_sweep_exits_1_and_names_the_commands(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "sweep", "--seeds", "1-2", "--only", "fig15", "--jobs", "1", "--no-progress",
                 "--out", str(tmp_path)]) == 1
    assert "FAIL fig15 seed 2: urb sim sensorhex --seed 2 --only fig15" in capsys.readouterr().out


@pytest.mark.parametrize("args, says", [(["--seeds", "3-1"], "from low to high"),
                                        (["--seeds", "1", "--only", "fig99"], "choose from")])
def test_sweep_usage_errors_exit_2(args: list[str], says: str, tmp_path: Path,
                                   capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "sweep", *args, "--out", str(tmp_path)]) == 2
    assert says in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []  # refused before anything ran


def test_unwritable_output_is_refused_before_the_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    assert main(["sim", "sweep", "--seeds", "1", "--only", "faults", "--out", str(blocker / "sweep")]) == 2
    assert "urb sim sweep: cannot write into" in capsys.readouterr().err


def test_worker_processes_give_the_serial_results(tmp_path: Path) -> None:
    """Real experiments in two worker processes, each running several runs in turn, against one process."""
    checks = []
    for jobs in (1, 2):
        out = tmp_path / f"jobs{jobs}"
        sweep = run_sweep(["fig16", "faults"], [1, 2], out, quick=True, jobs=jobs, keep=False,
                          progress=lambda f, m: None)
        assert sweep.passed
        checks.append((out / "checks.csv").read_text())
        assert not (out / "runs").exists()
    assert checks[0] == checks[1]
