"""`urb scan`, `urb read`, `urb write` (and the registration of `urb monitor`, `urb log`, which
live in cli_poll.py): the node tools.

Every command opens the given serial ports, discovers the nodes behind each bridge (the same
discovery as URBInterface.add_bus_manager) and then works on nodes by name, wherever they are,
or by bus address. A bad argument (a number out of range, a port given twice, a node type,
mailbox or FIELD=VALUE the schemas refuse) is a usage error, found before any port is opened
when the schemas suffice: the command's usage line, one explanation, exit status 2. Expected
failures of the bus (no such port, permission denied, no bridge answering, a node not found or
vanished, a bridge that went away) print one explanation and exit with status 1. Never a
traceback.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

from rich.markup import escape
from rich.table import Table

from urb_msgs import NodeInfo

from .api import DUPLICATE, MISMATCH, UNKNOWN_CLASS, NodeAccessor, NodeRecord
from .cli_args import (
    BAUD,
    COUNT,
    DURATION,
    INTERVAL,
    MAX_INTERVAL_S,
    MAX_RATE_HZ,
    MAX_TIMEOUT_S,
    RATE,
    TIMEOUT,
    NodeSpec,
    UsageError,
    check_node_mailboxes,
    check_ports,
    mailbox_number,
    parse_mailbox,
    parse_node,
    parse_values,
)
from .cli_common import EXIT_FAIL, EXIT_OK, connected, console, fail, find, flatten, fmt_value, guarded, request_failure
from .cli_poll import run_log, run_monitor
from .errors import ErrorFlag
from .managers.base import encode_message

PORT_HELP = "serial port of a bridge (e.g. /dev/ttyS0, /dev/ttyUSB0)"
NODE_HELP = ("the node: NAME[:INDEX] (MotorDriver:2) or CLASS[:INDEX] (0x10:2), INDEX 0..63 (default 0); or "
             "its bus address [PORT]@ADDR (@0x30; PORT may be left out when one port is given)")
MBOX_HELP = "mailbox number (0..7) or the name of its message (e.g. MotorFeedback)"

PORTS_TEXT = """\
Ports: every PORT is opened at --baud (8N1), the bridge at address 0 is asked for its
identification, told to rescan its downlink, and every node that answers is identified. A
device whose answer is not a URB bridge's identification that decodes and checks is no bridge
(a wrong --baud makes a bridge's answers look like noise). Values are shown and given in
engineering units from the schema (raw * scale + offset). A port whose last user ended without
waiting for its answers (Ctrl-C, kill) is used once their time is over: with --timeout up to
0.3, at most 0.3 s after Ctrl-C and 1.3 s after kill -9 (records in $URB_STATE_DIR, else
$XDG_RUNTIME_DIR/urb, else /tmp/urb-UID)."""

NODES_TEXT = """\
Nodes: NAME[:INDEX] or CLASS[:INDEX] names a node type of the host's schemas and its index; a
node that `urb scan` flags (DUPLICATE, MISMATCH) is refused by name. [PORT]@ADDR names
whatever answered discovery at downlink address ADDR (1..127; @0 is the bridge itself) behind
PORT, flagged or not: duplicates are told apart by their address, and a node whose class the
schemas do not declare (UNKNOWN_CLASS) or that was built from another schema (MISMATCH) shows
its mailboxes as raw bytes (message RawMailbox, one field `data`, in hex) of the sizes its
identification reports."""

USAGE_ERRORS = """\
  2  a usage error, with the command's usage line and one explanation: an option out of
     range (never NaN or infinity), a port given twice (also through a symbolic link), a
     NODE or MAILBOX that is malformed or that the host's schemas do not have (mailbox 9,
     mailbox -1, MotorDriver:x, an unknown node type); all found before any port is opened.
     For a node given by address, a mailbox its identification does not report is found once
     it has answered."""

SCAN_EPILOG = PORTS_TEXT + """

