"""`urb scan`, `urb read`, `urb write`, `urb monitor`, `urb log`: the node tools.

Every command opens the given serial ports, discovers the nodes behind each bridge (the same
discovery as URBInterface.add_bus_manager) and then works on nodes by name, wherever they are.
Expected failures (no such port, permission denied, no bridge answering, a node that vanished,
a bridge that went away) print one explanation and exit with status 1, never a traceback; a bad
argument (a number out of range, a port given twice, a FIELD=VALUE the schema refuses) is a usage
error: the command's usage line, one explanation, exit status 2.
"""

from __future__ import annotations

import argparse
import csv
import enum
import importlib
import importlib.util
import json
import math
import os
import sys
import threading
import time
import typing
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

from rich.console import Console
from rich.live import Live
from rich.table import Table

from urb_msgs import EncodeError, FieldInfo, Message, NodeInfo

from .api import NodeAccessor, NodeRecord, NodeRequest, URBInterface
from .errors import ErrorFlag, URBError, hint
from .managers import RS232Manager
from .managers.base import encode_message

EXIT_OK, EXIT_FAIL, EXIT_USAGE = 0, 1, 2

PORT_HELP = "serial port of a bridge (e.g. /dev/ttyS0, /dev/ttyUSB0)"
NODE_HELP = "node as NAME[:INDEX] (e.g. MotorDriver:2) or CLASS[:INDEX] with a number (0x10:2); index defaults to 0"
MBOX_HELP = "mailbox number (0..7) or the name of its message (e.g. MotorFeedback)"

PORTS_TEXT = """\
Ports: every PORT is opened at --baud (8N1), the bridge at address 0 is asked for its
identification, told to rescan its downlink, and every node that answers is identified.
Values are shown and given in engineering units from the schema (raw * scale + offset).
A port whose last user ended without waiting for its answers (Ctrl-C, kill) is used once
their time is over: with --timeout up to 0.3, at most 0.3 s after Ctrl-C and 1.3 s after
kill -9 (records in $URB_STATE_DIR, else $XDG_RUNTIME_DIR/urb, else /tmp/urb-UID)."""

SCAN_EPILOG = PORTS_TEXT + """

Exit status: 0 success; 1 a failure (port missing or not permitted, no bridge answering, a
node flagged DUPLICATE, MISMATCH or UNKNOWN_CLASS); 2 a usage error (an option out of range, a
port given twice)."""

READ_EPILOG = PORTS_TEXT + """

Exit status: 0 success; 1 a failure (port missing or not permitted, no bridge answering, the
node vanished or refused the request, the bridge went away); 2 a usage error (an option out of
range)."""

WRITE_EPILOG = PORTS_TEXT + """

Exit status: 0 the node stored the message; 1 a failure (port missing or not permitted, no
bridge answering, the node vanished or refused the request, the bridge went away); 2 a usage
error (an option out of range, a FIELD=VALUE or --raw HEX that the schema refuses)."""

POLL_EPILOG = PORTS_TEXT + """

A bridge that goes away during the run (BRIDGE_LOST: its port closed, or it stopped answering
altogether) is reported once on stderr and no longer read; the other bridges go on, and the
command stops when no bridge is left. At the end, reads still in flight are waited for up to
--timeout (plus 0.5 s).

Exit status: 0 success; 1 a failure (port missing or not permitted, no bridge answering, a node
that stopped answering (NO_NODE), a bridge that went away, or a bridge whose last read of every
mailbox got no response); 2 a usage error (an option out of range, a port given twice)."""

MAX_RATE_HZ = 100_000.0
MAX_TIMEOUT_S = 60.0
MAX_INTERVAL_S = 86_400.0


class UsageError(Exception):
    """A bad argument found by the command itself: `urb.cli.main` prints the command's usage
    line and this text, and exits with status 2."""


def _number(what: str, lo: float, hi: float = math.inf, *, lo_open: bool = False) -> Callable[[str], float]:
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


def _integer(what: str, lo: int, hi: int | None = None) -> Callable[[str], int]:
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


BAUD = _integer("a bit rate from 300 to 20000000", 300, 20_000_000)
TIMEOUT = _number(f"a number of seconds above 0 and at most {MAX_TIMEOUT_S:g}", 0.0, MAX_TIMEOUT_S, lo_open=True)
INTERVAL = _number(f"a number of seconds from 0 to {MAX_INTERVAL_S:g}", 0.0, MAX_INTERVAL_S)
COUNT = _integer("a number of reads, 1 or more", 1)
RATE = _number(f"a rate in Hz from 0.001 to {MAX_RATE_HZ:g}", 0.001, MAX_RATE_HZ)
DURATION = _number("a number of seconds above 0", 0.0, lo_open=True)


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


