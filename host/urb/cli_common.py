"""What the node commands share: opening the ports, finding a node, saying what failed, and
showing values in engineering units."""

from __future__ import annotations

import argparse
import enum
import sys
import typing
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from rich.console import Console

from urb_msgs import FieldInfo, Message

from .api import NodeAccessor, NodeRequest, URBInterface
from .cli_args import NodeSpec, check_ports
from .errors import DuplicateNodeError, ErrorFlag, FingerprintMismatchError, NoBridgeError, URBError, hint
from .managers import RS232Manager

EXIT_OK, EXIT_FAIL, EXIT_USAGE = 0, 1, 2


def console(stderr: bool = False) -> Console:
    """A console that does not wrap tables when the output is a file or a pipe."""
    stream = sys.stderr if stderr else sys.stdout
    return Console(file=stream, width=None if stream.isatty() else 200)


def fail(text: str) -> int:
    print(f"urb: {text}", file=sys.stderr)
    return EXIT_FAIL


def lost_after_s(args: argparse.Namespace) -> float:
    """How long a bridge may stay silent before it is declared lost, for --timeout."""
    return max(1.0, 5 * float(args.timeout))


def discovery_timeout_s(args: argparse.Namespace) -> float:
    """How long discovery of one bridge may take, for --timeout."""
    return max(3.0, 20 * float(args.timeout))


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
            m = RS232Manager(port, args.baud, timeout_s=args.timeout, lost_after_s=lost_after_s(args))
            try:
                urb.add_bus_manager(m, timeout_s=discovery_timeout_s(args))
            except NoBridgeError as exc:
                m.close()
                raise NoBridgeError(f"{exc} (This command used --baud {args.baud}.)") from None
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
    """A command whose expected failures (URBError) print one line and exit 1 (a closed output
    pipe is `urb.cli.main`'s: status 141, as for every command)."""
    def run(args: argparse.Namespace) -> int:
        try:
            return fn(args)
        except URBError as exc:
            return fail(str(exc))
    run.__doc__ = fn.__doc__
    return run


def find(urb: URBInterface, spec: NodeSpec) -> NodeAccessor:
    """The node a NODE argument names: by type and index (refused when flagged, with the bus
    addresses that reach it anyway), or by port and address."""
    if spec.address is not None:
        manager = next(rep.manager for rep in urb.reports.values() if rep.manager.name == spec.port)
        return urb.node_at(manager, spec.address)
    assert spec.info is not None
    try:
        return urb.find_node(spec.info, spec.index)
    except DuplicateNodeError as exc:
        where = ", ".join(f"{r.bridge.name}@{r.address}" for r in urb.nodes()
                          if r.class_id == spec.info.class_id and r.index == spec.index)
        raise DuplicateNodeError(f"{exc} Until then, give one by its bus address: {where}.") from None
    except FingerprintMismatchError as exc:
        rec = next(r for r in urb.nodes() if r.class_id == spec.info.class_id and r.index == spec.index)
        raise URBError(f"{exc} Until then, its bytes can be read by its bus address: "
                       f"urb read {rec.bridge.name} @{rec.address} MAILBOX.") from None


def went_away(bridge: str, reason: str | None) -> str:
    """'the bridge on PORT went away (why)', the port named once."""
    why = reason or "BRIDGE_LOST"
    if why.startswith(bridge + ": "):
        why = why[len(bridge) + 2:]
    if why.startswith("the bridge "):
        why = "it " + why[len("the bridge "):]
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
