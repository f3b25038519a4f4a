"""TraceBridge.tla on hand-written bridge traces: an accepted trace, and a rejected one that reports,
from its single TLC run, the longest prefix a behaviour of Bridge.tla matched."""

from __future__ import annotations

import pytest

from urb_sim.tracecheck import Event, check_bridge

PRESENT = {0x10: {1: 6}}
OK = 0  # URB_STATUS_OK


pytestmark = pytest.mark.usefixtures("tlc_installed")


def _reads(n: int) -> list[Event]:
    """n reads of node 0x10 mailbox 1, each answered OK before the next."""
    out: list[Event] = []
    for seq in range(1, n + 1):
        out += [Event("req", 0x10, 1, "read", 6, seq), Event("resp", seq=seq, status=OK)]
    return out


# lobster-trace: urb.ORD_007
def test_fault_free_trace_is_accepted() -> None:
    r = check_bridge(_reads(3), PRESENT)
    assert r.accepted, r.message
    assert r.matched_prefix == r.events == 6


def test_rejected_trace_reports_its_longest_matched_prefix() -> None:
    trace = _reads(3)
    trace[3].seq = 3  # the second response names the third request: event 4 matches no behaviour
    r = check_bridge(trace, PRESENT)
    assert not r.accepted
    assert r.matched_prefix == 3, r.message
    assert "matches up to event 3 of 6" in r.message


def test_no_node_for_a_present_node_needs_the_vanish_fault() -> None:
    """A present node that acknowledges neither its address nor the bridge's probe (it vanished, or
    bit errors hit both) is answered NO_NODE: Bridge.tla allows that only as a downlink fault."""
    trace = _reads(2)
    trace[3].status = 4  # URB_STATUS_NO_NODE
    assert not check_bridge(trace, PRESENT).accepted
    r = check_bridge(trace, PRESENT, faults=["NO_NODE"])
    assert r.accepted, r.message


# lobster-trace: urb.ORD_007
def test_a_mutant_must_be_rejected_where_its_mutation_is() -> None:
    from urb_sim.experiments import Result
    from urb_sim.experiments.traces import check_mutant, first_change
    from urb_sim.tracecheck import TraceResult

    trace = _reads(3)
    mutant = _reads(3)
    mutant[3].seq = 3
    assert first_change(trace, mutant) == 3 and first_change(trace, trace[:4]) == 4
    res = Result("traces", "t", "p")
    check_mutant(res, "at the mutation", "r", TraceResult(False, 6, 3, 5, 0.1, ""), 3)
    check_mutant(res, "before the mutation", "r", TraceResult(False, 6, 2, 5, 0.1, ""), 3)
    check_mutant(res, "accepted", "r", TraceResult(True, 6, 6, 5, 0.1, ""), 3)
    assert [c.passed for c in res.checks] == [True, False, False]
    assert res.checks[1].measured == "rejected at event 3; first mutated event 4"
