"""The generator on schemas a user might write, not only the bundled ones.

A schema with awkward but legal names, docs, widths and checks is generated into a temporary folder;
its C must compile warning-free with the project's strict flags (host gcc and clang, arm-none-eabi),
and its C and Python codecs must agree byte for byte (hypothesis, the C side under ASan+UBSan).
"""

from __future__ import annotations

import dataclasses
import importlib
import random
import re
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from urb.codec_driver import CodecDriver, build_driver
from urb_codegen.errors import SchemaError
from urb_codegen.generate import check_fresh, generate
from urb_codegen.parser import load

REPO = Path(__file__).resolve().parents[1]
WARNINGS = re.search(r"^CODEC_WARNINGS := (.*)$", (REPO / "mk" / "c.mk").read_text(), re.M)
assert WARNINGS is not None
STRICT = WARNINGS.group(1).split()

# Field names the generated Python binds itself (v, cls, self, data, n, out, length, i, e), docs with
# quotes and backslashes, a three-tier check, signed fields of odd widths at odd offsets, an implicit
# field named like a local of decode(), an empty message and a payload with no check; rules over
# signed and unsigned members (compared with each other), enums, payload lengths, a constant and an
# implicit member.
USER = r'''
schema user "A user's node: \"quoted\" docs, C:\\paths and a trailing backslash \\"

checksum tri "Three tiers: CRC-8 up to 4 covered bytes, CRC-16 up to 10, then CRC-32" {
    tier short width 8 poly 0x07 init 0x00 xorout 0x00 max_covered 4
    tier mid width 16 poly 0x1021 init 0xFFFF xorout 0x0000 max_covered 10
    tier long width 32 poly 0x04C11DB7 init 0xFFFFFFFF xorout 0xFFFFFFFF
}

const SHORTEST = 2 "A rule's constant"

enum Mode : i4 "A signed enum" {
    OFF = 0 "off"
    MAX = 7 "the largest value of i4"
}

enum Big : u32 "The largest value a C enum holds" {
    ZERO = 0 "zero"
    TOP = 0x7FFFFFFF "top"
}

message Names "Fields named like the generated code's own variables \"v\" and \"cls\"" {
    v: u4 "v"
    cls: u4 "cls"
    self: i8 "self"
    data: u8 "data"
    n: u8 "n"
    out: u8 "out"
    length: u8 "length"
    i: i3 "i"
    e: Mode "e"
    _: u1 "reserved"
    require self < data or e == MAX "a signed member against an unsigned one, or an enum member"
}

message Odd "Signed fields of odd widths, one across five bytes" {
    a: i2 "a"
    b: i7 "b"
    c: i12 "c"
    d: i32 @ 21 "an i32 at bit 21"
    _: u3 "reserved"
    r: i16 in -300..-5 "a negative range"
    w: i9[5] "a signed array"
    big: Big "big"
    k: u3 = 5 "fixed"
    _: u8 "reserved"
    require (c >= b and r != -5) or not (d > -1000) "signed members, a negative bound, nested not"
}

message Tail "A payload running to a three-tier check" {
    a: i5 "a"
    _: u3 "reserved"
    p: bytes[<= 32] "payload \"p\" ends with a backslash \\"
    c: tri covers a..p "check"
    require len(p) >= SHORTEST or a == 0 "a tail payload's length against a constant"
}

message Counted "A counted payload and a three-tier check" {
    count: u6 in 0..20 "count"
    s: i2 "s"
    p: bytes[count <= 20] "payload"
    c: tri covers count..p "check"
    require len(p) != 7 or s == -1 "a counted payload's length"
}

message Prefixed "An implicit field named like decode()'s locals" {
    n: u8 implicit "not sent"
    body: u8 "body"
    c: tri covers n..body "check"
    require n != 255 "a rule over the implicit member only: the caller's"
}

message Empty "Nothing on the wire" {
}

message Raw "Raw bytes, no check" {
    p: bytes[<= 8] "payload"
}
'''


@pytest.fixture(scope="module")
def generated(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Path, Any]]:
    root = tmp_path_factory.mktemp("user")
    (root / "schema").mkdir()
    (root / "schema" / "user.urbs").write_text(USER)
    generate(load([root / "schema" / "user.urbs"]), root / "c", root / "py" / "user_msgs")
    sys.path.insert(0, str(root / "py"))
    importlib.invalidate_caches()
    try:
        yield root, importlib.import_module("user_msgs")
    finally:
        sys.path.remove(str(root / "py"))
        for name in [m for m in sys.modules if m == "user_msgs" or m.startswith("user_msgs.")]:
            del sys.modules[name]


