#!/usr/bin/env python3
"""Structural coverage of the firmware and the generated C (`make coverage`; quality/README.md).

The node, bridge and codec tests run on two instrumented builds that mk/quality.mk makes from the
test programs' own rules:
  * gcc --coverage -O0, read with gcovr: statement (line) and branch coverage. A branch is an
    outcome of a conditional jump in gcc's object code: each condition of `a && b` has two.
  * clang 19 -fprofile-instr-generate -fcoverage-mapping -fcoverage-mcdc, read with llvm-cov:
    MC/DC of every decision of two or more conditions. llvm-cov counts a condition as covered
    when two executed test vectors of its decision have different outcomes and differ in that
    condition and in no other condition that both evaluated: unique-cause MC/DC in which
    conditions that C's short circuit left unevaluated do not count ("-" in llvm-cov's vectors),
    the form DO-178C's guidance accepts for short-circuit operators. Decisions of one condition
    get no MC/DC record (MC/DC reduces to branch coverage there: gcc's branch counts cover it).
    Clang 19 has no limit of 6 conditions any more (-fmcdc-max-conditions defaults to 32767), but
    it cannot measure a decision that contains a nested decision (`a && f(b || c)`): it warns, and
    this tool compiles every file in scope once more to collect those warnings as findings
    ("mcdc-unmeasured") that must be justified like an uncovered condition.

Every uncovered line, branch and MC/DC condition of the files in scope must be explained by a
justification in quality/coverage_justifications.toml (anchored by function and line text, see
report/urb_report/quality.py), and every justification must still explain something; that file
also says which files are in scope and which are excluded and why. The record is
build/evidence/coverage.json: one `coverage:<file>` item per file (line, branch and MC/DC
percentages, the uncovered items and their justifications; verdict fail when one is unexplained)
and one `coverage-justification:<id>` item per justification (fail when stale).

Reports: build/coverage/gcc/index.html (gcovr), build/coverage/clang/html/index.html (llvm-cov with
MC/DC vectors), build/coverage/summary.md.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import re
import shlex
import subprocess
import sys
import time
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

from urb_report.quality import (Entry, Finding, Matching, QualityError, SourceIndex, describe, entry_items, load_entries,
                                match, path_matches)
from urb_report.records import Item, command_version, package_version, write_record

ROOT = Path(__file__).resolve().parents[1]

KINDS = ("line", "branch", "mcdc", "mcdc-unmeasured")
UNMEASURED = re.compile(r"^(?P<file>[^:\s]+):(?P<line>\d+):(?P<col>\d+): warning: unsupported MC/DC boolean expression")


class CoverageError(Exception):
    """A run or a tool failed; the message says which and what to do."""


@dataclass
class Scope:
    """quality/coverage_justifications.toml's [scope]: the files measured, those excluded and why."""

    measured: list[str]
    excluded: dict[str, str]  # file -> reason
    stale: list[str]


@dataclass
class FileCoverage:
    lines: tuple[int, int] = (0, 0)  # covered, total
    branches: tuple[int, int] = (0, 0)
    mcdc: tuple[int, int] = (0, 0)
    findings: list[Finding] = field(default_factory=list)


def load_scope(path: Path, root: Path) -> Scope:
    import tomllib

    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise QualityError(f"{path}: cannot read it ({exc})") from exc
    scope = data.get("scope")
    if not isinstance(scope, dict) or not isinstance(scope.get("files"), list):
        raise QualityError(f"{path}: [scope] with `files` (glob patterns of the sources in scope) is missing")
    universe = sorted({p.relative_to(root).as_posix() for pat in scope["files"] for p in root.glob(pat) if p.is_file()})
    excluded: dict[str, str] = {}
    stale: list[str] = []
    for n, ex in enumerate(data.get("excluded", []), 1):
        files, reason = ex.get("files"), ex.get("reason", "")
        if not isinstance(files, list) or not isinstance(reason, str) or len(reason.split()) < 5:
            raise QualityError(f"{path}: [[excluded]] #{n} needs `files` (a list of globs) and a `reason` sentence")
        hit = [f for f in universe if path_matches(f, files)]
        if not hit:
            stale.append(f"{path.name}: [[excluded]] #{n} ({', '.join(files)}) excludes no file in scope: delete it")
        for f in hit:
            excluded[f] = " ".join(reason.split())
    return Scope(measured=[f for f in universe if f not in excluded], excluded=excluded, stale=stale)


