#!/usr/bin/env python3
"""Frama-C part of the URB proofs: WP with -wp-rte and Eva, each unit with a seeded mutant.

    python3 tools/proofs_framac.py                  # every unit and its mutant (replays proofs/framac/cache)
    python3 tools/proofs_framac.py --only mailbox   # units whose folder name contains "mailbox"
    python3 tools/proofs_framac.py --unit fifo --mutant complete_marks_ring_head --mutants-only
                                                    # exactly that unit and mutant
    python3 tools/proofs_framac.py --no-mutants     # the units only
    python3 tools/proofs_framac.py --record         # rewrite each unit's expected.json from this run
    python3 tools/proofs_framac.py --list           # the units and their settings, nothing run
    python3 tools/proofs_framac.py --prune-cache    # the whole offline replay, then delete the
                                                    # cache entries it did not read
    python3 tools/proofs_framac.py --cache offline --prune-results
                                                    # the whole run, then delete the recorded runs
                                                    # (proofs/framac/results) it did not use

A unit is a folder proofs/framac/<unit>/ holding PURPOSE (one line), unit.json (what to run) and
expected.json (what the run must give). unit.json:

    {"tool": "wp" | "eva",
     "sources": [files relative to the repository],   "cpp": [preprocessor options],
     "args": [more frama-c options, e.g. -wp-fct or -main],
     "mutants": [{"name", "file", "find", "replace", "why", "args": [options for the mutant run only]}]}

("mutant": {...} names a single one.) "annotations": [{"file", "before", "acsl"}] puts ACSL that C
cannot take from another file (loop invariants, variants, loop assigns) into a copy of a source: each
`acsl` (one /*@ ... */ comment) goes on its own line before the line that starts with `before` (which
must occur exactly once, at the start of a line). The copy must be the original's code with comments
added and nothing else, so the proof is the original's and the file's bytes (which the BMC records
read) stay as they are; mutants apply to the annotated copy. Eva units may set their own Eva options in "args" (for
example -eva-precision or -eva-partition-history): they come after the runner's defaults.

WP units run `-wp -wp-rte` with the provers z3 and cvc4 through why3 (Alt-Ergo is not available),
a per-goal timeout and the cache proofs/framac/cache. The default `--cache update` reuses the cached
prover answers and runs the provers on the goals that are not in the cache (a changed goal), adding
their answers; `make proofs-framac` (and so `make check` and CI) replays with `--cache offline`, which
runs no prover: a goal that is not in the cache fails as CACHE MISS, naming the command that proves
it. Every function must prove all its goals, and the goal count per function must equal
expected.json: a count that moves means the code or its contract changed, so re-record with
--record after reviewing the change.

Eva units analyse a main (proofs/framac/eva_*/main.c) that drives one firmware entry point with a
HAL of arbitrary inputs. Each alarm is keyed by file, function and property text (no line numbers,
so edits elsewhere in the file do not invalidate the list); every alarm must be in expected.json
and explained in proofs/framac/eva_alarms.md, and an alarm listed there that no longer occurs must
be removed (the list stays exact). A contract Eva finds invalid at any call site fails the unit
(INVALID): Eva's consolidated status of such a property is Unknown, so the runner reads its red
statuses (-eva-report-red-statuses); a behavior's postcondition red only where Eva could not decide
the behavior's assumes ("Behavior may be inactive") is counted, not failed. Contract statuses are
counted per unit.

Each mutant of a unit copies one source file, replaces `find` (which must occur exactly once) by
`replace` and runs the same analysis: WP must leave a goal unproved, Eva must raise an alarm that
is not in the reviewed list.

Whole runs are replayed when their inputs are byte-identical to a recorded run's (Eva runs, offline
WP runs and their mutants; tools/framac_cache.py, proofs/framac/results, FRAMAC_RESULT_CACHE=on|off|
refresh): see proofs/framac/README.md, "Result cache of whole runs". `--prune-results` after a whole
offline run deletes the entries no run used.

Outputs build/proofs/framac/summary.json ({"part": "framac", "rows": [...]}, one row per function
or Eva entry point and one per mutant), junit.xml, the Frama-C logs under logs/, and the evidence
record build/evidence/framac.json (WP goals per prover, Eva alarms with their reviews, mutants). Exit status:
0 every result as expected, 1 an unexpected result, 2 a missing tool or a broken unit folder.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import xml.etree.ElementTree as ET
from concurrent.futures import ThreadPoolExecutor
from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

if str(Path(__file__).resolve().parents[1]) not in sys.path:  # tools/ as a namespace package, also when
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this script is run or loaded by path
from tools import framac_cache, result_cache  # noqa: E402
from urb_report import c_source  # noqa: E402
from urb_report.records import Item, Verdict, command_version, write_record  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
UNITS_DIR = ROOT / "proofs" / "framac"
CACHE_DIR = UNITS_DIR / "cache"
RESULTS_DIR = UNITS_DIR / "results"  # whole recorded runs (tools/framac_cache.py), one folder per unit
ALARMS_MD = UNITS_DIR / "eva_alarms.md"
OUT_DIR = ROOT / "build" / "proofs" / "framac"
PROVERS = "z3,cvc4"
GOAL_TIMEOUT_S = 30  # per goal and prover, CPU seconds; generous because CI machines are shared, and a cache hit skips it
MACHDEP = "gcc_x86_32"  # 32-bit int, long, size_t and pointers, as on the Cortex-M0+ targets
EVA_UNROLL = 64  # unrolls every loop of at most 64 rounds (buffers, CRCs): exact, no widening there
EVA_PRECISION = 2  # Eva's meta-option: enough states for the I2C and parser state machines
OFFLINE_WP_PAR = 16  # WP tasks at once when no prover runs (--cache offline): see framac_command
RUN_TIMEOUT_S = 3600  # one frama-c process; catches a hang (a cold gen_core on a loaded 2-core machine takes ~20 min)


class SetupError(Exception):
    """A tool is missing or a unit folder is broken; the message says how to fix it."""


# =============================================================================== units


@dataclass
class Unit:
    name: str
    folder: Path
    tool: str  # wp | eva
    purpose: str
    sources: list[str]
    cpp: list[str]
    args: list[str]
    mutants: list[dict[str, Any]]
    expected: dict[str, Any]
    annotations: list[dict[str, str]] = field(default_factory=list)


def load_unit(folder: Path) -> Unit:
    def need(path: Path) -> str:
        if not path.is_file():
            raise SetupError(f"{path.relative_to(ROOT)} is missing: every unit folder needs PURPOSE, unit.json "
                             "and expected.json (create expected.json with --record)")
        return path.read_text(encoding="utf-8")

    purpose = need(folder / "PURPOSE").strip()
    if not purpose or "\n" in purpose:
        raise SetupError(f"{folder.relative_to(ROOT)}/PURPOSE must be exactly one line")
    cfg = json.loads(need(folder / "unit.json"))
    tool = cfg.get("tool")
    if tool not in ("wp", "eva"):
        raise SetupError(f"{folder.relative_to(ROOT)}/unit.json: tool must be \"wp\" or \"eva\", not {tool!r}")
    for src in cfg["sources"]:
        if not (ROOT / src).is_file():
            raise SetupError(f"{folder.relative_to(ROOT)}/unit.json names {src}, which does not exist")
    exp_path = folder / "expected.json"
    expected: dict[str, Any] = json.loads(exp_path.read_text(encoding="utf-8")) if exp_path.is_file() else {}
    mutants = list(cfg.get("mutants", [])) + ([cfg["mutant"]] if "mutant" in cfg else [])
    names = [m.get("name") for m in mutants]
    if len(set(names)) != len(names):
        raise SetupError(f"{folder.name}/unit.json: two mutants share a name: {names}")
    annotations = list(cfg.get("annotations", []))
    for note in annotations:
        if not (ROOT / note.get("file", "")).is_file() or not note.get("before") or not note.get("acsl"):
            raise SetupError(f"{folder.name}/unit.json: an annotation needs an existing `file`, a `before` line and "
                             f"its `acsl`: {note}")
    return Unit(folder.name, folder, tool, purpose, list(cfg["sources"]), list(cfg.get("cpp", [])),
                list(cfg.get("args", [])), mutants, expected, annotations)


def discover(only: list[str], exact: list[str] | None = None) -> list[Unit]:
    """The units whose folder name contains one of `only` or is one of `exact` (all when neither)."""
    folders = sorted(p.parent for p in UNITS_DIR.glob("*/unit.json"))
    unknown = sorted(set(exact or []) - {f.name for f in folders})
    if unknown:
        raise SetupError(f"no unit named {', '.join(unknown)} under {UNITS_DIR.relative_to(ROOT)}: see --list")
    if only or exact:
        folders = [f for f in folders if any(o in f.name for o in only) or f.name in (exact or [])]
    if not folders:
        raise SetupError(f"no unit under {UNITS_DIR.relative_to(ROOT)} matches {only}: see --list")
    return [load_unit(f) for f in folders]


# =============================================================================== running


def require_tools() -> None:
    missing = [c for c in ("frama-c", "why3", "z3", "cvc4") if shutil.which(c) is None]
    if missing:
        raise SetupError(f"{', '.join(missing)} missing: install with `sudo apt-get install frama-c-base why3 z3 cvc4` "
                         "(or run tools/setup.sh), then `why3 config detect`")
    conf = Path(os.environ.get("WHY3CONFIG", str(Path.home() / ".why3.conf")))
    text = conf.read_text(encoding="utf-8") if conf.is_file() else ""
    if "Z3" not in text or "CVC4" not in text:
        raise SetupError("why3 does not know z3 and cvc4: run `why3 config detect` (tools/setup.sh does it)")


@dataclass
class FramacRun:
    ok: bool  # frama-c exited normally
    seconds: float
    log: str
    report: dict[str, Any] = field(default_factory=dict)
    cpu_s: float = 0.0  # Frama-C's user + system seconds (a replayed run: the recorded run's)
    #: the run was replayed from proofs/framac/results: "<commit> <date>" it was computed on
    replayed: str = ""
    #: what the result cache did: "", "recorded <entry>", "spot-checked", "not used (why)"
    cache_note: str = ""
    #: a spot check's re-run disagreed with the recorded entry: what differs (fails the unit)
    cache_wrong: str = ""
    #: the run's key in proofs/framac/results (empty when the result cache was not used)
    key: str = ""


def annotated(unit: Unit, target: str) -> str:
    """The text of `target` with the unit's annotations for it (see unit.json "annotations"). Refuses
    an anchor that is not exactly one line start, an `acsl` that is not one ACSL comment, and any
    result whose code (comments and whitespace aside) differs from the original's."""
    original = (ROOT / target).read_text(encoding="utf-8")
    text = original
    for note in (n for n in unit.annotations if n["file"] == target):
        anchor, acsl = "\n" + note["before"], note["acsl"].rstrip()
        if text.count(anchor) != 1:
            raise SetupError(f"{unit.name}: the annotation anchor {note['before']!r} starts {text.count(anchor)} lines "
                             f"of {target} (must be one): update unit.json to the current code")
        if not (acsl.lstrip().startswith("/*@") and acsl.endswith("*/") and acsl.count("*/") == 1):
            raise SetupError(f"{unit.name}: an annotation must be one /*@ ... */ comment, not {acsl[:60]!r}")
        text = text.replace(anchor, "\n" + acsl + anchor)

    def tokens(source: str) -> str:
        return " ".join(c_source.code_of(source).split())

    if tokens(text) != tokens(original):
        raise SetupError(f"{unit.name}: the annotations of {target} change its code, not only its comments")
    return text


