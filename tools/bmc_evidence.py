"""Cover points and evidence records of the BMC proofs (tools/proofs.py imports this).

Cover points. A harness marks statements that must be reachable with URB_COVER("name")
(proofs/bmc/include/urb_verify.h). `make reach` (proofs/bmc/Makefile.common) lists the points
compiled into one run ("urb-cover-point: name", from the preprocessed harness) and runs ESBMC with
every property solved on its own (--multi-property): the point is an assertion of false, so ESBMC's
results table says FAILED exactly when some input within the bound gets there. A point counts per
part of the harness (the PART=n value of the sweep item; a harness without parts is one part): it
is reached when some item of that part reaches it, and every part must compile at least one point.
So a harness assumption that rules out a branch, or a part's whole purpose, makes the proof fail
with the point's name, where the vacuity check (the harness's end is reachable) still passes.

Evidence (certification report, issue #36): `bmc_record` turns one run of tools/proofs.py into
items bmc:<folder> (the proof, its vacuity check and worst-case witness), bmc-mutant:<folder>/<name>
and bmc-cover:<folder>/<name>, written with report/urb_report/records.py.
"""

from __future__ import annotations

import gzip
import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Mapping

REACH_CLAIM = "reach: the harness runs to its end on some input"
COVER_PREFIX = "cover: "
COVER_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]*")
# ESBMC's --multi-property results table: "  FAILED       [fn.assertion.1]   line  18  <comment>"
_CLAIM_RE = re.compile(r"^\s+(FAILED|PASSED|UNKNOWN)\s+\[[^\]]*\]\s+line\s+\d+\s+(.*?)\s*$", re.MULTILINE)
_POINT_RE = re.compile(r"^urb-cover-point: (.*?)\s*$", re.MULTILINE)
MUTANT_KINDS = ("off-by-one", "wrong-order", "missing-publish-or-free", "wrong-field", "dropped-error", "other")
# The folders whose cover points make check (make proofs-bmc: tools/proofs.py --covers --covers-deferred)
# does not judge, each with its reason; every other folder's cover runs must be recorded in the cache.
DEFERRED_FILE = "proofs/bmc/covers_deferred.json"


