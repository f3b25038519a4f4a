"""The certification report as one HTML page (build/report/index.html), printable to PDF.

Sections: summary (verdict, counts per requirement category and per activity), the traceability
matrix, one section per requirement, the proof tables, tests, coverage and MISRA, the simulation
figures, the tool list, assumptions and limits, history, the gate's problems, and how to
regenerate everything. The layout table's footer carries the provenance, so every printed page has it.
"""

from __future__ import annotations

import shutil
from collections import Counter
from collections.abc import Mapping, Sequence
from html import escape
from pathlib import Path
from typing import Any

from .evidence import ACTIVITIES, KIND_ACTIVITY, Resolution
from .gate import Analysis
from .records import ROOT, Record
from .requirements import Requirement
from .tools import ToolRow

CSS = """
@page { size: A4; margin: 14mm 14mm 10mm 14mm; }
body { font: 10pt/1.35 'DejaVu Sans', Arial, sans-serif; color: #111; margin: 0 0 8mm 0; }
h1 { font-size: 20pt; margin: 0 0 4pt 0; } h2 { font-size: 14pt; border-bottom: 1.5pt solid #333;
  margin-top: 16pt; page-break-after: avoid; } h3 { font-size: 11pt; margin: 10pt 0 3pt 0; page-break-after: avoid; }
table { border-collapse: collapse; width: 100%; margin: 4pt 0 8pt 0; font-size: 8.5pt; }
th, td { border: 0.5pt solid #999; padding: 2pt 4pt; vertical-align: top; text-align: left; }
th { background: #e8e8e8; } tr { page-break-inside: avoid; }
td.num, th.num { text-align: right; white-space: nowrap; }
code, .id { font-family: 'DejaVu Sans Mono', monospace; font-size: 8pt; word-break: break-all; }
.pass { color: #0a6b0a; font-weight: bold; } .fail, .error, .missing { color: #b00000; font-weight: bold; }
.stale { color: #a15c00; font-weight: bold; }
.verdict { font-size: 14pt; padding: 6pt; border: 2pt solid; margin: 8pt 0; }
.verdict.pass { border-color: #0a6b0a; } .verdict.fail { border-color: #b00000; }

.req { page-break-inside: avoid; border-left: 3pt solid #bbb; padding-left: 6pt; margin: 8pt 0; }
.req.r-fail { border-left-color: #b00000; } .req.r-pass { border-left-color: #0a6b0a; }
.gate { font-size: 8pt; color: #8a0000; }
.meta { color: #444; font-size: 8.5pt; } .small { font-size: 8pt; color: #333; }
table.layout, table.layout > tbody > tr > td, table.layout > tfoot > tr > td { border: none; padding: 0;
  font-size: 10pt; }
table.layout > tfoot > tr > td.footer { font-size: 7pt; color: #444; border-top: 0.5pt solid #999;
  padding-top: 2pt; height: 8mm; vertical-align: top; }
figure { page-break-inside: avoid; margin: 6pt 0; } figure img { max-width: 100%; max-height: 120mm; }
figcaption { font-size: 8pt; color: #333; }
.toc a { text-decoration: none; } a { color: #0645ad; }
section.break { page-break-before: always; }
"""

STATUS_WORD = {"pass": "pass", "fail": "FAIL", "error": "ERROR", "stale": "STALE", "missing": "MISSING"}


def _e(text: object) -> str:
    return escape(str(text), quote=True)


def _badge(status: str) -> str:
    return f'<span class="{_e(status)}">{_e(STATUS_WORD.get(status, status))}</span>'


def anchor(evidence: str) -> str:
    return "ev-" + "".join(c if c.isalnum() else "-" for c in evidence)


def _src_link(source: str) -> str:
    """A repository-relative "file:line" as a link to the file in the checkout."""
    if not source:
        return ""
    file, _, line = source.partition(":")
    path = ROOT / file
    if not path.exists():
        return f"<code>{_e(source)}</code>"
    href = "../../" + file  # build/report/index.html -> repository root
    return f'<a href="{_e(href)}"><code>{_e(source)}</code></a>'


