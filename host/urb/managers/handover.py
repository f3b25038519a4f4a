"""Hand-over of a port between host processes (spec/tla/Bridge.tla `HostRestart`).

A response carries only its request's 4-bit sequence number, and a new process (each `urb`
command is one) numbers its requests from 1 again. A process that ends without a draining
`close()` (killed, crashed, Ctrl-C, `close(drain=False)`) can leave requests the bridge still
answers; their late responses would reach the next process as the answers to its own requests.

So every process that opens a port keeps a small record, `PortHandover`, of until when responses
to its requests may still arrive (the newest request's sending + its lifetime, `placeholder_ns`:
by then the bridge no longer holds it, the premise of `ResponseMatcher.expire`). The next
process to open the port reads it and sends nothing before that instant (`MatchingCore.hand_over`;
what it receives meanwhile answers none of its requests and is discarded). A draining close
leaves nothing to wait for and removes the record.

The record is a file per port path in `$URB_STATE_DIR`, else `$XDG_RUNTIME_DIR/urb`, else
`<tmp>/urb-<uid>`; it holds a wall-clock time in nanoseconds (comparable between processes). While
requests go out it is written ahead by `AHEAD_NS`, so a busy process writes it about once a
second, and a process killed without notice makes the next one wait at most that much longer.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

AHEAD_NS = 1_000_000_000
"""How far beyond the newest request's lifetime the record is written while requests go out."""

MAX_WAIT_NS = 10 * AHEAD_NS
"""The longest a record makes the next process wait: a record further ahead (a wall clock set
back, a damaged file) is cut to this."""


def state_dir() -> Path:
    """Where the records live (created on first use)."""
    explicit = os.environ.get("URB_STATE_DIR")
    if explicit:
        return Path(explicit)
    runtime = os.environ.get("XDG_RUNTIME_DIR")
    if runtime:
        return Path(runtime) / "urb"
    return Path(tempfile.gettempdir()) / f"urb-{os.getuid()}"


def record_name(port: str) -> str:
    """The record's file name for `port` (its absolute path, '/' as '_')."""
    return os.path.abspath(port).strip("/").replace("/", "_") + ".handover"


# lobster-trace: urb.HOST_006
class PortHandover:
    """The record of one port, for the process that has it open. Times are the caller's
    monotonic nanoseconds (`time.monotonic_ns`, the threaded managers' clock)."""

    def __init__(self, port: str, directory: Path | None = None) -> None:
        self.path = (directory or state_dir()) / record_name(port)
        self._written_ns: int | None = None  # monotonic instant the record now says
        self._warned = False

    def predecessor_until(self, now_ns: int) -> int | None:
        """None when the previous process closed with a drain (or none had the port): nothing of
        it is left. Else when the responses to its requests are over (maybe already). An
        unreadable record counts as one written just now by a process using the default
        lifetime."""
        try:
            text = self.path.read_text(encoding="ascii").strip()
        except FileNotFoundError:
            return None
        except (OSError, UnicodeDecodeError):
            text = ""
        try:
            until = self._to_monotonic(int(text))
        except ValueError:
            from .rs232_core import PLACEHOLDER_NS  # here: rs232_core imports base, which imports this

            until = now_ns + PLACEHOLDER_NS
        return min(until, now_ns + MAX_WAIT_NS)

    def cover(self, until_ns: int, now_ns: int) -> None:
        """Responses to this process's requests may come until `until_ns`: make sure the record
        says so (written ahead by `AHEAD_NS`, so not on every request)."""
        if self._written_ns is None or until_ns > self._written_ns:
            self._write(until_ns + AHEAD_NS, now_ns)

    def settle(self, until_ns: int | None, now_ns: int) -> None:
        """At close: the exact instant the responses are over (`None`: nothing left in flight,
        the record is removed)."""
        if until_ns is None or until_ns <= now_ns:
            try:
                self.path.unlink()
            except FileNotFoundError:
                pass
            except OSError as exc:
                self._warn(exc)
            self._written_ns = None
            return
        self._write(until_ns, now_ns)

    def _write(self, until_ns: int, now_ns: int) -> None:
        wall = time.time_ns() + (until_ns - now_ns)
        tmp = self.path.with_suffix(f".{os.getpid()}.tmp")
        try:
            self.path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)  # the user's own
            tmp.write_text(f"{wall}\n", encoding="ascii")
            os.replace(tmp, self.path)  # a reader never sees half a record
        except OSError as exc:
            self._warn(exc)
            return
        self._written_ns = until_ns

    def _warn(self, exc: OSError) -> None:
        """The uplink works without the record: say so once, go on."""
        if not self._warned:
            self._warned = True
            print(f"urb: cannot write {self.path} ({exc}); a process opening the port after this one "
                  f"ends without close() may take its late responses. Set URB_STATE_DIR to a "
                  f"writable directory.", file=sys.stderr)

    @staticmethod
    def _to_monotonic(wall_ns: int) -> int:
        # Both clocks are read now, the wall clock first: converting with the caller's `now_ns`
        # made the instant early by however long ago the caller read it (the file read, a
        # preempted thread: 0.9 ms in a clean make check), and the next process sent that early.
        wall_now = time.time_ns()
        return time.monotonic_ns() + (wall_ns - wall_now)


__all__ = ["AHEAD_NS", "MAX_WAIT_NS", "PortHandover", "record_name", "state_dir"]
