"""`urb sim`: help, parameter listing, and a quick report run with its exit status."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from urb.cli import main


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


def test_sim_report(tmp_path: Path) -> None:
    assert main(["sim", "sensorhex", "--quick", "--only", "fig16", "--out", str(tmp_path), "--no-progress"]) == 0
    html = (tmp_path / "index.html").read_text()
    assert "PASS" in html and "fig16_usb_latency.png" in html
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["passed"] and summary["experiments"][0]["key"] == "fig16"


def test_sim_help_lists_each_subcommand_once(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["sim", "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: urb sim [-h] SUBCOMMAND ...")
    for name in ("sensorhex", "params"):
        assert sum(line.split()[:1] == [name] for line in out.splitlines()) == 1, out


@pytest.mark.parametrize("sub", ["sensorhex", "params"])
def test_sim_subcommand_usage_names_the_command(sub: str, capsys: pytest.CaptureFixture[str]) -> None:
    # argparse used to derive "urb sim [-h] SUBCOMMAND ... sensorhex" from `urb sim`'s own usage line
    with pytest.raises(SystemExit) as exc:
        main(["sim", sub, "--help"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.startswith(f"usage: urb sim {sub} [-h]")


def test_sim_usage_error_names_the_command(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["sim", "sensorhex", "--jobs", "0"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: urb sim sensorhex [-h]") and "urb sim sensorhex: error: argument --jobs" in err


def _without_wall_times(summary: dict[str, object]) -> dict[str, object]:
    experiments = [{k: v for k, v in e.items() if k != "wall_s"} for e in summary["experiments"]]  # type: ignore[attr-defined]
    return {**{k: v for k, v in summary.items() if k != "wall_s"}, "experiments": experiments}


def test_parallel_experiments_give_the_serial_results(tmp_path: Path) -> None:
    only = "fig16,faults,fig15"
    for jobs in ("1", "3"):
        out = tmp_path / f"jobs{jobs}"
        assert main(["sim", "sensorhex", "--quick", "--only", only, "--jobs", jobs, "--out", str(out),
                     "--no-progress"]) == 0
    serial, parallel = tmp_path / "jobs1", tmp_path / "jobs3"
    files = sorted(p.relative_to(serial) for p in serial.rglob("*") if p.is_file() and p.suffix in (".csv", ".png"))
    assert len(files) >= 6
    for rel in files:
        assert (serial / rel).read_bytes() == (parallel / rel).read_bytes(), rel
    s, p = (json.loads((d / "summary.json").read_text()) for d in (serial, parallel))
    assert [e["key"] for e in p["experiments"]] == ["fig16", "faults", "fig15"]  # the order asked for
    assert _without_wall_times(s) == _without_wall_times(p)


def test_jobs_must_be_positive(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["sim", "sensorhex", "--jobs", "0"])
    assert exc.value.code == 2
    assert "--jobs" in capsys.readouterr().err