def register(sub: Any) -> None:
    """Add the node commands to the `urb` parser."""
    fmt = argparse.RawDescriptionHelpFormatter

    def common(p: argparse.ArgumentParser) -> None:
        p.add_argument("--baud", type=BAUD, default=115200, metavar="N",
                       help="bit rate of every port, 300..20000000 (default 115200)")
        p.add_argument("--timeout", type=TIMEOUT, default=0.2, metavar="S",
                       help="seconds to wait for one response before reporting UPLINK_TIMEOUT, "
                            f"above 0 and at most {MAX_TIMEOUT_S:g} (default 0.2)")

    scan = sub.add_parser(
        "scan", help="discover the nodes behind one or more bridges and list them", formatter_class=fmt,
        description="List every node behind the bridges on the given ports, one row per node that answered:\n"
        "bridge and downlink address, node type, class, index, layout fingerprint (checked against\n"
        "the host's schema), firmware version and flags. Rows are never merged: two nodes with the\n"
        "same class and index are both flagged DUPLICATE (give them distinct indexes); a node built\n"
        "from another schema is flagged MISMATCH (rebuild its firmware or this host with `urb gen`).",
        epilog=SCAN_EPILOG + "\n\nExample:\n  urb scan /dev/ttyS0 /dev/ttyUSB0")
    scan.add_argument("ports", nargs="+", metavar="PORT", help=PORT_HELP)
    scan.add_argument("--json", action="store_true", help="print the table as JSON")
    common(scan)
    scan.set_defaults(run=run_scan)

    read = sub.add_parser(
        "read", help="read an outbox of a node, with values in engineering units", formatter_class=fmt,
        description="Read one outbox of one node and print its fields in engineering units, with the\n"
        "round-trip latency. With --count, read repeatedly every --interval seconds: a failed read\n"
        "is reported and the next one is made, except when the bridge went away (BRIDGE_LOST),\n"
        "which is reported once and ends the command.",
        epilog=READ_EPILOG + "\n\nExamples:\n  urb read /dev/ttyS0 MotorDriver:2 MotorFeedback\n"
        "  urb read /dev/ttyS0 Imu 1 --count 10 --interval 0.1\n  urb read /dev/ttyS0 0x20 1 --json")
    read.add_argument("port", metavar="PORT", help=PORT_HELP)
    read.add_argument("node", metavar="NODE", help=NODE_HELP)
    read.add_argument("mailbox", metavar="MAILBOX", help=MBOX_HELP)
    read.add_argument("--raw", action="store_true", help="print the bytes in hex instead of decoding them")
    read.add_argument("--json", action="store_true", help="print one JSON object per read")
    read.add_argument("--count", type=COUNT, default=1, metavar="N", help="number of reads, 1 or more (default 1)")
    read.add_argument("--interval", type=INTERVAL, default=0.5, metavar="S",
                      help=f"seconds between reads, 0..{MAX_INTERVAL_S:g} (default 0.5)")
    common(read)
    read.set_defaults(run=run_read)

    write = sub.add_parser(
        "write", help="write an inbox of a node from engineering values", formatter_class=fmt,
        description="Write one inbox of one node. Give every field of the inbox's message as FIELD=VALUE\n"
        "in engineering units (enum members by name, booleans as true/false, arrays as\n"
        "comma-separated lists); --defaults sets the fields you leave out to zero. --raw HEX writes\n"
        "bytes as they are. Options may come before, between or after the FIELD=VALUE words. The\n"
        "command succeeds only when the bridge reports that the node stored the message.",
        epilog=WRITE_EPILOG + "\n\nExamples:\n  urb write /dev/ttyS0 MotorDriver:2 MotorCommand voltage=1.5\n"
        "  urb write /dev/ttyS0 MotorDriver:0 2 mode=LOCAL_PD kp=0.01 kd=0 target=2000 voltage_limit=6\n"
        "  urb write /dev/ttyS0 MotorDriver:0 2 --defaults mode=LOCAL_PD target=2000\n"
        "  urb write /dev/ttyS0 Imu 0 --raw 030500000000")
    write.add_argument("port", metavar="PORT", help=PORT_HELP)
    write.add_argument("node", metavar="NODE", help=NODE_HELP)
    write.add_argument("mailbox", metavar="MAILBOX", help=MBOX_HELP)
    write.add_argument("values", nargs="*", metavar="FIELD=VALUE", help="field values in engineering units")
    write.add_argument("--raw", metavar="HEX", help="write these bytes instead of encoding fields")
    write.add_argument("--defaults", action="store_true", help="zero every field not given")
    common(write)
    write.set_defaults(run=run_write)

    for name in ("monitor", "log"):
        is_log = name == "log"
        p = sub.add_parser(
            name, help="record outboxes to a CSV (or Parquet) file for plotting" if is_log
            else "show live values, latency and errors per node",
            formatter_class=fmt,
            description=(
                "Read outboxes periodically and record every response to FILE, one row per read: times\n"
                "(submission and completion, ns), latency, bridge, address, node, mailbox, status and\n"
                "every field in engineering units (nested fields as packs[0].voltage). CSV always;\n"
                "Parquet (FILE ending in .parquet) when pyarrow is installed. Stops after --duration or\n"
                "on Ctrl-C, and prints a summary. Reads that complete after the file is closed (a second\n"
                "Ctrl-C) are not written." if is_log else
                "Read outboxes periodically and show, refreshing in place, the latest values of every\n"
                "node and mailbox with its achieved rate, round-trip latency (mean, 99th percentile,\n"
                "max) and error counts by flag. A read is not resubmitted while the previous one is\n"
                "pending (counted as skipped). Stops after --duration or on Ctrl-C."),
            epilog=POLL_EPILOG + ("\n\nExamples:\n  urb log /dev/ttyS0 -o run.csv --node MotorDriver:0 --mailbox 1 --rate 1000 --duration 10"
                                    if is_log else
                                    "\n\nExamples:\n  urb monitor /dev/ttyS0\n  urb monitor /dev/ttyS0 --node Imu --rate 100"))
        p.add_argument("ports", nargs="+", metavar="PORT", help=PORT_HELP)
        if is_log:
            p.add_argument("-o", "--output", required=True, type=Path, metavar="FILE", help="output file (.csv or .parquet)")
        p.add_argument("--node", action="append", default=[], metavar="NODE", help=NODE_HELP + "; repeatable (default: every usable node)")
        p.add_argument("--mailbox", action="append", default=[], metavar="MAILBOX",
                       help="outbox to read; repeatable (default: every outbox except 0)")
        p.add_argument("--rate", type=RATE, default=1000.0 if is_log else 50.0, metavar="HZ",
                       help=f"reads per second of each mailbox, 0.001..{MAX_RATE_HZ:g} (default {1000 if is_log else 50})")
        p.add_argument("--duration", type=DURATION, default=None if not is_log else 10.0, metavar="S",
                       help="stop after S seconds, above 0" + (" (default 10)" if is_log else " (default: until Ctrl-C)"))
        common(p)
        p.set_defaults(run=run_log if is_log else run_monitor)