def provenance_line(state: Mapping[str, Any], date: str, host: str, seeds: str) -> str:
    clean = "clean tree" if state.get("clean") else f"uncommitted changes {state.get('changes')}"
    return f"commit {str(state.get('commit'))[:12]} ({clean}) · report {date} · machine {host} · seeds {seeds}"


def render(a: Analysis, out_dir: Path, *, state: Mapping[str, Any], date: str, machine: Mapping[str, Any],
           tools: Sequence[ToolRow], assumptions_html: str, figures: Sequence[Path]) -> Path:
    """Write out_dir/index.html (and copy the figures next to it); return its path."""
    seeds = sorted({f"{r.name}={r.provenance.get('seed')}" for r in a.index.records
                    if r.provenance.get("seed") not in (None, "")})
    prov = provenance_line(state, date, str(machine.get("host", "")), ", ".join(seeds) or "none")
    fig_dir = out_dir / "figures"
    if fig_dir.exists():
        shutil.rmtree(fig_dir)
    copied = []
    for f in figures:
        fig_dir.mkdir(parents=True, exist_ok=True)
        target = fig_dir / f"{f.parent.name}-{f.name}"
        shutil.copy(f, target)
        copied.append((f, target))
    parts = [
        "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>",
        f"<title>URB certification evidence report, commit {_e(str(state.get('commit'))[:12])}</title>",
        f"<style>{CSS}</style></head><body>",
        # a table's footer repeats on every printed page: the provenance is on each one
        "<table class='layout'><tfoot><tr><td class='footer'>URB evidence report · " + _e(prov) +
        "</td></tr></tfoot><tbody><tr><td>",
        _summary(a, state, date, machine, seeds),
        _contents(),
        _matrix(a),
        _requirements(a),
        _records_section(a, "proofs", "Proof and model-checking results",
                         ("tlc", "tlc-mutation", "bmc", "framac", "fuzz", "mutation"),
                         "Every item of the TLC, ESBMC, Frama-C, fuzzing and mutation-score records, with its "
                         "expected and measured result. A mutant passes when the tool rejects it on the expected "
                         "property, or a survivor when it is explained as equivalent."),
        _tests(a),
        _records_section(a, "simulation", "Simulation acceptance criteria", ("sim",),
                         "Every criterion of every experiment's record: required (expected) against measured value, "
                         "under the hardware profile its id names (sim@<profile>:, the default profile otherwise)."),
        _downlinks_table(a),
        _review(a),
        _other_records(a),
        _figures(copied),
        _tools(tools),
        f"<section class='break' id='assumptions'><h2>Assumptions and limits</h2>{assumptions_html}</section>",
        _history(a),
        _problems(a),
        _regenerate(a),
        "</td></tr></tbody></table></body></html>",
    ]
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / "index.html"
    path.write_text("\n".join(parts), encoding="utf-8")
    return path


