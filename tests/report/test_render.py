"""The report itself: HTML with every section and requirement, provenance on every printed page,
the tool list filled from the records, and the PDF from Chromium."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path
from typing import Any

import pytest

from urb_report import gate, html, markers, pdf, records, requirements, tools
from urb_report.cli import ASSUMPTIONS, _markdown
from urb_report.junit import cmocka_group_sources
from urb_report.records import Item
from report_fixtures import baseline, catalogue, real_markers, state, write_records  # noqa: F401  (pytest fixtures)

WriteRecords = Any


@pytest.fixture
def page(catalogue: requirements.Catalogue, real_markers: list[markers.Marker],
         baseline: dict[str, dict[str, object]], state: dict[str, Any], write_records: WriteRecords,
         tmp_path: Path) -> Path:
    recs = write_records(drop=["sim:fig15/linear-growth"],
                         extra={"tlc": [Item(id="tlc:MCBridgeExtra", kind="model", verdict="pass")]})
    a = gate.analyse(catalogue, recs, state, real_markers, baseline, None, group_sources=cmocka_group_sources())
    rows = tools.load(recs, {"TLC": "2.15 (fixture)"})
    figure = tmp_path / "fig15" / "latency.png"
    figure.parent.mkdir()
    figure.write_bytes(b"\x89PNG\r\n\x1a\n")
    return html.render(a, tmp_path / "report", state=state, date="2026-12-01T00:00:00Z", machine=records.machine(),
                       tools=rows, assumptions_html=_markdown(ASSUMPTIONS), figures=[figure])


def test_the_html_has_every_section_requirement_and_the_provenance(page: Path, catalogue: requirements.Catalogue,
                                                                   state: dict[str, Any]) -> None:
    text = page.read_text()
    for section in ("summary", "matrix", "requirements", "proofs", "tests", "simulation", "review", "figures", "tools",
                    "assumptions", "history", "problems", "regenerate"):
        assert f"id='{section}'" in text, section
    for r in catalogue.requirements:
        assert f"id='{r.name}'" in text and r.statement[:40] in text.replace("&#x27;", "'")
    assert f"commit {state['commit'][:12]}" in text and "class='footer'" in text
    assert "sim:fig15/linear-growth" in text and "The gate FAILS: 1 problem," in text
    assert "What holds only on simulated hardware" in text          # ASSUMPTIONS.md rendered
    assert "2.15 (fixture)" in text                                 # a tool version from the records
    assert (page.parent / "figures" / "fig15-latency.png").is_file()


def test_the_tool_list_takes_versions_from_the_records_or_says_where_they_came_from(
        write_records: WriteRecords) -> None:
    recs = write_records()
    rows = {r.name: r for r in tools.load(recs, {"TRLC": "trlc 3.1.1", "LOBSTER": "bmw-lobster 1.0.6"})}
    assert rows["TRLC and LOBSTER (traceability)"].version_source == "from the records report"
    assert all(r.trusted_for for r in rows.values())
    esbmc = rows["ESBMC (bounded model checker)"]
    assert esbmc.version == "not recorded" and esbmc.limitations and esbmc.mitigations


def test_the_pdf_has_the_provenance_on_every_page(page: Path, state: dict[str, Any]) -> None:
    out = pdf.print_pdf(page, page.parent / "report.pdf")
    assert out.read_bytes()[:5] == b"%PDF-"
    info = subprocess.run(["pdfinfo", str(out)], capture_output=True, text=True, check=True).stdout
    pages = int(next(line.split()[-1] for line in info.splitlines() if line.startswith("Pages:")))
    assert pages > 20
    for n in (1, pages // 2, pages):
        text = subprocess.run(["pdftotext", "-f", str(n), "-l", str(n), str(out), "-"], capture_output=True,
                              text=True, check=True).stdout
        assert f"commit {state['commit'][:12]}" in text, n
    whole = subprocess.run(["pdftotext", str(out), "-"], capture_output=True, text=True, check=True).stdout
    for heading in PDF_SECTIONS:
        assert heading in whole, f"the PDF has no section {heading!r}"


# The headings a reviewer finds in the PDF, in its order (html.render).
PDF_SECTIONS = ("Summary per requirement category", "Traceability matrix", "Requirements",
                "Proof and model-checking results", "Tests", "Simulation acceptance criteria",
                "Coverage, MISRA and static analysis", "Simulation figures", "Tools (qualification record)",
                "Assumptions and limits", "History of requirements", "Gate problems", "How to regenerate")


def test_a_missing_chromium_is_a_clear_error(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setattr(shutil, "which", lambda name: None)
    with pytest.raises(pdf.PdfError, match="apt-get install chromium"):
        pdf.print_pdf(tmp_path / "x.html", tmp_path / "x.pdf")


def test_the_downlinks_table_comes_from_a_simulation_record_or_says_how_to_get_it() -> None:
    from types import SimpleNamespace

    table = {"caption": "Downlinks side by side (fixture)", "assumptions": ["Model: idealised parts."],
             "rows": [{"metric": "6-byte read, mean / max (us)", "I2C 400 kb/s": "201 / 201", "CAN 1 Mb/s": "166 / 172",
                       "RS485 1 Mb/s": "208 / 212"}]}
    with_it = SimpleNamespace(activity="sim", name="sim-can", config={"side_by_side": table})
    other = SimpleNamespace(activity="sim", name="sim-fig15", config={})
    text = html._downlinks_table(SimpleNamespace(index=SimpleNamespace(records=[other, with_it])))  # type: ignore[arg-type]
    assert "id='downlinks'" in text and "166 / 172" in text and "Model: idealised parts." in text and "sim-can" in text
    missing = html._downlinks_table(SimpleNamespace(index=SimpleNamespace(records=[other])))  # type: ignore[arg-type]
    assert "--downlink all" in missing and "166" not in missing
