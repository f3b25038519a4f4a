"""Parse *.urbs files with lark, resolve names, lay out bits and check every rule.

Every problem becomes a SchemaError with file:line:column and a one-line hint; callers never see a
lark or Python traceback for a bad schema.
"""

from __future__ import annotations

import keyword
import math
import re
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path

from lark import Lark, Token, Tree
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken

from .errors import Location, SchemaError, SchemaErrors
from .rule_check import RuleResolver
from .model import (
    MAILBOXES,
    MAX_MAILBOX_SIZE,
    ArrayType,
    BytesType,
    CheckType,
    ChecksumDecl,
    ConstDecl,
    CrcTier,
    EnumDecl,
    EnumMember,
    Field,
    FieldType,
    IntType,
    Mailbox,
    MessageDecl,
    NodeDecl,
    Schema,
)

_GRAMMAR = files("urb_codegen").joinpath("grammar.lark").read_text(encoding="utf-8")
_PARSER = Lark(_GRAMMAR, parser="lalr", propagate_positions=True, maybe_placeholders=False)

_INT_RE = re.compile(r"^([ui])(0|[1-9][0-9]*)$")
_INT_LIKE_RE = re.compile(r"^([ui])([0-9]+)$")  # also u08: refused, not read as u8

# Names the generated code cannot use. Python: keywords, and what a generated message class or module
# already binds (the Message API, class-body helpers, the runtime imports). C: identifiers starting with
# `_` are the implementation's (`__GNUC__`, `_Bool`; and a leading `_` marks Python's generated helpers
# such as `_pack`), and the macros of the headers the codecs include (`SIZE_MAX`, `EOF`).
_PY_KEYWORDS = frozenset(keyword.kwlist)
_PY_MESSAGE_ATTRS = frozenset(
    "NAME DOC FINGERPRINT LAYOUT MIN_SIZE MAX_SIZE SIZE FIELDS encode decode to_dict engineering "
    "raw_from_engineering field struct FieldInfo ClassVar RULES broken_rule "
    # the builtin types the class body annotates fields with (a field `int` hides them from mypy and get_type_hints)
    "int bool bytes list".split()
)
_PY_MODULE_NAMES = frozenset(
    "enum struct dataclass field ClassVar ArgumentError EncodeError FieldInfo FrameCheck MailboxInfo Message NodeInfo "
    "OutOfRangeError TooLongError TooShortError ChecksumError DecodeError check_bool check_bytes check_enum "
    "check_int check_length check_list decode_enum frame_bytes make_crc sign_extend MESSAGES NODES annotations "
    # the builtins the generated module calls or annotates with: a message `bool` broke every bool field
    "TypeError bool bytearray bytes classmethod dict enumerate int isinstance len list memoryview range "
    "staticmethod str tuple type".split()
)
_C_MACRO_RE = re.compile(
    r"^(U?INT(8|16|32|64|_LEAST(8|16|32|64)|_FAST(8|16|32|64)|PTR|MAX)_(MIN|MAX|C)"
    r"|(SIZE|PTRDIFF|SIG_ATOMIC|WCHAR|WINT)_(MIN|MAX)|EOF|BUFSIZ|FILENAME_MAX|FOPEN_MAX|TMP_MAX|L_tmpnam"
    r"|SEEK_(SET|CUR|END)|stdin|stdout|stderr|offsetof)$"
)
# Schema names become C files urb_<name>.[ch] next to the runtime, and Python modules in one package.
_RESERVED_SCHEMAS = frozenset("runtime urb_runtime test_support urb_test_support".split())


def _reserved_why(name: str, python_names: frozenset[str]) -> str | None:
    """Why the generated C or Python cannot use `name`, or None when it can."""
    if name in _PY_KEYWORDS:
        return "is a Python keyword"
    if name.startswith("_"):
        return "starts with '_' (reserved in C, and for the generated Python helpers)"
    if name in python_names:
        return "is a name the generated Python already uses"
    if _C_MACRO_RE.match(name):
        return "is a macro of the C headers the codecs include"
    return None


def node_ident(name: str) -> str:
    """Python module-level name of a node: `MotorDriver` -> `MOTOR_DRIVER`."""
    return re.sub(r"(?<!^)(?=[A-Z])", "_", name).upper()

_TOKEN_HINTS = {
    "STRING": 'every item needs a documentation string in double quotes, e.g. "what this is"',
    "NAME": "a name (letters, digits, underscores) is expected here",
    "INTEGER": "a number is expected here",
    "HEX": "a number is expected here",
    "RBRACE": "close the block with `}`",
    "LBRACE": "open the block with `{`",
    "COLON": "write fields as `name: type \"doc\"`",
    "CMP_OP": "a rule compares with ==, !=, <, <=, > or >= (e.g. `require status == OK or len(data) == 0 \"doc\"`)",
}


@dataclass
class _Raw:
    """A parsed but unresolved schema file."""

    path: Path
    source: str
    tree: Tree[Token]
    name: str
    imports: list[tuple[str, Location]]


def _loc(path: Path, node: Tree[Token] | Token) -> Location:
    if isinstance(node, Token):
        return Location(path, node.line or 1, node.column or 1)
    meta = node.meta
    return Location(path, getattr(meta, "line", 1), getattr(meta, "column", 1))


def _end_of(source: str) -> tuple[int, int]:
    """Line and column just after the last non-blank character."""
    lines = source.rstrip().splitlines() or [""]
    return len(lines), len(lines[-1]) + 1