# ----- running the tests ---------------------------------------------------------------------------

def run_programs(programs: Sequence[str], env: dict[str, str], root: Path, log_dir: Path,
                 args: Sequence[str] = ()) -> None:
    """Each test program must pass: a failing test under instrumentation is a broken run, not data."""
    log_dir.mkdir(parents=True, exist_ok=True)
    for prog in programs:
        log = log_dir / (prog.replace("/", "_") + ".log")
        extra = [a.replace("{name}", Path(prog).name) for a in args]
        with log.open("w") as out:
            proc = subprocess.run([str(root / prog), *extra], cwd=root, env=env, stdout=out, stderr=subprocess.STDOUT,
                                  timeout=900, check=False)
        if proc.returncode != 0:
            raise CoverageError(f"{prog} failed under coverage instrumentation (exit {proc.returncode}); "
                                f"its output is in {log}")


def run_codec_tests(dirs: str, compilers: str, env: dict[str, str], root: Path, log: Path) -> None:
    """tests/test_c_codecs.py against the instrumented codec_driver and unit_tests programs."""
    env = {**env, "URB_CODEC_PROGRAMS": dirs, "URB_CODEC_COMPILERS": compilers}
    with log.open("w") as out:
        proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "tests/test_c_codecs.py"],
                              cwd=root, env=env, stdout=out, stderr=subprocess.STDOUT, timeout=1800, check=False)
    if proc.returncode != 0:
        raise CoverageError(f"tests/test_c_codecs.py failed on the instrumented codecs; see {log}")


def fuzz_replays(root: Path, build: Path, toolchains: Sequence[tuple[str, str, str]]) -> tuple[list[str], list[str]]:
    """Builds every fuzz target of tools/fuzz.py (its sources and include directories) with
    tests/fuzz/replay_main.c instead of libFuzzer, once per (build subdirectory, compiler, flags), and
    replays its committed corpus (the inputs make fuzz starts from, each checked by the target's
    REQUIREs). Returns the replay programs and the clang ones among them (for llvm-cov)."""
    spec = importlib.util.spec_from_file_location("urb_fuzz_tool", ROOT / "tools" / "fuzz.py")
    if spec is None or spec.loader is None:
        raise CoverageError("cannot load tools/fuzz.py for its target list")
    fuzz = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = fuzz
    spec.loader.exec_module(fuzz)
    programs: list[str] = []
    clang_programs: list[str] = []
    for sub, cc, flags in toolchains:
        for name, target in sorted(fuzz.TARGETS.items()):
            exe = build / sub / "fuzz" / name
            exe.parent.mkdir(parents=True, exist_ok=True)
            argv = [cc, "-std=c99", "-D_DEFAULT_SOURCE", *shlex.split(flags), *[f"-I{i}" for i in target.includes],
                    *target.sources, "tests/fuzz/replay_main.c", "-o", str(exe)]
            _tool(argv, f"building the {name} corpus replay with {cc}", root)
            rel = exe.relative_to(root).as_posix()
            programs.append(rel)
            if sub == "clang":
                clang_programs.append(rel)
    return programs, clang_programs