# --------------------------------------------------------------------------------------------
# connecting
# --------------------------------------------------------------------------------------------

def console(stderr: bool = False) -> Console:
    """A console that does not wrap tables when the output is a file or a pipe."""
    stream = sys.stderr if stderr else sys.stdout
    return Console(file=stream, width=None if stream.isatty() else 200)


def fail(text: str) -> int:
    print(f"urb: {text}", file=sys.stderr)
    return EXIT_FAIL


@contextmanager
def connected(ports: list[str], args: argparse.Namespace) -> Iterator[URBInterface]:
    """Open every port and discover; raises URBError (handled by `guarded`), or UsageError
    for a port given twice. On the way out every manager closes, draining its requests in flight
    (so that the next command cannot get their late responses), except after Ctrl-C."""
    check_ports(ports)
    urb = URBInterface()
    drain = True
    try:
        for port in ports:
            m = RS232Manager(port, args.baud, timeout_s=args.timeout, lost_after_s=max(1.0, 5 * args.timeout))
            try:
                urb.add_bus_manager(m, timeout_s=max(3.0, 20 * args.timeout))
            except URBError:
                m.close()
                raise
        yield urb
    except KeyboardInterrupt:
        drain = False  # Ctrl-C: stop now (host/urb/README.md, "Closing drains")
        raise
    finally:
        urb.close(drain=drain)


def guarded(fn: Callable[[argparse.Namespace], int]) -> Callable[[argparse.Namespace], int]:
    def run(args: argparse.Namespace) -> int:
        try:
            return fn(args)
        except URBError as exc:
            return fail(str(exc))
        except BrokenPipeError:
            return EXIT_OK
    run.__doc__ = fn.__doc__
    return run


def parse_node(urb: URBInterface, text: str) -> NodeAccessor:
    name, _, index = text.partition(":")
    try:
        idx = int(index, 0) if index else 0
    except ValueError:
        raise URBError(f"node {text!r}: the index after ':' must be a number (e.g. MotorDriver:2)") from None
    cls: int | str
    try:
        cls = int(name, 0)
    except ValueError:
        cls = name
    return urb.find_node(cls, idx)


def parse_mailbox(info: NodeInfo, text: str, direction: str) -> int:
    try:
        n = int(text, 0)
    except ValueError:
        boxes = [m.number for m in info.mailboxes if m.direction == direction and m.message.NAME.lower() == text.lower()]
        if not boxes:
            have = ", ".join(f"{m.number} {m.message.NAME}" for m in info.mailboxes if m.direction == direction)
            raise URBError(f"{info.name} has no {direction} holding {text!r}; its {direction}es: {have}") from None
        return boxes[0]
    if info.mailbox(direction, n) is None:
        have = ", ".join(f"{m.number} {m.message.NAME}" for m in info.mailboxes if m.direction == direction)
        raise URBError(f"{info.name} has no {direction} {n}; its {direction}es: {have}")
    return n


