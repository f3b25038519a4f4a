"""What the generated decoders take and how they fail (issue #35), in Python and C alike.

* A decoder takes bytes, bytearray or memoryview; anything else (`decode(5)` decoded `bytes(5)`,
  a list decoded its items) is ArgumentError, a TypeError and not a DecodeError.
* The caller's mistakes are one error, ArgumentError, raised before the frame is read, as the C
  decoder returns URB_ERR_ARGUMENT before it looks at the frame: a missing implicit field, one of
  the wrong type or out of range, or one that breaks a rule over implicit members only.
  The wire's problems stay the DecodeError family, in the C decoder's order.
* The schema's rules (`require`) hold in both languages: a TIMEOUT response carrying data, a
  DownlinkWrite whose select has the read bit, a DownlinkReadSelect without it are out of range;
  a DownlinkReadResponse decoded with a write select is the caller's mistake.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import fastcrc
import pytest

import urb_msgs
from urb.codec_driver import CodecDriver, build_driver
from urb_msgs import (
    ArgumentError,
    ChecksumError,
    DecodeError,
    EncodeError,
    OutOfRangeError,
    TooLongError,
    TooShortError,
)
from urb_msgs.urb_core import (
    DownlinkReadResponse,
    DownlinkReadSelect,
    DownlinkWrite,
    MailboxSelect,
    Status,
    UplinkResponse,
)

REPO = Path(__file__).resolve().parents[1]
READ_1 = MailboxSelect(mailbox=1, read=True)
VALID_FOR_READ_1 = bytes.fromhex("e80324fae02e62")  # tests/vectors/core.json
C_NAMES = {TooShortError: "short", TooLongError: "long", ChecksumError: "checksum", OutOfRangeError: "range",
           ArgumentError: "argument"}


@pytest.fixture(scope="module")
def driver() -> Iterator[CodecDriver]:
    exe = build_driver(REPO / "gen" / "c", REPO / "build" / "c" / "codec_driver-contract")
    with CodecDriver(exe) as d:
        yield d


def _implicit(cls: type[urb_msgs.Message]) -> dict[str, Any]:
    return {"select": READ_1} if cls is DownlinkReadResponse else {}


@pytest.mark.parametrize("data", [5, 0, None, "1f89", [0x1F, 0x89], (0x1F,), 1.5, {0x1F}],
                         ids=["int", "zero", "None", "str", "list", "tuple", "float", "set"])
@pytest.mark.parametrize("name", sorted(urb_msgs.MESSAGES))
def test_decode_takes_only_bytes_like_frames(name: str, data: object) -> None:
    cls = urb_msgs.MESSAGES[name]
    with pytest.raises(ArgumentError, match="bytes, bytearray or memoryview") as info:
        cls.decode(data, **_implicit(cls))  # type: ignore[arg-type]
    assert isinstance(info.value, TypeError) and not isinstance(info.value, DecodeError)


@pytest.mark.parametrize("kind", [bytes, bytearray, memoryview])
def test_every_bytes_like_frame_decodes_alike(kind: type) -> None:
    frame = UplinkResponse(seq=5, status=Status.OK, data=bytes(range(10))).encode()
    assert UplinkResponse.decode(kind(frame)) == UplinkResponse.decode(frame)
    assert DownlinkReadResponse.decode(kind(VALID_FOR_READ_1), select=READ_1).data == VALID_FOR_READ_1[:-1]


MISSING = object()
BAD_SELECTS = {
    "missing": MISSING,
    "not a MailboxSelect": 3,
    "mailbox 9": MailboxSelect(mailbox=9, read=True),
    "read not a bool": MailboxSelect(mailbox=1, read=1),  # type: ignore[arg-type]
    "a write select": MailboxSelect(mailbox=1, read=False),
}
FRAMES = {"empty": b"", "one byte": b"\x00", "valid for mailbox 1": VALID_FOR_READ_1, "too long": bytes(40)}


@pytest.mark.parametrize("frame", FRAMES.values(), ids=FRAMES.keys())
@pytest.mark.parametrize("select", BAD_SELECTS.values(), ids=BAD_SELECTS.keys())
def test_a_bad_select_is_one_caller_error_whatever_the_frame(select: object, frame: bytes) -> None:
    """b"" gave TooShortError, b"\\x00" a TypeError, mailbox 9 an EncodeError; a write select decoded."""
    kwargs = {} if select is MISSING else {"select": select}
    with pytest.raises(ArgumentError, match="DownlinkReadResponse.decode") as info:
        DownlinkReadResponse.decode(frame, **kwargs)  # type: ignore[arg-type]
    assert not isinstance(info.value, (DecodeError, EncodeError))


@pytest.mark.parametrize("frame, error", [(b"", TooShortError), (b"\x00", ChecksumError), (bytes(40), TooLongError),
                                          (bytes.fromhex("0000"), ChecksumError)])
def test_with_a_valid_select_the_frame_s_problems_are_decode_errors(frame: bytes, error: type) -> None:
    with pytest.raises(error):
        DownlinkReadResponse.decode(frame, select=READ_1)


def _py_verdict(cls: type[urb_msgs.Message], frame: bytes, **kwargs: Any) -> str:
    try:
        cls.decode(frame, **kwargs)
    except (DecodeError, ArgumentError) as exc:
        return C_NAMES[type(exc)]
    return "ok"


def test_python_and_c_check_the_select_and_the_frame_in_the_same_order(driver: CodecDriver) -> None:
    """Every select byte without reserved bits (mailbox 0..7, read or write) with frames of every kind:
    the C decoder's verdict is Python's (argument before short, long and checksum)."""
    frames = [*FRAMES.values(), bytes.fromhex("e803b5"), bytes(16), bytes(15)]
    seen = set()
    for read in (False, True):
        for mailbox in range(8):
            select = MailboxSelect(mailbox=mailbox, read=read)
            for frame in frames:
                answer = driver.roundtrip("DownlinkReadResponse", frame, select.encode())
                python = _py_verdict(DownlinkReadResponse, frame, select=select)
                assert ("ok" if answer.ok else answer.error) == python, (select, frame.hex())
                seen.add(python)
    assert seen == {"argument", "short", "long", "checksum", "ok"}


def _with_crc8(body: bytes) -> bytes:
    return body + bytes([fastcrc.crc8.autosar(body)])


@pytest.mark.parametrize("status", [s for s in Status if s != Status.OK])
def test_only_a_successful_read_carries_data(driver: CodecDriver, status: Status) -> None:
    """core.urbs: data is present only for a successful read; both decoders accepted a TIMEOUT with data."""
    with pytest.raises(EncodeError, match=r"breaks the rule `require status == OK or len\(data\) == 0`"):
        UplinkResponse(seq=3, status=status, data=b"\x01").encode()
    assert UplinkResponse.decode(UplinkResponse(seq=3, status=status).encode()).status == status
    frame = _with_crc8(bytes([3 | status << 4, 0x01]))
    with pytest.raises(OutOfRangeError, match="Only a successful read carries data"):
        UplinkResponse.decode(frame)
    assert driver.roundtrip("UplinkResponse", frame).error == "range"
    ok = _with_crc8(bytes([3, 0x01]))
    assert UplinkResponse.decode(ok).data == b"\x01" and driver.roundtrip("UplinkResponse", ok).frame == ok


def test_the_read_bit_of_a_select_is_what_the_frame_says(driver: CodecDriver) -> None:
    """DownlinkWrite writes an inbox (read clear), DownlinkReadSelect selects an outbox (read set)."""
    with pytest.raises(EncodeError, match="require not select.read"):
        DownlinkWrite(select=MailboxSelect(mailbox=2, read=True), data=b"\x01").encode()
    with pytest.raises(EncodeError, match="require select.read"):
        DownlinkReadSelect(select=MailboxSelect(mailbox=2, read=False)).encode()
    with pytest.raises(EncodeError, match="require select.read"):
        DownlinkReadResponse(select=MailboxSelect(mailbox=2, read=False), data=b"\x01").encode()
    bad_write, bad_select = _with_crc8(bytes([0x82, 0x01])), bytes([0x02])
    for cls, frame in ((DownlinkWrite, bad_write), (DownlinkReadSelect, bad_select)):
        with pytest.raises(OutOfRangeError, match="breaks the rule"):
            cls.decode(frame)
        assert driver.roundtrip(cls.NAME, frame).error == "range"
    good_write, good_select = _with_crc8(bytes([0x02, 0x01])), bytes([0x82])
    assert DownlinkWrite.decode(good_write).encode() == good_write
    assert DownlinkReadSelect.decode(good_select).encode() == good_select


def test_rules_are_published_and_checked_by_broken_rule() -> None:
    assert UplinkResponse.RULES == ("status == OK or len(data) == 0",)
    assert DownlinkReadResponse.RULES == ("select.read",)
    assert UplinkResponse(status=Status.BUSY, data=b"x").broken_rule() is not None
    assert UplinkResponse(status=Status.OK, data=b"x").broken_rule() is None
    assert urb_msgs.MESSAGES["MotorCommand"].RULES == () and urb_msgs.MESSAGES["MotorCommand"]().broken_rule() is None
    assert "rule status == OK or len(data) == 0" in UplinkResponse.LAYOUT  # a rule changes the fingerprint
