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


def _profile_of(key: str) -> str:
    from .runner import split_key

    return split_key(key)[1]


def _latency_summary(res: Result) -> str:
    """A latency experiment's table in one line: the round trip's mean and max over its payloads."""
    rows = [r for r in res.table if isinstance(r.get("mean_ms"), (int, float))]
    if not rows:
        return ""
    means = [float(r["mean_ms"]) for r in rows if r["mean_ms"] == r["mean_ms"]]
    maxes = [float(r["max_ms"]) for r in rows if r["max_ms"] == r["max_ms"]]
    fits = [r for r in rows if r.get("fits_line", True)]
    worst = max((float(r["max_ms"]) for r in fits), default=float("nan"))
    return (f"payloads {rows[0]['payload']}-{rows[-1]['payload']} B: mean {min(means):.3f}-{max(means):.3f} ms, "
            f"max {max(maxes):.3f} ms" + (f" ({worst:.3f} ms over the payloads that fit the line)"
                                          if len(fits) < len(rows) else ""))


def _profiles_html(results: Sequence[Result]) -> str:
    """For each hardware profile that ran: its Table I and latency figures beside its assumptions."""
    from . import profiles as prof_mod
    from .runner import split_key

    by_profile: dict[str, dict[str, Result]] = {}  # every profile a result ran under, with its comparison results
    for r in results:
        name, profile = split_key(r.key)
        if name in prof_mod.PROFILE_EXPERIMENTS:
            by_profile.setdefault(profile, {})[name] = r
        else:
            by_profile.setdefault(profile, {})
    if not by_profile:
        return ""
    order = [n for n in prof_mod.names() if n in by_profile] + sorted(set(by_profile) - set(prof_mod.names()))
    parts = ["<section id='profiles'><h2>Hardware profiles: Table I and the latency figures per profile</h2>",
             "<p>Every figure of the simulation is a property of URB <i>and</i> of the model's inputs. Each profile "
             "(<code>sim/profiles/*.toml</code>) states its inputs with their sources; the same experiments ran "
             "under each. The default profile (<code>" + html.escape(prof_mod.DEFAULT) + "</code>) produced every "
             "other figure of this report.</p>"]
    summary = []
    for name in order:
        t1 = by_profile[name].get("table1")
        row: dict[str, object] = {"profile": name}
        if t1 is not None:
            for t1_row in t1.table[:3]:
                label = str(t1_row["metric"]).split(" (")[0].replace("initial ", "").replace(" in t_acq_end", "")
                row[label] = (f"{t1_row['sim average']} / {t1_row['sim max of runs']} / "
                              f"{t1_row['sim worst single cycle']}")
        for key in ("fig15", "fig16"):
            if key in by_profile[name]:
                row[key] = _latency_summary(by_profile[name][key])
        row["verdicts"] = ", ".join(f"{k} {r.verdict}" for k, r in by_profile[name].items())
        summary.append(row)
    parts.append("<p><b>Table I per profile</b> (average / max of runs / worst single cycle; the paper: convergence "
                 "78.4 / 88.4 ms, inter-node difference 0.19 / 0.56 us, jitter 0.92 / 1.33 us, average / Max) and "
                 "the latency figures (the paper: Fig. 15 at most 2 ms, Fig. 16 a constant 3 ms)</p>")
    parts.append(_table(summary))
    for name in order:
        try:
            prof = prof_mod.load(name)
        except prof_mod.ProfileError as exc:
            parts.append(f"<div class='note'>{html.escape(str(exc))}</div>")
            continue
        parts.append(f"<h3 id='profile-{html.escape(name)}'>{html.escape(name)}: {html.escape(prof.title)}</h3>"
                     f"<p>{html.escape(prof.about)}</p>")
        for key in prof_mod.PROFILE_EXPERIMENTS:
            found = by_profile[name].get(key)
            if found is None:
                continue
            for d in found.deviations:
                parts.append(f"<div class='note'><b>Does not reproduce the paper:</b> {html.escape(d)}</div>")
        t1 = by_profile[name].get("table1")
        if t1 is not None:
            parts.append(_table(t1.table[:3]))
        parts.append("<p class='small'><b>Model assumptions of this profile</b> (every other parameter: its "
                     "default, see Model parameters)</p>")
        parts.append(_table([{"parameter": a.param, "value": f"{a.value:g}", "source": a.source
                              + (f" [from {a.from_code}]" if a.from_code else ""), "affects": ", ".join(a.affects)}
                             for a in prof.assumptions]))
        if prof.targets:
            parts.append(_table([{"Table I figure": f"{t.metric} {t.statistic}", "paper": t.paper,
                                  "tolerance": t.tolerance, "checked": "yes" if t.required else "no (reported)",
                                  "why not checked": t.why} for t in prof.targets]))
    parts.append("</section>")
    return "\n".join(parts)


def _sensitivity_html(out: Path, results: Sequence[Result]) -> str:
    """The sensitivity study's plots, its conclusions and every point's figures."""
    from . import profiles as prof_mod
    from . import sensitivity
    from .runner import split_key

    points = [r for r in results if split_key(r.key)[0].startswith("sens:")]
    if not points:
        return ""
    profile = split_key(points[0].key)[1]
    title = prof_mod.load(profile).title
    files, rows, notes = sensitivity.summarize(points, out / "sensitivity", title)
    parts = ["<section id='sensitivity'><h2>Sensitivity: what other hardware gives</h2>",
             f"<p>Each factor varied alone from the <code>{html.escape(profile)}</code> profile ({html.escape(title)}); "
             "per value: Table I (synchronised runs of the table1 rig), Figs. 15-16 at a 6-byte payload, and the PD "
             "loop over USB with fixed gains (<code>urb_sim/sensitivity.py</code>). Dotted and dash-dot lines: the "
             "paper's Average and Max.</p><ul>"]
    parts += [f"<li>{html.escape(n)}</li>" for n in notes]
    parts.append("</ul>")
    for f in files:
        if f.suffix == ".png":
            parts.append(f"<p><img src='{html.escape(f.relative_to(out).as_posix())}' alt='sensitivity'></p>")
    parts.append(_table(rows))
    links = ", ".join(f"<a href='{html.escape(f.relative_to(out).as_posix())}'>{html.escape(f.name)}</a>"
                      for f in files if f.suffix == ".csv")
    parts.append(f"<p class='small'>Data: {links}</p></section>")
    return "\n".join(parts)


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
        if r.key.startswith("sens:"):
            continue  # a sensitivity point's figures are in its section
        for c in r.checks:
            parts.append(f"<tr><td><a href='#{r.key}'>{html.escape(r.key)}</a></td><td>{html.escape(c.name)}</td>"
                         f"<td>{html.escape(c.required)}</td><td>{html.escape(c.measured)}</td>{_badge(c.passed)}</tr>")
    parts.append("</table>")
    parts.append(_profiles_html(results))
    parts.append(_sensitivity_html(out, results))
    for r in results:
        if r.key.startswith("sens:"):
            continue  # in the sensitivity section
        profile = _profile_of(r.key)  # every figure says which hardware profile produced it
        parts.append(f"<section id='{r.key}'><h2>{html.escape(r.title)} <span class='small'>(hardware profile "
                     f"<a href='#profile-{html.escape(profile)}'>{html.escape(profile)}</a>)</span></h2>")
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
    parts.append("<section id='params'><h2>Model parameters</h2><p class='small'>Values of the default "
                 "profile's runs (the profile's assumptions over the parameters' defaults; experiments may override "
                 "some for their rig, each experiment's text says which).</p>")
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
