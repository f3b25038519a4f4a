"""`urb demo`: generate every codec from the bundled schemas and round-trip every message through
Python and C, printing a table. (The SensoRHex simulation will take this command over.)"""

from __future__ import annotations

import argparse
import random
import time
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table

import urb_msgs
from urb_codegen.errors import SchemaErrors
from urb_codegen.generate import REPO, check_fresh, generate, load_bundled
from urb_msgs import DecodeError, Message
from urb_msgs.urb_core import DownlinkReadResponse

from .cli_args import integer
from .codec_driver import CodecDriver, DriverError, build_driver
from .msgtools import random_message, to_plain

SAMPLES = integer("a number of messages, 1 or more", 1)
SEED = integer("a whole number", -(2**63), 2**63 - 1)

ERROR_NAMES = {urb_msgs.TooShortError: "short", urb_msgs.TooLongError: "long",
               urb_msgs.ChecksumError: "checksum", urb_msgs.OutOfRangeError: "range"}


def register(sub: Any) -> None:
    """Add `urb demo` to the `urb` parser."""
    demo = sub.add_parser(
        "demo", help="round-trip every message through the Python and C codecs",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Generate the C and Python codecs from spec/schema into build/demo/, build the C codec\n"
        "driver (with AddressSanitizer and UndefinedBehaviorSanitizer), then for every message:\n"
        "encode random valid messages in Python, decode and re-encode them in C, decode C's bytes\n"
        "in Python again, and corrupt one bit of every checked frame to show both sides reject it.\n"
        "\n"
        "Exit status: 0 every round trip is identical; 1 a message type differs, or the schemas,\n"
        "the codecs or the C driver could not be built; 2 a usage error (--samples below 1, a\n"
        "--seed that is not a whole number).",
    )
    demo.add_argument("--samples", type=SAMPLES, default=200, metavar="N",
                      help="random messages per type, 1 or more (default 200)")
    demo.add_argument("--seed", type=SEED, default=1, help="random seed (default 1); the same seed gives the same table")
    demo.add_argument("--out", type=Path, default=REPO / "build" / "demo", metavar="DIR", help="work folder (default build/demo)")
    demo.set_defaults(run=run_demo)


def _decode(cls: type[Message], frame: bytes, like: Message) -> Message:
    if isinstance(like, DownlinkReadResponse):
        return DownlinkReadResponse.decode(frame, select=like.select)
    decoded: Message = cls.decode(frame)
    return decoded


def _prefix(msg: Message) -> bytes | None:
    if isinstance(msg, DownlinkReadResponse):
        return msg._pack_implicit().to_bytes(1, "little")
    return None


def _error_name(exc: DecodeError) -> str:
    return next(name for cls, name in ERROR_NAMES.items() if isinstance(exc, cls))


def run_demo(args: argparse.Namespace) -> int:
    console = Console(highlight=False, width=None if Console().is_terminal else 132)
    started = time.monotonic()
    try:
        schemas = load_bundled()
    except SchemaErrors as exc:
        print(exc.render())
        return 1
    out: Path = args.out
    written = generate(schemas, out / "c", out / "python" / "urb_msgs")
    console.print(f"Generated {len(written)} files from {len(schemas)} schemas into {out}")
    fresh = check_fresh(schemas)
    console.print("Committed gen/ matches the schemas" if fresh.fresh else "[yellow]gen/ is stale: run `make gen`[/]")
    try:
        exe = build_driver(out / "c", out / "codec_driver")
    except DriverError as exc:
        console.print(f"[red]{exc}[/]")
        return 1
    console.print(f"Built the C codec driver with sanitizers: {exe}\n")

    rng = random.Random(args.seed)
    table = Table(title=f"Every message through Python -> C -> Python ({args.samples} random messages each, seed {args.seed})",
                  caption="unchecked: mailbox payloads; the link frame that carries them adds the check")
    for col in ("message", "schema", "bytes", "fingerprint", "Py>C>Py same", "fields agree", "bit flips caught C / Py"):
        table.add_column(col, justify="right" if col != "message" else "left", no_wrap=True)
    failures = 0
    with CodecDriver(exe) as driver:
        for name in sorted(urb_msgs.MESSAGES):
            cls = urb_msgs.MESSAGES[name]
            identical = agree = rejected_c = rejected_py = corrupted = 0
            checked = " check " in cls.LAYOUT
            for _ in range(args.samples):
                msg = random_message(cls, rng)
                frame = msg.encode()
                answer = driver.roundtrip(name, frame, _prefix(msg))
                if answer.ok and answer.frame == frame and _decode(cls, answer.frame, msg) == msg:
                    identical += 1
                plain = to_plain(msg)
                if answer.ok and all(answer.fields.get(k) == v for k, v in plain.items()):
                    agree += 1
                if checked:
                    corrupted += 1
                    bad = bytearray(frame)
                    bit = rng.randrange(8 * len(bad))
                    bad[bit // 8] ^= 1 << (bit % 8)
                    rejected_c += not driver.roundtrip(name, bytes(bad), _prefix(msg)).ok
                    try:
                        _decode(cls, bytes(bad), msg)
                    except DecodeError:
                        rejected_py += 1
            ok = identical == agree == args.samples and rejected_c == rejected_py == corrupted
            failures += not ok
            style = "" if ok else "[red]"
            size = str(cls.MIN_SIZE) if cls.MIN_SIZE == cls.MAX_SIZE else f"{cls.MIN_SIZE}..{cls.MAX_SIZE}"
            table.add_row(f"{style}{name}", cls.__module__.rsplit(".", 1)[-1], size, f"{cls.FINGERPRINT:08x}",
                          f"{identical}/{args.samples}", f"{agree}/{args.samples}",
                          f"{rejected_c}/{corrupted} / {rejected_py}/{corrupted}" if checked else "unchecked")
    console.print(table)
    verdict = "[green]all round trips identical[/]" if not failures else f"[red]{failures} message type(s) differ[/]"
    console.print(f"{verdict} in {time.monotonic() - started:.1f} s")
    return 0 if not failures else 1
