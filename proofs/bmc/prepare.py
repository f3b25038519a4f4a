#!/usr/bin/env python3
"""Prepare the sources one BMC proof runs on: a copy under build/, cost-instrumented, maybe mutated.

    prepare.py --out DIR --dir gen/c [--dir firmware/node ...] [--mutants mutants.json --mutant NAME]
               [--stub FUNCTION ...] [--views views.json]

Copies every *.c and *.h of each --dir (paths relative to the repository root) to DIR/<dir>/ and
then, in the copies only:

1. applies the seeded bug NAME from the proof's mutants.json (a literal find/replace inside one
   function of one file, or anywhere in the file when "function" is empty, for data such as a CRC
   table; an entry that no longer matches is an error, so mutants never go stale silently);
2. removes the definition of each --stub FUNCTION (the proof links a stub from proofs/bmc/stubs
   instead; the stub's contract is what that function's own proof establishes);
3. inserts the cost counter: `URB_COST(n);` at every function entry (call overhead plus a small
   allowance per statement outside loops) and at the top of every loop body (cycles per iteration
   of the enclosing function), with n from proofs/bmc/cost_model.json, and `#include "urb_verify.h"`
   at the top of each .c file. URB_COST expands to nothing unless URB_PROOF_COST is defined;
4. applies the proof's views (views.json): rewrites for checker limits that keep the meaning of the
   code, e.g. a store through a variable index split into constant-index cases, each entry with its
   "why" (the same find/replace rule as a mutant, on the instrumented copy).

The instrumentation is textual and relies on the house style of generated and firmware C: function
definitions start in column 0 and their body braces sit alone in column 0 (or end the signature
line); loop headers `for (...) {`, `while (...) {` and `do {` fit on one line.
Exit status: 0 done, 2 bad arguments or a mutant or view that does not apply.
"""

from __future__ import annotations

import argparse
import fnmatch
import json
import re
import shutil
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
COST_MODEL = Path(__file__).resolve().parent / "cost_model.json"
STATEMENT_CYCLES = 3  # allowance per straight-line statement (compare, store, branch)

_LOOP_RE = re.compile(r"^(\s*)(for|while)\s*\(.*\)\s*\{\s*(//.*)?$|^(\s*)do\s*\{\s*$")
_FUNC_START_RE = re.compile(r"^[A-Za-z_][\w\s\*]*\b([A-Za-z_]\w*)\s*\([^;]*\)\s*(\{)?\s*$")


class PrepareError(Exception):
    """A mutant that does not apply, or a source that cannot be instrumented."""


@dataclass(frozen=True)
class CostModel:
    call: int
    loop_default: int
    loops: dict[str, int]

    def loop_cycles(self, function: str) -> int:
        if function in self.loops:
            return self.loops[function]
        for pattern, cycles in self.loops.items():
            if fnmatch.fnmatchcase(function, pattern):
                return cycles
        return self.loop_default


def load_cost_model(path: Path = COST_MODEL) -> CostModel:
    data: dict[str, Any] = json.loads(path.read_text(encoding="utf-8"))
    return CostModel(int(data["call"]), int(data["loop_default"]), {str(k): int(v) for k, v in data["loops"].items()})


# --------------------------------------------------------------------------- function spans


def function_spans(lines: list[str]) -> dict[str, tuple[int, int, int]]:
    """name -> (signature line, opening brace line, closing brace line), 0-based, for definitions."""
    spans: dict[str, tuple[int, int, int]] = {}
    i = 0
    in_comment = False
    while i < len(lines):
        line = lines[i]
        if in_comment:
            in_comment = "*/" not in line
            i += 1
            continue
        if line.lstrip().startswith("/*") and "*/" not in line:
            in_comment = True
            i += 1
            continue
        m = _FUNC_START_RE.match(line)
        if m and not line.startswith(("#", " ", "\t", "return", "else", "typedef")):
            name = m.group(1)
            if m.group(2):
                open_line = i
            elif i + 1 < len(lines) and lines[i + 1].rstrip() == "{":
                open_line = i + 1
            else:
                i += 1
                continue
            close_line = next((j for j in range(open_line + 1, len(lines)) if lines[j].rstrip() == "}"), None)
            if close_line is None:
                raise PrepareError(f"function {name}: no closing brace in column 0")
            spans[name] = (i, open_line, close_line)
            i = close_line + 1
            continue
        i += 1
    return spans


