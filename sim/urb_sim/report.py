"""The HTML summary of a simulation run (build/sim/report/index.html): one table of acceptance
checks first, then one section per experiment with its figure, its numbers and its CSV files."""

from __future__ import annotations

import html
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .evidence import page_provenance
from .experiments import Result
from .native import params

CSS = """
body{font-family:system-ui,sans-serif;max-width:1100px;margin:2em auto;color:#222;line-height:1.45}
h1{margin-bottom:.2em} .sub{color:#666;margin-top:0}
table{border-collapse:collapse;margin:.8em 0;font-size:.92em} td,th{border:1px solid #ccc;padding:.3em .6em;text-align:left}
th{background:#f3f3f3} .pass{color:#fff;background:#2a8a3e;font-weight:bold} .fail{color:#fff;background:#c0392b;font-weight:bold}
img{max-width:100%;border:1px solid #ddd} .note{background:#fff8e1;border-left:4px solid #f0b400;padding:.4em .8em;margin:.4em 0}
code{background:#f4f4f4;padding:0 .2em} section{margin-top:2.2em} .small{font-size:.85em;color:#555}
.headline{font-size:1.05em;margin:.3em 0} ul.headline{margin-top:0}
"""


def _badge(ok: bool) -> str:
    return f'<td class="{"pass" if ok else "fail"}">{"PASS" if ok else "FAIL"}</td>'


def _table(rows: Sequence[dict[str, object]]) -> str:
    if not rows:
        return ""
    cols = list(rows[0].keys())
    head = "".join(f"<th>{html.escape(str(c))}</th>" for c in cols)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(str(r.get(c, '')))}</td>" for c in cols) + "</tr>" for r in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def _n(count: int, one: str, many: str) -> str:
    return f"{count} {one if count == 1 else many}"


def headline(results: Sequence[Result]) -> tuple[str, list[str]]:
    """The report's headline: a sentence, and the lines it introduces: every acceptance check that
    is not met, then every result that does not reproduce the paper (`Result.deviations`), each
    named. "All acceptance criteria met" alone would hide the second kind: a criterion can hold
    where the paper's claim does not (the gait is checked at 500 Hz, the paper's runs at 1 kHz)."""
    failed = [f"{r.verdict} {r.key}: {c.name}: required {c.required}; measured {c.measured}"
              for r in results for c in r.checks if not c.passed]
    failed += [f"ERROR {r.key}: no acceptance check" for r in results if not r.checks]
    deviations = [d for r in results for d in r.deviations]
    criteria = (_n(len(failed), "acceptance criterion is NOT met", "acceptance criteria are NOT met") if failed
                else "All acceptance criteria met")
    if deviations:
        paper = _n(len(deviations), "result does not reproduce the paper", "results do not reproduce the paper")
        return f"{criteria}{', and ' if failed else ', but '}{paper}:", failed + deviations
    if failed:
        return f"{criteria}:", failed
    return "All acceptance criteria met, and every result reproduces the paper.", []


def _provenance_html(prov: dict[str, Any]) -> str:
    """The run's provenance (records.provenance and the tools, evidence.page_provenance) as a table."""
    tree = "clean tree" if prov.get("clean") else f"uncommitted changes (hash {prov.get('changes')})"
    machine = prov.get("machine", {})
    rows = [{"item": "commit", "value": f"{prov.get('commit')} ({tree})"},
            {"item": "date", "value": prov.get("date", "")},
            {"item": "machine", "value": f"{machine.get('host', '')}: {machine.get('cpu', '')}, "
                                         f"{machine.get('cores', '')} cores, {machine.get('os', '')}"},
            {"item": "seed", "value": prov.get("seed", "")}]
    rows += [{"item": name, "value": version} for name, version in prov.get("tools", {}).items()]
    return "<section id='provenance'><h2>Provenance</h2>" + _table(rows) + "</section>"