def _syntax_error(path: Path, source: str, exc: UnexpectedInput) -> SchemaError:
    line = getattr(exc, "line", 1) or 1
    column = getattr(exc, "column", 1) or 1
    if isinstance(exc, UnexpectedEOF) or (isinstance(exc, UnexpectedToken) and exc.token.type == "$END"):
        if not re.sub(r"#[^\n]*", "", source).strip():
            return SchemaError(Location(path, 1, 1), "empty schema file", 'start it with `schema NAME "doc"`')
        return SchemaError(Location(path, *_end_of(source)), "unexpected end of file", "a block is not closed: add `}`")
    if isinstance(exc, UnexpectedCharacters):
        ch = exc.char
        if ch == '"':
            return SchemaError(Location(path, line, column), "unterminated string",
                               'close the string with `"` on the same line (write \\" for a quote inside it)')
        return SchemaError(
            Location(path, line, column),
            f"unexpected character {ch!r}",
            "remove it; comments start with `#` and strings use double quotes",
        )
    if isinstance(exc, UnexpectedToken):
        tok = exc.token
        before = source[: tok.start_pos].rstrip() if tok.start_pos is not None else ""
        if tok.type == "LSQB" and before.endswith("]"):
            return SchemaError(Location(path, line, column), "arrays have one dimension: a second `[...]` is not allowed",
                               "declare the inner array as a message, e.g. `message Row \"a row\" { v: u8[3] \"values\" }`, "
                               "and make the field `Row[2]`")
        expected = sorted(exc.expected)
        # a rule's comparison hint for a lone `=` in a rule; otherwise the more basic token (a doc string) first
        cmp_first = tok.type == "EQUAL" and "CMP_OP" in expected
        hint = next((_TOKEN_HINTS[e] for e in sorted(expected, key=lambda e: (e == "CMP_OP") != cmp_first)
                     if e in _TOKEN_HINTS), None)
        shown = ", ".join(_describe(e) for e in expected[:6])
        return SchemaError(
            Location(path, line, column),
            f"unexpected {tok.type.lower()} {str(tok)!r}; expected {shown}",
            hint or "see spec/schema/README.md for the syntax of each item",
        )
    return SchemaError(Location(path, line, column), "syntax error", "see spec/schema/README.md")


def _describe(terminal: str) -> str:
    literal = {
        "LBRACE": "'{'", "RBRACE": "'}'", "COLON": "':'", "EQUAL": "'='", "LSQB": "'['", "RSQB": "']'",
        "STRING": "a doc string", "NAME": "a name", "INTEGER": "a number", "HEX": "a number",
        "REQUIRE": "'require'", "CMP_OP": "a comparison (==, !=, <, <=, >, >=)", "SIGNED_INTEGER": "a number",
        "LPAR": "'('", "RPAR": "')'", "DOT": "'.'",
    }
    return literal.get(terminal, terminal.lower().replace("__anon", "token"))


