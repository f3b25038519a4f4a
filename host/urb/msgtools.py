"""Generic helpers over generated messages: build from plain data, dump to plain data, sample values."""

from __future__ import annotations

import enum
import random
import typing
from typing import Any

from urb_msgs import EncodeError, FieldInfo, Message


def from_plain(cls: type[Message], values: dict[str, Any]) -> Message:
    """A message from plain data (as `to_plain` returns it): nested dicts, lists, ints, bools, hex strings."""
    hints = typing.get_type_hints(cls)
    unknown = set(values) - {f.name for f in cls.FIELDS}
    if unknown:
        raise EncodeError(f"{cls.NAME} has no field(s) {', '.join(sorted(unknown))}")
    return cls(**{name: _convert(hints[name], value) for name, value in values.items()})


def _convert(hint: Any, value: Any) -> Any:
    if typing.get_origin(hint) is list:
        (inner,) = typing.get_args(hint)
        return [_convert(inner, v) for v in value]
    if isinstance(hint, type) and issubclass(hint, Message):
        return from_plain(hint, value)
    if isinstance(hint, type) and issubclass(hint, enum.IntEnum):
        return hint(value)
    if hint is bytes:
        return bytes.fromhex(value) if isinstance(value, str) else bytes(value)
    return value


def to_plain(msg: Message) -> dict[str, Any]:
    """JSON-ready field values: enums as ints, byte payloads as hex strings."""
    plain: dict[str, Any] = _plain(msg.to_dict())
    return plain


def _plain(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_plain(v) for v in value]
    if isinstance(value, bytes):
        return value.hex()
    return value


def random_message(cls: type[Message], rng: random.Random) -> Message:
    """A valid message with every field drawn from its allowed values (edges included often), drawn
    again until it keeps the schema's rules (`require`, msg.broken_rule())."""
    hints = typing.get_type_hints(cls)
    for _ in range(1000):
        msg = cls(**{f.name: _random_field(f, hints[f.name], rng) for f in cls.FIELDS})
        if msg.broken_rule() is None:
            return msg
    raise ValueError(f"1000 random {cls.NAME} messages all broke a rule: {msg.broken_rule()}")


def _random_field(info: FieldInfo, hint: Any, rng: random.Random) -> Any:
    if typing.get_origin(hint) is list:
        (inner,) = typing.get_args(hint)
        return [_random_scalar(info, inner, rng) for _ in range(info.count)]
    return _random_scalar(info, hint, rng)


def _random_scalar(info: FieldInfo, hint: Any, rng: random.Random) -> Any:
    if isinstance(hint, type) and issubclass(hint, Message):
        return random_message(hint, rng)
    if isinstance(hint, type) and issubclass(hint, enum.IntEnum):
        return rng.choice(list(hint))
    if hint is bool:
        return rng.random() < 0.5
    lo = info.lo if info.lo is not None else 0
    hi = info.hi if info.hi is not None else 0
    if hint is bytes:
        return bytes(rng.randrange(256) for _ in range(rng.choice([lo, hi, rng.randint(lo, hi)])))
    return rng.choice([lo, hi, rng.randint(lo, hi)])
