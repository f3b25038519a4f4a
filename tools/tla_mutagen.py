"""Mutant generation over the actions of a TLA+ module (used by tools/tla_mutate.py).

Each mutant changes ONE place in ONE definition of a specification module (the actions, the
helpers they use, Init, Next, the fairness conditions: every definition above the module's first
`----` separator line, except TypeOK and the `...vars` tuples); the properties below the
separator are what must catch it. The operators, by the kind of bug they seed:

    kind     operator        change
    bound    cmp             `<` <-> `<=`, `>` <-> `>=`
    bound    literal         an integer literal n -> n + 1, and n -> n - 1 (n > 0)
    guard    drop-guard      a conjunct without primed variables is removed
    guard    negate          `=` <-> `#` in a comparison, `\\in` <-> `\\notin`
    order    append-front    `Append(s, e)` -> `<<e>> \\o s`
    order    head-last       `Head(s)` -> `s[Len(s)]`
    order    swap-if         `IF c THEN a ELSE b` -> `IF c THEN b ELSE a` (one-line IFs)
    publish  unchanged       `x' = e` -> `x' = x`: an update (a publish, a free) left out
    field    field           `.f` -> `.g`, another field of the same record
    error    drop-disjunct   a disjunct is removed (an action of Next, an error branch)
    error    set-element     an element of a set literal is removed (`{"X"}` -> `{}`)

A mutant's id is `<Module>/<Definition>/<operator>#<n>` (the n-th site of that operator in that
definition, counting from 1), stable under edits of comments and of other definitions; the
mutant also records the original and the mutated text of the site, so a stale explanation of a
mutant whose site changed is noticed.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

KINDS: dict[str, str] = {
    "cmp": "bound", "literal": "bound", "drop-guard": "guard", "negate": "guard",
    "append-front": "order", "head-last": "order", "swap-if": "order", "unchanged": "publish",
    "field": "field", "drop-disjunct": "error", "set-element": "error",
}

_DEF_RE = re.compile(r"^([A-Za-z_]\w*)(\([^)]*\))?\s*==", re.MULTILINE)
_SEPARATOR_RE = re.compile(r"^-{4,}\s*$", re.MULTILINE)
_HEADER_RE = re.compile(r"^-+\s*MODULE\s+(\w+)", re.MULTILINE)
_VARIABLES_RE = re.compile(r"^VARIABLES?\b(.*?)(?=^\S)", re.MULTILINE | re.DOTALL)
_BINDER_RE = re.compile(r"(\\[EA]|CHOOSE|[\[{])\s*[A-Za-z_][\w\s,]*$")


@dataclass(frozen=True)
class Mutant:
    """One seeded bug: the module's text with one site of one definition changed."""

    id: str
    module: str
    definition: str
    operator: str
    kind: str
    line: int
    original: str
    mutated: str
    text: str


@dataclass(frozen=True)
class Definition:
    name: str
    start: int  # offset of the body (after `==`)
    end: int    # offset after the body


