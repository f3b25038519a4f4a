#!/usr/bin/env python3
"""Seed bugs into the firmware components automatically and check that the unit tests catch them.

    python3 tools/c_mutate.py list [--component NAME] [--sample]   # the mutants, nothing run
    python3 tools/c_mutate.py show ID                              # one mutant as a diff
    python3 tools/c_mutate.py run --sample [--jobs 2]              # the fixed sample (make check)
    python3 tools/c_mutate.py run [--component NAME] [--jobs 2]    # every mutant (make mutation-c-full)
    python3 tools/c_mutate.py run --sample --esbmc                 # survivors also through the BMC proofs

Operators (deterministic: the same sources give the same mutants, ids and sample), each of one
kind of the mutation score:

| operator | kind | change |
|---|---|---|
| `ror` | off-by-one | `<` <-> `<=`, `>` <-> `>=` in a comparison |
| `bound` | off-by-one | the bound of a comparison one the other way: `i < n - 1`, `i <= n + 1`, `a > b + 1`, `a >= b - 1` |
| `swap` | wrong order | two neighbouring statements of a block exchanged (an `if` or loop with a simple statement too) when one writes a variable or field the other reads or writes, or a call meets another call or a store through a pointer |
| `del-store` | missing publish/free | a store to shared state (`p->f = x;`, `a[i] = x;`, `p->n++;`) deleted |
| `del-call` | missing publish/free | a call statement deleted (`complete(b, s);`, `(void)urb_release_outbox_any(n, 0u);`) |
| `field` | wrong field | a member access `p->f` / `s.f` replaced by the next member of the same struct with the same type |
| `del-return` | dropped error | an early return in an `if` branch deleted (the code goes on as if nothing was wrong) |
| `del-error-set` | dropped error | an assignment of an error status (`status = URB_STATUS_BUSY;`) deleted |

Nothing is mutated in comments, preprocessor lines or the branches compiled only with a hand-seeded
bug (`#ifdef URB_MUTANT_*`), nor calls that no host test can observe (NOT_MUTATED_CALLS: timing
marks, test interleaving hooks, compiler barriers). Each mutant is one file of one component
(COMPONENTS in urb_report.mutation) with one change; its id `<file stem>:<function>:<operator>:<n>`
(the n-th site of that operator in that function) is stable while the function does not change.

For each mutant the component's cmocka tests run, its own test program first, built as in `make
test-firmware-node` / `test-firmware-bridge` (gcc, ASan + UBSan): a failing, crashing or hanging
program kills it; a mutant that does not compile is "stillborn" (not counted). A survivor must be
explained in tests/mutation/c_equivalents.json (id, the original and mutated text, why the change
cannot be observed or does not matter) or killed by a new test; an unexplained survivor fails the
run, and so does an explanation that no longer matches its mutant (the code changed: review it).

The sample takes, per component and kind, the SAMPLE_PER_KIND mutants with the smallest hash of
their id: fixed while the code is, spread over each component, and bounded. Results:
build/proofs/mutation/c.json (every mutant run, with its result), and for `make proofs`
build/proofs/mutation/summary.json and junit.xml (one row per component, the proof-part contract of
tools/proofs.py). Exit status: 0 no unexplained survivor, 1 an unexplained survivor or a stale
explanation, 2 a broken setup (a compiler missing, the unmutated control build failing its tests).
"""

from __future__ import annotations

import argparse
import difflib
import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field
from pathlib import Path

from urb_report import c_source
from urb_report.mutation import COMPONENTS, KINDS, Component

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "build" / "proofs" / "mutation"
WORK = OUT / "c"
EQUIVALENTS = ROOT / "tests" / "mutation" / "c_equivalents.json"
HEADERS = ["firmware/include", "firmware/node", "firmware/bridge"]
SAMPLE_PER_KIND = 3
RUN_TIMEOUT_S = 120  # one test program; the slowest (test_interleave) takes ~2 s of CPU under ASan
NOT_MUTATED_CALLS = {
    "mark": "a timing probe for the logic analyser (bridge.c): no behaviour depends on it",
    "URB_STEP": "the interleaving hook of the node tests; empty in the firmware",
    "URB_NODE_BARRIER": "a compiler barrier: no host test can observe reordering; TLC and ESBMC check the order",
}
OPERATOR_KIND = {"ror": "off-by-one", "bound": "off-by-one", "swap": "order", "del-store": "missing-effect",
                 "del-call": "missing-effect", "field": "field", "del-return": "error", "del-error-set": "error"}
ERROR_VALUE = re.compile(r"^\(?\s*(?:\(\w+\)\s*)?(?:URB_\w*ERR\w*|URB_STATUS_(?!OK\b)\w+)\s*\)?$")
SAN = ["-g", "-O1", "-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer"]


class SetupError(Exception):
    """A compiler is missing or the unmutated build fails; the message says what to do."""


