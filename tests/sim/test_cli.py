"""`urb sim`: help, parameter listing, and a quick report run with its exit status."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from urb.cli import main
from urb_report.records import read_record


def test_sim_help(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["sim", "sensorhex", "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert "fig15" in out and "Exit status" in out


def test_sim_params(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "params"]) == 0
    out = capsys.readouterr().out
    assert "node.ppm_sd" in out and "i2c.bitrate" in out


def test_sim_unknown_experiment(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "sensorhex", "--only", "fig99"]) == 2
    for empty in ("", ",,", " "):  # names nothing: was taken as "all", a 4-minute run nobody asked for
        assert main(["sim", "sensorhex", "--only", empty]) == 2
    assert "choose from" in capsys.readouterr().err


def test_sim_unwritable_output_is_refused_before_the_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    assert main(["sim", "sensorhex", "--quick", "--only", "faults", "--out", str(blocker / "report")]) == 2
    err = capsys.readouterr().err
    assert f"cannot write the report into {blocker / 'report'}: Not a directory; choose another --out DIR" in err
    assert blocker.read_text() == "not a folder"


def test_sim_unwritable_evidence_folder_is_refused_before_the_run(tmp_path: Path,
                                                                  capsys: pytest.CaptureFixture[str]) -> None:
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    assert main(["sim", "sensorhex", "--quick", "--only", "faults", "--out", str(tmp_path / "report"),
                 "--evidence", str(blocker / "evidence")]) == 2
    err = capsys.readouterr().err
    assert (f"cannot write the evidence records into {blocker / 'evidence'}: Not a directory; choose another "
            "--evidence DIR") in err
    assert not (tmp_path / "report" / "faults").exists()


def test_sim_report(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A run writes the report, stamped with its provenance, and one evidence record per experiment
    (issue #36): an item per acceptance criterion with its verdict, required and measured value,
    seed, source and the command that runs it again."""
    evidence = tmp_path / "evidence"
    assert main(["sim", "sensorhex", "--quick", "--only", "fig16", "--out", str(tmp_path), "--no-progress",
                 "--evidence", str(evidence), "--compare", "none"]) == 0
    html = (tmp_path / "index.html").read_text()
    assert "PASS" in html and "fig16_usb_latency.png" in html
    assert "<code>urb sim sensorhex --quick --seed 1</code>" in html  # reproduces this run, quick included
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["passed"] and summary["experiments"][0]["key"] == "fig16"
    assert summary["headline"] == ["All acceptance criteria met, and every result reproduces the paper."]
    commit = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True, check=True).stdout.strip()
    prov = summary["provenance"]
    assert prov["commit"] == commit and prov["seed"] == 1 and isinstance(prov["clean"], bool)
    assert {"simulation library compiler", "simulation library flags", "Python"} <= set(prov["tools"])
    assert f"<td>{commit} (" in html and f"commit {commit[:12]}" in html
    assert "<td>simulation library flags</td><td>-std=c99 -O3" in html and "<td>Python</td><td>CPython 3." in html

    [path] = sorted(evidence.glob("*.json"))
    assert path.name == "sim-fig16.json"
    record = read_record(path)
    assert record.activity == "sim" and record.provenance["commit"] == commit and record.provenance["seed"] == 1
    assert set(record.tools) == {"simulation library compiler", "simulation library flags", "Python"}
    assert record.config["quick"] is True and record.config["build"] == "optimised"
    checks = summary["experiments"][0]["checks"]
    assert [i.id for i in record.items] == ["sim:fig16/every-request-answered",
                                            "sim:fig16/bounded-by-the-derived-frames", "sim:fig16/constant",
                                            "sim:fig16/host-libraries-agree"]
    for item, check in zip(record.items, checks):
        assert (item.kind, item.verdict, item.expected, item.measured) == ("criterion", "pass", check["required"],
                                                                          check["measured"])
        assert item.source == "sim/urb_sim/experiments/latency.py"
        assert item.rerun == "urb sim sensorhex --seed 1 --quick --only fig16 --compare none"
        assert item.data["seed"] == 1
    assert f"evidence: 1 record(s) in {evidence}" in capsys.readouterr().out


