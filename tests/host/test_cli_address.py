"""Nodes reached by their bus address ([PORT]@ADDR), whatever their class and flags: the bridge
README's generic node at 0x30 (class 0x42, in the hosted bridge firmware), duplicates told apart,
a node built from another schema read as raw bytes; and `urb scan`'s advice names only the flags
that were raised, in the command line's own words."""

from __future__ import annotations

import json
from collections.abc import Callable

import pytest

from bridge_proc import BridgeProc, fake_bridge, hosted_bridge  # noqa: F401 (fixtures)
from cli_run import run
from urb.api import URBInterface
from urb.errors import DuplicateNodeError, ErrorFlag, FingerprintMismatchError, NodeNotFoundError
from urb.managers import BridgeModel, LoopbackByteTransport, SimManager, VirtualClock, fake_node
from urb_msgs import sensorhex as sx

README_NODES = ["motor,0,0x20", "0x42,3,0x30,in1=8,out1=8"]
"""firmware/bridge/README.md, "Hosted bridge program": a motor driver and a generic node."""


def test_the_readme_generic_node_is_read_and_written_by_address(hosted_bridge: Callable[..., BridgeProc],
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    bp = hosted_bridge(README_NODES)
    port = str(bp.link)
    code, out, err = run(capsys, "scan", port, "--json")
    rows = {r["address"]: r for r in json.loads(out)}
    assert code == 1 and rows[0x30]["flags"] == ["UNKNOWN_CLASS"] and rows[0x30]["class"] == 0x42
    code, out, err = run(capsys, "write", port, "@0x30", "1", "--raw", "0102030405060708")
    assert code == 0 and "class 0x42:3@48 inbox 1 RawMailbox: stored" in out, err
    code, out, err = run(capsys, "read", port, "@0x30", "1", "--raw")
    assert code == 0 and out.strip() == "0102030405060708", err  # echoed to outbox 1 by the fake node
    code, out, err = run(capsys, "write", port, f"{port}@48", "1", "data=a1a2a3a4a5a6a7a8")
    assert code == 0, err
    code, out, err = run(capsys, "read", port, "@0x30", "1", "--json")
    assert code == 0 and json.loads(out)["fields"] == {"data": "a1a2a3a4a5a6a7a8"}, err
    code, out, err = run(capsys, "read", port, "@0x30", "1")
    assert code == 0 and "class 0x42:3@48 outbox 1 RawMailbox" in out and "data  a1a2a3a4a5a6a7a8" in out, err
    # its identification says how big its mailboxes are
    code, _, err = run(capsys, "write", port, "@0x30", "1", "--raw", "01")
    assert code == 2 and "class 0x42:3@48 inbox 1 takes 8 bytes, --raw gives 1" in err, err
    # the schema's node at 0x20 by address: decoded with the schema
    code, out, err = run(capsys, "read", port, "@0x20", "MotorFeedback", "--json")
    assert code == 0 and set(json.loads(out)["fields"]) == {"encoder", "current", "voltage"}, err
    # @0: the bridge itself
    code, out, err = run(capsys, "read", port, "@0", "0", "--json")
    assert code == 0 and json.loads(out)["fields"]["fifo_depth"] > 0, err
    code, out, err = run(capsys, "monitor", port, "--node", "@0x30", "--mailbox", "1", "--rate", "50", "--duration", "0.4")
    assert code == 0 and "class 0x42:3@48/1" in out and "RawMailbox" in out and "data=a1a2a3a4a5a6a7a8" in out, err


def test_duplicates_are_reached_by_address_and_the_advice_names_only_duplicate(
        fake_bridge: Callable[..., BridgeProc], capsys: pytest.CaptureFixture[str]) -> None:
    bp = fake_bridge(["Imu:0@48", "Imu:0@50"])
    port = str(bp.link)
    code, out, err = run(capsys, "scan", port)
    assert code == 1
    advice = [line for line in out.splitlines() if line.startswith(("DUPLICATE", "MISMATCH", "UNKNOWN_CLASS"))]
    assert len(advice) == 1 and advice[0].startswith("DUPLICATE: Imu:0 answers at 2 places"), out
    assert f"{port}@48" in out and f"{port}@50" in out
    assert "MISMATCH" not in out and "UNKNOWN_CLASS" not in out and "find_node" not in out and "()" not in out
    code, _, err = run(capsys, "read", port, "Imu", "1")
    assert code == 1 and "answers at 2 places" in err and f"give one by its bus address: {port}@48, {port}@50" in err
    for address in ("48", "50"):
        code, out, err = run(capsys, "read", port, f"@{address}", "ImuSample", "--json")
        assert code == 0 and json.loads(out)["node"] == f"Imu:0@{address}", err


def test_a_mismatched_node_is_read_raw_by_address_and_the_advice_names_only_mismatch(
        fake_bridge: Callable[..., BridgeProc], capsys: pytest.CaptureFixture[str]) -> None:
    bp = fake_bridge(["MotorDriver:0@16", "Imu:0@48!fp=00c0ffee"])
    port = str(bp.link)
    code, out, _ = run(capsys, "scan", port)
    advice = [line for line in out.splitlines() if line.startswith(("DUPLICATE", "MISMATCH", "UNKNOWN_CLASS"))]
    assert code == 1 and len(advice) == 1, out
    assert advice[0].startswith("MISMATCH: Imu:0 at ") and "reports layout fingerprint 00c0ffee" in out
    assert f"urb read {port} @48 MAILBOX" in out and "DUPLICATE" not in out and "find_node" not in out
    code, _, err = run(capsys, "read", port, "Imu", "1")
    assert code == 1 and f"its bytes can be read by its bus address: urb read {port} @48 MAILBOX" in err, err
    code, out, err = run(capsys, "read", port, "@48", "1")
    assert code == 0 and "Imu:0@48 outbox 1 RawMailbox" in out and "data  " in out, err


def test_node_at_in_the_api() -> None:
    """URBInterface.node_at: the address tells duplicates apart; a node built from another schema
    gets its own layout (raw bytes), while find_node refuses both."""
    from urb.raw_node import RawMailbox

    clock = VirtualClock()
    bridge = BridgeModel(dict(fake_node(s) for s in ["Imu:0@48", "Imu:0@50", "MotorDriver:0@16!fp=00c0ffee"]))
    m = SimManager(clock, LoopbackByteTransport(clock, bridge), name="sim")
    urb = URBInterface()
    urb.add_bus_manager(m)
    with pytest.raises(DuplicateNodeError):
        urb.find_node("Imu", 0)
    with pytest.raises(FingerprintMismatchError):
        urb.find_node("MotorDriver", 0)
    first, second = urb.node_at(m, 48), urb.node_at(m, 50)
    assert (first.address, second.address) == (48, 50) and first.info is sx.NODES["Imu"]
    assert isinstance(first.read(1), sx.ImuSample)
    motor = urb.node_at(m, 16)
    assert motor.info.name == "class 0x10" and [b.size for b in motor.info.mailboxes if b.direction == "outbox"] == [25, 6, 4]
    assert motor.info.fingerprint == 0x00C0FFEE and len(motor.read_raw(1)) == 6
    assert isinstance(motor.read(1), RawMailbox)
    req = motor.new_request().write(1, bytes(2))
    motor.submit_request(req)
    assert req.wait() and req.flags == ErrorFlag.NONE
    assert urb.node_at(m, 0).info.name == "Bridge"
    with pytest.raises(NodeNotFoundError, match="no node answered at address 17"):
        urb.node_at(m, 17)