def _summary(a: Analysis, state: Mapping[str, Any], date: str, machine: Mapping[str, Any], seeds: list[str]) -> str:
    n = len(a.catalogue.requirements)
    failing = {p.requirement for p in a.problems if p.requirement}
    verdict = "pass" if a.ok else "fail"
    words = ("The gate passes: every requirement is traced and every cited item passed on this tree."
             if a.ok else f"The gate FAILS: {len(a.problems)} problem{'s' if len(a.problems) != 1 else ''}, "
                          f"{len(failing)} of {n} requirements affected (section Gate problems).")
    rows = []
    for cat, desc in a.catalogue.categories.items():
        reqs = [r for r in a.catalogue.requirements if r.category == cat]
        ok = sum(1 for r in reqs if a.requirement_status(r.tag) == "pass")
        items = [a.resolutions[e] for r in reqs for e in r.verified_by]
        c = Counter(x.status for x in items)
        rows.append(f"<tr><td>{_e(desc)}</td><td class='num'>{len(reqs)}</td><td class='num pass'>{ok}</td>"
                    f"<td class='num{' fail' if len(reqs) - ok else ''}'>{len(reqs) - ok}</td>"
                    f"<td class='num'>{len(items)}</td><td class='num'>{c['pass']}</td>"
                    f"<td class='num'>{c['fail'] + c['error']}</td><td class='num'>{c['stale']}</td>"
                    f"<td class='num'>{c['missing']}</td></tr>")
    total = Counter(x.status for r in a.catalogue.requirements for x in (a.resolutions[e] for e in r.verified_by))
    ok_all = sum(1 for r in a.catalogue.requirements if a.requirement_status(r.tag) == "pass")
    rows.append(f"<tr><th>all</th><th class='num'>{n}</th><th class='num'>{ok_all}</th><th class='num'>{n - ok_all}</th>"
                f"<th class='num'>{sum(total.values())}</th><th class='num'>{total['pass']}</th>"
                f"<th class='num'>{total['fail'] + total['error']}</th><th class='num'>{total['stale']}</th>"
                f"<th class='num'>{total['missing']}</th></tr>")
    acts = []
    for name, act in ACTIVITIES.items():
        recs = [r for r in a.index.records if r.activity == name]
        if not recs:
            acts.append(f"<tr><td>{_e(act.tool)}</td><td class='missing'>no record</td><td></td><td></td><td></td>"
                        f"<td>{_e(act.make)}</td></tr>")
            continue
        for r in recs:
            c = Counter(i.verdict for i in r.items)
            stale = a.index.stale.get(r.name, "")
            acts.append(f"<tr><td>{_e(act.tool)}</td><td><code>build/evidence/{_e(r.name)}.json</code>"
                        f"{'<br><span class=stale>STALE: ' + _e(stale) + '</span>' if stale else ''}</td>"
                        f"<td class='num'>{len(r.items)}</td><td class='num'>{c['pass']}</td>"
                        f"<td class='num'>{c['fail'] + c['error']}</td><td>{_e(act.make)}</td></tr>")
    others = sorted({r.activity for r in a.index.records} - set(ACTIVITIES))
    for name in others:
        for r in (r for r in a.index.records if r.activity == name):
            c = Counter(i.verdict for i in r.items)
            acts.append(f"<tr><td>{_e(name)}</td><td><code>build/evidence/{_e(r.name)}.json</code></td>"
                        f"<td class='num'>{len(r.items)}</td><td class='num'>{c['pass']}</td>"
                        f"<td class='num'>{c['fail'] + c['error']}</td><td></td></tr>")
    clean = "yes" if state.get("clean") else f"no (uncommitted changes, hash {state.get('changes')})"
    return f"""
<h1>URB certification evidence report</h1>
<p class='meta'>URB, the Universal Robot Bus: requirements, their verification and its results on one commit.</p>
<table><tr><th>commit</th><td><code>{_e(state.get('commit'))}</code></td><th>clean tree</th><td>{_e(clean)}</td></tr>
<tr><th>report date (UTC)</th><td>{_e(date)}</td><th>machine</th><td>{_e(machine.get('host'))}, {_e(machine.get('cpu'))},
{_e(machine.get('cores'))} cores, {_e(machine.get('os'))}</td></tr>
<tr><th>seeds</th><td colspan='3'>{_e(', '.join(seeds) or 'no record is seeded')}</td></tr></table>
<div class='verdict {verdict}'>{_e(words)}</div>
<h2 id='summary'>Summary per requirement category</h2>
<table><tr><th>category</th><th class='num'>requirements</th><th class='num'>pass</th><th class='num'>fail</th>
<th class='num'>cited items</th><th class='num'>passed</th><th class='num'>failed</th><th class='num'>stale</th>
<th class='num'>no result</th></tr>{''.join(rows)}</table>
<p class='small'>A requirement passes when every item it cites passed in a record produced from this tree, the
items carry markers back to it, LOBSTER traces it, and its text matches the accepted baseline.</p>
<h2 id='activities'>Verification activities (records read)</h2>
<table><tr><th>activity</th><th>record</th><th class='num'>items</th><th class='num'>passed</th>
<th class='num'>failed</th><th>written by</th></tr>{''.join(acts)}</table>
<h3>How to read this report</h3>
<p>Pick a requirement in the traceability matrix or in the section Requirements. Its section states it, says
why and where it comes from, and lists every item that verifies it: the TLA+ property and its must-fail mutant,
the proof, the test or the simulation criterion, each with its expected and measured result, the record and tool
version that produced it, the source file and the command that reruns it. The Assumptions and limits section
says what none of this covers.</p>
"""


