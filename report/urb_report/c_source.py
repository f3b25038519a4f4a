"""Just enough C structure for tools/c_mutate.py and tools/tla_xref.py: comments, code without
comments, literals, directives and dead seeded-bug branches, function bodies, statements and struct
fields, all by offset into the text.

The firmware follows a house style (C99, one statement per line mostly, braces on every block);
this is not a C parser, and every result is an offset range into the original text, so a
misreading shows up as a mutant that does not compile ("stillborn"), never as a silent change of
something else.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

_LEXEME = re.compile(r"/\*.*?(?:\*/|\Z)|//[^\n]*|\"(?:\\.|[^\"\\\n])*\"|'(?:\\.|[^'\\\n])*'", re.DOTALL)
_DIRECTIVE = re.compile(r"^[ \t]*#(?:[^\n]*\\\n)*[^\n]*", re.MULTILINE)
_KEYWORDS = {"if", "while", "for", "switch", "return", "sizeof", "do", "else", "case", "default", "break",
             "continue", "goto"}


def _blank(text: str) -> str:
    return re.sub(r"[^\n]", " ", text)


def comments(text: str) -> list[tuple[int, str]]:
    """Every comment's text (without its `/*`, `*/` or `//`) and the offset where that text starts;
    string and character literals are skipped."""
    out = []
    for m in _LEXEME.finditer(text):
        lexeme = m.group()
        if lexeme.startswith("/*"):
            out.append((m.start() + 2, lexeme[2:-2] if lexeme.endswith("*/") and len(lexeme) >= 4 else lexeme[2:]))
        elif lexeme.startswith("//"):
            out.append((m.start() + 2, lexeme[2:]))
    return out


def seeded_dead(text: str) -> list[tuple[int, int]]:
    """Offset ranges compiled only with a hand-seeded bug (`#ifdef URB_MUTANT_X` branches, the
    `#else` of `#ifndef URB_MUTANT_X`): dead in every normal build, so changing them changes nothing."""
    dead: list[tuple[int, int]] = []
    stack: list[tuple[bool, bool, int]] = []  # (tests a seeded bug, this branch is dead, its start)
    for m in _DIRECTIVE.finditer(text):
        line = m.group().strip()
        word = re.match(r"#\s*(\w+)", line)
        directive = word.group(1) if word else ""
        positive = "URB_MUTANT_" in line and (directive == "ifdef" or (directive in ("if", "elif") and
                                                                         not re.search(r"!\s*defined", line)))
        if directive in ("if", "ifdef", "ifndef"):
            stack.append(("URB_MUTANT_" in line, positive, m.end()))
            continue
        if directive not in ("else", "elif", "endif") or not stack:
            continue
        seeded, was_dead, start = stack.pop()
        if was_dead:
            dead.append((start, m.start()))
        if directive == "else":
            stack.append((seeded, seeded and not was_dead, m.end()))
        elif directive == "elif":
            stack.append((seeded, positive, m.end()))
    return dead


def code_of(text: str) -> str:
    """The text with comments, string and character literals, preprocessor directives and dead
    seeded-bug branches blanked (same length, newlines kept): offsets stay valid."""
    code = _LEXEME.sub(lambda m: _blank(m.group()), text)
    code = _DIRECTIVE.sub(lambda m: _blank(m.group()), code)
    for start, end in seeded_dead(text):
        code = code[:start] + _blank(code[start:end]) + code[end:]
    return code


@dataclass(frozen=True)
class Function:
    name: str
    open: int  # offset of the body's `{`
    close: int  # offset just after its `}`


def functions(code: str) -> list[Function]:
    """Every function definition of comment-free code (see code_of)."""
    out: list[Function] = []
    depth, start = 0, 0
    for m in re.finditer(r"[{}]", code):
        if m.group() == "{":
            if depth == 0:
                start = m.start()
            depth += 1
        elif depth > 0:
            depth -= 1
            if depth == 0:
                head = code[max(0, start - 2000):start].rstrip()
                sig = re.search(r"\b([A-Za-z_]\w*)\s*\([^;{}()]*(?:\([^;{}()]*\)[^;{}()]*)*\)$", head)
                if sig and sig.group(1) not in _KEYWORDS:
                    out.append(Function(sig.group(1), start, m.end()))
    return out


def function_at(code: str, offset: int) -> str:
    """The name of the function whose body holds `offset`, or ""."""
    return next((f.name for f in functions(code) if f.open <= offset < f.close), "")


# =============================================================================== statements


@dataclass
class Statement:
    """One statement: its kind ("expr", "decl", "return", "jump", "if", "loop", "switch", "block",
    "label"), its text range, and for compound statements the blocks (lists of statements) inside."""

    kind: str
    start: int
    end: int
    blocks: list[list[Statement]] = field(default_factory=list)
    guard: bool = False  # a statement that is the whole body of an `if` branch (directly or in braces)


def _skip_ws(code: str, i: int, end: int) -> int:
    while i < end and code[i].isspace():
        i += 1
    return i


def _matching(code: str, i: int, end: int) -> int:
    """Offset after the bracket that closes the one at `i`."""
    pairs = {"(": ")", "[": "]", "{": "}"}
    stack = [pairs[code[i]]]
    i += 1
    while i < end and stack:
        c = code[i]
        if c in pairs:
            stack.append(pairs[c])
        elif c in ")]}":
            if c != stack[-1]:
                raise ValueError(f"unbalanced {c!r} at offset {i}")
            stack.pop()
        i += 1
    if stack:
        raise ValueError("unbalanced brackets")
    return i


def _until_semicolon(code: str, i: int, end: int) -> int:
    """Offset after the `;` that ends the statement starting at `i` (brackets skipped)."""
    while i < end:
        c = code[i]
        if c in "([{":
            i = _matching(code, i, end)
            continue
        if c == ";":
            return i + 1
        i += 1
    raise ValueError("statement without `;`")


_DECL = re.compile(r"(?:(?:const|static|volatile|register)\s+)*(?:struct\s+\w+|enum\s+\w+|unsigned|signed|"
                   r"[A-Za-z_]\w*_t|bool|int|char|short|long|float|double|void)\b[\s*]*(?:const\s+)?[\s*]*"
                   r"([A-Za-z_]\w*)\s*(?:=|\[|;|,)")


def parse_block(code: str, start: int, end: int, guard: bool = False) -> list[Statement]:
    """The statements between `start` and `end` (the inside of a `{...}`)."""
    out: list[Statement] = []
    i = _skip_ws(code, start, end)
    while i < end:
        stmt = _statement(code, i, end)
        if guard:
            stmt.guard = True
        out.append(stmt)
        i = _skip_ws(code, stmt.end, end)
    return out


def _word(code: str, i: int) -> str:
    m = re.match(r"[A-Za-z_]\w*", code[i:i + 64])
    return m.group() if m else ""


def _sub(code: str, i: int, end: int, guard: bool = False) -> Statement:
    """A sub-statement (the body of an if/else/loop); a braced body is parsed as a block."""
    i = _skip_ws(code, i, end)
    stmt = _statement(code, i, end)
    if guard:
        stmt.guard = True
        for inner in stmt.blocks[0] if stmt.kind == "block" and stmt.blocks else []:
            inner.guard = True
    return stmt


def _statement(code: str, i: int, end: int) -> Statement:
    word = _word(code, i)
    if code[i] == "{":
        close = _matching(code, i, end)
        return Statement("block", i, close, [parse_block(code, i + 1, close - 1)])
    if code[i] == ";":
        return Statement("expr", i, i + 1)
    if word in ("if", "while", "for", "switch"):
        paren = _skip_ws(code, i + len(word), end)
        body_start = _matching(code, paren, end)
        body = _sub(code, body_start, end, guard=(word == "if"))
        blocks = [_flatten_body(body)]
        stop = body.end
        if word == "if":
            nxt = _skip_ws(code, stop, end)
            if _word(code, nxt) == "else":
                other = _sub(code, nxt + 4, end, guard=True)
                blocks.append(_flatten_body(other))
                stop = other.end
        kind = {"if": "if", "switch": "switch"}.get(word, "loop")
        return Statement(kind, i, stop, blocks)
    if word == "do":
        body = _sub(code, i + 2, end)
        return Statement("loop", i, _until_semicolon(code, body.end, end), [_flatten_body(body)])
    if word in ("case", "default"):
        colon = code.index(":", i)
        return Statement("label", i, colon + 1)
    if word == "return":
        return Statement("return", i, _until_semicolon(code, i, end))
    if word in ("break", "continue", "goto"):
        return Statement("jump", i, _until_semicolon(code, i, end))
    stop = _until_semicolon(code, i, end)
    return Statement("decl" if _DECL.match(code, i) else "expr", i, stop)


def _flatten_body(stmt: Statement) -> list[Statement]:
    """A body as a block's statement list: the block's own list, or the single statement."""
    return stmt.blocks[0] if stmt.kind == "block" else [stmt]


def walk(stmts: list[Statement]) -> list[Statement]:
    """Every statement, nested ones included, in text order."""
    out: list[Statement] = []
    for s in stmts:
        out.append(s)
        for block in s.blocks:
            out.extend(walk(block))
    return out


def blocks_of(stmts: list[Statement]) -> list[list[Statement]]:
    """Every statement list (the function body and each nested block), for swaps of neighbours."""
    out = [stmts]
    for s in stmts:
        for block in s.blocks:
            out.extend(blocks_of(block))
    return out


# =============================================================================== struct fields


@dataclass(frozen=True)
class Member:
    struct: str
    name: str
    type: str  # the declared type with array dimensions, whitespace normalised


def struct_members(text: str) -> list[Member]:
    """The members of every struct defined in a header, in declaration order (nested struct
    members are skipped: their type text would be the whole nested definition)."""
    code = code_of(text)
    out: list[Member] = []
    for m in re.finditer(r"\bstruct\s*(\w*)\s*\{", code):
        open_at = m.end() - 1
        close = _matching(code, open_at, len(code))
        tail = re.match(r"\s*(\w+)", code[close:])
        name = m.group(1) or (tail.group(1) if tail else "")  # the tag; see struct_aliases
        body = code[open_at + 1:close - 1]
        depth = 0
        decl = ""
        for c in body:
            if c == "{":
                depth += 1
            elif c == "}":
                depth -= 1
                decl = ""
                continue
            if depth:
                continue
            if c == ";":
                out.extend(_declared(name, decl))
                decl = ""
            else:
                decl += c
    return out


def _declared(struct: str, decl: str) -> list[Member]:
    """The members one declaration `type a, *b[4]` declares (none for function pointers and bit-fields)."""
    decl = " ".join(decl.split())
    if not decl or "(" in decl or ":" in decl:
        return []
    parts = decl.split(",")
    first = re.match(r"^(.*?\w)([\s*]+)([A-Za-z_]\w*)((?:\s*\[[^\]]*\])*)$", parts[0])
    if first is None:
        return []
    base = first.group(1).strip()
    out = [Member(struct, first.group(3), base + first.group(2).count("*") * "*" + re.sub(r"\s+", "", first.group(4)))]
    for part in parts[1:]:
        m = re.match(r"^\s*(\**)\s*([A-Za-z_]\w*)((?:\s*\[[^\]]*\])*)$", part)
        if m:
            out.append(Member(struct, m.group(2), base + m.group(1) + re.sub(r"\s+", "", m.group(3))))
    return out


def struct_aliases(text: str) -> dict[str, str]:
    """Typedef name -> struct tag, for `typedef struct tag name;` and `typedef struct tag {...} name;`."""
    code = code_of(text)
    out = {m.group(2): m.group(1) for m in re.finditer(r"\btypedef\s+struct\s+(\w+)\s+(\w+)\s*;", code)}
    for m in re.finditer(r"\btypedef\s+struct\s+(\w+)\s*\{", code):
        close = _matching(code, m.end() - 1, len(code))
        tail = re.match(r"\s*(\w+)\s*;", code[close:])
        if tail:
            out[tail.group(1)] = m.group(1)
    return out