def went_away(bridge: str, reason: str | None) -> str:
    """'the bridge on PORT went away (why)', the port named once."""
    why = reason or "BRIDGE_LOST"
    if why.startswith(bridge + ": "):
        why = why[len(bridge) + 2:]
    return f"the bridge on {bridge} went away ({why})"


def request_failure(node: NodeAccessor, req: NodeRequest) -> str:
    rec = node.record
    if req.flags == ErrorFlag.NO_NODE:
        return (f"node {rec.label} did not answer (NO_NODE): it was discovered at {rec.location} but no longer "
                f"acknowledges its address. Check its connector and power, then run `urb scan {rec.bridge.name}`.")
    if req.flags == ErrorFlag.BRIDGE_LOST:
        return f"{went_away(rec.bridge.name, rec.bridge.lost_reason)}; reconnect it and run the command again"
    return req.error or f"{rec.label}: {req.flags.describe()}: {hint(req.flags)}"


# --------------------------------------------------------------------------------------------
# values in engineering units
# --------------------------------------------------------------------------------------------

def engineering(f: FieldInfo, raw: Any) -> Any:
    if isinstance(raw, enum.IntEnum):
        return raw.name
    if isinstance(raw, bool):
        return raw
    if isinstance(raw, (bytes, bytearray)):
        return bytes(raw).hex()
    if isinstance(raw, int) and (f.scale is not None or f.offset is not None):
        return raw * (f.scale if f.scale is not None else 1.0) + (f.offset or 0.0)
    return raw


def flatten(msg: Message, prefix: str = "") -> list[tuple[str, Any, str | None]]:
    """(name, engineering value, unit) of every leaf field: nested as a.b, arrays as a[0]."""
    out: list[tuple[str, Any, str | None]] = []
    for f in msg.FIELDS:
        raw = getattr(msg, f.name)
        name = prefix + f.name
        if isinstance(raw, Message):
            out += flatten(raw, name + ".")
        elif isinstance(raw, list):
            for i, v in enumerate(raw):
                if isinstance(v, Message):
                    out += flatten(v, f"{name}[{i}].")
                else:
                    out.append((f"{name}[{i}]", engineering(f, v), f.unit))
        else:
            out.append((name, engineering(f, raw), f.unit))
    return out


def field_names(cls: type[Message]) -> list[str]:
    hints = typing.get_type_hints(cls)
    names: list[str] = []
    for f in cls.FIELDS:
        hint_ = hints[f.name]
        inner = typing.get_args(hint_)[0] if typing.get_origin(hint_) is list else hint_
        nested = isinstance(inner, type) and issubclass(inner, Message)
        if typing.get_origin(hint_) is list:
            for i in range(f.count):
                names += [f"{f.name}[{i}].{n}" for n in field_names(inner)] if nested else [f"{f.name}[{i}]"]
        elif nested:
            names += [f"{f.name}.{n}" for n in field_names(inner)]
        else:
            names.append(f.name)
    return names


def fmt_value(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v)


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
        return bytes.fromhex(text)
    value = float(text)
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


# --------------------------------------------------------------------------------------------
# scan
# --------------------------------------------------------------------------------------------

@guarded
def run_scan(args: argparse.Namespace) -> int:
    with connected(args.ports, args) as urb:
        rows = urb.nodes()
        if args.json:
            print(json.dumps([_row_dict(r) for r in rows], indent=2))
        else:
            out = console()
            for rep in urb.reports.values():
                info = rep.info
                assert info is not None
                out.print(f"[bold]{rep.manager.name}[/]: URB bridge firmware {info.fw_major}.{info.fw_minor}.{info.fw_patch}, "
                              f"{info.downlink.name} {info.bitrate_kbps} kb/s, FIFO {info.fifo_depth}, heartbeat "
                              f"{info.heartbeat_us} us, {len(rep.records)} node(s)", highlight=False)
            table = Table(show_edge=False, header_style="bold")
            for col in ("bridge", "addr", "node", "class", "index", "fingerprint", "schema", "firmware", "flags"):
                table.add_column(col, justify="right" if col in ("addr", "class", "index") else "left")
            for r in rows:
                schema = "ok" if r.expected_fingerprint == r.fingerprint else (
                    f"[red]expects {r.expected_fingerprint:08x}[/]" if r.expected_fingerprint is not None else "[red]unknown class[/]")
                table.add_row(r.bridge.name, str(r.address), r.name, f"0x{r.class_id:02x}", str(r.index), f"{r.fingerprint:08x}",
                              schema, r.firmware, "[red]" + " ".join(sorted(r.flags)) + "[/]" if r.flags else "")
            out.print(table)
            for rep in urb.reports.values():
                for p in rep.problems:
                    out.print(f"[yellow]warning:[/] {p}", highlight=False)
            if any(r.flags for r in rows):
                out.print("[red]Flagged nodes are refused by find_node():[/] DUPLICATE: give each node a distinct index; "
                              "MISMATCH: rebuild the node firmware or this host from the same schema (urb gen); "
                              "UNKNOWN_CLASS: the host's schema does not declare the class.", highlight=False)
        return EXIT_FAIL if any(r.flags for r in rows) else EXIT_OK


