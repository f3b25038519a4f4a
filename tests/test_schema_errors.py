"""Broken schemas give file:line:column, a caret, and a one-line hint; never a traceback."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from urb_codegen.errors import SchemaErrors
from urb_codegen.parser import load

HEADER = 'schema t "test schema"\nimport urb_core\n'


def _errors(tmp_path: Path, body: str) -> SchemaErrors:
    core = Path(__file__).resolve().parents[1] / "spec" / "schema" / "core.urbs"
    (tmp_path / "core.urbs").write_text(core.read_text())
    path = tmp_path / "t.urbs"
    path.write_text(HEADER + body)
    with pytest.raises(SchemaErrors) as info:
        load([path])
    return info.value


# Each case: schema body, expected (line, column) of the first error, words of the message.
CASES = {
    "unknown type": ('message M "m" {\n    a: u8 "a"\n    b: Bogus "b"\n}\n', (5, 8), "unknown type 'Bogus'"),
    "oversized bit field": ('message M "m" {\n    a: u33 "a"\n}\n', (4, 8), "wider than 32 bits"),
    "overlapping bit fields": ('message M "m" {\n    a: u4 @ 0 "a"\n    b: u4 @ 2 "b"\n    _: u4 @ 6 "c"\n}\n', (5, 5), "overlaps 'a'"),
    "payload over 32 bytes": ('message M "m" {\n    n: u8 "n"\n    d: bytes[n <= 40] "d"\n}\n', (5, 8), "payload over 32 bytes"),
    "mailbox over 32 bytes": ('message Big "b" {\n    a: u8[33] "a"\n}\nnode N class 0x40 "n" {\n    outbox 1 Big "o"\n}\n',
                              (7, 14), "payload over 32 bytes"),
    "duplicate mailbox numbers": ('message A "a" {\n    x: u8 "x"\n}\nnode N class 0x40 "n" {\n    outbox 1 A "o"\n    outbox 1 A "p"\n}\n',
                                  (8, 5), "duplicate mailbox number"),
    "mailbox 0 is reserved": ('message A "a" {\n    x: u8 "x"\n}\nnode N class 0x40 "n" {\n    inbox 0 A "o"\n}\n',
                              (7, 5), "inbox 0 is reserved"),
    "circular references": ('message A "a" {\n    b: B "b"\n}\nmessage B "b" {\n    a: A "a"\n}\n', (3, 9), "circular reference: A -> B -> A"),
    "self reference": ('message A "a" {\n    a: A "a"\n}\n', (4, 8), "contains itself"),
    "missing checksum coverage": ('message M "m" {\n    a: u8 "a"\n    b: u8 "b"\n    c: link_check covers b..b "c"\n}\n',
                                  (6, 5), "missing checksum coverage: a"),
    "check without coverage": ('message M "m" {\n    a: u8 "a"\n    c: link_check "c"\n}\n', (5, 5), "does not say what it covers"),
    "missing documentation": ('message M "m" {\n    a: u8\n}\n', (5, 1), "expected"),
    "unclosed block": ('message M "m" {\n    a: u8 "a"\n', (4, 14), "unexpected end of file"),
    "unaligned u16": ('message M "m" {\n    a: u4 "a"\n    b: u16 "b"\n    _: u4 "c"\n}\n', (5, 5), "starts at bit 4"),
    "not whole bytes": ('message M "m" {\n    a: u4 "a"\n}\n', (3, 9), "not whole bytes"),
    "enum value too wide": ('enum E : u2 "e" {\n    A = 4 "a"\n}\n', (4, 5), "does not fit in u2"),
    "duplicate field": ('message M "m" {\n    a: u8 "a"\n    a: u8 "b"\n}\n', (5, 5), "duplicate field 'a'"),
    "payload not last": ('message M "m" {\n    d: bytes[<= 4] "d"\n    a: u8 "a"\n}\n', (4, 5), "must be the last field"),
    # names the generated C or Python cannot use (they broke the output or mis-decoded silently)
    "python keyword field": ('message M "m" {\n    from: u8 "a"\n}\n', (4, 5), "field name 'from' is a Python keyword"),
    "field shadowing the message API": ('message M "m" {\n    encode: u8 "a"\n}\n', (4, 5), "generated Python already uses"),
    "field shadowing a class-body helper": ('message M "m" {\n    field: u8 "a"\n    b: u8[2] "b"\n}\n', (4, 5), "field name 'field'"),
    "field with a leading underscore": ('message M "m" {\n    __GNUC__: u8 "a"\n}\n', (4, 5), "starts with '_'"),
    "field named like a C header macro": ('message M "m" {\n    SIZE_MAX: u8 "a"\n}\n', (4, 5), "macro of the C headers"),
    "implicit field named data": ('message M "m" {\n    data: u8 implicit "a"\n    b: u8 "b"\n    c: link_check covers data..b "c"\n}\n',
                                  (4, 5), "implicit field cannot be named 'data'"),
    "python keyword enum member": ('enum E : u8 "e" {\n    None = 0 "n"\n}\n', (4, 5), "enum member 'None' is a Python keyword"),
    "enum member mro": ('enum E : u8 "e" {\n    mro = 0 "n"\n}\n', (4, 5), "enum member 'mro'"),
    "python keyword message": ('message class "m" {\n    a: u8 "a"\n}\n', (3, 9), "name 'class' is a Python keyword"),
    "message named like a runtime import": ('message Message "m" {\n    a: u8 "a"\n}\n', (3, 9), "generated Python already uses"),
    "node published like a const": ('const MY_NODE = 1 "c"\nmessage A "a" {\n    x: u8 "x"\n}\nnode MyNode class 0x40 "n" {\n    outbox 1 A "o"\n}\n',
                                    (7, 6), "published in Python as MY_NODE"),
    "node published as MESSAGES": ('message A "a" {\n    x: u8 "x"\n}\nnode Messages class 0x40 "n" {\n    outbox 1 A "o"\n}\n',
                                   (6, 6), "published in Python as MESSAGES"),
    # layouts the emitters turned into C that does not compile, or into silently different frames
    "fixed length field": ('message M "m" {\n    n: u8 = 4 "n"\n    p: bytes[n <= 4] "p"\n}\n', (5, 5), "length field 'n' is fixed"),
    "reserved length field": ('message M "m" {\n    _: u8 "n"\n    p: bytes[_ <= 4] "p"\n}\n', (5, 5), "length field '_' is reserved"),
    "implicit length field": ('message M "m" {\n    n: u8 implicit "n"\n    p: bytes[n <= 4] "p"\n    c: link_check covers n..p "c"\n}\n',
                              (5, 5), "length field 'n' is implicit"),
    "reserved field with a value": ('message M "m" {\n    _: u8 = 3 "a"\n}\n', (4, 11), "always sent as zero"),
    "option given twice": ('message M "m" {\n    a: u8 in 1..2 in 3..4 "a"\n}\n', (4, 19), "option given twice"),
    "fixed value outside its range": ('message M "m" {\n    a: u8 = 5 in 1..3 "a"\n}\n', (4, 5), "outside its range 1..3"),
    "fixed value not an enum member": ('enum E : u8 "e" {\n    A = 0 "a"\n}\nmessage M "m" {\n    a: E = 3 "a"\n}\n', (7, 10),
                                       "not a member of enum E"),
    "infinite scale": ('message M "m" {\n    a: u8 scale 1e999 "a"\n}\n', (4, 11), "not a finite number"),
    "rate not positive": ('message A "a" {\n    x: u8 "x"\n}\nnode N class 0x40 "n" {\n    outbox 1 A rate 0 "o"\n}\n', (7, 21),
                          "not a positive number of Hz"),
    "enum value beyond a C int": ('enum E : u32 "e" {\n    A = 0x80000000 "a"\n}\n', (4, 5), "does not fit in a C enum"),
    "constant beyond 32 bits": ('const BIG = 0x100000000 "b"\n', (3, 13), "does not fit in 32 bits"),
    "tier never used": ('checksum c "c" {\n    tier a width 8 poly 7 init 0 xorout 0 max_covered 10\n'
                        '    tier b width 16 poly 0x1021 init 0 xorout 0 max_covered 3\n    tier d width 32 poly 0x04C11DB7 init 0 xorout 0\n}\n',
                        (5, 10), "tier 'b' would never be used"),
    "duplicate tier": ('checksum c "c" {\n    tier a width 8 poly 7 init 0 xorout 0 max_covered 3\n    tier a width 16 poly 0x1021 init 0 xorout 0\n}\n',
                       (5, 10), "duplicate tier 'a'"),
    "unterminated string": ('message M "m" {\n    a: u8 "a\n}\n', (4, 11), "unterminated string"),
    # a field named like a type hid it in the Python class body: `Inner: Inner` then `y: Inner` gave
    # field(default_factory=<the Field of Inner>), a TypeError at every construction
    "field named like its enum": ('enum Mode : u8 "e" {\n    OFF = 0 "o"\n}\nmessage M "m" {\n    Mode: Mode "a"\n    x: Mode "b"\n}\n',
                                  (7, 5), "field name 'Mode' is the name of enum Mode"),
    "field named like a message": ('message Inner "i" {\n    a: u8 "a"\n}\nmessage M "m" {\n    Inner: Inner "a"\n    y: Inner "b"\n}\n',
                                   (7, 5), "field name 'Inner' is the name of message Inner"),
    "field named like an imported message": ('message M "m" {\n    Identification: u8 "a"\n}\n', (4, 5),
                                             "is the name of message Identification"),
    "field named like its own message": ('message M "m" {\n    M: u8 "a"\n}\n', (4, 5), "is the name of message M"),
    "message named like a builtin the module calls": ('message bool "m" {\n    a: u8 "a"\n}\n', (3, 9), "name 'bool'"),
    "field named like an annotation type": ('message M "m" {\n    int: u8 "a"\n    b: u8 "b"\n}\n', (4, 5), "field name 'int'"),
    # a length field that cannot hold the bound: MAX_SIZE promised frames no encoder produces
    "length field narrower than its bound": ('message M "m" {\n    n: u2 "n"\n    _: u6 "r"\n    p: bytes[n <= 32] "p"\n}\n',
                                             (6, 5), "length field 'n' (u2) holds at most 3 but the payload bound is 32"),
    "length field range below its bound": ('message M "m" {\n    n: u8 in 0..10 "n"\n    p: bytes[n <= 32] "p"\n}\n',
                                           (5, 5), "allows at most 10 but the payload bound is 32"),
    # `_` is zero bits: a message's fixed values (sent as 0 while LAYOUT said =5), an enum, a payload
    "reserved field of message type": ('message F "f" {\n    k: u8 = 5 "k"\n}\nmessage M "m" {\n    _: F "pad"\n}\n',
                                       (7, 8), "its type cannot be message F"),
    "reserved field of enum type": ('enum E : u8 "e" {\n    A = 1 "a"\n}\nmessage M "m" {\n    _: E "pad"\n}\n',
                                    (7, 8), "its type cannot be enum E"),
    "reserved payload": ('message M "m" {\n    a: u8 "a"\n    _: bytes[<= 4] "p"\n}\n', (5, 8), "its type cannot be bytes"),
    "reserved array of messages": ('message F "f" {\n    k: u8 "k"\n}\nmessage M "m" {\n    _: F[2] "pad"\n}\n',
                                   (7, 8), "its type cannot be message F"),
    "two-dimensional array": ('message M "m" {\n    a: u8[2][3] "a"\n}\n', (4, 13), "arrays have one dimension"),
    "integer type with a leading zero": ('message M "m" {\n    a: u08 "a"\n}\n', (4, 8), "'u08' is not an integer type"),
    "enum base with a leading zero": ('enum E : i016 "e" {\n    A = 1 "a"\n}\n', (3, 10), "'i016' is not an integer type"),
    "message spelled like an integer type": ('message u8 "m" {\n    a: u16 "a"\n}\n', (3, 9), "spelled like an integer type"),
    "two nodes share a class id": ('message A "a" {\n    x: u8 "x"\n}\nnode N1 class 0x40 "n" {\n    outbox 1 A "o"\n}\n'
                                   'node N2 class 0x40 "n" {\n    outbox 1 A "o"\n}\n', (9, 6), "already the class of node N1 (at "),
    "node sharing the bridge's class": ('message A "a" {\n    x: u8 "x"\n}\nnode N1 class 0x00 "n" {\n    outbox 1 A "o"\n}\n',
                                        (6, 6), "already the class of bridge Bridge"),
    # rules (`require`): every way a rule can be meaningless or unimplementable
    "rule naming no field": ('message M "m" {\n    a: u8 "a"\n    require a == b "r"\n}\n', (5, 18),
                             "unknown name 'b': not a field of M, nor a constant"),
    "rule comparing an enum with a number": ('message M "m" {\n    s: Status "s"\n    _: u4 "r"\n    require s == 3 "r"\n}\n',
                                             (6, 13), "compared here with the number 3"),
    "rule naming no member": ('message M "m" {\n    s: Status "s"\n    _: u4 "r"\n    require s == FINE "r"\n}\n', (6, 18),
                              "'FINE' is not a member of enum Status"),
    "rule ordering an enum": ('message M "m" {\n    s: Status "s"\n    _: u4 "r"\n    require s < OK "r"\n}\n', (6, 13),
                              "compares enum members"),
    "rule value outside the type": ('message M "m" {\n    a: u3 "a"\n    _: u5 "r"\n    require a != 9 "r"\n}\n', (6, 13),
                                    "`a` holds 0..7"),
    "rule on a number alone": ('message M "m" {\n    a: u8 "a"\n    require a "r"\n}\n', (5, 13), "not a bool"),
    "rule on a payload": ('message M "m" {\n    d: bytes[<= 4] "d"\n    require d == 0 "r"\n}\n', (5, 13), "is a byte payload"),
    "rule on a length field": ('message M "m" {\n    n: u8 "n"\n    d: bytes[n <= 4] "d"\n    require n != 3 "r"\n}\n', (6, 13),
                               "`n` counts the payload d"),
    "rule on a fixed field": ('message M "m" {\n    a: u8 = 3 "a"\n    b: u8 "b"\n    require a == b "r"\n}\n', (6, 13),
                              "is fixed to 3"),
    "rule on an array": ('message M "m" {\n    a: u8[2] "a"\n    require a == 1 "r"\n}\n', (5, 13), "is an array"),
    "rule on a whole message": ('message M "m" {\n    s: MailboxSelect "a"\n    require s == 1 "r"\n}\n', (5, 13),
                                "is a message (MailboxSelect)"),
    "rule path through a number": ('message M "m" {\n    a: u8 "a"\n    require a.b == 1 "r"\n}\n', (5, 15), "is not a message"),
    "rule nobody meets": ('message M "m" {\n    a: u2 "a"\n    _: u6 "r"\n    require a == 1 and a == 2 "r"\n}\n', (6, 5),
                          "no message satisfies `require a == 1 and a == 2`"),
    "rule everybody meets": ('message M "m" {\n    a: u2 "a"\n    _: u6 "r"\n    require a <= 3 "r"\n}\n', (6, 5),
                             "every message satisfies `require a <= 3`"),
    "rule comparing constants": ('message M "m" {\n    a: u8 "a"\n    require 1 == 2 "r"\n}\n', (5, 13), "names no field"),
    "rule comparing a number with a bool": ('message M "m" {\n    a: u8 "a"\n    b: bool "b"\n    _: u7 "r"\n    require a == b "r"\n}\n',
                                            (7, 13), "cannot be compared"),
    "rule inside a nested message": ('message In "i" {\n    a: u8 "a"\n    require a != 0 "r"\n}\nmessage M "m" {\n    i: In "a"\n}\n',
                                     (8, 5), "message In has rules"),
    "rule without documentation": ('message M "m" {\n    a: u8 "a"\n    require a != 0\n}\n', (6, 1), "expected"),
    "rule with a single =": ('message M "m" {\n    a: u8 "a"\n    require a = 0 "r"\n}\n', (5, 15), "unexpected equal"),
}

# The hint of each case above, where the generic one was wrong.
HINTS = {
    "two-dimensional array": "Row[2]",
    "integer type with a leading zero": "write u8",
    "enum base with a leading zero": "write i16",
    "length field narrower than its bound": "widen the length field to u6",
    "field named like its enum": "`mode`",
    "rule on a length field": "len(d)",
    "rule on a payload": "len(d)",
    "rule without documentation": "documentation string",
    "rule with a single =": "==",
    "rule naming no member": "OK, TIMEOUT",
}


@pytest.mark.parametrize("case", sorted(CASES), ids=str)
def test_broken_schema_points_at_the_problem(tmp_path: Path, case: str) -> None:
    body, (line, column), words = CASES[case]
    errors = _errors(tmp_path, body).errors
    first = errors[0]
    assert words in first.message, first.render()
    assert (first.location.line, first.location.column) == (line, column), first.render()
    rendered = first.render()
    assert rendered.startswith(f"{tmp_path / 't.urbs'}:{line}:{column}: error: ")
    lines = rendered.splitlines()
    assert lines[2].strip() == "^" and len(lines[2]) - 1 == 4 + column - 1  # caret under the column
    assert lines[3].startswith("  hint: ") and len(lines[3]) > 12
    if case in HINTS:
        assert HINTS[case] in first.hint, rendered


def test_cli_reports_errors_without_traceback(tmp_path: Path) -> None:
    bad = tmp_path / "bad.urbs"
    bad.write_text('schema bad "b"\nmessage M "m" {\n    a: u99 "a"\n}\n')
    proc = subprocess.run([sys.executable, "-m", "urb.cli", "schema", "check", str(bad)], capture_output=True, text=True)
    assert proc.returncode == 1
    assert f"{bad}:3:8: error:" in proc.stderr
    assert "hint:" in proc.stderr
    assert "Traceback" not in proc.stderr + proc.stdout


def test_cli_check_reports_what_only_the_emitters_see(tmp_path: Path) -> None:
    """A schema `urb gen` refuses (a C name of the runtime) is refused by `urb schema check` too."""
    bad = tmp_path / "clash.urbs"
    bad.write_text('schema clash "c"\nconst OK = 3 "the runtime success code"\n')
    proc = subprocess.run([sys.executable, "-m", "urb.cli", "schema", "check", str(bad)], capture_output=True, text=True)
    assert proc.returncode == 1, proc.stdout
    assert f"{bad}:2:" in proc.stderr and "URB_OK" in proc.stderr
    assert "Traceback" not in proc.stderr + proc.stdout and ": ok" not in proc.stdout


def test_cli_accepts_the_bundled_schemas() -> None:
    proc = subprocess.run([sys.executable, "-m", "urb.cli", "schema", "check"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert "core.urbs: ok" in proc.stdout and "sensorhex.urbs: ok" in proc.stdout


def test_cli_missing_file_is_a_clear_error(tmp_path: Path) -> None:
    proc = subprocess.run([sys.executable, "-m", "urb.cli", "schema", "check", str(tmp_path / "nope.urbs")],
                          capture_output=True, text=True)
    assert proc.returncode == 1 and "no such file" in proc.stderr and "Traceback" not in proc.stderr


def _not_utf8(tmp_path: Path) -> Path:
    """A schema whose line 2 has a Latin-1 byte (0xe9) at column 12, after valid text."""
    folder = tmp_path / "schemas"
    folder.mkdir()
    path = folder / "latin1.urbs"
    path.write_bytes(b'schema latin1 "l"\nmessage M "\xe9t\xe9" {\n    a: u8 "a"\n}\n')
    return path


def test_file_that_is_not_utf8_points_at_the_first_bad_byte(tmp_path: Path) -> None:
    path = _not_utf8(tmp_path)
    with pytest.raises(SchemaErrors) as info:
        load([path])
    first = info.value.errors[0]
    assert (first.location.line, first.location.column) == (2, 12)
    assert first.message == "not UTF-8 text: byte 0xe9 at byte offset 29 cannot be decoded"
    rendered = first.render()
    assert rendered.startswith(f"{path}:2:12: error: not UTF-8 text") and "hint: " in rendered
    assert rendered.splitlines()[2] == "    " + " " * 11 + "^"


@pytest.mark.parametrize("command", [["schema", "check", "{file}"], ["gen", "--check", "--schemas", "{dir}"],
                                     ["schema", "show", "--schemas", "{dir}"]], ids=" ".join)
def test_cli_reports_a_file_that_is_not_utf8(tmp_path: Path, command: list[str]) -> None:
    path = _not_utf8(tmp_path)
    binary = path.parent / "binary.urbs"
    binary.write_bytes(b"\xff\xfe\x00bad")
    argv = [a.format(file=binary, dir=path.parent) for a in command]
    proc = subprocess.run([sys.executable, "-m", "urb.cli", *argv], capture_output=True, text=True)
    assert proc.returncode == 1, proc.stderr
    assert "Traceback" not in proc.stderr + proc.stdout
    assert f"{binary}:1:1: error: not UTF-8 text: byte 0xff at byte offset 0" in proc.stderr
    if command[0] == "gen":  # every file is checked: both are reported
        assert f"{path}:2:12: error: not UTF-8 text" in proc.stderr


@pytest.mark.parametrize("name, words", [("runtime", "overwrite the generated runtime"), ("class", "Python keyword"),
                                         ("_runtime", "starts with '_'")])
def test_schema_names_the_generators_cannot_use(tmp_path: Path, name: str, words: str) -> None:
    path = tmp_path / "s.urbs"
    path.write_text(f'schema {name} "s"\nmessage M "m" {{\n    a: u8 "a"\n}}\n')
    with pytest.raises(SchemaErrors) as info:
        load([path])
    first = info.value.errors[0]
    assert words in first.message and (first.location.line, first.location.column) == (1, 8), first.render()


def test_empty_file_says_so(tmp_path: Path) -> None:
    path = tmp_path / "empty.urbs"
    path.write_text("# nothing yet\n\n")
    with pytest.raises(SchemaErrors) as info:
        load([path])
    first = info.value.errors[0]
    assert first.message == "empty schema file" and "schema NAME" in first.hint


def _siblings(tmp_path: Path, a: str, b: str) -> tuple[Path, Path, SchemaErrors]:
    """Two schemas in one folder that do not import each other, loaded together as `urb gen` does."""
    core = Path(__file__).resolve().parents[1] / "spec" / "schema" / "core.urbs"
    (tmp_path / "core.urbs").write_text(core.read_text())
    pa, pb = tmp_path / "a.urbs", tmp_path / "b.urbs"
    pa.write_text('schema a "a"\nimport urb_core\n' + a)
    pb.write_text('schema b "b"\nimport urb_core\n' + b)
    with pytest.raises(SchemaErrors) as info:
        load(sorted(tmp_path.glob("*.urbs")))
    return pa, pb, info.value


def test_sibling_schemas_declaring_one_message(tmp_path: Path) -> None:
    """urb_msgs.MESSAGES merged both modules and silently kept b's X; now a load-time error at b's X naming a's."""
    pa, pb, exc = _siblings(tmp_path, 'message X "x" {\n    a: u8 "a"\n}\n', 'const K = 1 "k"\nmessage X "x" {\n    b: u16 "b"\n}\n')
    [error] = exc.errors
    assert (error.location.path, error.location.line, error.location.column) == (pb, 4, 9), error.render()
    assert error.message == f"message 'X' is already declared as message X in schema a (at {pa}:3:9)"
    assert "MESSAGES" in error.hint


