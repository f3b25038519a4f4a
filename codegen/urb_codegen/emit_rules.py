"""A message's rules (`require`) as Python, C and ACSL expressions, for the two emitters.

Each renderer takes the rule's expression tree (model.Rule) and how a member is reached: in Python
`self.status` or `_out.status` (or a decoder's keyword argument `select` itself), in C and ACSL
`msg->status`. Every comparison and combination is parenthesised, so no language's precedence
matters. Enum members are written by name in Python and C (`Status.OK`, `URB_STATUS_OK`) and as
numbers in ACSL; bools as themselves (`select.read`, `!msg->select.read`).
"""

from __future__ import annotations

from collections.abc import Callable

from .model import (
    BytesType,
    EnumDecl,
    IntType,
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
)

Names = Callable[[str], str]  # emit_c's C naming, passed in (emit_c imports this module)


def _enum_of(expr: RuleCompare) -> EnumDecl | None:
    for side in (expr.left, expr.right):
        if isinstance(side, RuleField) and isinstance(side.leaf.type, EnumDecl):
            return side.leaf.type
    return None


def _is_bool(o: RuleOperand) -> bool:
    return isinstance(o, RuleField) and isinstance(o.leaf.type, IntType) and o.leaf.type.is_bool


def _signed(o: RuleOperand) -> bool:
    return isinstance(o, RuleField) and not isinstance(o.leaf.type, EnumDecl) and o.leaf.int_type.signed


class _Renderer:
    """Shared shape of the three languages: operators and how operands and constants look."""

    AND = " && "
    OR = " || "
    NOT = "!"

    def member(self, ref: RuleField) -> str:
        raise NotImplementedError

    def length(self, ref: RuleLength) -> str:
        raise NotImplementedError

    def constant(self, const: RuleConst, other: RuleOperand, expr: RuleCompare) -> str:
        raise NotImplementedError

    def truth(self, ref: RuleField, positive: bool) -> str:
        raise NotImplementedError

    def both_members(self, left: str, op: str, right: str, expr: RuleCompare) -> str:
        return f"({left} {op} {right})"

    def expr(self, e: RuleExpr) -> str:
        if isinstance(e, RuleTruth):
            return self.truth(e.member, True)
        if isinstance(e, RuleNot):
            return self.violated(e.inner)
        if isinstance(e, (RuleAll, RuleAny)):
            joiner = self.AND if isinstance(e, RuleAll) else self.OR
            return "(" + joiner.join(self.expr(item) for item in e.items) + ")"
        return self.compare(e)

    def violated(self, e: RuleExpr) -> str:
        """The expression that is true when `e` is false, without a double negation; like every
        expression here, one operand or wrapped in parentheses, so it nests anywhere."""
        if isinstance(e, RuleNot):
            return self.expr(e.inner)
        if isinstance(e, RuleTruth):
            return self.truth(e.member, False)
        if isinstance(e, RuleCompare):  # `a == 3` is broken when `a != 3`
            return self.compare(RuleCompare(e.left, _NEGATED[e.op], e.right))
        return f"({self.NOT}{self.expr(e)})"

    def compare(self, e: RuleCompare) -> str:
        left, right = e.left, e.right
        if isinstance(left, RuleConst) or isinstance(right, RuleConst):
            member, const, op = (right, left, _mirror(e.op)) if isinstance(left, RuleConst) else (left, right, e.op)
            assert not isinstance(member, RuleConst) and isinstance(const, RuleConst)
            if _is_bool(member):  # `read == true` is `read`, `read != true` is `not read`
                assert isinstance(member, RuleField)
                return self.truth(member, (const.value != 0) == (op == "=="))
            return f"({self.operand(member)} {op} {self.constant(const, member, e)})"
        return self.both_members(self.operand(left), e.op, self.operand(right), e)

    def operand(self, o: RuleOperand) -> str:
        if isinstance(o, RuleField):
            return self.member(o)
        assert isinstance(o, RuleLength)
        return self.length(o)


def unwrap(cond: str) -> str:
    """`(a)` -> `a` when the outer parentheses enclose the whole condition (an `if` needs none)."""
    if not (cond.startswith("(") and cond.endswith(")")):
        return cond
    depth = 0
    for i, ch in enumerate(cond):
        depth += {"(": 1, ")": -1}.get(ch, 0)
        if depth == 0 and i < len(cond) - 1:
            return cond  # `(a) || (b)`: the first parenthesis closes before the end
    return cond[1:-1]


