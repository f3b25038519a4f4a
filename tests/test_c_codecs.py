"""The generated C codecs (gen/c), driven through tests/c/codec_driver.c.

The driver and the C unit tests are built (by mk/c.mk) with gcc and with clang, both under
AddressSanitizer and UndefinedBehaviorSanitizer, so any out-of-bounds access, overflow or other
undefined behaviour aborts the driver and fails the test that sent the command. Checked here:
CRC check values, the hand-derived reference vectors (tests/vectors), random and mutated frames
decoded by C and by the Python codecs (urb_msgs) with identical outcomes, canonical round trips
(a frame C accepts encodes back to the same bytes), output capacity handling, and the C unit tests.
The driver's protocol is documented at the top of tests/c/codec_driver.c.
"""

from __future__ import annotations

import json
import os
import random
import subprocess
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import fastcrc
import pytest

import urb_msgs
from urb.msgtools import from_plain, random_message, to_plain
from urb_codegen.generate import load_bundled
from urb_codegen.model import ArrayType, BytesType, CheckType, CrcTier, EnumDecl, Field, IntType, MessageDecl

from tests.conftest import load_vectors

REPO = Path(__file__).resolve().parents[1]
GEN = REPO / "gen" / "c"
# `make coverage` (tools/coverage.py) runs this file on its instrumented builds of the same programs:
# URB_CODEC_PROGRAMS lists the directories that hold them (os.pathsep between; already built, nothing
# is rebuilt) and URB_CODEC_COMPILERS the compilers they are named after (<program>-<compiler>).
COMPILERS = os.environ.get("URB_CODEC_COMPILERS", "gcc clang").split()
PREBUILT = [Path(d).resolve() for d in os.environ.get("URB_CODEC_PROGRAMS", "").split(os.pathsep) if d]
SEED = 20261121
CASES_PER_MESSAGE = 900  # random and mutated frames per message and compiler

MESSAGES: dict[str, MessageDecl] = {m.name: m for s in load_bundled() for m in s.messages.values()}
PY_ERRORS = {
    urb_msgs.TooShortError: "short",
    urb_msgs.TooLongError: "long",
    urb_msgs.ChecksumError: "checksum",
    urb_msgs.OutOfRangeError: "range",
}


# --- building and talking to the driver --------------------------------------------------------


def _build(program: str, cc: str) -> Path:
    """build/c/<program>-<cc>, made by mk/c.mk (the one place that knows the flags)."""
    if PREBUILT:
        found = [d / f"{program}-{cc}" for d in PREBUILT if (d / f"{program}-{cc}").is_file()]
        if not found:
            pytest.fail(f"URB_CODEC_PROGRAMS: no {program}-{cc} in {', '.join(map(str, PREBUILT))}; "
                        "build it first (make coverage-build)")
        return found[0]
    target = f"build/c/{program}-{cc}"
    done = subprocess.run(["make", "-s", "--no-print-directory", "-f", "mk/c.mk", target],
                          cwd=REPO, capture_output=True, text=True)
    if done.returncode != 0:
        pytest.fail(f"make {target} failed:\n{done.stdout}{done.stderr}")
    return REPO / target