def _tool(argv: list[str], what: str, cwd: Path) -> str:
    proc = subprocess.run(argv, cwd=cwd, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise CoverageError(f"{what} failed (exit {proc.returncode}): {shlex.join(argv)}\n{proc.stderr[-2000:]}")
    return proc.stdout


def gcovr_report(root: Path, gcc_dir: Path, files: Sequence[str], out: Path) -> dict[str, Any]:
    """gcovr's JSON for `files` (and its HTML next to it), from the .gcda files under `gcc_dir`.
    --no-markers: no source comment can exclude code; exclusions live in the justification file."""
    filters = [arg for f in files for arg in ("-f", re.escape(f) + "$")]
    html = out / "gcc" / "index.html"
    html.parent.mkdir(parents=True, exist_ok=True)
    _tool([sys.executable, "-m", "gcovr", "--root", str(root), "--no-markers", "--exclude-unreachable-branches",
           *filters, "--json", str(out / "gcc.json"), "--html-details", str(html), "--html-title", "URB firmware coverage (gcc)",
           str(gcc_dir)], "gcovr", root)
    data: dict[str, Any] = json.loads((out / "gcc.json").read_text())
    return data


def llvm_report(root: Path, profiles: Path, programs: Sequence[str], files: Sequence[str], out: Path,
                suffix: str) -> dict[str, Any]:
    raws = sorted(profiles.glob("*.profraw"))
    if not raws:
        raise CoverageError(f"no clang profiles in {profiles}: did the clang-19 programs run?")
    merged = out / "clang" / "merged.profdata"
    _tool([f"llvm-profdata{suffix}", "merge", "-sparse", *map(str, raws), "-o", str(merged)], "llvm-profdata merge", root)
    objects = [str(root / programs[0])] + [a for p in programs[1:] for a in ("-object", str(root / p))]
    sources = [str(root / f) for f in files]
    export = _tool([f"llvm-cov{suffix}", "export", "-format=text", *objects, "-instr-profile", str(merged), *sources],
                   "llvm-cov export", root)
    (out / "clang" / "export.json").write_text(export)
    _tool([f"llvm-cov{suffix}", "show", "-format=html", "-show-mcdc", "-show-branches=count", "-show-line-counts-or-regions",
           "-output-dir", str(out / "clang" / "html"), *objects, "-instr-profile", str(merged), *sources],
          "llvm-cov show", root)
    data: dict[str, Any] = json.loads(export)
    return data


def unmeasured_decisions(root: Path, files: Sequence[str], clang: str, cflags: str, flags: str) -> list[Finding]:
    """Decisions clang 19 cannot measure for MC/DC (it warns once per decision while compiling)."""
    found: list[Finding] = []
    for f in files:
        if not f.endswith(".c"):
            continue
        proc = subprocess.run([clang, *shlex.split(cflags), *shlex.split(flags), "-S", "-o", os.devnull, f],
                              cwd=root, capture_output=True, text=True, check=False)
        if proc.returncode != 0:
            raise CoverageError(f"{clang} cannot compile {f} for the MC/DC check:\n{proc.stderr[-2000:]}")
        for line in proc.stderr.splitlines():
            m = UNMEASURED.match(line)
            if m and m["file"] in files:
                found.append(Finding(m["file"], int(m["line"]), "mcdc-unmeasured", int(m["col"]),
                                     "clang 19 cannot measure this decision for MC/DC (nested decision)"))
    return found


# ----- findings ------------------------------------------------------------------------------------

def gcc_findings(data: dict[str, Any], files: Sequence[str], cov: dict[str, FileCoverage]) -> None:
    for entry in data.get("files", []):
        name = entry["file"]
        if name not in files:
            continue
        fc = cov[name]
        lines = [ln for ln in entry["lines"] if not ln.get("gcovr/excluded", False)]
        fc.lines = (sum(1 for ln in lines if ln["count"] > 0), len(lines))
        taken = total = 0
        for ln in lines:
            if ln["count"] == 0:
                fc.findings.append(Finding(name, ln["line_number"], "line", 0, "never executed"))
            branches = ln.get("branches", [])
            missed = sum(1 for b in branches if b["count"] == 0)
            total += len(branches)
            taken += len(branches) - missed
            if missed and ln["count"] > 0:  # a never executed line is one finding already
                fc.findings.append(Finding(name, ln["line_number"], "branch", 0,
                                           f"{missed} of {len(branches)} branch outcomes never taken"))
        fc.branches = (taken, total)


def clang_findings(data: dict[str, Any], root: Path, files: Sequence[str], cov: dict[str, FileCoverage],
                   index: SourceIndex) -> None:
    for entry in data["data"][0]["files"]:
        name = Path(entry["filename"]).resolve().relative_to(root.resolve()).as_posix()
        if name not in files:
            continue
        fc = cov[name]
        conds = [b for b in entry.get("branches", []) if b[-1] == 6]  # MCDCBranchRegion
        covered = total = 0
        for rec in entry.get("mcdc_records", []):
            l1, c1, l2, c2, pairs = rec[0], rec[1], rec[2], rec[3], rec[6]
            total += len(pairs)
            covered += sum(1 for p in pairs if p)
            if all(pairs):
                continue
            inside = sorted({(b[0], b[1], b[2], b[3]) for b in conds if (l1, c1) <= (b[0], b[1]) and (b[2], b[3]) <= (l2, c2)})
            missing = []
            for k, ok in enumerate(pairs):
                if ok:
                    continue
                text = ""
                if len(inside) == len(pairs) and inside[k][0] == inside[k][2]:
                    s = inside[k]
                    text = " `" + index.line(name, s[0])[s[1] - 1:s[3] - 1] + "`"
                missing.append(f"C{k + 1}{text}")
            fc.findings.append(Finding(name, l1, "mcdc", c1, f"no independence pair for {', '.join(missing)} "
                                                            f"of {len(pairs)} conditions"))
        fc.mcdc = (covered, total)


# ----- the record ----------------------------------------------------------------------------------

def _pct(pair: tuple[int, int]) -> float | None:
    return round(100.0 * pair[0] / pair[1], 2) if pair[1] else None


def build_items(scope: Scope, cov: dict[str, FileCoverage], m: Matching, entries: Sequence[Entry],
                index: SourceIndex, rerun: str) -> list[Item]:
    items: list[Item] = []
    for name in scope.measured:
        fc = cov[name]
        unjust = [f for f in m.unjustified if f.file == name]
        counts = {k: sum(1 for f in unjust if f.rule == k) for k in KINDS}
        metrics = {"lines": fc.lines, "branches": fc.branches, "mcdc_conditions": fc.mcdc}
        measured = ", ".join(f"{k} {_pct(v)}% ({v[0]}/{v[1]})" for k, v in metrics.items() if v[1]) or "no executable code"
        items.append(Item(
            id=f"coverage:{name}", kind="coverage", verdict="fail" if unjust else "pass",
            expected="every uncovered line, branch and MC/DC condition justified",
            measured=measured + (f"; {len(unjust)} uncovered without justification" if unjust else ""),
            source=name, rerun=rerun,
            data={"lines": {"covered": fc.lines[0], "total": fc.lines[1], "percent": _pct(fc.lines)},
                  "branches": {"covered": fc.branches[0], "total": fc.branches[1], "percent": _pct(fc.branches)},
                  "mcdc_conditions": {"covered": fc.mcdc[0], "total": fc.mcdc[1], "percent": _pct(fc.mcdc)},
                  "unjustified_counts": counts,
                  "unjustified": [describe(f, index) for f in unjust],
                  "justified": [{"finding": describe(f, index), "justification": e.id}
                                for f, e in sorted(m.justified.items()) if f.file == name]}))
    for name, reason in sorted(scope.excluded.items()):
        items.append(Item(id=f"coverage:{name}", kind="coverage", verdict="pass", expected="measured or excluded with a reason",
                          measured="not measured (excluded from the scope)", source=name, rerun=rerun,
                          data={"excluded": reason}))
    items += entry_items(entries, m, index, prefix="coverage-justification", rerun=rerun,
                         expected="explains at least one uncovered item at each of its anchors")
    return items


def summary_markdown(scope: Scope, cov: dict[str, FileCoverage], m: Matching) -> str:
    rows = ["| file | lines | branches | MC/DC conditions | justified | unjustified |", "|---|---|---|---|---|---|"]

    def cell(p: tuple[int, int]) -> str:
        return f"{_pct(p)}% ({p[0]}/{p[1]})" if p[1] else "-"
    for name in scope.measured:
        fc = cov[name]
        just = sum(1 for f in m.justified if f.file == name)
        unj = sum(1 for f in m.unjustified if f.file == name)
        rows.append(f"| {name} | {cell(fc.lines)} | {cell(fc.branches)} | {cell(fc.mcdc)} | {just} | {unj} |")
    tot = [sum(cov[n].lines[i] for n in scope.measured) for i in (0, 1)]
    totb = [sum(cov[n].branches[i] for n in scope.measured) for i in (0, 1)]
    totm = [sum(cov[n].mcdc[i] for n in scope.measured) for i in (0, 1)]
    rows.append(f"| **total** | {cell((tot[0], tot[1]))} | {cell((totb[0], totb[1]))} | {cell((totm[0], totm[1]))} | "
                f"{len(m.justified)} | {len(m.unjustified)} |")
    by_reason: dict[str, list[str]] = defaultdict(list)
    for f, reason in sorted(scope.excluded.items()):
        by_reason[reason].append(f)
    rows += ["", "Excluded from the scope:", ""]
    rows += [f"- {', '.join(files)}: {reason}" for reason, files in by_reason.items()]
    return "\n".join(["# Structural coverage of the firmware and the generated C", "", *rows, ""])


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--root", type=Path, default=ROOT)
    ap.add_argument("--build", type=Path, default=Path("build/coverage"), help="the instrumented builds (mk/quality.mk)")
    ap.add_argument("--justifications", type=Path, default=Path("quality/coverage_justifications.toml"))
    ap.add_argument("--run", default="", help="instrumented test programs to run (space-separated)")
    ap.add_argument("--llvm-objects", default="", help="every clang-instrumented program, for llvm-cov")
    ap.add_argument("--codec-programs", default="", help="directories of codec_driver/unit_tests builds (os.pathsep-separated)")
    ap.add_argument("--codec-compilers", default="", help="compilers those programs are named after")
    ap.add_argument("--clang", default="clang-19")
    ap.add_argument("--llvm-suffix", default="-19")
    ap.add_argument("--gcc-flags", default="", help="instrumentation flags of the gcc build (for the record)")
    ap.add_argument("--clang-flags", default="", help="instrumentation flags of the clang build")
    ap.add_argument("--clang-cflags", default="", help="warning, include and define flags for the MC/DC check")
    ap.add_argument("--fuzz-replay", action="store_true",
                    help="also replay the committed fuzz corpora (tests/fuzz/corpus/) on both instrumented builds")
    ap.add_argument("--no-run", action="store_true", help="analyse the data of the last run again")
    ap.add_argument("--evidence", type=Path, default=None, help="record directory (default build/evidence)")
    args = ap.parse_args(argv)
    root = args.root.resolve()
    build = (root / args.build).resolve()
    jpath = root / args.justifications
    programs, llvm_objects = args.run.split(), args.llvm_objects.split()
    started = time.monotonic()
    try:
        scope = load_scope(jpath, root)
        entries = load_entries(jpath, "justification", rule_key="kinds", default_rules=("*",))
        for e in entries:
            if e.rules != ("*",) and not set(e.rules) <= set(KINDS):
                raise QualityError(f"{jpath}: justification {e.id}: `kinds` must be among {', '.join(KINDS)}")
        if not args.no_run:
            for gcda in build.rglob("*.gcda"):
                gcda.unlink()
            profiles = build / "clang" / "profiles"
            for raw in profiles.glob("*.profraw"):
                raw.unlink()
            profiles.mkdir(parents=True, exist_ok=True)
            env = {**os.environ, "LLVM_PROFILE_FILE": str(profiles / "%m-%p.profraw")}
            run_programs(programs, env, root, build / "logs")
            if args.codec_programs:
                run_codec_tests(args.codec_programs, args.codec_compilers, env, root, build / "logs" / "test_c_codecs.log")
            if args.fuzz_replay:
                replays, clang_replays = fuzz_replays(root, build, [("gcc", "gcc", args.gcc_flags),
                                                                    ("clang", args.clang, args.clang_flags)])
                run_programs(replays, env, root, build / "logs", args=["tests/fuzz/corpus/{name}"])
                llvm_objects += clang_replays
        files = scope.measured
        cov: dict[str, FileCoverage] = defaultdict(FileCoverage)
        index = SourceIndex(root)
        gcc_findings(gcovr_report(root, build / "gcc", files, build) if not args.no_run else
                     json.loads((build / "gcc.json").read_text()), files, cov)
        if llvm_objects:
            data = (llvm_report(root, build / "clang" / "profiles", llvm_objects, files, build, args.llvm_suffix)
                    if not args.no_run else json.loads((build / "clang" / "export.json").read_text()))
            clang_findings(data, root, files, cov, index)
            for f in unmeasured_decisions(root, files, args.clang, args.clang_cflags, args.clang_flags):
                cov[f.file].findings.append(f)
        missing = [f for f in files if f.endswith(".c") and cov[f].lines[1] == 0]
        if missing:
            raise CoverageError("in scope but run by no test program (no gcov data): " + ", ".join(missing) +
                                f"; add them to a test program or exclude them with a reason in {args.justifications}")
    except (CoverageError, QualityError) as exc:
        print(f"coverage: {exc}", file=sys.stderr)
        return 2
    findings = [f for name in files for f in cov[name].findings]
    m = match(findings, entries, index, what=str(args.justifications))
    rerun = "make coverage"
    items = build_items(scope, cov, m, entries, index, rerun)
    tools = {
        "gcc": command_version(["gcc", "--version"]), "gcov": command_version(["gcov", "--version"]),
        "gcovr": package_version("gcovr"), "clang": command_version([args.clang, "--version"]),
        "llvm-cov": command_version([f"llvm-cov{args.llvm_suffix}", "--version"]),
        "llvm-profdata": f"llvm-profdata{args.llvm_suffix} (LLVM of {args.clang})",
    }
    config = {"gcc_flags": args.gcc_flags, "clang_flags": args.clang_flags,
              "gcovr_options": "--no-markers --exclude-unreachable-branches",
              "mcdc_definition": "unique-cause MC/DC with short-circuit don't-cares (llvm-cov, clang 19)",
              "programs": programs, "llvm_objects": llvm_objects,
              "codec_tests": "tests/test_c_codecs.py" if args.codec_programs else "",
              "fuzz_corpus_replay": "tests/fuzz/corpus/<target>/ through tests/fuzz/replay_main.c" if args.fuzz_replay else "",
              "justifications": str(args.justifications), "seconds": round(time.monotonic() - started, 1)}
    write_record("coverage", items, tools, config=config, out_dir=args.evidence)
    summary = summary_markdown(scope, cov, m)
    build.mkdir(parents=True, exist_ok=True)
    (build / "summary.md").write_text(summary)
    for problem in m.problems() + scope.stale:
        print(f"coverage: {problem}", file=sys.stderr)
    for f in m.unjustified:
        print(f"coverage: not covered and not justified: {describe(f, index)}", file=sys.stderr)
    total = [sum(cov[n].lines[i] for n in files) for i in (0, 1)]
    print(f"coverage: {len(files)} files, lines {total[0]}/{total[1]}, {len(m.justified)} uncovered items justified, "
          f"{len(m.unjustified)} unjustified, {len(m.stale) + len(scope.stale)} stale justifications; "
          f"reports in {args.build}/ (summary.md, gcc/index.html, clang/html/index.html)")
    return 0 if m.ok and not scope.stale else 1


if __name__ == "__main__":
    sys.exit(main())
