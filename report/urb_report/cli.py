"""`urb report`: the certification evidence report and its gate (host/urb/cli.py defines the
command line and calls run() when the command runs).

    urb report                    build/report/index.html and report.pdf; prints the gate's verdict
    urb report --gate             the same, exit status 1 when the gate fails (make check runs it)
    urb report --no-pdf           skip Chromium
    urb report --update-baseline  accept changed requirement texts that history.trlc explains

It only reads: the requirements (spec/requirements/), the records (build/evidence/), the source
markers and the simulation's figures (build/sim/report/). Exit status: 0 done (and, with --gate,
the gate passed), 1 the gate failed or the report could not be made (the message says why), 2 a
usage error.
"""

from __future__ import annotations

import argparse
import sys
from datetime import datetime, timezone
from pathlib import Path

from . import gate, history, markers, records, requirements, tools
from .records import ROOT

REPORT_DIR = ROOT / "build" / "report"
SIM_FIGURES = ROOT / "build" / "sim" / "report"
ASSUMPTIONS = requirements.REQUIREMENTS_DIR / "ASSUMPTIONS.md"


def run(args: argparse.Namespace) -> int:
    try:
        cat = requirements.load()
    except requirements.RequirementsError as exc:
        print(f"urb report: {exc}", file=sys.stderr)
        return 1
    if args.update_baseline:
        return _update_baseline(cat)
    try:
        recs = records.read_records(args.evidence)
    except records.RecordError as exc:
        print(f"urb report: {exc}", file=sys.stderr)
        return 1
    state = records.tree_state()
    marks = markers.scan()
    from .junit import cmocka_group_sources

    a = gate.analyse(cat, recs, state, marks, history.read_baseline(), args.out / "lobster",
                     group_sources=cmocka_group_sources())
    date = datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    from . import html, lobster

    extra = lobster.versions()
    if a.lobster:
        extra = dict(a.lobster.versions)
    rows = tools.load(recs, extra)
    page = html.render(a, args.out, state=state, date=date, machine=records.machine(), tools=rows,
                       assumptions_html=_markdown(ASSUMPTIONS), figures=_figures())
    print(f"urb report: {page.relative_to(ROOT) if page.is_relative_to(ROOT) else page}")
    if not args.no_pdf:
        from .pdf import PdfError, print_pdf

        try:
            pdf = print_pdf(page, args.out / "report.pdf")
            print(f"urb report: {pdf.relative_to(ROOT) if pdf.is_relative_to(ROOT) else pdf}")
        except PdfError as exc:
            print(f"urb report: no PDF: {exc}", file=sys.stderr)
            if not args.gate:
                return 1
    gate.print_problems(a)
    return 1 if (args.gate and not a.ok) else 0


def _update_baseline(cat: requirements.Catalogue) -> int:
    unexplained = history.update(cat)
    if unexplained:
        for f in unexplained:
            print(f"urb report: not accepted: {f.requirement}: {f.message}", file=sys.stderr)
        print("urb report: baseline.json unchanged", file=sys.stderr)
        return 1
    print(f"urb report: wrote {history.BASELINE.relative_to(ROOT)} ({len(cat.requirements)} requirements); "
          f"commit it with history.trlc")
    return 0


def _figures() -> list[Path]:
    return sorted(SIM_FIGURES.rglob("*.png")) if SIM_FIGURES.is_dir() else []


def _markdown(path: Path) -> str:
    import markdown  # type: ignore[import-untyped]

    text = path.read_text(encoding="utf-8")
    return str(markdown.markdown(text.split("\n", 1)[1] if text.startswith("# ") else text, extensions=["tables"]))