def test_sibling_schemas_declaring_one_name_as_different_items(tmp_path: Path) -> None:
    _, pb, exc = _siblings(tmp_path, 'enum Mode : u8 "m" {\n    A = 0 "a"\n}\n', 'const Mode = 1 "k"\n')
    assert [(e.location.path, e.location.line) for e in exc.errors] == [(pb, 3)]
    assert "constant 'Mode' is already declared as enum Mode in schema a" in exc.errors[0].message


def test_sibling_schemas_sharing_a_node_class(tmp_path: Path) -> None:
    box = 'message {m} "m" {{\n    x: u8 "x"\n}}\nnode {n} class 0x40 "n" {{\n    outbox 1 {m} "o"\n}}\n'
    pa, pb, exc = _siblings(tmp_path, box.format(m="A", n="Na"), box.format(m="B", n="Nb"))
    [error] = exc.errors
    assert (error.location.path, error.location.line, error.location.column) == (pb, 6, 6), error.render()
    assert error.message == f"node Nb has class 0x40, already the class of node Na (at {pa}:6:6)"


def test_bundled_schemas_still_load() -> None:
    folder = Path(__file__).resolve().parents[1] / "spec" / "schema"
    assert {s.name for s in load(sorted(folder.glob("*.urbs")))} >= {"urb_core", "sensorhex"}


