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
    assert "choose from" in capsys.readouterr().err


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