@dataclass(frozen=True)
class Mutant:
    id: str
    component: str
    file: str
    function: str
    line: int
    operator: str
    kind: str
    start: int
    end: int
    original: str
    replacement: str

    def apply(self, text: str) -> str:
        assert text[self.start:self.end] == self.original, f"{self.id}: the source changed under the mutant"
        return text[:self.start] + self.replacement + text[self.end:]


# =============================================================================== operators


_RELATIONAL = re.compile(r"(?<![<>\-=!])(<=|>=|<|>)(?![<>=])")
_STOP = re.compile(r"&&|\|\||==|!=|[)\];,?:}]")
_ACCESS = re.compile(r"(->|(?<=[\w)\]])\s*\.)\s*([A-Za-z_]\w*)")
_ASSIGN = re.compile(r"(?<![=!<>+\-*/%&|^])(=|\+=|-=|\*=|/=|%=|&=|\|=|\^=|<<=|>>=)(?!=)")
_PATH = re.compile(r"[A-Za-z_]\w*(?:\s*(?:->|\.)\s*[A-Za-z_]\w*|\s*\[[^\]]*\])*")


def _depth0(code: str, start: int, end: int, pattern: re.Pattern[str]) -> re.Match[str] | None:
    """The first match of `pattern` at bracket depth 0 within code[start:end]."""
    depth = 0
    i = start
    while i < end:
        c = code[i]
        if c in "([{":
            depth += 1
        elif c in ")]}":
            if depth == 0:
                m = pattern.match(code, i)
                return m if m else None
            depth -= 1
        elif depth == 0:
            m = pattern.match(code, i)
            if m:
                return m
        i += 1
    return None


def _right_operand(code: str, start: int, end: int) -> tuple[int, int]:
    m = _depth0(code, start, end, _STOP)
    stop = m.start() if m else end
    left = start + len(code[start:stop]) - len(code[start:stop].lstrip())
    right = start + len(code[start:stop].rstrip())
    return left, right


def _comparisons(code: str, fn: c_source.Function) -> list[tuple[str, int, int, str, int, int]]:
    """(operator, its start, end, operand text, operand start, end) of each relational comparison."""
    out = []
    for m in _RELATIONAL.finditer(code, fn.open, fn.close):
        left, right = _right_operand(code, m.end(), fn.close)
        if right > left:
            out.append((m.group(1), m.start(), m.end(), code[left:right], left, right))
    return out


def _calls(code: str, stmt: c_source.Statement) -> str:
    """The callee when the statement is one call, `f(...);` or `(void)f(...);`, else ""."""
    text = code[stmt.start:stmt.end]
    m = re.match(r"\s*(?:\(\s*void\s*\)\s*)?([A-Za-z_][\w]*(?:\s*(?:->|\.)\s*\w+)*)\s*\(", text)
    if not m:
        return ""
    close = c_source._matching(code, stmt.start + m.end() - 1, stmt.end)
    return m.group(1) if code[close:stmt.end].strip() == ";" else ""


def _store(code: str, stmt: c_source.Statement) -> tuple[str, str] | None:
    """(left side, right side) of a top-level assignment, or (operand, "") of `x++;`-like statements."""
    text = code[stmt.start:stmt.end].strip().rstrip(";").strip()
    inc = re.fullmatch(r"(?:\+\+|--)\s*(.+)|(.+?)\s*(?:\+\+|--)", text)
    if inc:
        return (inc.group(1) or inc.group(2)).strip(), ""
    m = _depth0(code, stmt.start, stmt.end, _ASSIGN)
    if m is None:
        return None
    return code[stmt.start:m.start()].strip(), code[m.end():stmt.end].strip().rstrip(";").strip()


def _shared(lhs: str) -> bool:
    return bool(re.search(r"->|\.|\[", lhs)) or lhs.startswith("*")


_NOT_DATA = re.compile(r"[A-Z_0-9]+[uUlL]*|\d\w*|\w+_t|const|volatile|static|struct|enum|unsigned|signed|int|char|"
                       r"bool|short|long|void|sizeof|return|true|false|NULL")


def _paths(text: str) -> set[str]:
    """The variables and member paths a statement names (`p->f[i].g`), calls and types left out."""
    return {re.sub(r"\s+", "", p.group()) for p in _PATH.finditer(text)
            if not _NOT_DATA.fullmatch(p.group()) and not text[p.end():].lstrip().startswith("(")}


def _inside(inner: str, outer: str) -> bool:
    return inner.startswith(outer + "->") or inner.startswith(outer + ".") or inner.startswith(outer + "[")


def _overlap(written: set[str], named: set[str]) -> bool:
    """Whether a statement that writes `written` changes something another one names: the same
    path, a part of it (`p->f` after `p`), or the member path it is part of (`p->s` around
    `p->s.f`; a bare `p` is a pointer passed on, not the whole object)."""
    return any(w == n or _inside(n, w) or (_inside(w, n) and re.search(r"->|\.|\[", n))
               for w in written for n in named)