# --------------------------------------------------------------------------- mutation


_COMMENT_RE = re.compile(r"/\*.*?\*/|//[^\n]*", re.DOTALL)


def apply_mutant(root: Path, mutant: dict[str, Any]) -> None:
    """Applies one mutants.json entry to the copy under `root` (in place)."""
    _rewrite(root, mutant, f"mutant {mutant['name']}", "update mutants.json")


def apply_views(root: Path, views: list[dict[str, Any]]) -> None:
    """Applies every views.json entry, in order, to the copy under `root` (in place)."""
    for i, view in enumerate(views):
        _rewrite(root, view, f"view {i + 1} ({view.get('function') or view['file']})", "update views.json")


def _rewrite(root: Path, entry: dict[str, Any], what: str, remedy: str) -> None:
    """The literal find/replace of a mutant or view entry: the n-th occurrence, in code, inside one
    function (or anywhere in the file when "function" is empty)."""
    path = root / str(entry["file"])
    if not path.is_file():
        raise PrepareError(f"{what}: no file {entry['file']} in the prepared sources")
    text = path.read_text(encoding="utf-8")
    lines = text.split("\n")
    function = str(entry.get("function") or "")
    if function:
        spans = function_spans(lines)
        if function not in spans:
            raise PrepareError(f"{what}: no function {function} in {entry['file']}")
        _, open_line, close_line = spans[function]
        start = sum(len(line) + 1 for line in lines[:open_line])
        end = sum(len(line) + 1 for line in lines[: close_line + 1])
    else:  # file-level data, e.g. a table
        start, end = 0, len(text)
        function = str(entry["file"])
    body = text[start:end]
    find, replace = str(entry["find"]), str(entry["replace"])
    occurrence = int(entry.get("occurrence", 1))
    at = -1
    for _ in range(occurrence):
        at = body.find(find, at + 1)
        if at < 0:
            raise PrepareError(
                f"{what}: occurrence {occurrence} of {find!r} not found in {function}; "
                f"the code changed: regenerate the proof folders (proofs/bmc/generate.py) or {remedy}"
            )
    if any(m.start() <= at < m.end() for m in _COMMENT_RE.finditer(body)):
        raise PrepareError(
            f"{what}: occurrence {occurrence} of {find!r} in {function} is inside a comment "
            "(e.g. an ACSL annotation), so it would change nothing; make `find` match the code"
        )
    body = body[:at] + replace + body[at + len(find):]
    path.write_text(text[:start] + body + text[end:], encoding="utf-8")


def load_mutant(mutants_file: Path, name: str) -> dict[str, Any]:
    entries: list[dict[str, Any]] = json.loads(mutants_file.read_text(encoding="utf-8"))
    for entry in entries:
        if entry["name"] == name:
            return entry
    known = ", ".join(str(e["name"]) for e in entries) or "none"
    raise PrepareError(f"no mutant {name} in {mutants_file} (known: {known})")


def remove_function(root: Path, dirs: list[str], name: str) -> None:
    """Deletes the definition of `name` from the prepared copies: a stub under proofs/bmc/stubs replaces it."""
    for rel in dirs:
        for path in sorted((root / rel).glob("*.c")):
            lines = path.read_text(encoding="utf-8").split("\n")
            spans = function_spans(lines)
            if name in spans:
                start, _, end = spans[name]
                path.write_text("\n".join([*lines[:start], f"/* {name}: replaced by a stub (proofs/bmc/stubs) */",
                                           *lines[end + 1:]]), encoding="utf-8")
                return
    raise PrepareError(f"cannot stub {name}: no definition in {', '.join(dirs)}")


# --------------------------------------------------------------------------- instrumentation


