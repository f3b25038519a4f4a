"""Findings and the written records that explain them: the shared part of `make coverage`, `make
misra` and `make static` (tools/coverage.py, tools/misra.py, tools/static_analysis.py).

A finding is what a tool says about one place in the source: an uncovered line, branch or MC/DC
condition, a MISRA rule violation, an analyzer warning. Each must be explained by an entry of a
committed TOML file under quality/ (a coverage justification or a deviation) or it fails the check.

Entries never name bare line numbers, which move with every edit. They say where they apply with
stable anchors:
  files     glob patterns of repository paths ("firmware/node/*.c"; "**" crosses directories)
  function  the name of the C function that encloses the finding, or a list of names (absent: anywhere)
  anchors   texts that the finding's source line contains (whitespace is normalised)
  tokens    the token a finding's column points at (MISRA: the identifier the addon flagged)
  rules     the rule, check or coverage kind the entry applies to ("*": any)
An entry must still match something: one that matches no finding, or one of whose anchors or
tokens matches none, is stale and fails the check just like an unexplained finding, so the files
say exactly what is deviated and nothing more. A finding matched by two entries is an error too
(one place, one reason).
"""

from __future__ import annotations

import bisect
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

from urb_report.records import Item

ROOT = Path(__file__).resolve().parents[2]


class QualityError(Exception):
    """A justification or deviation file is malformed; the message names the file, entry and field."""


@dataclass(frozen=True, order=True)
class Finding:
    """One place a tool reports: `rule` is a coverage kind (line, branch, mcdc, mcdc-unmeasured), a
    MISRA rule number ("15.5") or "<tool>/<check>"; `file` is relative to the repository."""

    file: str
    line: int
    rule: str
    column: int = 0
    detail: str = ""


@dataclass(frozen=True)
class Entry:
    """One justification or deviation, as written in its TOML file (see the module docstring)."""

    id: str
    rules: tuple[str, ...]
    files: tuple[str, ...]
    functions: tuple[str, ...]
    anchors: tuple[str, ...]
    tokens: tuple[str, ...]
    reason: str
    extra: Mapping[str, Any] = field(default_factory=dict)

    def where(self) -> str:
        parts = [", ".join(self.files)]
        if self.functions:
            parts.append("in " + ", ".join(f"{f}()" for f in self.functions))
        if self.anchors:
            parts.append("on lines with " + " | ".join(repr(a) for a in self.anchors))
        if self.tokens:
            parts.append("at tokens " + ", ".join(self.tokens))
        return " ".join(parts)


def _strs(value: Any, what: str) -> tuple[str, ...]:
    if isinstance(value, str):
        return (value,)
    if isinstance(value, list) and all(isinstance(v, str) and v for v in value):
        return tuple(value)
    raise QualityError(f"{what} must be a string or a list of non-empty strings, not {value!r}")