def annotate_sources(unit: Unit, work: Path) -> tuple[list[str], list[str]]:
    """Sources and cpp options of a unit with annotations: each annotated file is a copy under `work`,
    whose directory comes first for includes (the spec file's `#include` then finds the copy)."""
    files = sorted({n["file"] for n in unit.annotations})
    if not files:
        return unit.sources, unit.cpp
    work.mkdir(parents=True, exist_ok=True)
    for target in files:
        (work / Path(target).name).write_text(annotated(unit, target), encoding="utf-8")
    sources = [str(work / Path(s).name) if s in files else s for s in unit.sources]
    return sources, [f"-I{work}"] + [f"-I{(ROOT / f).parent}" for f in files] + unit.cpp


def apply_mutant(unit: Unit, mutant: dict[str, Any], work: Path) -> tuple[list[str], list[str]]:
    """Sources and cpp options of the mutant run: the mutated file is a copy under `work` (of the
    annotated text when the unit annotates that file; the unit's other annotated files beside it)."""
    target = mutant["file"]
    if target not in unit.sources and not (ROOT / target).is_file():
        raise SetupError(f"{unit.name}: mutant file {target} does not exist")
    text = annotated(unit, target)
    find = mutant["find"]
    if text.count(find) != 1:
        raise SetupError(f"{unit.name}: the `find` text of mutant {mutant.get('name')} occurs {text.count(find)} "
                         f"times in {target} (must be once): update unit.json to the current code")
    sources, cpp = annotate_sources(unit, work)
    work.mkdir(parents=True, exist_ok=True)
    copy = work / Path(target).name
    copy.write_text(text.replace(find, mutant["replace"]), encoding="utf-8")
    # The copy's own directory comes first for "..." includes, so the original directory must
    # follow to resolve its neighbours (and a mutated header shadows the original one).
    cpp = [f"-I{work}", f"-I{(ROOT / target).parent}"] + [c for c in cpp if c != f"-I{work}"]
    sources = [str(copy) if s == target else s for s in sources]
    return sources, cpp


def wp_selection(unit_args: list[str], extra: list[str]) -> list[str]:
    """The unit's WP options followed by a mutant's. A mutant's `-wp-fct` replaces the unit's
    (frama-c adds a repeated `-wp-fct` to the list): a mutant is judged by its own functions' goals
    only, so proving the rest of the unit again would only cost time."""
    if "-wp-fct" not in extra[:-1]:
        return unit_args + extra
    kept: list[str] = []
    skip = False
    for arg in unit_args:
        if skip:
            skip = False
        elif arg == "-wp-fct":
            skip = True
        else:
            kept.append(arg)
    return kept + extra


