"""Hypothesis drives the generated C codecs through the codec driver: Python -> C -> Python."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import urb_msgs
from urb.codec_driver import CodecDriver, build_driver
from urb.msgtools import random_message
from urb_msgs import DecodeError, Message
from urb_msgs.urb_core import DownlinkReadResponse, MailboxSelect

REPO = Path(__file__).resolve().parents[1]
NAMES = sorted(urb_msgs.MESSAGES)
ERRORS = {urb_msgs.TooShortError: "short", urb_msgs.TooLongError: "long",
          urb_msgs.ChecksumError: "checksum", urb_msgs.OutOfRangeError: "range"}
SELECT = MailboxSelect(mailbox=1, read=True)


@pytest.fixture(scope="module")
def driver() -> Iterator[CodecDriver]:
    exe = build_driver(REPO / "gen" / "c", REPO / "build" / "c" / "codec_driver-hypothesis")
    with CodecDriver(exe) as d:
        yield d


def _prefix(msg: Message | None, name: str) -> bytes | None:
    if name != "DownlinkReadResponse":
        return None
    select = msg.select if isinstance(msg, DownlinkReadResponse) else SELECT
    return select.encode()


def _py_decode(name: str, frame: bytes, msg: Message | None = None) -> Message:
    cls = urb_msgs.MESSAGES[name]
    if cls is DownlinkReadResponse:
        select = msg.select if isinstance(msg, DownlinkReadResponse) else SELECT
        return DownlinkReadResponse.decode(frame, select=select)
    return cls.decode(frame)


messages = st.sampled_from(NAMES).flatmap(
    lambda name: st.randoms(use_true_random=False).map(lambda rng: random_message(urb_msgs.MESSAGES[name], rng)))


@settings(max_examples=800, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(msg=messages)
def test_python_c_python_round_trip_is_identical(driver: CodecDriver, msg: Message) -> None:
    frame = msg.encode()
    answer = driver.roundtrip(msg.NAME, frame, _prefix(msg, msg.NAME))
    assert answer.ok, answer.error
    assert answer.frame == frame
    assert _py_decode(msg.NAME, answer.frame, msg) == msg


# lobster-trace: urb.PKT_002
@settings(max_examples=1500, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(name=st.sampled_from(NAMES), data=st.binary(max_size=40))
def test_c_and_python_agree_on_any_bytes(driver: CodecDriver, name: str, data: bytes) -> None:
    answer = driver.roundtrip(name, data, _prefix(None, name))
    try:
        _py_decode(name, data)
    except DecodeError as exc:
        assert not answer.ok and answer.error == ERRORS[type(exc)]
    else:
        assert answer.ok and answer.frame == data
