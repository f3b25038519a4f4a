"""The accelerated codecs (urb_msgs._accel, the generated C codecs of gen/c) against the pure-Python
ones, the reference: byte-identical frames, equal messages of the same types, and the same
exception class and message on every refused message, frame and call (hypothesis, every message).

`make test-py` builds the extension first (`make accel`); a test process that runs the pure codecs
fails here with the reason instead of comparing the reference with itself.
"""

from __future__ import annotations

import dataclasses
import enum
import os
import random
import subprocess
import sys
from collections.abc import Callable
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import urb_msgs
from urb.msgtools import random_message
from urb_msgs import Message, _codec
from urb_msgs.urb_core import DownlinkReadResponse, MailboxSelect, Status, UplinkResponse

ALL = sorted(urb_msgs.MESSAGES)
CLASSES = [urb_msgs.MESSAGES[n] for n in ALL]


@pytest.fixture(scope="module", autouse=True)
def accelerated() -> None:
    if _codec.BACKEND != "accelerated":
        pytest.fail(f"urb_msgs runs the pure-Python codecs ({_codec.REASON}): build urb_msgs._accel with "
                    "`make accel` (make test-py does) and do not set URB_PURE_PYTHON")


# ---- comparing outcomes ------------------------------------------------------------------------


def shape(value: Any) -> Any:
    """`value` with the type of every part spelled out: 1 and True, bytes and bytearray, an enum
    member and its int, a list and a tuple all differ."""
    if isinstance(value, Message):
        return (type(value), tuple((f.name, shape(getattr(value, f.name))) for f in value.FIELDS))
    if isinstance(value, (list, tuple)):
        return (type(value), tuple(shape(v) for v in value))
    if isinstance(value, enum.Enum):
        return (type(value), value.name)
    return (type(value), value)


def outcome(call: Callable[[], Any]) -> tuple[Any, ...]:
    try:
        return ("returned", shape(call()))
    except Exception as exc:  # noqa: BLE001 - the exception is what is compared
        return ("raised", type(exc), str(exc))


def assert_same(accelerated: Callable[[], Any], pure: Callable[[], Any]) -> tuple[Any, ...]:
    got, want = outcome(accelerated), outcome(pure)
    assert got == want, f"accelerated {got}\n       pure {want}"
    return got


def assert_same_encode(msg: Message) -> tuple[Any, ...]:
    return assert_same(msg.encode, lambda: _codec.pure_encode(msg))


def assert_same_decode(cls: type[Message], data: Any, **implicit: Any) -> tuple[Any, ...]:
    return assert_same(lambda: cls.decode(data, **implicit), lambda: _codec.pure_decode(cls, data, **implicit))


def implicit_for(cls: type[Message], like: Message | None) -> dict[str, Any]:
    if cls is DownlinkReadResponse:
        return {"select": like.select if isinstance(like, DownlinkReadResponse) else MailboxSelect(mailbox=1, read=True)}
    return {}


# ---- strategies --------------------------------------------------------------------------------

valid = st.sampled_from(CLASSES).flatmap(
    lambda cls: st.randoms(use_true_random=False).map(lambda rng: random_message(cls, rng)))


class Wide(int):
    """An int subclass: the pure codec takes it, the fast path hands it over."""


class OtherEnum(enum.IntEnum):
    ZERO = 0
    ONE = 1


def _other_message(rng: random.Random) -> Message:
    return random_message(rng.choice(CLASSES), rng)


scalars = st.one_of(
    st.integers(min_value=-3, max_value=300),
    st.sampled_from([-1, 0, 1, 2**7, 2**8, 2**15, 2**16, 2**31, -2**31 - 1, 2**32, 2**63, -2**63 - 1, 2**70]),
    st.booleans(), st.none(), st.floats(allow_nan=False), st.text(max_size=3),
    st.builds(Wide, st.integers(min_value=0, max_value=20)),
    st.sampled_from(list(Status) + list(OtherEnum)),
    st.binary(max_size=40), st.binary(max_size=40).map(bytearray), st.binary(max_size=40).map(lambda b: memoryview(b)),
    st.randoms(use_true_random=False).map(_other_message),
)
wild = st.recursive(scalars, lambda inner: st.one_of(st.lists(inner, max_size=9), st.lists(inner, max_size=9).map(tuple)),
                    max_leaves=12)


