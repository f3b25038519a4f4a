#!/usr/bin/env python3
"""Run TLC on every URB TLA+ model and must-fail mutant listed in spec/tla/manifest.json.

Good models must pass with exactly the recorded number of distinct states and reach every
reachability witness the manifest lists for them (checked in the same run: tools/tla_witness.py);
each mutant must be refuted by TLC with exactly the expected invariant or temporal property, or by
a false ASSUME (a mutant of an operator that an MC module checks against its definition); the
distributed entries run a model with TLCServer and TLCWorkers on loopback and must find its
recorded count (tools/tla_distributed.py). Results go to build/tla/junit.xml (JUnit),
build/tla/results.json, build/tla/logs/ and the evidence record build/evidence/tlc.json
(tools/tla_evidence.py).

    python3 tools/modelcheck.py               # all default models and mutants
    python3 tools/modelcheck.py --update      # re-record state counts, depths, runtimes
    python3 tools/modelcheck.py --only Bridge # entries whose name contains "Bridge"
    python3 tools/modelcheck.py --exact MCBridge
    python3 tools/modelcheck.py --optional    # also the opt-in large configurations
    python3 tools/modelcheck.py --optional --only Large --distributed --local-workers 2

Exit status: 0 all as expected, 1 some result differs from the manifest, 2 setup problem.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "sim"))
sys.path.insert(0, str(ROOT))

from urb_sim.tlc import JVM_MODEL, JVM_QUICK, TlcSetupError, class_archive, find_jar, find_java, state_counts  # noqa: E402
from tools import tla_distributed, tla_evidence, tla_witness  # noqa: E402

SPEC_DIR = ROOT / "spec" / "tla"
MANIFEST = SPEC_DIR / "manifest.json"
OUT_DIR = ROOT / "build" / "tla"
EVIDENCE_DIR = ROOT / "build" / "evidence"

Outcome = Literal["pass", "invariant", "property", "assumption", "deadlock", "error"]

#: What a mutant expects when it must make an ASSUME of the specification false (TLC names no
#: operator for a false assumption, only its place).
ASSUMPTION = "ASSUME"


#: The environment cannot run TLC (no Java, no jar) or the manifest is bad.
SetupError = TlcSetupError


# --------------------------------------------------------------------------- TLC output parsing


@dataclass
class TlcResult:
    """What one TLC run reported, parsed from its output."""

    outcome: Outcome
    violated: str | None = None  # invariant / property name when TLC names it; ASSUMPTION for an ASSUME
    distinct_states: int | None = None
    generated_states: int | None = None
    depth: int | None = None
    message: str = ""


_DEPTH_RE = re.compile(r"The depth of the complete state graph search is (\d+)\.")
_INVARIANT_RE = re.compile(r"^Error: Invariant (\w+) is violated", re.MULTILINE)
_ACTION_PROP_RE = re.compile(r"^Error: Action property (\w+) (?:of (?:the )?\S+ )?is violated", re.MULTILINE)
_ASSUMPTION_RE = re.compile(r"^Error: Assumption (line \d+, col \d+ to line \d+, col \d+ of module \w+) is false",
                            re.MULTILINE)
_TEMPORAL_RE = re.compile(r"^Error: Temporal properties were violated", re.MULTILINE)
_DEADLOCK_RE = re.compile(r"^Error: Deadlock reached", re.MULTILINE)
_SUCCESS_RE = re.compile(r"Model checking completed\. No error has been found\.")
_ERROR_RE = re.compile(r"^Error: (.*)$", re.MULTILINE)
_EXCEPTION_RE = re.compile(r"^: (Attempted to [^\n]*(?:\n[^\n:]+)?)", re.MULTILINE)


def config_properties(cfg_text: str) -> list[str]:
    """Names listed after PROPERTY/PROPERTIES in a TLC .cfg file."""
    names: list[str] = []
    current: str | None = None
    for raw in cfg_text.splitlines():
        line = raw.split("\\*", 1)[0].strip()
        if not line:
            continue
        words = line.split()
        if words[0] in {
            "SPECIFICATION", "INIT", "NEXT", "INVARIANT", "INVARIANTS", "PROPERTY",
            "PROPERTIES", "CONSTANT", "CONSTANTS", "SYMMETRY", "VIEW", "CONSTRAINT",
            "CONSTRAINTS", "ACTION_CONSTRAINT", "ACTION_CONSTRAINTS", "CHECK_DEADLOCK",
        }:
            current = words[0]
            words = words[1:]
        if current in {"PROPERTY", "PROPERTIES"}:
            names.extend(words)
    return names


def parse_tlc_output(text: str, exit_code: int, cfg_text: str = "",
                     action_properties: frozenset[str] = frozenset()) -> TlcResult:
    """Classify a TLC run.  TLC names a violated invariant or action property but not a
    violated temporal property; for the latter the name is taken from the .cfg when it lists
    exactly one property that is not an action property (`action_properties`)."""
    res = TlcResult(outcome="error")
    counts = state_counts(text)
    if counts is not None:
        res.generated_states, res.distinct_states = counts
    depth = _DEPTH_RE.findall(text)
    if depth:
        res.depth = int(depth[-1])
    if m := _ASSUMPTION_RE.search(text):
        res.outcome, res.violated, res.message = "assumption", ASSUMPTION, f"false assumption at {m.group(1)}"
    elif m := _INVARIANT_RE.search(text):
        res.outcome, res.violated = "invariant", m.group(1)
    elif m := _ACTION_PROP_RE.search(text):
        res.outcome, res.violated = "property", m.group(1)
    elif _TEMPORAL_RE.search(text):
        props = [p for p in config_properties(cfg_text) if p not in action_properties]
        res.outcome = "property"
        res.violated = props[0] if len(props) == 1 else None
        if res.violated is None:
            res.message = "temporal violation; TLC does not say which of: " + ", ".join(props)
    elif _DEADLOCK_RE.search(text):
        res.outcome = "deadlock"
    elif _SUCCESS_RE.search(text) and exit_code == 0:
        res.outcome = "pass"
    else:
        errors = _ERROR_RE.findall(text)
        res.message = errors[0] if errors else f"TLC exited with code {exit_code} and no verdict"
        if detail := _EXCEPTION_RE.search(text):
            res.message += " " + detail.group(1).strip()
    return res


# --------------------------------------------------------------------------- manifest


@dataclass
class Entry:
    """One manifest row: a good model (expect 'pass') or a mutant (expect a violation)."""

    name: str
    module: str
    config: str
    kind: Literal["model", "mutant", "distributed"]
    optional: bool = False
    spec: str = ""  # models: the specification module the configuration checks (Bridge, ...)
    witnesses: list[str] = field(default_factory=list)  # models: Reach... predicates to reach
    workers: int = 0  # distributed entries: TLCWorkers started on this machine
    expect_violation: str | None = None  # mutants: name TLC must report
    covers: str | None = None  # mutants: Module.Invariant the mutant proves non-vacuous
    distinct_states: int | None = None
    depth: int | None = None
    runtime_s: float | None = None
    raw: dict[str, Any] = field(default_factory=dict)


def load_manifest(path: Path = MANIFEST) -> tuple[dict[str, Any], list[Entry]]:
    try:
        data: dict[str, Any] = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError as exc:
        raise SetupError(f"manifest not found: {path}") from exc
    except json.JSONDecodeError as exc:
        raise SetupError(f"{path}: invalid JSON: {exc}") from exc
    entries: list[Entry] = []
    for kind_key, kind in (("models", "model"), ("mutants", "mutant")):
        for row in data.get(kind_key, []):
            try:
                entries.append(
                    Entry(
                        name=str(row["name"]),
                        module=str(row["module"]),
                        config=str(row["config"]),
                        kind=kind,  # type: ignore[arg-type]
                        optional=bool(row.get("optional", False)),
                        spec=str(row.get("spec", "")),
                        witnesses=[str(w) for w in row.get("witnesses", [])],
                        expect_violation=row.get("violates"),
                        covers=row.get("covers"),
                        distinct_states=row.get("distinct_states"),
                        depth=row.get("depth"),
                        runtime_s=row.get("runtime_s"),
                        raw=row,
                    )
                )
            except KeyError as exc:
                raise SetupError(f"{path}: entry {row!r} lacks field {exc}") from exc
    models = {e.name: e for e in entries if e.kind == "model"}
    for row in data.get("distributed", []):
        model = models.get(str(row.get("model")))
        if model is None:
            raise SetupError(f"{path}: distributed entry {row!r} names no model of the manifest")
        entries.append(Entry(
            name=str(row["name"]), module=model.module, config=model.config, kind="distributed",
            spec=model.spec, distinct_states=model.distinct_states, workers=int(row.get("workers", 2)),
            raw=row))
    return data, entries


# --------------------------------------------------------------------------- running TLC


@dataclass
class RunOutcome:
    entry: Entry
    result: TlcResult
    runtime_s: float
    log: str
    ok: bool = False
    problems: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    reached: set[str] = field(default_factory=set)  # witnesses TLC printed
    witnesses_checked: bool = False  # the run had the witness invariant
    unchecked: list[str] = field(default_factory=list)  # properties the run could not check


def _scratch(tmp: Path, entry: Entry, spec_dir: Path, overrides: dict[str, str] | None) -> tuple[Path, Path]:
    """Copy every module, the entry's module and configuration into `tmp`; `overrides` maps a
    module file name to the text to use instead (a mutated specification)."""
    module, config = spec_dir / entry.module, spec_dir / entry.config
    for tla in spec_dir.glob("*.tla"):
        shutil.copy2(tla, tmp / tla.name)
    shutil.copy2(module, tmp / module.name)
    shutil.copy2(config, tmp / config.name)
    for name, text in (overrides or {}).items():
        (tmp / name).write_text(text, encoding="utf-8")
    (tmp / "java-tmp").mkdir()
    return module, config


def run_tlc(
    entry: Entry, java: str, jar: Path, workers: int, spec_dir: Path = SPEC_DIR, quick: bool = False, *,
    witnesses: bool = True, overrides: dict[str, str] | None = None, timeout: float | None = None,
    liveness: bool = True,
) -> RunOutcome:
    """Run TLC on one entry in a scratch directory holding every module it may need; a model's
    reachability witnesses are checked in the same run (tools/tla_witness.py). Without
    `liveness`, the configuration's temporal properties are left out (its invariants and action
    properties stay): the quick first pass of the mutation runs."""
    module = spec_dir / entry.module
    config = spec_dir / entry.config
    for f in (module, config):
        if not f.is_file():
            return RunOutcome(entry, TlcResult("error", message=f"missing file {f}"), 0.0, "")
    with tempfile.TemporaryDirectory(prefix="urb-tlc-") as tmp_s:
        tmp = Path(tmp_s)
        _scratch(tmp, entry, spec_dir, overrides)
        texts = [p.read_text(encoding="utf-8") for p in tmp.glob("*.tla")]
        cfg_text = config.read_text(encoding="utf-8")
        if not liveness:
            cfg_text = tla_distributed.split_config(cfg_text, texts)[0]
            (tmp / config.name).write_text(cfg_text, encoding="utf-8")
        module_name, config_name = module.name, config.name
        if witnesses and entry.witnesses:
            module_name, config_name = tla_witness.write_wrapper(tmp, module.name, config.name, entry.witnesses)
        # TLC's classes mapped from the class-data-sharing archive the trace checks use (urb_sim.tlc):
        # less CPU per JVM start; a missing or damaged archive only costs that speed.
        with class_archive(java, jar) as cds:
            cmd = [
                java, *(JVM_QUICK if quick else JVM_MODEL), *cds, f"-Djava.io.tmpdir={tmp / 'java-tmp'}",
                "-cp", str(jar), "tlc2.TLC",
                "-workers", str(workers),
                "-config", config_name, "-metadir", str(tmp / "meta"), module_name,
            ]
            start = time.monotonic()
            try:
                proc = subprocess.run(cmd, cwd=tmp, capture_output=True, text=True, check=False, timeout=timeout)
                log, code = proc.stdout + proc.stderr, proc.returncode
            except subprocess.TimeoutExpired as exc:
                out = exc.stdout.decode(errors="replace") if isinstance(exc.stdout, bytes) else (exc.stdout or "")
                runtime = time.monotonic() - start
                return RunOutcome(entry, TlcResult("error", message=f"timeout after {timeout:.0f} s"), runtime, out)
            runtime = time.monotonic() - start
    actions = frozenset(p for p in config_properties(cfg_text) if tla_distributed.is_action_property(p, texts))
    run = RunOutcome(entry, parse_tlc_output(log, code, cfg_text, actions), runtime, log)
    run.reached = tla_witness.reached(log)
    run.witnesses_checked = witnesses and bool(entry.witnesses)
    return run


def run_distributed(entry: Entry, java: str, jar: Path, local_workers: int, threads: int,
                    host: str = "127.0.0.1", port: int | None = None, spec_dir: Path = SPEC_DIR) -> RunOutcome:
    """Run one model with TLCServer and `local_workers` TLCWorkers (tools/tla_distributed.py):
    invariants and action properties only, no liveness, no witnesses."""
    with tempfile.TemporaryDirectory(prefix="urb-tlcd-") as tmp_s:
        tmp = Path(tmp_s)
        module, config = _scratch(tmp, entry, spec_dir, None)
        texts = [p.read_text(encoding="utf-8") for p in tmp.glob("*.tla")]
        try:
            d = tla_distributed.run_distributed(
                java, jar, JVM_QUICK if local_workers and entry.kind == "distributed" else JVM_MODEL, tmp,
                module.name, config.name, texts, local_workers=local_workers, threads=threads, host=host,
                port=port)
        except tla_distributed.DistributedError as exc:
            return RunOutcome(entry, TlcResult("error", message=str(exc)), 0.0, "")
    log = d.server_log + "".join(f"\n---- worker {k} ----\n{w}" for k, w in enumerate(d.worker_logs))
    run = RunOutcome(entry, parse_tlc_output(d.server_log, d.returncode), d.runtime_s, log)
    run.unchecked = d.unchecked
    if d.unchecked:
        run.notes.append("distributed TLC does not check liveness: not checked: " + ", ".join(d.unchecked))
    if entry.witnesses:
        run.notes.append("distributed TLC has no TLCSet: witnesses not checked")
    return run


def judge(run: RunOutcome, update: bool) -> None:
    """Compare a run with its manifest entry; fill run.ok and run.problems."""
    e, r = run.entry, run.result
    if e.kind in ("model", "distributed"):
        if r.outcome != "pass":
            what = f"{r.outcome} {r.violated or ''}".strip()
            run.problems.append(f"expected to pass, TLC reported: {what} {r.message}".strip())
        elif not update:
            if e.distinct_states is None:
                run.problems.append("no recorded state count (run with --update)")
            elif r.distinct_states != e.distinct_states:
                run.problems.append(
                    f"distinct states changed: manifest {e.distinct_states}, TLC {r.distinct_states}"
                    " (if the spec change is intended, run with --update and commit the manifest)"
                )
            if e.depth is not None and r.depth != e.depth:
                # Recorded, not enforced: with several workers TLC's BFS is not strictly
                # level-ordered, so the reported depth may differ by a few levels.
                run.notes.append(f"depth {r.depth} (manifest {e.depth})")
        if r.outcome == "pass" and run.witnesses_checked:
            missing = [w for w in e.witnesses if w not in run.reached]
            if missing:
                run.problems.append("reachability witnesses not reached: " + ", ".join(missing)
                                    + " (the model no longer reaches a situation it must; see spec/tla/README.md)")
    else:
        if r.outcome not in ("invariant", "property", "assumption"):
            what = r.outcome if r.outcome != "error" else f"error: {r.message}"
            run.problems.append(f"mutant not refuted as expected ({e.expect_violation}); TLC: {what}")
        elif r.violated != e.expect_violation:
            run.problems.append(
                f"wrong violation: expected {e.expect_violation}, TLC reported {r.violated or r.message}"
            )
    run.ok = not run.problems


# --------------------------------------------------------------------------- reporting


def write_junit(runs: list[RunOutcome], path: Path) -> None:
    suite = ET.Element(
        "testsuite",
        name="tla-modelcheck",
        tests=str(len(runs)),
        failures=str(sum(not r.ok for r in runs)),
        time=f"{sum(r.runtime_s for r in runs):.2f}",
    )
    for run in runs:
        e, r = run.entry, run.result
        case = ET.SubElement(
            suite, "testcase", classname=f"tla.{e.kind}", name=e.name, time=f"{run.runtime_s:.2f}"
        )
        props = ET.SubElement(case, "properties")
        for key, val in (
            ("module", e.module), ("config", e.config), ("outcome", r.outcome),
            ("violated", r.violated or ""), ("expected_violation", e.expect_violation or ""),
            ("covers", e.covers or ""), ("distinct_states", str(r.distinct_states or "")),
            ("depth", str(r.depth or "")),
            ("witnesses_reached", " ".join(w for w in e.witnesses if w in run.reached)),
            ("witnesses_missing", " ".join(w for w in e.witnesses if w not in run.reached)
             if run.witnesses_checked else ""),
            ("unchecked", " ".join(run.unchecked)),
        ):
            ET.SubElement(props, "property", name=key, value=val)
        if not run.ok:
            fail = ET.SubElement(case, "failure", message="; ".join(run.problems))
            fail.text = run.log[-4000:]
    path.parent.mkdir(parents=True, exist_ok=True)
    ET.ElementTree(suite).write(path, encoding="utf-8", xml_declaration=True)


def write_results(runs: list[RunOutcome], path: Path) -> None:
    rows = [
        {
            "name": run.entry.name, "kind": run.entry.kind, "ok": run.ok, "problems": run.problems,
            "outcome": run.result.outcome, "violated": run.result.violated,
            "covers": run.entry.covers, "distinct_states": run.result.distinct_states,
            "depth": run.result.depth, "runtime_s": round(run.runtime_s, 2),
            "witnesses": {w: w in run.reached for w in run.entry.witnesses} if run.witnesses_checked else {},
            "unchecked": run.unchecked,
        }
        for run in runs
    ]
    path.write_text(json.dumps(rows, indent=2) + "\n", encoding="utf-8")


def print_table(runs: list[RunOutcome]) -> None:
    head = f"{'entry':42} {'kind':6} {'result':28} {'distinct':>9} {'depth':>5} {'time':>6}  status"
    print(head)
    print("-" * len(head))
    for run in runs:
        r = run.result
        verdict = r.outcome if r.outcome == "pass" else f"{r.outcome}:{r.violated or '?'}"
        print(
            f"{run.entry.name:42} {run.entry.kind:6} {verdict[:28]:28} "
            f"{r.distinct_states if r.distinct_states is not None else '-':>9} "
            f"{r.depth if r.depth is not None else '-':>5} {run.runtime_s:6.1f}  "
            f"{'ok' if run.ok else 'FAIL'}"
        )
        for p in run.problems:
            print(f"    ! {p}")
        for n in run.notes:
            print(f"    ~ {n}")


def update_manifest(data: dict[str, Any], runs: list[RunOutcome], path: Path) -> None:
    by_name = {run.entry.name: run for run in runs}
    for key in ("models", "mutants"):
        for row in data.get(key, []):
            run = by_name.get(row["name"])
            if run is None:
                continue
            row["runtime_s"] = round(run.runtime_s, 1)
            if key == "models" and run.result.outcome == "pass":
                row["distinct_states"] = run.result.distinct_states
                row["depth"] = run.result.depth
    path.write_text(json.dumps(data, indent=2) + "\n", encoding="utf-8")


# --------------------------------------------------------------------------- entry points


def check_all(
    entries: list[Entry],
    workers: int | None = None,
    update: bool = False,
    jobs: int | None = None,
    distributed: bool = False,
    local_workers: int = 1,
    host: str = "127.0.0.1",
    port: int | None = None,
) -> list[RunOutcome]:
    """Run every entry (good models one at a time with all cores, mutants in parallel, then the
    distributed loopback checks). With `distributed`, the models run with TLCServer and
    `local_workers` TLCWorkers of `workers` threads each instead."""
    java, jar = find_java(), find_jar()
    cpus = os.cpu_count() or 1
    model_workers = workers or cpus
    models = [e for e in entries if e.kind == "model"]
    mutants = [e for e in entries if e.kind == "mutant"]
    if distributed:
        runs = [run_distributed(e, java, jar, local_workers, model_workers, host, port) for e in models]
    else:
        runs = [run_tlc(e, java, jar, model_workers) for e in models]
    with ThreadPoolExecutor(max_workers=jobs or cpus) as pool:
        runs += list(pool.map(lambda e: run_tlc(e, java, jar, 1, quick=True), mutants))
    runs += [run_distributed(e, java, jar, e.workers, 1) for e in entries if e.kind == "distributed"]
    for run in runs:
        judge(run, update)
    return runs


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--update", action="store_true", help="re-record state counts, depths and runtimes")
    ap.add_argument("--only", metavar="TEXT", help="run only entries whose name contains TEXT")
    ap.add_argument("--exact", metavar="NAME", help="run only the entry called NAME")
    ap.add_argument("--optional", action="store_true", help="include opt-in large configurations")
    ap.add_argument("--workers", type=int, help="TLC workers for good models (default: all cores); "
                    "with --distributed: threads per local TLCWorker")
    ap.add_argument("--distributed", action="store_true",
                    help="run the selected models with TLCServer and TLCWorkers (safety only; see "
                    "tools/tla_distributed.py)")
    ap.add_argument("--local-workers", type=int, default=1,
                    help="with --distributed: TLCWorkers to start on this machine (0: wait for remote ones)")
    ap.add_argument("--host", default="127.0.0.1",
                    help="with --distributed: the address the server and local workers use (default loopback)")
    ap.add_argument("--port", type=int, help="with --distributed: the server's RMI port (default: a free one)")
    ap.add_argument("--junit", type=Path, default=OUT_DIR / "junit.xml", help="JUnit XML output")
    ap.add_argument("--evidence", type=Path, default=None,
                    help="evidence record to write (default build/evidence/tlc.json; with --distributed "
                    "build/evidence/tlc-distributed.json)")
    args = ap.parse_args(argv)
    if args.distributed and args.update:
        print("modelcheck: --update records counts from the ordinary runs; do not combine it with --distributed",
              file=sys.stderr)
        return 2
    try:
        data, entries = load_manifest()
        chosen = [
            e for e in entries
            if (args.optional or not e.optional)
            and (args.only is None or args.only in e.name)
            and (args.exact is None or args.exact == e.name)
            and not (args.distributed and e.kind == "distributed")
        ]
        if args.distributed:
            chosen = [e for e in chosen if e.kind == "model"]
        if not chosen:
            print("modelcheck: no manifest entry selected", file=sys.stderr)
            return 2
        start = time.monotonic()
        runs = check_all(chosen, workers=args.workers, update=args.update, distributed=args.distributed,
                         local_workers=args.local_workers, host=args.host, port=args.port)
        total = time.monotonic() - start
    except SetupError as exc:
        print(f"modelcheck: {exc}", file=sys.stderr)
        return 2
    logs = args.junit.parent / "logs"
    logs.mkdir(parents=True, exist_ok=True)
    for run in runs:
        (logs / f"{run.entry.name}.log").write_text(run.log, encoding="utf-8")
    write_junit(runs, args.junit)
    write_results(runs, args.junit.parent / "results.json")
    evidence = args.evidence or (EVIDENCE_DIR / ("tlc-distributed.json" if args.distributed else "tlc.json"))
    tla_evidence.write(runs, entries, evidence, selection={
        "only": args.only, "exact": args.exact, "optional": args.optional, "distributed": args.distributed,
        "workers": args.workers or (os.cpu_count() or 1), "local_workers": args.local_workers if args.distributed
        else None, "mutant_workers": 1, "jvm_models": JVM_MODEL, "jvm_mutants": JVM_QUICK})
    print_table(runs)
    failed = [r for r in runs if not r.ok]
    print(
        f"\n{len(runs) - len(failed)}/{len(runs)} as expected in {total:.1f}s "
        f"(JUnit: {args.junit.relative_to(ROOT) if args.junit.is_relative_to(ROOT) else args.junit}; "
        f"evidence: {evidence.relative_to(ROOT) if evidence.is_relative_to(ROOT) else evidence})"
    )
    if args.update:
        update_manifest(data, runs, MANIFEST)
        print(f"manifest updated: {MANIFEST.relative_to(ROOT)}")
    if failed:
        print("modelcheck: FAILED: " + ", ".join(r.entry.name for r in failed), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
