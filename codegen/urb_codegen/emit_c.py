"""C emitter: plain structs and byte-wise codecs for every message, node tables, CRCs.

The model (model.py) already holds every bit offset; `c_fields` turns each field into C statements
(member checks, pack, unpack: constant shifts and masks on single bytes, no bit loop) and this module
hands them to the Jinja2 templates `templates/c_*.j2`, which own the shape of every file. Design
choices the generated code relies on:

* Every byte of a fixed part is written once by an encoder and read with constant shifts by a
  decoder; there are no packed structs, no buffer casts and no unaligned access (Cortex-M0 safe).
* Nested messages and arrays are flattened into the enclosing codec: an array becomes a loop over
  groups of elements that fill whole bytes (c_fields). Only `encode`/`decode` are public per message.
* Encoders validate the whole struct before writing, so on any error the output buffer is untouched.
* Decoders classify errors in the wire order: ARGUMENT (the caller's members, including the rules
  over implicit members only), SHORT, LONG, CHECKSUM, then RANGE (fields, then the frame's rules).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from jinja2 import Environment, FileSystemLoader, StrictUndefined

from . import c_fields
from .c_fields import At, acsl_runs, decode_facts, layout
from .c_names import _c_name, _comment, _ctype, _literal, _member, enum_c, file_stem, msg_c, snake
from .emit_rules import c_violation
from .errors import Location, SchemaError
from .model import (
    MAILBOXES,
    ArrayType,
    BytesType,
    CheckType,
    ChecksumDecl,
    CrcTier,
    EnumDecl,
    Field,
    IntType,
    MessageDecl,
    NodeDecl,
    Rule,
    Schema,
)

__all__ = ["RUNTIME_VERSION", "TEST_SUPPORT_DIR", "emit_c", "enum_c", "file_stem", "msg_c", "snake", "_ctype",
           "_member"]

RUNTIME_VERSION = 1
TEST_SUPPORT_DIR = "test"  # test-only sources (stdio), kept out of the product folder's *.c

_ERROR_CODES = [
    ("OK", 0, "Success"),
    ("SHORT", -1, "The frame is shorter than the message (or than its length field says)"),
    ("LONG", -2, "The frame is longer than the message (or than its length field says)"),
    ("CHECKSUM", -3, "The frame check does not match"),
    ("RANGE", -4, "A value is outside its range, its width, its enum, its fixed value, or padding is not zero"),
    ("CAPACITY", -5, "The output buffer is too small"),
    ("ARGUMENT", -6, "A NULL pointer, or implicit members given to a decoder that are invalid or break a rule"),
]


def _rule(title: str, char: str = "=") -> str:
    """A section banner comment padded to the width of the generated code (96 columns)."""
    head = f"/* {char * 5} {title} "
    return head + char * max(3, 93 - len(head)) + " */"


def _rule_checks(m: MessageDecl, rules: list[Rule], error: str) -> list[str]:
    """`if (!(rule)) { return error; }` for each rule, with the rule's schema text as a comment."""
    def prefix(e: EnumDecl) -> str:
        return "URB_" + snake(e.name).upper()
    return [f"if ({c_violation(r, _c_name, prefix)}) {{ return {error}; }}  /* require {_comment(r.text)} */"
            for r in rules]


# --- JSON printing for the test driver -----------------------------------------------------------


def _print_statements(fields: list[Field], prefix: str, depth: int) -> list[str]:
    """C statements printing the members of `fields` as JSON object entries (test support)."""
    out: list[str] = []
    first = True
    for f in fields:
        if f.is_padding or f.fixed is not None or isinstance(f.type, CheckType):
            continue
        key = f'"{"" if first else ","}\\"{f.name}\\":"'
        first = False
        out.append(f"fputs({key}, out);")
        member = prefix + _member(f)
        if isinstance(f.type, BytesType):
            counter = next((c for c in fields if c.name == f.type.count_field), None)
            length = prefix + _member(counter) if counter is not None else f"{member}_len"
            out.append(f"urb_test_print_hex(out, {member}, {length});")
        else:
            out += _print_value(f.type, member, depth)
    return out


