"""The host library drives a hosted bridge whose downlink is CAN (issue #39), and the same host
code gives the same results as on the hosted bridge's I2C downlink.

CAN topology: tools/can_hub.py (python-can's `virtual` bus; `--interface socketcan` for a real
one), urb-node-hosted (the node library with the echo application on the CAN downlink, two
nodes) and urb-bridge-hosted --downlink can, all separate processes on the hub's socket; the host
library talks to the bridge's pty as to any serial bridge. I2C topology: urb-bridge-hosted with
its in-process fake echo nodes of the same identity. `host_application` runs unchanged on both.

Seeded bug: urb-node-hosted built with URB_MUTANT_NODE_DL_FRONT_BUFFER (a write filled into the
buffer the application may hold) must change what the host application sees.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from bridge_proc import REPO, BridgeProc, build_hosted_bridge, hosted_bridge  # noqa: F401 (fixture)
from urb.api import URBInterface
from urb.managers import RS232Manager
from test_hosted_bridge import ECHO, ECHO_FP  # the generic echo node both topologies run
from urb_msgs import sensorhex as sx

NODES = [(7, 0x30), (8, 0x31)]
SPECS = [f"0x42,{i},{a:#x},in1=6,out1=6,fp={ECHO_FP:08x}" for i, a in NODES]

Result = tuple[list[tuple[str, int, int]], list[sx.MotorFeedback]]


def host_application(link: Path) -> Result:
    """The host program: discovery, then a write and a read-back on every echo node."""
    urb = URBInterface([ECHO])
    try:
        report = urb.add_bus_manager(RS232Manager(str(link), timeout_s=3.0, lost_after_s=6.0))
        assert report.problems == [], report.problems
        rows = [(r.name, r.index, r.address) for r in urb.nodes()]
        echoed = []
        for index, _addr in NODES:
            node = urb.find_node("EchoNode", index)
            sent = sx.MotorFeedback(encoder=1000 + index, current=-index, voltage=1200 + index)
            node.write_message(sent, mbox=1)
            deadline = time.monotonic() + 2.0
            got = node.read_message(sx.MotorFeedback)
            while got != sent and time.monotonic() < deadline:  # the application copies at its next update
                time.sleep(0.005)
                got = node.read_message(sx.MotorFeedback)
            echoed.append(got)
        return rows, echoed
    finally:
        urb.close()


def make(target: str, *extra: str) -> None:
    proc = subprocess.run(["make", "--no-print-directory", "-C", str(REPO), target, *extra],
                          capture_output=True, text=True, timeout=600)
    if proc.returncode != 0:
        raise RuntimeError(f"`make {target}` failed (exit {proc.returncode}):\n{proc.stdout[-1500:]}{proc.stderr[-3000:]}")


class Proc:
    """A helper process that prints one line when it is ready."""

    def __init__(self, argv: list[str], ready: str) -> None:
        self.p = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        assert self.p.stdout is not None
        line = self.p.stdout.readline()
        if not line.startswith(ready):
            self.p.kill()
            raise RuntimeError(f"{argv[0]} did not start ({line!r}): {self.p.stderr.read() if self.p.stderr else ''}")

    def close(self) -> None:
        self.p.terminate()
        try:
            self.p.wait(5.0)
        except subprocess.TimeoutExpired:
            self.p.kill()
            self.p.wait()


@pytest.fixture
def can_system(tmp_path: Path) -> Iterator[Callable[[str], Path]]:
    """Factory: ``can_system(node_program)`` -> the pty link of a hosted CAN topology."""
    build_hosted_bridge()
    procs: list[Proc | BridgeProc] = []
    with tempfile.TemporaryDirectory(prefix="urbcan") as d:  # a Unix socket path has at most 107 bytes
        sock = Path(d) / "can.sock"

        def start(node_program: str) -> Path:
            procs.append(Proc([sys.executable, str(REPO / "tools" / "can_hub.py"), "--socket", str(sock)], "can_hub:"))
            argv = [str(REPO / "build" / "firmware" / node_program), "--can-hub", str(sock)]
            for spec in SPECS:
                argv += ["--node", spec]
            procs.append(Proc(argv, "nodes:"))
            bp = BridgeProc([str(REPO / "build" / "firmware" / "urb-bridge-hosted"), "--downlink", "can",
                             "--can-hub", str(sock)], tmp_path / "ttyCAN0")
            procs.append(bp)
            bp.start()
            return bp.link

        yield start
        for p in reversed(procs):
            p.close()


EXPECTED: Result = ([("EchoNode", 7, 0x30), ("EchoNode", 8, 0x31)],
                    [sx.MotorFeedback(encoder=1000 + i, current=-i, voltage=1200 + i) for i, _ in NODES])


def test_same_host_application_on_i2c_and_can(hosted_bridge: Callable[..., BridgeProc],
                                               can_system: Callable[[str], Path]) -> None:
    make("node-hosted")
    on_can = host_application(can_system("urb-node-hosted"))
    on_i2c = host_application(hosted_bridge(SPECS).link)
    assert on_i2c == EXPECTED
    assert on_can == on_i2c


def test_seeded_node_bug_changes_what_the_host_sees(can_system: Callable[[str], Path]) -> None:
    make("node-hosted", "URB_MUTANT=NODE_DL_FRONT_BUFFER")
    rows, echoed = host_application(can_system("urb-node-hosted-NODE_DL_FRONT_BUFFER"))
    assert rows == EXPECTED[0]  # witness: discovery over CAN still works
    assert echoed != EXPECTED[1]