def _dependent(code: str, a: c_source.Statement, b: c_source.Statement) -> bool:
    """Whether exchanging neighbours a, b changes what they compute: one writes a variable or
    field (or a prefix of it: `p` and `p->f`) that the other reads or writes. A call's own effects
    are not looked into; it reads its arguments and writes what it is given the address of."""
    def written(stmt: c_source.Statement) -> set[str]:
        if stmt.blocks:  # a compound statement writes what the statements inside it write
            return {w for block in stmt.blocks for inner in c_source.walk(block) if not inner.blocks
                    for w in written(inner)}
        declared = _declares(code, stmt)
        if declared:
            return {declared}
        store = _store(code, stmt)
        out = _paths(store[0]) if store else set()
        return out | {re.sub(r"\s+", "", m.group(1)) for m in re.finditer(r"&\s*(" + _PATH.pattern + ")",
                                                                          code[stmt.start:stmt.end])}

    wa, wb = written(a), written(b)
    if _overlap(wa, _paths(code[b.start:b.end])) or _overlap(wb, _paths(code[a.start:a.end])):
        return True
    # A call may read or write anything reachable: it meets another call, or a store through a
    # pointer (a buffer read after its release, a flag set after the call that publishes).
    call = re.compile(r"\b(?!(?:if|while|for|switch|return|sizeof)\b)[A-Za-z_]\w*\s*\(")
    calls_a, calls_b = bool(call.search(code, a.start, a.end)), bool(call.search(code, b.start, b.end))
    through = re.compile(r"->|\*|\[")
    return (calls_a and (calls_b or any(through.search(w) for w in wb))) or \
        (calls_b and any(through.search(w) for w in wa))


_SWAPPABLE = ("expr", "decl", "if", "loop", "switch")


def _line_span(text: str, code: str, stmt: c_source.Statement) -> tuple[int, int]:
    """The statement with its own line's trailing comment when it fills its lines alone (so that a
    swap moves the comment with it), else just the statement."""
    line_start = text.rfind("\n", 0, stmt.start) + 1
    line_end = text.find("\n", stmt.end)
    line_end = len(text) if line_end < 0 else line_end
    if code[line_start:stmt.start].strip() or code[stmt.end:line_end].strip():
        return stmt.start, stmt.end
    return stmt.start, line_end


def _declares(code: str, stmt: c_source.Statement) -> str:
    m = c_source._DECL.match(code, stmt.start)
    return m.group(1) if stmt.kind == "decl" and m else ""


class Fields:
    """Struct members by struct, for the wrong-field operator, with the types of a function's
    variables to tell which struct an access reads."""

    def __init__(self) -> None:
        self.members: dict[str, list[c_source.Member]] = {}
        self.aliases: dict[str, str] = {}
        for folder in HEADERS:
            for header in sorted((ROOT / folder).glob("*.h")):
                text = header.read_text(encoding="utf-8")
                for m in c_source.struct_members(text):
                    self.members.setdefault(m.struct, []).append(m)
                self.aliases.update(c_source.struct_aliases(text))

    @staticmethod
    def _plain(typ: str) -> str:
        return " ".join(w for w in typ.replace("*", " * ").split() if w not in ("const", "volatile"))

    def struct_of(self, typ: str) -> str:
        name = re.sub(r"\[.*", "", self._plain(typ)).replace("*", "").replace("struct", "").strip()
        name = self.aliases.get(name, name)
        return name if name in self.members else ""

    def sibling(self, struct: str, name: str) -> str:
        """The next member of `struct` after `name` (cyclic) with the same type, or ""."""
        members = self.members.get(struct, [])
        at = next((i for i, m in enumerate(members) if m.name == name), None)
        if at is None:
            return ""
        typ = self._plain(members[at].type)
        for k in range(1, len(members)):
            other = members[(at + k) % len(members)]
            if self._plain(other.type) == typ:
                return other.name
        return ""

    def member_type(self, struct: str, name: str) -> str:
        return next((m.type for m in self.members.get(struct, []) if m.name == name), "")

    def base_struct(self, code: str, fn: c_source.Function, at: int) -> str:
        """The struct whose member the access at `at` (its `->` or `.`) reads, or "" when unknown."""
        head = code[max(0, at - 200):at]
        chain = re.search(r"([A-Za-z_]\w*)((?:\s*\[[^\]]*\]|\s*(?:->|\.)\s*[A-Za-z_]\w*)*)\s*$", head)
        if not chain:
            return ""
        var = chain.group(1)
        sig_start = code.rfind("\n", 0, code.rfind("(", 0, fn.open)) + 1
        scope = code[sig_start:at]
        decl = None
        for decl in re.finditer(rf"((?:struct\s+)?[A-Za-z_]\w*)\s*(?:const\s*)?(\*?)\s*(?:const\s*)?\b{var}\b\s*[;=,)\[]",
                                scope):
            pass
        if decl is None:
            return ""
        struct = self.struct_of(decl.group(1))
        for step in re.findall(r"(?:->|\.)\s*([A-Za-z_]\w*)", chain.group(2)):
            struct = self.struct_of(self.member_type(struct, step)) if struct else ""
        return struct