def _print_value(t: object, member: str, depth: int) -> list[str]:
    if isinstance(t, (IntType, EnumDecl)):
        it = t if isinstance(t, IntType) else t.base
        if it.is_bool:
            return [f'fputs({member} ? "true" : "false", out);']
        if it.signed:
            return [f'fprintf(out, "%ld", (long){member});']
        return [f'fprintf(out, "%lu", (unsigned long){member});']
    if isinstance(t, MessageDecl):
        return ["fputc('{', out);", *_print_statements(t.fields, member + ".", depth), "fputc('}', out);"]
    assert isinstance(t, ArrayType), t
    var = f"i{depth}"
    return [
        "fputc('[', out);",
        f"for (size_t {var} = 0u; {var} < {t.count}u; {var}++) {{",
        f"    if ({var} > 0u) {{ fputc(',', out); }}",
        *("    " + line for line in _print_value(t.element, f"{member}[{var}]", depth + 1)),
        "}",
        "fputc(']', out);",
    ]


# --- view models for the templates ---------------------------------------------------------------


@dataclass
class CPayload:
    member: str  # the data array
    max_len: int
    len_member: str  # member holding the length: the count field or `<field>_len`
    counted: bool
    count_bits: str  # C expression of the count field's value (counted only)
    needs_len_check: bool  # the length member's own bounds do not already keep it <= max_len


@dataclass
class CMessage:
    decl: MessageDecl
    fn: str
    type: str
    macro: str
    members: list[tuple[str, str, str]]  # (name, declaration, doc)
    notes: list[str]  # wire facts that are not members: fixed fields, implicit prefix
    validate: list[str]
    pack: list[str]
    unpack: list[str]
    implicit_validate: list[str]
    implicit_pack: list[str]  # encode's
    implicit_pack_decode: list[str]  # decode's (its locals named apart from the decoder's others)
    implicit_unpack: list[str]  # test support: prefix bytes -> implicit members
    payload: CPayload | None
    checksum: str | None  # C stem of the checksum functions
    print_body: list[str]
    decode_facts: list[tuple[str, str]]  # (label, ACSL predicate) a successful decode ensures
    rule_checks: list[str]  # encode: every rule, URB_ERR_RANGE when broken
    caller_rule_checks: list[str]  # decode, with the implicit members: URB_ERR_ARGUMENT
    frame_rule_checks: list[str]  # decode, after every field: URB_ERR_RANGE


@dataclass
class CEnum:
    decl: EnumDecl
    type: str
    macro: str
    value_type: str
    valid_expr: str
    valid_acsl: str  # the same test in ACSL, for the contract of <enum>_is_valid


@dataclass
class CTier:
    tier: CrcTier
    fn: str
    macro: str
    ctype: str
    above: int | None  # covered bytes beyond which this tier applies (None: from zero)

    @property
    def top_bit(self) -> int:
        return 1 << (self.tier.width - 1)

    @property
    def mask(self) -> int:
        return (1 << self.tier.width) - 1

    @property
    def nibbles(self) -> list[int]:
        """Register after shifting each 4-bit value n (in the top nibble) through the polynomial."""
        out = []
        for n in range(16):
            reg = n << (self.tier.width - 4)
            for _ in range(4):
                reg = ((reg << 1) ^ self.tier.poly) if reg & self.top_bit else reg << 1
            out.append(reg & self.mask)
        return out

    @property
    def nibble_rows(self) -> list[str]:
        """The nibble table as two C initializer rows of eight values."""
        digits = self.tier.width // 4
        values = [f"0x{v:0{digits}X}u" for v in self.nibbles]
        return [", ".join(values[:8]) + ",", ", ".join(values[8:])]


@dataclass
class CChecksum:
    decl: ChecksumDecl
    fn: str
    macro: str
    tiers: list[CTier]
    max_size: int


