"""`urb scan/read/write/monitor/log` against a bridge process on a pty."""

from __future__ import annotations

import csv
import importlib.util
import json
import os
import re
import select
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from bridge_proc import BridgeProc, build_hosted_bridge, fake_bridge, hosted_bridge  # noqa: F401 (fixtures)
from cli_run import run, usage_error
from urb import cli_nodes, cli_poll
from urb.cli import main

NODES = ["MotorDriver:0@16", "MotorDriver:1@17", "BatteryManager:0@32", "Imu:0@48"]


@pytest.fixture
def port(fake_bridge: Callable[..., BridgeProc]) -> tuple[str, BridgeProc]:
    bp = fake_bridge(NODES)
    return str(bp.link), bp


def test_scan_lists_nodes_and_flags(fake_bridge: Callable[..., BridgeProc], capsys: pytest.CaptureFixture[str]) -> None:
    bp = fake_bridge(NODES + ["IrDistance:0@49!fp=00c0ffee"])
    code, out, _ = run(capsys, "scan", str(bp.link))
    assert code == 1  # a flagged node
    assert "FIFO 8" in out and "MotorDriver" in out and "a81f00fc" in out and "MISMATCH" in out
    assert "expects 1c6fc9d4" in out
    code, out, _ = run(capsys, "scan", str(bp.link), "--json")
    rows = json.loads(out)
    assert [(r["node"], r["index"], r["address"]) for r in rows][:2] == [("MotorDriver", 0, 16), ("MotorDriver", 1, 17)]
    assert rows[-1]["flags"] == ["MISMATCH"] and rows[-1]["schema_file"] == "spec/schema/sensorhex.urbs"


def test_scan_two_ports_reports_duplicates(fake_bridge: Callable[..., BridgeProc], capsys: pytest.CaptureFixture[str]) -> None:
    a = fake_bridge(["Imu:0@48"], name="ttyA")
    b = fake_bridge(["Imu:0@50"], name="ttyB")
    code, out, _ = run(capsys, "scan", str(a.link), str(b.link), "--json")
    rows = json.loads(out)
    assert code == 1 and len(rows) == 2 and all(r["flags"] == ["DUPLICATE"] for r in rows)


def test_read_in_engineering_units(port: tuple[str, BridgeProc], capsys: pytest.CaptureFixture[str]) -> None:
    path, _ = port
    code, out, _ = run(capsys, "read", path, "BatteryManager", "BatteryStatus")
    assert code == 0 and "packs[0].voltage  11.1 V" in out and "packs[2].charge   78 %" in out
    code, out, _ = run(capsys, "read", path, "0x30:0", "1", "--json", "--count", "3", "--interval", "0")
    lines = [json.loads(x) for x in out.splitlines()]
    assert code == 0 and len(lines) == 3 and lines[0]["fields"]["accel[2]"] == pytest.approx(9.81)
    code, out, _ = run(capsys, "read", path, "MotorDriver:1", "0", "--raw")
    assert code == 0 and out.strip().startswith("1001")  # class 0x10, index 1


def test_write_then_read_back(port: tuple[str, BridgeProc], capsys: pytest.CaptureFixture[str]) -> None:
    path, bp = port
    code, out, _ = run(capsys, "write", path, "MotorDriver:1", "MotorCommand", "voltage=-2.5")
    assert code == 0 and "stored" in out
    code, out, _ = run(capsys, "read", path, "MotorDriver:1", "MotorFeedback", "--json")
    assert json.loads(out)["fields"]["voltage"] == pytest.approx(-2.5)
    code, _, _ = run(capsys, "write", path, "MotorDriver:0", "2", "mode=LOCAL_PD", "kp=0.0125", "kd=0.000002",
                     "target=-3000", "voltage_limit=6")
    assert code == 0
    stored = bytes.fromhex(bp.cmd("inbox 16 2"))
    from urb_msgs import sensorhex as sx

    cfg = sx.MotorConfig.decode(stored)
    assert (cfg.mode, cfg.kp, cfg.kd, cfg.target, cfg.voltage_limit) == (sx.MotorMode.LOCAL_PD, 125, 2, -3000, 6000)
    code, _, _ = run(capsys, "write", path, "Imu", "0", "--raw", "030500000000")
    assert code == 0 and bp.cmd("inbox 48 0") == "030500000000"