def parse_file(path: Path) -> _Raw:
    """Parse one file into a raw tree, or raise SchemaError."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise SchemaError(Location(path, 1, 1), f"cannot read schema: {exc.strerror}", "check the path") from None
    try:
        source = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise _not_utf8(path, data, exc) from None
    try:
        tree = _PARSER.parse(source)
    except UnexpectedInput as exc:
        raise _syntax_error(path, source, exc) from None
    schema_decl = tree.children[0]
    assert isinstance(schema_decl, Tree)
    name_tok = schema_decl.children[0]
    assert isinstance(name_tok, Token)
    imports = []
    for item in tree.children[1:]:
        if isinstance(item, Tree) and item.data == "import_decl":
            tok = item.children[0]
            assert isinstance(tok, Token)
            imports.append((str(tok), _loc(path, tok)))
    return _Raw(path, source, tree, str(name_tok), imports)


def _not_utf8(path: Path, data: bytes, exc: UnicodeDecodeError) -> SchemaError:
    """The error for a file that is not UTF-8 text, at the line and column of its first bad byte."""
    bad = exc.start
    line_start = data.rfind(b"\n", 0, bad) + 1
    line = data.count(b"\n", 0, bad) + 1
    column = len(data[line_start:bad].decode("utf-8")) + 1  # the bytes before `bad` decoded fine
    return SchemaError(Location(path, line, column),
                       f"not UTF-8 text: byte 0x{data[bad]:02x} at byte offset {bad} cannot be decoded",
                       "schema files are UTF-8 text; save the file as UTF-8, or check that it is a schema")


def _int(node: Tree[Token] | Token) -> int:
    tok = node.children[0] if isinstance(node, Tree) else node
    assert isinstance(tok, Token)
    return int(str(tok), 0)


def _doc(node: Tree[Token] | Token) -> str:
    tok = node.children[0] if isinstance(node, Tree) else node
    assert isinstance(tok, Token)
    return _unquote(str(tok))


def _unquote(s: str) -> str:
    return s[1:-1].replace('\\"', '"').replace("\\\\", "\\")


class _Builder:
    """Resolves one raw schema against its already-built imports."""

    def __init__(self, raw: _Raw, imports: list[Schema]) -> None:
        self.raw = raw
        self.path = raw.path
        self.schema = Schema(raw.name, "", raw.path, raw.source, imports=imports)
        self.errors: list[SchemaError] = []
        self._names: dict[str, Location] = {}

    # --- helpers ---------------------------------------------------------------------------
    def err(self, node: Tree[Token] | Token | Location, message: str, hint: str) -> None:
        loc = node if isinstance(node, Location) else _loc(self.path, node)
        self.errors.append(SchemaError(loc, message, hint))

    def declare(self, name_tok: Token) -> bool:
        name = str(name_tok)
        why = _reserved_why(name, _PY_MODULE_NAMES)
        if why is None and (name == "bool" or _INT_LIKE_RE.match(name)):
            self.err(name_tok, f"name '{name}' is spelled like an integer type",
                     f"rename it: a field of type `{name}` would always mean the integer, never this item")
            return False
        if why is not None:
            self.err(name_tok, f"name '{name}' {why}", "rename it; generated C and Python name their items after the schema")
            return False
        if name in self._names or self._lookup_imported(name) is not None:
            where = self._names.get(name)
            self.err(
                name_tok,
                f"duplicate name '{name}'" + (f" (first declared at {where})" if where else " (declared in an import)"),
                "give each constant, checksum, enum, message and node its own name",
            )
            return False
        self._names[name] = _loc(self.path, name_tok)
        return True

    def _lookup_imported(self, name: str) -> object | None:
        for imp in self.schema.imports:
            for table in (imp.consts, imp.enums, imp.checksums, imp.messages, imp.nodes):
                if name in table:
                    return table[name]
        return None

    def lookup(self, name: str) -> object | None:
        s = self.schema
        for table in (s.consts, s.enums, s.checksums, s.messages):
            if name in table:
                return table[name]
        return self._lookup_imported(name)

    # --- build -----------------------------------------------------------------------------
    def build(self) -> Schema:
        tree = self.raw.tree
        decl = tree.children[0]
        assert isinstance(decl, Tree)
        self.schema.doc = _doc(decl.children[1])
        name_tok = decl.children[0]
        assert isinstance(name_tok, Token)
        why = _reserved_why(str(name_tok), _PY_MODULE_NAMES | {"urb_msgs"})
        if why is None and str(name_tok) in _RESERVED_SCHEMAS:
            why = "would overwrite the generated runtime files"
        if why is not None:
            self.err(name_tok, f"schema name '{name_tok}' {why}", "rename the schema (it names the generated C files and Python module)")
        items = [c for c in tree.children[1:] if isinstance(c, Tree)]
        # Declare messages first so fields may refer to messages declared later.
        pending: list[tuple[Tree[Token], MessageDecl]] = []
        for item in items:
            if item.data == "message_decl":
                name_tok = item.children[0]
                assert isinstance(name_tok, Token)
                if self.declare(name_tok):
                    msg = MessageDecl(str(name_tok), _doc(item.children[1]), _loc(self.path, name_tok), [], self.raw.name)
                    self.schema.messages[msg.name] = msg
                    pending.append((item, msg))
        for item in items:
            if item.data == "const_decl":
                self.build_const(item)
            elif item.data == "checksum_decl":
                self.build_checksum(item)
            elif item.data == "enum_decl":
                self.build_enum(item)
        for item, msg in pending:
            self.build_fields(item, msg)
        for item, msg in pending:  # after every message's fields: a rule may name a nested message's field
            self.build_rules(item, msg)
        self.check_nested_rules()
        self.check_cycles()
        if not self.errors:
            for _, msg in pending:
                self.layout(msg)
        for item in items:
            if item.data == "node_decl":
                self.build_node(item)
        if self.errors:
            raise SchemaErrors(self.errors)
        return self.schema

    def build_const(self, item: Tree[Token]) -> None:
        name_tok, value, doc = item.children
        assert isinstance(name_tok, Token)
        if _int(value) > 0xFFFFFFFF:
            self.err(value, f"constant {name_tok} = {_int(value)} does not fit in 32 bits", "use a value up to 0xFFFFFFFF")
            return
        if self.declare(name_tok):
            self.schema.consts[str(name_tok)] = ConstDecl(str(name_tok), _int(value), _doc(doc), _loc(self.path, name_tok))

    def build_checksum(self, item: Tree[Token]) -> None:
        name_tok = item.children[0]
        assert isinstance(name_tok, Token)
        tiers: list[CrcTier] = []
        tier_nodes = [c for c in item.children[2:] if isinstance(c, Tree)]
        for i, tnode in enumerate(tier_nodes):
            tname = tnode.children[0]
            assert isinstance(tname, Token)
            if any(t.name == str(tname) for t in tiers):
                self.err(tname, f"duplicate tier '{tname}' in checksum '{name_tok}'", "give each tier its own name")
            params: dict[str, int] = {}
            for p in tnode.children[1:]:
                assert isinstance(p, Tree)
                key = p.children[0]
                assert isinstance(key, Token)
                if str(key) in params:
                    self.err(key, f"'{key}' given twice in tier '{tname}'", "keep one value per parameter")
                params[str(key)] = _int(p.children[1])
            for required in ("width", "poly", "init", "xorout"):
                if required not in params:
                    self.err(tname, f"tier '{tname}' has no '{required}'", f"add `{required} <number>` to the tier")
            width = params.get("width", 8)
            if width not in (8, 16, 32):
                self.err(tname, f"CRC width {width} is not supported", "use width 8, 16 or 32")
                width = 8
            for param in ("poly", "init", "xorout"):
                if params.get(param, 0) >= (1 << width):
                    self.err(tname, f"{param} {params[param]:#x} does not fit in {width} bits", f"use a value below {1 << width:#x}")
            if params.get("poly", 1) % 2 == 0:
                self.err(tname, "CRC polynomial must have its x^0 term (odd value)", "write the polynomial in normal form, e.g. 0x2F")
            last = i == len(tier_nodes) - 1
            max_cov = params.get("max_covered")
            if last and max_cov is not None:
                self.err(tname, "the last tier must cover frames of any length", "remove `max_covered` from the last tier")
            if not last and max_cov is None:
                self.err(tname, "only the last tier may leave `max_covered` out", "add `max_covered <bytes>` to this tier")
            below = [t.max_covered for t in tiers if t.max_covered is not None]
            if max_cov is not None and below and max_cov <= max(below):
                self.err(tname, f"tier '{tname}' would never be used: max_covered {max_cov} is not above the earlier tier's {max(below)}",
                         "list tiers from the shortest frames to the longest, with growing `max_covered`")
            tiers.append(CrcTier(str(tname), width, params.get("poly", 1), params.get("init", 0), params.get("xorout", 0), max_cov))
        if self.declare(name_tok):
            self.schema.checksums[str(name_tok)] = ChecksumDecl(
                str(name_tok), _doc(item.children[1]), _loc(self.path, name_tok), tiers, self.raw.name
            )

    def int_type(self, name: str) -> IntType | None:
        if name == "bool":
            return IntType(1, False, True)
        m = _INT_RE.match(name)
        if not m:
            return None
        return IntType(int(m.group(2)), m.group(1) == "i")

    def non_canonical_int(self, tok: Token) -> bool:
        """Report `u08`, `i016`: integer types are spelled without leading zeros (one spelling per type)."""
        m = _INT_LIKE_RE.match(str(tok))
        if m is None or _INT_RE.match(str(tok)):
            return False
        self.err(tok, f"'{tok}' is not an integer type: the width has a leading zero",
                 f"write {m.group(1)}{int(m.group(2))}")
        return True

    def check_int_width(self, tok: Token, t: IntType) -> bool:
        if t.bits < 1 or t.bits > 32:
            self.err(tok, f"bit field '{tok}' is wider than 32 bits" if t.bits > 32 else f"'{tok}' has no bits",
                     "integers are u1..u32 or i2..i32; split wider values into two fields")
            return False
        if t.signed and t.bits < 2:
            self.err(tok, "a signed field needs at least 2 bits", "use u1 or bool for a single bit")
            return False
        return True

    def build_enum(self, item: Tree[Token]) -> None:
        name_tok, base_tok, doc = item.children[:3]
        assert isinstance(name_tok, Token) and isinstance(base_tok, Token)
        base = self.int_type(str(base_tok))
        if base is None and self.non_canonical_int(base_tok):
            base = IntType(8, False)
        elif base is None or base.is_bool:
            self.err(base_tok, f"enum base '{base_tok}' is not an integer type", "use an unsigned type such as u8 or u4")
            base = IntType(8, False)
        elif not self.check_int_width(base_tok, base):
            base = IntType(8, False)
        members: list[EnumMember] = []
        seen_names: set[str] = set()
        seen_values: dict[int, str] = {}
        for m in item.children[3:]:
            assert isinstance(m, Tree)
            mname, mval, mdoc = m.children
            assert isinstance(mname, Token)
            value = _int(mval)
            why = _reserved_why(str(mname), frozenset({"mro"}))
            if why is not None:
                self.err(mname, f"enum member '{mname}' {why}", "rename the member")
            if value > 0x7FFFFFFF:
                self.err(mname, f"value {value} does not fit in a C enum (an int)", "use values up to 0x7FFFFFFF")
            if str(mname) in seen_names:
                self.err(mname, f"duplicate enum member '{mname}'", "give every member its own name")
            if value in seen_values:
                self.err(mname, f"value {value} is already used by '{seen_values[value]}'", "give every member its own value")
            if not base.min <= value <= base.max:
                self.err(mname, f"value {value} does not fit in {base.name}", f"use a value in {base.min}..{base.max} or widen the base type")
            seen_names.add(str(mname))
            seen_values[value] = str(mname)
            members.append(EnumMember(str(mname), value, _doc(mdoc), _loc(self.path, mname)))
        if self.declare(name_tok):
            self.schema.enums[str(name_tok)] = EnumDecl(str(name_tok), base, _doc(doc), _loc(self.path, name_tok), members, self.raw.name)

    # --- fields ----------------------------------------------------------------------------
    def resolve_type(self, tnode: Tree[Token], msg: MessageDecl) -> FieldType | None:
        kind = tnode.data
        if kind in ("named_type", "array_type"):
            tok = tnode.children[0]
            assert isinstance(tok, Token)
            name = str(tok)
            elem: IntType | EnumDecl | MessageDecl | ChecksumDecl | None
            it = self.int_type(name)
            if it is None and self.non_canonical_int(tok):
                return None
            if it is not None:
                if not self.check_int_width(tok, it):
                    return None
                elem = it
            else:
                found = self.lookup(name)
                if isinstance(found, (EnumDecl, MessageDecl, ChecksumDecl)):
                    elem = found
                else:
                    self.err(tok, f"unknown type '{name}'",
                             "use u1..u32, i2..i32, bool, bytes[...], or an enum, message or checksum declared in this schema or an import")
                    return None
            if isinstance(elem, MessageDecl) and elem is msg:
                self.err(tok, f"message '{msg.name}' contains itself", "a message cannot contain itself; remove the field")
                return None
            if kind == "array_type":
                count = _int(tnode.children[1])
                if isinstance(elem, ChecksumDecl):
                    self.err(tok, "a check cannot be an array", "declare one check field")
                    return None
                if count < 1 or count > 256:
                    self.err(tok, f"array of {count} elements", "arrays hold 1..256 elements")
                    return None
                return ArrayType(elem, count)
            if isinstance(elem, ChecksumDecl):
                return CheckType(elem, "", "")
            return elem
        if kind == "bytes_counted":
            count_tok = tnode.children[0]
            assert isinstance(count_tok, Token)
            max_len = _int(tnode.children[1])
            if not self.check_payload_max(tnode, max_len):
                return None
            return BytesType(max_len, str(count_tok))
        if kind == "bytes_tail":
            max_len = _int(tnode.children[0])
            if not self.check_payload_max(tnode, max_len):
                return None
            return BytesType(max_len, None)
        raise AssertionError(kind)

    def visible_type(self, name: str) -> EnumDecl | MessageDecl | None:
        """The enum or message `name` names in this schema's generated Python module (own or imported)."""
        for s in [self.schema, *self.schema.imports]:
            found = s.enums.get(name) or s.messages.get(name)
            if found is not None:
                return found
        return None

    def padding_type_ok(self, tnode: Tree[Token], t: FieldType) -> bool:
        """`_` is reserved bits, sent as zero: only integers (and arrays of them) mean exactly that."""
        inner = t.element if isinstance(t, ArrayType) else t
        if isinstance(inner, IntType):
            return True
        if isinstance(inner, MessageDecl):
            what = f"message {inner.name}: its fixed values and rules would not hold for the zeros sent"
        elif isinstance(inner, EnumDecl):
            what = f"enum {inner.name}: zero bits are not a choice among its members"
        elif isinstance(t, BytesType):
            what = "bytes: a reserved payload has no value to send"
        else:
            what = "a checksum: a check covers named fields and is never zero"
        self.err(tnode, f"a reserved field `_` is sent as zero bits, so its type cannot be {what}",
                 "declare reserved bits as an unsigned integer of their width, e.g. `_: u8` (or `_: u8[2]`)")
        return False

    def check_payload_max(self, node: Tree[Token], max_len: int) -> bool:
        if max_len > MAX_MAILBOX_SIZE:
            self.err(node, f"payload over {MAX_MAILBOX_SIZE} bytes (bytes[<= {max_len}])",
                     f"URB mailboxes hold at most {MAX_MAILBOX_SIZE} bytes; lower the bound")
            return False
        if max_len < 1:
            self.err(node, "a byte payload needs a bound of at least 1", "write bytes[<= N] with N in 1..32")
            return False
        return True

    def build_rules(self, item: Tree[Token], msg: MessageDecl) -> None:
        resolver = RuleResolver(msg, self.path, self.lookup, lambda loc, message, hint: self.err(loc, message, hint))
        for rnode in item.children[2:]:
            if isinstance(rnode, Tree) and rnode.data == "rule":
                rule = resolver.resolve(rnode, _doc(rnode.children[-1]))
                if rule is not None:
                    msg.rules.append(rule)

    def check_nested_rules(self) -> None:
        """A message with rules is checked by its own encode and decode only; nesting it would drop them."""
        for msg in self.schema.messages.values():
            for f in msg.fields:
                inner = f.type.element if isinstance(f.type, ArrayType) else f.type
                if isinstance(inner, MessageDecl) and inner.rules:
                    self.err(f.loc, f"message {inner.name} has rules (`require`), which only its own encode and decode "
                             f"check: nested in {msg.name}, they would not hold",
                             f"state the rule in {msg.name} on the nested fields (`require {f.name}.<field> ...`), "
                             f"or nest a message without rules")

    def build_fields(self, item: Tree[Token], msg: MessageDecl) -> None:
        seen: dict[str, Location] = {}
        for fnode in item.children[2:]:
            assert isinstance(fnode, Tree)
            if fnode.data == "rule":
                continue
            name_tok = fnode.children[0]
            tnode = fnode.children[1]
            assert isinstance(name_tok, Token) and isinstance(tnode, Tree)
            name = str(name_tok)
            if name != "_" and name in seen:
                self.err(name_tok, f"duplicate field '{name}' (first at {seen[name]})", "rename one of the fields")
                continue
            why = None if name == "_" else _reserved_why(name, _PY_MESSAGE_ATTRS)
            if why is not None:
                self.err(name_tok, f"field name '{name}' {why}", "rename the field (it becomes a C struct member and a Python attribute)")
                continue
            seen[name] = _loc(self.path, name_tok)
            shadowed = self.visible_type(name)
            if shadowed is not None:
                kind = "enum" if isinstance(shadowed, EnumDecl) else "message"
                self.err(name_tok, f"field name '{name}' is the name of {kind} {name} (declared at {shadowed.loc})",
                         f"rename the field, e.g. `{name[:1].lower() + name[1:]}`: in the generated Python class the "
                         "field would hide the type from the fields after it")
                continue
            ftype = self.resolve_type(tnode, msg)
            opts = fnode.children[2:-1]
            doc = _doc(fnode.children[-1])
            if ftype is None:
                continue
            if name == "_" and not self.padding_type_ok(tnode, ftype):
                continue
            f = Field(name, ftype, doc, _loc(self.path, name_tok))
            given: set[str] = set()
            for opt in opts:
                assert isinstance(opt, Tree)
                if opt.data in given:
                    self.err(opt, f"option given twice on field '{name}'", "keep one of them")
                    continue
                given.add(opt.data)
                if f.is_padding and opt.data not in ("opt_implicit", "opt_position"):
                    self.err(opt, "a reserved field `_` is always sent as zero and takes no value, range, unit or scaling",
                             "remove the option, or give the field a name")
                    continue
                self.apply_option(f, opt)
            if f.fixed is not None and f.range is not None and not f.range[0] <= f.fixed <= f.range[1]:
                self.err(f.loc, f"fixed value {f.fixed} of '{name}' is outside its range {f.range[0]}..{f.range[1]}",
                         "drop the range (a fixed field holds one value) or fix the value")
            msg.fields.append(f)
        self.check_message_shape(msg)

    def apply_option(self, f: Field, opt: Tree[Token]) -> None:
        kind = opt.data
        scalar = isinstance(f.type, (IntType, EnumDecl))
        numeric = isinstance(f.type, IntType) and not f.type.is_bool or (
            isinstance(f.type, ArrayType) and isinstance(f.type.element, IntType) and not f.type.element.is_bool
        )
        if kind == "opt_fixed":
            val = opt.children[0]
            if not scalar:
                self.err(opt, f"field '{f.name}' cannot have a fixed value", "only integer, bool and enum fields take `= value`")
                return
            value = self.fixed_value(val, f)
            if value is None:
                return
            if isinstance(f.type, EnumDecl) and all(m.value != value for m in f.type.members):
                self.err(opt, f"fixed value {value} is not a member of enum {f.type.name}",
                         "use one of: " + ", ".join(m.name for m in f.type.members))
                return
            it = f.int_type
            if not it.min <= value <= it.max:
                self.err(opt, f"fixed value {value} does not fit in {it.name}", f"use a value in {it.min}..{it.max}")
                return
            f.fixed = value
        elif kind == "opt_range":
            lo, hi = (int(str(c.children[0]), 0) for c in opt.children if isinstance(c, Tree))
            if not isinstance(f.type, IntType) or f.type.is_bool:
                self.err(opt, f"field '{f.name}' cannot have a range", "only integer fields take `in lo..hi`")
                return
            if lo > hi or lo < f.type.min or hi > f.type.max:
                self.err(opt, f"range {lo}..{hi} is empty or outside {f.type.name} ({f.type.min}..{f.type.max})",
                         "write `in lo..hi` with lo <= hi inside the type's range")
                return
            f.range = (lo, hi)
        elif kind in ("opt_unit", "opt_scale", "opt_offset"):
            if not numeric:
                self.err(opt, f"field '{f.name}' cannot carry units or scaling",
                         "units, scale and offset apply to integer fields and integer arrays")
                return
            tok = opt.children[0]
            assert isinstance(tok, Token)
            if kind == "opt_unit":
                f.unit = _unquote(str(tok))
            elif kind == "opt_scale":
                f.scale = float(str(tok))
                if not math.isfinite(f.scale):
                    self.err(opt, f"scale {tok} is not a finite number", "write the scale as a number such as 0.001")
                elif f.scale == 0.0:
                    self.err(opt, "scale 0 loses every value", "use a non-zero scale")
            else:
                f.offset = float(str(tok))
                if not math.isfinite(f.offset):
                    self.err(opt, f"offset {tok} is not a finite number", "write the offset as a number such as -40")
        elif kind == "opt_covers":
            first, last = (str(c) for c in opt.children)
            if not isinstance(f.type, CheckType):
                self.err(opt, f"field '{f.name}' is not a check", "`covers` belongs to a field whose type is a checksum")
                return
            f.type = CheckType(f.type.checksum, first, last)
        elif kind == "opt_implicit":
            f.implicit = True
        elif kind == "opt_position":
            f.position = _int(opt.children[0])

    def fixed_value(self, val: Tree[Token] | Token, f: Field) -> int | None:
        if isinstance(val, Tree):
            return _int(val)
        name = str(val)
        if isinstance(f.type, EnumDecl):
            member = next((m for m in f.type.members if m.name == name), None)
            if member is None:
                self.err(val, f"'{name}' is not a member of enum {f.type.name}", "use one of: " + ", ".join(m.name for m in f.type.members))
                return None
            f.fixed_name = name
            return member.value
        const = self.lookup(name)
        if isinstance(const, ConstDecl):
            f.fixed_name = name
            return const.value
        self.err(val, f"unknown constant '{name}'", "declare it with `const NAME = value \"doc\"`")
        return None

    def check_message_shape(self, msg: MessageDecl) -> None:
        fields = msg.fields
        names = [f.name for f in fields]
        checks = [f for f in fields if isinstance(f.type, CheckType)]
        bytes_fields = [f for f in fields if isinstance(f.type, BytesType)]
        if len(checks) > 1:
            self.err(checks[1].loc, "a message has at most one check field", "remove the extra check")
        if len(bytes_fields) > 1:
            self.err(bytes_fields[1].loc, "a message has at most one byte payload", "merge the payloads into one bytes field")
        for f in bytes_fields[:1]:
            after = fields[fields.index(f) + 1:]
            if any(not isinstance(a.type, CheckType) for a in after):
                self.err(f.loc, "the byte payload must be the last field (only the check may follow)",
                         "move fixed-size fields before the payload")
            assert isinstance(f.type, BytesType)
            if f.type.count_field is not None:
                cname = f.type.count_field
                counter = next((c for c in fields[: fields.index(f)] if c.name == cname), None)
                if counter is None:
                    self.err(f.loc, f"length field '{cname}' is not an earlier field of {msg.name}",
                             "declare the length field (an unsigned integer) before the payload")
                elif not isinstance(counter.type, IntType) or counter.type.signed or counter.type.is_bool:
                    self.err(f.loc, f"length field '{cname}' must be an unsigned integer", "declare it as u8 (or uN)")
                elif counter.is_padding or counter.fixed is not None or counter.implicit:
                    what = "reserved" if counter.is_padding else "fixed" if counter.fixed is not None else "implicit"
                    self.err(f.loc, f"length field '{cname}' is {what}, so it cannot carry the payload length",
                             "count the payload with a named, sent field such as `n: u8 in 0..N`")
                elif counter.range is not None and counter.range[1] > f.type.max_len:
                    self.err(f.loc, f"length field '{cname}' allows {counter.range[1]} but the payload holds {f.type.max_len}",
                             "make the range of the length field match the payload bound")
                elif counter.range is not None and counter.range[1] < f.type.max_len:
                    self.err(f.loc, f"length field '{cname}' allows at most {counter.range[1]} but the payload bound is "
                             f"{f.type.max_len}: no frame reaches the stated maximum size",
                             f"make the range of the length field end at {f.type.max_len}, or lower the bound to "
                             f"`bytes[{cname} <= {counter.range[1]}]`")
                elif counter.type.max < f.type.max_len:
                    need = f.type.max_len.bit_length()
                    self.err(f.loc, f"length field '{cname}' ({counter.type.name}) holds at most {counter.type.max} but the "
                             f"payload bound is {f.type.max_len}: no frame reaches the stated maximum size",
                             f"widen the length field to u{need} (or u8), or lower the bound to `bytes[{cname} <= {counter.type.max}]`")
        for f in checks[:1]:
            assert isinstance(f.type, CheckType)
            if fields[-1] is not f:
                self.err(f.loc, "the check must be the last field", "move the check to the end of the message")
            if not f.type.first:
                self.err(f.loc, f"check '{f.name}' does not say what it covers",
                         f"add `covers {names[0]}..{names[max(0, len(names) - 2)]}` (every field before the check)")
                continue
            if f.type.first not in names or f.type.last not in names:
                missing = f.type.first if f.type.first not in names else f.type.last
                self.err(f.loc, f"check covers unknown field '{missing}'", "name fields of this message in `covers first..last`")
                continue
            i0, i1 = names.index(f.type.first), names.index(f.type.last)
            if i0 > i1:
                self.err(f.loc, "check range runs backwards", "write `covers first..last` in declaration order")
                continue
            idx = fields.index(f)
            uncovered = [g.name for j, g in enumerate(fields[:idx]) if not i0 <= j <= i1]
            if uncovered:
                self.err(f.loc, f"missing checksum coverage: {', '.join(uncovered)} not covered by '{f.name}'",
                         f"write `covers {names[0]}..{names[idx - 1]}` so every field before the check is protected")
            if i1 >= idx:
                self.err(f.loc, "a check cannot cover itself", f"end the range at '{names[idx - 1]}'")
        implicit = [f for f in fields if f.implicit]
        for f in implicit:
            if f.name in ("cls", "data"):
                self.err(f.loc, f"an implicit field cannot be named '{f.name}': decode() takes it as a keyword argument next to `{f.name}`",
                         "rename the field")
        if implicit:
            if not checks:
                self.err(implicit[0].loc, "an implicit field only matters to a check, and this message has none",
                         "remove `implicit` or add a check that covers the field")
            if fields[: len(implicit)] != implicit:
                self.err(implicit[0].loc, "implicit fields must come first", "move implicit fields to the start of the message")

    def check_cycles(self) -> None:
        def contains(m: MessageDecl) -> list[MessageDecl]:
            out = []
            for f in m.fields:
                t = f.type.element if isinstance(f.type, ArrayType) else f.type
                if isinstance(t, MessageDecl):
                    out.append(t)
            return out

        reported: set[str] = set()
        for start in self.schema.messages.values():
            stack: list[tuple[MessageDecl, list[str]]] = [(start, [start.name])]
            while stack:
                cur, path = stack.pop()
                for nxt in contains(cur):
                    if nxt is start:
                        cycle = " -> ".join([*path, start.name])
                        if start.name not in reported:
                            reported.update(path)
                            self.err(start.loc, f"circular reference: {cycle}",
                                     "a message cannot contain itself through other messages; break the cycle")
                    elif nxt.name not in path and nxt.schema == self.raw.name:
                        stack.append((nxt, [*path, nxt.name]))

    # --- layout ----------------------------------------------------------------------------
    def field_bits(self, t: FieldType) -> int:
        if isinstance(t, IntType):
            return t.bits
        if isinstance(t, EnumDecl):
            return t.bits
        if isinstance(t, MessageDecl):
            if t.bytes_field is not None or t.check_field is not None or t.implicit_fields:
                return -1
            return t.fixed_bits
        if isinstance(t, ArrayType):
            elem = self.field_bits(t.element)
            return -1 if elem < 0 else elem * t.count
        return 0

    def layout(self, msg: MessageDecl) -> None:
        if msg.fixed_bits or not msg.fields:
            return
        for f in msg.fields:
            t = f.type
            inner = t.element if isinstance(t, ArrayType) else t
            if isinstance(inner, MessageDecl):
                self.layout(inner)
        cursor = {True: 0, False: 0}  # implicit prefix and wire part are laid out separately
        occupied: list[tuple[int, int, Field]] = []
        for f in msg.fields:
            if isinstance(f.type, (BytesType, CheckType)):
                continue
            bits = self.field_bits(f.type)
            if bits < 0:
                self.err(f.loc, f"field '{f.name}' nests a message with a payload or check",
                         "nested messages must be fixed-size: no bytes[] and no check inside")
                continue
            start = cursor[f.implicit] if f.position is None else f.position
            for (s, e, other) in occupied:
                if other.implicit == f.implicit and start < e and s < start + bits:
                    self.err(f.loc, f"bit field '{f.name}' (bits {start}..{start + bits - 1}) overlaps '{other.name}' (bits {s}..{e - 1})",
                             "move the field with `@ <bit>` or drop the explicit position")
            f.bit_offset = start
            f.bit_width = bits
            occupied.append((start, start + bits, f))
            cursor[f.implicit] = max(cursor[f.implicit], start + bits)
        msg.implicit_bits = cursor[True]
        msg.fixed_bits = cursor[False]
        if msg.implicit_bits % 8:
            self.err(msg.loc, f"implicit fields of {msg.name} take {msg.implicit_bits} bits, not whole bytes",
                     "pad the implicit fields to a multiple of 8 bits with `_: uN`")
        if msg.fixed_bits % 8:
            self.err(msg.loc, f"fixed part of {msg.name} takes {msg.fixed_bits} bits, not whole bytes",
                     f"add `_: u{8 - msg.fixed_bits % 8} \"reserved\"` so the message ends on a byte boundary")
        for f in msg.fields:
            if not isinstance(f.type, IntType) or f.type.is_bool or f.type.bits % 8 or f.position is not None:
                continue
            if f.bit_offset % 8 and not f.implicit:
                self.err(f.loc, f"{f.type.name} field '{f.name}' starts at bit {f.bit_offset}, inside a byte",
                         "byte-sized integers (u8/u16/u32, i8/i16/i32) must start on a byte boundary; reorder or pad")
        if msg.fixed_bits // 8 + msg.max_payload > 255:
            self.err(msg.loc, f"{msg.name} is longer than 255 bytes", "split the message")

    # --- nodes -----------------------------------------------------------------------------
    def build_node(self, item: Tree[Token]) -> None:
        kind_tok, name_tok, class_val, doc = item.children[:4]
        assert isinstance(kind_tok, Token) and isinstance(name_tok, Token)
        kind = str(kind_tok)
        class_id = _int(class_val)
        if not 0 <= class_id <= 255:
            self.err(name_tok, f"class {class_id} does not fit in 8 bits", "node classes are 0..255")
        mailboxes: list[Mailbox] = []
        for mnode in item.children[4:]:
            assert isinstance(mnode, Tree)
            dir_tok, num_val, msg_tok = mnode.children[:3]
            assert isinstance(dir_tok, Token) and isinstance(msg_tok, Token)
            rate = None
            rest = mnode.children[3:]
            if len(rest) == 2:
                rate_tok = rest[0]
                assert isinstance(rate_tok, Token)
                rate = float(str(rate_tok))
                if not (math.isfinite(rate) and rate > 0):
                    self.err(rate_tok, f"rate {rate_tok} is not a positive number of Hz", "write the refresh rate in Hz, e.g. `rate 100`, or leave it out")
                    rate = None
            mdoc = _doc(rest[-1])
            number = _int(num_val)
            direction = str(dir_tok)
            loc = _loc(self.path, dir_tok)
            if not 0 <= number < MAILBOXES:
                self.err(dir_tok, f"{direction} {number} does not exist", f"mailboxes are numbered 0..{MAILBOXES - 1}")
                continue
            if number == 0 and kind == "node":
                what = "identification (Identification)" if direction == "outbox" else "commands (Command)"
                self.err(dir_tok, f"{direction} 0 is reserved for {what}", "number your mailboxes from 1; every node gets mailbox 0 from urb_core")
                continue
            dup = next((m for m in mailboxes if m.direction == direction and m.number == number), None)
            if dup is not None:
                self.err(dir_tok, f"duplicate mailbox number: {direction} {number} is already declared at {dup.loc}",
                         "give each inbox and each outbox its own number")
                continue
            found = self.lookup(str(msg_tok))
            if not isinstance(found, MessageDecl):
                self.err(msg_tok, f"unknown message '{msg_tok}'", "declare the message in this schema or an import")
                continue
            if not found.is_fixed_size:
                self.err(msg_tok, f"message '{found.name}' has a payload, check or implicit field and cannot be a mailbox",
                         "mailbox messages are fixed-size layouts; the link adds the check")
                continue
            if found.fixed_size > MAX_MAILBOX_SIZE:
                self.err(msg_tok, f"payload over {MAX_MAILBOX_SIZE} bytes: {found.name} takes {found.fixed_size} bytes",
                         f"mailboxes hold at most {MAX_MAILBOX_SIZE} bytes; split the message over two mailboxes")
                continue
            if found.fixed_size == 0:
                self.err(msg_tok, f"message '{found.name}' is empty", "give the mailbox message at least one field")
                continue
            mailboxes.append(Mailbox(direction, number, found, rate, mdoc, loc))
        if kind == "node":
            ident = self.lookup("Identification")
            command = self.lookup("Command")
            if not isinstance(ident, MessageDecl) or not isinstance(command, MessageDecl):
                self.err(name_tok, "nodes need urb_core's Identification and Command messages", "add `import urb_core`")
            else:
                mailboxes[:0] = [
                    Mailbox("outbox", 0, ident, None, "Identification (urb_core)", _loc(self.path, name_tok)),
                    Mailbox("inbox", 0, command, None, "Commands (urb_core)", _loc(self.path, name_tok)),
                ]
        elif kind == "bridge":
            for direction in ("outbox", "inbox"):
                if not any(m.direction == direction and m.number == 0 for m in mailboxes):
                    self.err(name_tok, f"a bridge must declare its {direction} 0", f"add `{direction} 0 <Message> \"doc\"`")
        ident = node_ident(str(name_tok))
        clash = next((n for n in [*self._names, *self.schema.nodes.values()]
                      if (n.name if isinstance(n, NodeDecl) else n) == ident or
                      (isinstance(n, NodeDecl) and node_ident(n.name) == ident)), None)
        if ident in _PY_MODULE_NAMES or self._lookup_imported(ident) is not None or clash is not None:
            self.err(name_tok, f"node {name_tok} is published in Python as {ident}, a name already in use",
                     "rename the node or the item it clashes with")
        elif self.declare(name_tok):
            self.schema.nodes[str(name_tok)] = NodeDecl(str(name_tok), kind, class_id, _doc(doc), _loc(self.path, name_tok), mailboxes, self.raw.name)