def _row_dict(r: NodeRecord) -> dict[str, Any]:
    return {"bridge": r.bridge.name, "address": r.address, "node": r.name, "class": r.class_id, "index": r.index,
            "fingerprint": f"{r.fingerprint:08x}",
            "schema_fingerprint": None if r.expected_fingerprint is None else f"{r.expected_fingerprint:08x}",
            "schema_file": r.info.schema_file if r.info else None, "firmware": r.firmware, "flags": sorted(r.flags)}


# --------------------------------------------------------------------------------------------
# read / write
# --------------------------------------------------------------------------------------------

@guarded
def run_read(args: argparse.Namespace) -> int:
    with connected([args.port], args) as urb:
        node = parse_node(urb, args.node)
        box = parse_mailbox(node.info, args.mailbox, "outbox")
        mb = node.info.mailbox("outbox", box)
        assert mb is not None
        status = EXIT_OK
        for k in range(args.count):
            if k:
                time.sleep(args.interval)
            req = node.submit_request(node.new_request().read(box))
            if not req.wait(args.timeout * 20 + 1):
                return fail(f"{node.label}: no completion (is the bridge still running?)")
            if not req.ok:
                print(f"urb: {request_failure(node, req)}", file=sys.stderr)
                if req.flags & ErrorFlag.BRIDGE_LOST:
                    return EXIT_FAIL  # every later read would fail the same way
                status = EXIT_FAIL
                continue
            lat = (req.latency_ns or 0) / 1e3
            data = req.data or b""
            if args.raw:
                print(json.dumps({"data": data.hex(), "latency_us": round(lat, 1)}) if args.json else data.hex())
                continue
            msg = req.message()
            values = flatten(msg)
            if args.json:
                print(json.dumps({"node": node.label, "mailbox": box, "message": mb.message.NAME, "latency_us": round(lat, 1),
                                  "fields": {n: v for n, v, _ in values}}))
            else:
                print(f"{node.label} outbox {box} {mb.message.NAME} ({node.record.location}, {lat:.0f} us)")
                width = max(len(n) for n, _, _ in values)
                for n, v, unit in values:
                    print(f"  {n:<{width}}  {fmt_value(v)}{' ' + unit if unit else ''}")
        return status


@guarded
def run_write(args: argparse.Namespace) -> int:
    raw: bytes | None = None
    if args.raw is not None:
        if args.values:
            raise UsageError(f"give either FIELD=VALUE words or --raw HEX, not both (got --raw and {' '.join(args.values)})")
        try:
            raw = bytes.fromhex(args.raw)
        except ValueError:
            raise UsageError(f"--raw {args.raw!r} is not hex (e.g. --raw 0a0b)") from None
    with connected([args.port], args) as urb:
        node = parse_node(urb, args.node)
        box = parse_mailbox(node.info, args.mailbox, "inbox")
        mb = node.info.mailbox("inbox", box)
        assert mb is not None
        if raw is not None:
            payload = raw
            if len(payload) != mb.size:
                raise UsageError(f"{node.info.name} inbox {box} takes {mb.size} bytes, --raw gives {len(payload)}")
        else:
            if not args.values and not args.defaults:
                names = ", ".join(f"{f.name}" + (f" [{f.unit}]" if f.unit else "") for f in mb.message.FIELDS)
                raise UsageError(f"give the fields of {mb.message.NAME} as FIELD=VALUE: {names}")
            payload = encode_message(parse_values(mb.message, args.values, args.defaults))
        req = node.submit_request(node.new_request().write(box, payload))
        if not req.wait(args.timeout * 20 + 1):
            return fail(f"{node.label}: no completion (is the bridge still running?)")
        if not req.ok:
            return fail(request_failure(node, req))
        print(f"{node.label} inbox {box} {mb.message.NAME}: stored ({(req.latency_ns or 0) / 1e3:.0f} us)")
        return EXIT_OK


# --------------------------------------------------------------------------------------------
# monitor / log: a periodic poller
# --------------------------------------------------------------------------------------------

