"""Bridge processes on pseudo-terminals, and the `fake_bridge` fixture, for the host library tests.

Test modules import the fixture explicitly (`from bridge_proc import fake_bridge`): a
conftest.py here would shadow tests/conftest.py, which other suites import by name.

`BridgeProc` runs a bridge as its own process with its RS232 uplink on a pty and a stable
symlink to it (so a restarted bridge is reopened at the same path, like /dev/ttyS0).
"""

from __future__ import annotations

import os
import select
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
FAKE_BRIDGE = HERE / "fake_bridge.py"

SENSORHEX = [f"MotorDriver:{i}@{0x10 + i}" for i in range(6)] + [
    "BatteryManager:0@32", "Imu:0@48", "IrDistance:0@49"]
"""The SensoRHex hexapod: six motor drivers, battery manager, IMU, IR distance node."""


class BridgeProc:
    """A bridge process behind a pty; `link` always points at its current pty."""

    def __init__(self, argv: list[str], link: Path) -> None:
        self.argv = argv
        self.link = link
        self.proc: subprocess.Popen[bytes] | None = None
        self.pty: str = ""
        self._buf = b""

    def start(self) -> BridgeProc:
        self.proc = subprocess.Popen(self.argv + ["--link", str(self.link)], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        first = self.readline(10.0)
        if not first.startswith("PTY "):
            err = self.proc.stderr.read().decode() if self.proc.stderr and self.proc.poll() is not None else ""
            raise RuntimeError(f"bridge did not print its pty: {first!r} {err}")
        self.pty = first.split(" ", 1)[1]
        assert self.readline(10.0) == "READY"
        return self

    def readline(self, timeout: float = 5.0) -> str:
        assert self.proc is not None and self.proc.stdout is not None
        fd = self.proc.stdout.fileno()
        deadline = time.monotonic() + timeout
        while b"\n" not in self._buf:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError(f"bridge process said nothing for {timeout} s")
            ready, _, _ = select.select([fd], [], [], left)
            if ready:
                chunk = os.read(fd, 4096)
                if not chunk:
                    raise EOFError("bridge process ended")
                self._buf += chunk
        line, self._buf = self._buf.split(b"\n", 1)
        return line.decode().strip()

    def cmd(self, line: str) -> str:
        """Send a control command; returns the text after ``ok``."""
        assert self.proc is not None and self.proc.stdin is not None
        self.proc.stdin.write(line.encode() + b"\n")
        self.proc.stdin.flush()
        answer = self.readline()
        assert answer.startswith("ok"), f"{line!r}: {answer}"
        return answer[3:]

    def kill(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGKILL)
            self.proc.wait(5)
        self._buf = b""

    def restart(self) -> BridgeProc:
        self.kill()
        return self.start()

    def close(self) -> None:
        self.kill()
        for stream in (self.proc.stdin, self.proc.stdout, self.proc.stderr) if self.proc else ():
            if stream is not None:
                stream.close()


@pytest.fixture
def fake_bridge(tmp_path: Path) -> Iterator[Callable[..., BridgeProc]]:
    """Factory: ``fake_bridge(nodes=[...], name="tty0", extra=[...])`` -> a started BridgeProc."""
    procs: list[BridgeProc] = []

    def make(nodes: list[str] | None = None, name: str = "ttyURB0", extra: list[str] | None = None) -> BridgeProc:
        argv = [sys.executable, str(FAKE_BRIDGE)]
        for n in SENSORHEX if nodes is None else nodes:
            argv += ["--node", n]
        bp = BridgeProc(argv + list(extra or []), tmp_path / name)
        procs.append(bp)
        return bp.start()

    yield make
    for bp in procs:
        bp.close()