def framac_command(unit: Unit, sources: list[str], cpp: list[str], extra: list[str], report: Path,
                   jobs: int, cache: str, cache_dir: Path) -> list[str]:
    cmd = ["frama-c", "-machdep", MACHDEP, "-cpp-extra-args=" + " ".join(shlex.quote(c) for c in cpp)]
    cmd += [s if os.path.isabs(s) else str(ROOT / s) for s in sources]
    if unit.tool == "wp":
        cmd += wp_selection(unit.args, extra)
        # Offline, no prover runs: a "task" is a cache lookup, and WP polls its tasks, so with few
        # slots it mostly waits (gen_core: 159 s of wall time for 95 s of CPU at -wp-par 2).
        par = max(jobs, OFFLINE_WP_PAR) if cache == "offline" else jobs
        cmd += ["-wp", "-wp-rte", "-wp-prover", PROVERS, "-wp-timeout", str(GOAL_TIMEOUT_S), "-wp-par", str(par),
                "-wp-cache", cache, "-wp-cache-dir", str(cache_dir), "-wp-report-json", str(report),
                "-wp-session", str(report.parent / (report.stem + ".session"))]
    else:
        # -eva-precision is a meta-option: the unit's own options must follow it to refine it.
        cmd += ["-eva", "-eva-no-show-progress", "-eva-msg-key=-final-states", "-eva-precision", str(EVA_PRECISION),
                "-eva-auto-loop-unroll", str(EVA_UNROLL)]
        cmd += unit.args + extra
        # Every property with its status (contracts counted too), and the properties Eva found
        # invalid for some states: their consolidated status may still be Unknown (see eva_red).
        cmd += ["-eva-report-red-statuses", str(red_report(report))]
        cmd += ["-then", "-report-csv", str(report)]
    return cmd


def red_report(report: Path) -> Path:
    """Where an Eva run lists its red properties (next to its report)."""
    return report.with_name(report.stem + ".red.csv")


def run_framac(cmd: list[str], log_path: Path, report: Path) -> FramacRun:
    """Runs Frama-C for real (killed after RUN_TIMEOUT_S); its CPU time is its own (wait4), not
    that of the runs other threads make at the same time."""
    log_path.parent.mkdir(parents=True, exist_ok=True)
    report.unlink(missing_ok=True)
    red_report(report).unlink(missing_ok=True)
    start = time.monotonic()
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        proc = subprocess.Popen(cmd, cwd=ROOT, stdout=out, stderr=err)
        timer = threading.Timer(RUN_TIMEOUT_S, proc.kill)
        timer.start()
        _, status, usage = os.wait4(proc.pid, 0)
        killed = not timer.is_alive()
        timer.cancel()
        proc.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        text = out.read().decode(errors="replace") + err.read().decode(errors="replace")
    ok = proc.returncode == 0 and not killed
    if killed:
        text += f"\n*** killed after {RUN_TIMEOUT_S} s\n"
    seconds = time.monotonic() - start
    log_path.write_text(" ".join(cmd) + "\n\n" + text, encoding="utf-8")
    return FramacRun(ok, seconds, text, _json_report(ok, report), cpu_s=usage.ru_utime + usage.ru_stime)


def _json_report(ok: bool, report: Path) -> dict[str, Any]:
    if ok and report.is_file() and report.suffix == ".json":
        data: dict[str, Any] = json.loads(report.read_text(encoding="utf-8"))
        return data
    return {}


# =============================================================================== result cache


def outcome(tool: str, run: FramacRun, report: Path) -> dict[str, Any] | None:
    """What the runner judges of a run (tools/framac_cache.py compares and records it), or None
    when the run gave no verdict: Frama-C failed or was killed, wrote no report, Eva stopped on an
    error, or a WP goal had no answer (offline: not in proofs/framac/cache). Never recorded."""
    if not run.ok:
        return None
    if tool == "wp":
        funcs = wp_functions(run) if run.report else {}
        if not funcs or any(f["unanswered"] for f in funcs.values()):
            return None
        return {fn: {k: f[k] for k in ("proved", "total", "unproved", "goals", "by")} for fn, f in funcs.items()}
    bad = _EVA_BAD_RE.search(run.log)
    if bad or not report.is_file() or not red_report(report).is_file():
        return None
    return {"alarms": eva_alarms(report), "invalid": eva_invalid(report), "red": eva_red(report, run.log),
            "contracts": contract_statuses(report)}


def _restore(recorded: framac_cache.Recorded, cmd: list[str], log_path: Path, report: Path,
             seconds: float) -> FramacRun:
    """Writes a recorded run's report files and log where the real run would have, as its FramacRun."""
    log_path.parent.mkdir(parents=True, exist_ok=True)
    report.unlink(missing_ok=True)
    red_report(report).unlink(missing_ok=True)
    for name, text in recorded.outputs.items():
        (report.parent / name).write_text(text, encoding="utf-8")
    replayed = f"{recorded.commit} {recorded.date}"
    log_path.write_text(" ".join(cmd) + f"\n\nurb-framac-cache: hit {recorded.key} cpu {recorded.cpu_s:.2f} "
                        f"computed on {replayed} ({recorded.path.relative_to(ROOT) if recorded.path.is_relative_to(ROOT) else recorded.path})\n"
                        + recorded.log, encoding="utf-8")
    return FramacRun(True, seconds, recorded.log, _json_report(True, report), cpu_s=recorded.cpu_s, replayed=replayed,
                     key=recorded.key)


def run_cached(unit: Unit, label: str, cmd: list[str], log_path: Path, report: Path, cache: str,
               cache_dir: Path) -> FramacRun:
    """run_framac, or the recorded run of the same inputs (tools/framac_cache.py). WP runs use it
    only offline on the committed answer cache: otherwise provers may add answers during the run."""
    usable = unit.tool == "eva" or (cache == "offline" and cache_dir == CACHE_DIR)
    mode = framac_cache.mode()
    if not usable or mode == "off":
        return run_framac(cmd, log_path, report)
    start = time.monotonic()
    try:
        key = framac_cache.run_key(cmd, str(ROOT), framac_cache.tool_identity(unit.tool),
                                   framac_cache.dependencies(cmd, ROOT, framac_cache.share_libc()),
                                   f"wp answers {framac_cache.folder_digest(CACHE_DIR)}" if unit.tool == "wp" else "")
    except framac_cache.CacheError as e:
        run = run_framac(cmd, log_path, report)
        run.cache_note = f"not used ({e})"
        return run
    recorded = framac_cache.load(RESULTS_DIR, unit.name, key, str(ROOT)) if mode == "on" else None
    if recorded is not None:
        per_mille, seed, max_cpu = framac_cache.spot_check_settings()
        if not (result_cache.spot_checked(key, seed, per_mille) and recorded.cpu_s <= max_cpu):
            return _restore(recorded, cmd, log_path, report, time.monotonic() - start)
        with tempfile.TemporaryDirectory(prefix="urb-framac-recorded-") as tmp:
            was = _restore(recorded, cmd, Path(tmp) / "log", Path(tmp) / report.name, 0.0)
            expected = outcome(unit.tool, was, Path(tmp) / report.name)
        run = run_framac(cmd, log_path, report)
        now = outcome(unit.tool, run, report)
        if now != expected:
            run.cache_wrong = (f"SPOT CHECK FAILED: Frama-C run again now gives {json.dumps(now)[:300]}, the entry "
                               f"{recorded.path.relative_to(ROOT) if recorded.path.is_relative_to(ROOT) else recorded.path} "
                               f"recorded {json.dumps(expected)[:300]}: the entry is wrong; delete it, or rerun with "
                               f"{framac_cache.ENV}=refresh")
        run.cache_note, run.key = f"spot-checked {key}", key
        return run
    run = run_framac(cmd, log_path, report)
    run.key = key
    if outcome(unit.tool, run, report) is not None:
        outputs = {p.name: p.read_text(encoding="utf-8") for p in (report, red_report(report)) if p.is_file()}
        path = framac_cache.record(RESULTS_DIR, unit.name, label, key, str(ROOT), cmd, run.log, outputs, run.cpu_s,
                                   run.seconds)
        run.cache_note = f"recorded {path.relative_to(ROOT) if path.is_relative_to(ROOT) else path}"
    return run