@dataclass
class CNode:
    decl: NodeDecl
    fn: str
    macro: str
    mailboxes: list[tuple[str, int, int, str]]  # (direction, number, size, message) sorted
    numbers: list[tuple[str, int]]  # (macro suffix, number)


@dataclass
class CSchema:
    schema: Schema
    stem: str
    guard: str  # include guard of the header
    source: str
    includes: list[str]
    consts: list[tuple[str, int, str]]
    enums: list[CEnum] = field(default_factory=list)
    messages: list[CMessage] = field(default_factory=list)
    nodes: list[CNode] = field(default_factory=list)


class _Names:
    """Every global C identifier the emitter creates, so two schema items never map to one name."""

    def __init__(self) -> None:
        self.seen: dict[str, tuple[str, Location | None]] = {}

    def reserve(self, name: str, what: str) -> None:
        """A name the generated runtime or test support declares: no schema item may take it."""
        self.seen[name] = (what, None)

    def add(self, name: str, what: str, loc: Location) -> str:
        if name in self.seen:
            first, at = self.seen[name]
            if at is None:
                raise SchemaError(loc, f"{what} becomes the C name {name}, which the generated runtime reserves ({first})",
                                  "rename it: every C name the runtime declares (URB_OK, URB_ERR_*, urb_get_bits, ...) is taken")
            raise SchemaError(loc, f"{what} and {first} (at {at}) both become the C name {name}",
                              "rename one of them", related=at,
                              message_there=f"{first} and {what} (at {loc}) both become the C name {name}")
        self.seen[name] = (what, loc)
        return name

    def check_members(self, messages: list[CMessage]) -> None:
        """A struct member named like one of the generated macros (`uint8_t URB_OK;`) does not compile."""
        for view in messages:
            for f in view.decl.fields:
                member = _member(f)
                if member.isupper() and member in self.seen:
                    what, at = self.seen[member]
                    where = f"the generated runtime ({what})" if at is None else f"{what} (at {at})"
                    raise SchemaError(f.loc, f"field '{f.name}' of {view.decl.name} has the name of the C macro {member}, "
                                      f"defined for {where}", "rename the field: the macro would replace the struct member")


def _enum_view(e: EnumDecl, names: _Names) -> CEnum:
    values = sorted(m.value for m in e.members)
    runs: list[tuple[int, int]] = []
    for v in values:
        if runs and runs[-1][1] == v - 1:
            runs[-1] = (runs[-1][0], v)
        else:
            runs.append((v, v))
    lo_type = -(1 << 31) if e.base.signed else 0
    parts = []
    for lo, hi in runs:
        lit_lo, lit_hi = _literal(lo, e.base.signed), _literal(hi, e.base.signed)
        if lo == hi:
            parts.append(f"(value == {lit_lo})")
        elif lo == lo_type:
            parts.append(f"(value <= {lit_hi})")
        else:
            parts.append(f"((value >= {lit_lo}) && (value <= {lit_hi}))")
    macro = "URB_" + snake(e.name).upper()
    for m in e.members:
        names.add(f"{macro}_{m.name}", f"enum {e.name}", e.loc)
    names.add(enum_c(e) + "_is_valid", f"enum {e.name}", e.loc)
    return CEnum(e, names.add(enum_c(e) + "_t", f"enum {e.name}", e.loc), macro,
                 "int32_t" if e.base.signed else "uint32_t", " || ".join(parts),
                 acsl_runs([m.value for m in e.members], "value"))


def _field_doc(f: Field) -> str:
    extra = []
    if isinstance(f.type, EnumDecl):
        extra.append(enum_c(f.type) + "_t")
    if f.range is not None:
        extra.append(f"range {f.range[0]}..{f.range[1]}")
    if f.unit is not None:
        extra.append(f"unit {f.unit}")
    if f.scale is not None:
        extra.append(f"scale {f.scale:g}")
    if f.offset is not None:
        extra.append(f"offset {f.offset:g}")
    if f.implicit:
        extra.append("implicit: not sent, covered by the check; set it before decoding")
    return _comment(f.doc + (f" [{'; '.join(extra)}]" if extra else ""))