@dataclass
class Channel:
    """One (node, outbox) being polled, with its statistics."""

    node: NodeAccessor
    box: int
    cls: type[Message]
    pending: bool = False
    ok: int = 0
    skipped: int = 0
    errors: dict[str, int] = field(default_factory=dict)
    latencies: list[int] = field(default_factory=list)
    last: list[tuple[str, Any, str | None]] = field(default_factory=list)
    first_ns: int | None = None
    last_ns: int | None = None
    last_flags: ErrorFlag | None = None
    """Outcome of the latest completed read (None before the first)."""

    @property
    def label(self) -> str:
        return f"{self.node.label}/{self.box}"

    @property
    def bridge(self) -> str:
        return self.node.manager.name

    def latency_ms(self) -> tuple[float, float, float]:
        lat = sorted(self.latencies[-5000:])
        if not lat:
            return (math.nan, math.nan, math.nan)
        return (sum(lat) / len(lat) / 1e6, lat[min(len(lat) - 1, int(len(lat) * 0.99))] / 1e6, lat[-1] / 1e6)

    def rate(self) -> float:
        if self.first_ns is None or self.last_ns is None or self.last_ns <= self.first_ns:
            return 0.0
        return (self.ok - 1) / ((self.last_ns - self.first_ns) / 1e9) if self.ok > 1 else 0.0


def channels_for(urb: URBInterface, nodes: list[str], boxes: list[str]) -> list[Channel]:
    accessors = [parse_node(urb, n) for n in nodes] if nodes else [
        urb.find_node(r.class_id, r.index) for r in urb.nodes() if r.usable]
    if not accessors:
        raise URBError("no usable node to poll (see `urb scan` for flagged nodes)")
    out: list[Channel] = []
    for acc in accessors:
        numbers = [parse_mailbox(acc.info, b, "outbox") for b in boxes] if boxes else sorted(
            m.number for m in acc.info.mailboxes if m.direction == "outbox" and m.number != 0)
        for n in numbers:
            mb = acc.info.mailbox("outbox", n)
            assert mb is not None
            out.append(Channel(acc, n, mb.message))
    return out