def _mutants_of(comp: Component, path: str, text: str, fields: Fields) -> list[Mutant]:
    code = c_source.code_of(text)
    out: list[Mutant] = []
    for fn in c_source.functions(code):
        if comp.functions(path) is not None and fn.name not in (comp.functions(path) or ()):
            continue
        counters: dict[str, int] = {}

        def add(op: str, start: int, end: int, replacement: str) -> None:
            counters[op] = counters.get(op, 0) + 1
            out.append(Mutant(f"{Path(path).stem}:{fn.name}:{op}:{counters[op]}", comp.name, path, fn.name,
                              text.count("\n", 0, start) + 1, op, OPERATOR_KIND[op], start, end, text[start:end],
                              replacement))

        for op, o_start, o_end, operand, left, right in _comparisons(code, fn):
            add("ror", o_start, o_end, {"<": "<=", "<=": "<", ">": ">=", ">=": ">"}[op])
            shift = "- 1" if op in ("<", ">=") else "+ 1"
            simple = re.fullmatch(r"[\w\->.\[\]]+", operand) is not None
            add("bound", left, right, f"{text[left:right] if simple else '(' + text[left:right] + ')'} {shift}")
        body = c_source.parse_block(code, fn.open + 1, fn.close - 1)
        last = body[-1] if body else None
        for stmt in c_source.walk(body):
            if stmt.kind == "return" and stmt.guard and stmt is not last:
                add("del-return", stmt.start, stmt.end, ";")
            if stmt.kind != "expr":
                continue
            callee = _calls(code, stmt)
            store = _store(code, stmt)
            if callee and callee not in NOT_MUTATED_CALLS:
                add("del-call", stmt.start, stmt.end, ";")
            elif store and store[1] and ERROR_VALUE.match(store[1]):
                add("del-error-set", stmt.start, stmt.end, ";")
            elif store and _shared(store[0]):
                add("del-store", stmt.start, stmt.end, ";")
        for block in c_source.blocks_of(body):
            for a, b in zip(block, block[1:]):
                if a.kind not in _SWAPPABLE or b.kind not in _SWAPPABLE or (a.blocks and b.blocks):
                    continue
                declared = _declares(code, a)
                if declared and re.search(rf"\b{declared}\b", code[b.start:b.end]):
                    continue
                if code[a.start:a.end].split() == code[b.start:b.end].split() or not _dependent(code, a, b) or \
                        {_calls(code, a), _calls(code, b)} & NOT_MUTATED_CALLS.keys():
                    continue
                (a_start, a_end), (b_start, b_end) = _line_span(text, code, a), _line_span(text, code, b)
                add("swap", a_start, b_end, text[b_start:b_end] + text[a_end:b_start] + text[a_start:a_end])
        seen: set[str] = set()
        for m in _ACCESS.finditer(code, fn.open, fn.close):
            name = m.group(2)
            struct = fields.base_struct(code, fn, m.start())
            other = fields.sibling(struct, name) if struct else ""
            if other and name not in seen:  # one site per member and function
                seen.add(name)
                add("field", m.start(2), m.end(2), other)
    return out


def generate(components: list[Component] | None = None) -> list[Mutant]:
    """Every mutant of the components (all by default), in file order."""
    fields = Fields()
    out: list[Mutant] = []
    for comp in components or COMPONENTS:
        if not comp.mutated:
            continue
        for path in comp.files():
            out += _mutants_of(comp, path, (ROOT / path).read_text(encoding="utf-8"), fields)
    ids = [m.id for m in out]
    assert len(set(ids)) == len(ids), "mutant ids must be unique"
    return out


def sample(mutants: list[Mutant], per_kind: int = SAMPLE_PER_KIND) -> list[Mutant]:
    """Per component and kind, the `per_kind` mutants with the smallest sha256 of their id."""
    groups: dict[tuple[str, str], list[Mutant]] = {}
    for m in mutants:
        groups.setdefault((m.component, m.kind), []).append(m)
    chosen = {m.id for group in groups.values()
              for m in sorted(group, key=lambda x: hashlib.sha256(x.id.encode()).hexdigest())[:per_kind]}
    return [m for m in mutants if m.id in chosen]


# =============================================================================== building and running


@dataclass(frozen=True)
class Suite:
    """How the unit tests of a group of components are built: the library sources a mutant may be
    in, the programs with the sources each links besides the library, the flags."""

    name: str
    library: tuple[str, ...]
    programs: dict[str, tuple[str, ...]]
    flags: tuple[str, ...]

    def sources(self) -> list[str]:
        return sorted({*self.library, *(s for srcs in self.programs.values() for s in srcs)})


_NODE_COMMON = ("tests/firmware/node/node_fixture.c", "gen/c/urb_runtime.c", "gen/c/urb_core.c", "gen/c/urb_sensorhex.c",
                "firmware/hal/hosted/urb_hal_hosted.c")