@pytest.mark.parametrize("cc", ["gcc", "clang", "arm-none-eabi-gcc"])
def test_user_schema_c_compiles_warning_free(generated: tuple[Path, Any], cc: str) -> None:
    root, _ = generated
    if shutil.which(cc) is None:
        pytest.fail(f"{cc} is not installed; run tools/setup.sh")
    target = ["-mcpu=cortex-m0plus", "-mthumb", "-Os"] if cc.startswith("arm") else ["-Wshadow"]
    sources = sorted((root / "c").glob("*.c")) + ([] if cc.startswith("arm") else sorted((root / "c" / "test").glob("*.c")))
    for source in sources:
        done = subprocess.run([cc, *target, *STRICT, f"-I{root / 'c'}", f"-I{root / 'c' / 'test'}", "-c", str(source),
                               "-o", str(root / f"{source.stem}-{cc}.o")], capture_output=True, text=True)
        assert done.returncode == 0, done.stderr


def test_python_docstrings_keep_quotes_and_backslashes(generated: tuple[Path, Any]) -> None:
    _, mod = generated
    assert mod.user.__doc__ == 'A user\'s node: "quoted" docs, C:\\paths and a trailing backslash \\'
    assert mod.user.Names.__doc__ == 'Fields named like the generated code\'s own variables "v" and "cls"'


def test_fields_named_like_generated_locals_decode_to_themselves(generated: tuple[Path, Any]) -> None:
    _, mod = generated
    msg = mod.user.Names(v=15, cls=1, self=-128, data=2, n=3, out=4, length=5, i=-4, e=mod.user.Mode.MAX)
    assert mod.user.Names.decode(msg.encode()) == msg
    pre = mod.user.Prefixed(n=200, body=7)
    assert mod.user.Prefixed.decode(pre.encode(), n=200) == pre
    with pytest.raises(mod.ChecksumError):
        mod.user.Prefixed.decode(pre.encode(), n=201)  # the caller's n is checked, not the frame length


@pytest.fixture(scope="module")
def driver(generated: tuple[Path, Any]) -> Iterator[CodecDriver]:
    root, _ = generated
    with CodecDriver(build_driver(root / "c", root / "codec_driver")) as d:
        yield d


def _c_answer(driver: CodecDriver, cls: Any, frame: bytes, msg: Any = None) -> Any:
    if hasattr(cls, "_pack_implicit"):
        prefix = (msg if msg is not None else cls(n=0))._pack_implicit().to_bytes(1, "little")
        return driver.roundtrip(cls.NAME, frame, prefix)
    return driver.roundtrip(cls.NAME, frame)


def _py_decode(cls: Any, frame: bytes, msg: Any = None) -> Any:
    if hasattr(cls, "_pack_implicit"):
        return cls.decode(frame, n=msg.n if msg is not None else 0)
    return cls.decode(frame)


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(min_value=0, max_value=2**32 - 1))
def test_c_and_python_agree_on_valid_messages(generated: tuple[Path, Any], driver: CodecDriver, seed: int) -> None:
    import urb.msgtools as msgtools

    _, mod = generated
    rng = random.Random(seed)
    cls = rng.choice(sorted(mod.MESSAGES.values(), key=lambda c: c.NAME))
    original = getattr(msgtools, "Message")
    setattr(msgtools, "Message", mod.Message)  # random_message recognises nested messages by their base class
    try:
        msg = msgtools.random_message(cls, rng)
    finally:
        setattr(msgtools, "Message", original)
    frame = msg.encode()
    answer = _c_answer(driver, cls, frame, msg)
    assert answer.ok and answer.frame == frame, (msg, frame.hex(), answer)
    assert _py_decode(cls, frame, msg) == msg


