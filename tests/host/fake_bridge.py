#!/usr/bin/env python3
"""A fake URB bridge as its own process, with its RS232 uplink on a pseudo-terminal.

Test fixture standing in for the hosted bridge firmware: it runs `urb.managers.BridgeModel`
(spec/tla/Bridge.tla in Python, exact wire format) behind a pty, so `RS232Manager` talks to it
through pyserial exactly as it would to /dev/ttyS0.

    python3 tests/host/fake_bridge.py --node MotorDriver:0@8 --node Imu:0@20 [--link PATH]

prints ``PTY <path>`` on its first stdout line, then ``READY``. Commands on stdin, one per line,
each answered ``ok ...`` (or ``error ...``) on stdout:

    unplug ADDR | plug ADDR          the node stops / starts acknowledging its address
    vanish ADDR N                    the node answers N more transactions, then is unplugged
    fault ADDR STATUS [N]            the next N transactions of ADDR end with STATUS (e.g. TIMEOUT)
    lock ADDR | unlock ADDR          the node's inboxes are held by the application (NODE_BUSY)
    stretch ADDR MS                  every transaction of ADDR lasts MS ms longer (clock stretching)
    corrupt [INDEX [XOR]]            flip bits of byte INDEX of the response stream, counted from now
    drop [N]                         ignore the next N request frames entirely (lost on the line)
    garbage HEX                      write raw bytes to the uplink
    inbox ADDR MBOX                  ok HEX: what the node last received in that inbox
    stats                            ok JSON: counters
    quit
"""

from __future__ import annotations

import argparse
import json
import os
import select
import sys
import termios
import time
import tty
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "host"))
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "gen" / "python"))

from urb.managers.loopback import BridgeModel, fake_node  # noqa: E402
from urb_msgs.urb_core import Status  # noqa: E402


class FakeBridgeProcess:
    def __init__(self, model: BridgeModel, link: str | None) -> None:
        self.model = model
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        attrs = termios.tcgetattr(self.slave)
        attrs[3] &= ~termios.ECHO
        termios.tcsetattr(self.slave, termios.TCSANOW, attrs)
        self.path = os.ttyname(self.slave)
        if link:
            tmp = link + ".tmp"
            if os.path.lexists(tmp):
                os.unlink(tmp)
            os.symlink(self.path, tmp)
            os.replace(tmp, link)
        self.corrupt: dict[int, int] = {}
        self.sent = 0
        self.drop = 0
        self.dropped_frames = 0

    def reply(self, text: str) -> None:
        sys.stdout.write(text + "\n")
        sys.stdout.flush()

    def command(self, line: str) -> bool:
        words = line.split()
        if not words:
            return True
        op, args = words[0], words[1:]
        nodes = self.model.nodes
        try:
            if op in ("unplug", "plug"):
                nodes[int(args[0], 0)].present = op == "plug"
            elif op == "vanish":
                nodes[int(args[0], 0)].vanish_after = int(args[1])
            elif op == "fault":
                n = int(args[2]) if len(args) > 2 else 1
                nodes[int(args[0], 0)].faults.extend([Status[args[1]]] * n)
            elif op in ("lock", "unlock"):
                nodes[int(args[0], 0)].inbox_locked = op == "lock"
            elif op == "stretch":
                nodes[int(args[0], 0)].stretch_ns = int(float(args[1]) * 1_000_000)
            elif op == "corrupt":
                index = int(args[0]) if args else 0
                self.corrupt[self.sent + index] = int(args[1], 0) if len(args) > 1 else 0x04
            elif op == "drop":
                self.drop += int(args[0]) if args else 1
            elif op == "garbage":
                os.write(self.master, bytes.fromhex(args[0]))
            elif op == "inbox":
                data = nodes[int(args[0], 0)].inboxes.get(int(args[1]), b"")
                self.reply(f"ok {data.hex()}")
                return True
            elif op == "stats":
                s = self.model.stats
                self.reply("ok " + json.dumps({"requests": s.requests, "responses": s.responses,
                                               "dropped_bytes": s.dropped_bytes, "busy": s.busy,
                                               "by_status": s.by_status, "dropped_frames": self.dropped_frames}))
                return True
            elif op == "quit":
                self.reply("ok")
                return False
            else:
                self.reply(f"error unknown command {op}")
                return True
        except (IndexError, KeyError, ValueError) as exc:
            self.reply(f"error {exc!r}")
            return True
        self.reply("ok")
        return True

    def on_input(self, data: bytes, now: int) -> None:
        if self.drop:
            # lose whole request frames: feed nothing to the model for this chunk
            self.drop -= 1
            self.dropped_frames += 1
            return
        self.model.receive(data, now)

    def flush(self, now: int) -> None:
        out = bytearray(self.model.process(now))
        for i in range(len(out)):
            out[i] ^= self.corrupt.pop(self.sent + i, 0)
        self.sent += len(out)
        if out:
            os.write(self.master, bytes(out))

    def run(self) -> None:
        self.reply(f"PTY {self.path}")
        self.reply("READY")
        stdin = sys.stdin.fileno()
        watch = [self.master, stdin]
        buf = b""
        while True:
            nxt = self.model.next_event_ns()
            timeout = None if nxt is None else max(0.0, (nxt - time.monotonic_ns()) / 1e9)
            ready, _, _ = select.select(watch, [], [], timeout)
            now = time.monotonic_ns()
            if self.master in ready:
                try:
                    data = os.read(self.master, 4096)
                except OSError:
                    data = b""
                if data:
                    self.on_input(data, now)
            if stdin in ready:
                chunk = os.read(stdin, 4096)
                if not chunk:
                    return
                buf += chunk
                while b"\n" in buf:
                    line, buf = buf.split(b"\n", 1)
                    if not self.command(line.decode()):
                        return
            self.flush(time.monotonic_ns())


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--node", action="append", default=[], metavar="NAME:INDEX@ADDR",
                    help="a fake node (options: !fp=HEX wrong fingerprint, !fw=A.B.C)")
    ap.add_argument("--link", metavar="PATH", help="also make PATH a symlink to the pty")
    ap.add_argument("--fifo-depth", type=int, default=8)
    ap.add_argument("--idle-gap-us", type=int, default=2000,
                    help="drop a partial request after this silence (pty timing is not a UART's; default 2000)")
    ap.add_argument("--timed-downlink", action="store_true", help="each transaction takes its I2C time at 400 kb/s")
    args = ap.parse_args()
    nodes = dict(fake_node(s) for s in args.node)
    model = BridgeModel(nodes, fifo_depth=args.fifo_depth, idle_gap_ns=args.idle_gap_us * 1000,
                        timed_downlink=args.timed_downlink)
    FakeBridgeProcess(model, args.link).run()
    return 0


if __name__ == "__main__":
    sys.exit(main())
