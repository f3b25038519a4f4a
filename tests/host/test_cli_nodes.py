"""`urb scan/read/write/monitor/log` against a bridge process on a pty."""

from __future__ import annotations

import csv
import importlib.util
import json
import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from bridge_proc import BridgeProc, fake_bridge  # noqa: F401 (fixture)
from urb.cli import main

NODES = ["MotorDriver:0@16", "MotorDriver:1@17", "BatteryManager:0@32", "Imu:0@48"]


@pytest.fixture
def port(fake_bridge: Callable[..., BridgeProc]) -> tuple[str, BridgeProc]:
    bp = fake_bridge(NODES)
    return str(bp.link), bp


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


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
    (["write", "{p}", "MotorDriver:0", "2", "mode=VOLTAGE"], "missing kp, kd, target, voltage_limit"),
    (["write", "{p}", "MotorDriver:0", "1", "voltage=99"], "outside -32.768..32.767 V"),
    (["write", "{p}", "MotorDriver:0", "1", "current=1"], "has no field current"),
    (["write", "{p}", "MotorDriver:0", "2", "mode=FAST", "--defaults"], "not one of DISABLED, VOLTAGE, LOCAL_PD"),
    (["read", "{p}", "MotorDriver:7", "1"], "no MotorDriver with index 7"),
    (["read", "{p}", "Gripper", "1"], "no node type named 'Gripper'"),
    (["read", "{p}", "Imu", "ImuSample2"], "has no outbox holding"),
    (["read", "{p}", "Imu", "5"], "has no outbox 5"),
])
def test_usage_errors_say_what_to_do(port: tuple[str, BridgeProc], capsys: pytest.CaptureFixture[str],
                                     argv: list[str], message: str) -> None:
    code, _, err = run(capsys, *[a.format(p=port[0]) for a in argv])
    assert code == 1 and message in err and err.startswith("urb: ")


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
    assert len(rows) > 50
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
    listed = [line.split()[0] for line in text.splitlines() if line.startswith("    ") and line.split()]
    assert listed == list(commands), text
    assert "urb COMMAND --help" in text


def test_python_dash_m_urb_is_the_urb_command() -> None:
    proc = subprocess.run([sys.executable, "-m", "urb", "--version"], capture_output=True, text=True, check=False)
    assert proc.returncode == 0 and proc.stdout.startswith("urb "), proc.stderr
    proc = subprocess.run([sys.executable, "-m", "urb", "nonsense"], capture_output=True, text=True, check=False)
    assert proc.returncode == 2 and "invalid choice" in proc.stderr