# =============================================================================== WP results

_GOAL_RE = re.compile(r"^\[wp\] \[[^\]]+\] Goal typed_(\S+) : (\w+)(.*)$", re.MULTILINE)
_MS_RE = re.compile(r"\((?:Qed:)?(\d+(?:\.\d+)?)(ms|s)\)")


_NOT_PROVERS = ("wp:main", "qed", "script")


def _no_prover_answer(verdicts: dict[str, Any]) -> bool:
    """A property that no prover answered: with --cache offline, a goal missing from the cache. WP
    then reports no prover's verdict (only its own, Qed's and, under -wp-auto, the strategy's
    "script" one), or a prover's "failed": a prover that answered says valid, unknown, timeout..."""
    return not any(name not in _NOT_PROVERS and any(k not in ("total", "rank", "failed") for k in counts)
                   for name, counts in verdicts.items())


PROVER_NAMES = {"qed": "qed", "z3": "z3", "cvc4": "cvc4", "cvc5": "cvc5", "alt-ergo": "alt-ergo", "script": "script"}


def proved_by(goals: dict[str, Any]) -> dict[str, int]:
    """How many of a function's WP properties each prover proved (qed is WP's simplifier; a
    property two provers proved counts for both; "script" is a -wp-auto strategy whose parts the
    provers proved). WP's report gives verdicts per property, and a property may hold several goals."""
    counts: dict[str, int] = {}
    for verdicts in goals.values():
        for name, v in verdicts.items():
            key = PROVER_NAMES.get(name.split(":")[0].lower())
            if key and v.get("valid", 0) > 0:
                counts[key] = counts.get(key, 0) + 1
    return dict(sorted(counts.items()))


def miss_kind(goal: str, recorded: dict[str, Any] | None) -> str:
    """Why an offline replay found no cached answer for `goal`: "changed" when the unit's
    expected.json records a goal of that name (its formula changed: the code, its contract or a
    callee's contract moved), "new" when it records the function's goals and this one is not among
    them, "new or changed" when expected.json holds no goal names for the function."""
    names = (recorded or {}).get("goals")
    if not names:
        return "new or changed (expected.json records no goal names for this function: run --record)"
    return "changed" if goal in names else "new"


def real_verdict_command(units: list[str], mutants: list[str], unit_rows: bool) -> str:
    """The one command that runs the provers on the goals an offline replay missed: the units
    (their own functions when `unit_rows`) and the named mutants, in update mode."""
    cmd = ".venv/bin/python tools/proofs_framac.py --cache update"
    cmd += "".join(f" --unit {u}" for u in sorted(set(units)))
    cmd += "".join(f" --mutant {m}" for m in sorted(set(mutants))) if mutants else " --no-mutants"
    return cmd + ("" if unit_rows else " --mutants-only")


def wp_functions(run: FramacRun) -> dict[str, dict[str, Any]]:
    """Per function: proved, total, the unproved properties, those of them no prover answered
    (cache misses offline) and the solver time of its goals."""
    result: dict[str, dict[str, Any]] = {}
    for fn, props in run.report.get("wp:functions", {}).items():
        main = props["wp:section"]["wp:main"]
        unproved = sorted(p for p, v in props.items()
                          if p != "wp:section" and v["wp:main"].get("valid", 0) < v["wp:main"]["total"])
        unanswered = [p for p in unproved if _no_prover_answer(props[p])]
        result[fn] = {"proved": int(main.get("valid", 0)), "total": int(main["total"]), "unproved": unproved,
                      "unanswered": unanswered, "seconds": 0.0, "goals": sorted(p for p in props if p != "wp:section"),
                      "by": proved_by({p: v for p, v in props.items() if p != "wp:section"})}
    names = sorted(result, key=len, reverse=True)  # longest first: urb_x_encode before urb_x
    for goal, _status, rest in _GOAL_RE.findall(run.log):
        owner = next((n for n in names if goal.startswith(n + "_")), None)
        if owner is None:
            continue
        for value, unit in _MS_RE.findall(rest):
            result[owner]["seconds"] += float(value) / (1000.0 if unit == "ms" else 1.0)
    return result


# =============================================================================== Eva results


def read_alarm_list() -> set[str]:
    """Alarm keys explained in eva_alarms.md: the first column of its table, in backquotes."""
    return set(read_alarm_reviews())


def read_alarm_reviews() -> dict[str, str]:
    """Alarm key -> its review (why it is not a bug) from eva_alarms.md."""
    if not ALARMS_MD.is_file():
        return {}
    reviews = {}
    for line in ALARMS_MD.read_text(encoding="utf-8").splitlines():
        m = re.match(r"^\|\s*`([^`]+)`\s*\|(.*)\|\s*$", line)
        if m:
            reviews[m.group(1)] = m.group(2).strip()
    return reviews


_CONTRACT_KINDS = ("precondition", "postcondition", "loop invariant", "loop variant", "assigns", "from",
                   "complete behaviors", "disjoint behaviors")


def _report_rows(report: Path) -> list[dict[str, str]]:
    """The rows of the Report plugin's CSV (tab-separated, one header line), or none without a report."""
    if not report.is_file():
        return []
    lines = report.read_text(encoding="utf-8").splitlines()
    header = lines[0].split("\t") if lines else []
    return [dict(zip(header, line.split("\t"))) for line in lines[1:]]


_PROVEN = ("Valid", "Valid under hyp.", "Considered valid", "Dead")


def eva_alarms(report: Path) -> list[str]:
    """Alarm keys `file:function: kind: property` from the Report plugin's CSV (unproved properties only)."""
    keys = []
    for cols in _report_rows(report):
        kind = cols.get("property kind", "")
        if cols.get("status", "") in _PROVEN:
            continue
        if kind.startswith(_CONTRACT_KINDS):
            continue  # the ACSL contracts are WP's to prove; Eva's verdict on them is not an alarm
        where = Path(cols.get("file", "?")).name  # a mutant's copy keeps its file name
        prop = re.sub(r"\s+", " ", cols.get("property", "")).strip()
        keys.append(f"{where}:{cols.get('function', '?')}: {kind}: {prop}")
    return sorted(set(keys))


def eva_invalid(report: Path) -> list[str]:
    """Properties of any kind, contracts included, that Eva found false (status Invalid). A
    precondition false at a call site is one: Eva stops every path through that call without an
    alarm of its own, so the code behind it goes unanalysed (a `\\valid(p)` on a const `*p` did
    that to the bridge's serving path)."""
    found = []
    for cols in _report_rows(report):
        status = cols.get("status", "")
        if status.startswith("Invalid") and "dead" not in status:
            prop = re.sub(r"\s+", " ", cols.get("property", "")).strip()
            found.append(f"{Path(cols.get('file', '?')).name}:{cols.get('line', '?')}:{cols.get('function', '?')}: "
                         f"{cols.get('property kind', '')}: {prop}")
    return sorted(set(found))


