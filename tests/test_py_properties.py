"""Property tests of the generated Python codecs (hypothesis)."""

from __future__ import annotations

import random
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import urb_msgs
from urb.msgtools import random_message
from urb_msgs import DecodeError, Message
from urb_msgs.urb_core import DownlinkReadResponse, MailboxSelect

ALL = sorted(urb_msgs.MESSAGES)
CHECKED = [n for n in ALL if " check " in urb_msgs.MESSAGES[n].LAYOUT]


def _decode(cls: type[Message], data: bytes, like: Message | None = None) -> Message:
    if cls is DownlinkReadResponse:
        select = like.select if isinstance(like, DownlinkReadResponse) else MailboxSelect(mailbox=1, read=True)
        return DownlinkReadResponse.decode(data, select=select)
    return cls.decode(data)


messages = st.sampled_from(ALL).flatmap(
    lambda name: st.randoms(use_true_random=False).map(lambda rng: random_message(urb_msgs.MESSAGES[name], rng))
)


@settings(max_examples=600, suppress_health_check=[HealthCheck.too_slow])
@given(messages)
def test_valid_messages_round_trip(msg: Message) -> None:
    frame = msg.encode()
    assert msg.MIN_SIZE <= len(frame) <= msg.MAX_SIZE
    assert _decode(type(msg), frame, msg) == msg


# lobster-trace: urb.PKT_002
@settings(max_examples=1500)
@given(st.sampled_from(ALL), st.binary(max_size=40))
def test_random_bytes_decode_cleanly_or_canonically(name: str, data: bytes) -> None:
    """Any byte string gives a DecodeError or a message that encodes back to the same bytes."""
    cls = urb_msgs.MESSAGES[name]
    try:
        msg = _decode(cls, data)
    except DecodeError:
        return
    assert msg.encode() == data


@settings(max_examples=400, suppress_health_check=[HealthCheck.too_slow])  # random_message redraws for the rules
@given(st.sampled_from(CHECKED).flatmap(
    lambda name: st.tuples(st.randoms(use_true_random=False).map(lambda r: random_message(urb_msgs.MESSAGES[name], r)),
                           st.lists(st.integers(min_value=0, max_value=10_000), min_size=1, max_size=3, unique=True))))
# lobster-trace: urb.CRC_001
def test_checked_frames_reject_one_to_three_bit_errors(case: tuple[Message, list[int]]) -> None:
    """link_check keeps Hamming distance 4 for every length it is used at (see spec/schema/README.md)."""
    msg, positions = case
    frame = bytearray(msg.encode())
    bits = {p % (8 * len(frame)) for p in positions}
    for bit in bits:
        frame[bit // 8] ^= 1 << (bit % 8)
    with pytest.raises(DecodeError):
        _decode(type(msg), bytes(frame), msg)


# lobster-trace: urb.CRC_001
@pytest.mark.parametrize("name", CHECKED)
def test_every_single_bit_flip_is_detected(name: str) -> None:
    rng = random.Random(name)
    for _ in range(20):
        msg = random_message(urb_msgs.MESSAGES[name], rng)
        frame = msg.encode()
        for bit in range(8 * len(frame)):
            corrupt = bytearray(frame)
            corrupt[bit // 8] ^= 1 << (bit % 8)
            with pytest.raises(DecodeError):
                _decode(type(msg), bytes(corrupt), msg)


def test_encode_rejects_out_of_range_values_with_the_field_name() -> None:
    from urb_msgs import EncodeError
    from urb_msgs.sensorhex import BatteryPack, MotorCommand
    with pytest.raises(EncodeError, match=r"MotorCommand.voltage = 40000 is outside -32768..32767"):
        MotorCommand(voltage=40000).encode()
    with pytest.raises(EncodeError, match=r"BatteryPack.charge = 101 is outside 0..100"):
        BatteryPack(charge=101).encode()
    with pytest.raises(EncodeError, match=r"must be an integer"):
        MotorCommand(voltage=1.5).encode()  # type: ignore[arg-type]


def test_engineering_units_follow_scale_and_offset() -> None:
    from urb_msgs.sensorhex import MotorFeedback
    fb = MotorFeedback(encoder=10, current=-1500, voltage=12000)
    assert fb.engineering() == {"encoder": 10, "current": -1.5, "voltage": 12.0}
    assert MotorFeedback.raw_from_engineering("current", -1.5) == -1500
    with pytest.raises(urb_msgs.EncodeError, match="outside"):
        MotorFeedback.raw_from_engineering("current", 40.0)


def test_bits_no_field_claims_must_be_zero(tmp_path: Path) -> None:
    """Explicit positions can leave gaps; the decoder treats them as padding, as the C decoder does."""
    import importlib
    import sys

    from urb_codegen.emit_py import emit_python
    from urb_codegen.parser import load

    schema = tmp_path / "gaps.urbs"
    schema.write_text('schema gaps "g"\nmessage G "g" {\n    a: u4 @ 0 "a"\n    b: u2 @ 6 "b"\n}\n')
    pkg = tmp_path / "gaps_pkg"
    emit_python(load([schema]), pkg)
    sys.path.insert(0, str(tmp_path))
    try:
        mod = importlib.import_module("gaps_pkg.gaps")
        assert mod.G.decode(bytes([0x43])) == mod.G(a=3, b=1)
        with pytest.raises(mod.OutOfRangeError, match="no field claims"):
            mod.G.decode(bytes([0x10]))
    finally:
        sys.path.remove(str(tmp_path))