def _member_decl(f: Field) -> list[tuple[str, str, str]]:
    """The struct member(s) of a field: (name, declaration, doc)."""
    t = f.type
    name = _member(f)
    if isinstance(t, BytesType):
        decls = [(name, f"uint8_t {name}[{t.max_len}]", _comment(f.doc))]
        if t.count_field is None:
            decls.append((f"{name}_len", f"uint8_t {name}_len", f"Bytes used in {name} (0..{t.max_len})"))
        return decls
    dims = ""
    while isinstance(t, ArrayType):
        dims += f"[{t.count}]"
        t = t.element
    if isinstance(t, MessageDecl):
        ctype = msg_c(t) + "_t"
    else:
        assert isinstance(t, (IntType, EnumDecl))
        ctype = _ctype(t if isinstance(t, IntType) else t.base)
    return [(name, f"{ctype} {name}{dims}", _field_doc(f))]


def _message_view(m: MessageDecl, names: _Names) -> CMessage:
    fn = msg_c(m)
    macro = fn.upper()
    names.add(fn + "_t", f"message {m.name}", m.loc)
    for suffix in ("_encode", "_decode"):
        names.add(fn + suffix, f"message {m.name}", m.loc)
    for suffix in ("_SIZE", "_MIN_SIZE", "_MAX_SIZE", "_FINGERPRINT"):
        names.add(macro + suffix, f"message {m.name}", m.loc)

    members: list[tuple[str, str, str]] = []
    notes: list[str] = []
    for f in m.fields:
        if f.fixed is not None:
            notes.append(f"{f.name} = {f.fixed_name or f.fixed} on the wire (written by encode, checked by decode)")
        if not f.is_padding and f.fixed is None and not isinstance(f.type, CheckType):
            members += _member_decl(f)
    local = [name for name, _, _ in members]
    dup = {n for n in local if local.count(n) > 1}
    if dup:
        raise SchemaError(m.loc, f"message {m.name} would have two C members named {sorted(dup)[0]}",
                          "rename the field (a bytes[<= N] field adds a member <field>_len)")

    payload = None
    bf = m.bytes_field
    if bf is not None:
        assert isinstance(bf.type, BytesType)
        counter = next((f for f in m.fields if f.name == bf.type.count_field), None)
        if counter is not None:
            assert isinstance(counter.type, IntType)
            bound = counter.type.max if counter.range is None else min(counter.type.max, counter.range[1])
        else:
            bound = 255  # the uint8_t `<field>_len` member
        payload = CPayload(
            _member(bf), bf.type.max_len,
            _member(counter) if counter else _member(bf) + "_len",
            counter is not None,
            c_fields.bits(At(counter.bit_offset), counter.bit_width, "buf") if counter else "",
            bound > bf.type.max_len,
        )
    implicit = m.implicit_fields
    if implicit:
        notes.append(f"implicit prefix of {m.implicit_size} byte(s) ({', '.join(f.name for f in implicit)}): "
                     "not sent, but covered by the check")
    wire = [f for f in m.fields if not f.implicit]
    checksum = m.checksum
    buf_fixed = f"buf[0 .. {m.fixed_size - 1}]" if m.fixed_size else ""
    fixed_items = layout(wire, m.fixed_bits, "msg->", At(0), 0)
    implicit_items = layout(implicit, m.implicit_bits, "msg->", At(0), 0)
    # the locals each function declares, so that no two get one name: encode packs the fixed part and
    # the implicit prefix, decode packs the prefix and unpacks the fixed part
    encode_names: set[str] = set()
    decode_names: set[str] = set()
    implicit_assigns = f"prefix[0 .. {m.implicit_size - 1}]"
    return CMessage(
        decl=m, fn=fn, type=fn + "_t", macro=macro, members=members, notes=notes,
        validate=[*c_fields.validate(implicit, "msg->", "URB_ERR_RANGE"),
                  *c_fields.validate(wire, "msg->", "URB_ERR_RANGE")],
        pack=c_fields.pack(fixed_items, "buf", buf_fixed, encode_names),
        unpack=c_fields.unpack(fixed_items, "buf", "URB_ERR_RANGE", decode_names),
        implicit_validate=c_fields.validate(implicit, "msg->", "URB_ERR_ARGUMENT"),
        implicit_pack=c_fields.pack(implicit_items, "prefix", implicit_assigns, encode_names),
        implicit_pack_decode=c_fields.pack(implicit_items, "prefix", implicit_assigns, decode_names),
        implicit_unpack=c_fields.unpack(implicit_items, "prefix", "URB_ERR_RANGE"),
        payload=payload,
        checksum=None if checksum is None else "urb_" + checksum.name,
        print_body=_print_statements(m.fields, "msg->", 0),
        decode_facts=decode_facts(m),
        rule_checks=_rule_checks(m, m.rules, "URB_ERR_RANGE"),
        caller_rule_checks=_rule_checks(m, m.caller_rules, "URB_ERR_ARGUMENT"),
        frame_rule_checks=_rule_checks(m, m.frame_rules, "URB_ERR_RANGE"),
    )


