"""Hand-derived reference vectors against the generated Python codecs."""

from __future__ import annotations

from typing import Any

import fastcrc
import pytest

import urb_msgs
from urb.msgtools import from_plain, to_plain
from urb_msgs import ArgumentError, ChecksumError, OutOfRangeError, TooLongError, TooShortError

from tests.conftest import load_vectors

VALID = load_vectors("valid")
ERRORS = load_vectors("error")
ERROR_CLASSES = {"short": TooShortError, "long": TooLongError, "checksum": ChecksumError, "range": OutOfRangeError,
                 "argument": ArgumentError}


def _implicit(v: dict[str, Any]) -> dict[str, Any]:
    cls = urb_msgs.MESSAGES[v["message"]]
    if "implicit" not in v:
        return {}
    proto = from_plain(cls, v["implicit"])
    return {k: getattr(proto, k) for k in v["implicit"]}


def _ident(v: dict[str, Any]) -> str:
    return f"{v['message']}:{v['hex'][:16]}"


def test_every_message_has_a_vector() -> None:
    covered = {v["message"] for v in VALID}
    missing = {name for name, cls in urb_msgs.MESSAGES.items() if cls.FIELDS} - covered
    allowed_without = {"BridgeInfo", "BridgeScan", "BridgeCommand", "DownlinkWrite", "DownlinkReadSelect", "BatteryPack"}
    assert missing <= allowed_without, f"messages without a reference vector: {sorted(missing - allowed_without)}"


# lobster-trace: urb.PKT_001
@pytest.mark.parametrize("v", VALID, ids=_ident)
def test_encode_matches_vector(v: dict[str, Any]) -> None:
    cls = urb_msgs.MESSAGES[v["message"]]
    msg = from_plain(cls, {**v["fields"], **v.get("implicit", {})})
    assert msg.encode().hex() == v["hex"]


# lobster-trace: urb.PKT_001
@pytest.mark.parametrize("v", VALID, ids=_ident)
def test_decode_matches_vector(v: dict[str, Any]) -> None:
    cls = urb_msgs.MESSAGES[v["message"]]
    msg = cls.decode(bytes.fromhex(v["hex"]), **_implicit(v))
    plain = to_plain(msg)
    for key, value in v["fields"].items():
        assert plain[key] == value, key


# lobster-trace: urb.PKT_002
@pytest.mark.parametrize("v", ERRORS, ids=_ident)
def test_error_vectors_raise_the_precise_error(v: dict[str, Any]) -> None:
    cls = urb_msgs.MESSAGES[v["message"]]
    with pytest.raises(ERROR_CLASSES[v["error"]]):
        cls.decode(bytes.fromhex(v["hex"]), **_implicit(v))


CHECKED = [v for v in VALID if " check " in urb_msgs.MESSAGES[v["message"]].LAYOUT]


def test_vectors_cover_checked_frames() -> None:
    assert len(CHECKED) >= 6


# lobster-trace: urb.CRC_002
@pytest.mark.parametrize("v", CHECKED, ids=_ident)
def test_vector_check_bytes_agree_with_an_independent_crc(v: dict[str, Any]) -> None:
    """Guards the vector files: recompute each check with fastcrc (a separate implementation)."""
    frame = bytes.fromhex(v["hex"])
    prefix = b""
    if "implicit" in v:
        sel = v["implicit"]["select"]
        prefix = bytes([sel["mailbox"] | (0x80 if sel["read"] else 0)])
    for width in (1, 2):
        covered = prefix + frame[:-width]
        if (width == 1) == (len(covered) <= 14):
            break
    if width == 1:
        assert frame[-1] == fastcrc.crc8.autosar(covered)
    else:
        assert int.from_bytes(frame[-2:], "little") == fastcrc.crc16.ibm_3740(covered)