_INVALID_MESSAGE = re.compile(r"^\[eva:alarm\] (\S+):(\d+): Warning: *\n\s*(function [^\n]*? got status invalid\.[^\n]*)",
                              re.MULTILINE)
_INACTIVE = "Behavior may be inactive"


def eva_red(report: Path, log: str) -> dict[str, list[str]]:
    """The properties Eva found invalid for some states (`-eva-report-red-statuses`). A contract
    false at one call site but true at another is consolidated to Unknown in the report, so it was
    neither an alarm nor an invalid property; here it is "invalid" (a precondition at a call site,
    a postcondition...). Except "undecided": a named behavior's postcondition Eva found false in
    a context where it could not tell whether the behavior applies (its log says "Behavior may be
    inactive, no reduction performed"; WP proves the behaviors). "alarms": run-time-error alarms
    that are definite in some context; like every alarm they must be recorded and reviewed."""
    messages: dict[tuple[str, str], list[str]] = {}
    for m in _INVALID_MESSAGE.finditer(log):
        messages.setdefault((Path(m.group(1)).name, m.group(2)), []).append(m.group(3))
    out: dict[str, list[str]] = {"invalid": [], "undecided": [], "alarms": []}
    for cols in _report_rows(red_report(report)):
        prop = re.sub(r"\s+", " ", cols.get("property", "")).strip()
        name, line = Path(cols.get("file", "?")).name, cols.get("line", "?")
        text = (f"{name}:{line}:{cols.get('function', '?')}: {cols.get('name', '')} (consolidated status "
                f"{cols.get('status', '?')}, invalid in {cols.get('#contexts', '?')} context(s)): {prop}")
        said = messages.get((name, line), [])
        if cols.get("kind") == "Alarm":
            out["alarms"].append(text)
        elif said and all(_INACTIVE in msg for msg in said):
            out["undecided"].append(text)
        else:
            out["invalid"].append(text)
    return {k: sorted(set(v)) for k, v in out.items()}


def contract_statuses(report: Path) -> dict[str, int]:
    """How many ACSL contract properties of the analysed sources (pre- and postconditions, assigns,
    loop annotations...) the Eva report holds per consolidated status: valid, unknown, invalid, not
    reached. (A contract invalid at one call site only is consolidated to unknown: eva_red.)"""
    counts = {"valid": 0, "unknown": 0, "invalid": 0, "not reached": 0}
    for cols in _report_rows(report):
        if not cols.get("property kind", "").startswith(_CONTRACT_KINDS) or \
                cols.get("directory", "").startswith("FRAMAC_SHARE"):
            continue  # Frama-C's own library specifications are not ours to count
        status = cols.get("status", "")
        key = ("invalid" if status.startswith("Invalid") else "valid" if status in _PROVEN else
               "not reached" if status == "Never tried" or "dead" in status else "unknown")
        counts[key] += 1
    return counts


_EVA_BAD_RE = re.compile(r"NON TERMINATING FUNCTION|\[kernel\] User Error|\[kernel\] Failure|"
                         r"Completely invalid destination|Assertion got status invalid", re.MULTILINE)


# =============================================================================== rows


@dataclass
class Row:
    function: str
    tool: str
    properties: str
    bound: str
    result: str
    expected: bool
    time_s: float
    detail: str = ""
    unit: str = ""
    data: dict[str, Any] = field(default_factory=dict)  # for the evidence record (build/evidence/framac.json)


def wp_bound() -> str:
    return f"unbounded (deductive); {PROVERS} via why3, {GOAL_TIMEOUT_S} s per goal"


def check_wp(unit: Unit, run: FramacRun, record: bool, cache: str, mutant: str = "") -> tuple[list[Row],
                                                                                            dict[str, Any]]:
    if not run.ok or not run.report:
        return [Row(unit.name, "frama-c wp", "-", wp_bound(), "ERROR", False, run.seconds,
                    f"frama-c failed: see build/proofs/framac/logs/{unit.name}.log", unit.name)], {}
    funcs = wp_functions(run)
    want: dict[str, Any] = unit.expected.get("functions", {})
    rows = []
    for fn in sorted(set(funcs) | set(want)):
        got = funcs.get(fn)
        exp = want.get(fn)
        if got is None:
            rows.append(Row(fn, "frama-c wp", "no goals", wp_bound(), "MISSING", record, 0.0,
                            "expected.json lists it but WP produced no goal: function removed or renamed?",
                            unit.name))
            continue
        complete = got["proved"] == got["total"]
        same = exp is not None and exp["total"] == got["total"] and exp["proved"] == got["proved"]
        result = "proved" if complete else "UNPROVED"
        detail = ", ".join(got["unproved"])
        if cache == "offline" and got["unanswered"]:
            result = "CACHE MISS"
            goals = "; ".join(f"{g} ({miss_kind(g, exp)})" for g in got["unanswered"])
            command = real_verdict_command([unit.name], [mutant] if mutant else [], unit_rows=not mutant)
            detail = (f"no cached prover answer (offline: no prover ran, so no verdict) for {goals}; the real "
                      f"verdict: `{command}` (fills {CACHE_DIR.relative_to(ROOT)}: commit the new entries with the "
                      "change)")
        if complete and not same and not record:
            result = "COUNT CHANGED"
            detail = (f"expected {exp['proved']}/{exp['total']} goals" if exp else "not in expected.json") + \
                "; review the change, then run tools/proofs_framac.py --record"
        data = {"total": got["total"], "proved": got["proved"], "by": got["by"], "unproved": got["unproved"],
                "cache_misses": got["unanswered"] if cache == "offline" else []}
        rows.append(Row(fn, "frama-c wp", f"{got['proved']}/{got['total']} goals (RTE + ACSL contract)", wp_bound(),
                        result, complete and (same or record), round(got["seconds"], 3), detail, unit.name, data))
    recorded = {"functions": {fn: {"proved": g["proved"], "total": g["total"], "goals": g["goals"]}
                              for fn, g in sorted(funcs.items())}}
    return rows, recorded