# `urb schema check FILE` checks FILE with its siblings: the schemas of its folder, which `urb gen` generates together.

MSG = 'message {m} "m" {{\n    x: u8 "x"\n}}\n'
NODE = MSG + 'node {n} class 0x40 "n" {{\n    outbox 1 {m} "o"\n}}\n'


def _check(*files: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "urb.cli", "schema", "check", *map(str, files)],
                          capture_output=True, text=True)


def _folder(path: Path, core: bool = False, **bodies: str) -> dict[str, Path]:
    """A schema folder: one `NAME.urbs` (schema NAME) a body; with core, a copy of core.urbs, imported by each."""
    path.mkdir(parents=True, exist_ok=True)
    if core:
        (path / "core.urbs").write_text((Path(__file__).resolve().parents[1] / "spec" / "schema" / "core.urbs").read_text())
    files = {}
    for name, body in bodies.items():
        files[name] = path / f"{name}.urbs"
        files[name].write_text(f'schema {name} "{name}"\n' + ("import urb_core\n" if core else "") + body)
    return files


@pytest.mark.parametrize("focus", ["a", "b"])
def test_check_file_reports_a_sibling_declaring_one_message(tmp_path: Path, focus: str) -> None:
    """Both files are wrong together: checking either reports the conflict at its own line, naming the other's."""
    f = _folder(tmp_path, a=MSG.format(m="X"), b='const K = 1 "k"\n' + MSG.format(m="X"))
    here, there = (f["a"], f["b"]) if focus == "a" else (f["b"], f["a"])
    at = {f["a"]: "2:9", f["b"]: "3:9"}
    proc = _check(here)
    assert proc.returncode == 1, proc.stdout
    assert proc.stderr.startswith(f"{here}:{at[here]}: error: message 'X' "), proc.stderr
    assert f"(at {there}:{at[there]})" in proc.stderr  # the other declaration, file:line:column
    assert f"{there}:{at[there]}: note: " in proc.stderr and "hint: give it another name" in proc.stderr
    assert proc.stderr.count(": error: ") == 1 and "Traceback" not in proc.stderr and ": ok" not in proc.stdout


