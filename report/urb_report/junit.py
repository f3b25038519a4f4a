"""Test results as evidence records: pytest's and cmocka's JUnit XML -> build/evidence/<name>.json.

    python3 -m urb_report.junit pytest build/junit/pytest.xml [--name pytest] [--seed N]
    python3 -m urb_report.junit cmocka --name cmocka-node --xml clang=DIR/clang-test_x.xml ... \
        [--log gcc=DIR/gcc-test_x.log ...]

pytest runs with `-o junit_family=xunit1`, whose test cases carry their file, so each item's id is
the pytest node id: `pytest:tests/host/test_cores.py::test_x[param]`. cmocka items are
`cmocka:<group>/<test>` (the group name each test program passes to cmocka_run_group_tests_name).
A cmocka program runs under two compilers: the clang build writes JUnit XML, the gcc build prints
cmocka's standard report (so that CI's log shows it), which `--log` reads; a test passes only when
it passed under every compiler that ran it. A test that was skipped gave no result: its verdict is
"error". The record is written whether the tests passed or not, so that it is never left over
from an earlier run.
"""

from __future__ import annotations

import argparse
import re
import sys
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from .records import ROOT, Item, RecordError, Verdict, package_version, write_record


@dataclass(frozen=True)
class Case:
    suite: str
    name: str
    verdict: Verdict
    message: str
    time_s: float
    file: str = ""
    line: int = 0


def _verdict(case: ET.Element) -> tuple[Verdict, str]:
    for tag, verdict in (("failure", "fail"), ("error", "error"), ("skipped", "error")):
        el = case.find(tag)
        if el is not None:
            text = (el.get("message") or el.text or "").strip().splitlines()
            prefix = "skipped: " if tag == "skipped" else ""
            return verdict, prefix + (text[0][:300] if text else tag)  # type: ignore[return-value]
    return "pass", ""


def read_junit(path: Path) -> list[tuple[ET.Element, ET.Element]]:
    """(testsuite, testcase) pairs of a JUnit file; RecordError when it is missing or not JUnit."""
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as exc:
        raise RecordError(f"{path}: cannot read the JUnit XML ({exc}); did the test run write it?") from exc
    suites = [root] if root.tag == "testsuite" else list(root.iter("testsuite"))
    if root.tag not in ("testsuite", "testsuites"):
        raise RecordError(f"{path}: not JUnit XML (root element <{root.tag}>)")
    return [(s, c) for s in suites for c in s.findall("testcase")]


def pytest_cases(path: Path, root: Path = ROOT) -> list[Case]:
    """pytest's xunit1 JUnit XML -> cases named by node id. The node id's file comes from the
    classname (the longest dotted prefix that is a test file under `root`), since the `file`
    attribute names where the test function is defined, which for hypothesis state machines is
    hypothesis itself; the `file` attribute is the fallback."""
    cases = []
    for _, tc in read_junit(path):
        classname = tc.get("classname") or ""
        parts = classname.split(".") if classname else []
        file, classes = "", []
        for i in range(len(parts), 0, -1):
            candidate = "/".join(parts[:i]) + ".py"
            if (root / candidate).is_file():
                file, classes = candidate, parts[i:]
                break
        if not file:
            file = tc.get("file") or ""
            if not file:
                raise RecordError(f"{path}: test case {classname}.{tc.get('name')} names no test file: run pytest "
                                  "with -o junit_family=xunit1 from the repository root")
            module = file[:-3].replace("/", ".")
            classes = classname[len(module) + 1:].split(".") if classname.startswith(module + ".") else []
        nodeid = "::".join([file, *[c for c in classes if c], tc.get("name") or ""])
        verdict, message = _verdict(tc)
        line = int(tc.get("line") or 0) + 1 if tc.get("file") == file else 0
        cases.append(Case("", nodeid, verdict, message, float(tc.get("time") or 0.0), file, line))
    return cases


