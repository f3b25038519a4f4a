"""The `urb` command line keeps what its --help promises: exit status 2 for every usage error
(found before any port is opened when the schemas suffice), 1 for failures, 141 for a reader that
went away; `urb --version` names the commit and the schema layout fingerprint; messages say what
happened and what to do next, each thing once."""

from __future__ import annotations

import os
import random
import re
import select
import signal
import subprocess
import sys
import threading
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from bridge_proc import REPO, BridgeProc, fake_bridge  # noqa: F401 (fixture)
from cli_run import killed_after, run, usage_error
from urb.cli import build_parser
from urb_codegen.generate import load_bundled
from urb_codegen.model import fingerprint_of


@pytest.fixture
def never_opened(tmp_path: Path) -> Iterator[Path]:
    """A PORT that fails with "not a serial port" if anything opens it: every usage error must be
    found before a port is opened."""
    link = tmp_path / "ttyNEVER"
    link.symlink_to("/dev/null")
    yield link


@pytest.mark.parametrize("argv, message", [
    (["read", "{p}", "MotorDriver", "9"], "mailbox '9': mailboxes are numbered 0 to 7"),
    (["read", "{p}", "MotorDriver", "-1"], "mailbox '-1': mailboxes are numbered 0 to 7"),
    (["read", "{p}", "MotorDriver:x", "1"], "node 'MotorDriver:x': the index after ':' must be a number from 0 to 63"),
    (["read", "{p}", "MotorDriver:64", "1"], "the index after ':' must be a number from 0 to 63"),
    (["read", "{p}", "Gripper", "1"], "no node type named 'Gripper' in the host's schemas"),
    (["read", "{p}", "0x42", "1"], "class 0x42 is not declared in the host's schemas"),
    (["read", "{p}", "Imu", "ImuSample2"], "Imu has no outbox holding 'ImuSample2'; its outboxes: 0 Identification"),
    (["read", "{p}", "Imu", "5"], "Imu has no outbox 5"),
    (["read", "{p}", "@128", "1"], "the address after '@' must be a number from 0 to 127"),
    (["read", "{p}", "Imu", "1x"], "mailbox '1x': give a mailbox number from 0 to 7 or the name of its message"),
    (["read", "{p}", "/dev/ttyOTHER@0x30", "1"], "/dev/ttyOTHER is not one of the ports given"),
    (["write", "{p}", "MotorDriver", "9", "voltage=1"], "mailbox '9': mailboxes are numbered 0 to 7"),
    (["write", "{p}", "MotorDriver:x", "1", "voltage=1"], "the index after ':' must be a number"),
    (["write", "{p}", "MotorDriver", "1", "voltage=abc"],
     "MotorCommand.voltage = 'abc': not a number; give a value in -32.768..32.767 V"),
    (["write", "{p}", "MotorDriver", "MotorConfig", "--defaults", "target=1.5"], "takes an integer"),
    (["write", "{p}", "MotorDriver", "1"], "give the fields of MotorCommand as FIELD=VALUE: voltage [V]"),
    (["write", "{p}", "MotorDriver", "1", "--raw", "001122"], "MotorDriver inbox 1 takes 2 bytes, --raw gives 3"),
    (["monitor", "{p}", "--node", "MotorDriver:x"], "the index after ':' must be a number"),
    (["monitor", "{p}", "--mailbox", "9"], "mailbox '9': mailboxes are numbered 0 to 7"),
    (["monitor", "{p}", "--node", "Imu", "--mailbox", "MotorFeedback"], "Imu has no outbox holding 'MotorFeedback'"),
    (["log", "{p}", "-o", "x.csv", "--node", "Gripper"], "no node type named 'Gripper'"),
    (["log", "{p}", "{p}2", "-o", "x.csv", "--node", "@0x30"], "with several ports, say which one: PORT@ADDR"),
])
def test_usage_errors_exit_2_before_any_port_is_opened(never_opened: Path, capsys: pytest.CaptureFixture[str],
                                                       argv: list[str], message: str) -> None:
    if "{p}2" in argv:
        Path(f"{never_opened}2").symlink_to("/dev/zero")
    err = usage_error(capsys, *[a.format(p=never_opened) for a in argv])
    assert message in err, err
    assert "not a serial port" not in err  # refused before the port was opened


def test_bus_failures_exit_1_and_usage_errors_found_after_discovery_exit_2(
        fake_bridge: Callable[..., BridgeProc], capsys: pytest.CaptureFixture[str]) -> None:
    bp = fake_bridge(["MotorDriver:0@16", "Imu:0@48"])
    code, _, err = run(capsys, "read", str(bp.link), "MotorDriver:7", "1")
    assert code == 1 and err.startswith("urb: no MotorDriver with index 7 was discovered"), err
    code, _, err = run(capsys, "read", str(bp.link), "@0x31", "1")
    assert code == 1 and "no node answered at address 49" in err and "addresses that did: 16 (MotorDriver:0)" in err
    # a node given by address: its own identification says which mailboxes it has
    code, _, err = run(capsys, "read", str(bp.link), "@48", "5")
    assert code == 2 and "urb read: error: Imu:0@48 has no outbox 5; its outboxes: 0 Identification" in err, err