def test_check_file_reports_a_sibling_sharing_its_node_class(tmp_path: Path) -> None:
    f = _folder(tmp_path, core=True, a=NODE.format(m="A", n="Na"), b=NODE.format(m="B", n="Nb"))
    proc = _check(f["a"])
    assert proc.returncode == 1, proc.stdout
    assert proc.stderr.startswith(f"{f['a']}:6:6: error: node Na has class 0x40, also the class of "
                                  f"node Nb (at {f['b']}:6:6)"), proc.stderr
    assert f"{f['b']}:6:6: note: the other declaration" in proc.stderr and "hint: give every node type its own class id" in proc.stderr


def test_check_file_reports_a_c_name_clash_with_a_sibling(tmp_path: Path) -> None:
    """What only the C emitter sees across files: a's constant B_H is URB_B_H, the include guard of urb_b.h."""
    f = _folder(tmp_path, a='const B_H = 1 "k"\n', b=MSG.format(m="M"))
    proc = _check(f["a"])
    assert proc.returncode == 1, proc.stdout
    assert proc.stderr.startswith(f"{f['a']}:2:7: error: const B_H and schema b (at {f['b']}:1:1) both become "
                                  "the C name URB_B_H"), proc.stderr
    assert _check(f["b"]).stderr.startswith(f"{f['b']}:1:1: error: schema b and const B_H (at {f['a']}:2:7)")


