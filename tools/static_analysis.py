#!/usr/bin/env python3
"""Static analysis of the shipped firmware and the generated C (`make static`; quality/README.md).

Two analyzers, over the files and the target configuration that `make misra` checks:
  * clang-tidy 19 (Debian's clang-tidy-19) with the checks clang-analyzer-* (the Clang Static
    Analyzer: path-sensitive null dereference, uninitialised reads, dead stores, division by zero,
    out-of-bounds and more), bugprone-* and cert-* (those that apply to C), minus
    bugprone-easily-swappable-parameters (a naming heuristic about adjacent parameters of one type,
    not a defect; the libraries' (node, n, k) signatures would all be reported). It parses for the
    target: --target=armv6m-none-eabi with newlib's headers.
  * gcc -fanalyzer (arm-none-eabi-gcc 12, the compiler of the images, -Os as they are built):
    interprocedural path analysis within each file (null dereference, use of uninitialised values,
    leaks, double free, out-of-bounds shifts and more).
Every finding must be explained by a deviation in quality/static_deviations.toml (same format and
anchors as the MISRA deviations, `rule` = "<tool>/<check>"), and every deviation must still match a
finding. Record: build/evidence/static.json, one `static:<tool>/<check>@<file>:<line>` item per
finding and one `static-deviation:<id>` item per deviation.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shlex
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any, Sequence

from urb_report.quality import (Finding, QualityError, SourceIndex, describe, entry_items, finding_items,
                                load_entries, match)
from urb_report.records import command_version, write_record

ROOT = Path(__file__).resolve().parents[1]
TIDY_CHECKS = "-*,clang-analyzer-*,bugprone-*,cert-*,-bugprone-easily-swappable-parameters"
TIDY_LINE = re.compile(r"^(?P<file>[^:\s][^:]*):(?P<line>\d+):(?P<col>\d+): (?P<sev>warning|error): "
                       r"(?P<msg>.*) \[(?P<checks>[\w.,-]+)\]$")


def _rel(root: Path, name: str) -> str:
    p = Path(name)
    p = p if p.is_absolute() else root / p
    try:
        return p.resolve().relative_to(root.resolve()).as_posix()
    except ValueError:
        return p.as_posix()


def run_clang_tidy(root: Path, sources: Sequence[str], tidy: str, cflags: str, jobs: int) -> list[Finding]:
    """clang-tidy's warnings in repository files (the first check name of each, e.g. cert-dcl37-c's
    alias bugprone-reserved-identifier). A compiler error is a broken configuration, not a finding."""
    def one(src: str) -> str:
        proc = subprocess.run([tidy, "--quiet", f"--checks={TIDY_CHECKS}", "--header-filter=.*", src, "--",
                               *shlex.split(cflags)], cwd=root, capture_output=True, text=True, check=False)
        if re.search(r"^\S+: error: ", proc.stdout, re.M) or proc.returncode not in (0, 1):
            raise QualityError(f"clang-tidy cannot analyse {src} as configured:\n{(proc.stdout + proc.stderr)[-2000:]}")
        return proc.stdout

    with ThreadPoolExecutor(max_workers=jobs) as pool:
        outputs = list(pool.map(one, sources))
    findings: set[Finding] = set()
    for out in outputs:
        for line in out.splitlines():
            m = TIDY_LINE.match(line)
            if not m:
                continue
            file = _rel(root, m["file"])
            if file.startswith("/"):
                continue  # a system header
            check = m["checks"].split(",")[0]
            findings.add(Finding(file, int(m["line"]), f"clang-tidy/{check}", int(m["col"]), m["msg"]))
    return sorted(findings)


def run_gcc_analyzer(root: Path, sources: Sequence[str], gcc: str, cflags: str, jobs: int) -> list[Finding]:
    """gcc -fanalyzer's diagnostics (JSON), each under its -W option (e.g. -Wanalyzer-null-dereference)."""
    def one(src: str) -> list[dict[str, Any]]:
        proc = subprocess.run([gcc, *shlex.split(cflags), "-fanalyzer", "-fdiagnostics-format=json", "-c", src,
                               "-o", os.devnull], cwd=root, capture_output=True, text=True, check=False)
        try:
            diags: list[dict[str, Any]] = json.loads(proc.stderr or "[]")
        except json.JSONDecodeError as exc:
            raise QualityError(f"{gcc} -fanalyzer printed no JSON for {src}:\n{proc.stderr[-2000:]}") from exc
        if proc.returncode != 0 and not any(d.get("kind") == "warning" for d in diags):
            raise QualityError(f"{gcc} cannot compile {src} as configured:\n{proc.stderr[-2000:]}")
        return diags

    with ThreadPoolExecutor(max_workers=jobs) as pool:
        results = list(pool.map(one, sources))
    findings: set[Finding] = set()
    for diags in results:
        for d in diags:
            if d.get("kind") not in ("warning", "error"):
                continue
            caret = (d.get("locations") or [{}])[0].get("caret", {})
            option = d.get("option") or d.get("kind", "diagnostic")
            file = _rel(root, caret.get("file", "?"))
            findings.add(Finding(file, int(caret.get("line", 0)), f"gcc-analyzer/{option.lstrip('-')}",
                                 int(caret.get("column", 0)), str(d.get("message", ""))))
    return sorted(findings)


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--root", type=Path, default=ROOT)
    ap.add_argument("--sources", required=True, help="the C files to analyse (space-separated, repository paths)")
    ap.add_argument("--tidy", default="clang-tidy-19")
    ap.add_argument("--tidy-cflags", default="", help="target, standard, defines and include directories for clang-tidy")
    ap.add_argument("--gcc", default="arm-none-eabi-gcc")
    ap.add_argument("--gcc-cflags", default="", help="target, optimisation, defines and include directories for gcc")
    ap.add_argument("--deviations", type=Path, default=Path("quality/static_deviations.toml"))
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--evidence", type=Path, default=None, help="record directory (default build/evidence)")
    args = ap.parse_args(argv)
    root = args.root.resolve()
    sources = args.sources.split()
    started = time.monotonic()
    try:
        entries = load_entries(root / args.deviations, "deviation", rule_key="rule")
        findings = run_clang_tidy(root, sources, args.tidy, args.tidy_cflags, args.jobs)
        findings += run_gcc_analyzer(root, sources, args.gcc, args.gcc_cflags, args.jobs)
    except QualityError as exc:
        print(f"static: {exc}", file=sys.stderr)
        return 2
    index = SourceIndex(root)
    m = match(findings, entries, index, what=str(args.deviations))
    rerun = "make static"
    items = finding_items(findings, m, index, prefix="static", rerun=rerun,
                          expected="no finding, or a deviation in quality/static_deviations.toml explains it")
    items += entry_items(entries, m, index, prefix="static-deviation", rerun=rerun,
                         expected="explains at least one finding at each of its anchors")
    tools = {"clang-tidy": command_version([args.tidy, "--version"]) + f" ({args.tidy})",
             "gcc": command_version([args.gcc, "--version"])}
    config = {"sources": sources, "clang_tidy_checks": TIDY_CHECKS, "clang_tidy_flags": args.tidy_cflags,
              "gcc_flags": args.gcc_cflags + " -fanalyzer", "deviations": str(args.deviations),
              "findings": len(findings), "seconds": round(time.monotonic() - started, 1)}
    write_record("static", items, tools, config=config, out_dir=args.evidence)
    for problem in m.problems():
        print(f"static: {problem}", file=sys.stderr)
    for f in m.unjustified:
        print(f"static: finding without a deviation: {describe(f, index)}", file=sys.stderr)
    print(f"static: {len(sources)} files, clang-tidy and gcc -fanalyzer: {len(findings)} findings, "
          f"{len(m.justified)} deviated, {len(m.unjustified)} without a deviation, {len(m.stale)} stale deviations")
    return 0 if m.ok else 1


if __name__ == "__main__":
    sys.exit(main())