@pytest.mark.parametrize("argv, message", [
    ([], "urb: error: give a COMMAND"),
    (["nonsense"], "invalid choice: 'nonsense'"),
    (["schema"], "urb schema: error: give a SUBCOMMAND: check or show"),
    (["demo", "--samples", "0"], "argument --samples: '0' is not a number of messages, 1 or more"),
    (["demo", "--seed", "x"], "argument --seed: 'x' is not a whole number"),
])
def test_usage_errors_of_the_other_commands_exit_2(capsys: pytest.CaptureFixture[str], argv: list[str],
                                                   message: str) -> None:
    code, out, err = run(capsys, *argv)
    assert code == 2 and err.startswith("usage: urb") and message in err, (code, err)
    assert out == ""


def _helps() -> Iterator[tuple[str, str]]:
    """(command, --help text) of `urb` and of every command and subcommand this package
    registers (`urb sim` is sim/'s own)."""
    parser = build_parser()
    yield "urb", parser.format_help()
    commands = next(a for a in parser._actions if isinstance(a.choices, dict)).choices
    assert isinstance(commands, dict)
    for name, sub in commands.items():
        if name == "sim":
            continue
        yield name, sub.format_help()
        for action in sub._actions:
            if isinstance(action.choices, dict):
                for subname, subsub in action.choices.items():
                    yield f"{name} {subname}", subsub.format_help()


def test_every_help_documents_its_exit_status() -> None:
    seen = []
    for name, text in _helps():
        seen.append(name)
        assert "Exit status" in text, name
        if name != "urb":
            assert re.search(r"\b2\b[^.]*usage error", text.replace("\n", " ")), name
    assert seen == ["urb", "scan", "read", "write", "monitor", "log", "gen", "schema", "schema check",
                    "schema show", "demo", "report"]
    top = dict(_helps())["urb"]
    for status in ("0 ", "1 ", "2 ", "130 ", "141 "):
        assert f"\n  {status}" in top, status


def test_a_reader_that_goes_away_ends_the_command_with_status_141(fake_bridge: Callable[..., BridgeProc]) -> None:
    """`urb read ... | head -1`: quiet, and SIGPIPE's status, as the top-level help says (it was 0
    for the node commands and 141 for the others)."""
    bp = fake_bridge(["Imu:0@48"])
    proc = subprocess.Popen([sys.executable, "-m", "urb", "read", str(bp.link), "Imu", "1", "--count", "2000",
                             "--interval", "0", "--raw"], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert proc.stdout is not None and proc.stderr is not None
    first = proc.stdout.readline()
    proc.stdout.close()  # the reader goes away after one line
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=60) == 141 and first and "Traceback" not in err, err


def test_version_names_the_commit_and_the_schema_layout_fingerprint(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "--version")
    head = subprocess.run(["git", "-C", str(REPO), "rev-parse", "HEAD"], capture_output=True, text=True,
                          check=True).stdout.strip()
    # the fingerprint computed here from spec/schema by the codegen, not from the generated codecs
    schemas = load_bundled()
    messages = {m.name: m.layout_text for s in schemas for m in s.messages.values()}
    nodes = {n.name: n.layout_text for s in schemas for n in s.nodes.values()}
    expected = fingerprint_of("".join([messages[k] for k in sorted(messages)] + [nodes[k] for k in sorted(nodes)]))
    assert code == 0
    assert out.startswith("urb 0.1.0, commit ") and f"commit {head}" in out, out
    assert out.rstrip().endswith(f"schema layout fingerprint {expected:08x}"), out
    assert re.fullmatch(r"urb 0\.1\.0, commit [0-9a-f]{40}( \(with uncommitted changes\))?, schema layout "
                        r"fingerprint [0-9a-f]{8}\n", out), out


def test_version_outside_a_checkout_says_unknown_commit(tmp_path: Path) -> None:
    from urb.version import version_text

    assert ", unknown commit (not run from a git checkout), schema layout fingerprint " in version_text(tmp_path)
    # an installed copy inside some other checkout (a virtual environment in a clone) is no checkout of its own
    subprocess.run(["git", "init", "-q", str(tmp_path)], check=True)
    copy = tmp_path / ".venv" / "lib" / "urb"
    copy.mkdir(parents=True)
    assert "unknown commit" in version_text(copy)