def test_check_file_notes_errors_of_unrelated_siblings_without_showing_them(tmp_path: Path) -> None:
    """A sibling's own errors are not FILE's: FILE is ok (exit 0); a note names the sibling and the command,
    and says when the sibling could not be compared with FILE (b does not build, c does not parse; d and e
    share a node class but were compared with a)."""
    f = _folder(tmp_path, core=True, a=MSG.format(m="A"), b=MSG.format(m="B").replace("u8", "u99"), c="message {\n",
                d=NODE.format(m="D", n="Nd"), e=NODE.format(m="E", n="Ne"))
    proc = _check(f["a"])
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == f"{f['a']}: ok (1 messages, 0 enums, 0 nodes)\n"
    assert ": error: " not in proc.stderr and "Traceback" not in proc.stderr
    notes = {line.split()[4].rstrip(","): line for line in proc.stderr.splitlines()}
    assert sorted(notes) == sorted(str(f[n]) for n in "bce"), proc.stderr
    for n in "bce":
        assert notes[str(f[n])].startswith(f"urb schema check: note: {f[n]}, generated together with {f['a']} by "
                                           f"`urb gen`, has 1 error of its own (not shown: `urb schema check {f[n]}`")
        assert ("could not be compared" in notes[str(f[n])]) == (n != "e")