_NEGATED = {"==": "!=", "!=": "==", "<": ">=", "<=": ">", ">": "<=", ">=": "<"}


def _mirror(op: str) -> str:
    """The operator with its operands swapped: `3 < x` is `x > 3`."""
    return {"<": ">", ">": "<", "<=": ">=", ">=": "<="}.get(op, op)


class _Python(_Renderer):
    AND = " and "
    OR = " or "
    NOT = "not "

    def __init__(self, root: str) -> None:
        self.root = root  # "self." or "_out.", or "" for a decoder's keyword arguments

    def member(self, ref: RuleField) -> str:
        return self.root + ref.text

    def length(self, ref: RuleLength) -> str:
        return f"len({self.root}{ref.payload.name})"

    def constant(self, const: RuleConst, other: RuleOperand, expr: RuleCompare) -> str:
        enum = _enum_of(expr)
        if enum is not None and const.name is not None:
            return f"{enum.name}.{const.name}"
        return str(const.value)

    def truth(self, ref: RuleField, positive: bool) -> str:
        return self.member(ref) if positive else f"(not {self.member(ref)})"


class _C(_Renderer):
    def __init__(self, member_name: Names, enum_prefix: Callable[[EnumDecl], str]) -> None:
        self.member_name = member_name  # a field's C member: a C keyword gets a trailing `_`
        self.enum_prefix = enum_prefix  # `Status` -> `URB_STATUS`, the prefix of its members' names

    def member(self, ref: RuleField) -> str:
        return "msg->" + ".".join(self.member_name(f.name) for f in ref.path)

    def length(self, ref: RuleLength) -> str:
        t = ref.payload.type
        assert isinstance(t, BytesType)
        if t.count_field is not None:
            return f"msg->{self.member_name(t.count_field)}"
        return f"msg->{self.member_name(ref.payload.name)}_len"

    def constant(self, const: RuleConst, other: RuleOperand, expr: RuleCompare) -> str:
        enum = _enum_of(expr)
        if enum is not None and const.name is not None:
            return f"{self.enum_prefix(enum)}_{const.name}"
        if _signed(other):
            return str(const.value) if const.value != -(1 << 31) else f"({const.value + 1} - 1)"
        return f"{const.value}u"

    def truth(self, ref: RuleField, positive: bool) -> str:
        return self.member(ref) if positive else f"(!{self.member(ref)})"

    def both_members(self, left: str, op: str, right: str, expr: RuleCompare) -> str:
        if _signed(expr.left) != _signed(expr.right):  # no signed/unsigned mix: compare as 64-bit
            return f"((int64_t){left} {op} (int64_t){right})"
        return f"({left} {op} {right})"


class _Acsl(_C):
    def constant(self, const: RuleConst, other: RuleOperand, expr: RuleCompare) -> str:
        return str(const.value)

    def both_members(self, left: str, op: str, right: str, expr: RuleCompare) -> str:
        return f"({left} {op} {right})"  # ACSL compares mathematical integers: no conversion to fear

    def truth(self, ref: RuleField, positive: bool) -> str:
        return f"({self.member(ref)} {'!=' if positive else '=='} 0)"


def python_violation(rule: Rule, root: str) -> str:
    """Python expression that is true when `rule` is broken; members are read as `<root><path>`."""
    return unwrap(_Python(root).violated(rule.expr))


def python_condition(rule: Rule, root: str) -> str:
    """Python expression that is true when `rule` holds; members are read as `<root><path>`."""
    return _Python(root).expr(rule.expr)


def c_violation(rule: Rule, member_name: Names, enum_prefix: Callable[[EnumDecl], str]) -> str:
    """C expression over `msg->...` that is true when `rule` is broken."""
    return unwrap(_C(member_name, enum_prefix).violated(rule.expr))


def acsl_condition(rule: Rule, member_name: Names) -> str:
    """ACSL predicate over `msg->...` that holds when `rule` does (for the decoder's contract)."""
    return _Acsl(member_name, lambda e: "").expr(rule.expr)