def test_ports_that_are_no_serial_port_say_so(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    regular = tmp_path / "passwd"
    regular.write_text("root:x:0:0::/root:/bin/sh\n")
    code, _, err = run(capsys, "scan", str(regular))
    assert code == 1 and f"urb: {regular}: not a serial port (a regular file). Give the bridge's device" in err, err
    assert "ioctl" not in err
    code, _, err = run(capsys, "scan", str(tmp_path))
    assert code == 1 and f"urb: {tmp_path}: is a directory, not a serial port" in err, err
    assert "Errno" not in err
    code, _, err = run(capsys, "scan", "/dev/null")
    assert code == 1 and "urb: /dev/null: not a serial port (a device that is not a terminal)" in err, err


def test_a_bridge_that_goes_away_is_said_once(fake_bridge: Callable[..., BridgeProc],
                                             capsys: pytest.CaptureFixture[str]) -> None:
    """The port failing mid-command: "went away" once, with why (it read "went away (the device
    went away ...)")."""
    bp = fake_bridge(["Imu:0@48"])
    with killed_after(bp, 1.5):
        code, _, err = run(capsys, "read", str(bp.link), "Imu", "1", "--count", "100000", "--interval", "0.01")
    assert code == 1 and err.count("went away") == 1, err
    assert re.search(r"the bridge on \S+ went away \((I/O error: the device was unplugged, or the bridge process ended|"
                     r"it sent nothing for \d+ ms with requests outstanding)\); reconnect it and run the command again",
                     err), err


class NoisyPort:
    """A pseudo-terminal whose far end sends random bytes and nothing else: a device at another
    baud rate."""

    def __init__(self, seed: int) -> None:
        self.master, self.slave = os.openpty()
        self.path = os.ttyname(self.slave)
        self.rng = random.Random(seed)
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            readable, writable, _ = select.select([self.master], [self.master], [], 0.01)
            if readable:
                os.read(self.master, 4096)
            if writable:
                os.write(self.master, bytes(self.rng.getrandbits(8) for _ in range(12)))
            self._stop.wait(0.001)

    def close(self) -> None:
        self._stop.set()
        self.thread.join()
        os.close(self.master)
        os.close(self.slave)


def test_scan_on_a_noisy_port_finds_no_bridge(capsys: pytest.CaptureFixture[str]) -> None:
    for seed in range(3):
        port = NoisyPort(seed)
        try:
            code, out, err = run(capsys, "scan", port.path)
        finally:
            port.close()
        assert code == 1 and out == "", err
        assert err.startswith(f"urb: no URB bridge answered on {port.path} (") and "none of them a URB bridge's" in err, err
        assert "Check that the baud rate matches the bridge firmware's" in err and "(This command used --baud 115200.)" in err


def test_monitor_keeps_going_when_its_bridge_stalls_and_comes_back(
        fake_bridge: Callable[..., BridgeProc], capsys: pytest.CaptureFixture[str]) -> None:
    """The bridge stops answering for 2 s (SIGSTOP: its port stays open), long enough to be lost;
    `urb monitor` says so, reconnects in the background and reads it again once it is back (it
    used to stop for good)."""
    bp = fake_bridge(["Imu:0@48"])
    assert bp.proc is not None
    proc = bp.proc
    stalled_at: list[int] = []

    def stall() -> None:
        while True:  # discovery, then some reads, before the stall
            requests = int(re.search(r'"requests": (\d+)', bp.cmd("stats")).group(1))  # type: ignore[union-attr]
            if requests >= 40:
                break
            threading.Event().wait(0.05)
        stalled_at.append(requests)
        proc.send_signal(signal.SIGSTOP)
        threading.Event().wait(2.0)
        proc.send_signal(signal.SIGCONT)

    staller = threading.Thread(target=stall)
    staller.start()
    try:
        code, out, err = run(capsys, "monitor", str(bp.link), "--node", "Imu", "--rate", "100", "--duration", "7")
    finally:
        staller.join()
    assert err.count("went away") == 1 and "reconnecting in the background" in err, err
    assert re.search(r"urb: the bridge on \S+ is back after \d+\.\d s \(\d+ attempts?\); reading it again", err), err
    assert code == 0, err  # it came back: no failure
    answered = int(re.search(r'"requests": (\d+)', bp.cmd("stats")).group(1))  # type: ignore[union-attr]
    assert answered - stalled_at[0] > 100, (stalled_at, answered)  # read again, at 100 Hz, after the stall
    assert "Imu:0/1" in out and "BRIDGE_LOST:1" in out


def test_monitor_without_reconnect_stops_at_the_loss(fake_bridge: Callable[..., BridgeProc],
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    bp = fake_bridge(["Imu:0@48"])
    with killed_after(bp, 2.0):
        code, _, err = run(capsys, "monitor", str(bp.link), "--node", "Imu", "--rate", "100", "--duration", "30",
                           "--no-reconnect")
    assert code == 1 and "stopping (no bridge left)" in err and "reconnecting" not in err, err


def test_monitor_says_when_a_bridge_did_not_come_back(fake_bridge: Callable[..., BridgeProc],
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    """Killed (its pty gone): the reconnection attempts fail until the end, which says so, in the
    command line's words (not the library's "call reconnect() again")."""
    bp = fake_bridge(["Imu:0@48"])
    with killed_after(bp, 1.5):
        code, _, err = run(capsys, "monitor", str(bp.link), "--node", "Imu", "--rate", "100", "--duration", "4")
    assert code == 1 and "reconnecting in the background" in err, err
    assert re.search(r"urb: the bridge on \S+ did not come back \(\d+ attempts to reconnect; last attempt: \S+: no "
                     r"such port\. Check the path and the cable; [^\n]*\)\n", err), err
    assert "reconnect()" not in err and "is back" not in err
