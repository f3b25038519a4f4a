"""The node commands' arguments: numbers, ports, NODE, MAILBOX and FIELD=VALUE words.

Everything here is decided from the command line and the host's schemas alone, before a port is
opened: a wrong argument is a usage error (`UsageError`: the command's usage line, one
explanation, exit status 2), never a failure of the bus. What only the bus can tell (no such node
was discovered, a node that vanished) is a failure (exit status 1), found later.
"""

from __future__ import annotations

import argparse
import enum
import math
import os
import typing
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import urb_msgs
from urb_msgs import EncodeError, FieldInfo, Message, NodeInfo
from urb_msgs.urb_core import MAILBOXES

from .managers.base import encode_message

MAX_ADDRESS = 127
"""Downlink addresses are 7 bits; 0 is the bridge itself."""
MAX_INDEX = 63
"""A node's index is 6 bits (Identification.index)."""

MAX_RATE_HZ = 100_000.0
MAX_TIMEOUT_S = 60.0
MAX_INTERVAL_S = 86_400.0


class UsageError(Exception):
    """A bad argument found by the command itself: `urb.cli.main` prints the command's usage
    line and this text, and exits with status 2."""


def number(what: str, lo: float, hi: float = math.inf, *, lo_open: bool = False) -> Callable[[str], float]:
    """An argparse type: a finite number in lo..hi (lo excluded with lo_open)."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and (value > lo if lo_open else value >= lo) and value <= hi):
            raise argparse.ArgumentTypeError(f"{text!r} is not {what}")
        return value
    parse.__name__ = "number"
    return parse


def integer(what: str, lo: int, hi: int | None = None) -> Callable[[str], int]:
    """An argparse type: an integer in lo..hi."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {what}") from None
        if value < lo or (hi is not None and value > hi):
            raise argparse.ArgumentTypeError(f"{text!r} is not {what}")
        return value
    parse.__name__ = "integer"
    return parse


BAUD = integer("a bit rate from 300 to 20000000", 300, 20_000_000)
TIMEOUT = number(f"a number of seconds above 0 and at most {MAX_TIMEOUT_S:g}", 0.0, MAX_TIMEOUT_S, lo_open=True)
INTERVAL = number(f"a number of seconds from 0 to {MAX_INTERVAL_S:g}", 0.0, MAX_INTERVAL_S)
COUNT = integer("a number of reads, 1 or more", 1)
RATE = number(f"a rate in Hz from 0.001 to {MAX_RATE_HZ:g}", 0.001, MAX_RATE_HZ)
DURATION = number("a number of seconds above 0", 0.0, lo_open=True)


def check_ports(ports: list[str]) -> None:
    """Raise UsageError when a port is given twice (by the same path or through a link): the
    second opening would fail as if another program held the port."""
    seen: dict[str, str] = {}
    for port in ports:
        real = os.path.realpath(port)
        if real in seen:
            first = seen[real]
            raise UsageError(f"{port} is given twice" if first == port else
                             f"{first} and {port} are the same port ({real}); give each port once")
        seen[real] = port


def node_types() -> dict[int, NodeInfo]:
    """The node types of the host's schemas, by class (what `URBInterface` knows)."""
    return {n.class_id: n for n in urb_msgs.NODES.values() if n.kind == "node"}


@dataclass(frozen=True)
class NodeSpec:
    """A NODE argument: a node type and index (`info`, `index`), or a bus address on a port
    (`port`, `address`)."""

    text: str
    info: NodeInfo | None = None
    index: int = 0
    port: str | None = None
    address: int | None = None


def _known_names(types: dict[int, NodeInfo]) -> str:
    return ", ".join(f"{n.name} (0x{c:02x})" for c, n in sorted(types.items()))


