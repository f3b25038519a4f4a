"""Report rows say what they show: traces.csv holds only what the seed decides (no TLC wall time),
an experiment's second table (bandwidth's motor workload) has its own columns in the report, and
the headline names every check not met and every result that does not reproduce the paper."""

from __future__ import annotations

import html
import json
from pathlib import Path

from urb_sim.experiments import Result
from urb_sim.experiments.traces import row
from urb_sim.report import headline, write_report
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


def _result(key: str, passed: bool, deviations: list[str]) -> Result:
    res = Result(key, "t", "p", deviations=deviations)
    res.check("c", "r", "m", passed)
    return res


def test_the_headline_names_every_result_that_does_not_reproduce_the_paper(tmp_path: Path) -> None:
    """Issue #35: "All acceptance criteria met" stood above a finding that the paper's six legs at 1 kHz
    do not reproduce. The headline names it, and every other such result and failed check."""
    six_legs = "Fig. 20: the paper's six legs under 1-kHz control do not fit; the gait runs at 500 Hz"
    nine_bytes = "bandwidth: RS232 sustains 9-byte reads at 1 kHz, not the paper's 10"
    results = [_result("fig20", True, [six_legs]), _result("bandwidth", True, [nine_bytes]),
               _result("fig16", True, [])]
    write_report(tmp_path, results, seed=1, quick=True, overrides={}, wall_s=0.0, provenance={})
    page = (tmp_path / "index.html").read_text()
    head = page[:page.index("<h2>Acceptance</h2>")]
    assert "<b>All acceptance criteria met, but 2 results do not reproduce the paper:</b>" in head
    assert html.escape(six_legs) in head and html.escape(nine_bytes) in head
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["headline"] == ["All acceptance criteria met, but 2 results do not reproduce the paper:",
                                   six_legs, nine_bytes]
    assert summary["experiments"][0]["deviations"] == [six_legs]
    # each in its experiment's section too
    assert page.count(f"<b>Does not reproduce the paper:</b> {html.escape(six_legs)}") == 1


def test_the_headline_names_failed_checks_before_the_paper(tmp_path: Path) -> None:
    results = [_result("fig20", True, ["Fig. 20: six legs"]), _result("fig16", False, [])]
    assert headline(results) == ("1 acceptance criterion is NOT met, and 1 result does not reproduce the paper:",
                                 ["FAIL fig16: c: required r; measured m", "Fig. 20: six legs"])
    assert headline([_result("fig16", True, [])]) == (
        "All acceptance criteria met, and every result reproduces the paper.", [])
