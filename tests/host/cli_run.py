"""Running `urb` in-process for the command-line tests: its exit status, stdout and stderr, and
never a traceback."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager

import pytest

from bridge_proc import BridgeProc
from urb.cli import main


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    """`urb ARGV`: (exit status, stdout, stderr), whether the command returned or argparse exited."""
    try:
        code = main(list(argv))
    except SystemExit as exc:
        code = exc.code  # type: ignore[assignment]
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


def usage_error(capsys: pytest.CaptureFixture[str], *argv: str) -> str:
    """Run a command that must end in a usage error (exit 2, the command's usage line, no
    traceback, whether argparse or the command itself found it); returns stderr."""
    code, _, err = run(capsys, *argv)
    assert code == 2, err
    assert err.startswith(f"usage: urb {argv[0]} ") and f"urb {argv[0]}: error: " in err, err
    return err


@contextmanager
def killed_after(bp: BridgeProc, seconds: float) -> Iterator[None]:
    """The bridge process is killed `seconds` into the block (its pty goes away)."""
    killer = threading.Timer(seconds, bp.kill)
    killer.start()
    try:
        yield
    finally:
        killer.join()