def pytest_items(cases: Sequence[Case]) -> list[Item]:
    """One item per node id; a node id reported twice keeps its worst verdict."""
    merged: dict[str, Case] = {}
    rank = {"pass": 0, "error": 1, "fail": 2}
    for c in cases:
        old = merged.get(c.name)
        if old is None or rank[c.verdict] > rank[old.verdict]:
            merged[c.name] = c
    cases = list(merged.values())
    return [Item(id=f"pytest:{c.name}", kind="test", verdict=c.verdict, expected="passes",
                 measured=c.message or "passed", source=f"{c.file}:{c.line}" if c.line else c.file,
                 rerun=f".venv/bin/python -m pytest -q '{c.name}'", data={"time_s": round(c.time_s, 3)})
            for c in cases]


_STD_RESULT = re.compile(r"^\[\s+(OK|FAILED|SKIPPED)\s+\] (\S+)\s*$")
_STD_START = re.compile(r"^\[=+\] Running (\d+) test\(s\)\.")


def cmocka_std_log(path: Path) -> list[dict[str, Verdict]]:
    """cmocka's standard report -> one {test: verdict} per group, in the order the groups ran."""
    try:
        text = path.read_text(errors="replace")
    except OSError as exc:
        raise RecordError(f"{path}: cannot read the cmocka log ({exc})") from exc
    groups: list[dict[str, Verdict]] = []
    for line in text.splitlines():
        if _STD_START.match(line):
            groups.append({})
            continue
        m = _STD_RESULT.match(line)
        if m and groups:
            word, name = m.groups()
            # cmocka prints "[  FAILED  ] name" again in its summary: a failure stays a failure
            if groups[-1].get(name) != "fail":
                groups[-1][name] = {"OK": "pass", "FAILED": "fail"}.get(word, "error")  # type: ignore[assignment]
    return groups


def cmocka_cases(xml: Sequence[tuple[str, Path]], logs: Sequence[tuple[str, Path]]
                 ) -> tuple[list[Case], dict[str, list[str]]]:
    """Merge each program's runs: `xml` pairs a label ("clang:test_x") with a JUnit file (several
    files per program when cmocka wrote one per group), `logs` a label ("gcc:test_x") with a
    standard report; the program name after the colon pairs them, and each group of a report is
    the XML group with the same test names. Returns the cases and, per test, the compilers it ran
    under."""
    merged: dict[tuple[str, str], Case] = {}
    compilers: dict[str, list[str]] = {}
    suites_of: dict[str, dict[str, set[str]]] = {}
    for label, path in xml:
        compiler, _, program = label.partition(":")
        suites = suites_of.setdefault(program, {})
        for suite_el, tc in read_junit(path):
            suite = suite_el.get("name") or program
            suites.setdefault(suite, set()).add(tc.get("name") or "")
            verdict, message = _verdict(tc)
            _merge(merged, compilers, Case(suite, tc.get("name") or "", verdict, message, float(tc.get("time") or 0.0)),
                   compiler)
    for label, path in logs:
        compiler, _, program = label.partition(":")
        found = suites_of.get(program)
        if found is None:
            raise RecordError(f"{path}: no JUnit XML of program {program} to name its cmocka groups; pass --xml for it")
        suites = found
        groups = cmocka_std_log(path)
        if len(groups) != len(suites):
            raise RecordError(f"{path}: {len(groups)} cmocka groups ran under {compiler}, the XML of {program} has "
                              f"{len(suites)}: did the run stop early? see the log")
        for results in groups:
            names = [s for s, tests in suites.items() if tests == set(results)]
            if len(names) != 1:
                raise RecordError(f"{path}: a group ran {sorted(results)} under {compiler}, which matches "
                                  f"{len(names)} groups of the XML: the two builds differ")
            for name, verdict in results.items():
                _merge(merged, compilers, Case(names[0], name, verdict, "" if verdict == "pass" else f"{verdict}", 0.0),
                       compiler)
    return list(merged.values()), compilers


def _merge(merged: dict[tuple[str, str], Case], compilers: dict[str, list[str]], case: Case, compiler: str) -> None:
    key = (case.suite, case.name)
    compilers.setdefault(f"{case.suite}/{case.name}", []).append(compiler)
    old = merged.get(key)
    if old is None or (old.verdict == "pass" and case.verdict != "pass"):
        merged[key] = Case(case.suite, case.name, case.verdict,
                           case.message if case.verdict == "pass" else f"{case.message} ({compiler})".strip(),
                           max(case.time_s, old.time_s if old else 0.0))