def load_entries(path: Path, table: str, *, rule_key: str, required: Sequence[str] = (),
                 optional: Sequence[str] = ("evidence",), default_rules: Sequence[str] = ()) -> list[Entry]:
    """The `[[table]]` entries of the TOML file `path`. Each needs `id` (unique), `files`, `reason`
    (a sentence, not a placeholder), `rule_key` (unless `default_rules`) and every key of `required`;
    `function`, `anchors`, `tokens` and the keys of `optional` may be given, and those of `required`
    and `optional` are kept in `extra`. Any other key is an error: a misspelt `anchor` would
    otherwise widen the entry to the whole file."""
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise QualityError(f"{path}: cannot read it ({exc})") from exc
    raw = data.get(table, [])
    if not isinstance(raw, list):
        raise QualityError(f"{path}: `{table}` must be an array of tables ([[{table}]])")
    entries: list[Entry] = []
    seen: set[str] = set()
    known = {"id", "files", "function", "anchors", "tokens", "reason", rule_key}
    for n, item in enumerate(raw, 1):
        where = f"{path}: [[{table}]] #{n}"
        if not isinstance(item, dict):
            raise QualityError(f"{where}: not a table")
        ident = item.get("id")
        if not isinstance(ident, str) or not re.fullmatch(r"[a-z0-9][a-z0-9._-]*", ident):
            raise QualityError(f"{where}: `id` must be a lowercase name like 'mailbox-idle-read', not {ident!r}")
        where = f"{path}: {table} {ident}"
        if ident in seen:
            raise QualityError(f"{where}: the id is used twice")
        seen.add(ident)
        for key in ("files", "reason", *required):
            if key not in item:
                raise QualityError(f"{where}: `{key}` is missing")
        unknown = sorted(set(item) - known - set(required) - set(optional))
        if unknown:
            allowed = ", ".join(sorted(known | set(required) | set(optional)))
            raise QualityError(f"{where}: unknown key(s) {', '.join(unknown)} (known: {allowed})")
        reason = item["reason"]
        if not isinstance(reason, str) or len(reason.split()) < 5:
            raise QualityError(f"{where}: `reason` must say in a sentence why the finding is safe or unreachable")
        if rule_key in item:
            rules = _strs(item[rule_key], f"{where}: `{rule_key}`")
        elif default_rules:
            rules = tuple(default_rules)
        else:
            raise QualityError(f"{where}: `{rule_key}` is missing")
        functions = _strs(item["function"], f"{where}: `function`") if "function" in item else ()
        entries.append(Entry(
            id=ident, rules=rules, files=_strs(item["files"], f"{where}: `files`"), functions=functions,
            anchors=_strs(item.get("anchors", []), f"{where}: `anchors`") if item.get("anchors") else (),
            tokens=_strs(item.get("tokens", []), f"{where}: `tokens`") if item.get("tokens") else (),
            reason=" ".join(reason.split()), extra={k: v for k, v in item.items() if k not in known}))
    return entries


# ----- source index: lines, enclosing functions, tokens -------------------------------------------

_FUNC_HEAD = re.compile(r"([A-Za-z_]\w*)\s*\(")
_NOT_A_NAME = {"__attribute__", "__asm__", "asm", "if", "while", "for", "switch", "return", "sizeof"}


def _blank_comments_and_literals(text: str) -> str:
    """`text` with comments, string and character literals and preprocessor lines replaced by
    spaces (newlines kept), so braces and parentheses in them are not counted."""
    out = list(text)
    i, n = 0, len(text)
    line_start = True
    while i < n:
        c = text[i]
        if line_start and c in " \t":
            i += 1
            continue
        if line_start and c == "#":  # a directive, with its continuation lines
            j = i
            while j < n and not (text[j] == "\n" and text[j - 1] != "\\"):
                if text[j] != "\n":
                    out[j] = " "
                j += 1
            i = j
            continue
        line_start = c == "\n"
        if text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
        elif text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
        elif c in "\"'":
            j = i + 1
            while j < n and text[j] != c:
                j += 2 if text[j] == "\\" else 1
            j = min(j + 1, n)
        else:
            i += 1
            continue
        for k in range(i, j):
            if out[k] != "\n":
                out[k] = " "
        i = j
    return "".join(out)


def function_spans(text: str) -> list[tuple[str, int, int]]:
    """(name, first line, last line) of every function definition in C source `text`: the lines
    from its declarator to its closing brace, 1-based."""
    code = _blank_comments_and_literals(text)
    starts = [0] + [i + 1 for i, c in enumerate(code) if c == "\n"]

    def line_of(offset: int) -> int:
        return bisect.bisect_right(starts, offset)

    spans: list[tuple[str, int, int]] = []
    depth = 0
    head_start = 0
    current: tuple[str, int] | None = None
    for i, c in enumerate(code):
        if c == "{":
            if depth == 0:
                head = code[head_start:i]
                name = _function_name(head)
                if name:
                    current = (name, line_of(head_start + len(head) - len(head.lstrip())))
            depth += 1
        elif c == "}":
            depth = max(0, depth - 1)
            if depth == 0:
                if current is not None:
                    spans.append((current[0], current[1], line_of(i)))
                    current = None
                head_start = i + 1
        elif c == ";" and depth == 0:
            head_start = i + 1
    return spans