class Driver:
    """A running codec_driver: send command lines, get answer lines; a crash fails the test."""

    def __init__(self, exe: Path) -> None:
        self.exe = exe
        self.stderr = tempfile.TemporaryFile(mode="w+")
        env = {**os.environ, "ASAN_OPTIONS": "detect_leaks=1:abort_on_error=0", "UBSAN_OPTIONS": "print_stacktrace=1"}
        self.proc = subprocess.Popen([str(exe)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=self.stderr, text=True, env=env)

    def batch(self, lines: list[str]) -> list[str]:
        """Answers to `lines`, in order (a writer thread keeps the pipes from filling up)."""
        assert self.proc.stdin is not None and self.proc.stdout is not None
        stdin = self.proc.stdin

        def write() -> None:
            try:
                for line in lines:
                    stdin.write(line + "\n")
                stdin.flush()
            except BrokenPipeError:
                pass  # the driver died; the reader reports it

        writer = threading.Thread(target=write)
        writer.start()
        answers = []
        for line in lines:
            answer = self.proc.stdout.readline()
            if not answer:
                writer.join()
                self.proc.wait()
                self.stderr.seek(0)
                pytest.fail(f"{self.exe.name} crashed (exit {self.proc.returncode}) on: {line}\n{self.stderr.read()[-6000:]}")
            answers.append(answer.rstrip("\n"))
        writer.join()
        return answers

    def ask(self, line: str) -> str:
        return self.batch([line])[0]

    def close(self) -> int:
        assert self.proc.stdin is not None
        self.proc.stdin.close()
        rc = self.proc.wait(timeout=30)
        self.stderr.seek(0)
        assert rc == 0, f"{self.exe.name} exited with {rc} (leak or sanitizer report):\n{self.stderr.read()[-6000:]}"
        return rc


@pytest.fixture(scope="session", params=COMPILERS)
def driver(request: pytest.FixtureRequest) -> Iterator[Driver]:
    d = Driver(_build("codec_driver", request.param))
    yield d
    d.close()


# --- an independent model of the wire format, just enough for the tests -----------------------


def crc(tier: CrcTier, data: bytes) -> int:
    """MSB-first CRC straight from the tier parameters (checked against fastcrc below)."""
    top, mask = 1 << (tier.width - 1), (1 << tier.width) - 1
    value = tier.init
    for b in data:
        value ^= b << (tier.width - 8)
        for _ in range(8):
            value = ((value << 1) ^ tier.poly) if value & top else value << 1
            value &= mask
    return value ^ tier.xorout


def with_check(m: MessageDecl, body: bytes, prefix: bytes) -> bytes:
    """`body` followed by the check the schema requires for it (the implicit prefix is covered)."""
    cs = m.checksum
    if cs is None:
        return body
    tier = cs.tier_for(len(prefix) + len(body))
    return body + crc(tier, prefix + body).to_bytes(tier.width // 8, "little")


def check_width_of_frame(m: MessageDecl, n: int) -> int | None:
    """Check bytes of a well-formed frame of `n` bytes (None: no payload length gives n bytes)."""
    return next((m.check_width(p) for p in range(m.max_payload + 1) if m.wire_size(p) == n), None)


def pack(fields: list[Field], plain: dict[str, Any]) -> int:
    """Fields (values as in JSON) as one integer, LSB-first: used for implicit prefixes."""
    out = 0
    for f in fields:
        if f.is_padding or isinstance(f.type, (BytesType, CheckType)):
            continue
        value = f.fixed if f.fixed is not None else plain[f.name]
        out |= _pack_value(f.type, value, f.bit_width) << f.bit_offset
    return out


def _pack_value(t: object, value: Any, width: int) -> int:
    if isinstance(t, MessageDecl):
        return pack(t.fields, value)
    if isinstance(t, ArrayType):
        step = width // t.count
        return sum(_pack_value(t.element, v, step) << (i * step) for i, v in enumerate(value))
    assert isinstance(t, (IntType, EnumDecl))
    return int(value) & ((1 << width) - 1)


def implicit_prefix(m: MessageDecl, implicit: dict[str, Any]) -> bytes:
    return pack(m.implicit_fields, implicit).to_bytes(m.implicit_size, "little")


def count_fields(m: MessageDecl) -> set[str]:
    """Length fields of counted payloads: C members, derived from the payload in Python."""
    bf = m.bytes_field
    return {bf.type.count_field} if bf is not None and isinstance(bf.type, BytesType) and bf.type.count_field else set()


# --- commands and oracles ----------------------------------------------------------------------


def _hex(data: bytes) -> str:
    return data.hex() or "-"


def decode_command(m: MessageDecl, frame: bytes, prefix: bytes = b"") -> str:
    if m.implicit_fields:
        return f"I {m.name} {_hex(prefix)} {_hex(frame)}"
    return f"D {m.name} {_hex(frame)}"


def parse_answer(answer: str) -> tuple[str, str | None, Any]:
    """("OK", hex, json) or ("short" | "long" | ..., None, None)."""
    parts = answer.split(" ", 2)
    if parts[0] == "ERR" and len(parts) == 2:
        return parts[1], None, None
    assert parts[0] == "OK" and len(parts) == 3, answer
    return "OK", parts[1], json.loads(parts[2])


def python_decode(m: MessageDecl, frame: bytes, implicit: dict[str, Any]) -> tuple[str, Any]:
    cls = urb_msgs.MESSAGES[m.name]
    kwargs = {}
    if implicit:
        proto = from_plain(cls, implicit)
        kwargs = {k: getattr(proto, k) for k in implicit}
    try:
        msg = cls.decode(frame, **kwargs)
    except urb_msgs.DecodeError as exc:
        return PY_ERRORS[type(exc)], None
    return "OK", to_plain(msg)


def random_implicit(m: MessageDecl, rng: random.Random) -> dict[str, Any]:
    if not m.implicit_fields:
        return {}
    plain = to_plain(random_message(urb_msgs.MESSAGES[m.name], rng))
    return {f.name: plain[f.name] for f in m.implicit_fields}


# --- tests -------------------------------------------------------------------------------------


# lobster-trace: urb.CRC_002
def test_crc_check_values(driver: Driver) -> None:
    """CRC-8/AUTOSAR and CRC-16/CCITT-FALSE check values; the driver also compares byte-wise and buffer CRCs."""
    assert driver.ask("K crc8_link_check " + b"123456789".hex()) == "OK df"
    assert driver.ask("K crc16_link_check " + b"123456789".hex()) == "OK 29b1"
    rng = random.Random(SEED)
    samples = [bytes(rng.randrange(256) for _ in range(rng.randrange(40))) for _ in range(200)]
    answers = driver.batch([f"K {name} {_hex(s)}" for s in samples for name in ("crc8_link_check", "crc16_link_check")])
    expected = [f"OK {v:0{w}x}" for s in samples for v, w in ((fastcrc.crc8.autosar(s), 2), (fastcrc.crc16.ibm_3740(s), 4))]
    assert answers == expected


# lobster-trace: urb.CRC_002
def test_python_crc_model_agrees_with_fastcrc() -> None:
    tiers = {t.name: t for t in MESSAGES["UplinkResponse"].checksum.tiers}  # type: ignore[union-attr]
    assert crc(tiers["crc8"], b"123456789") == 0xDF == fastcrc.crc8.autosar(b"123456789")
    assert crc(tiers["crc16"], b"123456789") == 0x29B1 == fastcrc.crc16.ibm_3740(b"123456789")


def test_driver_knows_every_message(driver: Driver) -> None:
    assert set(driver.ask("L").split()[1:]) == set(MESSAGES)


def _vector_id(v: dict[str, Any]) -> str:
    return f"{v['message']}:{v['hex'][:16]}" + (f":{v['error']}" if "error" in v else "")


@pytest.mark.parametrize("v", load_vectors("valid"), ids=_vector_id)
def test_valid_vector(driver: Driver, v: dict[str, Any]) -> None:
    m = MESSAGES[v["message"]]
    implicit = v.get("implicit", {})
    status, frame, decoded = parse_answer(driver.ask(decode_command(m, bytes.fromhex(v["hex"]), implicit_prefix(m, implicit))))
    assert status == "OK"
    assert frame == v["hex"]
    for key, value in {**v["fields"], **implicit}.items():
        assert decoded[key] == value, key
    for name in count_fields(m):
        assert decoded[name] * 2 == len(decoded[m.bytes_field.name])  # type: ignore[union-attr]


@pytest.mark.parametrize("v", load_vectors("error"), ids=_vector_id)
def test_error_vector(driver: Driver, v: dict[str, Any]) -> None:
    m = MESSAGES[v["message"]]
    prefix = implicit_prefix(m, v.get("implicit", {}))
    assert driver.ask(decode_command(m, bytes.fromhex(v["hex"]), prefix)) == f"ERR {v['error']}"


def _random_cases(m: MessageDecl, rng: random.Random) -> Iterator[tuple[bytes, dict[str, Any]]]:
    """Frames with their implicit values: raw noise, noise with a valid check, valid frames, and
    valid frames with flipped bits and a repaired check (so decoding gets past the checksum)."""
    cls = urb_msgs.MESSAGES[m.name]
    count = count_fields(m)
    for i in range(CASES_PER_MESSAGE):
        implicit = random_implicit(m, rng)
        prefix = implicit_prefix(m, implicit)
        kind = i % 4
        if kind == 0:
            frame = bytes(rng.randrange(256) for _ in range(rng.randrange(m.max_size + 3)))
        elif kind == 1:
            payload = rng.randrange(m.max_payload + 1)
            body = bytearray(rng.randrange(256) for _ in range(m.fixed_size + payload))
            if count and rng.random() < 0.7:  # make the length field agree most of the time
                (name,) = count
                f = next(f for f in m.fields if f.name == name)
                value = int.from_bytes(body[: m.fixed_size], "little") & ~(((1 << f.bit_width) - 1) << f.bit_offset)
                body[: m.fixed_size] = (value | payload << f.bit_offset).to_bytes(m.fixed_size, "little")
            frame = with_check(m, bytes(body), prefix)
        else:
            proto = random_message(cls, rng)
            for name in implicit:
                setattr(proto, name, getattr(from_plain(cls, implicit), name))
            frame = proto.encode()
            if kind == 3:
                width = check_width_of_frame(m, len(frame)) or 0
                body = bytearray(frame[: len(frame) - width])
                if body:
                    for _ in range(rng.choice([1, 1, 2, 3])):
                        body[rng.randrange(len(body))] ^= 1 << rng.randrange(8)
                frame = with_check(m, bytes(body), prefix)
        yield frame, implicit


# lobster-trace: urb.MEM_001, urb.PKT_004
@pytest.mark.parametrize("name", sorted(MESSAGES))
def test_random_frames_decode_like_python(driver: Driver, name: str) -> None:
    """Never crashes; same verdict as the Python codec; an accepted frame re-encodes to itself."""
    m = MESSAGES[name]
    rng = random.Random(f"{SEED}:{name}")
    cases = list(_random_cases(m, rng))
    answers = driver.batch([decode_command(m, frame, implicit_prefix(m, implicit)) for frame, implicit in cases])
    verdicts: dict[str, int] = {}
    for (frame, implicit), answer in zip(cases, answers):
        status, encoded, decoded = parse_answer(answer)
        py_status, py_plain = python_decode(m, frame, implicit)
        assert status == py_status, f"{name} {frame.hex()}: C says {status}, Python says {py_status}"
        verdicts[status] = verdicts.get(status, 0) + 1
        if status == "OK":
            assert encoded == _hex(frame), f"{name}: accepted {frame.hex()} but re-encodes to {encoded}"
            assert {k: v for k, v in decoded.items() if k not in count_fields(m)} == py_plain
    assert verdicts.get("OK", 0) > CASES_PER_MESSAGE // 5, verdicts  # the valid cases really got through
    if any(f.is_padding or f.fixed is not None or f.range or isinstance(f.type, EnumDecl) for f in m.fields):
        assert verdicts.get("range", 0) > 0, verdicts  # and the mutations reached the range checks


# lobster-trace: urb.PKT_004
@pytest.mark.parametrize("name", sorted(MESSAGES))
def test_encode_respects_capacity(driver: Driver, name: str) -> None:
    """Every capacity below the frame size is URB_ERR_CAPACITY with the buffer untouched (the
    driver checks canaries and the buffer); the exact size and more succeed."""
    m = MESSAGES[name]
    rng = random.Random(f"{SEED}:capacity:{name}")
    cls = urb_msgs.MESSAGES[name]
    lines, expected = [], []
    for _ in range(4):
        implicit = random_implicit(m, rng)
        proto = random_message(cls, rng)
        for key in implicit:
            setattr(proto, key, getattr(from_plain(cls, implicit), key))
        frame = proto.encode()
        prefix = _hex(implicit_prefix(m, implicit))
        for capacity in [*range(len(frame)), len(frame), len(frame) + 7]:
            lines.append(f"C {name} {capacity} {prefix} {frame.hex()}")
            expected.append("ERR capacity" if capacity < len(frame) else f"OK {frame.hex()}")
    assert driver.batch(lines) == expected


@pytest.mark.parametrize("cc", COMPILERS)
def test_c_unit_tests(cc: str) -> None:
    exe = _build("unit_tests", cc)
    done = subprocess.run([str(exe)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stdout + done.stderr


def test_emitter_is_deterministic(tmp_path: Path) -> None:
    from urb_codegen.emit_c import emit_c

    first = {p.relative_to(tmp_path / "a"): p.read_bytes() for p in emit_c(load_bundled(), tmp_path / "a")}
    second = {p.relative_to(tmp_path / "b"): p.read_bytes() for p in emit_c(load_bundled(), tmp_path / "b")}
    assert first == second
    assert first == {p: (GEN / p).read_bytes() for p in first}  # and gen/c is what it emits


def test_emitter_rejects_clashing_c_names(tmp_path: Path) -> None:
    from urb_codegen.emit_c import emit_c
    from urb_codegen.errors import SchemaError
    from urb_codegen.parser import load

    schema = tmp_path / "clash.urbs"
    schema.write_text('schema clash "c"\n'
                      'enum Foo : u8 "e" { BAR_SIZE = 0 "m" }\n'
                      'message FooBar "m" { x: u8 "x" }\n')
    with pytest.raises(SchemaError, match="URB_FOO_BAR_SIZE"):
        emit_c(load([schema]), tmp_path / "out")