def load_deferred(path: Path) -> dict[str, str]:
    """The deferral file: folder -> why its cover points are not judged in make check (with the measured
    cost of recording them). Raises ValueError naming what is wrong: a folder needs a written reason."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as e:
        raise ValueError(f"{path}: cannot read the cover deferrals ({e}); it is a JSON object "
                         'folder -> {"reason": ..., "cover_cpu_s": ...}') from None
    if not isinstance(data, dict):
        raise ValueError(f"{path}: a JSON object folder -> {{\"reason\": ...}} is expected")
    out: dict[str, str] = {}
    for folder, entry in data.items():
        reason = entry.get("reason") if isinstance(entry, dict) else None
        if not isinstance(reason, str) or len(reason.strip()) < 20:
            raise ValueError(f"{path}: {folder}: give a written \"reason\" (why its cover runs are not recorded, "
                             "what recording them costs), or record them and remove the entry")
        cost = entry.get("cover_cpu_s")
        out[folder] = reason.strip() + (f" (recording them: about {cost} s of CPU)" if cost is not None else "")
    return out


def variant_of(item: str) -> str:
    """A sweep item as Makefile.common names its run ("PART=1,LEN=3" -> "PART1-LEN3")."""
    return item.replace("=", "").replace(",", "-")


def recorded_cover_runs(cache: Path, folder: str, tier: str = "fast") -> set[str]:
    """The sweep items (as variant_of names them; "" without a sweep) of `folder` whose reach run with
    its cover points compiled in (no -DURB_COVER_OFF) is recorded in the result cache."""
    found: set[str] = set()
    for entry in (cache / folder).glob("*.json.gz"):
        with gzip.open(entry, "rt", encoding="utf-8") as fh:
            data = json.load(fh)
        command, label = str(data.get("command", "")), str(data.get("label", ""))
        m = re.fullmatch(rf"{re.escape(tier)} reach(?:-(\S+))? reach", label)
        if m and "-DURB_VERIFY_REACH" in command.split() and "-DURB_COVER_OFF" not in command.split():
            found.add(m.group(1) or "")
    return found


def parse_claims(text: str) -> dict[str, bool]:
    """Each property of a --multi-property run by its description: True when ESBMC refuted it
    (FAILED: reachable, for a cover point or the reach assertion)."""
    out: dict[str, bool] = {}
    for verdict, comment in _CLAIM_RE.findall(text):
        out[comment] = out.get(comment, False) or verdict == "FAILED"
    return out


def parse_cover_points(text: str) -> list[str]:
    """The cover points `make reach` says were compiled into its run, in its order."""
    return _POINT_RE.findall(text)


def part_of(item: str) -> str:
    """The harness part a sweep item runs ("PART=2" of "PART=2,FRAME_LEN=5"); "" without parts."""
    m = re.search(r"(?:^|,)(PART=\w+)", item)
    return m.group(1) if m else ""


@dataclass
class CoverRun:
    """What one reach run of one item says about the cover points."""

    item: str
    outcome: str  # pass | fail | timeout | error (tools/proofs.py Run.outcome)
    points: list[str]
    reached: set[str]
    log: str = ""


@dataclass
class CoverVerdict:
    """One cover point of one proof, over the parts whose items compile it."""

    name: str
    reached_by: dict[str, list[str]] = field(default_factory=dict)  # part -> items reaching it
    missing: dict[str, list[str]] = field(default_factory=dict)  # part -> items that compile it, none reaching

    @property
    def ok(self) -> bool:
        return not self.missing


def judge_covers(runs: Iterable[CoverRun]) -> tuple[list[CoverVerdict], list[str]]:
    """Every cover point against the runs of its parts; and the problems (a point no item of its part
    reaches, a part without a point, a badly named point, a run that ended without a verdict)."""
    by_part: dict[str, list[CoverRun]] = {}
    for r in runs:
        by_part.setdefault(part_of(r.item), []).append(r)
    verdicts: dict[str, CoverVerdict] = {}
    problems: list[str] = []
    for part, part_runs in sorted(by_part.items()):
        where = part or "the harness"
        compiled = {p for r in part_runs for p in r.points}
        if not compiled:
            problems.append(f"{where}: no cover point (URB_COVER) in any of its items: add one per part and per "
                            "branch that matters (proofs/README.md, Cover points)")
        for name in sorted(compiled):
            if not COVER_NAME.fullmatch(name):
                problems.append(f"cover point {name!r}: use letters, digits and - _ . only (it is an evidence id)")
            v = verdicts.setdefault(name, CoverVerdict(name))
            compiling = [r for r in part_runs if name in r.points]
            reaching = [r.item or "run" for r in compiling if name in r.reached]
            if reaching:
                v.reached_by[part] = reaching
            else:
                v.missing[part] = [r.item or "run" for r in compiling]
                unfinished = [r for r in compiling if r.outcome not in ("pass", "fail")]
                note = (f"; {len(unfinished)} of its runs gave no verdict ({unfinished[0].outcome}, log {unfinished[0].log})"
                        if unfinished else "")
                problems.append(f"cover point {name} NOT REACHED in {where} (items {', '.join(v.missing[part])}){note}")
    return sorted(verdicts.values(), key=lambda v: v.name), problems


def mutant_kind_problem(mutant: Mapping[str, Any]) -> str:
    """What is wrong with a seeded bug's "kind" (the mutation table's class of bug), "" when nothing."""
    kind = mutant.get("kind")
    if kind not in MUTANT_KINDS:
        return (f"mutant {mutant.get('name')!r} needs \"kind\": one of {', '.join(MUTANT_KINDS)} (got {kind!r}); "
                "see proofs/README.md, Mutants")
    return ""


# =============================================================================== evidence


def _verdict(ok: bool, result: str) -> str:
    if ok:
        return "pass"
    return "error" if result in ("TIMEOUT", "ERROR") else "fail"


@dataclass
class ProofEvidence:
    """What tools/proofs.py learnt about one proof folder in one run, for its evidence items."""

    folder: str
    tier: str
    purpose: str
    properties: str
    bound: str
    settings: dict[str, str]
    proof_row: dict[str, Any]
    reach_row: dict[str, Any] | None
    tight_row: dict[str, Any] | None
    mutant_rows: dict[str, dict[str, Any]]
    mutants: list[dict[str, Any]]
    covers: list[CoverVerdict]
    cost: int | None
    budget: int | None
    #: COST_CHECK = separate (proofs/bmc/Makefile.common): the [cost probe] row, the probes at COST
    cost_row: dict[str, Any] | None = None


def proof_items(e: ProofEvidence) -> list[dict[str, Any]]:
    """The evidence items of one proof: bmc:, bmc-mutant:, bmc-cover: (as keyword dicts of records.Item)."""
    source = f"proofs/bmc/{e.folder}/harness.c"
    rerun = f"python3 tools/proofs.py --tier {e.tier} --only {e.folder}"
    parts = [e.proof_row] + [r for r in (e.reach_row, e.cost_row, e.tight_row) if r is not None]
    ok = all(bool(r["expected"]) for r in parts)
    measured = "; ".join(f"{r['function'].removeprefix(e.folder).strip() or 'proof'}: {r['result']}" for r in parts)
    worst = {"worst_case_cycles": e.cost, "budget_cycles": e.budget,
             "share_of_budget": round(e.cost / e.budget, 3) if e.cost is not None and e.budget else None}
    items: list[dict[str, Any]] = [{
        "id": f"bmc:{e.folder}", "kind": "proof", "verdict": _verdict(ok, str(e.proof_row["result"])),
        "expected": "proved on every run of the tier; the harness's end reachable"
                    + ("; no entry above the recorded worst case (COST probes)" if e.cost_row is not None else "")
                    + ("; the recorded worst case reached" if e.tight_row is not None else ""),
        "measured": measured, "source": source, "rerun": rerun,
        "data": {"tier": e.tier, "purpose": e.purpose, "properties": e.properties, "bound": e.bound,
                 "result": e.proof_row["result"], "detail": e.proof_row["detail"],
                 "reach": e.reach_row["result"] if e.reach_row else None,
                 "worst_case_witness": e.tight_row["result"] if e.tight_row else None,
                 "worst_case_probe": e.cost_row["result"] if e.cost_row else None,
                 **worst, "time_s": e.proof_row["time_s"], "cpu_s": e.proof_row.get("cpu_s"),
                 "runs_replayed_from_cache": sum(int(r.get("replayed", 0)) for r in parts),
                 "runs": sum(int(r.get("runs", 0)) for r in parts), **e.settings}}]
    for m in e.mutants:
        name = str(m["name"])
        row = e.mutant_rows.get(name)
        if row is None:
            continue  # a full-tier seeded bug in a fast run
        items.append({
            "id": f"bmc-mutant:{e.folder}/{name}", "kind": "mutant",
            "verdict": _verdict(bool(row["expected"]), str(row["result"])),
            "expected": "killed on " + " or ".join(f'"{x}"' for x in ([m["expect"]] if isinstance(m["expect"], str)
                                                                  else m["expect"])),
            "measured": f"{row['result']}: {row['detail']}", "source": f"proofs/bmc/{e.folder}/mutants.json",
            "rerun": f"make -C proofs/bmc/{e.folder} mutant MUTANT={name} TIER={e.tier}",
            "data": {"kind": m.get("kind"), "why": m.get("why"), "file": m.get("file"), "function": m.get("function"),
                     "expect": m["expect"], "result": row["result"], "time_s": row["time_s"], "tier": e.tier,
                     "runs_replayed_from_cache": row.get("replayed", 0), "runs": row.get("runs", 0)}})
    for v in e.covers:
        items.append({
            "id": f"bmc-cover:{e.folder}/{v.name}", "kind": "cover", "verdict": "pass" if v.ok else "fail",
            "expected": "reached by some run of every part that compiles it",
            "measured": ("reached" if v.ok else "NOT REACHED in " + ", ".join(p or "the harness" for p in v.missing)),
            "source": source, "rerun": f"make -C proofs/bmc/{e.folder} reach TIER={e.tier}",
            "data": {"reached_by": v.reached_by, "not_reached_in": v.missing, "tier": e.tier}})
    return items
