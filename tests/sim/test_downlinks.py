"""The CAN and RS485 SensoRHex variants (experiments `can` and `rs485`, `urb sim sensorhex --downlink`):
they pass, repeat byte for byte at a seed, write their evidence with the side-by-side table, and a
criterion fails when the model breaks what it bounds."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from urb.cli import main
from urb_sim.experiments import Result, downlinks
from urb_sim.fieldbus import cycle, measure


def _digest(r: Result) -> list[object]:
    return [[(c.name, c.measured, c.passed) for c in r.checks], r.table, r.tables]


def test_the_can_variant_passes_repeats_and_shows_three_downlinks(tmp_path: Path) -> None:
    first = downlinks.can_variant(tmp_path / "a", quick=True, seed=1)
    assert first.passed, [(c.name, c.measured) for c in first.checks if not c.passed]
    assert _digest(downlinks.can_variant(tmp_path / "b", quick=True, seed=1)) == _digest(first)
    caption, rows = first.tables[0]
    assert caption.startswith("Downlinks side by side")
    assert set(rows[0]) == {"metric", "I2C 400 kb/s", "CAN 1 Mb/s", "RS485 1 Mb/s"}
    assert any(n.startswith("Model: ") and "left out" in n for n in first.notes)


def test_the_rs485_variant_passes(tmp_path: Path) -> None:
    r = downlinks.rs485_variant(tmp_path, quick=True, seed=2)
    assert r.passed, [(c.name, c.measured) for c in r.checks if not c.passed]
    assert {c.name for c in r.checks} >= {"RS485 errors reported as I2C flags", "SYNC inter-node difference within bound"}


def test_the_latency_criterion_fails_when_a_node_answers_later_than_assumed(tmp_path: Path,
                                                                            monkeypatch: pytest.MonkeyPatch) -> None:
    """The seeded bug: the bounds assume nodes answer within 10 us, the model lets them take 100."""
    real = measure.downlink

    def slow(*args: Any, **kwargs: Any) -> Any:
        d = real(*args, **kwargs)
        if isinstance(d, cycle.CanDownlink):
            d.node_latency_us = (2.0, 100.0)
        return d

    res = Result("can", "t", "p")
    downlinks._latency(res, tmp_path, "can", [6], 10, 1)
    assert res.checks[0].passed
    monkeypatch.setattr(measure, "downlink", slow)
    res = Result("can", "t", "p")
    downlinks._latency(res, tmp_path, "can", [6], 10, 1)
    assert not res.checks[0].passed and "outside" in res.checks[0].measured


def test_downlink_option_runs_the_variant_and_writes_its_record(tmp_path: Path,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["sim", "sensorhex", "--downlink", "rs485", "--quick", "--no-progress", "--jobs", "1",
                 "--out", str(tmp_path / "out"), "--evidence", str(tmp_path / "ev")])
    assert code == 0, capsys.readouterr()
    record = json.loads((tmp_path / "ev" / "sim-rs485.json").read_text())
    assert [i["id"] for i in record["items"]][0] == "sim:rs485/read-latency-within-derived-bounds"
    assert record["config"]["side_by_side"]["rows"] and record["config"]["side_by_side"]["assumptions"]
    assert "Downlinks side by side" in (tmp_path / "out" / "index.html").read_text()
    with pytest.raises(SystemExit) as exc:
        main(["sim", "sensorhex", "--downlink", "usb"])
    assert exc.value.code == 2