def _contents() -> str:
    entries = [("summary", "Summary"), ("matrix", "Traceability matrix"), ("requirements", "Requirements"),
               ("proofs", "Proof and model-checking results"), ("tests", "Tests"),
               ("simulation", "Simulation acceptance criteria"), ("downlinks", "Downlinks side by side"),
               ("review", "Coverage, MISRA and static analysis"), ("figures", "Simulation figures"),
               ("tools", "Tools"), ("assumptions", "Assumptions and limits"), ("history", "History of requirements"),
               ("problems", "Gate problems"), ("regenerate", "How to regenerate")]
    return "<div class='toc'><h3>Contents</h3><ol>" + "".join(
        f"<li><a href='#{k}'>{_e(v)}</a></li>" for k, v in entries) + "</ol></div>"


def _matrix(a: Analysis) -> str:
    rows = []
    for r in a.catalogue.requirements:
        first = True
        for e in r.verified_by:
            res = a.resolutions[e]
            head = (f"<td rowspan='{len(r.verified_by)}'><a href='#{_e(r.name)}'><code>{_e(r.tag)}</code></a><br>"
                    f"{_badge(a.requirement_status(r.tag))}</td>") if first else ""
            first = False
            rows.append(f"<tr>{head}<td class='id'><a href='#{anchor(e)}-{_e(r.name)}'>{_e(e)}</a></td>"
                        f"<td>{_e(res.activity)}</td><td>{_badge(res.status)}</td></tr>")
    return ("<section class='break' id='matrix'><h2>Traceability matrix</h2>"
            "<p class='small'>requirement → evidence → result on this tree. Links lead to the requirement's section "
            "and the item's row in it.</p><table><tr><th>requirement</th><th>evidence item</th><th>activity</th>"
            f"<th>result</th></tr>{''.join(rows)}</table></section>")


def _requirements(a: Analysis) -> str:
    out = ["<section class='break' id='requirements'><h2>Requirements</h2>"]
    changes: dict[str, list[Any]] = {}
    for c in a.catalogue.changes:
        changes.setdefault(c.requirement, []).append(c)
    impl: dict[str, list[str]] = {}
    for m in a.markers:
        if not m.is_activity:
            for t in m.requirements:
                impl.setdefault(t, []).append(f"{m.file}:{m.line}" + (f" ({m.item})" if m.item else ""))
    trace = {} if a.lobster is None else _lobster_status(a)
    for cat, desc in a.catalogue.categories.items():
        reqs = [r for r in a.catalogue.requirements if r.category == cat]
        if not reqs:
            continue
        out.append(f"<h3>{_e(desc[:1].upper() + desc[1:])}</h3>")
        for r in reqs:
            out.append(_requirement(a, r, changes.get(r.tag, []), impl.get(r.tag, []), trace.get(r.tag, "")))
    out.append("</section>")
    return "".join(out)


def _lobster_status(a: Analysis) -> dict[str, str]:
    from .lobster import tracing_status

    return tracing_status(a.lobster.report) if a.lobster else {}


