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


def test_cli_reports_errors_without_traceback(tmp_path: Path) -> None:
    bad = tmp_path / "bad.urbs"
    bad.write_text('schema bad "b"\nmessage M "m" {\n    a: u99 "a"\n}\n')
    proc = subprocess.run([sys.executable, "-m", "urb.cli", "schema", "check", str(bad)], capture_output=True, text=True)
    assert proc.returncode == 1
    assert f"{bad}:3:8: error:" in proc.stderr
    assert "hint:" in proc.stderr
    assert "Traceback" not in proc.stderr + proc.stdout


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