@pytest.mark.parametrize("argv, message", [
    (["read", "{p}", "MotorDriver:7", "1"], "no MotorDriver with index 7"),
    (["read", "{p}", "Imu:1", "1"], "no Imu with index 1"),
])
def test_nodes_not_discovered_are_failures(port: tuple[str, BridgeProc], capsys: pytest.CaptureFixture[str],
                                           argv: list[str], message: str) -> None:
    """What only the bus can tell is a failure (exit 1); a NODE or MAILBOX the schemas do not
    have is a usage error (tests/host/test_cli_usage.py)."""
    code, _, err = run(capsys, *[a.format(p=port[0]) for a in argv])
    assert code == 1 and message in err and err.startswith("urb: ")


@pytest.mark.parametrize("argv, message", [
    (["write", "{p}", "MotorDriver:0", "2", "mode=VOLTAGE"], "missing kp, kd, target, voltage_limit"),
    (["write", "{p}", "MotorDriver:0", "1", "voltage=99"], "outside -32.768..32.767 V"),
    (["write", "{p}", "MotorDriver:0", "1", "current=1"], "has no field current"),
    (["write", "{p}", "MotorDriver:0", "2", "mode=FAST", "--defaults"], "not one of DISABLED, VOLTAGE, LOCAL_PD"),
    # not finite: the field and the values it takes (a scaled field, then an integer one)
    (["write", "{p}", "MotorDriver:0", "MotorCommand", "voltage=inf"],
     "MotorCommand.voltage = 'inf': not a finite number; give a value in -32.768..32.767 V"),
    (["write", "{p}", "MotorDriver:0", "MotorCommand", "voltage=nan"],
     "MotorCommand.voltage = 'nan': not a finite number; give a value in -32.768..32.767 V"),
    (["write", "{p}", "MotorDriver:0", "MotorCommand", "voltage=-1e308"],  # finite, infinite once scaled
     "MotorCommand.voltage = '-1e308': outside -32.768..32.767 V"),
    (["write", "{p}", "MotorDriver:0", "MotorConfig", "--defaults", "target=-inf"],
     "MotorConfig.target = '-inf': not a finite number; give a value in -2147483648..2147483647"),
    (["write", "{p}", "MotorDriver:0", "MotorConfig", "--defaults", "target=nan"],
     "MotorConfig.target = 'nan': not a finite number; give a value in -2147483648..2147483647"),
    (["write", "{p}", "MotorDriver:0", "MotorConfig", "--defaults", "target=1e30"],
     "MotorConfig.target = '1e30': outside -2147483648..2147483647"),
    (["write", "{p}", "MotorDriver:0", "1", "--raw", "001122"], "MotorDriver inbox 1 takes 2 bytes, --raw gives 3"),
    (["write", "{p}", "MotorDriver:0", "1", "--raw", "zz"], "--raw 'zz' is not hex (two hex digits a byte"),
    (["write", "{p}", "MotorDriver:0", "1", "voltage=abc"], "MotorCommand.voltage = 'abc': not a number; give a value in"),
    (["write", "{p}", "MotorDriver:0", "1", "--raw", "0011", "voltage=1"], "give either FIELD=VALUE words or --raw HEX, not both"),
])
def test_values_the_schema_refuses_are_usage_errors(port: tuple[str, BridgeProc], capsys: pytest.CaptureFixture[str],
                                                   argv: list[str], message: str) -> None:
    err = usage_error(capsys, *[a.format(p=port[0]) for a in argv])
    assert message in err


