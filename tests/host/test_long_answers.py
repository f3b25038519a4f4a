"""A request the bridge answers late by design (a SCAN command: answered when the scan is over)
keeps its sequence number and the bridge alive for as long as it may take, and the requests
behind it start their clocks after it (`Transfer.answer_within_ns`, `rs232_core.SCAN_ANSWER_NS`).

A scan at 100 kb/s with a node holding SCL low probes every address to the downlink timeout:
866.8 ms, where the usual 100-ms timeout and 300-ms lifetime would time out the SCAN and the
scan-map read, release their numbers while the bridge still holds them (Bridge.tla
`HostExpire`'s premise broken), and declare a silent bridge lost after 500 ms.
"""

from __future__ import annotations

import pytest

from urb import api
from urb.api import URBInterface
from urb.errors import ErrorFlag, NoBridgeError
from urb.managers import (
    BridgeModel,
    LoopbackByteTransport,
    LoopbackFrameTransport,
    Rs232Core,
    SimManager,
    VirtualClock,
    fake_node,
)
from urb.managers.base import NS_PER_MS, Transfer
from urb.managers.rs232_core import PLACEHOLDER_NS, SCAN_ANSWER_NS, SCAN_WORST_US
from urb_msgs.urb_core import Status, UplinkResponse

MS = NS_PER_MS


def test_scan_answer_time_covers_the_worst_scan() -> None:
    assert SCAN_WORST_US == 866_775  # 127 addresses x (6720-us downlink timeout + 105-us bus clear)
    assert SCAN_ANSWER_NS >= PLACEHOLDER_NS + SCAN_WORST_US * 1000


def core_with_a_long_request(placeholder_ns: int = 300 * MS) -> tuple[Rs232Core, Transfer, Transfer]:
    """A SCAN-like write sent at 0 that may take 1.5 s, and a read sent behind it at 10 ms."""
    core = Rs232Core(timeout_ns=100 * MS, lost_after_ns=500 * MS, placeholder_ns=placeholder_ns)
    core.reset(0)
    scan = Transfer(address=0, mailbox=0, read=False, length=2, data=b"\x01\x00", answer_within_ns=1500 * MS)
    behind = Transfer(address=0, mailbox=1, read=True, length=16)
    core.submit(scan, 0)
    core.frames_to_send(0)
    core.submit(behind, 10 * MS)
    core.frames_to_send(10 * MS)
    return core, scan, behind


def test_a_long_request_and_the_one_behind_it_time_out_after_its_answer_time() -> None:
    core, scan, behind = core_with_a_long_request()
    assert (scan.due_ns, scan.expires_ns) == (1500 * MS, 1500 * MS)
    assert (behind.due_ns, behind.expires_ns) == (1600 * MS, 1800 * MS)  # its clocks start at 1.5 s
    core.poll(1499 * MS)
    assert not scan.done and not behind.done and core.lost_reason is None  # 1.5 s of silence is no loss
    core.poll(1500 * MS)  # its lifetime is its answer time: no placeholder left
    assert scan.flags == ErrorFlag.UPLINK_TIMEOUT and not behind.done
    assert core.in_flight == 1 and core.placeholders == 0
    core.poll(1600 * MS)
    assert behind.done and core.in_flight == 1 and core.placeholders == 1
    assert core.next_deadline() == 1800 * MS


def test_silence_after_the_long_answer_time_is_a_loss_again() -> None:
    core, _, behind = core_with_a_long_request(placeholder_ns=600 * MS)  # `behind` in flight until 2.1 s
    core.poll(1999 * MS)
    assert behind.done and core.in_flight == 1
    assert core.lost_reason is None
    core.poll(2000 * MS)
    assert core.lost_reason is not None and "500 ms" in core.lost_reason


def test_an_answered_long_request_no_longer_holds_back_the_next_ones() -> None:
    core, scan, behind = core_with_a_long_request()
    core.receive(UplinkResponse(seq=scan.seq, status=Status.OK, data=b"").encode(), 20 * MS)
    assert scan.ok and not behind.done
    later = Transfer(address=0, mailbox=1, read=True, length=16)
    core.submit(later, 30 * MS)
    core.frames_to_send(30 * MS)
    assert (later.due_ns, later.expires_ns) == (130 * MS, 330 * MS)


@pytest.mark.parametrize("kind", ["rs232", "usb"])
@pytest.mark.parametrize("answer_within", ["scan", "mutant-usual"])
def test_discovery_with_a_slow_scan(kind: str, answer_within: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """A bridge whose SCAN takes 900 ms (the 100-kb/s worst case): discovery finds every node.
    With the usual answer time (the mutant: the code before) it fails on the scan map."""
    if answer_within != "scan":
        monkeypatch.setattr(api, "SCAN_ANSWER_NS", 0)
    clock = VirtualClock()
    nodes = dict(fake_node(s) for s in ("MotorDriver:0@16", "Imu:0@48"))
    bridge = BridgeModel(nodes, timed_downlink=True, bitrate_kbps=100, scan_ns=900 * MS)
    transport = LoopbackByteTransport(clock, bridge) if kind == "rs232" else LoopbackFrameTransport(clock, bridge)
    m = SimManager(clock, transport, name=f"slow-scan-{kind}")
    urb = URBInterface()
    if answer_within == "scan":
        report = urb.add_bus_manager(m)
        assert report.present == [16, 48] and not report.problems, report
        assert m.lost_reason is None and m.stats.late_responses == 0
    else:
        with pytest.raises(NoBridgeError, match="scan map"):
            urb.add_bus_manager(m)