def _mutable_paths(msg: Message, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Every place a value can be swapped: each field, each array element, each nested field."""
    out: list[tuple[Any, ...]] = []
    for f in msg.FIELDS:
        value = getattr(msg, f.name)
        out.append((*prefix, f.name))
        if isinstance(value, Message):
            out += _mutable_paths(value, (*prefix, f.name))
        elif isinstance(value, list):
            for i, item in enumerate(value):
                out.append((*prefix, f.name, i))
                if isinstance(item, Message):
                    out += _mutable_paths(item, (*prefix, f.name, i))
    return out


def _set(msg: Any, path: tuple[Any, ...], value: Any) -> None:
    *walk, last = path
    target = msg
    for step in walk:
        target = target[step] if isinstance(step, int) else getattr(target, step)
    if isinstance(last, int):
        target[last] = value
    else:
        setattr(target, last, value)


@st.composite
def broken(draw: st.DrawFn) -> Message:
    """A valid message with one to three of its values (a field, an element, a nested field)
    replaced by anything: out of range, of another type, of a subclass, or valid after all."""
    msg = draw(valid)
    for _ in range(draw(st.integers(min_value=1, max_value=3))):
        paths = _mutable_paths(msg)
        _set(msg, draw(st.sampled_from(paths)), draw(wild))
    return msg


# ---- the comparisons ----------------------------------------------------------------------------


@settings(max_examples=300, suppress_health_check=[HealthCheck.too_slow])
@given(valid)
def test_valid_messages_encode_and_decode_alike(msg: Message) -> None:
    result = assert_same_encode(msg)
    assert result[0] == "returned", result
    frame = msg.encode()
    implicit = implicit_for(type(msg), msg)
    decoded = assert_same_decode(type(msg), frame, **implicit)
    assert decoded == ("returned", shape(msg))
    for kind in (bytearray, memoryview):
        assert_same_decode(type(msg), kind(frame), **implicit)


@settings(max_examples=800, suppress_health_check=[HealthCheck.too_slow])
@given(broken())
def test_any_field_values_encode_alike_or_fail_alike(msg: Message) -> None:
    assert_same_encode(msg)


@settings(max_examples=800)
@given(st.sampled_from(CLASSES), st.binary(max_size=40))
def test_random_bytes_decode_alike_or_fail_alike(cls: type[Message], data: bytes) -> None:
    assert_same_decode(cls, data, **implicit_for(cls, None))


@settings(max_examples=300, suppress_health_check=[HealthCheck.too_slow])
@given(valid, st.lists(st.integers(min_value=0, max_value=10_000), min_size=1, max_size=3),
       st.integers(min_value=-2, max_value=2))
def test_damaged_frames_fail_alike(msg: Message, flips: list[int], resize: int) -> None:
    """A valid frame with bits flipped and bytes cut off or added: the same DecodeError."""
    frame = bytearray(msg.encode())
    for bit in flips:
        if frame:
            frame[(bit // 8) % len(frame)] ^= 1 << (bit % 8)
    frame = frame[:len(frame) + resize] if resize < 0 else frame + bytes(resize)
    assert_same_decode(type(msg), bytes(frame), **implicit_for(type(msg), msg))


@settings(max_examples=300, suppress_health_check=[HealthCheck.too_slow])
@given(st.one_of(wild, st.randoms(use_true_random=False).map(lambda r: random_message(MailboxSelect, r))),
       st.binary(max_size=36), st.sampled_from(["select", "selection", None]))
def test_decode_calls_with_any_implicit_argument_fail_alike(select: Any, data: bytes, keyword: str | None) -> None:
    """The implicit select of DownlinkReadResponse: missing, of any type, out of range, a write select,
    under another keyword; the frame random or valid for it."""
    if isinstance(select, MailboxSelect) and select.read and data:
        data = DownlinkReadResponse(select=select, data=data[:32]).encode()
    implicit = {} if keyword is None else {keyword: select}
    assert_same_decode(DownlinkReadResponse, data, **implicit)


@pytest.mark.parametrize("data", [5, None, "1f89", [0x1F, 0x89], 1.5])
@pytest.mark.parametrize("cls", CLASSES, ids=ALL)
def test_frames_that_are_no_bytes_fail_alike(cls: type[Message], data: object) -> None:
    assert_same_decode(cls, data, **implicit_for(cls, None))


@pytest.mark.parametrize("cls", CLASSES, ids=ALL)
def test_a_deleted_field_fails_alike(cls: type[Message]) -> None:
    """An empty slot (`del msg.field`): the pure codec's AttributeError, for every field."""
    for f in cls.FIELDS:
        msg = random_message(cls, random.Random(f.name))
        delattr(msg, f.name)
        assert assert_same_encode(msg)[:2] == ("raised", AttributeError)


def test_an_implicit_member_decodes_to_the_callers_object() -> None:
    select = MailboxSelect(mailbox=2, read=True)
    frame = DownlinkReadResponse(select=select, data=b"\x01\x02").encode()
    assert DownlinkReadResponse.decode(frame, select=select).select is select


# ---- construction: the dataclass __init__ ----------------------------------------------------------


def _init_by_dataclass(cls: type[Message], args: tuple[Any, ...], kwargs: dict[str, Any]) -> Message:
    obj = object.__new__(cls)
    cls.__init__(obj, *args, **kwargs)
    return obj


@settings(max_examples=300)
@given(st.sampled_from(CLASSES), st.lists(st.integers(min_value=0, max_value=3), max_size=5),
       st.lists(st.sampled_from(["seq", "data", "status", "select", "mailbox", "read", "nope", "address"]),
                max_size=3))
def test_constructing_a_message_is_the_dataclass_init(cls: type[Message], args: list[int], keys: list[str]) -> None:
    """Positional and keyword fields, defaults, default factories, and the TypeError of a wrong call
    (too many arguments, an unknown or repeated keyword) are the dataclass __init__'s."""
    kwargs = {k: i for i, k in enumerate(keys)}
    assert_same(lambda: cls(*args, **kwargs), lambda: _init_by_dataclass(cls, tuple(args), kwargs))


def test_default_factories_give_fresh_objects() -> None:
    a, b = DownlinkReadResponse(), DownlinkReadResponse()
    assert a.select == b.select and a.select is not b.select


def test_a_subclass_keeps_the_pure_codec_and_its_own_type() -> None:
    class Mine(UplinkResponse):
        __slots__ = ()

    msg = Mine(seq=3, status=Status.OK, data=b"\x07")
    frame = msg.encode()
    assert frame == UplinkResponse(seq=3, status=Status.OK, data=b"\x07").encode()
    decoded = Mine.decode(frame)
    assert type(decoded) is Mine and decoded == msg


# ---- the checks above can fail ----------------------------------------------------------------------


def test_a_codec_that_changes_one_byte_is_caught(monkeypatch: pytest.MonkeyPatch) -> None:
    """Witness for the comparisons: an encode that flips one bit of the check, or a decode that
    drops a byte of the payload, fails them."""
    accelerated_encode = UplinkResponse.encode
    accelerated_decode = UplinkResponse.decode
    msg = UplinkResponse(seq=1, status=Status.OK, data=b"\x05\x06")
    frame = msg.encode()
    assert_same_encode(msg)
    assert_same_decode(UplinkResponse, frame)

    def flipped(self: UplinkResponse) -> bytes:
        out = bytearray(accelerated_encode(self))
        out[-1] ^= 1
        return bytes(out)

    def truncated(data: bytes) -> UplinkResponse:
        out = accelerated_decode(data)
        out.data = out.data[:-1]
        return out

    monkeypatch.setattr(UplinkResponse, "encode", flipped)
    with pytest.raises(AssertionError, match="accelerated"):
        assert_same_encode(msg)
    monkeypatch.setattr(UplinkResponse, "decode", truncated)
    with pytest.raises(AssertionError, match="accelerated"):
        assert_same_decode(UplinkResponse, frame)


def test_an_error_message_that_differs_is_caught() -> None:
    assert outcome(lambda: int("x")) != outcome(lambda: int("y"))
    assert outcome(lambda: b"\x01") != outcome(lambda: bytearray(b"\x01"))
    assert outcome(lambda: [Status.OK]) != outcome(lambda: [0])


def test_a_c_codec_that_refuses_what_the_reference_accepts_is_an_error() -> None:
    """When the C codec refuses a message the pure codec encodes, the accelerated encode raises
    RuntimeError (never a silent answer): shown by installing a reference that encodes anything."""
    from urb_msgs import _accel

    cls = UplinkResponse
    fields = dataclasses.fields(cls)

    def install(pure_encode: Callable[..., bytes]) -> None:
        encode, decode = _accel.install(
            cls.NAME, cls, pure_encode, _codec._PURE_DECODE[cls], tuple(f.name for f in fields),
            tuple(None if f.default is dataclasses.MISSING else f.default for f in fields),
            tuple(None if f.default_factory is dataclasses.MISSING else f.default_factory for f in fields))
        setattr(cls, "encode", encode)
        setattr(cls, "decode", decode)

    install(lambda msg: b"\x00")  # a reference that never refuses
    try:
        with pytest.raises(RuntimeError, match="the two codecs disagree"):
            UplinkResponse(seq=1, status=Status.TIMEOUT, data=b"\x01").encode()  # breaks the rule
        assert UplinkResponse(seq=1, status=Status.OK).encode() == _codec.pure_encode(UplinkResponse(seq=1))
    finally:
        install(_codec._PURE_ENCODE[cls])
    with pytest.raises(urb_msgs.EncodeError, match="breaks the rule"):
        UplinkResponse(seq=1, status=Status.TIMEOUT, data=b"\x01").encode()


# ---- selection -----------------------------------------------------------------------------------


def _backend(setting: str | None) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != _codec.ENV}
    if setting is not None:
        env[_codec.ENV] = setting
    code = ("import urb_msgs, urb_msgs._codec as c; from urb_msgs.urb_core import UplinkResponse as U; "
            "print(c.BACKEND, type(U.__dict__['encode']).__name__)")
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=False)


@pytest.mark.parametrize("setting, want", [(None, "accelerated method_descriptor"), ("", "accelerated method_descriptor"),
                                           ("0", "accelerated method_descriptor"), ("1", "pure function")])
def test_urb_pure_python_selects_the_codec(setting: str | None, want: str) -> None:
    done = _backend(setting)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == want


def test_a_bad_urb_pure_python_says_what_to_set() -> None:
    done = _backend("yes")
    assert done.returncode != 0
    assert "URB_PURE_PYTHON='yes': use 1 (pure-Python codecs), 0 (accelerated codecs" in done.stderr


def test_a_stale_build_is_not_used(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(_codec, "FINGERPRINT", "0" * 16)
    monkeypatch.delenv(_codec.ENV, raising=False)
    use, why = _codec._selection()
    assert not use and "built from other generated sources" in why and "make accel" in why
    monkeypatch.setenv(_codec.ENV, "0")
    with pytest.raises(ImportError, match="URB_PURE_PYTHON=0 asks for the accelerated codecs"):
        _codec._selection()