def _requirement(a: Analysis, r: Requirement, changes: list[Any], impl: list[str], trace: str) -> str:
    status = a.requirement_status(r.tag)
    rows = []
    for e in r.verified_by:
        res = a.resolutions[e]
        rows.append(_evidence_row(e, res, r.name))
    probs = [p for p in a.problems if p.requirement == r.tag and p.check != "evidence"]  # those are in the table
    crit = f"<p><b>Acceptance criterion:</b> {_e(r.criterion)}</p>" if r.criterion else ""
    hist = ""
    if changes:
        hist = "<p><b>History:</b></p><table><tr><th>version</th><th>old</th><th>new</th><th>reason</th></tr>" + "".join(
            f"<tr><td>{c.from_version} → {c.to_version}<br>{_e(c.date)}</td><td>{_e(c.old_text)}</td>"
            f"<td>{_e(c.new_text)}</td><td>{_e(c.reason)}</td></tr>" for c in changes) + "</table>"
    code = ("<p class='small'><b>Implemented at</b> (markers): " + ", ".join(_src_link(s.split(' ')[0]) + _e(
        s[len(s.split(' ')[0]):]) for s in impl[:12]) + "</p>") if impl else ""
    problems = ("<p class='gate'>Gate: " + "<br>".join(_e(f"[{p.check}] {p.message}") for p in probs) + "</p>"
                if probs else "")
    return f"""
<div class='req r-{status}' id='{_e(r.name)}'>
<h3><code>{_e(r.tag)}</code> {_badge(status)} <span class='meta'>version {r.version} · {_e(', '.join(r.methods))}
· LOBSTER: {_e(trace or 'not run')}</span></h3>
<p>{_e(r.statement)}</p>{crit}
<p class='small'><b>Rationale:</b> {_e(r.rationale)}<br><b>Source:</b> {_e(r.source_kind.replace('_', ' '))}: {_e(r.source)}
· <b>defined in</b> {_src_link(f'{r.file}:{r.line}')}</p>
<table><tr><th>evidence</th><th>result</th><th>expected</th><th>measured</th><th>source · rerun · record</th></tr>
{''.join(rows)}</table>{code}{hist}{problems}
</div>"""


def _evidence_row(e: str, res: Resolution, req_name: str) -> str:
    if not res.hits:
        return (f"<tr id='{anchor(e)}-{_e(req_name)}'><td class='id'>{_e(e)}</td><td>{_badge(res.status)}</td>"
                f"<td colspan='3' class='small'>{_e(res.detail)}</td></tr>")
    rec, item = res.hits[0]
    n = len(res.hits)
    measured = item.measured if n == 1 else f"{sum(1 for _, i in res.hits if i.verdict == 'pass')} of {n} items passed"
    if res.status in ("fail", "error", "stale"):
        measured = res.detail
    tool = "; ".join(f"{k} {v}" for k, v in list(rec.tools.items())[:2])
    return (f"<tr id='{anchor(e)}-{_e(req_name)}'><td class='id'>{_e(e)}</td><td>{_badge(res.status)}</td>"
            f"<td class='small'>{_e(item.expected)}</td><td class='small'>{_e(measured)}</td>"
            f"<td class='small'>{_src_link(item.source)}<br><code>{_e(item.rerun)}</code><br>"
            f"{_e(rec.name)}.json · {_e(tool)}</td></tr>")


def _records_section(a: Analysis, ident: str, title: str, activities: Sequence[str], intro: str) -> str:
    out = [f"<section class='break' id='{ident}'><h2>{_e(title)}</h2><p class='small'>{_e(intro)}</p>"]
    for act in activities:
        recs = [r for r in a.index.records if r.activity == act]
        if not recs:
            out.append(f"<h3>{_e(ACTIVITIES[act].tool)}</h3><p class='missing'>No record for activity {_e(act)}: "
                       f"{_e(ACTIVITIES[act].make)} writes build/evidence/{_e(act)}.json.</p>")
        for r in recs:
            out.append(_record_table(a, r))
    out.append("</section>")
    return "".join(out)