def check_eva(unit: Unit, run: FramacRun, report: Path, record: bool, reviewed: set[str]) -> tuple[list[Row],
                                                                                                    dict[str, Any]]:
    bound = "all inputs the HAL can give (abstract interpretation)"
    bad = _EVA_BAD_RE.search(run.log)
    if not run.ok or bad:
        why = bad.group(0) if bad else "frama-c failed"
        return [Row(unit.name, "frama-c eva", "-", bound, "ERROR", False, run.seconds,
                    f"{why}: see build/proofs/framac/logs/{unit.name}.log", unit.name)], {}
    if not red_report(report).is_file():
        return [Row(unit.name, "frama-c eva", "-", bound, "ERROR", False, run.seconds,
                    f"Eva wrote no list of red properties ({red_report(report).name}): see "
                    f"build/proofs/framac/logs/{unit.name}.log", unit.name)], {}
    contracts = contract_statuses(report)
    invalid, red = eva_invalid(report), eva_red(report, run.log)
    if invalid or red["invalid"]:
        # A property false in some context: Eva cuts the paths behind it (no alarm of its own),
        # and its consolidated status may say Unknown. Never a reviewed result.
        detail = "; ".join([f"invalid: {p}" for p in invalid] + [f"invalid at some call site: {p}" for p in red["invalid"]])
        return [Row(unit.name, "frama-c eva", f"{len(invalid) + len(red['invalid'])} properties invalid in some context",
                    bound, "INVALID", False, run.seconds, detail, unit.name, {"contracts": contracts, "red": red})], {}
    alarms = eva_alarms(report)
    listed = set(unit.expected.get("alarms", []))
    new = [a for a in alarms if a not in listed or a not in reviewed]
    gone = sorted(listed - set(alarms))
    ok = (not new and not gone) or record
    if record:
        new = [a for a in alarms if a not in reviewed]
        ok = not new
    detail = "; ".join([f"NEW ALARM {a}" for a in new] + [f"no longer raised (remove from the list): {a}"
                                                          for a in gone])
    if new and record:
        detail += "; explain each alarm in proofs/framac/eva_alarms.md (why it is not a bug), or fix the code"
    result = "no alarm" if not alarms else ("reviewed alarms" if ok else "ALARM")
    shown = ", ".join(f"{n} {status}" for status, n in contracts.items())
    row = Row(unit.name, "frama-c eva", f"{len(alarms)} alarms ({len(alarms) - len(new)} reviewed); contracts: {shown} "
              f"({len(red['undecided'])} behavior postconditions undecided in some context)",
              bound, result, ok, round(run.seconds, 3), detail, unit.name, {"alarms": alarms, "new": new,
                                                                           "contracts": contracts, "red": red})
    return [row], {"alarms": alarms}


def mutant_targets(mutant: dict[str, Any]) -> set[str] | None:
    """The functions a WP mutant's run proves (its `-wp-fct`), or None when it names none."""
    args = list(mutant.get("args", []))
    for i, arg in enumerate(args[:-1]):
        if arg == "-wp-fct":
            return {f.strip() for f in str(args[i + 1]).split(",") if f.strip()}
    return None


def mutant_row(unit: Unit, mutant: dict[str, Any], rows: list[Row]) -> Row:
    tool = "frama-c wp" if unit.tool == "wp" else "frama-c eva"
    data = mutant_data(mutant)
    if any(r.result == "ERROR" for r in rows):
        return Row(f"{unit.name} mutant {mutant['name']}", tool, mutant["why"], "-", "ERROR", False,
                   sum(r.time_s for r in rows), rows[0].detail, unit.name, data)
    missed: list[Row] = []
    if unit.tool == "wp":
        # A kill is a goal of a mutated function left unproved: a goal elsewhere (a unit whose own
        # proof is incomplete, a prover timeout) says nothing about the seeded bug, and neither
        # does a goal no prover answered (offline, not in the cache).
        targets = mutant_targets(mutant)
        targeted = [r for r in rows if targets is None or r.function in targets]
        missed = [r for r in targeted if r.result == "CACHE MISS"]
        caught = [f"{r.function}: {r.detail}" for r in targeted if r.result == "UNPROVED"]
    else:  # a new alarm, or a property Eva finds invalid in some context (a broken contract)
        caught = [r.detail for r in rows if (r.result == "ALARM" and "NEW ALARM" in r.detail) or r.result == "INVALID"]
    if missed:
        result, detail = "CACHE MISS", missed[0].detail
    else:
        result, detail = ("killed" if caught else "SURVIVED"), "; ".join(caught)
    return Row(f"{unit.name} mutant {mutant['name']}", tool, mutant["why"], "same as the unit", result,
               result == "killed", round(sum(r.time_s for r in rows), 3), detail[:400], unit.name, data)


def mutant_data(mutant: dict[str, Any]) -> dict[str, Any]:
    """What the mutation table needs of a mutant: the file, the function it changes, its kind."""
    text = (ROOT / mutant["file"]).read_text(encoding="utf-8") if (ROOT / mutant["file"]).is_file() else ""
    at = text.find(mutant["find"])
    function = c_source.function_at(c_source.code_of(text), at) if at >= 0 else ""
    return {"mutant": mutant["name"], "file": mutant["file"], "mutated_function": function,
            "kind": mutant.get("kind", "other")}


# =============================================================================== driver


def run_unit(unit: Unit, mutant: dict[str, Any] | None, jobs: int, cache: str, cache_dir: Path, record: bool,
             reviewed: set[str]) -> tuple[list[Row], dict[str, Any], FramacRun]:
    tag = f"{unit.name}.mutant.{mutant['name']}" if mutant else unit.name
    report = OUT_DIR / "reports" / (tag + (".json" if unit.tool == "wp" else ".csv"))
    report.parent.mkdir(parents=True, exist_ok=True)
    sources, cpp = annotate_sources(unit, OUT_DIR / "annotated" / unit.name)
    extra: list[str] = []
    if mutant:
        sources, cpp = apply_mutant(unit, mutant, OUT_DIR / "mutants" / unit.name / mutant["name"])
        extra = list(mutant.get("args", []))
    cmd = framac_command(unit, sources, cpp, extra, report, jobs, cache, cache_dir)
    run = run_cached(unit, f"mutant {mutant['name']}" if mutant else "unit", cmd, OUT_DIR / "logs" / f"{tag}.log",
                     report, cache, cache_dir)
    if unit.tool == "wp":
        rows, recorded = check_wp(unit, run, record and not mutant, cache, mutant["name"] if mutant else "")
    else:
        rows, recorded = check_eva(unit, run, report, record and not mutant, reviewed)
    if mutant:
        rows = [mutant_row(unit, mutant, rows)]
        recorded = {}
    for r in rows:
        # Every item says whether its Frama-C run was replayed (proofs/framac/results) and when it was computed.
        r.data.update({"runs_replayed_from_cache": 1 if run.replayed else 0, "computed_on": run.replayed or "now",
                       "framac_cpu_s": round(run.cpu_s, 2), "result_cache": run.cache_note or ("hit" if run.replayed else "")})
        if run.cache_wrong:
            r.result, r.expected, r.detail = "CACHE WRONG", False, run.cache_wrong
    return rows, recorded, run


def write_outputs(rows: list[Row], wall: float) -> None:
    OUT_DIR.mkdir(parents=True, exist_ok=True)
    data = {"part": "framac", "wall_s": round(wall, 1),
            "rows": [{"function": r.function, "tool": r.tool, "properties": r.properties, "bound": r.bound,
                      "result": r.result, "expected": r.expected, "time_s": r.time_s, "detail": r.detail,
                      "unit": r.unit, **({k: r.data[k] for k in ("mutant", "file", "mutated_function", "kind")}
                                         if "mutant" in r.data else {})} for r in rows]}
    (OUT_DIR / "summary.json").write_text(json.dumps(data, indent=2) + "\n", encoding="utf-8")
    suites = ET.Element("testsuites", name="urb-proofs-framac")
    for tool in ("frama-c wp", "frama-c eva"):
        group = [r for r in rows if r.tool == tool]
        if not group:
            continue
        suite = ET.SubElement(suites, "testsuite", name=f"proofs.framac.{tool.split()[-1]}", tests=str(len(group)),
                              failures=str(sum(not r.expected for r in group)),
                              time=f"{sum(r.time_s for r in group):.3f}")
        for r in group:
            case = ET.SubElement(suite, "testcase", classname=f"proofs.framac.{r.unit}", name=r.function,
                                 time=f"{r.time_s:.3f}")
            ET.SubElement(case, "system-out").text = f"{r.properties}; {r.bound}; {r.result}"
            if not r.expected:
                ET.SubElement(case, "failure", message=r.result).text = r.detail
    ET.ElementTree(suites).write(OUT_DIR / "junit.xml", encoding="utf-8", xml_declaration=True)


