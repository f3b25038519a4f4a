"""The real firmware and the real host library together in virtual time: discovery and periodic
reads over both uplinks, heartbeat lock, and basic accounting."""

from __future__ import annotations

import statistics

import pytest

from urb.api import NodeRequest
from urb_sim.native import App
from urb_sim.system import Loop, System

NS_PER_MS = 1_000_000


@pytest.mark.parametrize("uplink", ["rs232", "usb"])
def test_discovery_and_reads(uplink: str) -> None:
    s = System(seed=11, probe_out=6)
    b = s.bridge(uplink)
    for i in range(3):
        s.node(b, App.PROBE, 0x10 + i, i)
    s.start()
    found = sorted((r.address, r.index) for r in s.urb.nodes())
    assert found == [(0x10, 0), (0x11, 1), (0x12, 2)]
    node = s.urb.find_node(0x7E, 1)
    done: list[NodeRequest] = []

    def tick() -> None:
        node.submit_request(node.new_request().read(1, 6).set_callback(done.append))

    Loop(s.host, NS_PER_MS, tick, count=200)
    s.host.advance(220 * NS_PER_MS)
    assert len(done) == 200 and all(r.ok for r in done)
    data = [r.data for r in done]
    counters = [int.from_bytes(d[:4], "little") for d in data if d is not None]
    assert counters == sorted(counters) and len(set(counters)) > 150  # fresh data every cycle
    lat = [r.latency_ns for r in done if r.latency_ns is not None]
    if uplink == "rs232":
        # request 4 bytes + response 8 bytes = 12 characters = 1.04 ms of line time, plus I2C
        assert 1.1 * NS_PER_MS < statistics.mean(lat) < 1.5 * NS_PER_MS
    else:
        assert 1.0 * NS_PER_MS < statistics.mean(lat) <= 3.2 * NS_PER_MS
    for i in range(3):
        st = s.world.node_status(i)
        assert st.synced and st.init_result == 0
    s.close()