def parse_node(text: str, ports: list[str]) -> NodeSpec:
    """NAME[:INDEX], CLASS[:INDEX] or [PORT]@ADDR; raises UsageError saying what is wrong and
    what the argument takes. PORT may be left out when one port is given."""
    if "@" in text:
        return _parse_address(text, ports)
    name, colon, index_text = text.partition(":")
    index = _number_or(index_text, -1) if colon else 0
    if not 0 <= index <= MAX_INDEX:
        raise UsageError(f"node {text!r}: the index after ':' must be a number from 0 to {MAX_INDEX} (e.g. MotorDriver:2)")
    types = node_types()
    class_id = _number_or(name, -1) if name.strip()[:1].isdigit() else -1
    if class_id < 0:
        found = [n for n in types.values() if n.name.lower() == name.strip().lower()]
        if not found:
            raise UsageError(f"node {text!r}: no node type named {name!r} in the host's schemas (known: "
                             f"{_known_names(types)}); a node of another type can be reached by its bus "
                             f"address, e.g. @0x30 (`urb scan PORT` lists the addresses)")
        return NodeSpec(text, info=found[0], index=index)
    if class_id not in types:
        raise UsageError(f"node {text!r}: class {name} is not declared in the host's schemas (known: "
                         f"{_known_names(types)}); reach the node by its bus address instead, e.g. @0x30 "
                         f"(`urb scan PORT` lists the addresses)")
    return NodeSpec(text, info=types[class_id], index=index)


def _parse_address(text: str, ports: list[str]) -> NodeSpec:
    port_text, _, address_text = text.rpartition("@")
    address = _number_or(address_text, -1)
    if not 0 <= address <= MAX_ADDRESS:
        raise UsageError(f"node {text!r}: the address after '@' must be a number from 0 to {MAX_ADDRESS} "
                         f"(e.g. @0x30; 0 is the bridge itself)")
    if not port_text:
        if len(ports) != 1:
            raise UsageError(f"node {text!r}: with several ports, say which one: PORT@ADDR (PORT one of "
                             f"{', '.join(ports)})")
        return NodeSpec(text, port=ports[0], address=address)
    real = os.path.realpath(port_text)
    port = next((p for p in ports if p == port_text or os.path.realpath(p) == real), None)
    if port is None:
        raise UsageError(f"node {text!r}: {port_text} is not one of the ports given ({', '.join(ports)}); "
                         f"write PORT@ADDR with one of them, or @ADDR when there is one port")
    return NodeSpec(text, port=port, address=address)


def _number_or(text: str, otherwise: int) -> int:
    """A decimal (010 is ten) or 0x/0o/0b number; `otherwise` when `text` is none."""
    word = text.strip()
    try:
        return int(word) if word.isdigit() else int(word, 0)
    except ValueError:
        return otherwise


def parse_mailbox(text: str) -> int | str:
    """A MAILBOX argument: its number (0..7), or the name of its message (checked against the
    node later, `mailbox_number`); raises UsageError for anything else."""
    word = text.strip()
    if word[:1].isalpha():
        return word
    number = _number_or(word, -1)
    if number == -1 and word != "-1":
        raise UsageError(f"mailbox {text!r}: give a mailbox number from 0 to {MAILBOXES - 1} or the name of its "
                         f"message (e.g. MotorFeedback)")
    if not 0 <= number < MAILBOXES:
        raise UsageError(f"mailbox {text!r}: mailboxes are numbered 0 to {MAILBOXES - 1}")
    return number


def mailbox_number(info: NodeInfo, spec: int | str, direction: str, label: str | None = None) -> int:
    """The number of the `direction` mailbox of node type `info` that `spec` (from
    `parse_mailbox`) names; UsageError when the node has none such, listing the ones it has."""
    boxes = [m for m in info.mailboxes if m.direction == direction]
    if isinstance(spec, int):
        found = [m.number for m in boxes if m.number == spec]
    else:
        found = [m.number for m in boxes if m.message.NAME.lower() == spec.lower()]
    if found:
        return found[0]
    have = ", ".join(f"{m.number} {m.message.NAME} ({m.size} bytes)" for m in boxes) or "none"
    what = f"{direction} {spec}" if isinstance(spec, int) else f"{direction} holding {spec!r}"
    who = label or info.name
    raise UsageError(f"{who} has no {what}; its {direction}es: {have}")


def check_node_mailboxes(spec: NodeSpec, mailboxes: list[int | str], direction: str) -> None:
    """For a node given by type, check now that its schema has these mailboxes (a node given by
    address is checked once its identification is known)."""
    if spec.info is None:
        return
    for box in mailboxes:
        mailbox_number(spec.info, box, direction)


