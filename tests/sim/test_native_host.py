"""The native host traffic model (used for speed) agrees with the host library on the same rig."""

from __future__ import annotations

import statistics

import pytest

from urb.api import NodeRequest
from urb_sim.native import RS232, USB, App, World
from urb_sim.system import NS_PER_MS, Loop, System


def _run(w: World, seconds: float) -> None:
    limit = int(seconds * 1e9)
    while w.run(limit):
        while w.host_take() is not None:
            pass


@pytest.mark.parametrize("uplink", ["rs232", "usb"])
def test_native_host_matches_host_library(uplink: str) -> None:
    w = World(5)
    w.set("probe.out_size", 6)
    b = w.add_bridge(RS232 if uplink == "rs232" else USB)
    w.add_node(b, App.PROBE, 0x10, 0)
    w.native_host(b, 1)
    w.native_request(b, 0x10, 1, True, 6)
    w.start()
    _run(w, 0.6)
    sent, ok = w.native_stat(b, "sent"), w.native_stat(b, "ok")
    native_ms = w.native_stat(b, "lat_mean_ns") / 1e6
    assert sent > 400 and ok >= sent - w.native_stat(b, "pending") and w.native_stat(b, "failed") == 0
    w.close()

    s = System(seed=5, probe_out=6)
    sb = s.bridge(uplink)
    s.node(sb, App.PROBE, 0x10, 0)
    s.start()
    node = s.urb.find_node(0x7E, 0)
    done: list[NodeRequest] = []
    Loop(s.host, NS_PER_MS, lambda: node.submit_request(node.new_request().read(1, 6).set_callback(done.append)),
         count=300)
    s.host.advance(320 * NS_PER_MS)
    lib_ms = statistics.mean(r.latency_ns for r in done if r.latency_ns is not None) / 1e6
    s.close()
    # Same frames, same buses, same CPU model: latencies agree within a tenth of a millisecond.
    assert abs(native_ms - lib_ms) < 0.1, (native_ms, lib_ms)