class Poller:
    """Submits a read of every channel every 1/rate s (absolute schedule, no resubmission while
    pending) and hands each completed request to `on_result` on the dispatcher.

    A bridge found lost (its manager's `lost_reason`, or a read completed BRIDGE_LOST) is
    reported once on stderr and its channels are no longer read; polling ends when no bridge is
    left. Once `run` has returned, completions are ignored: `on_result` never runs again (the
    requests still in flight complete BRIDGE_LOST when the ports close)."""

    def __init__(self, channels: list[Channel], rate: float, on_result: Callable[[Channel, NodeRequest], None],
                 grace_s: float = 2.0) -> None:
        if not (math.isfinite(rate) and rate > 0):
            raise URBError("--rate must be a positive number")
        self.channels = channels
        self.period_ns = max(1, int(1e9 / rate))
        self.on_result = on_result
        self.grace_s = grace_s
        self.lock = threading.RLock()
        self.vanished: set[str] = set()
        self.lost: dict[str, str] = {}
        """Bridges that went away (name -> reason), each reported once on stderr."""
        self.unanswered: list[Channel] = []
        """Channels whose read was still in flight when the poller stopped."""
        self.interrupted = False
        self._found_lost: dict[str, str] = {}
        self._stopped = False
        self._running = False

    def _callback(self, ch: Channel) -> Callable[[NodeRequest], None]:
        def done(req: NodeRequest) -> None:
            with self.lock:  # held through on_result, so that nothing is recorded after stop()
                if self._stopped:
                    return  # completed after the end (BRIDGE_LOST when the port closes): not recorded
                ch.pending = False
                ch.last_flags = req.flags
                if req.ok:
                    ch.ok += 1
                    ch.latencies.append(req.latency_ns or 0)
                    ch.first_ns = ch.first_ns if ch.first_ns is not None else req.completed_ns
                    ch.last_ns = req.completed_ns
                else:
                    name = req.flags.describe()
                    ch.errors[name] = ch.errors.get(name, 0) + 1
                    if req.flags == ErrorFlag.NO_NODE:
                        self.vanished.add(ch.node.label)
                    if req.flags & ErrorFlag.BRIDGE_LOST:
                        self._found_lost.setdefault(ch.bridge, ch.node.manager.lost_reason or "BRIDGE_LOST")
                self.on_result(ch, req)
        return done

    def _bridge_lost(self, ch: Channel) -> bool:
        """Whether the channel's bridge is known lost (noting a newly lost one); lock held."""
        if ch.bridge in self._found_lost:
            return True
        reason = ch.node.manager.lost_reason
        if reason is not None:
            self._found_lost[ch.bridge] = reason
            return True
        return False

    def tick(self) -> None:
        for ch in self.channels:
            with self.lock:
                if self._bridge_lost(ch):
                    continue
                if ch.pending:
                    ch.skipped += 1
                    continue
                ch.pending = True
            ch.node.submit_request(ch.node.new_request().read(ch.box).set_callback(self._callback(ch)))

    def _report_lost(self) -> None:
        """Say once on stderr which bridge went away, and why (main thread)."""
        with self.lock:
            for ch in self.channels:
                self._bridge_lost(ch)
            new = [(name, reason) for name, reason in self._found_lost.items() if name not in self.lost]
            self.lost.update(new)
            left = self.bridges_left()  # the lock is reentrant
        for name, reason in new:
            then = "" if not self._running else (
                "; stopping (no bridge left)" if not left else "; no longer reading it, the other bridges go on")
            print(f"urb: {went_away(name, reason)}{then}", file=sys.stderr)

    def bridges_left(self) -> bool:
        with self.lock:
            return bool({ch.bridge for ch in self.channels} - set(self._found_lost))

    def run(self, duration_s: float | None, idle: Callable[[], None] | None = None) -> None:
        """Poll until `duration_s` passes, Ctrl-C (sets `interrupted`) or no bridge is left; then
        wait up to `grace_s` for the reads in flight, and stop. A second Ctrl-C while waiting
        stops at once (KeyboardInterrupt propagates)."""
        self._running = True
        try:
            try:
                self._poll(duration_s, idle)
            except KeyboardInterrupt:
                self.interrupted = True
            started = time.monotonic()
            told = False
            while time.monotonic() < started + self.grace_s:
                with self.lock:
                    in_flight = sum(ch.pending for ch in self.channels)
                if not in_flight:
                    break
                if not told and time.monotonic() > started + 0.5:
                    told = True
                    print(f"urb: waiting up to {self.grace_s:g} s for {in_flight} read(s) in flight "
                          f"(Ctrl-C to stop now)", file=sys.stderr)
                time.sleep(0.01)
        finally:
            self._running = False
            self.stop()

    def _poll(self, duration_s: float | None, idle: Callable[[], None] | None) -> None:
        start = time.monotonic_ns()
        end = None if duration_s is None else start + int(duration_s * 1e9)
        k = 0
        while end is None or time.monotonic_ns() < end:
            self._report_lost()
            if not self.bridges_left():
                return
            target = start + k * self.period_ns
            now = time.monotonic_ns()
            if target > now:
                time.sleep(min(target - now, 50_000_000) / 1e9)
                if idle is not None:
                    idle()
                continue
            missed = (now - target) // self.period_ns
            k += 1 + int(missed)  # never burst to catch up
            self.tick()
            if idle is not None:
                idle()

    def stop(self) -> None:
        """Record no completion from now on; note the reads still in flight."""
        with self.lock:
            if self._stopped:
                return
            self._stopped = True
            self.unanswered = [ch for ch in self.channels if ch.pending]
        self._report_lost()

    def silent_bridges(self) -> list[str]:
        """Bridges not lost whose last read of every mailbox got no response (UPLINK_TIMEOUT, or
        still in flight at the end): a bridge that stopped answering."""
        out: list[str] = []
        with self.lock:
            in_flight = {id(ch) for ch in self.unanswered}
            for name in dict.fromkeys(ch.bridge for ch in self.channels):
                if name in self.lost:
                    continue
                mine = [ch for ch in self.channels if ch.bridge == name]
                if all(id(ch) in in_flight or (ch.last_flags is not None and bool(ch.last_flags & ErrorFlag.UPLINK_TIMEOUT))
                       for ch in mine):
                    out.append(name)
        return out

    def report_end(self, ports: list[str]) -> bool:
        """Explain on stderr what went wrong during the run; True when something did (exit 1).
        Lost bridges were reported when found."""
        for label in sorted(self.vanished):
            print(f"urb: node {label} stopped answering (NO_NODE): check its connector and power, then run "
                  f"`urb scan {' '.join(ports)}`", file=sys.stderr)
        silent = self.silent_bridges()
        for name in silent:
            print(f"urb: the bridge on {name} stopped answering: the last read of each of its mailboxes got no "
                  f"response (UPLINK_TIMEOUT); check that it is powered and its cable", file=sys.stderr)
        late = [ch for ch in self.unanswered if ch.bridge not in self.lost]
        if late:
            print(f"urb: {len(late)} read(s) still in flight {self.grace_s:g} s after the end are not recorded: "
                  f"{', '.join(ch.label for ch in late)}", file=sys.stderr)
        return bool(self.lost or self.vanished or silent or late)


def stats_table(channels: list[Channel], title: str) -> Table:
    table = Table(title=title, show_edge=False, header_style="bold", title_justify="left")
    for col in ("node/outbox", "message", "values", "rate Hz", "mean ms", "p99 ms", "max ms", "ok", "errors", "skipped"):
        table.add_column(col, justify="right" if col not in ("node/outbox", "message", "values", "errors") else "left")
    for ch in channels:
        mean, p99, mx = ch.latency_ms()
        vals = " ".join(f"{n}={fmt_value(v)}{unit or ''}" for n, v, unit in ch.last[:6])
        if len(ch.last) > 6:
            vals += " ..."
        errs = " ".join(f"{k}:{v}" for k, v in sorted(ch.errors.items()))
        table.add_row(ch.label, ch.cls.NAME, vals, f"{ch.rate():.1f}", _ms(mean), _ms(p99), _ms(mx), str(ch.ok),
                      f"[red]{errs}[/]" if errs else "", str(ch.skipped))
    return table