_NODE_EXTRA = {"test_pll": ("tests/firmware/pll/pll_model.c",),
               "test_apps": tuple(f"firmware/apps/sensorhex/sensorhex_{a}.c" for a in ("motor", "battery", "imu", "ir")),
               "test_single": ("firmware/node/urb_single.c",)}
NODE_TESTS = ("test_mailbox", "test_i2c", "test_node", "test_pll", "test_apps", "test_single", "test_interleave")
_BRIDGE_TESTS = tuple(sorted(str(p.relative_to(ROOT)) for p in (ROOT / "tests" / "firmware" / "bridge").glob("*.c")
                             if p.name != "cost_driver.c"))

SUITES = {
    "node": Suite("node", ("firmware/node/urb_mailbox.c", "firmware/node/urb_i2c.c", "firmware/node/urb_pll.c",
                           "firmware/node/urb_node.c", "firmware/node/urb_observe.c"),
                  {t: (f"tests/firmware/node/{t}.c", *_NODE_COMMON, *_NODE_EXTRA.get(t, ())) for t in NODE_TESTS},
                  ("-std=c99", "-w", "-DURB_NODE_TESTING", "-Ifirmware/include", "-Ifirmware/node",
                   "-Ifirmware/hal/hosted", "-Ifirmware/apps/sensorhex", "-Igen/c", "-Itests/firmware/node",
                   "-Itests/firmware/pll")),
    "bridge": Suite("bridge", ("firmware/bridge/bridge.c", "firmware/bridge/bridge_uplink.c",
                               "firmware/bridge/i2c_master.c"),
                    {"bridge-tests": ("gen/c/urb_core.c", "gen/c/urb_runtime.c", "firmware/hal/hosted/bridge_hosted.c",
                                      "firmware/hal/hosted/bridge_fake_i2c.c", *_BRIDGE_TESTS)},
                    ("-std=c99", "-w", "-D_DEFAULT_SOURCE", "-Ifirmware/include", "-Igen/c", "-Ifirmware/hal/hosted",
                     "-Ifirmware/bridge")),
}
# The test program of each component that runs first (its own tests); the rest follow, slowest last.
FIRST_PROGRAM = {"node mailbox": "test_mailbox", "node I2C": "test_i2c", "inbox-0 commands": "test_node",
                 "PLL": "test_pll"}


def suite_of(path: str) -> Suite:
    return next(s for s in SUITES.values() if path in s.library)


def _obj(work: Path, src: str) -> Path:
    return work / (src.replace("/", "_").removesuffix(".c") + ".o")


def _compile(src: Path, obj: Path, suite: Suite, extra: tuple[str, ...] = ()) -> str:
    """"" when it compiled, else the compiler's message."""
    obj.parent.mkdir(parents=True, exist_ok=True)
    cmd = ["gcc", *suite.flags, *extra, *SAN, "-c", str(src), "-o", str(obj)]
    out = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, check=False)
    return "" if out.returncode == 0 else (out.stderr.strip().splitlines() or ["compile error"])[0][:300]


def _link(program: Path, objs: list[Path]) -> str:
    out = subprocess.run(["gcc", *SAN, "-o", str(program), *map(str, objs), "-lcmocka", "-lm"], cwd=ROOT,
                         capture_output=True, text=True, check=False)
    return "" if out.returncode == 0 else (out.stderr.strip().splitlines() or ["link error"])[0][:300]


def _run(program: Path) -> str:
    """"" when the program passed, else how it failed (the failing tests, a sanitizer, a timeout)."""
    env = dict(os.environ, CMOCKA_MESSAGE_OUTPUT="stdout", ASAN_OPTIONS="detect_leaks=0")
    try:
        out = subprocess.run([str(program)], cwd=ROOT, capture_output=True, text=True, timeout=RUN_TIMEOUT_S,
                             env=env, check=False)
    except subprocess.TimeoutExpired:
        return f"{program.name}: hangs (killed after {RUN_TIMEOUT_S} s)"
    if out.returncode == 0:
        return ""
    text = out.stdout + out.stderr
    failed = sorted(set(re.findall(r"^\[  FAILED  \] (\w+)$", text, re.MULTILINE)))
    sanitizer = re.search(r"(AddressSanitizer|runtime error|UndefinedBehaviorSanitizer)[^\n]{0,120}", text)
    how = ", ".join(failed) if failed else (sanitizer.group(0) if sanitizer else f"exit status {out.returncode}")
    return f"{program.name}: {how}"[:300]