@settings(max_examples=1500, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(index=st.integers(min_value=0, max_value=100), data=st.binary(max_size=48))
def test_c_and_python_agree_on_any_bytes(generated: tuple[Path, Any], driver: CodecDriver, index: int, data: bytes) -> None:
    _, mod = generated
    classes = sorted(mod.MESSAGES.values(), key=lambda c: c.NAME)
    cls = classes[index % len(classes)]
    errors = {mod.TooShortError: "short", mod.TooLongError: "long", mod.ChecksumError: "checksum", mod.OutOfRangeError: "range"}
    answer = _c_answer(driver, cls, data)
    try:
        msg = _py_decode(cls, data)
    except mod.DecodeError as exc:
        assert not answer.ok and answer.error == errors[type(exc)], (cls.NAME, data.hex(), exc, answer)
    else:
        assert answer.ok and answer.frame == data, (cls.NAME, data.hex(), answer)
        assert msg.encode() == data


def test_rules_hold_in_both_languages(generated: tuple[Path, Any], driver: CodecDriver) -> None:
    """A frame that breaks a rule is out of range in both; a rule over the implicit member alone is the
    caller's mistake in both (ArgumentError, URB_ERR_ARGUMENT), whatever the frame."""
    _, mod = generated
    user = mod.user
    assert user.Tail.RULES == ("len(p) >= SHORTEST or a == 0",)
    for msg in (user.Names(self=5, data=4, e=user.Mode.OFF), user.Tail(a=1, p=b"x"), user.Counted(p=bytes(7), s=0),
                user.Odd(b=5, c=4, d=0, r=-6)):
        assert msg.broken_rule() is not None
        with pytest.raises(mod.EncodeError, match="breaks the rule"):
            msg.encode()
        fixed = dataclasses.replace(msg, **({"e": user.Mode.MAX} if isinstance(msg, user.Names) else
                                             {"a": 0} if isinstance(msg, user.Tail) else
                                             {"s": -1} if isinstance(msg, user.Counted) else {"c": 5}))
        frame = fixed.encode()
        assert _c_answer(driver, type(msg), frame).frame == frame and type(msg).decode(frame) == fixed
    tail = user.Tail(a=1, p=b"xy").encode()  # one payload byte less breaks the rule: cut it, re-check
    body = tail[:2]
    broken = body + user._tri.seal(body)
    with pytest.raises(mod.OutOfRangeError, match="breaks the rule"):
        user.Tail.decode(broken)
    assert _c_answer(driver, user.Tail, broken).error == "range"
    frame = user.Prefixed(n=254, body=7).encode()
    with pytest.raises(mod.ArgumentError, match="break the rule"):
        user.Prefixed.decode(frame, n=255)
    assert driver.roundtrip("Prefixed", frame, bytes([255])).error == "argument"
    assert driver.roundtrip("Prefixed", b"", bytes([255])).error == "argument"  # before the frame is read


def test_generated_rules_mean_what_the_model_says(generated: tuple[Path, Any]) -> None:
    """broken_rule() of the generated Python against model.rule_holds (the rules' semantics, evaluated
    from the schema model alone) on messages drawn without regard to the rules: both verdicts occur."""
    import typing

    import urb.msgtools as msgtools
    from urb_codegen.model import RuleConst, RuleField, rule_holds

    root, mod = generated
    model = {m.name: m for m in load([root / "schema" / "user.urbs"])[0].messages.values()}
    rng = random.Random(35)
    verdicts: dict[str, set[bool]] = {}
    for name, decl in model.items():
        if not decl.rules:
            continue
        cls = mod.MESSAGES[name]
        hints = typing.get_type_hints(cls)
        for _ in range(300):
            msg = cls(**{f.name: msgtools._random_field(f, hints[f.name], rng) for f in cls.FIELDS})
            values: dict[str, int] = {}
            for rule in decl.rules:
                for o in rule.operands:
                    if isinstance(o, RuleField):
                        value: Any = msg
                        for f in o.path:
                            value = getattr(value, f.name)
                        values[o.key] = int(value)
                    elif not isinstance(o, RuleConst):
                        values[o.key] = len(getattr(msg, o.payload.name))
            holds = all(rule_holds(rule.expr, values) for rule in decl.rules)
            assert (msg.broken_rule() is None) == holds, (msg, values)
            verdicts.setdefault(name, set()).add(holds)
    assert verdicts and all(v == {True, False} for v in verdicts.values()), verdicts


def test_three_tier_frame_between_tiers_is_too_long_in_both(generated: tuple[Path, Any], driver: CodecDriver) -> None:
    """6 bytes of Tail: CRC-8 would cover 5 (over its 4), CRC-16 would cover 4 (CRC-8's): no frame has 6 bytes."""
    _, mod = generated
    frame = bytes(6)
    with pytest.raises(mod.TooLongError):
        mod.user.Tail.decode(frame)
    assert driver.roundtrip("Tail", frame).error == "long"


def _emit_error(tmp_path: Path, body: str) -> SchemaError:
    from urb_codegen.emit_c import emit_c

    path = tmp_path / "t.urbs"
    path.write_text('schema t "t"\n' + body)
    with pytest.raises(SchemaError) as info:
        emit_c(load([path]), tmp_path / "out")
    return info.value


@pytest.mark.parametrize("body, name", [
    ('const ERR_RANGE = 3 "an error code of the runtime"\n', "URB_ERR_RANGE"),
    ('const OK = 3 "the runtime success code"\n', "URB_OK"),
    ('const RUNTIME_VERSION = 3 "the runtime version macro"\n', "URB_RUNTIME_VERSION"),
    ('enum Err : u8 "members become URB_ERR_*" {\n    RANGE = 0 "r"\n}\n', "URB_ERR_RANGE"),
    ('const T_H = 1 "the header guard of urb_t.h"\n', "URB_T_H"),
    ('checksum c "c" {\n    tier a width 8 poly 7 init 0 xorout 0\n}\nconst A_C_INIT = 1 "a tier macro"\n', "URB_A_C_INIT"),
], ids=["error code", "ok", "runtime version", "enum members", "header guard", "crc macro"])
def test_c_names_of_the_runtime_are_refused(tmp_path: Path, body: str, name: str) -> None:
    error = _emit_error(tmp_path, body)
    assert name in error.message and error.location.path.name in ("t.urbs", "urb_runtime.h")
    assert error.location.path.name == "t.urbs", error.render()


@pytest.mark.parametrize("body, name", [
    ('const ERR_RANGE = 3 "an error code of the runtime"\n', "URB_ERR_RANGE"),
    ('const OK = 3 "the runtime success code"\n', "URB_OK"),
    ('const RUNTIME_VERSION = 3 "the runtime version macro"\n', "URB_RUNTIME_VERSION"),
    ('enum Err : u8 "members become URB_ERR_*" {\n    RANGE = 0 "r"\n}\n', "URB_ERR_RANGE"),
], ids=["error code", "ok", "runtime version", "enum members"])
def test_runtime_clash_says_the_name_is_reserved(tmp_path: Path, body: str, name: str) -> None:
    """The other side of the clash is the runtime, not a place in a file (it said `urb_runtime.h:1:1`)."""
    error = _emit_error(tmp_path, body)
    assert "urb_runtime.h" not in error.message and ":1:1" not in error.message, error.render()
    assert f"the C name {name}, which the generated runtime reserves" in error.message, error.render()


@pytest.mark.parametrize("body, words", [
    ('message M "m" {\n    URB_OK: u8 "a"\n}\n', "C macro URB_OK, defined for the generated runtime"),
    ('const K = 1 "k"\nmessage M "m" {\n    URB_K: u8 "a"\n}\n', "C macro URB_K, defined for const K (at "),
    ('message M "m" {\n    URB_M_SIZE: u8 "a"\n}\n', "C macro URB_M_SIZE, defined for message M (at "),
], ids=["runtime", "const", "message size"])
def test_field_named_like_a_generated_macro(tmp_path: Path, body: str, words: str) -> None:
    """`uint8_t URB_OK;` became `uint8_t 0;`: the C did not compile. Refused at the field."""
    error = _emit_error(tmp_path, body)
    assert words in error.message, error.render()
    assert error.location.path.name == "t.urbs" and error.location.column == 5, error.render()
    assert error.location.line == body.count("\n", 0, body.index("URB_")) + 2


def test_generated_modules_use_no_builtin_a_schema_may_shadow(generated: tuple[Path, Any]) -> None:
    """A message named `bool` replaced the builtin every bool field decodes with; each builtin a generated
    module names must be a name the checker refuses for module-level items."""
    import builtins
    import io
    import tokenize

    from urb_codegen.parser import _PY_MODULE_NAMES

    root, _ = generated
    modules = [p for p in (root / "py" / "user_msgs").glob("*.py") if not p.name.startswith("_")]
    modules += [p for p in (REPO / "gen" / "python" / "urb_msgs").glob("*.py") if not p.name.startswith("_")]
    used = {tok.string for p in modules for tok in tokenize.generate_tokens(io.StringIO(p.read_text()).readline)
            if tok.type == tokenize.NAME and tok.string in dir(builtins) and tok.string not in ("True", "False", "None")}
    assert used and used <= _PY_MODULE_NAMES, sorted(used - _PY_MODULE_NAMES)


def test_gen_removes_files_of_a_removed_schema(tmp_path: Path) -> None:
    schemas = tmp_path / "schema"
    shutil.copytree(REPO / "spec" / "schema", schemas)
    (schemas / "extra.urbs").write_text('schema extra "e"\nmessage X "x" {\n    a: u8 "a"\n}\n')
    c_dir, py_dir = tmp_path / "c", tmp_path / "py"
    generate(load(sorted(schemas.glob("*.urbs"))), c_dir, py_dir)
    assert (c_dir / "urb_extra.c").exists() and (py_dir / "extra.py").exists()
    (c_dir / "notes.h").write_text("/* mine, not generated */\n")
    (schemas / "extra.urbs").unlink()
    left = load(sorted(schemas.glob("*.urbs")))
    generate(left, c_dir, py_dir)
    assert not (c_dir / "urb_extra.c").exists() and not (c_dir / "urb_extra.h").exists()
    assert not (py_dir / "extra.py").exists()
    assert (c_dir / "notes.h").exists()  # not generated: kept, and reported by --check
    assert check_fresh(left, c_dir, py_dir).extra == [c_dir / "notes.h"]