def mask(text: str) -> str:
    """`text` with comments and string contents replaced by spaces (same length, newlines kept),
    so the operators never touch them."""
    out = list(text)
    i, n, depth = 0, len(text), 0
    while i < n:
        if text.startswith("(*", i):
            depth, j = 1, i + 2
            while j < n and depth:
                if text.startswith("(*", j):
                    depth, j = depth + 1, j + 2
                elif text.startswith("*)", j):
                    depth, j = depth - 1, j + 2
                else:
                    j += 1
            for k in range(i, j):
                if out[k] != "\n":
                    out[k] = " "
            i = j
        elif text.startswith("\\*", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            for k in range(i, j):
                out[k] = " "
            i = j
        elif text[i] == '"':
            j = text.find('"', i + 1)
            j = n if j < 0 else j
            for k in range(i + 1, j):
                out[k] = " "
            i = j + 1
        else:
            i += 1
    return "".join(out)


def variables(masked: str) -> set[str]:
    names: set[str] = set()
    for m in _VARIABLES_RE.finditer(masked):
        names |= set(re.findall(r"[A-Za-z_]\w*", m.group(1)))
    return names


def definitions(masked: str) -> list[Definition]:
    """The definitions above the first separator line after the VARIABLES declaration."""
    var = re.search(r"^VARIABLES?\b", masked, re.MULTILINE)
    sep = _SEPARATOR_RE.search(masked, var.end() if var else 0)
    limit = sep.start() if sep else len(masked)
    defs: list[Definition] = []
    starts = [m for m in _DEF_RE.finditer(masked) if m.start() < limit]
    for m in starts:
        nxt = re.search(r"^\S", masked[m.end():limit], re.MULTILINE)
        end = m.end() + nxt.start() if nxt else limit
        name = m.group(1)
        if name == "TypeOK" or name.lower().endswith("vars"):
            continue
        defs.append(Definition(name, m.end(), end))
    return defs


def behavioural(masked: str, defs: list[Definition], specs: list[str] | None = None,
                companions: list[str] | None = None) -> set[str]:
    """Names of the definitions the behaviour depends on: what the checked specifications use,
    transitively (through the companion modules' definitions too). Definitions that only the
    type invariant, the properties or unchecked specifications use are not mutated: a mutant
    there can only fail a property for the wrong reason, or survive for want of a check."""
    bodies = {d.name: masked[d.start:d.end] for d in defs}
    own = set(bodies)
    for text in companions or []:
        for m in _DEF_RE.finditer(text):
            nxt = re.search(r"^\S", text[m.end():], re.MULTILINE)
            end = m.end() + nxt.start() if nxt else len(text)
            bodies.setdefault(m.group(1), text[m.end():end])
    if specs is None:
        todo = [n for n in own if n == "Init" or n.startswith("Spec") or n.endswith(("Spec", "Next"))]
    else:
        todo = list(specs)
    seen: set[str] = set()
    while todo:
        name = todo.pop()
        if name in seen or name not in bodies:
            continue
        seen.add(name)
        for ident in set(re.findall(r"[A-Za-z_]\w*", bodies[name])):
            if ident in bodies and ident not in seen:
                todo.append(ident)
    return seen & own


def record_fields(masked: str) -> list[list[str]]:
    """Groups of field names that make one record: `[a |-> .., b |-> ..]` and `[a: .., b: ..]`."""
    groups: list[list[str]] = []
    for m in re.finditer(r"\[\s*([A-Za-z_]\w*)\s*(\|->|:)", masked):
        sep = m.group(2)
        depth, i, fields, seg = 0, m.start() + 1, [m.group(1)], m.start() + 1
        while i < len(masked):
            c = masked[i]
            if c in "([{":
                depth += 1
            elif c in ")]}":
                if depth == 0:
                    break
                depth -= 1
            elif c == "," and depth == 0:
                seg = i + 1
                f = re.match(r"\s*([A-Za-z_]\w*)\s*" + re.escape(sep), masked[seg:])
                if f:
                    fields.append(f.group(1))
            i += 1
        if len(fields) > 1 and fields not in groups:
            groups.append(fields)
    return groups


def _line_start(text: str, pos: int) -> int:
    return text.rfind("\n", 0, pos) + 1


def _col(text: str, pos: int) -> int:
    return pos - _line_start(text, pos)


def _bracket_end(masked: str, pos: int, end: int) -> int:
    """Offset after the bracketed expression starting at `pos` (one of ( [ { and <<)."""
    depth, i = 0, pos
    while i < end:
        if masked.startswith("<<", i):
            depth, i = depth + 1, i + 2
            continue
        if masked.startswith(">>", i):
            depth, i = depth - 1, i + 2
            if depth == 0:
                return i
            continue
        c = masked[i]
        if c in "([{":
            depth += 1
        elif c in ")]}":
            depth -= 1
            if depth == 0:
                return i + 1
        i += 1
    return end


def _junction_items(masked: str, d: Definition, op: str) -> list[tuple[int, int, int]]:
    """(start, end, column) of the items of bulleted `/\\` or `\\/` lists in the definition: a
    bullet is the operator first on its line or right after `==`, IN, THEN, ELSE, `:` or `(`;
    its item runs to the next line that starts at or left of the bullet's column."""
    items: list[tuple[int, int, int]] = []
    for m in re.finditer(re.escape(op), masked[d.start:d.end]):
        pos = d.start + m.start()
        before = masked[_line_start(masked, pos):pos]
        head = before.rstrip()
        if head.strip() and not re.search(r"(==|\bIN|\bTHEN|\bELSE|:|\()$", head):
            continue
        col = _col(masked, pos)
        end, i = d.end, masked.find("\n", pos)
        while 0 <= i < d.end:
            nxt = i + 1
            line = masked[nxt:masked.find("\n", nxt) if masked.find("\n", nxt) >= 0 else d.end]
            stripped = line.lstrip()
            if stripped and len(line) - len(stripped) <= col:
                end = nxt
                break
            i = masked.find("\n", nxt)
        while end > pos and masked[end - 1] in " \n":
            end -= 1
        # an item ends where a closing bracket of an enclosing expression is
        depth, j = 0, pos
        while j < end:
            c = masked[j]
            if c in "([{":
                depth += 1
            elif c in ")]}":
                if depth == 0:
                    end = j
                    break
                depth -= 1
            j += 1
        while end > pos and masked[end - 1] in " \n":
            end -= 1
        items.append((pos, end, col))
    return items


def _siblings(items: list[tuple[int, int, int]], masked: str) -> list[list[tuple[int, int]]]:
    """Group bullets into lists (same column, consecutive, nothing but the previous item between)."""
    lists: list[list[tuple[int, int]]] = []
    current: list[tuple[int, int]] = []
    last: tuple[int, int, int] | None = None
    for start, end, col in items:
        if last is not None and col == last[2] and masked[last[1]:start].strip() == "":
            current.append((start, end))
        else:
            if current:
                lists.append(current)
            current = [(start, end)]
        last = (start, end, col)
    if current:
        lists.append(current)
    return lists


def _inline_parts(masked: str, d: Definition, op: str) -> list[tuple[int, int]]:
    """Spans `op part` of one-line infix junctions `a op b op c` at bracket depth 0 in lines
    that hold no keyword, quantifier or implication (which would change what the operator
    binds); the first operand is returned as `part op`."""
    spans: list[tuple[int, int]] = []
    body = masked[d.start:d.end]
    offset = d.start
    for line in body.split("\n"):
        content = line.strip()
        lead = len(line) - len(line.lstrip())
        text = content
        base = offset + lead
        for bullet in ("/\\ ", "\\/ "):
            if text.startswith(bullet):
                text, base = text[3:], base + 3
        offset += len(line) + 1
        if op not in text or re.search(r"\b(IF|THEN|ELSE|LET|IN|CHOOSE|CASE)\b|\\[EA]\b|:|=>|~|\\/" if op == "/\\"
                                       else r"\b(IF|THEN|ELSE|LET|IN|CHOOSE|CASE)\b|\\[EA]\b|:|=>|~|/\\", text):
            continue
        depth, cuts = 0, []
        i = 0
        while i < len(text):
            c = text[i]
            if text.startswith("<<", i):
                depth += 1
                i += 2
                continue
            if text.startswith(">>", i):
                depth -= 1
                i += 2
                continue
            if c in "([{":
                depth += 1
            elif c in ")]}":
                depth -= 1
            elif depth == 0 and text.startswith(op, i):
                cuts.append(i)
                i += 2
                continue
            i += 1
        if not cuts or depth != 0:
            continue
        bounds = [0, *cuts, len(text)]
        for k in range(len(bounds) - 1):
            if k == 0:
                if "==" not in text[:cuts[0]]:  # not the head of a LET definition `d == a /\ b`
                    spans.append((base, base + cuts[0] + 2))
            else:
                spans.append((base + bounds[k], base + bounds[k + 1]))
    return spans


def _unchanged_sites(masked: str, d: Definition, variables_: set[str]) -> list[tuple[int, int, str]]:
    """(start, end, variable) of the right-hand side e of each `x' = e`."""
    sites: list[tuple[int, int, str]] = []
    for m in re.finditer(r"\b([A-Za-z_]\w*)'\s*=(?!=)", masked[d.start:d.end]):
        var = m.group(1)
        if var not in variables_:
            continue
        rhs = d.start + m.end()
        col = _col(masked, d.start + m.start())
        expr_start = rhs + len(masked[rhs:]) - len(masked[rhs:].lstrip(" "))
        is_compound = re.match(r"(IF|LET|CASE|CHOOSE|\\E|\\A)\b", masked[expr_start:]) is not None
        i, depth, end = expr_start, 0, d.end
        while i < d.end:
            if masked.startswith("<<", i):
                depth, i = depth + 1, i + 2
                continue
            if masked.startswith(">>", i):
                depth, i = depth - 1, i + 2
                continue
            c = masked[i]
            if c in "([{":
                depth += 1
            elif c in ")]}":
                if depth == 0:
                    end = i
                    break
                depth -= 1
            elif c == "\n" and depth == 0:
                nxt = masked[i + 1:masked.find("\n", i + 1) if masked.find("\n", i + 1) >= 0 else d.end]
                if not nxt.strip() or len(nxt) - len(nxt.lstrip()) <= col or nxt.lstrip().startswith(("/\\", "\\/")):
                    end = i
                    break
            elif depth == 0 and not is_compound and (masked.startswith("/\\", i) or masked.startswith("\\/", i)):
                end = i
                break
            i += 1
        while end > expr_start and masked[end - 1] in " \n":
            end -= 1
        if masked[expr_start:end].strip() != var:
            sites.append((expr_start, end, var))
    return sites


class _Builder:
    def __init__(self, module: str, text: str, masked: str) -> None:
        self.module, self.text, self.masked = module, text, masked
        self.mutants: list[Mutant] = []
        self.counts: dict[tuple[str, str], int] = {}

    def add(self, d: Definition, operator: str, start: int, end: int, replacement: str) -> None:
        original = self.text[start:end]
        if original == replacement:
            return
        key = (d.name, operator)
        self.counts[key] = self.counts.get(key, 0) + 1
        self.mutants.append(Mutant(
            id=f"{self.module}/{d.name}/{operator}#{self.counts[key]}", module=self.module,
            definition=d.name, operator=operator, kind=KINDS[operator],
            line=self.text.count("\n", 0, start) + 1, original=" ".join(original.split()),
            mutated=" ".join(replacement.split()) or "(removed)",
            text=self.text[:start] + replacement + self.text[end:]))


def generate(text: str, specs: list[str] | None = None, companions: list[str] | None = None) -> list[Mutant]:
    """Every mutant of one specification module, in a stable order. `specs` names the
    specifications the configurations check (default: every `Spec...`, Init and `...Next` of
    the module); `companions` are the texts of the modules that extend this one (an MC module
    may define a configuration's specification), searched for what those specifications use."""
    masked = mask(text)
    header = _HEADER_RE.search(masked) or _HEADER_RE.search(text)
    if header is None:
        raise ValueError("no MODULE header")
    module = header.group(1)
    b = _Builder(module, text, masked)
    vars_ = variables(masked)
    groups = record_fields(masked)
    defs = definitions(masked)
    live = behavioural(masked, defs, specs, [mask(c) for c in companions or []])
    for d in defs:
        if d.name not in live:
            continue
        body = masked[d.start:d.end]
        initial = d.name == "Init"
        # guard: drop a conjunct that constrains no primed variable (bulleted lists of two or
        # more, and the parts of one-line conjunctions); Init's conjuncts are assignments
        inline = [] if initial else _inline_parts(masked, d, "/\\")
        for lst in [] if initial else _siblings(_junction_items(masked, d, "/\\"), masked):
            if len(lst) < 2:
                continue
            for start, end in lst:
                if _droppable(masked[start:end]) and not any(start <= s < end for s, _ in inline):
                    b.add(d, "drop-guard", start, end, "")
        for start, end in inline:
            if _droppable(masked[start:end]):
                b.add(d, "drop-guard", start, end, "")
        # error: drop a disjunct
        for lst in _siblings(_junction_items(masked, d, "\\/"), masked):
            if len(lst) < 2:
                continue
            for start, end in lst:
                b.add(d, "drop-disjunct", start, end, "")
        for start, end in _inline_parts(masked, d, "\\/"):
            b.add(d, "drop-disjunct", start, end, "")
        # bound: comparisons
        for m in re.finditer(r"(?<![<=>|\-/\\])(<=|>=|=<|<|>)(?![<=>\-])", body):
            op = m.group(1)
            swap = {"<": "<=", "<=": "<", "=<": "<", ">": ">=", ">=": ">"}[op]
            b.add(d, "cmp", d.start + m.start(1), d.start + m.end(1), swap)
        # bound: integer literals off by one
        for m in re.finditer(r"(?<![\w])(\d+)(?![\w])", body):
            n = int(m.group(1))
            s, e = d.start + m.start(1), d.start + m.end(1)
            b.add(d, "literal", s, e, str(n + 1))
            if n > 0:
                b.add(d, "literal", s, e, str(n - 1))
        # guard: negated comparisons and membership (not in Init: its `=` and `\\in` assign)
        for m in re.finditer(r"(?<![=<>!|/\\'#~])(=|#)(?![=<>])", "" if initial else body):
            pos = d.start + m.start(1)
            prev = masked[:pos].rstrip()
            if prev.endswith("'") or _is_except_path(masked, prev):
                continue
            b.add(d, "negate", pos, pos + 1, "#" if m.group(1) == "=" else "=")
        for m in re.finditer(r"\\(notin|in)\b", "" if initial else body):
            s = d.start + m.start()
            if _binds(masked, s):
                continue  # `x \in S` binds x (a quantifier, CHOOSE, a set or function constructor)
            b.add(d, "negate", s, d.start + m.end(), "\\in" if m.group(1) == "notin" else "\\notin")
        # order
        for m in re.finditer(r"\bAppend\(", body):
            s = d.start + m.start()
            e = _bracket_end(masked, d.start + m.end() - 1, d.end)
            args = _split_args(text[d.start + m.end():e - 1])
            if len(args) == 2:
                b.add(d, "append-front", s, e, f"<<{args[1].strip()}>> \\o {args[0].strip()}")
        for m in re.finditer(r"\bHead\(", body):
            s = d.start + m.start()
            e = _bracket_end(masked, d.start + m.end() - 1, d.end)
            arg = text[d.start + m.end():e - 1].strip()
            b.add(d, "head-last", s, e, f"{arg}[Len({arg})]")
        for m in re.finditer(r"\bIF\b(.*?)\bTHEN\b(.*?)\bELSE\b([^\n]*)", body):
            then_, else_ = m.group(2), _balanced_prefix(m.group(3)).rstrip()
            if "\n" in m.group(0) or re.search(r"\b(IF|THEN|ELSE|LET)\b", then_ + else_) \
                    or re.search(r"/\\|\\/", else_) or _balanced_prefix(then_) != then_:
                continue
            s = d.start + m.start(2)
            e = d.start + m.start(3) + len(else_)
            tt = text[d.start + m.start(2):d.start + m.end(2)].strip()
            et = text[d.start + m.start(3):e].strip()
            b.add(d, "swap-if", s, e, f" {et} ELSE {tt}")
        # publish / free: an update left out
        for start, end, var in _unchanged_sites(masked, d, vars_):
            b.add(d, "unchanged", start, end, var)
        # field: another field of the same record
        for m in re.finditer(r"(?<=[\w\])])\.([A-Za-z_]\w*)", body):
            name = m.group(1)
            group = next((g for g in groups if name in g), None)
            if group is None:
                continue
            other = group[(group.index(name) + 1) % len(group)]
            b.add(d, "field", d.start + m.start(1), d.start + m.end(1), other)
        # error: an element of a set literal left out
        for m in re.finditer(r"\{", body):
            s = d.start + m.start()
            e = _bracket_end(masked, s, d.end)
            inner_m = masked[s + 1:e - 1]
            if re.search(r":|\\in\b|\.\.", inner_m) or "\n" in inner_m:
                continue
            parts = _split_args(text[s + 1:e - 1])
            if len(parts) == 1 and parts[0].strip().startswith('"'):
                b.add(d, "set-element", s, e, "{}")
            elif len(parts) > 1:
                for k in range(len(parts)):
                    rest = ", ".join(p.strip() for j, p in enumerate(parts) if j != k)
                    b.add(d, "set-element", s, e, "{" + rest + "}")
    return b.mutants


def _balanced_prefix(s: str) -> str:
    """The longest prefix of `s` that closes no bracket it did not open."""
    depth = 0
    for i, c in enumerate(s):
        if c in "([{":
            depth += 1
        elif c in ")]}":
            depth -= 1
            if depth < 0:
                return s[:i]
    return s


def _binds(masked: str, pos: int) -> bool:
    """True when the `\\in` at `pos` binds a variable: `\\E x \\in`, `CHOOSE x \\in`,
    `[x \\in`, `{x \\in` (a filter), or `{e : x \\in` (a map: no `\\in` before its colon)."""
    line = masked[_line_start(masked, pos):pos]
    if _BINDER_RE.search(line):
        return True
    if not re.search(r":\s*[A-Za-z_][\w\s,]*$", line):
        return False
    depth, i = 0, pos - 1
    while i >= 0:  # find the bracket this `\\in` is inside
        c = masked[i]
        if c in ")]}":
            depth += 1
        elif c in "([{":
            if depth == 0:
                break
            depth -= 1
        i -= 1
    if i < 0 or masked[i] != "{":
        return False
    inner = _top_level(masked[i + 1:pos])
    colon = inner.rfind(":")
    return "\\in" not in inner[:colon]


def _top_level(s: str) -> str:
    """`s` without what its brackets enclose."""
    out, depth = [], 0
    for c in s:
        if c in "([{":
            depth += 1
        elif c in ")]}":
            depth -= 1
        elif depth == 0:
            out.append(c)
    return "".join(out)


def _droppable(conjunct: str) -> bool:
    """A conjunct whose removal leaves a specification: no primed variable, no UNCHANGED (TLC
    needs every variable's next value), not the initial predicate or the next-state relation."""
    core = conjunct.strip().removeprefix("/\\").removesuffix("/\\").strip()
    return ("'" not in conjunct and "UNCHANGED" not in conjunct
            and not re.match(r"(Init\b|\[\]\[)", core))


def _is_except_path(masked: str, prev: str) -> bool:
    """True when the text before an `=` ends with an EXCEPT path: `!` then components `[k]` and
    `.f` in any order (`![k]`, `!.f`, `![s].buf`)."""
    j, parts = len(prev) - 1, 0
    while j >= 0:
        field = re.search(r"\.\w+$", prev[:j + 1])
        if field:
            j, parts = field.start() - 1, parts + 1
        elif prev[j] == "]":
            j, parts = _open_of(prev, j) - 1, parts + 1
        else:
            break
    return parts > 0 and j >= 0 and prev[j] == "!"


def _open_of(s: str, close: int) -> int:
    depth = 0
    for i in range(close, -1, -1):
        if s[i] == "]":
            depth += 1
        elif s[i] == "[":
            depth -= 1
            if depth == 0:
                return i
    return 0


def _split_args(s: str) -> list[str]:
    """Split `s` at the commas of bracket depth 0."""
    parts, depth, cur = [], 0, ""
    i = 0
    while i < len(s):
        if s.startswith("<<", i) or s.startswith(">>", i):
            depth += 1 if s[i] == "<" else -1
            cur += s[i:i + 2]
            i += 2
            continue
        c = s[i]
        if c in "([{":
            depth += 1
        elif c in ")]}":
            depth -= 1
        if c == "," and depth == 0:
            parts.append(cur)
            cur = ""
        else:
            cur += c
        i += 1
    parts.append(cur)
    return parts