class Builder:
    """The unmutated (control) objects of every suite, built once, and the runs of mutants."""

    def __init__(self, work: Path) -> None:
        self.work = work
        if shutil.which("gcc") is None:
            raise SetupError("gcc missing: run tools/setup.sh")

    def control(self, jobs: int, suites: set[str] | None = None) -> dict[str, float]:
        """Builds the objects of the suites named (every suite by default) and runs their programs
        unmutated; seconds per program."""
        times: dict[str, float] = {}
        for suite in SUITES.values():
            if suites is not None and suite.name not in suites:
                continue
            with ThreadPoolExecutor(max_workers=jobs) as pool:
                errors = list(pool.map(lambda s: _compile(ROOT / s, _obj(self.work / suite.name, s), suite),
                                       suite.sources()))
            bad = [e for e in errors if e]
            if bad:
                raise SetupError(f"the unmutated {suite.name} sources do not compile: {bad[0]}")
            for program in suite.programs:
                start = time.monotonic()
                failure = self._link_and_run(suite, program, {}, self.work / suite.name / "control")
                times[program] = time.monotonic() - start
                if failure:
                    raise SetupError(f"the unmutated {suite.name} tests fail ({failure}): fix them before mutating")
        return times

    def _link_and_run(self, suite: Suite, program: str, replaced: dict[str, Path], where: Path) -> str:
        objs = [replaced.get(s, _obj(self.work / suite.name, s)) for s in (*suite.library, *suite.programs[program])]
        binary = where / program
        binary.parent.mkdir(parents=True, exist_ok=True)
        failure = _link(binary, objs)
        return f"{program}: does not link: {failure}" if failure else _run(binary)

    def check(self, mutant: Mutant) -> dict[str, str]:
        """Result of one mutant: {"result": killed|survived|stillborn, "killed_by" or "error"}."""
        suite = suite_of(mutant.file)
        where = self.work / "mutants" / re.sub(r"[^\w.-]+", "_", mutant.id)
        where.mkdir(parents=True, exist_ok=True)
        src = where / Path(mutant.file).name
        src.write_text(mutant.apply((ROOT / mutant.file).read_text(encoding="utf-8")), encoding="utf-8")
        obj = where / "mutant.o"
        error = _compile(src, obj, suite, (f"-I{(ROOT / mutant.file).parent}",))
        if error:
            shutil.rmtree(where, ignore_errors=True)
            return {"result": "stillborn", "error": error}
        first = FIRST_PROGRAM.get(mutant.component)
        order = [p for p in suite.programs if p == first] + [p for p in suite.programs if p != first]
        try:
            for program in order:
                failure = self._link_and_run(suite, program, {mutant.file: obj}, where)
                if failure:
                    return {"result": "killed", "killed_by": failure}
            return {"result": "survived"}
        finally:
            shutil.rmtree(where, ignore_errors=True)


# =============================================================================== ESBMC on survivors

# The fast-tier BMC proofs of each component (proofs/bmc/fw_*): `--esbmc` runs them on the mutants
# the unit tests let through (minutes per run: opt-in, never in make check).
ESBMC_PROOFS = {"node mailbox": ("fw_mailbox_inbox", "fw_mailbox_outbox"), "node I2C": ("fw_node_i2c_slave",),
                "inbox-0 commands": ("fw_node_inbox0_command",), "PLL": ("fw_node_pll_update",),
                "bridge FIFO": ("fw_bridge_fifo",), "uplink parsers": ("fw_bridge_rs232_parser", "fw_bridge_usb_parser"),
                "downlink master": ("fw_bridge_downlink_master",)}


def as_bmc_mutant(m: Mutant, name: str) -> dict[str, object]:
    """The mutant as an entry of a proof folder's mutants.json (proofs/bmc/prepare.py: the n-th
    occurrence of a literal text inside one function)."""
    text = (ROOT / m.file).read_text(encoding="utf-8")
    fn = next(f for f in c_source.functions(c_source.code_of(text)) if f.name == m.function)
    line_start = text.rfind("\n", 0, fn.open) + 1
    occurrence = text[line_start:m.start].count(m.original) + 1
    return {"name": name, "file": m.file, "function": m.function, "find": m.original, "replace": m.replacement,
            "occurrence": occurrence, "why": f"generated by tools/c_mutate.py: {m.id}", "expect": "any failure"}


def esbmc_check(m: Mutant, folder: str, work: Path) -> str:
    """"killed: <property>", "survived" or "error: ..." of one fast-tier run of proofs/bmc/<folder>
    on the mutant. The folder is copied (its mutants.json replaced by this mutant's) and make is
    pointed at the copy through CURDIR; the proof's own folder is not touched."""
    real = ROOT / "proofs" / "bmc" / folder
    copy = work / folder
    shutil.rmtree(copy, ignore_errors=True)
    shutil.copytree(real, copy)
    name = "cmut-" + hashlib.sha256(m.id.encode()).hexdigest()[:10]
    (copy / "mutants.json").write_text(json.dumps([as_bmc_mutant(m, name)], indent=1), encoding="utf-8")
    cmd = ["make", "-s", "-C", str(real), "mutant", "TIER=fast", f"CURDIR={copy}", f"PROOF={folder}",
           f"MUTANT={name}", f"PYTHON={sys.executable}"]
    try:
        out = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=3600, check=False)
    except subprocess.TimeoutExpired:
        return "error: no verdict within an hour"
    text = out.stdout + out.stderr
    if "VERIFICATION FAILED" in text:
        violated = re.search(r"Violated property:\s*\n\s*(file [^\n]*)\n\s*([^\n]*)", text)
        return "killed: " + (f"{violated.group(2).strip()[:100]} ({violated.group(1).strip()[:80]})" if violated
                             else "VERIFICATION FAILED")
    if out.returncode == 0 and "VERIFICATION SUCCESSFUL" in text:
        return "survived"
    return "error: " + (text.strip().splitlines() or ["no output"])[-1][:200]