CACHE_FIELDS = ("runs_replayed_from_cache", "computed_on", "framac_cpu_s", "result_cache")


def evidence_items(rows: list[Row], reviews: dict[str, str]) -> list[Item]:
    """The evidence record's items: `wp:<unit>/<function>` with its goals table (total, proved by
    each prover, unproved, justified), `eva:<unit>` with its alarms and their reviews and the
    contract statuses, `framac-mutant:<unit>/<mutant>`."""
    items = []
    for r in rows:
        verdict: Verdict = "pass" if r.expected else ("error" if r.result == "ERROR" else "fail")
        if "mutant" in r.data:
            items.append(Item(f"framac-mutant:{r.unit}/{r.data['mutant']}", "mutant", verdict, "killed", r.result,
                              r.data["file"], f"python3 tools/proofs_framac.py --unit {r.unit} --mutant "
                              f"{r.data['mutant']} --mutants-only", {**r.data, "detail": r.detail}))
        elif r.tool == "frama-c wp":
            goals = {"total": r.data.get("total", 0), "proved": r.data.get("proved", 0),
                     "by": {p: r.data.get("by", {}).get(p, 0) for p in ("qed", "z3", "cvc4", "cvc5", "script")},
                     "unproved": r.data.get("unproved", []), "justified": [], "cache_misses": r.data.get("cache_misses", [])}
            items.append(Item(f"wp:{r.unit}/{r.function}", "wp", verdict, "every goal proved", r.properties,
                              f"proofs/framac/{r.unit}/unit.json", f"python3 tools/proofs_framac.py --unit {r.unit} "
                              "--no-mutants", {"goals": goals, "result": r.result, "time_s": r.time_s, "detail": r.detail,
                                               **{k: r.data[k] for k in CACHE_FIELDS if k in r.data}}))
        else:
            alarms = [{"alarm": a, "review": reviews.get(a, ""), "status": "reviewed" if a in reviews and
                       a not in r.data.get("new", []) else "NOT REVIEWED"} for a in r.data.get("alarms", [])]
            items.append(Item(f"eva:{r.unit}", "eva", verdict, "every alarm recorded and reviewed, no invalid property",
                              r.properties, f"proofs/framac/{r.unit}/unit.json",
                              f"python3 tools/proofs_framac.py --unit {r.unit} --no-mutants",
                              {"alarms": alarms, "contracts": r.data.get("contracts", {}), "result": r.result,
                               "detail": r.detail, **{k: r.data[k] for k in CACHE_FIELDS if k in r.data}}))
    return items


def write_evidence(rows: list[Row], args: argparse.Namespace, runs: list[FramacRun]) -> Path:
    """build/evidence/framac.json (report/urb_report/records.py)."""
    tools = {"Frama-C": command_version(["frama-c", "-version"]), "why3": command_version(["why3", "--version"]),
             "z3": command_version(["z3", "--version"]), "cvc4": command_version(["cvc4", "--version"]),
             "flags": f"-machdep {MACHDEP}; WP: -wp -wp-rte -wp-prover {PROVERS} -wp-timeout {GOAL_TIMEOUT_S} "
                      f"-wp-cache {args.cache}; Eva: -eva-precision {EVA_PRECISION} -eva-auto-loop-unroll {EVA_UNROLL} "
                      "-eva-report-red-statuses; each unit's own options in its unit.json"}
    config = {"cache": args.cache, "jobs": args.jobs, "units": sorted({r.unit for r in rows}),
              "mutants": not args.no_mutants, "provers": PROVERS.split(","), "goal_timeout_s": GOAL_TIMEOUT_S,
              "framac_runs": len(runs), "replayed_from_cache": sum(1 for r in runs if r.replayed),
              "framac_result_cache": os.environ.get(framac_cache.ENV, "on"),
              "framac_cpu_s": round(sum(r.cpu_s for r in runs if not r.replayed), 1),
              "hypotheses": "HAL contracts assumed at their call sites, never proved: proofs/framac/README.md, "
                            "\"HAL contracts (WP hypotheses)\"; Eva admits: eva_alarms.md, Hypotheses"}
    return write_record("framac", evidence_items(rows, read_alarm_reviews()), tools, config=config)


def print_table(rows: list[Row]) -> None:
    headers = ["function", "tool", "properties", "result", "time"]
    lines = [[r.function, r.tool, r.properties[:48], r.result, f"{r.time_s:.1f}s"] for r in rows]
    widths = [max(len(h), *(len(x[i]) for x in lines)) if lines else len(h) for i, h in enumerate(headers)]
    for cells in [headers, ["-" * w for w in widths]] + lines:
        print("  ".join(c.ljust(w) for c, w in zip(cells, widths)).rstrip())
    for r in rows:
        if not r.expected:
            print(f"UNEXPECTED {r.function} ({r.unit}): {r.result} {r.detail}")


def copy_unread(cache_dir: Path, work_dir: Path) -> list[Path]:
    """Copy each cache entry into work_dir and set the copy's access time to 0 (its modification
    time kept), so that a read shows: the file system then updates it on the first read (relatime
    does, since 0 < mtime). The replay reads the copies because anything that reads the entries in
    the work tree would count as a read: `git status` rehashes every file whose ctime changed, and
    setting the access time changes the ctime."""
    copies = []
    for entry in sorted(cache_dir.glob("*.json")):
        copy = Path(shutil.copy2(entry, work_dir / entry.name))
        os.utime(copy, ns=(0, copy.stat().st_mtime_ns))
        copies.append(copy)
    return copies


def prune_unread(copies: list[Path], cache_dir: Path) -> tuple[int, int]:
    """Delete from cache_dir the entries whose copy was not read since `copy_unread`; (kept,
    deleted). Deletes nothing and raises SetupError when no copy was read: the file system records
    no access times (noatime)."""
    unread = [c for c in copies if c.stat().st_atime_ns == 0]
    if len(unread) == len(copies):
        raise SetupError(f"no entry of {cache_dir} was read, or the file system does not record access times "
                         f"(mounted noatime?): nothing pruned")
    for c in unread:
        (cache_dir / c.name).unlink()
    return len(copies) - len(unread), len(unread)


def prune_results(runs: list[FramacRun]) -> tuple[int, int]:
    """Deletes the entries of proofs/framac/results that none of `runs` (a whole run) used: runs of
    inputs that changed since. (kept, deleted)"""
    used = {r.key for r in runs if r.key}
    stale = [e for e in RESULTS_DIR.glob("*/*.json.gz") if e.name.removesuffix(".json.gz") not in used]
    for entry in stale:
        entry.unlink()
    return len(used), len(stale)