def _strip_comments(line: str, in_comment: bool) -> tuple[str, bool]:
    """The code part of `line` (comments removed) and whether a block comment continues."""
    out = ""
    i = 0
    while i < len(line):
        if in_comment:
            end = line.find("*/", i)
            if end < 0:
                return out, True
            i = end + 2
            in_comment = False
        elif line.startswith("/*", i):
            in_comment = True
            i += 2
        elif line.startswith("//", i):
            break
        else:
            out += line[i]
            i += 1
    return out, in_comment


def instrument(text: str, model: CostModel) -> str:
    """Inserts URB_COST at function entries and loop bodies (see the module doc)."""
    lines = text.split("\n")
    spans = function_spans(lines)
    inserts: dict[int, str] = {}  # line index -> text inserted after it
    for name, (_, open_line, close_line) in spans.items():
        stack: list[bool] = []  # one entry per open brace inside the body: True for a loop body
        statements = 0
        in_comment = False
        for j in range(open_line + 1, close_line):
            code, in_comment = _strip_comments(lines[j], in_comment)
            loop = _LOOP_RE.match(code) if code.strip() else None
            if loop:
                indent = (loop.group(1) or loop.group(4) or "") + "    "
                inserts[j] = f"{indent}URB_COST({model.loop_cycles(name)}u);"
            elif not any(stack) and code.rstrip().endswith(";"):
                statements += 1
            opens = code.count("{")
            for ch in code:
                if ch == "{":
                    opens -= 1
                    stack.append(bool(loop) and opens == 0)  # the loop header's own brace is its last
                elif ch == "}" and stack:
                    stack.pop()
        inserts[open_line] = f"    URB_COST({model.call + STATEMENT_CYCLES * statements}u); /* {name}: entry */"
    out: list[str] = ['#include "urb_verify.h" /* proof build: cost counter (proofs/bmc/prepare.py) */']
    for j, line in enumerate(lines):
        out.append(line)
        if j in inserts:
            out.append(inserts[j])
    return "\n".join(out)


# --------------------------------------------------------------------------- driver


def prepare(out: Path, dirs: list[str], mutants_file: Path | None, mutant: str | None,
            model: CostModel | None = None, stubbed: list[str] | None = None, views_file: Path | None = None) -> Path:
    """Builds the prepared tree under `out` (replacing it) and returns it."""
    model = model or load_cost_model()
    if out.exists():
        shutil.rmtree(out)
    for rel in dirs:
        src = ROOT / rel
        if not src.is_dir():
            raise PrepareError(f"source folder {rel} does not exist")
        dst = out / rel
        dst.mkdir(parents=True, exist_ok=True)
        for f in sorted(src.iterdir()):
            if f.is_file() and f.suffix in (".c", ".h"):
                shutil.copyfile(f, dst / f.name)
    if mutant:
        if mutants_file is None:
            raise PrepareError("--mutant needs --mutants")
        apply_mutant(out, load_mutant(mutants_file, mutant))
    for name in stubbed or []:
        remove_function(out, dirs, name)
    for rel in dirs:
        for f in sorted((out / rel).glob("*.c")):
            f.write_text(instrument(f.read_text(encoding="utf-8"), model), encoding="utf-8")
    if views_file is not None:
        apply_views(out, json.loads(views_file.read_text(encoding="utf-8")))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, required=True, help="folder to (re)create")
    ap.add_argument("--dir", action="append", default=[], help="source folder relative to the repository root")
    ap.add_argument("--mutants", type=Path, help="the proof's mutants.json")
    ap.add_argument("--mutant", help="name of the seeded bug to apply")
    ap.add_argument("--stub", action="append", default=[], help="function whose definition a stub replaces")
    ap.add_argument("--views", type=Path, help="the proof's views.json (rewrites for checker limits)")
    args = ap.parse_args(argv)
    if not args.dir:
        print("prepare.py: give at least one --dir", file=sys.stderr)
        return 2
    try:
        prepare(args.out, args.dir, args.mutants, args.mutant or None, stubbed=args.stub, views_file=args.views)
    except PrepareError as e:
        print(f"prepare.py: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
