"""What each evidence id a requirement cites resolves to in the records of build/evidence/.

An id is "<kind>:<name>"; its kind names the activity whose record holds it (ACTIVITIES). The id
resolves to the items with exactly that id, and for pytest also to its parametrised cases
(`pytest:f.py::test_x` covers `pytest:f.py::test_x[gcc]` and `[clang]`). `record:<name>` cites a
whole record: it passes when that record exists, is fresh and every item in it passes.

A cited id has exactly one status:
  pass     every matching item passed, in a record produced from this tree
  fail     some matching item has the verdict "fail"
  error    some matching item gave no result (verdict "error": crashed, timed out, skipped)
  stale    a matching record was produced from another commit or other uncommitted changes
  missing  no record of its activity, or the record has no such item
"""

from __future__ import annotations

import difflib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from .records import Item, Record


@dataclass(frozen=True)
class Activity:
    name: str        # the record's activity field
    tool: str        # what a reviewer calls it
    make: str        # the make target that writes the record


ACTIVITIES: dict[str, Activity] = {a.name: a for a in (
    Activity("tlc", "TLC model checking", "make modelcheck"),
    Activity("tlc-mutation", "TLA+ generated mutants (TLC)", "python3 tools/tla_mutate.py"),
    Activity("bmc", "ESBMC bounded model checking", "make proofs-bmc"),
    Activity("framac", "Frama-C WP and Eva", "make proofs-framac"),
    Activity("fuzz", "libFuzzer", "make fuzz"),
    Activity("mutation", "C mutation score (cmocka against generated mutants)", "make proofs-mutation"),
    Activity("pytest", "pytest", "make test-py (and make test-c)"),
    Activity("cmocka", "cmocka", "make test-firmware-node test-firmware-bridge"),
    Activity("sim", "simulation acceptance criteria",
             "make test-sim-san (urb sim sensorhex --quick; make sim-report for the full run)"),
    Activity("coverage", "structural coverage (gcovr, llvm-cov MC/DC)", "make coverage"),
    Activity("misra", "MISRA C:2012 (cppcheck)", "make misra"),
    Activity("static", "static analysis (clang-tidy, gcc -fanalyzer)", "make static"),
    Activity("size", "flash and RAM budgets", "make size-node"),
)}

KIND_ACTIVITY: dict[str, str] = {
    "tla": "tlc", "tlc": "tlc", "tlc-mutant": "tlc", "tlc-reach": "tlc", "tlc-distributed": "tlc",
    "tlc-mutation": "tlc-mutation",
    "bmc": "bmc", "bmc-mutant": "bmc", "bmc-cover": "bmc",
    "wp": "framac", "eva": "framac", "framac-mutant": "framac",
    "fuzz": "fuzz", "fuzz-mutant": "fuzz",
    "mutation": "mutation", "c-mutant": "mutation",
    "pytest": "pytest", "cmocka": "cmocka", "sim": "sim",
    "coverage": "coverage", "coverage-justification": "coverage",
    "misra": "misra", "misra-deviation": "misra",
    "static": "static", "static-deviation": "static", "size": "size",
}


def activity_of(kind: str) -> str | None:
    """The activity whose record holds items of `kind`; `sim@<profile>` (a simulation criterion under
    another hardware profile than the default) is the simulation's."""
    if kind.startswith("sim@"):
        return "sim"
    return KIND_ACTIVITY.get(kind)


STATUSES = ("pass", "fail", "error", "stale", "missing")


@dataclass(frozen=True)
class Resolution:
    evidence: str
    status: str
    detail: str
    hits: tuple[tuple[Record, Item], ...] = ()
    records: tuple[Record, ...] = ()

    @property
    def activity(self) -> str:
        kind = self.evidence.split(":", 1)[0]
        if kind == "record":
            return self.evidence.split(":", 1)[1]
        return activity_of(kind) or kind