@pytest.mark.parametrize("argv, message", [
    (["read", "{p}", "MotorDriver", "1", "--count", "2", "--interval", "-1"], "argument --interval: '-1' is not"),
    (["read", "{p}", "MotorDriver", "1", "--interval", "nan"], "argument --interval: 'nan' is not"),
    (["read", "{p}", "MotorDriver", "1", "--count", "0"], "argument --count: '0' is not a number of reads, 1 or more"),
    (["read", "{p}", "MotorDriver", "1", "--count", "-2"], "argument --count: '-2' is not"),
    (["read", "{p}", "MotorDriver", "1", "--timeout", "0"], "argument --timeout: '0' is not a number of seconds above 0"),
    (["read", "{p}", "MotorDriver", "1", "--timeout", "-1"], "argument --timeout: '-1' is not"),
    (["read", "{p}", "MotorDriver", "1", "--timeout", "1e300"], "argument --timeout: '1e300' is not"),
    (["monitor", "{p}", "--rate", "2e9"], "argument --rate: '2e9' is not a rate in Hz"),
    (["monitor", "{p}", "--rate", "0"], "argument --rate: '0' is not"),
    (["monitor", "{p}", "--rate", "-5"], "argument --rate: '-5' is not"),
    (["log", "{p}", "-o", "x.csv", "--rate", "inf"], "argument --rate: 'inf' is not"),
    (["monitor", "{p}", "--duration", "nan"], "argument --duration: 'nan' is not a number of seconds above 0"),
    (["log", "{p}", "-o", "x.csv", "--duration", "-1"], "argument --duration: '-1' is not"),
    (["scan", "{p}", "--baud", "99999999999999"], "argument --baud: '99999999999999' is not a bit rate"),
    (["scan", "{p}", "{p}"], "{p} is given twice"),
    (["monitor", "{p}", "{p}"], "{p} is given twice"),
    (["log", "{p}", "{p}", "-o", "x.csv"], "{p} is given twice"),
    (["scan", "{p}", "{alias}"], "{p} and {alias} are the same port (/dev/null)"),
])
def test_bad_numbers_and_ports_are_usage_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                argv: list[str], message: str) -> None:
    link, alias = tmp_path / "ttyX", tmp_path / "ttyALIAS"
    link.symlink_to("/dev/null")  # never opened: every case is refused before a port is opened
    alias.symlink_to(link)
    err = usage_error(capsys, *[a.format(p=link, alias=alias) for a in argv])
    assert message.format(p=link, alias=alias) in err
    assert "in use by another program" not in err


def test_options_anywhere_among_field_values(port: tuple[str, BridgeProc], capsys: pytest.CaptureFixture[str]) -> None:
    path, bp = port
    code, out, _ = run(capsys, "write", path, "MotorDriver:0", "2", "--defaults", "mode=LOCAL_PD", "kp=0.01")
    assert code == 0 and "stored" in out
    from urb_msgs import sensorhex as sx

    cfg = sx.MotorConfig.decode(bytes.fromhex(bp.cmd("inbox 16 2")))
    assert (cfg.mode, cfg.kp, cfg.target) == (sx.MotorMode.LOCAL_PD, 100, 0)
    code, out, _ = run(capsys, "write", path, "MotorDriver:1", "1", "--timeout", "0.5", "voltage=1")
    assert code == 0 and "stored" in out
    code, out, _ = run(capsys, "scan", path, "--json", "--timeout", "0.5")
    assert code == 0 and len(json.loads(out)) == 4
    # an unknown option: the command's own usage, not the top-level one
    err = usage_error(capsys, "write", path, "MotorDriver:0", "1", "--bogus", "voltage=1")
    assert "unrecognized arguments: --bogus" in err


def test_vanished_node_is_explained(port: tuple[str, BridgeProc], capsys: pytest.CaptureFixture[str]) -> None:
    path, bp = port
    bp.cmd("vanish 48 1")  # answers its identification read during discovery, then is gone
    code, _, err = run(capsys, "read", path, "Imu", "1")
    assert code == 1
    assert "node Imu:0 did not answer (NO_NODE): it was discovered at" in err and "address 48" in err
    assert f"urb scan {path}" in err
    # gone at scan time: find_node cannot hand it out
    code, _, err = run(capsys, "read", path, "Imu", "1")
    assert code == 1 and "no Imu with index 0 was discovered" in err


