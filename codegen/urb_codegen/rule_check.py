"""Resolve and check the rules of a message (`require EXPR "doc"`, see spec/schema/README.md).

A rule names scalar members of its message (`status`, `select.read` through a nested message) and
payload lengths (`len(data)`), compares them with each other or with numbers, constants, enum
members and true/false, and combines comparisons with `not`, `and`, `or`. Each name is resolved
against the message's own fields first; a name that is no field is read as a member of the enum on
the other side of its comparison, then as a constant, then as true/false next to a bool.

Refused, each with a hint: a name that is no field, member or constant; a path into something
other than a nested message; reserved, fixed, length, payload, check and array fields; comparisons
between different kinds (an enum with a number, a bool with a number); `<` and friends on enums
and bools; numbers outside the member's type; and, when the members it names take at most
2**16 value combinations, a rule that no combination satisfies or that every combination does.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterator
from pathlib import Path

from lark import Token, Tree

from .errors import Location
from .model import (
    ArrayType,
    BytesType,
    CheckType,
    ConstDecl,
    EnumDecl,
    Field,
    IntType,
    MessageDecl,
    Rule,
    RuleAll,
    RuleAny,
    RuleCompare,
    RuleConst,
    RuleExpr,
    RuleField,
    RuleLength,
    RuleNot,
    RuleOperand,
    RuleTruth,
    rule_holds,
)

ErrorSink = Callable[[Location, str, str], None]
Lookup = Callable[[str], object | None]

_ENUMERATE_LIMIT = 1 << 16  # value combinations a rule's satisfiability check walks at most


class _Refused(Exception):
    """A problem already reported; resolution of this rule stops."""


def _location(path: Path, node: Tree[Token] | Token) -> Location:
    if isinstance(node, Token):
        return Location(path, node.line or 1, node.column or 1)
    return Location(path, getattr(node.meta, "line", 1), getattr(node.meta, "column", 1))


class _Pending:
    """A bare name whose meaning depends on the other side of its comparison (a member, a constant)."""

    def __init__(self, token: Token) -> None:
        self.token = token


class RuleResolver:
    """Turns the parse tree of one `require` into a model Rule of `msg`, reporting through `err`."""

    def __init__(self, msg: MessageDecl, path: Path, lookup: Lookup, err: ErrorSink) -> None:
        self.msg = msg
        self.path = path
        self.lookup = lookup
        self.report = err

    def fail(self, node: Tree[Token] | Token, message: str, hint: str) -> _Refused:
        self.report(_location(self.path, node), message, hint)
        return _Refused()

    def resolve(self, tree: Tree[Token], doc: str) -> Rule | None:
        """The rule, or None after reporting why it cannot be one."""
        keyword = tree.children[0]
        expr_node = tree.children[1]
        assert isinstance(keyword, Token) and isinstance(expr_node, (Tree, Token))
        try:
            expr = self.expr(expr_node)
            rule = Rule(expr, doc, _location(self.path, keyword))
            self.check_meaningful(rule, keyword)
        except _Refused:
            return None
        return rule

    # --- expressions ---------------------------------------------------------------------------
    def expr(self, node: Tree[Token] | Token) -> RuleExpr:
        assert isinstance(node, Tree), node
        kind = node.data
        subs = [c for c in node.children if isinstance(c, (Tree, Token))]
        if kind in ("rule_or", "rule_and"):
            items: list[RuleExpr] = []
            for sub in subs:
                part = self.expr(sub)
                same = RuleAny if kind == "rule_or" else RuleAll
                items += part.items if isinstance(part, same) else [part]  # a or b or c: one list
            return RuleAny(items) if kind == "rule_or" else RuleAll(items)
        if kind == "rule_not":
            return RuleNot(self.expr(subs[0]))
        if kind == "rule_truth":
            operand = self.operand(subs[0])
            text = _text(subs[0])
            if isinstance(operand, _Pending):
                raise self.fail(node, f"'{text}' is not a field of {self.msg.name}: a rule on its own needs a bool field",
                                "name a bool field (`select.read`), or compare, e.g. `status == OK`")
            if not isinstance(operand, RuleField) or not _is_bool(operand.leaf):
                raise self.fail(node, f"`{operand.text}` is {self.describe(operand)}, not a bool: a rule needs a condition",
                                f"compare it, e.g. `{operand.text} != 0`, or name a bool field")
            return RuleTruth(operand)
        if kind == "rule_compare":
            left_node, op_tok, right_node = subs
            assert isinstance(op_tok, Token)
            return self.compare(node, self.operand(left_node), str(op_tok), self.operand(right_node))
        raise AssertionError(kind)

    def compare(self, node: Tree[Token], left: RuleOperand | _Pending, op: str,
                right: RuleOperand | _Pending) -> RuleCompare:
        if isinstance(left, (_Pending, RuleConst)) and isinstance(right, (_Pending, RuleConst)):
            raise self.fail(node, "this comparison names no field: its result never changes",
                            "compare a field (or `len(payload)`) with a value, e.g. `status == OK`")
        if isinstance(left, _Pending):
            assert not isinstance(right, (_Pending, RuleConst))
            left = self.value_for(left.token, right)
        if isinstance(right, _Pending):
            assert not isinstance(left, RuleConst)
            right = self.value_for(right.token, left)
        kinds = [self.kind(o) for o in (left, right)]
        known = [k for k in kinds if k is not None]
        if len(set(known)) > 1:
            raise self.fail(node, f"`{left.text}` ({self.describe(left)}) and `{right.text}` ({self.describe(right)}) "
                            "cannot be compared", "compare a field with a value or field of the same kind "
                            "(numbers with numbers, an enum with its members, a bool with true or false)")
        kind = known[0]
        if kind != "number" and op not in ("==", "!="):
            raise self.fail(node, f"`{op}` compares numbers, but `{left.text} {op} {right.text}` compares "
                            f"{'enum members' if kind.startswith('enum') else 'bools'}",
                            "an enum or a bool has no order: use == or !=")
        for this, other in ((left, right), (right, left)):
            if not isinstance(this, RuleConst) or isinstance(other, RuleConst):
                continue
            if kind != "number" and this.name is None:
                raise self.fail(node, f"`{other.text}` is {self.describe(other)}, compared here with the number "
                                f"{this.value}", "write " + ("the member's name" if kind.startswith("enum")
                                                              else "true or false") + " instead of a number")
            lo, hi = self.bounds(other)
            if not lo <= this.value <= hi:
                raise self.fail(node, f"`{other.text}` holds {lo}..{hi}, so comparing it with {this.text} "
                                "decides nothing", f"use a value in {lo}..{hi}")
        return RuleCompare(left, op, right)

    def value_for(self, token: Token, other: RuleOperand) -> RuleConst:
        """The bare name `token` read against the operand it is compared with."""
        name = str(token)
        if isinstance(other, RuleField) and isinstance(other.leaf.type, EnumDecl):
            enum = other.leaf.type
            member = next((m for m in enum.members if m.name == name), None)
            if member is None:
                raise self.fail(token, f"'{name}' is not a member of enum {enum.name} (the type of `{other.text}`)",
                                "use one of: " + ", ".join(m.name for m in enum.members))
            return RuleConst(member.value, name)
        if isinstance(other, RuleField) and _is_bool(other.leaf):
            if name not in ("true", "false"):
                raise self.fail(token, f"`{other.text}` is a bool, so '{name}' must be true or false",
                                "write `true` or `false`, or name the bool alone (`select.read`, `not select.read`)")
            return RuleConst(1 if name == "true" else 0, name)
        found = self.lookup(name)
        if isinstance(found, ConstDecl):
            return RuleConst(found.value, name)
        raise self.fail(token, f"unknown name '{name}': not a field of {self.msg.name}, nor a constant",
                        "name a field of this message, `len(<payload>)`, a constant, a number, an enum member "
                        "next to a field of that enum, or true/false next to a bool")

    # --- operands ------------------------------------------------------------------------------
    def operand(self, node: Tree[Token] | Token) -> RuleOperand | _Pending:
        assert isinstance(node, Tree), node
        if node.data == "rule_number":
            tok = node.children[0]
            assert isinstance(tok, Token)
            return RuleConst(_number(str(tok)))
        if node.data == "rule_len":
            tok = node.children[0]
            assert isinstance(tok, Token)
            payload = next((f for f in self.msg.fields if f.name == str(tok)), None)
            if payload is None or not isinstance(payload.type, BytesType):
                raise self.fail(tok, f"`len({tok})`: {self.msg.name} has no byte payload named '{tok}'",
                                "len() takes the name of the message's bytes[...] field")
            return RuleLength(payload)
        assert node.data == "rule_path", node.data
        names = [t for t in node.children if isinstance(t, Token)]
        first = next((f for f in self.msg.fields if f.name == str(names[0])), None)
        if first is None:
            if len(names) == 1:
                return _Pending(names[0])  # a member or a constant: decided by the other side
            raise self.fail(names[0], f"'{names[0]}' is not a field of {self.msg.name}",
                            "start the path with a field of this message")
        path = [first]
        for tok in names[1:]:
            inner = path[-1].type
            if not isinstance(inner, MessageDecl):
                raise self.fail(tok, f"`{'.'.join(f.name for f in path)}` is not a message, so it has no '{tok}'",
                                "a path goes through nested message fields only: `select.read`")
            sub = next((f for f in inner.fields if f.name == str(tok)), None)
            if sub is None:
                raise self.fail(tok, f"message {inner.name} has no field '{tok}'",
                                "fields: " + ", ".join(f.name for f in inner.fields if not f.is_padding))
            path.append(sub)
        ref = RuleField(tuple(path))
        self.check_member(names[-1], ref)
        return ref

    def check_member(self, tok: Token, ref: RuleField) -> None:
        f = ref.leaf
        counts = {b.type.count_field for b in self.msg.fields if isinstance(b.type, BytesType) and b.type.count_field}
        if f.is_padding:
            raise self.fail(tok, "`_` is reserved (always zero), so a rule cannot name it", "name a field")
        if f.fixed is not None:
            raise self.fail(tok, f"`{ref.text}` is fixed to {f.fixed_name or f.fixed}: a rule about it is always "
                            "true or always false", "name a field that carries a value")
        if len(ref.path) == 1 and f.name in counts:
            payload = next(b for b in self.msg.fields if isinstance(b.type, BytesType) and b.type.count_field == f.name)
            raise self.fail(tok, f"`{f.name}` counts the payload {payload.name}, which Python derives from the "
                            "payload itself", f"write `len({payload.name})`")
        if isinstance(f.type, BytesType):
            raise self.fail(tok, f"`{ref.text}` is a byte payload, not a number", f"compare its length: `len({f.name})`")
        if isinstance(f.type, CheckType):
            raise self.fail(tok, f"`{ref.text}` is the frame check, which the decoder verifies itself",
                            "name the fields the rule is about")
        if isinstance(f.type, ArrayType):
            raise self.fail(tok, f"`{ref.text}` is an array; rules name single members",
                            "make the element a field of its own, or state the rule in prose")
        if isinstance(f.type, MessageDecl):
            inner = [g.name for g in f.type.fields if not g.is_padding and g.fixed is None]
            raise self.fail(tok, f"`{ref.text}` is a message ({f.type.name}); rules compare its fields",
                            f"name one of them, e.g. `{ref.text}.{inner[0] if inner else '...'}`")

    # --- kinds and domains ---------------------------------------------------------------------
    def kind(self, o: RuleOperand) -> str | None:
        """'number', 'bool' or 'enum <Name>'; None for a constant (it takes the other side's kind)."""
        if isinstance(o, RuleConst):
            return None
        if isinstance(o, RuleLength):
            return "number"
        t = o.leaf.type
        if isinstance(t, EnumDecl):
            return f"enum {t.name}"
        return "bool" if _is_bool(o.leaf) else "number"

    def describe(self, o: RuleOperand) -> str:
        if isinstance(o, RuleConst):
            return "a value"
        if isinstance(o, RuleLength):
            return "a payload length"
        t = o.leaf.type
        if isinstance(t, EnumDecl):
            return f"an enum {t.name}"
        return "a bool" if _is_bool(o.leaf) else f"a {o.leaf.int_type.name} number"

    def bounds(self, o: RuleOperand) -> tuple[int, int]:
        """Smallest and largest value of the operand in a message whose fields are valid."""
        if isinstance(o, RuleConst):
            return o.value, o.value
        if isinstance(o, RuleLength):
            t = o.payload.type
            assert isinstance(t, BytesType)
            counter = next((f for f in self.msg.fields if f.name == t.count_field), None)
            lo, hi = counter.range if counter is not None and counter.range is not None else (0, t.max_len)
            return lo, min(hi, t.max_len)
        f = o.leaf
        if isinstance(f.type, EnumDecl):
            values = [m.value for m in f.type.members]
            return min(values), max(values)
        it = f.int_type
        return f.range if f.range is not None else (it.min, it.max)

    def values(self, o: RuleOperand) -> list[int]:
        """Every value the operand takes in a message whose fields are valid."""
        if isinstance(o, RuleField) and isinstance(o.leaf.type, EnumDecl):
            return sorted(m.value for m in o.leaf.type.members)
        lo, hi = self.bounds(o)
        return list(range(lo, hi + 1))

    def check_meaningful(self, rule: Rule, where: Token) -> None:
        """Refuse a rule that no valid message meets, or that every one does (when cheap to decide)."""
        members: dict[str, RuleOperand] = {o.key: o for o in rule.operands if not isinstance(o, RuleConst)}
        total = 1
        for o in members.values():
            lo, hi = self.bounds(o)
            total *= hi - lo + 1
        if total > _ENUMERATE_LIMIT:
            return  # too many combinations to walk: not decided here
        domains = [self.values(o) for o in members.values()]
        seen = {rule_holds(rule.expr, dict(zip(members, combo))) for combo in itertools.product(*domains)}
        if seen == {False}:
            raise self.fail(where, f"no message satisfies `require {rule.text}`: encode would refuse every one",
                            "check the comparisons (and/or, the values)")
        if seen == {True}:
            raise self.fail(where, f"every message satisfies `require {rule.text}`: it checks nothing",
                            "drop the rule (the fields' types already ensure it), or fix the comparison")


def _number(text: str) -> int:
    """A decimal (leading zeros allowed) or 0x hexadecimal number, with an optional minus sign."""
    sign = -1 if text.startswith("-") else 1
    digits = text.lstrip("-")
    return sign * (int(digits, 16) if digits.lower().startswith("0x") else int(digits, 10))


def _is_bool(f: Field) -> bool:
    return isinstance(f.type, IntType) and f.type.is_bool


def _text(node: Tree[Token] | Token) -> str:
    if isinstance(node, Token):
        return str(node)
    return ".".join(str(t) for t in _tokens(node))


def _tokens(node: Tree[Token]) -> Iterator[Token]:
    for c in node.children:
        if isinstance(c, Token):
            yield c
        elif isinstance(c, Tree):
            yield from _tokens(c)