def _checksum_view(cs: ChecksumDecl, names: _Names) -> CChecksum:
    fn = "urb_" + cs.name
    tiers: list[CTier] = []
    above: int | None = None
    for t in cs.tiers:
        tfn = f"urb_{t.name}_{cs.name}"
        names.add(tfn, f"checksum {cs.name}", cs.loc)
        names.add(tfn + "_byte", f"checksum {cs.name}", cs.loc)
        names.add(tfn + "_final", f"checksum {cs.name}", cs.loc)
        names.add(tfn.upper() + "_INIT", f"checksum {cs.name}", cs.loc)
        names.add(tfn.upper() + "_MAX_COVERED", f"checksum {cs.name}", cs.loc)
        tiers.append(CTier(t, tfn, tfn.upper(), f"uint{t.width}_t", above))
        if t.max_covered is not None:
            above = t.max_covered if above is None else max(above, t.max_covered)
    for suffix in ("", "_size", "_payload_len"):
        names.add(fn + suffix, f"checksum {cs.name}", cs.loc)
    names.add(fn.upper() + "_MAX_SIZE", f"checksum {cs.name}", cs.loc)
    return CChecksum(cs, fn, fn.upper(), tiers, max(t.width for t in cs.tiers) // 8)


def _node_view(n: NodeDecl, names: _Names) -> CNode:
    fn = "urb_node_" + snake(n.name)
    macro = fn.upper()
    boxes = sorted(n.mailboxes, key=lambda b: (b.direction != "outbox", b.number))
    numbers = []
    for b in boxes:
        same = [o for o in boxes if o.direction == b.direction and o.message is b.message]
        suffix = f"{b.direction.upper()}_{snake(b.message.name).upper()}" + (f"_{b.number}" if len(same) > 1 else "")
        numbers.append((suffix, b.number))
        names.add(f"{macro}_{suffix}", f"node {n.name}", n.loc)
        names.add(f"{macro}_{b.direction.upper()}{b.number}_SIZE", f"node {n.name}", n.loc)
    for suffix in ("_CLASS", "_FINGERPRINT"):
        names.add(macro + suffix, f"node {n.name}", n.loc)
    for table in ("_inbox_sizes", "_outbox_sizes"):
        names.add(fn + table, f"node {n.name}", n.loc)
    return CNode(n, fn, macro, [(b.direction, b.number, b.size, b.message.name) for b in boxes], numbers)


# --- entry point ---------------------------------------------------------------------------------


def _environment() -> Environment:
    env = Environment(
        loader=FileSystemLoader(str(Path(__file__).parent / "templates")),
        undefined=StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
        autoescape=False,
    )
    env.globals.update(runtime_version=RUNTIME_VERSION, error_codes=_ERROR_CODES, mailboxes=MAILBOXES)
    env.filters["comment"] = _comment
    env.filters["rule"] = _rule
    env.filters["u"] = lambda value: f"{value}u"
    return env


def _all_schemas(schemas: list[Schema]) -> list[Schema]:
    """The given schemas and their imports, imports first, each once."""
    out: list[Schema] = []

    def visit(s: Schema) -> None:
        if any(o.name == s.name for o in out):
            return
        for dep in s.imports:
            visit(dep)
        out.append(s)

    for s in schemas:
        visit(s)
    return out


def _runtime_names(names: _Names) -> None:
    """Reserve the C names the runtime and the test support declare, so no schema item takes one."""
    for name, _, _ in _ERROR_CODES:
        names.reserve("URB_" + ("OK" if name == "OK" else "ERR_" + name), "its error code")
    for name in ("URB_RUNTIME_VERSION", "URB_RUNTIME_H", "URB_TEST_SUPPORT_H", "urb_get_bits", "urb_put_bits",
                 "urb_get_le", "urb_put_le", "urb_sign_extend", "urb_runtime", "urb_test_support",
                 "urb_test_message_t", "urb_test_crc_t", "urb_test_messages", "urb_test_message_count",
                 "urb_test_crcs", "urb_test_crc_count", "urb_test_print_hex"):
        names.reserve(name, "a name it declares")


def emit_c(schemas: list[Schema], out_dir: Path) -> list[Path]:
    """Write urb_runtime.[ch], urb_<schema>.[ch] and test/urb_test_support.[ch]; return their paths."""
    env = _environment()
    names = _Names()
    _runtime_names(names)
    ordered = _all_schemas(schemas)
    views: list[CSchema] = []
    checksums: list[CChecksum] = []
    for s in ordered:
        view = CSchema(
            schema=s,
            stem=names.add(file_stem(s), f"schema {s.name}", Location(s.path, 1, 1)),
            guard=names.add(file_stem(s).upper() + "_H", f"schema {s.name}", Location(s.path, 1, 1)),
            # Same wording as the Python emitter; no directories, so output does not depend on where it goes.
            source=f"{s.path.name} (schema {s.name}, source fingerprint {s.source_hash})",
            includes=[file_stem(i) + ".h" for i in s.imports],
            consts=[(names.add("URB_" + c.name, f"const {c.name}", c.loc), c.value, _comment(c.doc)) for c in s.consts.values()],
        )
        view.enums = [_enum_view(e, names) for e in s.enums.values()]
        view.messages = [_message_view(m, names) for m in s.messages.values()]
        view.nodes = [_node_view(n, names) for n in s.nodes.values()]
        checksums += [_checksum_view(c, names) for c in s.checksums.values()]
        views.append(view)
    names.check_members([m for v in views for m in v.messages])
    runtime_sources = ", ".join(v.source for v in views if v.schema.checksums) or "no schema"

    runtime_title = "URB runtime: error codes, bit access and frame checks shared by every codec."
    files: dict[str, str] = {}
    for ext in ("h", "c"):
        files[f"urb_runtime.{ext}"] = env.get_template(f"c_runtime_{ext}.j2").render(
            title=runtime_title, guard="URB_RUNTIME_H" if ext == "h" else None, source=runtime_sources,
            checksums=checksums,
        )
        for v in views:
            files[f"{v.stem}.{ext}"] = env.get_template(f"c_schema_{ext}.j2").render(
                title=f"{v.schema.name}: {_comment(v.schema.doc)}.", guard=v.guard if ext == "h" else None,
                source=v.source, s=v,
            )
        files[f"{TEST_SUPPORT_DIR}/urb_test_support.{ext}"] = env.get_template(f"c_test_{ext}.j2").render(
            title="URB codec test support: codecs by name, JSON printers, CRC entry points (tests only).",
            guard="URB_TEST_SUPPORT_H" if ext == "h" else None, source=", ".join(v.source for v in views),
            schemas=views, checksums=checksums,
        )

    written = []
    for rel, text in files.items():
        path = out_dir / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        data = text.encode("utf-8")
        if not path.exists() or path.read_bytes() != data:  # bytes: a corrupted file is just different
            path.write_bytes(data)
        written.append(path)
    return written