def test_missing_port_and_no_bridge(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "scan", str(tmp_path / "ttyNONE"))
    assert code == 1 and "no such port" in err
    master, slave = os.openpty()
    try:
        code, _, err = run(capsys, "scan", os.ttyname(slave), "--timeout", "0.05")
        assert code == 1 and "no URB bridge answered" in err
    finally:
        os.close(master)
        os.close(slave)


def test_monitor_shows_statistics(port: tuple[str, BridgeProc], capsys: pytest.CaptureFixture[str]) -> None:
    path, _ = port
    code, out, _ = run(capsys, "monitor", path, "--duration", "0.5", "--rate", "100")
    assert code == 0
    for label in ("MotorDriver:0/1", "MotorDriver:1/2", "BatteryManager:0/1", "Imu:0/1"):
        assert label in out
    assert "p99 ms" in out and "encoder=" in out


def test_monitor_reports_a_node_that_vanishes_mid_run(port: tuple[str, BridgeProc], capsys: pytest.CaptureFixture[str]) -> None:
    path, bp = port
    import threading

    timer = threading.Timer(0.3, lambda: bp.cmd("unplug 17"))
    timer.start()
    try:
        code, out, err = run(capsys, "monitor", path, "--node", "MotorDriver:1", "--duration", "0.8", "--rate", "100")
    finally:
        timer.join()
    assert code == 1 and "NO_NODE:" in out
    assert "node MotorDriver:1 stopped answering (NO_NODE)" in err and "urb scan" in err