def _downlinks_table(a: Analysis) -> str:
    """The I2C, CAN and RS485 downlinks side by side, from the first simulation record that carries
    the table (sim-can.json or sim-rs485.json: urb sim sensorhex --downlink can|rs485|all)."""
    found = [r for r in a.index.records if r.activity == "sim" and isinstance(r.config.get("side_by_side"), Mapping)]
    out = ["<section id='downlinks'><h2>Downlinks side by side</h2>"]
    if not found:
        out.append("<p class='missing'>No simulation record holds the comparison: <code>urb sim sensorhex "
                   "--downlink all</code> (or make test-sim-san) writes build/evidence/sim-can.json.</p></section>")
        return "".join(out)
    r = found[0]
    table = r.config["side_by_side"]
    rows: Sequence[Mapping[str, Any]] = table.get("rows", [])
    cols = list(rows[0]) if rows else []
    out.append(f"<p class='small'>{_e(table.get('caption', ''))} (record <code>{_e(r.name)}.json</code>).</p><table><tr>"
               + "".join(f"<th>{_e(c)}</th>" for c in cols) + "</tr>"
               + "".join("<tr>" + "".join(f"<td class='small'>{_e(row.get(c, ''))}</td>" for c in cols) + "</tr>"
                         for row in rows) + "</table>")
    out.append("<p class='small'>" + "<br>".join(_e(x) for x in table.get("assumptions", [])) + "</p></section>")
    return "".join(out)


def _record_table(a: Analysis, r: Record, limit: int = 2000) -> str:
    c = Counter(i.verdict for i in r.items)
    tools = ", ".join(f"{k} {v}" for k, v in r.tools.items())
    stale = a.index.stale.get(r.name)
    head = (f"<h3>{_e(ACTIVITIES[r.activity].tool if r.activity in ACTIVITIES else r.activity)}: "
            f"<code>{_e(r.name)}.json</code></h3><p class='small'>{len(r.items)} items: {c['pass']} passed, "
            f"{c['fail']} failed, {c['error']} without result · tools: {_e(tools)} · commit "
            f"{_e(str(r.provenance.get('commit'))[:12])}, {_e(r.provenance.get('date'))}, seed "
            f"{_e(r.provenance.get('seed'))}{' · <span class=stale>STALE: ' + _e(stale) + '</span>' if stale else ''}</p>")
    rows = []
    for i in r.items[:limit]:
        extra = ", ".join(f"{k}={v}" for k, v in i.data.items() if not isinstance(v, (dict, list)))[:160]
        cited = " ★" if i.id in a.cited_by or any(i.id.startswith(e + "[") for e in a.cited_by) else ""
        rows.append(f"<tr><td class='id'>{_e(i.id)}{cited}</td><td>{_badge(i.verdict)}</td><td class='small'>"
                    f"{_e(i.expected)}</td><td class='small'>{_e(i.measured)}</td><td class='small'>{_e(extra)}</td></tr>")
    more = f"<p class='small'>... and {len(r.items) - limit} more in the record.</p>" if len(r.items) > limit else ""
    return (head + "<table><tr><th>item (★ cited)</th><th>verdict</th><th>expected</th><th>measured</th><th>data</th>"
            f"</tr>{''.join(rows)}</table>{more}")


SHOWN_ACTIVITIES = ("tlc", "tlc-mutation", "bmc", "framac", "fuzz", "mutation", "sim", "pytest", "cmocka",
                    "coverage", "misra", "static", "size")


def _other_records(a: Analysis) -> str:
    """Records of activities no section above is about: shown too, so the report holds every record read."""
    others = [r for r in a.index.records if r.activity not in SHOWN_ACTIVITIES]
    if not others:
        return ""
    return ("<section class='break' id='other-records'><h2>Other records</h2>"
            + "".join(_record_table(a, r, limit=400) for r in others) + "</section>")


