"""spec/schema/README.md is the format's specification: its examples and tables hold for the codecs.

Every `wire` block line of the README is checked against the Python codecs (the reference) and the
C codecs (through the codec driver): `encode NAME JSON = HEX` must encode to HEX and decode back to
the same message; `reject NAME [JSON] HEX = ERROR` must be refused with ERROR (JSON: the implicit
fields the caller gives; HEX `-` is the empty frame). The table of impossible frame lengths (wire
rule 7) must list exactly the lengths no frame of each message has, and the CRC check values
must be what the tiers compute.
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

import urb_msgs
from urb.codec_driver import CodecDriver, build_driver
from urb.msgtools import from_plain, to_plain
from urb_codegen.generate import load_bundled
from urb_msgs import ArgumentError, ChecksumError, DecodeError, OutOfRangeError, TooLongError, TooShortError

REPO = Path(__file__).resolve().parents[1]
README = (REPO / "spec" / "schema" / "README.md").read_text(encoding="utf-8")
ERRORS = {"short": TooShortError, "long": TooLongError, "checksum": ChecksumError, "range": OutOfRangeError,
          "argument": ArgumentError}
MESSAGES = {m.name: m for s in load_bundled() for m in s.messages.values()}


def _wire_lines() -> list[str]:
    blocks = re.findall(r"^```wire\n(.*?)^```", README, re.S | re.M)
    return [line for block in blocks for line in block.splitlines() if line.strip()]


LINES = _wire_lines()
ENCODE = [line for line in LINES if line.startswith("encode ")]
REJECT = [line for line in LINES if line.startswith("reject ")]


@pytest.fixture(scope="module")
def driver() -> Iterator[CodecDriver]:
    exe = build_driver(REPO / "gen" / "c", REPO / "build" / "c" / "codec_driver-readme")
    with CodecDriver(exe) as d:
        yield d


def _hex(text: str) -> bytes:
    return b"" if text.strip() == "-" else bytes.fromhex(text)


def _prefix(name: str, implicit: dict[str, Any]) -> bytes | None:
    """The implicit prefix bytes the C driver takes (None for a message without implicit fields)."""
    m = MESSAGES[name]
    if not m.implicit_fields:
        return None
    proto = from_plain(urb_msgs.MESSAGES[name], implicit)
    return int(proto._pack_implicit()).to_bytes(m.implicit_size, "little")  # type: ignore[attr-defined]


def test_the_readme_has_every_kind_of_example() -> None:
    """Examples of every rule the README states: signed values, arrays, nested messages, both check
    tiers, an implicit prefix, and each kind of refusal."""
    names = {line.split()[1] for line in LINES}
    assert {"UplinkReadRequest", "MotorFeedback", "Identification", "BatteryStatus", "UplinkResponse",
            "DownlinkReadResponse"} <= names, names
    assert {line.rsplit("=", 1)[1].strip() for line in REJECT} == {"long", "range", "argument"}
    assert all(line.startswith(("encode ", "reject ")) for line in LINES), LINES


@pytest.mark.parametrize("line", ENCODE, ids=lambda line: line.split()[1] + ":" + line.rsplit("=", 1)[1].split()[0])
def test_encode_example(driver: CodecDriver, line: str) -> None:
    _, name, rest = line.split(" ", 2)
    fields_json, frame_hex = rest.rsplit("=", 1)
    fields = json.loads(fields_json)
    frame = _hex(frame_hex)
    cls = urb_msgs.MESSAGES[name]
    msg = from_plain(cls, fields)
    assert msg.encode() == frame, f"{name}: the codec gives {msg.encode().hex(' ')}"
    implicit = {f.name: getattr(msg, f.name) for f in MESSAGES[name].implicit_fields}
    assert to_plain(cls.decode(frame, **implicit)) == to_plain(msg)
    implicit_plain = {k: v for k, v in fields.items() if k in implicit}
    answer = driver.roundtrip(name, frame, _prefix(name, implicit_plain))
    assert answer.ok and answer.frame == frame, answer


@pytest.mark.parametrize("line", REJECT, ids=lambda line: line.split()[1] + ":" + line.rsplit("=", 1)[1].strip())
def test_reject_example(driver: CodecDriver, line: str) -> None:
    _, name, rest = line.split(" ", 2)
    body, error = rest.rsplit("=", 1)
    implicit_plain: dict[str, Any] = {}
    if body.lstrip().startswith("{"):
        decoder = json.JSONDecoder()
        implicit_plain, end = decoder.raw_decode(body.lstrip())
        body = body.lstrip()[end:]
    frame = _hex(body)
    cls = urb_msgs.MESSAGES[name]
    proto = from_plain(cls, implicit_plain) if implicit_plain else None
    kwargs = {k: getattr(proto, k) for k in implicit_plain}
    with pytest.raises(ERRORS[error.strip()]) as info:
        cls.decode(frame, **kwargs)
    assert error.strip() == "argument" or isinstance(info.value, DecodeError)
    answer = driver.roundtrip(name, frame, _prefix(name, implicit_plain))
    assert not answer.ok and answer.error == error.strip(), answer


def _impossible_table() -> dict[str, set[int]]:
    section = README[README.index("**7. Frame lengths.**"):README.index("**8. Decoding")]
    rows = re.findall(r"^\| `(\w+)` \| [^|]+ \| ([\d, ]+) \|", section, re.M)
    return {name: {int(n) for n in lengths.split(",")} for name, lengths in rows}


def test_impossible_frame_lengths_are_exactly_those_the_readme_lists() -> None:
    """Wire rule 7's table, against the model: every length between the shortest and the longest
    frame that no payload length gives, for every message whose length varies."""
    listed = _impossible_table()
    actual: dict[str, set[int]] = {}
    for m in MESSAGES.values():
        if m.min_size == m.max_size:
            continue
        possible = {m.wire_size(p) for p in range(m.max_payload + 1)}
        actual[m.name] = {n for n in range(m.min_size, m.max_size + 1) if n not in possible}
    assert listed == actual


@pytest.mark.parametrize("length", [16])
def test_the_listed_lengths_are_refused_as_too_long(length: int) -> None:
    for name in ("UplinkResponse", "DownlinkWrite"):
        with pytest.raises(TooLongError):
            urb_msgs.MESSAGES[name].decode(bytes(length))


def test_crc_check_values_and_bit_order_as_the_readme_states() -> None:
    """`123456789` gives 0xDF (CRC-8/AUTOSAR) and 0x29B1 (CRC-16/CCITT-FALSE), computed here with the
    README's pseudo-code from the tier parameters of the schema."""
    tiers = {t.name: t for t in MESSAGES["UplinkResponse"].checksum.tiers}  # type: ignore[union-attr]

    def crc(width: int, poly: int, init: int, xorout: int, data: bytes) -> int:
        reg = init
        for b in data:
            reg ^= b << (width - 8)
            for _ in range(8):
                reg = ((reg << 1) ^ poly) & ((1 << width) - 1) if reg >> (width - 1) & 1 else (reg << 1) & ((1 << width) - 1)
        return reg ^ xorout

    for name, value in (("crc8", 0xDF), ("crc16", 0x29B1)):
        t = tiers[name]
        assert crc(t.width, t.poly, t.init, t.xorout, b"123456789") == value
        assert f"give{'s' if name == 'crc16' else ''} 0x{value:X}" in README
