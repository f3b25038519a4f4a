"""The checked, resolved schema model that the emitters read.

Wire rules (spec/schema/README.md): fields pack LSB-first in declared order, so the fixed part of a
message is one little-endian integer with every field at a bit offset; multi-byte integers are
little-endian; a variable payload, when present, follows the fixed part; the check closes the frame.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Union

from .errors import Location

MAX_MAILBOX_SIZE = 32
MAILBOXES = 8


@dataclass(frozen=True)
class IntType:
    """An integer of `bits` bits; `bool` is a 1-bit unsigned integer with a flag."""

    bits: int
    signed: bool
    is_bool: bool = False

    @property
    def name(self) -> str:
        if self.is_bool:
            return "bool"
        return f"{'i' if self.signed else 'u'}{self.bits}"

    @property
    def min(self) -> int:
        return -(1 << (self.bits - 1)) if self.signed else 0

    @property
    def max(self) -> int:
        return (1 << (self.bits - 1)) - 1 if self.signed else (1 << self.bits) - 1


@dataclass
class ConstDecl:
    name: str
    value: int
    doc: str
    loc: Location


@dataclass
class EnumMember:
    name: str
    value: int
    doc: str
    loc: Location


@dataclass
class EnumDecl:
    name: str
    base: IntType
    doc: str
    loc: Location
    members: list[EnumMember]
    schema: str = ""

    @property
    def bits(self) -> int:
        return self.base.bits


@dataclass(frozen=True)
class CrcTier:
    """One CRC: MSB-first (not reflected), stored little-endian after the covered bytes."""

    name: str
    width: int
    poly: int
    init: int
    xorout: int
    max_covered: int | None  # None: used for every longer frame


@dataclass
class ChecksumDecl:
    name: str
    doc: str
    loc: Location
    tiers: list[CrcTier]
    schema: str = ""

    def tier_for(self, covered: int) -> CrcTier:
        """The CRC used when `covered` bytes are checked."""
        for tier in self.tiers:
            if tier.max_covered is None or covered <= tier.max_covered:
                return tier
        raise AssertionError("the last tier has no limit")  # guaranteed by the checker


@dataclass(frozen=True)
class ArrayType:
    element: "ScalarOrStruct"
    count: int


@dataclass(frozen=True)
class BytesType:
    max_len: int
    count_field: str | None  # None: the payload runs to the check (or the end of the frame)


@dataclass(frozen=True)
class CheckType:
    checksum: ChecksumDecl
    first: str
    last: str


ScalarOrStruct = Union[IntType, EnumDecl, "MessageDecl"]
FieldType = Union[IntType, EnumDecl, "MessageDecl", ArrayType, BytesType, CheckType]


@dataclass
class Field:
    name: str
    type: FieldType
    doc: str
    loc: Location
    fixed: int | None = None
    fixed_name: str | None = None
    range: tuple[int, int] | None = None
    unit: str | None = None
    scale: float | None = None
    offset: float | None = None
    implicit: bool = False
    position: int | None = None
    bit_offset: int = 0  # within the fixed part (or within the implicit prefix)
    bit_width: int = 0

    @property
    def is_padding(self) -> bool:
        return self.name == "_"

    @property
    def is_scalar(self) -> bool:
        return isinstance(self.type, (IntType, EnumDecl))

    @property
    def int_type(self) -> IntType:
        """The integer representation of a scalar field (enums use their base type)."""
        if isinstance(self.type, IntType):
            return self.type
        if isinstance(self.type, EnumDecl):
            return self.type.base
        raise TypeError(f"field {self.name} is not a scalar")

    @property
    def has_engineering(self) -> bool:
        return self.unit is not None or self.scale is not None or self.offset is not None


# --- rules (`require EXPR "doc"`) ------------------------------------------------------------------


@dataclass
class RuleField:
    """A scalar member named by a path of fields: `status`, `select.read`."""

    path: tuple["Field", ...]

    @property
    def leaf(self) -> "Field":
        return self.path[-1]

    @property
    def text(self) -> str:
        return ".".join(f.name for f in self.path)

    @property
    def key(self) -> str:
        return self.text


@dataclass
class RuleLength:
    """`len(payload)`: the number of payload bytes."""

    payload: "Field"

    @property
    def text(self) -> str:
        return f"len({self.payload.name})"

    @property
    def key(self) -> str:
        return self.text


@dataclass
class RuleConst:
    """A number, a constant, an enum member or true/false, as the rule spells it (`name`)."""

    value: int
    name: str | None = None

    @property
    def text(self) -> str:
        return self.name if self.name is not None else str(self.value)


RuleOperand = Union[RuleField, RuleLength, RuleConst]
COMPARISONS = ("==", "!=", "<", "<=", ">", ">=")


@dataclass
class RuleCompare:
    left: RuleOperand
    op: str  # one of COMPARISONS
    right: RuleOperand


@dataclass
class RuleTruth:
    """A bool member on its own: true when the member is."""

    member: RuleField


@dataclass
class RuleNot:
    inner: "RuleExpr"


@dataclass
class RuleAll:
    """`a and b and ...`"""

    items: list["RuleExpr"]


@dataclass
class RuleAny:
    """`a or b or ...`"""

    items: list["RuleExpr"]


RuleExpr = Union[RuleCompare, RuleTruth, RuleNot, RuleAll, RuleAny]
_PRECEDENCE = {RuleAny: 1, RuleAll: 2, RuleNot: 3}


def rule_text(expr: RuleExpr, outer: int = 0) -> str:
    """The canonical text of a rule expression: single spaces, parentheses only where needed."""
    own = _PRECEDENCE.get(type(expr), 4)
    if isinstance(expr, RuleCompare):
        text = f"{expr.left.text} {expr.op} {expr.right.text}"
    elif isinstance(expr, RuleTruth):
        text = expr.member.text
    elif isinstance(expr, RuleNot):
        text = "not " + rule_text(expr.inner, own)
    else:
        joiner = " or " if isinstance(expr, RuleAny) else " and "
        text = joiner.join(rule_text(item, own) for item in expr.items)
    return f"({text})" if own < outer or (own == outer and own < 3) else text


def rule_operands(expr: RuleExpr) -> list[RuleOperand]:
    """Every operand of the expression, left to right."""
    if isinstance(expr, RuleCompare):
        return [expr.left, expr.right]
    if isinstance(expr, RuleTruth):
        return [expr.member]
    if isinstance(expr, RuleNot):
        return rule_operands(expr.inner)
    return [o for item in expr.items for o in rule_operands(item)]


def rule_holds(expr: RuleExpr, values: dict[str, int]) -> bool:
    """The rule evaluated with `values` (operand key -> raw integer value; bools are 0 or 1)."""
    if isinstance(expr, RuleCompare):
        a, b = (o.value if isinstance(o, RuleConst) else values[o.key] for o in (expr.left, expr.right))
        return {"==": a == b, "!=": a != b, "<": a < b, "<=": a <= b, ">": a > b, ">=": a >= b}[expr.op]
    if isinstance(expr, RuleTruth):
        return values[expr.member.key] != 0
    if isinstance(expr, RuleNot):
        return not rule_holds(expr.inner, values)
    if isinstance(expr, RuleAll):
        return all(rule_holds(item, values) for item in expr.items)
    return any(rule_holds(item, values) for item in expr.items)


@dataclass
class Rule:
    """`require EXPR "doc"`: a condition over several fields that every valid message meets.

    A rule whose members are all implicit (supplied by the decoder's caller, never sent) is the
    caller's: a decoder checks it with its other arguments, before the frame. Any other rule is the
    frame's: a decoder checks it after every field, and a frame that breaks it is out of range."""

    expr: RuleExpr
    doc: str
    loc: Location

    @property
    def text(self) -> str:
        return rule_text(self.expr)

    @property
    def operands(self) -> list[RuleOperand]:
        return rule_operands(self.expr)

    @property
    def caller_only(self) -> bool:
        """True when every operand is an implicit member: the rule is about the decoder's arguments."""
        members = [o for o in self.operands if not isinstance(o, RuleConst)]
        return all(isinstance(o, RuleField) and o.path[0].implicit for o in members)


@dataclass
class MessageDecl:
    name: str
    doc: str
    loc: Location
    fields: list[Field]
    schema: str = ""
    rules: list[Rule] = field(default_factory=list)
    # Filled in by the layout pass:
    implicit_bits: int = 0
    fixed_bits: int = 0

    # --- shape -----------------------------------------------------------------------------
    @property
    def wire_fields(self) -> list[Field]:
        """Fields in the transmitted fixed part, in order (no implicit, bytes or check fields)."""
        return [f for f in self.fields if not f.implicit and not isinstance(f.type, (BytesType, CheckType))]

    @property
    def implicit_fields(self) -> list[Field]:
        return [f for f in self.fields if f.implicit]

    @property
    def bytes_field(self) -> Field | None:
        return next((f for f in self.fields if isinstance(f.type, BytesType)), None)

    @property
    def check_field(self) -> Field | None:
        return next((f for f in self.fields if isinstance(f.type, CheckType)), None)

    @property
    def checksum(self) -> ChecksumDecl | None:
        cf = self.check_field
        return cf.type.checksum if cf is not None and isinstance(cf.type, CheckType) else None

    @property
    def fixed_size(self) -> int:
        """Bytes of the transmitted fixed part."""
        return self.fixed_bits // 8

    @property
    def implicit_size(self) -> int:
        return self.implicit_bits // 8

    @property
    def max_payload(self) -> int:
        bf = self.bytes_field
        return bf.type.max_len if bf is not None and isinstance(bf.type, BytesType) else 0

    @property
    def is_fixed_size(self) -> bool:
        return self.bytes_field is None and self.check_field is None and not self.implicit_fields

    def check_width(self, payload_len: int) -> int:
        """Bytes of the check for a payload of `payload_len` bytes (0 without a check)."""
        cs = self.checksum
        if cs is None:
            return 0
        return cs.tier_for(self.implicit_size + self.fixed_size + payload_len).width // 8

    def wire_size(self, payload_len: int) -> int:
        """Total bytes on the wire for a payload of `payload_len` bytes."""
        return self.fixed_size + payload_len + self.check_width(payload_len)

    @property
    def min_size(self) -> int:
        return self.wire_size(0)

    @property
    def max_size(self) -> int:
        return self.wire_size(self.max_payload)

    # --- fingerprint -----------------------------------------------------------------------
    def layout_lines(self, prefix: str = "") -> list[str]:
        """Canonical description of every bit on the wire; the fingerprint hashes it."""
        out: list[str] = []
        for f in self.fields:
            out.extend(_field_layout(f, prefix))
        return out

    @property
    def layout_text(self) -> str:
        """Fields, then the rules: a rule narrows the frames a decoder accepts, as a range does."""
        rules = [f"rule {r.text}" for r in self.rules]
        return "\n".join([f"message {self.name}", *self.layout_lines(), *rules]) + "\n"

    @property
    def frame_rules(self) -> list[Rule]:
        """Rules a decoder checks on the frame, after every field (out of range when broken)."""
        return [r for r in self.rules if not r.caller_only]

    @property
    def caller_rules(self) -> list[Rule]:
        """Rules over implicit members only: a decoder checks them with its arguments, first."""
        return [r for r in self.rules if r.caller_only]

    @property
    def fingerprint(self) -> int:
        return fingerprint_of(self.layout_text)


def _field_layout(f: Field, prefix: str) -> list[str]:
    where = "implicit " if f.implicit else ""
    path = prefix + f.name
    extras = ""
    if f.fixed is not None:
        extras += f" fixed={f.fixed}"
    if f.range is not None:
        extras += f" range={f.range[0]}..{f.range[1]}"
    if f.unit is not None:
        extras += f" unit={f.unit}"
    if f.scale is not None:
        extras += f" scale={f.scale!r}"
    if f.offset is not None:
        extras += f" offset={f.offset!r}"
    t = f.type
    if isinstance(t, IntType):
        return [f"{where}{path} @{f.bit_offset} {t.name}{extras}"]
    if isinstance(t, EnumDecl):
        members = ",".join(f"{m.name}={m.value}" for m in t.members)
        return [f"{where}{path} @{f.bit_offset} enum {t.base.name} {{{members}}}{extras}"]
    if isinstance(t, MessageDecl):
        return [f"{where}{path} @{f.bit_offset} struct"] + [
            line for sub in t.fields for line in _field_layout(sub, path + ".")
        ]
    if isinstance(t, ArrayType):
        return [f"{where}{path} @{f.bit_offset} array {t.count} x {f.bit_width // t.count} bits{extras}"] + (
            [line for sub in t.element.fields for line in _field_layout(sub, path + "[].")]
            if isinstance(t.element, MessageDecl)
            else [f"{path}[] {_scalar_name(t.element)}"]
        )
    if isinstance(t, BytesType):
        count = t.count_field if t.count_field else "tail"
        return [f"{path} bytes max={t.max_len} count={count}"]
    assert isinstance(t, CheckType)
    tiers = ";".join(
        f"{c.name}(w={c.width},poly={c.poly:#x},init={c.init:#x},xorout={c.xorout:#x},max={c.max_covered})"
        for c in t.checksum.tiers
    )
    return [f"{path} check {t.first}..{t.last} {tiers}"]


def _scalar_name(t: ScalarOrStruct) -> str:
    if isinstance(t, IntType):
        return t.name
    if isinstance(t, EnumDecl):
        return "enum " + t.base.name + " {" + ",".join(f"{m.name}={m.value}" for m in t.members) + "}"
    return "struct " + t.name


def fingerprint_of(text: str) -> int:
    """First four bytes of SHA-256 of the canonical layout text, read little-endian."""
    return int.from_bytes(hashlib.sha256(text.encode("utf-8")).digest()[:4], "little")


@dataclass
class Mailbox:
    direction: str  # "inbox" or "outbox"
    number: int
    message: MessageDecl
    rate_hz: float | None
    doc: str
    loc: Location

    @property
    def size(self) -> int:
        return self.message.fixed_size


@dataclass
class NodeDecl:
    name: str
    kind: str  # "node" or "bridge"
    class_id: int
    doc: str
    loc: Location
    mailboxes: list[Mailbox]
    schema: str = ""

    def mailbox(self, direction: str, number: int) -> Mailbox | None:
        return next((m for m in self.mailboxes if m.direction == direction and m.number == number), None)

    @property
    def layout_text(self) -> str:
        lines = [f"{self.kind} class={self.class_id}"]
        for m in sorted(self.mailboxes, key=lambda m: (m.direction, m.number)):
            lines.append(f"{m.direction} {m.number} size={m.size} {m.message.name} {m.message.fingerprint:08x}")
        return "\n".join(lines) + "\n"

    @property
    def fingerprint(self) -> int:
        """Layout fingerprint of all mailboxes; outbox 0 identification carries it."""
        return fingerprint_of(self.layout_text)

    def sizes(self, direction: str) -> list[int]:
        """Mailbox sizes 0..7 in one direction (0 = unused)."""
        out = [0] * MAILBOXES
        for m in self.mailboxes:
            if m.direction == direction:
                out[m.number] = m.size
        return out


@dataclass
class Schema:
    name: str
    doc: str
    path: Path
    source: str
    imports: list["Schema"] = field(default_factory=list)
    consts: dict[str, ConstDecl] = field(default_factory=dict)
    enums: dict[str, EnumDecl] = field(default_factory=dict)
    checksums: dict[str, ChecksumDecl] = field(default_factory=dict)
    messages: dict[str, MessageDecl] = field(default_factory=dict)
    nodes: dict[str, NodeDecl] = field(default_factory=dict)

    @property
    def source_hash(self) -> str:
        """SHA-256 prefix of this schema's source text and its imports', for generated headers."""
        h = hashlib.sha256()
        for s in [*self.imports, self]:
            h.update(s.source.encode("utf-8"))
        return h.hexdigest()[:16]

    def all_checksums(self) -> list[ChecksumDecl]:
        """Checksums this schema's messages use, own and imported, each once."""
        seen: dict[str, ChecksumDecl] = {}
        for s in [*self.imports, self]:
            seen.update(s.checksums)
        return list(seen.values())
