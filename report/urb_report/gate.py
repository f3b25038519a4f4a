"""The gate: every reason why the evidence does not support the requirements on this tree.

It reads the requirements (TRLC), the records of build/evidence/, the source markers and the
baseline, and fails (one Problem per reason, each naming its requirement where there is one) on:
  evidence   a cited item that did not pass: failed, gave no result, stale (another commit or
             other uncommitted changes), or missing (no record of its activity, or no such item)
  marker     a cited test, cmocka test, TLA+ property, fuzz target or BMC harness without the
             `lobster-trace` marker naming the requirement; a marker naming an unknown
             requirement; a marker saying an item verifies a requirement that does not cite it;
             an implementation marker that belongs to no function, or names a requirement twice
             for one function
  trace      LOBSTER's tracing policy (lobster-ci-report): a requirement without verification,
             code or evidence tracing to an unknown requirement
  record     a stale record, or a failed item in any record
  review     an uncovered line or decision without justification (coverage record), a MISRA
             finding without deviation (misra record), a static-analysis finding without a
             reason (static record): their items' verdicts say so
  history    a statement or criterion changed without a version step and a history entry
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from . import history, lobster
from .evidence import ACTIVITIES, EvidenceIndex, Resolution
from .markers import Marker
from .records import ROOT, Record
from .requirements import Catalogue

# Cited evidence of these kinds must carry a marker naming the requirement in its source.
MARKED_KINDS = ("pytest", "cmocka", "tla", "fuzz", "bmc")
REVIEW_ACTIVITIES = {"coverage": "an uncovered line or decision without a justification",
                     "misra": "a MISRA C:2012 finding without a deviation record",
                     "static": "a static-analysis finding without a written reason"}


@dataclass(frozen=True)
class Problem:
    requirement: str      # "urb.X", or "" when no requirement is concerned
    check: str            # evidence | marker | trace | record | review | history | requirements
    message: str

    def line(self) -> str:
        who = self.requirement or "(no requirement)"
        return f"{who} [{self.check}] {self.message}"


@dataclass
class Analysis:
    catalogue: Catalogue
    index: EvidenceIndex
    markers: Sequence[Marker]
    resolutions: dict[str, Resolution] = field(default_factory=dict)
    problems: list[Problem] = field(default_factory=list)
    lobster: lobster.LobsterResult | None = None
    history: list[history.Finding] = field(default_factory=list)
    cited_by: dict[str, list[str]] = field(default_factory=dict)   # evidence id -> requirement tags

    @property
    def ok(self) -> bool:
        return not self.problems

    def requirement_status(self, tag: str) -> str:
        """pass | fail: every cited item passed, the markers and the history are in order."""
        return "fail" if any(p.requirement == tag for p in self.problems) else "pass"


def analyse(cat: Catalogue, records: Sequence[Record], state: Mapping[str, Any], markers: Sequence[Marker],
            baseline: dict[str, dict[str, object]], lobster_dir: Path | None, *, group_sources: Mapping[str, str],
            html: bool = True) -> Analysis:
    """Everything the report shows and the gate judges. `lobster_dir` None skips LOBSTER (tests of
    the other checks); `group_sources` maps cmocka group names to their test files."""
    a = Analysis(cat, EvidenceIndex(records, state), markers)
    tags = {r.tag for r in cat.requirements}
    for req in cat.requirements:
        for e in req.verified_by:
            a.cited_by.setdefault(e, []).append(req.tag)
    marker_ids = {m.evidence for m in markers if m.is_activity}
    for e in sorted(set(a.cited_by) | marker_ids):
        a.resolutions[e] = a.index.resolve(e)
    _evidence(a)
    _markers(a, tags, group_sources)
    _records(a)
    _review(a)
    a.history = history.check(cat, baseline)
    a.problems += [Problem(f.requirement, "history", f.message) for f in a.history]
    if lobster_dir is not None:
        code = lobster.code_items(markers)
        ev = lobster.evidence_items(a.cited_by, a.resolutions, markers)
        a.lobster = lobster.run(lobster_dir, code, ev, html=html)
        if not a.lobster.ok:
            for msg in a.lobster.messages:
                a.problems.append(Problem(_tag_of(msg, cat), "trace", f"LOBSTER: {msg}"))
    return a


def _evidence(a: Analysis) -> None:
    for req in a.catalogue.requirements:
        for e in req.verified_by:
            r = a.resolutions[e]
            if r.status != "pass":
                a.problems.append(Problem(req.tag, "evidence", f"{e}: {r.status}: {r.detail}"))


def _marked(markers: Sequence[Marker], evidence: str, tag: str) -> bool:
    for m in markers:
        if tag in m.requirements and m.evidence and (m.evidence == evidence or evidence.startswith(m.evidence + "[")):
            return True
    return False


def where_to_mark(evidence: str, group_sources: Mapping[str, str]) -> str:
    """Where the marker for `evidence` goes, in words."""
    kind, _, name = evidence.partition(":")
    if kind == "pytest":
        file, _, test = name.partition("::")
        return f"a `# lobster-trace:` comment above {test.split('[')[0]} in {file}"
    if kind == "cmocka":
        group, _, test = name.partition("/")
        return f"a `/* lobster-trace: */` comment above {test} in {group_sources.get(group, 'its cmocka test file')}"
    if kind == "tla":
        module, _, op = name.partition(".")
        return f"a `\\* lobster-trace:` comment above {op} in spec/tla/{module}.tla"
    if kind == "fuzz":
        return f"a `/* lobster-trace: */` comment in tests/fuzz/{name}.c"
    if kind == "bmc":
        return f"a `/* lobster-trace: */` comment in proofs/bmc/{name}/harness.c"
    return "its source"


def _markers(a: Analysis, tags: set[str], group_sources: Mapping[str, str]) -> None:
    for m in a.markers:
        for tag in m.requirements:
            if tag not in tags:
                a.problems.append(Problem(tag, "marker", f"{m.file}:{m.line} cites {tag}, which is no requirement "
                                                         f"(spec/requirements/*.trlc)"))
            elif m.is_activity and not any(e == m.evidence or e.startswith(m.evidence + "[")
                                           for e in a.catalogue.by_tag()[tag].verified_by):
                a.problems.append(Problem(tag, "marker", f"{m.file}:{m.line} marks {m.evidence} as verifying {tag}, "
                                                         f"which does not cite it: add it to {tag}'s verified_by or "
                                                         f"remove the marker"))
    seen: set[tuple[str, str, str]] = set()
    for m in a.markers:
        if m.is_activity:
            continue
        if not m.item:
            a.problems.append(Problem(m.requirements[0], "marker", f"{m.file}:{m.line}: an implementation marker "
                                                                   "that belongs to no function: put it directly above "
                                                                   "the function that implements the requirement"))
        for tag in m.requirements:
            if (m.file, m.item, tag) in seen:
                a.problems.append(Problem(tag, "marker", f"{m.file}:{m.line}: {m.item or m.file} names {tag} twice: "
                                                         "one marker per function"))
            seen.add((m.file, m.item, tag))
    generated = _generated_bmc()
    for req in a.catalogue.requirements:
        for e in req.verified_by:
            if needs_marker(e, generated) and not _marked(a.markers, e, req.tag):
                a.problems.append(Problem(req.tag, "marker", f"{e} carries no `lobster-trace: {req.tag}` marker: "
                                                             f"put {where_to_mark(e, group_sources)}"))


def _records(a: Analysis) -> None:
    for name, why in sorted(a.index.stale.items()):
        rec = next(r for r in a.index.records if r.name == name)
        cited = sorted({t for i in rec.items for t in a.cited_by.get(i.id, [])})
        who = f" (cited by {', '.join(cited[:6])}{' ...' if len(cited) > 6 else ''})" if cited else ""
        how = ACTIVITIES[rec.activity].make if rec.activity in ACTIVITIES else f"the {rec.activity} activity"
        a.problems.append(Problem("", "record", f"build/evidence/{name}.json is stale: {why}{who}; rerun "
                                                f"{how} on this tree (or make check)"))
    for rec in a.index.records:
        if rec.activity in REVIEW_ACTIVITIES:
            continue
        for item in rec.items:
            if item.verdict == "fail" and item.id not in a.cited_by and not any(
                    item.id.startswith(e + "[") for e in a.cited_by):
                a.problems.append(Problem("", "record", f"{item.id} failed in build/evidence/{rec.name}.json: "
                                                        f"{item.measured} (expected: {item.expected})"))


def _review(a: Analysis) -> None:
    for rec in a.index.records:
        what = REVIEW_ACTIVITIES.get(rec.activity)
        if what is None:
            continue
        cited = a.cited_by.get(f"record:{rec.activity}", []) + a.cited_by.get(f"record:{rec.name}", [])
        for item in rec.items:
            if item.verdict != "pass":
                for tag in cited or [""]:
                    a.problems.append(Problem(tag, "review", f"{item.id}: {what}: {item.measured or item.verdict}"))


def _tag_of(message: str, cat: Catalogue) -> str:
    """The requirement a LOBSTER message is about: named in it, or defined at its file:line."""
    tags = {r.tag for r in cat.requirements}
    for word in message.replace(",", " ").replace("@", " ").split():
        if word in tags:
            return word
    loc = message.split(": ", 1)[0].split(":")
    if len(loc) >= 2 and loc[1].isdigit():
        for r in cat.requirements:
            if message.startswith(r.file) and r.line == int(loc[1]):
                return r.tag
    return ""


def _generated_bmc() -> set[str]:
    path = ROOT / "proofs" / "bmc" / "GENERATED"
    if not path.is_file():
        return set()
    return {ln.strip() for ln in path.read_text().splitlines() if ln.strip() and not ln.startswith("#")}


def needs_marker(evidence: str, generated_bmc: set[str]) -> bool:
    """Whether a cited item must carry a marker: tests, cmocka tests, TLA+ properties, fuzz targets and
    hand-written BMC harnesses do; generated BMC folders (proofs/bmc/GENERATED, rewritten from the
    schema) cannot, and mutants, WP and Eva units, records and simulation criteria are linked
    through the requirement alone."""
    kind, _, name = evidence.partition(":")
    if kind == "bmc":
        return name not in generated_bmc
    return kind in MARKED_KINDS


def print_problems(a: Analysis, limit: int = 400) -> None:
    """The gate's verdict on standard output: one line per problem, grouped by requirement."""
    probs = sorted(a.problems, key=lambda p: (p.requirement == "", p.requirement, p.check))
    for p in probs[:limit]:
        print(f"GATE FAIL {p.line()}")
    if len(probs) > limit:
        print(f"GATE FAIL ... and {len(probs) - limit} more (build/report/index.html lists them all)")
    failing = sorted({p.requirement for p in probs if p.requirement})
    n = len(a.catalogue.requirements)
    if probs:
        print(f"report gate: FAILED: {len(probs)} problems; {len(failing)} of {n} requirements affected: "
              f"{', '.join(failing[:12])}{' ...' if len(failing) > 12 else ''}")
    else:
        print(f"report gate: passed: {n} requirements, every cited item passed on this tree")