def test_check_file_shows_its_conflict_but_not_a_third_file_s_errors(tmp_path: Path) -> None:
    f = _folder(tmp_path, a=MSG.format(m="X"), b=MSG.format(m="X"), c='const K = 1 "k"\nconst K = 2 "k"\n')
    proc = _check(f["b"])
    assert proc.returncode == 1
    assert [line.split(": error: ")[0] for line in proc.stderr.splitlines() if ": error: " in line] == [f"{f['b']}:2:9"]
    assert f"note: {f['c']}, generated together with {f['b']} by `urb gen`, has 1 error of its own" in proc.stderr


def test_check_files_of_different_folders_checks_each_with_its_own_siblings(tmp_path: Path) -> None:
    """Two folders are never generated together: the same message in both is fine; a sibling's is not."""
    one = _folder(tmp_path / "one", a=MSG.format(m="X"))
    two = _folder(tmp_path / "two", b=MSG.format(m="X"), c=MSG.format(m="Y"))
    proc = _check(one["a"], two["b"])
    assert proc.returncode == 0, proc.stderr
    assert f"{one['a']}: ok" in proc.stdout and f"{two['b']}: ok" in proc.stdout and str(two["c"]) not in proc.stdout
    two["c"].write_text('schema c "c"\n' + MSG.format(m="X"))
    proc = _check(one["a"], two["b"])
    assert proc.returncode == 1 and f"{one['a']}: ok" in proc.stdout and str(two["b"]) not in proc.stdout
    assert proc.stderr.startswith(f"{two['b']}:2:9: error: message 'X' "), proc.stderr
    assert str(one["a"]) not in proc.stderr