def test_log_to_csv(port: tuple[str, BridgeProc], capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    path, _ = port
    out_file = tmp_path / "run.csv"
    code, _, err = run(capsys, "log", path, "-o", str(out_file), "--node", "MotorDriver:0", "--node", "BatteryManager",
                       "--mailbox", "1", "--rate", "200", "--duration", "0.5")
    assert code == 0 and "rows to" in err
    rows = list(csv.DictReader(out_file.open()))
    # every row the summary counts is in the file; how many there are depends on the machine's load
    # (200 Hz x 0.5 s x 2 nodes at most), so only "several per node" is required here
    assert f"{len(rows)} rows to" in err and len(rows) >= 10
    nodes = {r["node"] for r in rows}
    assert nodes == {"MotorDriver:0", "BatteryManager:0"}
    motor = next(r for r in rows if r["node"] == "MotorDriver:0")
    battery = next(r for r in rows if r["node"] == "BatteryManager:0")
    assert motor["status"] == "OK" and motor["encoder"] != "" and motor["packs[0].voltage"] == ""
    assert float(battery["packs[1].voltage"]) == pytest.approx(11.11)
    assert int(motor["t_complete_ns"]) > int(motor["t_submit_ns"]) and float(motor["latency_us"]) > 0


def test_log_to_parquet(port: tuple[str, BridgeProc], capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    import pyarrow.parquet as pq  # a dev dependency, so that this path runs in CI

    path, _ = port
    out_file = tmp_path / "run.parquet"
    code, _, err = run(capsys, "log", path, "-o", str(out_file), "--node", "Imu", "--node", "MotorDriver:0",
                       "--duration", "0.3", "--rate", "100")
    assert code == 0, err
    rows = pq.read_table(out_file).to_pylist()
    assert len(rows) > 10
    assert {r["node"] for r in rows} == {"Imu:0", "MotorDriver:0"}
    assert all(r["status"] == "OK" for r in rows)
    motor = next(r for r in rows if r["node"] == "MotorDriver:0")
    assert motor["encoder"] != "" and int(motor["t_complete_ns"]) > int(motor["t_submit_ns"])


def test_log_to_parquet_without_pyarrow(port: tuple[str, BridgeProc], capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                        monkeypatch: pytest.MonkeyPatch) -> None:
    real_find_spec = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "pyarrow" else real_find_spec(name, *a))
    path, _ = port
    out_file = tmp_path / "run.parquet"
    code, _, err = run(capsys, "log", path, "-o", str(out_file), "--node", "Imu", "--duration", "0.3", "--rate", "100")
    assert code == 1 and "writing Parquet needs pyarrow (pip install pyarrow)" in err and not out_file.exists()


class _KillingTime:
    """`time` for cli_nodes, whose first sleep (between two reads of `urb read --count`) runs
    `hook` first: a bridge killed at a known point."""

    def __init__(self, hook: Callable[[], None]) -> None:
        self.hook: Callable[[], None] | None = hook
        self.sleeps = 0

    def __getattr__(self, name: str) -> Any:
        return getattr(time, name)

    def sleep(self, seconds: float) -> None:
        self.sleeps += 1
        if self.hook is not None:
            hook, self.hook = self.hook, None
            hook()
        time.sleep(seconds)


def after_ticks(monkeypatch: pytest.MonkeyPatch, n: int, action: Callable[[], None]) -> None:
    """Run `action` once the monitor/log poller has submitted its n-th round of reads."""
    original = cli_poll.Poller.tick
    count = [0]

    def tick(self: cli_poll.Poller) -> None:
        count[0] += 1
        if count[0] == n:
            action()
        original(self)

    monkeypatch.setattr(cli_poll.Poller, "tick", tick)


def test_read_count_stops_at_a_lost_bridge(port: tuple[str, BridgeProc], capsys: pytest.CaptureFixture[str],
                                           monkeypatch: pytest.MonkeyPatch) -> None:
    path, bp = port
    clock = _KillingTime(bp.kill)  # killed after the first read
    monkeypatch.setattr(cli_nodes, "time", clock)
    code, out, err = run(capsys, "read", path, "MotorDriver", "1", "--count", "5", "--interval", "0.05")
    assert code == 1
    assert out.count("MotorDriver:0 outbox 1 MotorFeedback") == 1
    assert err.count(f"the bridge on {path} went away (") == 1, err
    assert clock.sleeps == 1  # no more reads, no more waiting


def test_log_stops_and_fails_when_its_only_bridge_goes_away(port: tuple[str, BridgeProc], capsys: pytest.CaptureFixture[str],
                                                          monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    path, bp = port
    after_ticks(monkeypatch, 20, bp.kill)
    out_file = tmp_path / "run.csv"
    t0 = time.monotonic()
    code, _, err = run(capsys, "log", path, "-o", str(out_file), "--node", "MotorDriver:0", "--node", "Imu",
                       "--rate", "200", "--duration", "10")
    assert time.monotonic() - t0 < 6.0  # stopped at the loss, not after --duration
    assert code == 1 and "rows to" in err
    assert err.count(f"urb: the bridge on {path} went away (") == 1 and "stopping (no bridge left)" in err, err
    rows = list(csv.DictReader(out_file.open()))
    statuses = [r["status"] for r in rows]
    assert statuses.count("OK") >= 10
    # at most the reads in flight, one per channel (MotorDriver:0/1, /2, Imu:0/1): no more polling
    assert statuses.count("BRIDGE_LOST") <= 3


def test_log_goes_on_with_the_other_bridge(fake_bridge: Callable[..., BridgeProc], capsys: pytest.CaptureFixture[str],
                                          monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    a = fake_bridge(["MotorDriver:0@16"], name="ttyA")
    b = fake_bridge(["Imu:0@48"], name="ttyB")
    after_ticks(monkeypatch, 10, a.kill)
    out_file = tmp_path / "run.csv"
    code, _, err = run(capsys, "log", str(a.link), str(b.link), "-o", str(out_file), "--mailbox", "1",
                       "--rate", "100", "--duration", "0.8")
    assert code == 1
    assert err.count(f"the bridge on {a.link} went away (") == 1 and f"the bridge on {b.link}" not in err
    assert "no longer reading it, the other bridges go on" in err, err
    rows = list(csv.DictReader(out_file.open()))
    a_rows = [r for r in rows if r["bridge"] == str(a.link)]
    b_rows = [r for r in rows if r["bridge"] == str(b.link)]
    assert [r["status"] for r in a_rows].count("BRIDGE_LOST") <= 1
    last_a = max(int(r["t_submit_ns"]) for r in a_rows)
    assert sum(int(r["t_submit_ns"]) > last_a for r in b_rows) > 10  # B still read for the rest of the run
    assert all(r["status"] == "OK" for r in b_rows)


def test_monitor_stops_when_its_bridge_goes_away(port: tuple[str, BridgeProc], capsys: pytest.CaptureFixture[str],
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    path, bp = port
    after_ticks(monkeypatch, 10, bp.kill)
    t0 = time.monotonic()
    code, out, err = run(capsys, "monitor", path, "--node", "Imu", "--rate", "100", "--duration", "10", "--no-reconnect")
    assert time.monotonic() - t0 < 6.0
    assert code == 1 and "Imu:0/1" in out
    assert err.count(f"the bridge on {path} went away (") == 1, err


def test_log_fails_when_the_bridge_stops_answering_at_the_end(port: tuple[str, BridgeProc], capsys: pytest.CaptureFixture[str],
                                                              monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    path, bp = port
    assert bp.proc is not None
    proc = bp.proc
    after_ticks(monkeypatch, 5, lambda: proc.send_signal(signal.SIGSTOP))  # stalled, port still open
    out_file = tmp_path / "run.csv"
    code, _, err = run(capsys, "log", path, "-o", str(out_file), "--node", "MotorDriver:0", "--mailbox", "1",
                       "--rate", "100", "--duration", "0.6", "--timeout", "0.5")
    assert code == 1
    assert f"urb: the bridge on {path} stopped answering: the last read of each of its mailboxes got no response" in err, err
    statuses = [r["status"] for r in csv.DictReader(out_file.open())]
    assert statuses[-1] == "UPLINK_TIMEOUT" and statuses.count("OK") >= 3  # the last read waited for, and logged


def _ctrl_c_interrupts() -> None:
    """In the child: SIGINT back to its default, so Python turns it into KeyboardInterrupt. A test suite
    started in the background from a non-interactive shell (`make check &`) runs with SIGINT ignored,
    as POSIX shells do for asynchronous commands; the child would inherit that, ignore both Ctrl-Cs and
    end 30 s later on its own (exit 1, its reads timed out), which is what `urb` should do there."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def test_log_never_writes_after_closing_its_file(fake_bridge: Callable[..., BridgeProc], tmp_path: Path) -> None:
    """Ctrl-C with a read unanswered (the bridge stalled), then Ctrl-C again while the command
    waits for it: the file is closed, and the read that completes BRIDGE_LOST when the port
    closes is not written to it (it was a traceback: "I/O operation on closed file")."""
    bp = fake_bridge(["MotorDriver:0@16"])
    assert bp.proc is not None
    out_file = tmp_path / "run.csv"
    proc = subprocess.Popen([sys.executable, "-m", "urb", "log", str(bp.link), "-o", str(out_file), "--rate", "100",
                             "--duration", "30", "--timeout", "30"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=_ctrl_c_interrupts)
    try:
        deadline = time.monotonic() + 10
        while not (out_file.exists() and out_file.stat().st_size > 0) and time.monotonic() < deadline:
            time.sleep(0.02)  # the header is written once discovery is done
        time.sleep(0.3)
        # the bridge answers nothing from now on, yet stays up: not SIGSTOP, whose last response could still
        # reach a loaded host after the first Ctrl-C and end the wait normally (exit 1, seen in CI)
        bp.cmd("drop 1000000")
        deadline = time.monotonic() + 10
        while json.loads(bp.cmd("stats"))["dropped_frames"] == 0 and time.monotonic() < deadline:
            time.sleep(0.05)  # a request has gone unanswered
        time.sleep(1.0)  # and every response sent before the drop has reached the host
        proc.send_signal(signal.SIGINT)
        assert proc.stderr is not None
        said = b""
        deadline = time.monotonic() + 10
        while b"(Ctrl-C to stop now)" not in said and time.monotonic() < deadline:
            if select.select([proc.stderr.fileno()], [], [], 0.1)[0]:
                chunk = os.read(proc.stderr.fileno(), 4096)
                if not chunk:
                    break
                said += chunk
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
        _, rest = proc.communicate(timeout=20)
        err = said.decode() + rest
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert "Traceback" not in err and "closed file" not in err, err
    assert re.search(r"urb: waiting up to 30.5 s for [12] read\(s\) in flight \(Ctrl-C to stop now\)", err), err
    assert proc.returncode == 130 and "urb: interrupted" in err, (proc.returncode, err)
    rows = list(csv.DictReader(out_file.open()))
    assert len(rows) > 10 and all(r["status"] == "OK" for r in rows)


def test_hosted_bridge_fingerprints_are_hex(hosted_bridge: Callable[..., BridgeProc], capsys: pytest.CaptureFixture[str]) -> None:
    bp = hosted_bridge(["motor,0,0x20,fp=deadbeef", "motor,1,0x21,fp=0123", "imu,0,0x30,fp=0X00C0FFEE",
                        "battery,0,0x31"])
    code, out, _ = run(capsys, "scan", str(bp.link), "--json")
    rows = {r["node"] + ":" + str(r["index"]): r for r in json.loads(out)}
    assert code == 1  # three nodes with a fingerprint that is not the schema's
    assert (rows["MotorDriver:0"]["fingerprint"], rows["MotorDriver:1"]["fingerprint"],
            rows["Imu:0"]["fingerprint"]) == ("deadbeef", "00000123", "00c0ffee")
    assert rows["BatteryManager:0"]["fingerprint"] == rows["BatteryManager:0"]["schema_fingerprint"]
    for bad in ("xyz", "", "0x", "123456789", "-1", "12 ", "0x1g"):
        proc = subprocess.run([str(build_hosted_bridge()), "--node", f"motor,0,0x20,fp={bad}", "--seconds", "1"],
                              capture_output=True, text=True, timeout=10)
        assert proc.returncode == 2 and f"bad fingerprint 'fp={bad}': give 1 to 8 hex digits" in proc.stderr, (bad, proc.stderr)


def test_hosted_bridge_numbers_are_decimal_or_0x_hex(hosted_bridge: Callable[..., BridgeProc],
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    # a leading 0 is not octal (010 was read as 8), and a sign is not a number
    bp = hosted_bridge(["motor,010,0x20", "motor,0x0B,0x21"])
    code, out, _ = run(capsys, "scan", str(bp.link), "--json")
    assert code == 0
    assert sorted(r["index"] for r in json.loads(out)) == [10, 11]
    for bad in ("-1", "+1", " 1", "1x", "0x"):
        proc = subprocess.run([str(build_hosted_bridge()), "--node", f"motor,{bad},0x20", "--seconds", "1"],
                              capture_output=True, text=True, timeout=10)
        assert proc.returncode == 2, (bad, proc.stderr)


def test_help_texts_read_like_man_pages(capsys: pytest.CaptureFixture[str]) -> None:
    for cmd in ("scan", "read", "write", "monitor", "log"):
        with pytest.raises(SystemExit) as exc:
            main([cmd, "--help"])
        text = capsys.readouterr().out
        assert exc.value.code == 0
        assert "Exit status:" in text and "Example" in text and "--baud" in text and "usage: urb " + cmd in text, cmd
    proc = subprocess.run([sys.executable, "-m", "urb.cli", "read", "--help"], capture_output=True, text=True, check=True)
    assert "engineering units" in proc.stdout


def test_top_level_help_lists_each_command_once(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    text = capsys.readouterr().out
    assert exc.value.code == 0
    commands = ("scan", "read", "write", "monitor", "log", "gen", "schema", "demo", "sim")
    section = text[text.index("\ncommands:\n"):].split("\n\n")[0]
    listed = [line.split()[0] for line in section.splitlines() if line.startswith("    ") and line.split()]
    assert listed == list(commands), text
    assert "urb COMMAND --help" in text


def test_python_dash_m_urb_is_the_urb_command() -> None:
    proc = subprocess.run([sys.executable, "-m", "urb", "--version"], capture_output=True, text=True, check=False)
    assert proc.returncode == 0 and proc.stdout.startswith("urb "), proc.stderr
    proc = subprocess.run([sys.executable, "-m", "urb", "nonsense"], capture_output=True, text=True, check=False)
    assert proc.returncode == 2 and "invalid choice" in proc.stderr