def _tests(a: Analysis) -> str:
    out = ["<section class='break' id='tests'><h2>Tests</h2><p class='small'>Per test file (pytest) and cmocka group: "
           "how many tests ran and passed. Every test is an item of its record; cited ones appear with their "
           "requirement.</p>"]
    for act in ("pytest", "cmocka"):
        recs = [r for r in a.index.records if r.activity == act]
        if not recs:
            out.append(f"<p class='missing'>No record for activity {act}: {_e(ACTIVITIES[act].make)} writes it.</p>")
        for r in recs:
            groups: dict[str, Counter[str]] = {}
            for i in r.items:
                key = i.id.split(":", 1)[1].split("::")[0] if act == "pytest" else i.id.split(":", 1)[1].split("/")[0]
                groups.setdefault(key, Counter())[i.verdict] += 1
            rows = "".join(f"<tr><td><code>{_e(k)}</code></td><td class='num'>{sum(v.values())}</td>"
                           f"<td class='num'>{v['pass']}</td><td class='num'>{v['fail'] + v['error']}</td></tr>"
                           for k, v in sorted(groups.items()))
            stale = a.index.stale.get(r.name)
            out.append(f"<h3><code>{_e(r.name)}.json</code>{' <span class=stale>STALE</span>' if stale else ''}</h3>"
                       f"<p class='small'>{_e(', '.join(f'{k} {v}' for k, v in r.tools.items()))} · config: "
                       f"{_e(', '.join(f'{k}={v}' for k, v in r.config.items()))[:300]}</p>"
                       f"<table><tr><th>{'file' if act == 'pytest' else 'group'}</th><th class='num'>tests</th>"
                       f"<th class='num'>passed</th><th class='num'>failed</th></tr>{rows}</table>")
    out.append("</section>")
    return "".join(out)


def _review(a: Analysis) -> str:
    out = ["<section class='break' id='review'><h2>Coverage, MISRA and static analysis</h2>"]
    for act, what in (("coverage", "Structural coverage: an item passes when its file is covered or every uncovered "
                                   "line and decision has a written justification."),
                      ("misra", "MISRA C:2012: an item passes when the finding has a deviation record."),
                      ("static", "Static analysis: an item passes when the finding has a written reason."),
                      ("size", "Flash and RAM budgets.")):
        recs = [r for r in a.index.records if r.activity == act]
        out.append(f"<p class='small'>{_e(what)}</p>")
        if not recs:
            out.append(f"<p class='missing'>No record for activity {act}: {_e(ACTIVITIES[act].make)} writes it.</p>")
        for r in recs:
            out.append(_record_table(a, r, limit=400))
    out.append("</section>")
    return "".join(out)


def _figures(figs: Sequence[tuple[Path, Path]]) -> str:
    out = ["<section class='break' id='figures'><h2>Simulation figures</h2>"]
    if not figs:
        out.append("<p class='missing'>No figures: build/sim/report/ holds none. <code>make demo</code> "
                   "(urb sim sensorhex) writes them.</p>")
    for src, target in figs:
        rel = src.relative_to(ROOT) if src.is_relative_to(ROOT) else src
        out.append(f"<figure><img src='figures/{_e(target.name)}' alt='{_e(rel)}'><figcaption>{_e(rel)}</figcaption>"
                   "</figure>")
    out.append("</section>")
    return "".join(out)


def _tools(tools: Sequence[ToolRow]) -> str:
    rows = "".join(
        f"<tr><td><b>{_e(t.name)}</b></td><td class='small'>{_e(t.version)}<br><i>{_e(t.version_source)}</i></td>"
        f"<td class='small'>{_e(t.configuration)}</td><td class='small'>{_e(t.trusted_for)}</td>"
        f"<td class='small'>{'<br>'.join('– ' + _e(x) for x in t.limitations)}</td>"
        f"<td class='small'>{'<br>'.join('– ' + _e(x) for x in t.mitigations)}</td></tr>" for t in tools)
    return ("<section class='break' id='tools'><h2>Tools (qualification record)</h2><p class='small'>Each tool with "
            "the exact version that produced this commit's records (or, where no record names it, the installed "
            "version at report time), its configuration, what it is trusted for, its known limitations and how "
            "they are mitigated. Source: report/data/tools.json.</p><table><tr><th>tool</th><th>version</th>"
            "<th>configuration</th><th>trusted for</th><th>limitations</th><th>mitigations</th></tr>"
            f"{rows}</table></section>")