def test_check_a_bundled_file_alone() -> None:
    folder = Path(__file__).resolve().parents[1] / "spec" / "schema"
    proc = _check(folder / "sensorhex.urbs")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith(f"{folder / 'sensorhex.urbs'}: ok") and "core.urbs" not in proc.stdout
    assert proc.stderr == ""


def test_check_file_reports_a_conflict_with_a_sibling_that_has_errors_of_its_own(tmp_path: Path) -> None:
    """b does not build (u99), yet what it declared without error meets a's names: the conflict is shown."""
    f = _folder(tmp_path, a=MSG.format(m="X"), b=MSG.format(m="X") + MSG.format(m="Y").replace("u8", "u99"))
    proc = _check(f["a"])
    assert proc.returncode == 1
    assert proc.stderr.startswith(f"{f['a']}:2:9: error: message 'X' is declared again as message X in schema b "
                                  f"(at {f['b']}:2:9)"), proc.stderr
    assert proc.stderr.count(": error: ") == 1 and f"note: {f['b']}, generated together" in proc.stderr


def test_errors_of_a_schema_two_others_import_are_reported_once(tmp_path: Path) -> None:
    """Each importer built the broken schema again: its errors came once per importer."""
    f = _folder(tmp_path, c='const A = 1 "a"\nconst A = 2 "b"\n', a="import c\n", b="import c\n")
    with pytest.raises(SchemaErrors) as info:
        load(sorted(f.values()))
    assert [(e.location.path, e.location.line) for e in info.value.errors] == [(f["c"], 3)], info.value.render()