Exit status:
  0  every node answered and is usable
  1  a failure: a port missing, not a serial port or not permitted, no bridge answering, a
     node flagged DUPLICATE, MISMATCH or UNKNOWN_CLASS (a line under the table says what to
     do about each)
""" + USAGE_ERRORS

READ_EPILOG = PORTS_TEXT + "\n\n" + NODES_TEXT + """

Exit status:
  0  every read succeeded
  1  a failure: a port missing, not a serial port or not permitted, no bridge answering, the
     node not found or flagged, a read that failed, the bridge gone away
""" + USAGE_ERRORS

WRITE_EPILOG = PORTS_TEXT + "\n\n" + NODES_TEXT + """

Exit status:
  0  the node stored the message
  1  a failure: a port missing, not a serial port or not permitted, no bridge answering, the
     node not found or flagged, the write refused or unconfirmed, the bridge gone away
""" + USAGE_ERRORS + """
     So is a FIELD=VALUE or --raw HEX that the schema (or the node's identification)
     refuses: a value out of range or not a number, the wrong number of bytes; the message
     names the field and the values it takes."""

POLL_EPILOG = PORTS_TEXT + "\n\n" + NODES_TEXT + """

Bridges that go away: a bridge is lost (BRIDGE_LOST) when its port fails or it sends nothing
for max(1 s, 5 x --timeout) while reads are outstanding; that is said once on stderr. With
--reconnect (the default of `urb monitor`) its port is reopened and the bridge rediscovered in
the background, 0.25 s after the loss, then at doubling intervals up to 4 s, until it answers:
a line says when it is back and reading resumes (nodes not found again then fail
UNKNOWN_NODE). With --no-reconnect (the default of `urb log`) the bridge is no longer read, the
other bridges go on, and the command stops when no bridge is left. At the end, reads still in
flight are waited for up to --timeout (plus 0.5 s).

Exit status:
  0  success, also when a bridge went away and came back
  1  a failure: a port missing, not a serial port or not permitted, no bridge answering, a
     node not found or flagged, a node that stopped answering (NO_NODE), a bridge that went
     away and was not back at the end, or a bridge whose last read of every mailbox got no
     response
""" + USAGE_ERRORS


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
        "same class and index are both flagged DUPLICATE; a node built from another schema is\n"
        "flagged MISMATCH; a class the host's schemas do not declare UNKNOWN_CLASS. Under the table,\n"
        "one line per flagged node says what to do about it.",
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
        "  urb read /dev/ttyS0 Imu 1 --count 10 --interval 0.1\n  urb read /dev/ttyS0 0x20 1 --json\n"
        "  urb read /dev/ttyS0 @0x30 1 --raw      (the node at address 0x30, whatever its class)")
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
        "comma-separated lists, bytes in hex); --defaults sets the fields you leave out to zero.\n"
        "--raw HEX writes bytes as they are. Options may come before, between or after the\n"
        "FIELD=VALUE words. The command succeeds only when the bridge reports that the node\n"
        "stored the message.",
        epilog=WRITE_EPILOG + "\n\nExamples:\n  urb write /dev/ttyS0 MotorDriver:2 MotorCommand voltage=1.5\n"
        "  urb write /dev/ttyS0 MotorDriver:0 2 mode=LOCAL_PD kp=0.01 kd=0 target=2000 voltage_limit=6\n"
        "  urb write /dev/ttyS0 MotorDriver:0 2 --defaults mode=LOCAL_PD target=2000\n"
        "  urb write /dev/ttyS0 Imu 0 --raw 030500000000\n"
        "  urb write /dev/ttyS0 @0x30 1 --raw 0102030405060708")
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
                "pending (counted as skipped). A bridge that goes away is reconnected when it comes\n"
                "back (--no-reconnect to stop reading it instead). Stops after --duration or on Ctrl-C."),
            epilog=POLL_EPILOG + ("\n\nExamples:\n  urb log /dev/ttyS0 -o run.csv --node MotorDriver:0 --mailbox 1 --rate 1000 --duration 10"
                                    if is_log else
                                    "\n\nExamples:\n  urb monitor /dev/ttyS0\n  urb monitor /dev/ttyS0 --node Imu --rate 100\n"
                                    "  urb monitor /dev/ttyS0 /dev/ttyUSB0 --node /dev/ttyUSB0@0x30 --mailbox 1"))
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
        p.add_argument("--reconnect", action=argparse.BooleanOptionalAction, default=not is_log,
                       help="reopen a bridge that went away and read it again once it answers "
                            f"(default: {'off' if is_log else 'on'})")
        common(p)
        p.set_defaults(run=run_log if is_log else run_monitor)


# --------------------------------------------------------------------------------------------
# scan
# --------------------------------------------------------------------------------------------

@guarded
def run_scan(args: argparse.Namespace) -> int:
    check_ports(args.ports)
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
                    out.print(f"[yellow]warning:[/] {p}", highlight=False, soft_wrap=True)
            for line in flag_advice(rows):  # one line each, never cut (a terminal wraps it)
                out.print(f"[red]{escape(line)}[/]", highlight=False, soft_wrap=True)
        return EXIT_FAIL if any(r.flags for r in rows) else EXIT_OK


def flag_advice(rows: list[NodeRecord]) -> list[str]:
    """One line per flagged node (per group of duplicates): what is wrong and what to do, with
    the bus address that reaches it meanwhile. Only the flags that were raised."""
    lines: list[str] = []
    duplicates: dict[tuple[int, int], list[NodeRecord]] = defaultdict(list)
    for r in rows:
        if DUPLICATE in r.flags:
            duplicates[(r.class_id, r.index)].append(r)
    for same in duplicates.values():
        where = ", ".join(f"{r.bridge.name}@{r.address}" for r in same)
        lines.append(f"DUPLICATE: {same[0].label} answers at {len(same)} places ({where}): give each node a "
                     f"distinct index, then scan again; until then `urb read`, `write` and `monitor` refuse it by "
                     f"name and reach each one by its address ({where}).")
    for r in rows:
        at = f"{r.bridge.name}@{r.address}"
        if MISMATCH in r.flags and r.info is not None:
            differs = (f"reports layout fingerprint {r.fingerprint:08x}, but this host's {r.info.schema_file} gives "
                       f"{r.info.fingerprint:08x}" if r.fingerprint != r.info.fingerprint else
                       f"reports the fingerprint of this host's {r.info.schema_file} but other mailbox sizes")
            lines.append(f"MISMATCH: {r.label} at {at} {differs}: the node and this host were built from different "
                         f"schemas. Rebuild the node's firmware or this host from the same schema (`urb gen`); until "
                         f"then its bytes can be read by address: urb read {r.bridge.name} @{r.address} MAILBOX.")
        if UNKNOWN_CLASS in r.flags:
            lines.append(f"UNKNOWN_CLASS: the node at {at} has class 0x{r.class_id:02x}, which the host's schemas do "
                         f"not declare. Add its schema (spec/schema, then `urb gen`) to use it by name; until then "
                         f"its bytes can be read by address: urb read {r.bridge.name} @{r.address} MAILBOX.")
    return lines


def _row_dict(r: NodeRecord) -> dict[str, Any]:
    return {"bridge": r.bridge.name, "address": r.address, "node": r.name, "class": r.class_id, "index": r.index,
            "fingerprint": f"{r.fingerprint:08x}",
            "schema_fingerprint": None if r.expected_fingerprint is None else f"{r.expected_fingerprint:08x}",
            "schema_file": r.info.schema_file if r.info else None, "firmware": r.firmware, "flags": sorted(r.flags)}


# --------------------------------------------------------------------------------------------
# read / write
# --------------------------------------------------------------------------------------------

def _target(args: argparse.Namespace, direction: str) -> tuple[NodeSpec, int | str]:
    """NODE and MAILBOX, checked before the port is opened (UsageError when wrong)."""
    spec = parse_node(args.node, [args.port])
    box = parse_mailbox(args.mailbox)
    check_node_mailboxes(spec, [box], direction)
    return spec, box


def _shown(node: NodeAccessor, spec: NodeSpec) -> str:
    """How a node is named in the output: class and index, and the address it was given by."""
    return node.label if spec.address is None else f"{node.label}@{node.address}"


@guarded
def run_read(args: argparse.Namespace) -> int:
    spec, box_spec = _target(args, "outbox")
    with connected([args.port], args) as urb:
        node = find(urb, spec)
        name = _shown(node, spec)
        box = mailbox_number(node.info, box_spec, "outbox", name)
        mb = node.info.mailbox("outbox", box)
        assert mb is not None
        status = EXIT_OK
        for k in range(args.count):
            if k:
                time.sleep(args.interval)
            req = node.submit_request(node.new_request().read(box))
            if not req.wait(args.timeout * 20 + 1):
                return fail(f"{name}: no completion (is the bridge still running?)")
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
            values = flatten(req.message())
            if args.json:
                print(json.dumps({"node": name, "mailbox": box, "message": mb.message.NAME, "latency_us": round(lat, 1),
                                  "fields": {n: v for n, v, _ in values}}))
            else:
                print(f"{name} outbox {box} {mb.message.NAME} ({node.record.location}, {lat:.0f} us)")
                width = max(len(n) for n, _, _ in values)
                for n, v, unit in values:
                    print(f"  {n:<{width}}  {fmt_value(v)}{' ' + unit if unit else ''}")
        return status


def _payload(info: NodeInfo, box: int, args: argparse.Namespace, raw: bytes | None, who: str) -> bytes:
    """The bytes to write to inbox `box` of node type `info`: --raw HEX, or the FIELD=VALUE words
    encoded; UsageError when the schema (or the node's identification) refuses them."""
    mb = info.mailbox("inbox", box)
    assert mb is not None
    if raw is None:
        if not args.values and not args.defaults:
            names = ", ".join(f"{f.name}" + (f" [{f.unit}]" if f.unit else "") for f in mb.message.FIELDS)
            raise UsageError(f"give the fields of {mb.message.NAME} as FIELD=VALUE: {names}")
        payload = encode_message(parse_values(mb.message, args.values, args.defaults))
    else:
        payload = raw
    if len(payload) != mb.size:
        given = "--raw gives" if raw is not None else "the values give"
        raise UsageError(f"{who} inbox {box} takes {mb.size} bytes, {given} {len(payload)}")
    return payload


@guarded
def run_write(args: argparse.Namespace) -> int:
    raw: bytes | None = None
    if args.raw is not None:
        if args.values:
            raise UsageError(f"give either FIELD=VALUE words or --raw HEX, not both (got --raw and {' '.join(args.values)})")
        try:
            raw = bytes.fromhex(args.raw)
        except ValueError:
            raise UsageError(f"--raw {args.raw!r} is not hex (two hex digits a byte, e.g. --raw 0a0b)") from None
    spec, box_spec = _target(args, "inbox")
    if spec.info is not None:  # known from the schema: refused before the port is opened
        _payload(spec.info, mailbox_number(spec.info, box_spec, "inbox"), args, raw, spec.info.name)
    with connected([args.port], args) as urb:
        node = find(urb, spec)
        name = _shown(node, spec)
        box = mailbox_number(node.info, box_spec, "inbox", name)
        mb = node.info.mailbox("inbox", box)
        assert mb is not None
        payload = _payload(node.info, box, args, raw, spec.info.name if spec.info is not None else name)
        req = node.submit_request(node.new_request().write(box, payload))
        if not req.wait(args.timeout * 20 + 1):
            return fail(f"{name}: no completion (is the bridge still running?)")
        if not req.ok:
            return fail(request_failure(node, req))
        print(f"{name} inbox {box} {mb.message.NAME}: stored ({(req.latency_ns or 0) / 1e3:.0f} us)")
        return EXIT_OK
