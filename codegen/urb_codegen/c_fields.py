"""C statements for the fixed part of a message: member checks, packing, unpacking, decoded facts.

Wire rule 1 (spec/schema/README.md) makes the fixed part one little-endian integer whose field of
width w at bit offset o holds its raw value in bits o .. o + w - 1. The statements here address
the bytes of that integer directly, with constant shifts and masks:

* Packing writes every byte of the fixed part exactly once, as the OR of the pieces of the fields
  that have bits in it: a field crossing a byte boundary gives one piece per byte, a bool is
  `(member ? bit : 0u)`, fixed values fold into one constant, and reserved bits and gaps are simply
  not set. So an encoder needs no clearing pass and no read-modify-write of the buffer.
* Unpacking reads a field from the bytes it spans, each shifted into place, with one constant mask
  where a neighbour's bits follow the field in its last byte, or where WP needs a constant mask to
  bound the member (`_masked`). Signed members are sign-extended as
  `(raw > 2^(w-1) - 1) ? (raw - 2^w) : raw` in 64-bit arithmetic that no value can overflow
  (compilers reduce it to one sign-extending load). Reserved bits and gaps are checked per byte,
  all bits of a byte at once.
* An array is a loop over groups of g elements, g = 8 / gcd(element width, 8): the fewest elements
  that fill whole bytes (1 for byte-sized elements and nested messages, 4 for `u6`, 8 for `bool`),
  with the g elements of a group unrolled, so every shift stays a constant. An array that does not
  start on a byte boundary, or is not a whole number of groups, is unrolled entirely.

No bit loop runs in a codec: the runtime keeps urb_get_bits / urb_put_bits (and their proofs) for
hand-written code. Buffers are read and written one byte at a time through plain lvalues, so there
are no packed structs, no casts of buffers and no unaligned access (Cortex-M0 safe).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Union

from .c_names import _c_name, _comment, _ctype, _ctype_limits, _literal, _member, enum_c
from .emit_rules import acsl_condition
from .model import ArrayType, BytesType, CheckType, EnumDecl, Field, IntType, MessageDecl


@dataclass(frozen=True)
class At:
    """A bit offset in C: a constant plus loop terms such as `48u * i0` (each a whole number of bytes)."""

    const: int
    terms: tuple[str, ...] = ()

    def plus(self, n: int) -> At:
        return At(self.const + n, self.terms)

    def index(self, stride: int, var: str) -> At:
        return At(self.const, (*self.terms, f"{stride}u * {var}"))

    def byte(self, plus: int = 0) -> str:
        """The C index of the byte holding this offset (plus `plus` bytes)."""
        terms = []
        for term in self.terms:
            stride, var = term.split("u * ")
            assert int(stride) % 8 == 0, term  # loops only step by whole bytes
            terms.append(var if int(stride) == 8 else f"{int(stride) // 8}u * {var}")
        const = self.const // 8 + plus
        return " + ".join([*terms, f"{const}u"] if const or not terms else terms)


@dataclass(frozen=True)
class Leaf:
    """One scalar on the wire: its field, C lvalue (None for fixed fields) and position."""

    field: Field
    itype: IntType
    enum: EnumDecl | None
    member: str | None
    at: At
    width: int


@dataclass(frozen=True)
class Pad:
    """Bits that must be zero: a reserved `_` field or a gap no field claims. `label` is how the BMC
    harnesses name them (`padding at bit 21`), written next to the decoder's check."""

    at: At
    width: int
    label: str


@dataclass(frozen=True)
class Loop:
    """An array as a loop over groups of `group` elements, `span` bits (whole bytes) per trip."""

    field: Field
    element: object
    member: str
    var: str
    group: int
    trips: int
    at: At  # element 0, on a byte boundary
    span: int
    items: tuple[Item, ...]
    depth: int


Item = Union[Leaf, Pad, Loop]


# --- layout: every field of a fixed part as leaves, padding and loops ------------------------------