def write_report(out: Path, results: Sequence[Result], *, seed: int, quick: bool, overrides: dict[str, float],
                 wall_s: float, provenance: dict[str, Any] | None = None) -> Path:
    """Write index.html and summary.json into `out`; returns the HTML path. `provenance` (commit,
    clean tree, date, machine, seed, tools: `evidence.page_provenance`) is stamped on both."""
    out.mkdir(parents=True, exist_ok=True)
    ok = all(r.passed for r in results)
    prov = provenance if provenance is not None else page_provenance(seed, [r.key for r in results])
    sim_s = sum(r.sim_s for r in results)
    sentence, lines = headline(results)
    tree = "" if prov.get("clean") else ", uncommitted changes"
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>URB SensoRHex simulation</title>"
             f"<style>{CSS}</style></head><body>",
             "<h1>URB: simulated SensoRHex buses</h1>",
             f"<p class='headline'><b>{html.escape(sentence)}</b></p>",
             ("<ul class='headline'>" + "".join(f"<li>{html.escape(line)}</li>" for line in lines) + "</ul>"
              if lines else ""),
             f"<p class='sub'>Seed {seed}{' (quick run: fewer samples)' if quick else ''}, {prov.get('date', '')}, "
             f"commit {str(prov.get('commit', ''))[:12]}{tree} (<a href='#provenance'>provenance</a>), "
             f"{sim_s:.1f} s simulated in {wall_s:.1f} s of wall time.</p>",
             "<p>The real node library, SensoRHex applications and bridge firmware, compiled for the host, run on "
             "simulated microcontrollers and buses (byte-timed UART and I2C, 1-ms USB frames, clocks with crystal "
             "error and drift); the host library runs unchanged on a simulated CPU whose threads wake on the 1-kHz "
             "OS tick. Every figure below is reproducible from its seed: "
             f"<code>urb sim sensorhex{' --quick' if quick else ''} --seed {seed}</code>. "
             "The models and their parameters are documented in <code>sim/README.md</code>.</p>",
             "<h2>Acceptance</h2><table><tr><th>experiment</th><th>check</th><th>required</th><th>measured</th>"
             "<th></th></tr>"]
    for r in results:
        for c in r.checks:
            parts.append(f"<tr><td><a href='#{r.key}'>{html.escape(r.key)}</a></td><td>{html.escape(c.name)}</td>"
                         f"<td>{html.escape(c.required)}</td><td>{html.escape(c.measured)}</td>{_badge(c.passed)}</tr>")
    parts.append("</table>")
    for r in results:
        parts.append(f"<section id='{r.key}'><h2>{html.escape(r.title)}</h2>")
        parts.append(f"<p><b>Paper:</b> {html.escape(r.paper)}. <b>Result:</b> "
                     f"{r.verdict} ({r.sim_s:.1f} s simulated, {r.wall_s:.1f} s wall).</p>")
        for d in r.deviations:
            parts.append(f"<div class='note'><b>Does not reproduce the paper:</b> {html.escape(d)}</div>")
        for f in r.files:
            if f.suffix == ".png":
                parts.append(f"<p><img src='{html.escape(f.relative_to(out).as_posix())}' alt='{html.escape(r.title)}'></p>")
        parts.append(_table(r.table))
        for caption, rows in r.tables:
            parts.append(f"<p><b>{html.escape(caption)}</b></p>{_table(rows)}")
        for n in r.notes:
            parts.append(f"<div class='note'>{html.escape(n)}</div>")
        links = ", ".join(f"<a href='{html.escape(f.relative_to(out).as_posix())}'>{html.escape(f.name)}</a>"
                          for f in r.files if f.suffix != ".png")
        if links:
            parts.append(f"<p class='small'>Data: {links}</p>")
        parts.append("</section>")
    rows = [{"parameter": p.name, "value": overrides.get(p.name, p.default), "default": p.default, "meaning": p.doc}
            for p in params()]
    parts.append("<section id='params'><h2>Model parameters</h2><p class='small'>Values used by this run "
                 "(experiments may override some for their rig; each experiment's text says which).</p>")
    parts.append(_table(rows))
    parts.append("</section>")
    parts.append(_provenance_html(prov))
    parts.append("</body></html>")
    path = out / "index.html"
    path.write_text("\n".join(parts), encoding="utf-8")
    summary = {"passed": ok, "headline": [sentence, *lines], "seed": seed, "quick": quick, "wall_s": wall_s,
               "sim_s": sim_s, "provenance": prov,
               "experiments": [{"key": r.key, "passed": r.passed, "verdict": r.verdict, "wall_s": r.wall_s, "sim_s": r.sim_s,
                                "deviations": r.deviations,
                                "checks": [c.__dict__ for c in r.checks], "table": r.table,
                                "tables": [{"caption": c, "rows": t} for c, t in r.tables], "notes": r.notes,
                                "files": [f.relative_to(out).as_posix() for f in r.files]} for r in results]}
    (out / "summary.json").write_text(json.dumps(summary, indent=1, default=str), encoding="utf-8")
    return path