def _check_across(schemas: list[Schema]) -> list[SchemaError]:
    """Rules over every schema loaded together (what one `urb gen` generates into one C namespace and
    one Python package): each item name is declared once, and each node class id belongs to one node type.

    A schema and its direct imports are already checked by the builder; this catches siblings (two files
    declaring message X: urb_msgs.MESSAGES silently kept one) and imports of imports.
    """
    errors: list[SchemaError] = []
    first: dict[str, tuple[str, Location, str]] = {}
    classes: dict[int, NodeDecl] = {}
    for s in schemas:  # imports before the schemas importing them: the later declaration is reported
        items: list[tuple[str, str, Location]] = [
            *(("constant", c.name, c.loc) for c in s.consts.values()),
            *(("checksum", c.name, c.loc) for c in s.checksums.values()),
            *(("enum", e.name, e.loc) for e in s.enums.values()),
            *(("message", m.name, m.loc) for m in s.messages.values()),
            *(("node", n.name, n.loc) for n in s.nodes.values()),
        ]
        for kind, name, loc in sorted(items, key=lambda i: (i[2].line, i[2].column)):
            if name in first:
                other_kind, other_loc, other_schema = first[name]
                errors.append(SchemaError(
                    loc, f"{kind} '{name}' is already declared as {other_kind} {name} in schema {other_schema} (at {other_loc})",
                    "give it another name: every schema generated together shares one Python registry "
                    "(urb_msgs.MESSAGES, NODES) and one C namespace", related=other_loc,
                    message_there=f"{other_kind} '{name}' is declared again as {kind} {name} in schema {s.name} (at {loc})"))
            else:
                first[name] = (kind, loc, s.name)
        for node in s.nodes.values():
            other = classes.get(node.class_id)
            if other is not None:
                errors.append(SchemaError(
                    node.loc, f"{node.kind} {node.name} has class {node.class_id:#04x}, already the class of "
                    f"{other.kind} {other.name} (at {other.loc})",
                    "give every node type its own class id: discovery tells node types apart by it "
                    "(find_node(name, index) looks a node up by its class)", related=other.loc,
                    message_there=f"{other.kind} {other.name} has class {other.class_id:#04x}, also the class of "
                    f"{node.kind} {node.name} (at {node.loc})"))
            else:
                classes[node.class_id] = node
    return errors


