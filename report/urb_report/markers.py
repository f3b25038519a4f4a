"""Source markers: comments `lobster-trace: urb.MBX_001` in C, Python and TLA+ that point from code,
tests and models back to the requirements they implement or verify.

A marker is a comment of its file's language (C `/* ... */` or `//`, Python `#`, TLA+ `\\*` or
`(* ... *)`); several requirements may follow, separated by commas. It belongs to the function,
test or TLA+ operator it stands in or directly above. What that item is decides its evidence id,
which the gate compares with the requirements' `verified_by` lists:

| file | item | evidence id |
|---|---|---|
| tests/**/test_*.py | the test function (class) | pytest:<file>::<Class>::<test> |
| tests/**/*.c with a cmocka group | the test function | cmocka:<group>/<function> |
| tests/fuzz/fuzz_<target>.c | the file | fuzz:fuzz_<target> |
| proofs/bmc/<folder>/harness.c | the file | bmc:<folder> |
| spec/tla/<Module>.tla | the operator defined next | tla:<Module>.<Operator> |
| anything else | the function (or file) | none: an implementation marker |

Implementation markers (firmware, host library, code generator, simulation) become LOBSTER
implementation items; the others become activity items.
"""

from __future__ import annotations

import ast
import re
import subprocess
from dataclasses import dataclass
from pathlib import Path

from .records import ROOT

LANGUAGES = {".c": "C", ".h": "C", ".py": "Python", ".tla": "TLA+"}
MARKER_WORD = "lobster-trace:"
_TAGS = r"(urb\.[A-Za-z0-9_]+(?:\s*,\s*urb\.[A-Za-z0-9_]+)*)"
_COMMENT = {
    "C": re.compile(r"(?:/\*|//|^\s*\*)\s*lobster-trace:\s*" + _TAGS),
    "Python": re.compile(r"#\s*lobster-trace:\s*" + _TAGS),
    "TLA+": re.compile(r"(?:\\\*|\(\*|^\s*\*)\s*lobster-trace:\s*" + _TAGS),
}
_C_FUNCTION = re.compile(r"^(?:static\s+|inline\s+|extern\s+)*[A-Za-z_][\w\s\*]*?\b([A-Za-z_]\w*)\s*\([^;]*$")
_C_GROUP = re.compile(r'cmocka_run_group_tests_name\(\s*"([A-Za-z0-9_]+)"')
_TLA_DEF = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)\s*(?:\([^)]*\))?\s*==")


@dataclass(frozen=True)
class Marker:
    file: str                  # repository-relative
    line: int
    language: str
    requirements: tuple[str, ...]   # tags as written, e.g. ("urb.MBX_001",)
    item: str                  # the function, test or operator it belongs to ("" for the file)
    evidence: str              # the evidence id it gives ("" for an implementation marker)

    @property
    def is_activity(self) -> bool:
        return bool(self.evidence)


def source_files(root: Path = ROOT) -> list[Path]:
    """The tracked (and new, not ignored) C, Python and TLA+ files of the repository, generated code
    and the report's own test fixtures excluded."""
    proc = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard"], cwd=root,
                          capture_output=True, text=True, check=False)
    names = proc.stdout.split() if proc.returncode == 0 else [
        str(p.relative_to(root)) for p in root.rglob("*") if p.is_file()]
    out = []
    for name in sorted(set(names)):
        if Path(name).suffix not in LANGUAGES or name.startswith(("gen/", "build/", ".venv/", "tests/report/")):
            continue
        p = root / name
        if p.is_file():
            out.append(p)
    return out


def scan(files: list[Path] | None = None, root: Path = ROOT) -> list[Marker]:
    """Every marker in `files` (default: source_files()), in file and line order."""
    markers: list[Marker] = []
    for path in files if files is not None else source_files(root):
        try:
            text = path.read_text(encoding="utf-8", errors="replace")
        except OSError:
            continue
        if MARKER_WORD not in text:
            continue
        markers.extend(scan_text(_rel(path, root), text))
    return markers