# =============================================================================== explanations and driver


def load_equivalents(path: Path | None = None) -> dict[str, dict[str, str]]:
    """id -> {"original", "replacement", "why"} of the reviewed survivors (tests/mutation/c_equivalents.json)."""
    path = path or EQUIVALENTS
    if not path.is_file():
        return {}
    entries = json.loads(path.read_text(encoding="utf-8"))
    out: dict[str, dict[str, str]] = {}
    for e in entries:
        if not all(isinstance(e.get(k), str) and e.get(k) for k in ("id", "original", "replacement", "why")):
            raise SetupError(f"{_shown(path)}: every entry needs id, original, replacement and why: {e}")
        out[e["id"]] = e
    return out


def stale_explanations(mutants: list[Mutant], equivalents: dict[str, dict[str, str]]) -> list[str]:
    """Explanations whose mutant no longer exists or no longer makes the change they reviewed."""
    by_id = {m.id: m for m in mutants}
    out = []
    for key, e in sorted(equivalents.items()):
        m = by_id.get(key)
        if m is None:
            out.append(f"{key}: no such mutant any more (the code changed): review and remove the explanation")
        elif (" ".join(m.original.split()), " ".join(m.replacement.split())) != \
                (" ".join(e["original"].split()), " ".join(e["replacement"].split())):
            out.append(f"{key}: the mutant now changes `{' '.join(m.original.split())[:80]}` to "
                       f"`{' '.join(m.replacement.split())[:80]}`, not what was reviewed: review the explanation")
    return out


def _shown(path: Path) -> str:
    return str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else str(path)


def diff(m: Mutant) -> str:
    text = (ROOT / m.file).read_text(encoding="utf-8")
    return "".join(difflib.unified_diff(text.splitlines(True), m.apply(text).splitlines(True), f"a/{m.file}",
                                        f"b/{m.file}", n=2))


def write_results(results: list[dict[str, object]], chosen: str, seconds: float, stale: list[str]) -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "c.json").write_text(json.dumps({"tool": "c_mutate", "set": chosen, "wall_s": round(seconds, 1),
                                            "stale_explanations": stale, "mutants": results}, indent=1) + "\n",
                                encoding="utf-8")
    rows = []
    for comp in [c.name for c in COMPONENTS if c.mutated]:
        mine = [r for r in results if r["component"] == comp and r["result"] != "stillborn"]
        unexplained = [r for r in mine if r["result"] == "survived" and not r["explained"]]
        killed = sum(r["result"] == "killed" for r in mine)
        explained = sum(r["result"] == "survived" and bool(r["explained"]) for r in mine)
        if not mine:
            continue
        # A component where nothing dies says the tests did not run or cannot fail: never a pass.
        result = "UNEXPLAINED SURVIVOR" if unexplained else ("NO KILL" if not killed else "all killed or explained")
        rows.append({"function": f"{comp} [generated mutants]", "tool": "c_mutate + cmocka",
                     "properties": f"{len(mine)} seeded bugs ({chosen} set): {killed} killed, {explained} equivalent",
                     "bound": "the component's cmocka tests (gcc, ASan + UBSan)",
                     "result": result, "expected": result == "all killed or explained", "time_s": round(sum(float(str(r["time_s"])) for r in mine), 2),
                     "detail": "; ".join(str(r["id"]) for r in unexplained)[:400]})
    if stale:
        rows.append({"function": "c_equivalents.json", "tool": "c_mutate", "properties": "explanations current",
                     "bound": "-", "result": "STALE", "expected": False, "time_s": 0.0, "detail": "; ".join(stale)[:400]})
    (OUT / "summary.json").write_text(json.dumps({"part": "mutation", "rows": rows}, indent=2) + "\n", encoding="utf-8")
    suites = ET.Element("testsuites", name="urb-mutation")
    suite = ET.SubElement(suites, "testsuite", name="proofs.mutation", tests=str(len(rows)),
                          failures=str(sum(not r["expected"] for r in rows)))
    for r in rows:
        case = ET.SubElement(suite, "testcase", classname="proofs.mutation", name=str(r["function"]),
                             time=f"{float(str(r['time_s'])):.3f}")
        if not r["expected"]:
            ET.SubElement(case, "failure", message=str(r["result"])).text = str(r["detail"])
    ET.ElementTree(suites).write(OUT / "junit.xml", encoding="utf-8", xml_declaration=True)


