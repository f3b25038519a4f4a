"""Node-side STUCK_BUS: SCL held low on a downlink. Every node's I2C peripheral times out
(node.scl_timeout_ms, SMBus-style), the node library aborts the transaction in progress and
reports STUCK_BUS to the application once (after LOST_SYNC: no SYNC gets through); the bridge times out and clears the bus; every failed
host request reaches its callback with a flag naming the stuck bus (or its consequences)."""

from __future__ import annotations

import json
from pathlib import Path

from urb_sim.experiments import faults

MS = 1_000_000


def _scl_scenario() -> faults.Scenario:
    return next(sc for sc in faults.scenarios() if sc.key == "i2c_scl_stuck")


def _events(path: Path) -> list[dict[str, object]]:
    return [json.loads(line) for line in path.read_text().splitlines()]


# lobster-trace: urb.ERR_005
def test_nodes_report_stuck_bus(tmp_path: Path) -> None:
    trace = tmp_path / "faults.ndjson"
    out = faults.run_scenario(_scl_scenario(), seed=302, trace=trace)
    assert out.submitted > 0 and faults.accounting(out.submitted, out.called_back)[1]
    assert sum(out.failures.values()) > 0 and not out.wrong_flags, dict(out.wrong_flags)
    assert out.failures.get("BUS_STUCK", 0) > 0  # the bridge names the cause
    assert out.recovered and out.reaction_ok, out.reaction
    ev = _events(trace)
    inject = next(e for e in ev if e["ev"] == "scl_stuck")
    t0 = int(str(inject["t"]))
    for node in ("usb0/n16", "usb0/n17", "usb0/n18"):
        timeouts = [e for e in ev if e["dev"] == node and e["ev"] == "scl_timeout"]
        reports = [e for e in ev if e["dev"] == node and e["ev"] == "app_fault"]
        assert len(timeouts) == 1, node
        dt = int(str(timeouts[0]["t"])) - t0
        assert 25 * MS <= dt < 25 * MS + 10_000  # the timeout, plus the interrupt latency
        stuck = [r for r in reports if r["fault"] == "stuck_bus"]
        assert len(stuck) == 1, node
        assert 0 < int(str(stuck[0]["t"])) - int(str(timeouts[0]["t"])) < 2 * MS  # the next main-loop pass
        # no SYNC gets through either: the PLL reports LOST_SYNC (before the SCL timeout)
        assert {str(r["fault"]) for r in reports} == {"lost_sync", "stuck_bus"}, node
    bridge = {str(e["ev"]) for e in ev if e["dev"] in ("usb0", "usb0/i2c")}
    assert {"bus_clear", "bus_released"} <= bridge, bridge  # the nine-pulse clear, then SCL lets go


def test_no_stuck_bus_when_scl_released_before_the_timeout(tmp_path: Path) -> None:
    """The report comes from SCL staying low through the timeout, not from the injection: with a
    timeout longer than the 200-ms fault no node reports it (and the scenario's reaction check,
    which requires one report per node, fails)."""
    trace = tmp_path / "faults.ndjson"
    out = faults.run_scenario(_scl_scenario(), seed=302, trace=trace, params={"node.scl_timeout_ms": 250.0})
    ev = _events(trace)
    assert not [e for e in ev if e["ev"] == "scl_timeout" or e.get("fault") == "stuck_bus"]
    assert not out.reaction_ok
    assert faults.accounting(out.submitted, out.called_back)[1]