def _history(a: Analysis) -> str:
    out = ["<section id='history'><h2>History of requirements</h2>"]
    if a.catalogue.changes:
        out.append("<table><tr><th>requirement</th><th>version</th><th>date</th><th>old text</th><th>new text</th>"
                   "<th>reason</th></tr>")
        for c in a.catalogue.changes:
            out.append(f"<tr><td><a href='#{_e(c.requirement.split('.')[-1])}'><code>{_e(c.requirement)}</code></a></td>"
                       f"<td>{c.from_version} → {c.to_version}</td><td>{_e(c.date)}</td><td class='small'>"
                       f"{_e(c.old_text)}</td><td class='small'>{_e(c.new_text)}</td><td class='small'>{_e(c.reason)}"
                       "</td></tr>")
        out.append("</table>")
    else:
        out.append("<p>No requirement has changed since its first version (spec/requirements/history.trlc).</p>")
    pending = [f for f in a.history]
    if pending:
        out.append("<p class='fail'>Not accepted:</p><ul>" + "".join(
            f"<li><code>{_e(f.requirement)}</code>: {_e(f.message)}</li>" for f in pending) + "</ul>")
    out.append("</section>")
    return "".join(out)


def _problems(a: Analysis) -> str:
    if a.ok:
        return "<section id='problems'><h2>Gate problems</h2><p class='pass'>None.</p></section>"
    rows = "".join(f"<tr><td><code>{_e(p.requirement or '-')}</code></td><td>{_e(p.check)}</td>"
                   f"<td class='small'>{_e(p.message)}</td></tr>"
                   for p in sorted(a.problems, key=lambda p: (p.requirement == "", p.requirement, p.check)))
    return (f"<section class='break' id='problems'><h2>Gate problems ({len(a.problems)})</h2>"
            "<table><tr><th>requirement</th><th>check</th><th>problem</th></tr>"
            f"{rows}</table></section>")


def _regenerate(a: Analysis) -> str:
    rows = "".join(f"<tr><td>{_e(act.tool)}</td><td><code>{_e(act.make)}</code></td></tr>" for act in ACTIVITIES.values())
    kinds = "".join(f"<tr><td><code>{_e(k)}:</code></td><td>{_e(v)}</td></tr>" for k, v in sorted(KIND_ACTIVITY.items()))
    return f"""<section id='regenerate'><h2>How to regenerate</h2>
<p>Every result here was read from <code>build/evidence/*.json</code>; nothing was rerun for the report. On a
clean checkout of the commit above, <code>make check</code> regenerates every record with the same seeds (so the same
verdicts) and ends with <code>urb report --gate</code>; <code>make report</code> then writes this report again
(<code>build/report/index.html</code> and <code>report.pdf</code>). One item: the command in its row
(<i>rerun</i>). One activity:</p>
<table><tr><th>activity</th><th>command</th></tr>{rows}</table>
<p class='small'>Evidence ids are <code>&lt;kind&gt;:&lt;name&gt;</code>; the kind names the activity:</p>
<table><tr><th>kind</th><th>activity</th></tr>{kinds}<tr><td><code>record:</code></td><td>a whole record: every item
of it must pass</td></tr></table>
<p class='small'>The tracing view of LOBSTER: <a href='lobster/tracing.html'>lobster/tracing.html</a>; its data:
<code>build/report/lobster/report.lobster</code>.</p></section>"""