def control_suites(mutants: list[Mutant]) -> set[str]:
    """The suites a run builds unmutated: those of the chosen mutants' files (a run restricted to one
    component skips the other suite's control build, minutes on a loaded machine)."""
    return {suite_of(m.file).name for m in mutants}


def run(mutants: list[Mutant], jobs: int, chosen: str, esbmc: bool = False) -> int:
    equivalents = load_equivalents()
    stale = stale_explanations(generate(), equivalents)
    builder = Builder(WORK)
    start = time.monotonic()
    builder.control(jobs, control_suites(mutants))
    print(f"c_mutate: control builds pass ({time.monotonic() - start:.0f} s); {len(mutants)} mutants, {jobs} jobs",
          flush=True)

    def one(m: Mutant) -> dict[str, object]:
        t0 = time.monotonic()
        outcome: dict[str, object] = dict(builder.check(m))
        verdicts: dict[str, str] = {}
        if esbmc and outcome["result"] == "survived":
            verdicts = {f: esbmc_check(m, f, WORK / "esbmc" / re.sub(r"[^\w.-]+", "_", m.id))
                        for f in ESBMC_PROOFS.get(m.component, ())}
            outcome["esbmc"] = verdicts
        caught = [f"{f}: {v}" for f, v in verdicts.items() if v.startswith("killed")]
        explained = equivalents.get(m.id, {}).get("why", "") or \
            (f"the unit tests miss it; ESBMC kills it ({'; '.join(caught)})" if caught else "")
        return {**{k: v for k, v in asdict(m).items() if k not in ("start", "end")}, **outcome,
                "explained": explained if outcome["result"] == "survived" else "",
                "time_s": round(time.monotonic() - t0, 2)}

    with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        results = list(pool.map(one, mutants))
    seconds = time.monotonic() - start
    write_results(results, chosen, seconds, stale)
    rows = json.loads((OUT / "summary.json").read_text(encoding="utf-8"))["rows"]
    counted = [r for r in results if r["result"] != "stillborn"]
    survivors = [r for r in counted if r["result"] == "survived"]
    unexplained = [r for r in survivors if not r["explained"]]
    for r in unexplained:
        print(f"SURVIVED {r['id']} ({r['component']}, {KINDS[str(r['kind'])]}), line {r['line']}: "
              f"`{' '.join(str(r['original']).split())[:70]}` -> `{' '.join(str(r['replacement']).split())[:70]}`")
    for s in stale:
        print(f"STALE EXPLANATION {s}")
    print(f"c_mutate: {len(counted)} mutants ({len(results) - len(counted)} stillborn): "
          f"{sum(r['result'] == 'killed' for r in counted)} killed, {len(survivors) - len(unexplained)} survived and "
          f"explained, {len(unexplained)} unexplained; {seconds:.0f} s wall; {_shown(OUT / 'c.json')}")
    for r in rows:
        if r["result"] == "NO KILL":
            print(f"NO KILL {r['function']}: not one mutant made a test fail: are the tests built and run?")
    return 1 if not all(r["expected"] for r in rows) else 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    for name in ("list", "run"):
        p = sub.add_parser(name)
        p.add_argument("--component", action="append", default=[], help="only this component (repeatable)")
        p.add_argument("--sample", action="store_true", help=f"the fixed sample ({SAMPLE_PER_KIND} per component and kind)")
        p.add_argument("--id", action="append", default=[], help="only the mutant of this id (repeatable)")
        if name == "run":
            p.add_argument("--jobs", type=int, default=2, help="mutants checked at once (default 2)")
            p.add_argument("--esbmc", action="store_true",
                           help="also run the component's fast-tier ESBMC proofs on each unit-test survivor (slow)")
    sub.add_parser("show").add_argument("id")
    args = ap.parse_args(argv)
    try:
        all_mutants = generate()
        if args.cmd == "show":
            m = next((x for x in all_mutants if x.id == args.id), None)
            if m is None:
                raise SetupError(f"no mutant {args.id}: see `c_mutate.py list`")
            print(f"{m.id} ({m.component}, {KINDS[m.kind]}, operator {m.operator})\n{diff(m)}", end="")
            return 0
        known = {c.name for c in COMPONENTS if c.mutated}
        unknown = sorted(set(args.component) - known)
        if unknown:
            raise SetupError(f"no component {', '.join(unknown)}; components: {', '.join(sorted(known))}")
        chosen = sample(all_mutants) if args.sample else all_mutants
        chosen = [m for m in chosen if (not args.component or m.component in args.component)
                  and (not args.id or m.id in args.id)]
        if args.cmd == "list":
            for m in chosen:
                print(f"{m.id:48} {m.component:18} {m.kind:15} {' '.join(m.original.split())[:40]!r} -> "
                      f"{' '.join(m.replacement.split())[:40]!r}")
            print(f"{len(chosen)} mutants")
            return 0
        label = "sample" if args.sample else ("full" if not (args.component or args.id) else "selection")
        return run(chosen, args.jobs, label, args.esbmc)
    except SetupError as exc:
        print(f"c_mutate: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