@dataclass
class Loaded:
    """Everything `load_report` found, nothing raised."""

    schemas: list[Schema]  # every schema that built: the files given, their imports, the siblings read
    errors: list[SchemaError]  # every error of every file read, in the order found
    unread: set[Path]  # files that did not parse or build: not all their declarations were compared
    imports: dict[Path, set[Path]]  # each file that parsed -> the files it imports, directly or not


def load(paths: list[Path]) -> list[Schema]:
    """Parse, resolve and check schema files; imports resolve among them and their folders.

    Raises SchemaErrors (with every problem found) when any file is wrong.
    """
    loaded = load_report(paths, keep_going=False)
    if loaded.errors:
        raise SchemaErrors(loaded.errors)
    explicit = {p.resolve() for p in paths}
    return [s for s in loaded.schemas if s.path.resolve() in explicit] or loaded.schemas


def load_report(paths: list[Path], keep_going: bool = True) -> Loaded:
    """Parse, resolve and check schema files together (as `load`), and report rather than raise.

    With keep_going, a file that does not parse does not stop the others from being built and
    compared; without it (what `load` does) nothing is built when any file does not parse.
    """
    raws: dict[str, _Raw] = {}
    errors: list[SchemaError] = []
    unread: set[Path] = set()
    queue = [p.resolve() for p in paths]
    seen: set[Path] = set()
    while queue:
        path = queue.pop(0)
        if path in seen:
            continue
        seen.add(path)
        try:
            raw = parse_file(path)
        except SchemaError as exc:
            errors.append(exc)
            unread.add(path)
            continue
        if raw.name in raws:
            errors.append(SchemaError(Location(path, 1, 1), f"schema '{raw.name}' is also defined in {raws[raw.name].path}",
                                      "give each schema file its own `schema` name", related=Location(raws[raw.name].path, 1, 1),
                                      message_there=f"schema '{raw.name}' is also defined in {path}"))
            unread.add(path)
            continue
        raws[raw.name] = raw
        for name, _loc_ in raw.imports:
            if name not in raws:
                queue.extend(p for p in sorted(path.parent.glob("*.urbs")) if p not in seen)
    imports = {raw.path: _imported(raw, raws) for raw in raws.values()}
    if errors and not keep_going:
        return Loaded([], errors, unread, imports)
    built: dict[str, Schema] = {}
    compared: list[Schema] = []  # what the rules across schemas see: the built ones, with keep_going the partial ones too
    failed: set[str] = set()  # built once, with errors: a schema two others import is reported once
    visiting: list[str] = []

    def build(name: str, at: Location | None) -> Schema | None:
        if name in built or name in failed:
            return built.get(name)
        raw = raws.get(name)
        if raw is None:
            assert at is not None
            broken = sorted(p for p in unread if p.parent == at.path.parent)
            hint = "put the imported .urbs file in the same folder" + (
                f" (or fix {', '.join(p.name for p in broken)}: a file there that does not parse)" if broken else "")
            errors.append(SchemaError(at, f"unknown schema '{name}'", hint))
            return None
        if name in visiting:
            assert at is not None
            errors.append(SchemaError(at, f"circular import: {' -> '.join([*visiting, name])}", "remove one of the imports"))
            return None
        visiting.append(name)
        imports = [s for s in (build(n, loc) for n, loc in raw.imports) if s is not None]
        visiting.pop()
        builder = _Builder(raw, imports)
        try:
            schema = builder.build()
        except SchemaErrors as exc:
            errors.extend(exc.errors)
            unread.add(raw.path)
            failed.add(name)
            if keep_going:  # what it declared without error still meets the siblings' names and classes
                compared.append(builder.schema)
            return None
        built[name] = schema
        compared.append(schema)
        return schema

    for raw in list(raws.values()):
        build(raw.name, None)
    errors.extend(_check_across(compared))
    return Loaded(list(built.values()), errors, unread, imports)


def _imported(raw: _Raw, raws: dict[str, _Raw]) -> set[Path]:
    """The files `raw` imports, directly or through other imports (those that parsed)."""
    found: set[Path] = set()
    todo = [name for name, _ in raw.imports]
    while todo:
        other = raws.get(todo.pop())
        if other is not None and other.path not in found and other is not raw:
            found.add(other.path)
            todo += [name for name, _ in other.imports]
    return found