def parse_values(cls: type[Message], values: list[str], defaults: bool) -> Message:
    """A message from FIELD=VALUE words in engineering units; raises UsageError saying which
    word is wrong and what the field takes."""
    hints = typing.get_type_hints(cls)
    given: dict[str, str] = {}
    for word in values:
        name, eq, value = word.partition("=")
        if not eq:
            raise UsageError(f"{word!r}: give values as FIELD=VALUE (fields of {cls.NAME}: {', '.join(f.name for f in cls.FIELDS)})")
        given[name.strip()] = value.strip()
    names = [f.name for f in cls.FIELDS]
    unknown = [n for n in given if n not in names]
    if unknown:
        raise UsageError(f"{cls.NAME} has no field {', '.join(unknown)}; its fields: {', '.join(names)}")
    missing = [n for n in names if n not in given]
    if missing and not defaults:
        raise UsageError(f"missing {', '.join(missing)} for {cls.NAME}: give every field, or pass --defaults to zero the others")
    kwargs: dict[str, Any] = {}
    for f in cls.FIELDS:
        if f.name not in given:
            continue
        hint_ = hints[f.name]
        text = given[f.name]
        try:
            if typing.get_origin(hint_) is list:
                inner = typing.get_args(hint_)[0]
                items = [x for x in text.split(",") if x]
                if len(items) != f.count:
                    raise UsageError(f"{cls.NAME}.{f.name} takes {f.count} comma-separated values, got {len(items)}")
                kwargs[f.name] = [_scalar(cls, f, inner, x) for x in items]
            else:
                kwargs[f.name] = _scalar(cls, f, hint_, text)
        except EncodeError as exc:
            raise UsageError(str(exc)) from None
        except ValueError as exc:
            raise UsageError(f"{cls.NAME}.{f.name} = {text!r}: {exc}") from None
    msg = cls(**kwargs)
    try:
        encode_message(msg)
    except EncodeError as exc:
        raise UsageError(str(exc)) from None
    return msg


def _scalar(cls: type[Message], f: FieldInfo, hint_: Any, text: str) -> Any:
    if isinstance(hint_, type) and issubclass(hint_, enum.IntEnum):
        try:
            return hint_[text.upper()]
        except KeyError:
            try:
                return hint_(int(text, 0))
            except ValueError:
                raise ValueError(f"not one of {', '.join(m.name for m in hint_)}") from None
    if hint_ is bool:
        if text.lower() in ("1", "true", "yes", "on"):
            return True
        if text.lower() in ("0", "false", "no", "off"):
            return False
        raise ValueError("use true or false")
    if isinstance(hint_, type) and issubclass(hint_, Message):
        raise ValueError("nested messages cannot be given field by field; use --raw HEX")
    if hint_ is bytes:
        try:
            return bytes.fromhex(text)
        except ValueError:
            raise ValueError("not hex bytes; give two hex digits a byte (e.g. 0a1b)") from None
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"not a number; give a value in {value_range(f)}") from None
    if not math.isfinite(value):
        raise ValueError(f"not a finite number; give a value in {value_range(f)}")
    if f.scale is None and f.offset is None:
        if value != int(value):
            raise ValueError(f"this field takes an integer in {value_range(f)}")
        if f.lo is not None and f.hi is not None and not f.lo <= int(value) <= f.hi:
            raise ValueError(f"outside {value_range(f)}")
        return int(value)
    try:
        return cls.raw_from_engineering(f.name, value)
    except OverflowError:  # finite, but not once scaled (1e308 V)
        raise ValueError(f"outside {value_range(f)}") from None


def value_range(f: FieldInfo) -> str:
    """The engineering values field `f` can hold, e.g. '-32.768..32.767 V'."""
    unit = f" {f.unit}" if f.unit else ""
    if f.lo is None or f.hi is None:
        return "the range of the field"
    if f.scale is None and f.offset is None:
        return f"{f.lo}..{f.hi}{unit}"
    scale, off = f.scale if f.scale is not None else 1.0, f.offset or 0.0
    lo, hi = sorted((f.lo * scale + off, f.hi * scale + off))
    return f"{lo:g}..{hi:g}{unit}"


