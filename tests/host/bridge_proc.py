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
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from urb.managers import BridgeModel

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
FAKE_BRIDGE = HERE / "fake_bridge.py"
HOSTED_BRIDGE = REPO / "build" / "firmware" / "urb-bridge-hosted"
HOSTED_KIND = {"MotorDriver": "motor", "BatteryManager": "battery", "Imu": "imu", "IrDistance": "ir"}

SENSORHEX = [f"MotorDriver:{i}@{0x10 + i}" for i in range(6)] + [
    "BatteryManager:0@32", "Imu:0@48", "IrDistance:0@49"]
"""The SensoRHex hexapod: six motor drivers, battery manager, IMU, IR distance node."""


def serve_usb_transfers(sock: socket.socket, model: BridgeModel) -> None:
    """The bridge end of a SOCK_SEQPACKET pair (a USB bridge behind a character device): one OUT
    transfer per recv, answered with the model's previous IN buffer; returns when the pair ends."""
    while True:
        try:
            data = sock.recv(4096)
        except OSError:
            return
        if not data:
            return
        model.usb_out(data, time.monotonic_ns())
        back = model.usb_in()
        if back is not None:
            try:
                sock.send(back)
            except OSError:
                return


def build_hosted_bridge() -> Path:
    """The hosted bridge program, built with `make bridge-hosted` when missing or stale.
    Raises (never skips) with the build's own output when it cannot be built."""
    proc = subprocess.run(["make", "--no-print-directory", "-C", str(REPO), "bridge-hosted"],
                          capture_output=True, text=True, timeout=600)
    if proc.returncode != 0 or not HOSTED_BRIDGE.exists():
        raise RuntimeError(f"cannot build {HOSTED_BRIDGE.relative_to(REPO)} with `make bridge-hosted` "
                           f"(exit {proc.returncode}); the hosted-bridge tests need it:\n{proc.stdout[-1500:]}{proc.stderr[-3000:]}")
    return HOSTED_BRIDGE


def hosted_argv(nodes: list[str], extra: list[str] | None = None) -> list[str]:
    """Command line of the hosted bridge for nodes given as NAME:INDEX@ADDR (SensoRHex names)
    or as the program's own KIND,INDEX,ADDR[,KEY=VALUE] specs."""
    argv = [str(build_hosted_bridge())] + list(extra or [])
    for spec in nodes:
        if "@" in spec:
            name_index, addr = spec.split("@")
            name, index = name_index.split(":")
            spec = f"{HOSTED_KIND[name]},{index},{addr}"
        argv += ["--node", spec]
    return argv


class LineTap:
    """A pseudo-terminal proxy between the host and a bridge's pty: the RS232 line, where bytes
    can be corrupted or lost whatever the bridge. The host opens `path`."""

    def __init__(self, bridge_pty: str, link: Path) -> None:
        import threading
        import tty

        self.bridge_fd = os.open(bridge_pty, os.O_RDWR | os.O_NOCTTY)
        tty.setraw(self.bridge_fd)
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        self.path = link
        if link.is_symlink():
            link.unlink()
        link.symlink_to(os.ttyname(self.slave))
        self._corrupt: dict[int, int] = {}
        self._to_host = 0
        self._drop_requests = 0
        self.lock = threading.Lock()
        self._stop = False
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def corrupt_response(self, index: int = 0, xor: int = 0x10) -> None:
        """Flip bits of byte `index` (counted from now) of the bridge-to-host stream."""
        with self.lock:
            self._corrupt[self._to_host + index] = xor

    def drop_requests(self, n: int = 1) -> None:
        """Lose the next n host-to-bridge writes (one request frame each)."""
        with self.lock:
            self._drop_requests += n

    def _run(self) -> None:
        while not self._stop:
            ready, _, _ = select.select([self.master, self.bridge_fd], [], [], 0.05)
            for fd in ready:
                try:
                    data = bytearray(os.read(fd, 4096))
                except OSError:
                    data = bytearray()
                if not data:
                    if fd == self.bridge_fd:
                        return
                    continue
                with self.lock:
                    if fd == self.master:
                        if self._drop_requests:
                            self._drop_requests -= 1
                            continue
                        os.write(self.bridge_fd, bytes(data))
                    else:
                        for i in range(len(data)):
                            data[i] ^= self._corrupt.pop(self._to_host + i, 0)
                        self._to_host += len(data)
                        os.write(self.master, bytes(data))

    def close(self) -> None:
        self._stop = True
        self.thread.join(timeout=2)
        for fd in (self.bridge_fd, self.master, self.slave):
            try:
                os.close(fd)
            except OSError:
                pass


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
        try:
            first = self.readline(10.0)
        except (TimeoutError, EOFError) as exc:
            err = self.proc.stderr.read().decode() if self.proc.stderr and self.proc.poll() is not None else ""
            raise RuntimeError(f"bridge {self.argv[0]} did not start: {exc} {err}") from None
        if first.startswith("PTY "):  # tests/host/fake_bridge.py
            self.pty = first.split(" ", 1)[1]
            assert self.readline(10.0) == "READY"
        elif first.startswith("pty: "):  # build/firmware/urb-bridge-hosted
            self.pty = first.split(" ", 1)[1]
            deadline = time.monotonic() + 5.0
            while not (self.link.is_symlink() and os.readlink(self.link) == self.pty):
                if time.monotonic() > deadline:
                    raise RuntimeError(f"bridge did not link {self.link} to {self.pty}")
                time.sleep(0.01)
        else:
            raise RuntimeError(f"bridge did not print its pty: {first!r}")
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
def hosted_bridge(tmp_path: Path) -> Iterator[Callable[..., BridgeProc]]:
    """Factory: ``hosted_bridge(nodes=[...], name=..., extra=[...])`` -> a started BridgeProc
    running build/firmware/urb-bridge-hosted (built if needed; a build failure fails the test)."""
    procs: list[BridgeProc] = []

    def make(nodes: list[str] | None = None, name: str = "ttyHOSTED0", extra: list[str] | None = None) -> BridgeProc:
        bp = BridgeProc(hosted_argv(SENSORHEX if nodes is None else nodes, extra), tmp_path / name)
        procs.append(bp)
        return bp.start()

    yield make
    for bp in procs:
        bp.close()


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