def _ms(v: float) -> str:
    return "-" if math.isnan(v) else f"{v:.2f}"


@guarded
def run_monitor(args: argparse.Namespace) -> int:
    with connected(args.ports, args) as urb:
        channels = channels_for(urb, args.node, args.mailbox)

        def on_result(ch: Channel, req: NodeRequest) -> None:
            if req.ok:
                try:
                    ch.last = flatten(req.message())
                except URBError:
                    ch.last = [("raw", (req.data or b"").hex(), None)]

        poller = Poller(channels, args.rate, on_result, grace_s=args.timeout + 0.5)
        term = console()
        title = f"urb monitor: {', '.join(args.ports)} at {args.rate:g} Hz per mailbox"

        def final_title() -> str:
            return title + (" (stopped)" if poller.interrupted else "")

        if term.is_terminal:
            with Live(stats_table(channels, title), console=term, refresh_per_second=4, transient=False) as live:
                poller.run(args.duration, idle=lambda: live.update(stats_table(channels, title)))
                live.update(stats_table(channels, final_title()))
        else:
            poller.run(args.duration)
            term.print(stats_table(channels, final_title()))
        return EXIT_FAIL if poller.report_end(args.ports) else EXIT_OK


class _Sink:
    """Row writer: CSV streamed, Parquet collected and written at the end (pyarrow)."""

    def __init__(self, path: Path, columns: list[str]) -> None:
        self.path = path
        self.columns = columns
        self.rows = 0
        self.closed = False
        self.dropped = 0
        """Rows given after close(): not written."""
        self.parquet = path.suffix.lower() in (".parquet", ".pq")
        self._fh: TextIO | None = None
        self._writer: Any = None
        self._buffer: list[dict[str, Any]] = []
        if self.parquet:
            if importlib.util.find_spec("pyarrow") is None:
                raise URBError(f"{path}: writing Parquet needs pyarrow (pip install pyarrow); or give a .csv file")
        else:
            try:
                self._fh = path.open("w", newline="")
            except OSError as exc:
                raise URBError(f"{path}: cannot write the log ({exc.strerror})") from None
            self._writer = csv.DictWriter(self._fh, fieldnames=columns, extrasaction="ignore")
            self._writer.writeheader()

    def write(self, row: dict[str, Any]) -> None:
        if self.closed:
            self.dropped += 1
            return
        self.rows += 1
        if self.parquet:
            self._buffer.append(row)
        else:
            self._writer.writerow(row)

    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        if self._fh is not None:
            self._fh.close()
        if self.parquet:
            pa: Any = importlib.import_module("pyarrow")
            pq: Any = importlib.import_module("pyarrow.parquet")
            table = pa.table({c: [r.get(c) for r in self._buffer] for c in self.columns})
            pq.write_table(table, str(self.path))


@guarded
def run_log(args: argparse.Namespace) -> int:
    with connected(args.ports, args) as urb:
        channels = channels_for(urb, args.node, args.mailbox)
        fields: list[str] = []
        for ch in channels:
            fields += [n for n in field_names(ch.cls) if n not in fields]
        columns = ["t_submit_ns", "t_complete_ns", "latency_us", "bridge", "address", "node", "mailbox", "message",
                   "status"] + fields
        sink = _Sink(args.output, columns)
        write_lock = threading.Lock()

        def on_result(ch: Channel, req: NodeRequest) -> None:
            row: dict[str, Any] = {
                "t_submit_ns": req.submitted_ns, "t_complete_ns": req.completed_ns,
                "latency_us": round((req.latency_ns or 0) / 1e3, 1), "bridge": ch.node.manager.name,
                "address": ch.node.address, "node": ch.node.label, "mailbox": ch.box, "message": ch.cls.NAME,
                "status": req.flags.describe()}
            if req.ok:
                try:
                    ch.last = flatten(req.message())
                    row.update({n: v for n, v, _ in ch.last})
                except URBError:
                    row["status"] = "UNDECODABLE"
            with write_lock:
                sink.write(row)

        poller = Poller(channels, args.rate, on_result, grace_s=args.timeout + 0.5)
        try:
            poller.run(args.duration)  # returns after poller.stop(): no row comes in later
        finally:
            with write_lock:
                sink.close()
        stopped = " (stopped)" if poller.interrupted else ""
        console(stderr=True).print(stats_table(channels, f"urb log: {sink.rows} rows to {args.output}{stopped}"))
        return EXIT_FAIL if poller.report_end(args.ports) else EXIT_OK