def run_all(units: list[Unit], args: argparse.Namespace, cache_dir: Path, reviewed: set[str]) -> tuple[list[Row],
                                                                                                   list[FramacRun]]:
    """Run the units and their mutants as the options select; rows in unit order, and the runs."""
    jobs: list[tuple[Unit, dict[str, Any] | None]] = []
    if not args.mutants_only:
        jobs += [(u, None) for u in units]
    if not args.no_mutants:
        jobs += [(u, m) for u in units for m in u.mutants if not args.mutant or m["name"] in args.mutant]
    # --jobs frama-c processes at once. Eva is one process per entry point; a WP process runs up
    # to -wp-par provers itself (--jobs; offline, OFFLINE_WP_PAR cache lookups).
    rows: list[Row] = []
    runs: list[FramacRun] = []
    with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        futures = [(u, m, pool.submit(run_unit, u, m, 1 if u.tool == "eva" else args.jobs, args.cache, cache_dir,
                                      args.record, reviewed)) for u, m in jobs]
        for u, m, fut in futures:
            unit_rows, recorded, run = fut.result()
            rows += unit_rows
            runs.append(run)
            how = f"replayed, computed on {run.replayed} in {run.cpu_s:.1f} s CPU" if run.replayed else \
                f"{run.cpu_s:.1f} s CPU{'; ' + run.cache_note if run.cache_note else ''}"
            print(f"  {u.name}{' (mutant ' + m['name'] + ')' if m else ''}: {run.seconds:.1f} s ({how})", flush=True)
            if args.record and not m and recorded:
                (u.folder / "expected.json").write_text(json.dumps(recorded, indent=2) + "\n", encoding="utf-8")
    return rows, runs


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--only", action="append", default=[], help="units whose folder name contains this")
    ap.add_argument("--unit", action="append", default=[], help="the unit of exactly this name (repeatable)")
    ap.add_argument("--mutant", action="append", default=[],
                    help="only the mutants of this name (repeatable; the selected units still run unless "
                         "--mutants-only)")
    ap.add_argument("--no-mutants", action="store_true", help="skip the seeded mutants")
    ap.add_argument("--mutants-only", action="store_true", help="run only the seeded mutants")
    ap.add_argument("--record", action="store_true", help="rewrite each unit's expected.json from this run")
    ap.add_argument("--cache", default="update", choices=["update", "replay", "offline", "rebuild", "none"],
                    help="WP cache mode (default update: cached answers are reused, misses run the provers; "
                         "offline, as make proofs-framac: no prover runs, a goal not in the cache fails)")
    ap.add_argument("--jobs", type=int, default=2, help="frama-c processes and provers in parallel (default 2)")
    ap.add_argument("--list", action="store_true", help="print the units, run nothing")
    ap.add_argument("--prune-results", action="store_true",
                    help="after a whole offline run, delete the entries of proofs/framac/results no run used "
                         "(runs whose inputs changed since); needs the whole run")
    ap.add_argument("--prune-cache", action="store_true",
                    help="replay every unit and mutant from the cache (offline), then delete the entries no "
                         "goal read: answers to goals that no longer exist. Needs the whole run")
    args = ap.parse_args(argv)
    try:
        if args.prune_cache:
            if args.only or args.unit or args.mutant or args.no_mutants or args.mutants_only or args.record:
                raise SetupError("--prune-cache needs the whole run: no --only, --no-mutants, --mutants-only "
                                 "or --record")
            args.cache = "offline"
        if args.prune_results and (args.only or args.unit or args.mutant or args.no_mutants or args.mutants_only
                                   or args.cache != "offline" or args.prune_cache):
            raise SetupError("--prune-results needs the whole offline run: --cache offline, no --only, --unit, "
                             "--mutant, --no-mutants, --mutants-only or --prune-cache")
        units = discover(args.only, args.unit)
        missing = sorted(set(args.mutant) - {m["name"] for u in units for m in u.mutants})
        if missing:
            raise SetupError(f"no mutant named {', '.join(missing)} in the selected units: see their unit.json")
        if args.list:
            for u in units:
                print(f"{u.name:24} {u.tool:4} {u.purpose}")
            return 0
        require_tools()
        try:
            framac_cache.mode()
            framac_cache.spot_check_settings()
        except framac_cache.CacheError as e:
            raise SetupError(f"{e} (see tools/framac_cache.py)") from None
        reviewed = read_alarm_list()
        # --prune-cache replays from copies outside the work tree: see copy_unread.
        scratch = tempfile.TemporaryDirectory(prefix="urb-framac-cache-") if args.prune_cache else nullcontext(None)
        with scratch as scratch_dir:
            cache_dir = Path(scratch_dir) if scratch_dir else CACHE_DIR
            copies = copy_unread(CACHE_DIR, cache_dir) if args.prune_cache else []
            start = time.monotonic()
            rows, runs = run_all(units, args, cache_dir, reviewed)
            wall = time.monotonic() - start
            write_outputs(rows, wall)
            evidence = write_evidence(rows, args, runs)
            print_table(rows)
            bad = [r for r in rows if not r.expected]
            if args.prune_results:
                if bad:
                    print("proofs_framac: results not pruned: the run had unexpected results", file=sys.stderr)
                else:
                    kept, deleted = prune_results(runs)
                    print(f"framac results: {kept} entries used and kept, {deleted} unused deleted "
                          f"({RESULTS_DIR.relative_to(ROOT)})")
            if args.prune_cache:
                if bad:
                    print("proofs_framac: cache not pruned: the replay had unexpected results", file=sys.stderr)
                else:
                    kept, deleted = prune_unread(copies, CACHE_DIR)
                    print(f"framac cache: {kept} entries read and kept, {deleted} unread deleted ({CACHE_DIR})")
    except SetupError as exc:
        print(f"proofs_framac: {exc}", file=sys.stderr)
        return 2
    wp_rows = [r for r in rows if r.tool == "frama-c wp" and " mutant " not in r.function]
    goals = [int(r.properties.split("/")[1].split()[0]) for r in wp_rows if "/" in r.properties]
    print(f"framac: {len(wp_rows)} WP functions, {sum(goals)} goals; "
          f"{sum(r.tool == 'frama-c eva' and ' mutant ' not in r.function for r in rows)} Eva entry points; "
          f"{sum(' mutant ' in r.function for r in rows)} mutants; {len(bad)} unexpected; {wall:.0f} s wall; "
          f"build/proofs/framac/summary.json, junit.xml, {evidence.relative_to(ROOT)}")
    replayed = sum(1 for r in runs if r.replayed)
    print(f"framac result cache: {replayed} of {len(runs)} Frama-C runs replayed from "
          f"{RESULTS_DIR.relative_to(ROOT)} (inputs byte-identical to a recorded run's), {len(runs) - replayed} run now"
          + ("; commit the new entries (git add proofs/framac/results) to reuse them"
             if any(r.cache_note.startswith("recorded") for r in runs) else "")
          + f"; {framac_cache.ENV}={os.environ.get(framac_cache.ENV, 'on')} (off: run every one)")
    missed = [r for r in rows if r.result == "CACHE MISS"]
    if missed:
        command = real_verdict_command([r.unit for r in missed], [r.data["mutant"] for r in missed if "mutant" in r.data],
                                       unit_rows=any("mutant" not in r.data for r in missed))
        print(f"framac: {len(missed)} CACHE MISS (no prover ran, no verdict): the real verdict: {command}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
