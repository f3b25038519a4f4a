#!/usr/bin/env python3
"""Cross-reference the TLA+ actions and the C that implements them.

The firmware cites the action it implements in a comment (`/* MailboxInbox.tla: IsrWriteBegin */`).
This tool checks both directions: every citation names an operator the module defines, and every
action of the modules the firmware implements line by line is cited somewhere. `--table` prints the
correspondence table that spec/tla/README.md carries.
"""

from __future__ import annotations

import argparse
import re
import sys
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
TLA_DIR = REPO / "spec" / "tla"
C_DIRS = [REPO / "firmware"]
CITATION = re.compile(r"\b([A-Z]\w*)\.tla: ([A-Z]\w*)")
DEFINITION = re.compile(r"^([A-Z]\w*)\s*(\([^)]*\))?\s*==", re.MULTILINE)
NEXT_STATE = re.compile(r"\[\]\[\s*([A-Z]\w*)\s*\]_")  # [][Next]_vars

# Modules whose every action must have a C counterpart, and the actions done by application code
# through the locked buffer pointer (not by the library).
LINE_BY_LINE = {
    "MailboxOutbox": {"AppWriteByte"},
    "MailboxInbox": {"AppReadByte"},
}


@dataclass(frozen=True)
class Citation:
    module: str
    action: str
    path: Path
    line: int


def definitions(module: str) -> dict[str, str]:
    """Operator name -> body text for one module."""
    text = (TLA_DIR / f"{module}.tla").read_text()
    matches = list(DEFINITION.finditer(text))
    out: dict[str, str] = {}
    for m, nxt in zip(matches, [*matches[1:], None]):
        out[m.group(1)] = text[m.end(): nxt.start() if nxt else len(text)]
    return out


def actions(module: str) -> list[str]:
    """The actions of every next-state relation a specification of the module uses (`[][Next]_vars`,
    and Bridge.tla's ReconnectNext, ResetNext and RestartNext): operators they name that change
    state (have primes), found by expanding the ones that only combine others (IsrNext, AppNext,
    ...)."""
    defs = definitions(module)
    out: list[str] = []

    def expand(name: str, seen: set[str]) -> None:
        if name in seen:
            return
        seen.add(name)
        body = _uncommented(defs[name])
        if "'" in body and name not in roots:
            if name not in out:
                out.append(name)
            return
        for ident in re.findall(r"\b[A-Z]\w*\b", body):
            if ident in defs:
                expand(ident, seen)

    roots = [m.group(1) for body in defs.values() for m in NEXT_STATE.finditer(_uncommented(body))]
    for root in dict.fromkeys(roots):
        expand(root, set())
    return out


def _uncommented(tla: str) -> str:
    return re.sub(r"\(\*.*?\*\)|\\\*[^\n]*", "", tla, flags=re.DOTALL)


def _shown(path: Path) -> str:
    return str(path.relative_to(REPO)) if path.is_relative_to(REPO) else str(path)


def citations() -> list[Citation]:
    """Every `Module.tla: Action` citation in the C sources."""
    out: list[Citation] = []
    for root in C_DIRS:
        for path in sorted([*root.rglob("*.c"), *root.rglob("*.h")]):
            for i, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
                out.extend(Citation(m.group(1), m.group(2), path, i) for m in CITATION.finditer(line))
    return out


def problems() -> list[str]:
    """Citations of undefined operators, and line-by-line actions nobody implements."""
    found = citations()
    defs = {p.stem: definitions(p.stem) for p in TLA_DIR.glob("*.tla")}
    out = [
        f"{_shown(c.path)}:{c.line}: cites {c.module}.tla: {c.action}, which "
        + ("the module does not define" if c.module in defs else "is not a module in spec/tla")
        for c in found if c.action not in defs.get(c.module, {})
    ]
    for module, by_app in LINE_BY_LINE.items():
        cited = {c.action for c in found if c.module == module}
        for action in actions(module):
            if action not in cited and action not in by_app:
                out.append(f"spec/tla/{module}.tla: action {action} has no C counterpart citing it")
    return out


def table() -> str:
    """Markdown table: module, action, C files citing it (files, not lines, so edits keep it valid)."""
    where: dict[tuple[str, str], list[str]] = defaultdict(list)
    for c in citations():
        loc = f"`{_shown(c.path)}`"
        if loc not in where[(c.module, c.action)]:
            where[(c.module, c.action)].append(loc)
    lines = ["| module | action | implemented at |", "|---|---|---|"]
    for module in sorted({p.stem for p in TLA_DIR.glob("*.tla")} - {p.stem for p in TLA_DIR.glob("MC*.tla")}):
        for action in actions(module):
            locs = where.get((module, action))
            if locs:
                cell = ", ".join(locs)
            elif action in LINE_BY_LINE.get(module, set()):
                cell = "application code, through the locked buffer"
            else:
                cell = "not firmware: the host or the environment"
            lines.append(f"| {module} | {action} | {cell} |")
    return "\n".join(lines) + "\n"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--table", action="store_true", help="print the action -> C table (markdown)")
    args = parser.parse_args()
    if args.table:
        print(table(), end="")
        return 0
    bad = problems()
    for p in bad:
        print(p, file=sys.stderr)
    print(f"tla_xref: {len(citations())} citations checked, {len(bad)} problem(s)")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