def cmocka_items(cases: Sequence[Case], compilers: dict[str, list[str]], sources: dict[str, str],
                 rerun: str) -> list[Item]:
    items = []
    for c in sorted(cases, key=lambda c: (c.suite, c.name)):
        key = f"{c.suite}/{c.name}"
        items.append(Item(id=f"cmocka:{key}", kind="test", verdict=c.verdict, expected="passes under " + ", ".join(
            sorted(set(compilers.get(key, [])))), measured=c.message or "passed", source=sources.get(c.suite, ""),
            rerun=rerun, data={"compilers": sorted(set(compilers.get(key, [])))}))
    return items


_GROUP = re.compile(r'cmocka_run_group_tests_name\(\s*"([A-Za-z0-9_]+)"')


def cmocka_group_sources(root: Path = ROOT) -> dict[str, str]:
    """Each cmocka group name -> the test file (repository-relative) that runs it."""
    out = {}
    for path in sorted((root / "tests").rglob("*.c")):
        for m in _GROUP.finditer(path.read_text(errors="replace")):
            out[m.group(1)] = str(path.relative_to(root))
    return out


def _labelled(values: Sequence[str], option: str) -> list[tuple[str, Path]]:
    out = []
    for v in values:
        label, sep, path = v.partition("=")
        if not sep or ":" not in label:
            raise RecordError(f"{option} {v!r}: expected COMPILER:PROGRAM=PATH, e.g. clang:test_i2c=build/x.xml")
        out.append((label, Path(path)))
    return out


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python3 -m urb_report.junit", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="kind", required=True)
    p = sub.add_parser("pytest", help="pytest's xunit1 JUnit XML -> build/evidence/<name>.json")
    p.add_argument("xml", type=Path)
    p.add_argument("--name", default="pytest")
    p.add_argument("--seed", default=None, help="the --hypothesis-seed the run used")
    p.add_argument("--args", default="", help="the pytest command line, for the record's configuration")
    c = sub.add_parser("cmocka", help="cmocka JUnit XML and standard reports -> build/evidence/<name>.json")
    c.add_argument("--name", required=True)
    c.add_argument("--xml", action="append", default=[], metavar="COMPILER:PROGRAM=PATH")
    c.add_argument("--log", action="append", default=[], metavar="COMPILER:PROGRAM=PATH")
    c.add_argument("--rerun", default="", help="the command that reruns these tests")
    c.add_argument("--tool", action="append", default=[], metavar="NAME=VERSION")
    args = ap.parse_args(argv)
    try:
        if args.kind == "pytest":
            cases = pytest_cases(args.xml)
            if not cases:
                raise RecordError(f"{args.xml}: no test cases; an empty run proves nothing")
            import platform

            tools = {"pytest": package_version("pytest"), "pytest-xdist": package_version("pytest-xdist"),
                     "hypothesis": package_version("hypothesis"), "Python": platform.python_version()}
            out = write_record("pytest", pytest_items(cases), tools, name=args.name,
                               config={"command": args.args, "junit": str(args.xml)}, seed=args.seed)
        else:
            ccases, compilers = cmocka_cases(_labelled(args.xml, "--xml"), _labelled(args.log, "--log"))
            if not ccases:
                raise RecordError("no cmocka test cases in the given files; an empty run proves nothing")
            sources = cmocka_group_sources()
            tools = dict(t.split("=", 1) for t in args.tool)
            tools.setdefault("cmocka", _cmocka_version())
            out = write_record("cmocka", cmocka_items(ccases, compilers, sources, args.rerun), tools, name=args.name,
                               config={"xml": args.xml, "logs": args.log})
    except RecordError as exc:
        print(f"urb_report.junit: {exc}", file=sys.stderr)
        return 2
    print(f"evidence: {out.relative_to(Path.cwd()) if out.is_relative_to(Path.cwd()) else out}")
    return 0


def _cmocka_version() -> str:
    """The Debian package's version of the cmocka library the tests link."""
    import subprocess

    proc = subprocess.run(["dpkg-query", "-W", "-f=${Version}", "libcmocka-dev"], capture_output=True, text=True,
                          check=False)
    return f"libcmocka-dev {proc.stdout.strip()}" if proc.returncode == 0 and proc.stdout.strip() else "not found"


if __name__ == "__main__":
    sys.exit(main())