def _function_name(head: str) -> str:
    """The name a definition head declares ("static int f(int a)" -> "f"), or "" for anything else
    (an initialiser, a struct, enum or union body)."""
    if "=" in head or not head.strip().endswith(")"):
        return ""
    depth = 0
    names: list[str] = []
    for i, c in enumerate(head):
        if c == "(":
            if depth == 0:
                m = re.search(r"([A-Za-z_]\w*)\s*$", head[:i])
                if m and m.group(1) not in _NOT_A_NAME:
                    names.append(m.group(1))
            depth += 1
        elif c == ")":
            depth -= 1
    return names[-1] if names else ""


class SourceIndex:
    """Reads repository files once: their lines, the function around a line, the token at a column."""

    def __init__(self, root: Path = ROOT) -> None:
        self.root = root
        self._lines: dict[str, list[str]] = {}
        self._spans: dict[str, list[tuple[str, int, int]]] = {}

    def lines(self, file: str) -> list[str]:
        if file not in self._lines:
            try:
                text = (self.root / file).read_text(encoding="utf-8", errors="replace")
            except OSError:
                text = ""
            self._lines[file] = text.splitlines()
            self._spans[file] = function_spans(text)
        return self._lines[file]

    def line(self, file: str, number: int) -> str:
        lines = self.lines(file)
        return lines[number - 1] if 0 < number <= len(lines) else ""

    def function_at(self, file: str, number: int) -> str:
        self.lines(file)
        for name, first, last in self._spans[file]:
            if first <= number <= last:
                return name
        return ""

    def token_at(self, file: str, number: int, column: int) -> str:
        """The identifier, number or operator starting at the 1-based `column` of line `number`."""
        text = self.line(file, number)[max(column - 1, 0):]
        m = re.match(r"[A-Za-z_]\w*|[0-9][\w.]*|\S", text)
        return m.group(0) if m else ""


def _norm(text: str) -> str:
    return " ".join(text.split())


def path_matches(path: str, patterns: Iterable[str]) -> bool:
    """Whether `path` matches one of the glob `patterns` ("*" stays within a directory, "**/" spans any)."""
    for pattern in patterns:
        regex = re.escape(pattern).replace(r"\*\*/", "(?:.*/)?").replace(r"\*\*", ".*").replace(r"\*", "[^/]*")
        regex = regex.replace(r"\?", "[^/]")
        if re.fullmatch(regex, path):
            return True
    return False


@dataclass
class Matching:
    """The outcome of matching findings against entries."""

    justified: dict[Finding, Entry]
    unjustified: list[Finding]
    stale: dict[str, list[str]]  # entry id -> what is stale about it (the entry, an anchor, a token)
    conflicts: list[str]  # findings matched by more than one entry
    used: dict[str, list[Finding]]  # entry id -> the findings it explains

    @property
    def ok(self) -> bool:
        return not self.unjustified and not self.stale and not self.conflicts

    def problems(self) -> list[str]:
        """Every stale entry and conflict, one message each (what to do included)."""
        return [msg for msgs in self.stale.values() for msg in msgs] + self.conflicts


def _entry_matches(entry: Entry, finding: Finding, index: SourceIndex) -> tuple[bool, str, str]:
    """Whether `entry` explains `finding`, and which anchor and token made it ("" when none is set)."""
    if "*" not in entry.rules and finding.rule not in entry.rules:
        return False, "", ""
    if not path_matches(finding.file, entry.files):
        return False, "", ""
    if entry.functions and index.function_at(finding.file, finding.line) not in entry.functions:
        return False, "", ""
    anchor = token = ""
    if entry.anchors:
        text = _norm(index.line(finding.file, finding.line))
        hits = [a for a in entry.anchors if _norm(a) in text]
        if not hits:
            return False, "", ""
        anchor = hits[0]
    if entry.tokens:
        tok = index.token_at(finding.file, finding.line, finding.column)
        if tok not in entry.tokens:
            return False, "", ""
        token = tok
    return True, anchor, token


