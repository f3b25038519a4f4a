"""Report rows say what they show: traces.csv holds only what the seed decides (no TLC wall time),
and an experiment's second table (bandwidth's motor workload) has its own columns in the report."""

from __future__ import annotations

import json
from pathlib import Path

from urb_sim.experiments import Result
from urb_sim.experiments.traces import row
from urb_sim.report import write_report
from urb_sim.tracecheck import TraceResult


def test_traces_csv_row_has_no_wall_time() -> None:
    """Same seed, same traces.csv byte for byte: TLC's wall time (1.234 s here) is not in a row."""
    assert row("usb", "t", TraceResult(True, 6, 6, 5, 1.234, "")) == ["usb", "t", 6, 1, 6, 5]


def test_further_tables_are_rendered_with_their_own_columns(tmp_path: Path) -> None:
    res = Result("bandwidth", "t", "p")
    res.check("c", "r", "m", True)
    res.table.append({"uplink": "usb", "payload B": 31})
    res.tables.append(("motor workload <caption>", [{"motors per bridge": 3, "sustained": "NO"}]))
    write_report(tmp_path, [res], seed=1, quick=True, overrides={}, wall_s=0.0)
    page = (tmp_path / "index.html").read_text()
    assert "<b>motor workload &lt;caption&gt;</b>" in page
    assert page.index("<th>payload B</th>") < page.index("<th>motors per bridge</th>")
    assert "<td>payload B</td>" not in page
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["experiments"][0]["tables"] == [
        {"caption": "motor workload <caption>", "rows": [{"motors per bridge": 3, "sustained": "NO"}]}]