def layout(fields: list[Field], width: int, prefix: str, at: At, depth: int) -> list[Item]:
    """The items of `fields`, which span `width` bits from `at` (nested messages flattened). Bits no
    field claims (left by `@` positions) are padding."""
    out: list[Item] = []
    cursor = 0
    for f in sorted((f for f in fields if not isinstance(f.type, (BytesType, CheckType))), key=lambda f: f.bit_offset):
        if f.bit_offset > cursor:
            out.append(Pad(at.plus(cursor), f.bit_offset - cursor, "undeclared bits"))
        cursor = max(cursor, f.bit_offset + f.bit_width)
        pos = at.plus(f.bit_offset)
        if f.is_padding:
            out.append(Pad(pos, f.bit_width, f"padding at bit {f.bit_offset}"))
        else:
            member = None if f.fixed is not None else prefix + _member(f)
            out += _items(f, f.type, member, pos, f.bit_width, depth)
    if width > cursor:
        out.append(Pad(at.plus(cursor), width - cursor, "undeclared bits"))
    return out


def _items(f: Field, t: object, member: str | None, at: At, width: int, depth: int) -> list[Item]:
    if isinstance(t, IntType):
        return [Leaf(f, t, None, member, at, width)]
    if isinstance(t, EnumDecl):
        return [Leaf(f, t.base, t, member, at, width)]
    if isinstance(t, MessageDecl):
        return layout(t.fields, t.fixed_bits, f"{member}.", at, depth)
    assert isinstance(t, ArrayType) and member is not None, t
    stride = width // t.count
    group = 8 // math.gcd(stride, 8)
    if at.const % 8 == 0 and t.count % group == 0 and t.count > group:
        var = f"i{depth}"
        base = at.index(stride * group, var)
        items: list[Item] = []
        for e in range(group):
            index = var if group == 1 else f"{group}u * {var}" + (f" + {e}u" if e else "")
            items += _items(f, t.element, f"{member}[{index}]", base.plus(e * stride), stride, depth + 1)
        return [Loop(f, t.element, member, var, group, t.count // group, at, stride * group, tuple(items), depth)]
    out: list[Item] = []
    for e in range(t.count):
        out += _items(f, t.element, f"{member}[{e}u]", at.plus(e * stride), stride, depth + 1)
    return out


def _bytes_of(item: Leaf | Pad) -> range:
    """Indexes (relative to the item's loop) of the bytes an item has bits in."""
    return range(item.at.const // 8, (item.at.const + item.width - 1) // 8 + 1)


def _loop_lines(loop: Loop, body: list[str], assigns: str, invariants: list[str]) -> list[str]:
    if not body:
        return []
    return [
        f"/*@ loop invariant 0 <= {loop.var} <= {loop.trips};",
        *invariants,
        f"    loop assigns {assigns};",
        f"    loop variant {loop.trips} - {loop.var}; */",
        f"for (size_t {loop.var} = 0u; {loop.var} < {loop.trips}u; {loop.var}++) {{",
        *("    " + line for line in body),
        "}",
    ]


# --- packing -------------------------------------------------------------------------------------


def pack(items: list[Item], buf: str, assigns: str, names: set[str] | None = None) -> list[str]:
    """Statements writing every byte the items span, each once: `buf[k] = (uint8_t)(piece | ...);`.
    `assigns`: the ACSL locations a loop may write besides its index.

    A member spanning several bytes is read once, into a local, before the first store: a store
    through `uint8_t *` may alias the message, so a compiler would reload the member for each byte
    (and could not merge the byte stores into wider ones)."""
    names = set() if names is None else names
    out: list[str] = []
    values: dict[int, str] = {}  # id(leaf) -> local holding its value
    for item in items:
        if isinstance(item, Leaf) and item.member is not None and len(_bytes_of(item)) > 1:
            values[id(item)] = _local(item.member, names)
            out.append(f"uint32_t const {values[id(item)]} = (uint32_t){item.member};")
    cells: dict[int, tuple[At, list[str], int]] = {}  # byte -> (offset, pieces, constant bits)
    loops: dict[int, Loop] = {}
    for item in items:
        if isinstance(item, Loop):
            loops[item.at.const // 8] = item
            continue
        for b in _bytes_of(item):
            at, pieces, const = cells.get(b, (At(8 * b, item.at.terms), [], 0))
            if isinstance(item, Leaf):
                piece = _piece(item, b, values.get(id(item)))
                if isinstance(piece, int):
                    const |= piece
                else:
                    pieces.append(piece)
            cells[b] = (at, pieces, const)
    for b in sorted({*cells, *loops}):
        if b in loops:
            loop = loops[b]
            out += _loop_lines(loop, pack(list(loop.items), buf, assigns, names),
                               ", ".join(x for x in (loop.var, assigns) if x), [])
            continue
        at, pieces, const = cells[b]
        if const:
            pieces.append(f"0x{const:X}u")
        if not pieces:
            value = "0u"
        elif len(pieces) == 1 and not const:
            value = f"(uint8_t){pieces[0]}"
        elif len(pieces) == 1:
            value = pieces[0]
        else:
            value = f"(uint8_t)({' | '.join(pieces)})"
        out.append(f"{buf}[{at.byte()}] = {value};")
    return out


def _local(member: str, names: set[str], prefix: str = "v_") -> str:
    """A local's name for a member's value: `msg->packs[i0].voltage` -> `v_packs_voltage`,
    `msg->sizes[4u * i0 + 1u]` -> `v_sizes_1`, unique within the function."""
    path = member.removeprefix("msg->")
    path = re.sub(r"\[(?:\d+u \* i\d+ \+ )?(\d+)u\]", r"_\1", path)  # a constant or group index
    path = re.sub(r"\[\d+u \* i\d+\]", "_0", path)  # element 0 of a group
    path = re.sub(r"\[i\d+\]", "", path)  # the loop's element
    name = prefix + path.replace(".", "_")
    unique, n = name, 2
    while unique in names:
        unique, n = f"{name}_{n}", n + 1
    names.add(unique)
    return unique


def _piece(leaf: Leaf, b: int, local: str | None) -> str | int:
    """The bits of `leaf` in byte `b`, in place: a C expression (reading `local` when the member's
    value is in one), or an int for a fixed value."""
    w = leaf.width
    start = max(leaf.at.const, 8 * b)
    shift = start - 8 * b  # where the piece starts in the byte
    first = start - leaf.at.const  # which bit of the raw value it starts with
    count = min(leaf.at.const + w, 8 * b + 8) - start
    if leaf.member is None:
        fixed = leaf.field.fixed
        assert fixed is not None
        return (((fixed & ((1 << w) - 1)) >> first) & ((1 << count) - 1)) << shift
    if leaf.itype.is_bool:
        return f"({leaf.member} ? 0x{1 << shift:X}u : 0u)"
    value = local if local is not None else f"(uint32_t){leaf.member}"
    if first:
        value = f"({value} >> {first}u)"
    # Bits of the value above the piece would land on the next field's bits of this byte: mask them
    # unless the piece ends the byte, or the value is known to have none (a checked unsigned member).
    if shift + count < 8 and not (first + count == w and _fits_width(leaf)):
        value = f"({value} & 0x{(1 << count) - 1:X}u)"
    if shift:
        value = f"({value} << {shift}u)"
    return value


def _fits_width(leaf: Leaf) -> bool:
    """The encoder has checked that the member's value is below 2^width (unsigned members against
    their width or range, enums against their members); signed members carry sign bits above it."""
    if leaf.enum is not None:
        return all(0 <= m.value < (1 << leaf.width) for m in leaf.enum.members)
    return not leaf.itype.signed


# --- unpacking -----------------------------------------------------------------------------------


def unpack(items: list[Item], buf: str, error: str, names: set[str] | None = None) -> list[str]:
    """Statements reading every member from `buf` and checking fixed values, padding, enums and
    ranges (`return error;` on the first failure).

    A byte that several statements read (a byte of bools, a field and the reserved bits beside it)
    is read once, into a local, first: a store to a member may alias the buffer, so a compiler
    would read the byte again after each store."""
    names = set() if names is None else names
    pads: dict[int, tuple[At, int, list[str]]] = {}  # byte -> (offset, mask of pad bits, labels)
    uses: dict[int, int] = {}  # byte -> statements reading it
    for item in items:
        if isinstance(item, Loop):
            continue
        for b in _bytes_of(item):
            if isinstance(item, Pad):
                at, mask, labels = pads.get(b, (At(8 * b, item.at.terms), 0, []))
                lo, hi = max(item.at.const, 8 * b) - 8 * b, min(item.at.const + item.width, 8 * b + 8) - 8 * b
                pads[b] = (at, mask | (((1 << (hi - lo)) - 1) << lo), labels + [item.label])
                uses[b] = uses.get(b, 0) + (len(labels) == 0)  # one check per byte
            else:
                uses[b] = uses.get(b, 0) + 1
    out: list[str] = []
    reads: dict[int, str] = {}  # byte -> C expression of its value (a local when read repeatedly)
    for item in sorted(items, key=lambda it: it.at.const):
        if isinstance(item, Loop):
            continue
        for b in _bytes_of(item):
            if b in reads:
                continue
            at = At(8 * b, item.at.terms)
            reads[b] = f"(uint32_t){buf}[{at.byte()}]"
            if uses[b] > 1:
                out.append(f"uint32_t const {buf[0]}{b} = {reads[b]};")
                reads[b] = f"{buf[0]}{b}"
    checked: set[int] = set()
    for item in sorted(items, key=lambda it: it.at.const):
        if isinstance(item, Loop):
            out += _unpack_loop(item, buf, error, names)
        elif isinstance(item, Pad):
            for b in _bytes_of(item):
                if b not in checked:
                    checked.add(b)
                    _, mask, labels = pads[b]
                    test = f"{reads[b]} != 0u" if mask == 0xFF else f"({reads[b]} & 0x{mask:X}u) != 0u"
                    out.append(f"if ({test}) {{ return {error}; }}  /* {', '.join(dict.fromkeys(labels))} */")
        else:
            out += _unpack_leaf(item, reads, error, names)
    return out


def _unpack_loop(loop: Loop, buf: str, error: str, names: set[str]) -> list[str]:
    t = loop.field.type
    assert isinstance(t, ArrayType)
    # A decoder's loop writes this array only, so what was decoded before it stays known, and the
    # elements decoded so far keep the bounds the decoder's contract states.
    bound = f"j{loop.depth}"
    done = loop.var if loop.group == 1 else f"{loop.group} * {loop.var}"
    invariants = [f"    loop invariant \\forall integer {bound}; 0 <= {bound} < {done} ==> {fact};"
                  for _, fact in _facts(loop.field, loop.element, f"{loop.member}[{bound}]", loop.depth + 1, True)]
    written = f"{loop.var}, {loop.member}[0 .. {t.count - 1}]"
    body = unpack(list(loop.items), buf, error, names)
    return _loop_lines(loop, body, written, invariants)


def bits(at: At, width: int, buf: str) -> str:
    """The `width` bits at `at` of `buf` as a uint32_t expression, masked where a neighbour's bits
    follow (a counted payload's length field)."""
    reads = {b: f"(uint32_t){buf}[{At(8 * b, at.terms).byte()}]" for b in range(at.const // 8, (at.const + width + 7) // 8)}
    raw = _raw(at, width, reads)
    return f"({raw} & 0x{(1 << width) - 1:X}u)" if (at.const + width) % 8 else raw


def _raw(at: At, width: int, reads: dict[int, str]) -> str:
    """The raw bits of a field as a uint32_t expression: each byte it spans (`reads`: byte index ->
    its value in C) shifted into place. Bits of a neighbour above the field's last bit (when it ends
    inside a byte) are not masked here."""
    lo, hi = at.const, at.const + width
    chunks = []
    for b in range(lo // 8, (hi - 1) // 8 + 1):
        start = max(lo, 8 * b)
        chunk = reads[b]
        if start > 8 * b:
            chunk = f"({chunk} >> {start - 8 * b}u)"
        if start > lo:
            chunk = f"({chunk} << {start - lo}u)"
        chunks.append(chunk)
    return f"({' | '.join(chunks)})" if len(chunks) > 1 else chunks[0]


def _unpack_leaf(leaf: Leaf, reads: dict[int, str], error: str, names: set[str]) -> list[str]:
    t, m, w = leaf.itype, leaf.member, leaf.width
    mask = (1 << w) - 1
    raw = _raw(leaf.at, w, reads)
    ends_in_byte = (leaf.at.const + w) % 8 != 0  # a neighbour's bits follow in the last byte
    if m is None:
        fixed = leaf.field.fixed
        assert fixed is not None
        name = leaf.field.fixed_name or str(fixed)
        value = f"({raw} & 0x{mask:X}u)" if ends_in_byte else raw
        return [f"if ({value} != {fixed & mask}u) {{ return {error}; }}  /* fixed: {_comment(name)} */"]
    if t.is_bool:
        byte = leaf.at.const // 8
        return [f"{m} = (({reads[byte]} & 0x{1 << (leaf.at.const - 8 * byte):X}u) != 0u);"]
    checks = _limits(leaf, with_width=False)
    if t.signed:
        # raw - 2^w when raw is above the largest positive value 2^(w-1) - 1: a comparison and one
        # subtraction, without a bit operator on a signed value (MISRA C rule 10.1). In 64 bits no
        # uint32_t raw can make the subtraction overflow, so WP's overflow goal needs no bound on
        # raw (which would take reasoning about the | and << that assemble it: z3 and cvc4 fail
        # there). The raw bits sit in a local because MISRA C (rule 10.8) forbids casting a
        # composite expression to a signed type. gcc -O2 makes the whole one sign-extending load.
        local = _local(m, names, "r_")
        return [f"uint32_t const {local} = {f'({raw} & 0x{mask:X}u)' if ends_in_byte else raw};",
                f"{m} = ({_ctype(t)})(({local} > 0x{(1 << (w - 1)) - 1:X}u) ? "
                f"((int64_t){local} - {1 << w}) : (int64_t){local});",
                *_reject(checks, error)]
    if ends_in_byte or _masked(leaf, checks):
        value = f"({_ctype(t)})({raw} & 0x{mask:X}u)"
    else:
        value = f"({_ctype(t)}){raw}"
    return [f"{m} = {value};", *_reject(checks, error)]


def _masked(leaf: Leaf, checks: list[str]) -> bool:
    """An unsigned member narrower than its C type and without an upper range check is masked to its
    width when decoded, even where no neighbour's bits follow it (`address`, the top 7 bits of a
    byte): the mask changes no value, but WP's provers bound a constant mask at once, so the
    decoder's contract can state the width (`ensures decoded_<member>`)."""
    t = leaf.itype
    if t.signed or t.is_bool or leaf.enum is not None or leaf.width >= _ctype_limits(t)[1].bit_length():
        return False
    return not any(" > " in c for c in checks)


# --- member checks (encoders; a decoder's implicit members) -----------------------------------------


def validate(fields: list[Field], prefix: str, error: str, depth: int = 0) -> list[str]:
    """`if (member invalid) { return error; }` for every member of `fields` (arrays as loops)."""
    out: list[str] = []
    for f in sorted((f for f in fields if not isinstance(f.type, (BytesType, CheckType))), key=lambda f: f.bit_offset):
        if not f.is_padding and f.fixed is None:
            out += _validate_typed(f, f.type, prefix + _member(f), f.bit_width, depth, error)
    return out


def _validate_typed(f: Field, t: object, member: str, width: int, depth: int, error: str) -> list[str]:
    if isinstance(t, (IntType, EnumDecl)):
        leaf = Leaf(f, t if isinstance(t, IntType) else t.base, t if isinstance(t, EnumDecl) else None, member,
                    At(0), width)
        return _reject(_limits(leaf, with_width=True), error)
    if isinstance(t, MessageDecl):
        return validate(t.fields, f"{member}.", error, depth)
    assert isinstance(t, ArrayType), t
    var = f"i{depth}"
    body = _validate_typed(f, t.element, f"{member}[{var}]", width // t.count, depth + 1, error)
    if not body:
        return []
    return [
        f"/*@ loop invariant 0 <= {var} <= {t.count};",
        f"    loop assigns {var};",
        f"    loop variant {t.count} - {var}; */",
        f"for (size_t {var} = 0u; {var} < {t.count}u; {var}++) {{",
        *("    " + line for line in body),
        "}",
    ]


def _limits(leaf: Leaf, with_width: bool) -> list[str]:
    """Conditions that make a member invalid, leaving out those its C type already rules out."""
    t = leaf.itype
    if t.is_bool or leaf.member is None:
        return []
    if leaf.enum is not None:  # members fit the base type, so membership covers the width too
        return [f"!{enum_c(leaf.enum)}_is_valid({leaf.member})"]
    lo, hi = (t.min, t.max) if with_width else _ctype_limits(t)
    if leaf.field.range is not None:
        lo, hi = max(lo, leaf.field.range[0]), min(hi, leaf.field.range[1])
    cmin, cmax = _ctype_limits(t)
    conds = []
    if lo > cmin:
        conds.append(f"{leaf.member} < {_literal(lo, t.signed)}")
    if hi < cmax:
        conds.append(f"{leaf.member} > {_literal(hi, t.signed)}")
    return conds


def _reject(conds: list[str], error: str) -> list[str]:
    """`if (a || b) { return error; }`, or nothing without conditions."""
    if not conds:
        return []
    test = " || ".join(f"({c})" for c in conds) if len(conds) > 1 else conds[0]
    return [f"if ({test}) {{ return {error}; }}"]


# --- decoded-member facts for the ACSL contracts ---------------------------------------------------


def acsl_runs(values: list[int], term: str) -> str:
    """`term` is one of `values`, as ACSL over runs of consecutive values: `term <= 8`, `(term == 0 || 2 <= term <= 5)`."""
    runs: list[list[int]] = []
    for v in sorted(values):
        if runs and runs[-1][1] == v - 1:
            runs[-1][1] = v
        else:
            runs.append([v, v])
    parts = [f"{term} == {lo}" if lo == hi else f"{term} <= {hi}" if lo == 0 else f"{lo} <= {term} <= {hi}"
             for lo, hi in runs]
    return parts[0] if len(parts) == 1 else "(" + " || ".join(parts) + ")"


def _leaf_fact(f: Field, t: IntType, enum: EnumDecl | None, term: str, in_array: bool) -> str | None:
    """What a successful decode guarantees of one scalar member beyond its C type, or None.

    Unsigned members: the width and the range (the decoder masks or checks them). Enums: membership
    (the decoder calls <enum>_is_valid, whose contract says the same). Signed members: only a range,
    which the decoder checks; the width of a signed member narrower than its C type is not stated
    (no such member in the schemas). Array elements: only bounds the decoder checks (enum, range); a
    width bound that comes from the mask alone is not stated, because z3 and cvc4 time out on the
    loop invariant that carries it (Identification's u6[8] sizes: the mask's `land` bound inside the
    quantified invariant)."""
    if t.is_bool:
        return None
    if enum is not None:
        return acsl_runs([m.value for m in enum.members], term)
    cmin, cmax = _ctype_limits(t)
    lo, hi = (t.min, t.max) if not t.signed and not in_array else (cmin, cmax)
    if f.range is not None:
        lo, hi = max(lo, f.range[0]), min(hi, f.range[1])
    if lo <= cmin and hi >= cmax:
        return None
    if lo <= cmin:
        return f"{term} <= {hi}"
    if hi >= cmax:
        return f"{lo} <= {term}"
    return f"{lo} <= {term} <= {hi}"


def _facts(f: Field, t: object, term: str, depth: int, in_array: bool = False) -> list[tuple[str, str]]:
    """(label suffix, ACSL predicate) for every constrained scalar inside a member of type `t`."""
    if isinstance(t, (IntType, EnumDecl)):
        fact = _leaf_fact(f, t if isinstance(t, IntType) else t.base, t if isinstance(t, EnumDecl) else None, term,
                          in_array)
        return [] if fact is None else [("", fact)]
    if isinstance(t, MessageDecl):
        out = []
        for g in t.fields:
            if g.is_padding or g.fixed is not None or isinstance(g.type, (BytesType, CheckType)):
                continue
            out += [(f"_{g.name}{label}", fact)
                    for label, fact in _facts(g, g.type, f"{term}.{_member(g)}", depth, in_array)]
        return out
    if isinstance(t, ArrayType):
        var = f"j{depth}"
        return [(label, f"\\forall integer {var}; 0 <= {var} < {t.count} ==> {fact}")
                for label, fact in _facts(f, t.element, f"{term}[{var}]", depth + 1, True)]
    return []


def decode_facts(m: MessageDecl) -> list[tuple[str, str]]:
    """(label, predicate) of every member a successful decode bounds: `decoded_address`, ..."""
    out = []
    for f in m.fields:
        if f.is_padding or f.fixed is not None or isinstance(f.type, CheckType):
            continue
        name = _member(f)
        if isinstance(f.type, BytesType):
            if f.type.count_field is None:  # the decoder sets <field>_len to the payload length
                out.append((f"decoded_{name}_len", f"msg->{name}_len <= {f.type.max_len}"))
            continue
        out += [(f"decoded_{f.name}{label}", fact) for label, fact in _facts(f, f.type, f"msg->{name}", 0)]
    # the rules hold too: the caller's were checked before the frame (decode never changes those
    # members), the frame's after every field
    out += [(f"rule_{i}", acsl_condition(r, _c_name)) for i, r in enumerate(m.rules, 1)]
    return out