def scan_text(rel: str, text: str) -> list[Marker]:
    """The markers of one file whose repository-relative path is `rel`."""
    language = LANGUAGES.get(Path(rel).suffix, "")
    pattern = _COMMENT.get(language)
    if pattern is None:
        return []
    lines = text.splitlines()
    owner = _owners(rel, language, text, lines)
    out = []
    for i, line in enumerate(lines, 1):
        m = pattern.search(line)
        if not m:
            continue
        tags = tuple(t.strip() for t in m.group(1).split(","))
        item = owner(i)
        out.append(Marker(rel, i, language, tags, item, _evidence(rel, language, item, text)))
    return out


def _rel(path: Path, root: Path) -> str:
    try:
        return str(path.resolve().relative_to(root.resolve()))
    except ValueError:
        return str(path)


def _owners(rel: str, language: str, text: str, lines: list[str]):  # type: ignore[no-untyped-def]
    """A function: marker line -> the item the marker belongs to."""
    if language == "Python":
        return _python_owner(text, lines)
    if language == "TLA+":
        starts = [(i, m.group(1)) for i, l in enumerate(lines, 1) if (m := _TLA_DEF.match(l))]
        return lambda line: _next_start(starts, lines, line, ("\\*", "(*", "*"))
    starts = [(i, m.group(1)) for i, l in enumerate(lines, 1)
              if (m := _C_FUNCTION.match(l)) and m.group(1) not in ("if", "for", "while", "switch", "return")]
    return lambda line: _next_start(starts, lines, line, ("/*", "*", "//")) or _enclosing(starts, line)


def _next_start(starts: list[tuple[int, str]], lines: list[str], line: int, comment: tuple[str, ...]) -> str:
    """The item starting after `line` when only comment lines (or blank ones) stand between."""
    for start, name in starts:
        if start > line:
            between = lines[line:start - 1]
            if all(not l.strip() or l.strip().startswith(comment) for l in between):
                return name
            return ""
    return ""


def _enclosing(starts: list[tuple[int, str]], line: int) -> str:
    """The last item starting before `line` (a marker inside a C function's body)."""
    before = [name for start, name in starts if start < line]
    return before[-1] if before else ""


def _python_owner(text: str, lines: list[str]):  # type: ignore[no-untyped-def]
    """Marker line -> "Class::function" or "function": the innermost definition whose span (comment
    lines directly above and decorators included) holds the line."""
    try:
        tree = ast.parse(text)
    except SyntaxError:
        return lambda line: ""
    spans: list[tuple[int, int, str]] = []

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                name = f"{prefix}::{child.name}" if prefix else child.name
                first = min([child.lineno, *[d.lineno for d in child.decorator_list]])
                while first > 1 and lines[first - 2].strip().startswith("#"):
                    first -= 1
                spans.append((first, child.end_lineno or child.lineno, name))
                visit(child, name)

    visit(tree, "")
    spans.sort(key=lambda s: s[1] - s[0])

    def owner(line: int) -> str:
        for first, last, name in spans:
            if first <= line <= last:
                return name
        return ""
    return owner


def _evidence(rel: str, language: str, item: str, text: str) -> str:
    """The evidence id of the item a marker belongs to, or "" for implementation code."""
    parts = Path(rel).parts
    if language == "Python" and parts[0] == "tests" and Path(rel).name.startswith("test_") and item:
        return f"pytest:{rel}::{item}"
    if language == "C" and parts[0] == "tests":
        if parts[:2] == ("tests", "fuzz") and Path(rel).stem.startswith("fuzz_"):
            return f"fuzz:{Path(rel).stem}"
        group = _C_GROUP.search(text)
        if group and item:
            return f"cmocka:{group.group(1)}/{item}"
    if language == "C" and parts[:2] == ("proofs", "bmc") and len(parts) == 4 and parts[3] == "harness.c":
        return f"bmc:{parts[2]}"
    if language == "TLA+" and parts[:2] == ("spec", "tla") and len(parts) == 3 and item:
        return f"tla:{Path(rel).stem}.{item}"
    return ""
