"""The `urb` command line: one entry point, one module per command family."""

from __future__ import annotations

import argparse
import os
import signal
import sys
from collections.abc import Sequence
from pathlib import Path

from urb_sim import cli as sim_cli

from . import cli_nodes, cli_schema, demo
from .cli_args import UsageError
from .version import version_text

DESCRIPTION = "URB, the Universal Robot Bus: schema compiler, codecs and tools."
EPILOG = """\
Run `urb COMMAND --help` for the manual of one command.

Exit status (every command; its own --help says what counts as a failure there):
  0    success
  1    a failure: a check that did not pass, a port, bridge, node or file that could not be
       used; stderr says what happened and what to do next
  2    a usage error: no command, an unknown command or option, a value out of range, an argument that
       names nothing (a node type, mailbox or field the schemas do not have); the command's
       usage line and one explanation on stderr
  130  interrupted by Ctrl-C before the command could finish (`urb monitor` and `urb log`
       stop cleanly on the first Ctrl-C and exit 0 or 1 as above)
  141  the reader of the output went away (`urb sim params | head -1`): the command ends
       quietly, as other Unix tools do (128 + SIGPIPE)

`urb --version` prints the version, the commit it was run from (or "unknown commit" outside a
git checkout) and the layout fingerprint of the bundled schemas."""


class VersionAction(argparse.Action):
    """--version: computed when asked for (it runs git), printed, exit 0."""

    def __init__(self, option_strings: list[str], dest: str = argparse.SUPPRESS, **kwargs: object) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS,
                         help="print the version, commit and schema layout fingerprint, and exit")

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: object,
                 option_string: str | None = None) -> None:
        print(version_text())
        parser.exit(0)


def build_parser() -> argparse.ArgumentParser:
    """The full argument parser: every command registered by its module."""
    return _build()[0]


def _build() -> tuple[argparse.ArgumentParser, dict[str, argparse.ArgumentParser]]:
    """The parser and each command's own parser, by name (for usage errors found later)."""
    parser = argparse.ArgumentParser(
        prog="urb", description=DESCRIPTION, epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--version", action=VersionAction)
    sub = parser.add_subparsers(title="commands", dest="command", metavar="COMMAND")
    cli_nodes.register(sub)
    cli_schema.register(sub)
    demo.register(sub)
    sim_cli.register(sub)
    _register_report(sub)
    return parser, dict(sub.choices)


def _register_report(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """`urb report`: the certification evidence report and its gate (report/urb_report/cli.py,
    imported only when the command runs)."""
    p = sub.add_parser(
        "report", help="certification evidence report (HTML, PDF) and its gate",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Collect the evidence records of build/evidence/, trace them to the requirements of "
                    "spec/requirements/ and write build/report/index.html and build/report/report.pdf. "
                    "Nothing is rerun: each activity of `make check` writes its record, this reads them.",
        epilog="Exit status: 0 written (with --gate: and the gate passed), 1 the gate failed (one line per\n"
               "problem, naming its requirement) or the report could not be made (the message says why),\n"
               "2 a usage error (an unknown option).\n"
               "Example: make check && urb report   (then open build/report/report.pdf)")
    p.add_argument("--gate", action="store_true", help="exit 1 when the gate fails (make check runs this)")
    p.add_argument("--no-pdf", action="store_true", help="write the HTML only (no Chromium)")
    p.add_argument("--update-baseline", action="store_true",
                   help="accept changed requirement texts that spec/requirements/history.trlc explains")
    p.add_argument("--evidence", type=Path, default=None, metavar="DIR", help="records from DIR, not build/evidence/")
    p.add_argument("--out", type=Path, default=None, metavar="DIR", help="write to DIR, not build/report/")
    p.set_defaults(run=_run_report)


def _run_report(args: argparse.Namespace) -> int:
    from urb_report import cli as report_cli

    if args.out is None:
        args.out = report_cli.REPORT_DIR
    return report_cli.run(args)


def parse(parser: argparse.ArgumentParser, commands: dict[str, argparse.ArgumentParser],
          argv: list[str]) -> argparse.Namespace:
    """Parse the command line; options may come anywhere among a command's positionals
    (`urb write PORT NODE 2 --defaults mode=LOCAL_PD`). A usage error shows the usage of the
    command it belongs to, not the top-level one, and exits with status 2."""
    args, extras = parser.parse_known_args(argv)
    if not extras:
        return args
    command = commands.get(getattr(args, "command", None) or "")
    if command is None:
        parser.error(f"unrecognized arguments: {' '.join(extras)}")
    # The top level has no option taking a value, so the first word naming the command is it.
    rest = argv[argv.index(args.command) + 1:]
    try:
        return command.parse_intermixed_args(rest, argparse.Namespace(command=args.command))
    except TypeError:  # a command with subcommands of its own cannot be parsed intermixed
        command.error(f"unrecognized arguments: {' '.join(extras)}")


def main(argv: Sequence[str] | None = None) -> int:
    """Run one command; returns the process exit status (0 ok, 1 failed check, 2 usage error)."""
    parser, commands = _build()
    args = parse(parser, commands, list(sys.argv[1:] if argv is None else argv))
    if not getattr(args, "run", None):
        parser.error("give a COMMAND (`urb --help` lists them)")
    try:
        status: int = args.run(args)
        sys.stdout.flush()  # here, not at exit, so that a closed pipe is caught below
    except UsageError as exc:  # found by the command itself (e.g. a FIELD=VALUE the schema refuses)
        command = commands.get(args.command, parser)
        command.print_usage(sys.stderr)
        print(f"{command.prog}: error: {exc}", file=sys.stderr)
        return 2
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