def test_sim_help_lists_each_subcommand_once(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["sim", "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: urb sim [-h] SUBCOMMAND ...")
    for name in ("sensorhex", "sweep", "merge", "sensitivity", "profiles", "params"):
        assert sum(line.split()[:1] == [name] for line in out.splitlines()) == 1, out


@pytest.mark.parametrize("sub", ["sensorhex", "sweep", "merge", "sensitivity", "profiles", "params"])
def test_sim_subcommand_usage_names_the_command(sub: str, capsys: pytest.CaptureFixture[str]) -> None:
    # argparse used to derive "urb sim [-h] SUBCOMMAND ... sensorhex" from `urb sim`'s own usage line
    with pytest.raises(SystemExit) as exc:
        main(["sim", sub, "--help"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.startswith(f"usage: urb sim {sub} [-h]")


@pytest.mark.parametrize("sub", [[], ["sensorhex"], ["sweep"], ["merge"], ["sensitivity"], ["profiles"], ["params"]])
def test_sim_help_states_the_exit_status(sub: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    # every page of the manual says what its exit codes mean (issue #35: `urb sim --help` did not)
    with pytest.raises(SystemExit) as exc:
        main(["sim", *sub, "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert "Exit status" in out and " 2 " in out.replace("\n", " "), out


def test_sim_usage_error_names_the_command(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["sim", "sensorhex", "--jobs", "0"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: urb sim sensorhex [-h]") and "urb sim sensorhex: error: argument --jobs" in err


def _without_wall_times(summary: dict[str, object]) -> dict[str, object]:
    """The summary without what differs from run to run: wall times and the provenance's date."""
    experiments = [{k: v for k, v in e.items() if k != "wall_s"} for e in summary["experiments"]]  # type: ignore[attr-defined]
    provenance = {k: v for k, v in summary["provenance"].items() if k != "date"}  # type: ignore[attr-defined]
    return {**{k: v for k, v in summary.items() if k != "wall_s"}, "experiments": experiments,
            "provenance": provenance}


def test_parallel_experiments_give_the_serial_results(tmp_path: Path) -> None:
    only = "fig16,faults,fig15"
    for jobs in ("1", "3"):
        out = tmp_path / f"jobs{jobs}"
        assert main(["sim", "sensorhex", "--quick", "--only", only, "--jobs", jobs, "--out", str(out),
                     "--no-progress", "--evidence", str(out / "evidence")]) == 0
    serial, parallel = tmp_path / "jobs1", tmp_path / "jobs3"
    files = sorted(p.relative_to(serial) for p in serial.rglob("*") if p.is_file() and p.suffix in (".csv", ".png"))
    assert len(files) >= 6
    for rel in files:
        assert (serial / rel).read_bytes() == (parallel / rel).read_bytes(), rel
    s, p = (json.loads((d / "summary.json").read_text()) for d in (serial, parallel))
    # the order asked for, then the same under each other hardware profile
    assert [e["key"] for e in p["experiments"]] == ["fig16", "faults", "fig15", "fig16@ideal", "fig15@ideal",
                                                   "fig16@paper", "fig15@paper"]
    assert _without_wall_times(s) == _without_wall_times(p)


def test_jobs_must_be_positive(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["sim", "sensorhex", "--jobs", "0"])
    assert exc.value.code == 2
    assert "--jobs" in capsys.readouterr().err


def test_repeated_experiment_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    # two workers would write fig15/ at once and the report would list it twice
    assert main(["sim", "sensorhex", "--only", "fig15,fig16,fig15"]) == 2
    assert "--only names fig15 more than once" in capsys.readouterr().err


@pytest.mark.parametrize("seed", ["-1", "9223372036854775808", "18446744073709551616", "1.5"])
def test_seed_outside_the_simulated_range_is_refused(seed: str, capsys: pytest.CaptureFixture[str]) -> None:
    # the world keeps 64 bits: 2**64 used to run silently as seed 0
    with pytest.raises(SystemExit) as exc:
        main(["sim", "sensorhex", "--seed", seed])
    assert exc.value.code == 2
    assert "--seed: expected a whole number from 0 to 9223372036854775807" in capsys.readouterr().err


def test_empty_output_folder_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    # Path("") is the current folder: the report used to land wherever the command ran
    with pytest.raises(SystemExit) as exc:
        main(["sim", "sensorhex", "--out", ""])
    assert exc.value.code == 2
    assert "--out: expected a folder name, got an empty one" in capsys.readouterr().err


def test_params_prints_whole_numbers_in_full(capsys: pytest.CaptureFixture[str]) -> None:
    from urb_sim.native import params

    assert main(["sim", "params"]) == 0
    lines = {line.split()[0]: line.split()[1] for line in capsys.readouterr().out.splitlines()}
    fingerprint = next(p for p in params() if p.name == "probe.fingerprint").default
    assert lines["probe.fingerprint"] == str(int(fingerprint))  # not 2.11957e+09


@pytest.mark.parametrize("unbuffered", [True, False])
def test_closed_pipe_ends_quietly(unbuffered: bool) -> None:
    # `urb sim params | head -1`: the reader leaves early; no traceback, SIGPIPE's exit status, whether
    # the output is written as it is printed or in one flush at the end
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
    if unbuffered:
        env["PYTHONUNBUFFERED"] = "1"
    proc = subprocess.Popen([sys.executable, "-m", "urb", "sim", "params"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, env=env)
    assert proc.stdout is not None and proc.stderr is not None
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=60) == 141
    assert err == ""


def test_each_profile_has_its_evidence_ids_and_report_section(tmp_path: Path) -> None:
    """Under another hardware profile an experiment's record is sim-<experiment>@<profile>.json with ids
    sim@<profile>:<experiment>/<criterion>, its config names the profile, and its command reruns it
    under that profile alone; the report shows each profile's figures beside its assumptions."""
    evidence = tmp_path / "evidence"
    assert main(["sim", "sensorhex", "--quick", "--only", "fig16", "--compare", "paper", "--out", str(tmp_path),
                 "--no-progress", "--evidence", str(evidence)]) == 0
    assert sorted(p.name for p in evidence.glob("*.json")) == ["sim-fig16.json", "sim-fig16@paper.json"]
    default, paper = read_record(evidence / "sim-fig16.json"), read_record(evidence / "sim-fig16@paper.json")
    assert default.config["profile"] == "cortex-m0plus" and paper.config["profile"] == "paper"
    assert [i.id for i in paper.items] == ["sim@paper:fig16/every-request-answered",
                                           "sim@paper:fig16/bounded-by-the-derived-frames", "sim@paper:fig16/constant",
                                           "sim@paper:fig16/host-libraries-agree",
                                           "sim@paper:fig16/paper-profile-reproduces-the-paper-s-fig16_ms-average"]
    assert paper.items[-1].verdict == "pass" and paper.items[-1].expected.startswith("3 +- 0.1 ms")
    assert all(i.data["profile"] == "paper" for i in paper.items)
    assert paper.items[0].rerun == "urb sim sensorhex --seed 1 --quick --only fig16 --profile paper --compare none"
    html = (tmp_path / "index.html").read_text()
    assert "<section id='profiles'>" in html and "id='profile-paper'" in html and "id='profile-cortex-m0plus'" in html
    assert "scope.sample_ns" in html and "node.mask_cycles" in html  # each profile's assumptions beside its figures


def test_an_unknown_profile_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "sensorhex", "--only", "fig16", "--profile", "pic18"]) == 2
    assert "no hardware profile 'pic18': choose one of cortex-m0plus" in capsys.readouterr().err
    assert main(["sim", "sensorhex", "--only", "fig16", "--compare", "ideal,avr"]) == 2
    assert "no hardware profile 'avr'" in capsys.readouterr().err