def match(findings: Sequence[Finding], entries: Sequence[Entry], index: SourceIndex, *, what: str) -> Matching:
    """Match every finding against every entry. `what` names the entry file in messages."""
    justified: dict[Finding, Entry] = {}
    unjustified: list[Finding] = []
    conflicts: list[str] = []
    used: dict[str, list[Finding]] = {e.id: [] for e in entries}
    anchors_hit: dict[str, set[str]] = {e.id: set() for e in entries}
    tokens_hit: dict[str, set[str]] = {e.id: set() for e in entries}
    for f in sorted(set(findings)):
        hits = []
        for e in entries:
            ok, anchor, token = _entry_matches(e, f, index)
            if ok:
                hits.append(e)
                anchors_hit[e.id].add(anchor)
                tokens_hit[e.id].add(token)
        if not hits:
            unjustified.append(f)
            continue
        if len(hits) > 1:
            conflicts.append(f"{f.file}:{f.line}: {f.rule} is explained by {len(hits)} entries of {what} "
                             f"({', '.join(e.id for e in hits)}): keep one")
        justified[f] = hits[0]
        used[hits[0].id].append(f)
    stale: dict[str, list[str]] = {}
    for e in entries:
        msgs: list[str] = []
        if not used[e.id]:
            msgs.append(f"{what}: entry {e.id} ({e.where()}) explains no finding any more: the code it "
                        "covered changed, or is now covered or compliant; update or delete the entry")
        else:
            msgs += [f"{what}: entry {e.id}: anchor {a!r} matches no finding: update or delete it"
                     for a in e.anchors if a not in anchors_hit[e.id]]
            msgs += [f"{what}: entry {e.id}: token {t!r} matches no finding: update or delete it"
                     for t in e.tokens if t not in tokens_hit[e.id]]
        if msgs:
            stale[e.id] = msgs
    return Matching(justified=justified, unjustified=unjustified, stale=stale, conflicts=conflicts, used=used)


def describe(finding: Finding, index: SourceIndex) -> str:
    """One line for a finding: place, rule, enclosing function, the source line."""
    fn = index.function_at(finding.file, finding.line)
    where = f"{finding.file}:{finding.line}" + (f":{finding.column}" if finding.column else "")
    detail = f" ({finding.detail})" if finding.detail else ""
    return f"{where}: {finding.rule}{detail}" + (f" in {fn}()" if fn else "") + \
        f": {index.line(finding.file, finding.line).strip()[:100]}"


def entry_items(entries: Sequence[Entry], m: Matching, index: SourceIndex, *, prefix: str, rerun: str,
                expected: str) -> list[Item]:
    """One record item per entry: pass while it explains findings at each of its anchors and tokens,
    fail when stale. Its data says where it applies, why, and what it explains on this run."""
    items = []
    for e in entries:
        used = m.used.get(e.id, [])
        stale = m.stale.get(e.id, [])
        items.append(Item(
            id=f"{prefix}:{e.id}", kind=prefix, verdict="fail" if stale else "pass", expected=expected,
            measured=f"explains {len(used)} finding(s)" + ("; stale: " + " / ".join(stale) if stale else ""),
            source=", ".join(e.files), rerun=rerun,
            data={"rules": list(e.rules), "where": e.where(), "reason": e.reason, **dict(e.extra),
                  "explains": [describe(f, index) for f in used]}))
    return items


def finding_items(findings: Sequence[Finding], m: Matching, index: SourceIndex, *, prefix: str, rerun: str,
                  expected: str) -> list[Item]:
    """One record item per (rule, file, line): `<prefix>:<rule>@<file>:<line>`, pass when an entry
    explains it (measured: the entry and its reason), fail when none does."""
    groups: dict[tuple[str, str, int], list[Finding]] = {}
    for f in sorted(set(findings)):
        groups.setdefault((f.rule, f.file, f.line), []).append(f)
    items = []
    for (rule, file, line), fs in sorted(groups.items(), key=lambda kv: (kv[0][1], kv[0][2], kv[0][0])):
        entry = m.justified.get(fs[0])
        items.append(Item(
            id=f"{prefix}:{rule}@{file}:{line}", kind=prefix, verdict="pass" if entry else "fail", expected=expected,
            measured=f"deviated by {entry.id}: {entry.reason}" if entry else "no deviation explains this finding",
            source=f"{file}:{line}", rerun=rerun,
            data={"columns": [f.column for f in fs], "details": sorted({f.detail for f in fs if f.detail}),
                  "function": index.function_at(file, line), "code": index.line(file, line).strip(),
                  "deviation": entry.id if entry else None}))
    return items