def test_check_a_folder_checks_its_files(tmp_path: Path) -> None:
    """`urb schema check DIR` checks the folder's *.urbs files together (it said "cannot read
    schema: Is a directory")."""
    good = _folder(tmp_path / "good", core=True, a=NODE.format(m="M", n="N"), b=MSG.format(m="Other"))
    proc = _check(tmp_path / "good")
    assert proc.returncode == 0, proc.stderr
    assert sorted(proc.stdout.splitlines()) == [f"{tmp_path / 'good' / name}.urbs: ok" + rest for name, rest in (
        ("a", " (1 messages, 0 enums, 1 nodes)"), ("b", " (1 messages, 0 enums, 0 nodes)"),
        ("core", " (14 messages, 4 enums, 1 nodes)"))], proc.stdout
    assert set(good) == {"a", "b"}
    bad = _folder(tmp_path / "bad", a=MSG.format(m="X"), b=MSG.format(m="Y").replace("u8", "u99"))
    proc = _check(tmp_path / "bad")
    assert proc.returncode == 1 and f"{bad['b']}:3:8: error:" in proc.stderr and "Is a directory" not in proc.stderr
    assert "Traceback" not in proc.stderr + proc.stdout


def test_check_a_folder_without_schemas_says_so(tmp_path: Path) -> None:
    (tmp_path / "notes.txt").write_text("no schema here\n")
    proc = _check(tmp_path)
    assert proc.returncode == 1 and proc.stdout == ""
    assert proc.stderr == (f"urb schema check: {tmp_path}: no *.urbs files in this folder; give schema files, or a "
                           f"folder that holds them\n"), proc.stderr