@dataclass
class EvidenceIndex:
    """The records of one report run, indexed by item id."""

    records: Sequence[Record]
    state: Mapping[str, Any]          # records.tree_state() of the tree the report is about
    by_id: dict[str, list[tuple[Record, Item]]] = field(default_factory=dict)
    by_activity: dict[str, list[Record]] = field(default_factory=dict)
    stale: dict[str, str] = field(default_factory=dict)   # record name -> why it is stale

    def __post_init__(self) -> None:
        from .records import is_stale

        for rec in self.records:
            self.by_activity.setdefault(rec.activity, []).append(rec)
            why = is_stale(rec, self.state)
            if why:
                self.stale[rec.name] = why
            for item in rec.items:
                self.by_id.setdefault(item.id, []).append((rec, item))

    def resolve(self, evidence: str) -> Resolution:
        kind, _, name = evidence.partition(":")
        if kind == "record":
            return self._resolve_record(evidence, name)
        activity = activity_of(kind)
        if activity is None:
            return Resolution(evidence, "missing", f"unknown kind of evidence {kind!r} (known: "
                              f"{', '.join(sorted(KIND_ACTIVITY))}, sim@<profile>, record)")
        # an id is found in whichever record holds it; its activity only says where to look when none does
        hits = list(self.by_id.get(evidence, []))
        if kind == "pytest":
            prefix = evidence + "["
            hits += [h for key, hs in self.by_id.items() if key.startswith(prefix) for h in hs]
        recs = self.by_activity.get(activity, [])
        if not hits and not recs:
            return Resolution(evidence, "missing", _no_record(activity))
        if not hits:
            known = [i.id for r in recs for i in r.items]
            near = difflib.get_close_matches(evidence, known, n=2, cutoff=0.75)
            hint = f"; the nearest ids there: {', '.join(near)}" if near else ""
            where = ", ".join(f"build/evidence/{r.name}.json" for r in recs)
            how = f"; {ACTIVITIES[activity].make} writes it" if activity in ACTIVITIES else ""
            return Resolution(evidence, "missing", f"no item with this id in the {activity} record ({where}): "
                              f"renamed, deleted or not run{hint}{how}", records=tuple(recs))
        return self._judge(evidence, hits)

    def _resolve_record(self, evidence: str, name: str) -> Resolution:
        recs = [r for r in self.records if r.name == name or r.activity == name]
        if not recs:
            return Resolution(evidence, "missing", _no_record(name))
        hits = [(r, i) for r in recs for i in r.items]
        if not hits:
            return Resolution(evidence, "missing", f"the {name} record has no items", records=tuple(recs))
        return self._judge(evidence, hits)

    def _judge(self, evidence: str, hits: list[tuple[Record, Item]]) -> Resolution:
        recs = tuple({r.name: r for r, _ in hits}.values())
        stale = [f"{r.name}.json: {self.stale[r.name]}" for r in recs if r.name in self.stale]
        if stale:
            how = "; ".join(sorted({ACTIVITIES[r.activity].make for r in recs if r.activity in ACTIVITIES}))
            return Resolution(evidence, "stale", "; ".join(stale) + f" (rerun {how or 'it'} on this tree)", tuple(hits),
                              recs)
        for verdict in ("fail", "error"):
            bad = [i for _, i in hits if i.verdict == verdict]
            if bad:
                what = "; ".join(f"{i.id}: {i.measured or verdict} (expected: {i.expected or 'pass'})" for i in bad[:3])
                more = f" and {len(bad) - 3} more" if len(bad) > 3 else ""
                return Resolution(evidence, verdict, what + more, tuple(hits), recs)
        n = len(hits)
        detail = hits[0][1].measured if n == 1 else f"{n} items passed"
        return Resolution(evidence, "pass", detail, tuple(hits), recs)


def _no_record(activity: str) -> str:
    a = ACTIVITIES.get(activity)
    how = f"; {a.make} writes it" if a else ""
    return f"no record for activity {activity} (build/evidence/{activity}*.json){how}"
