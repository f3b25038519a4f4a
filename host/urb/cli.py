"""The `urb` command line: one entry point, one module per command family."""

from __future__ import annotations

import argparse
import os
import signal
import sys
from collections.abc import Sequence

from urb_sim import cli as sim_cli

from . import __version__, cli_nodes, cli_schema, demo

DESCRIPTION = "URB, the Universal Robot Bus: schema compiler, codecs and tools."
EPILOG = "Run `urb COMMAND --help` for the options of one command."


def build_parser() -> argparse.ArgumentParser:
    """The full argument parser: every command registered by its module."""
    parser = argparse.ArgumentParser(
        prog="urb", description=DESCRIPTION, epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--version", action="version", version=f"urb {__version__}")
    sub = parser.add_subparsers(title="commands", dest="command", metavar="COMMAND")
    cli_nodes.register(sub)
    cli_schema.register(sub)
    demo.register(sub)
    sim_cli.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run one command; returns the process exit status (0 ok, 1 failed check, 2 usage error)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "run", None):
        parser.print_help()
        return 2
    try:
        status: int = args.run(args)
        sys.stdout.flush()  # here, not at exit, so that a closed pipe is caught below
    except KeyboardInterrupt:
        print("urb: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # the reader went away (`urb sim params | head`): stop quietly, as other Unix tools do;
        # stdout goes to /dev/null so that the interpreter's final flush does not fail again
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 128 + signal.SIGPIPE
    return status


if __name__ == "__main__":
    sys.exit(main())
