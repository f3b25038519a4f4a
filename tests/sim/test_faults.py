"""The fault scenarios' reaction checks measure the firmware's and the host library's reaction, so
each can fail: a fault that hits nothing, or a reaction that is not the designed one, is a FAIL
(sim/urb_sim/experiments/faults.py). One scenario per test, to stay fast."""

from __future__ import annotations

import dataclasses
from typing import Any

import pytest

from urb.errors import ErrorFlag
from urb.managers import rs232_core
from urb.managers.base import finish
from urb_sim.experiments import faults


def _scenario(key: str, **change: Any) -> faults.Scenario:
    sc = next(sc for sc in faults.scenarios() if sc.key == key)
    return dataclasses.replace(sc, **change)


def test_uart_bit_errors_that_corrupt_nothing_fail() -> None:
    """At a bit error rate that flips nothing in the 200-ms window, the scenario tested nothing:
    both the reaction check and the flags check (no failure at all) say so."""
    out = faults.run_scenario(_scenario("uart_bit_errors", inject=faults._uart(ber=1e-9)), seed=1)
    assert out.callbacks == out.submitted and out.recovered
    assert not out.reaction_ok
    assert "corrupted no character" in out.reaction
    required, measured, passed = faults._flags_check(out)
    assert not passed
    assert required.startswith("at least one request fails")
    assert measured.startswith("no failure at all")


def test_usb_in_loss_reaction_is_the_host_timing_out_the_lost_responses(monkeypatch: pytest.MonkeyPatch) -> None:
    """The requests whose responses were lost complete UPLINK_TIMEOUT, counted against the bridge's
    own response counter. A host library that flagged them UPLINK_CHECKSUM instead (a flag the flags
    check allows) fails the reaction check."""
    sc = _scenario("usb_in_loss")
    out = faults.run_scenario(sc, seed=308)
    assert out.reaction_ok, out.reaction
    assert out.flagged["UPLINK_TIMEOUT"] > 0

    def wrong_flag(self: rs232_core.ResponseMatcher, k: int, now: int) -> None:
        for _ in range(k):
            self.completed.append(finish(self.inflight.popleft(), now, ErrorFlag.UPLINK_CHECKSUM))

    monkeypatch.setattr(rs232_core.ResponseMatcher, "lost_before", wrong_flag)
    bad = faults.run_scenario(sc, seed=308)
    assert faults._flags_check(bad)[2]  # UPLINK_CHECKSUM is an allowed flag ...
    assert not bad.reaction_ok  # ... but not the designed reaction to a lost response
    assert "0 requests completed UPLINK_TIMEOUT" in bad.reaction


def test_failures_are_plotted_after_the_injection() -> None:
    """The timeline and the fault window share one origin (the loop's start, simulated time): a
    node that loses power fails requests only after the injection."""
    out = faults.run_scenario(_scenario("node_power_loss"), seed=303)
    bad = [t for t, ok in out.timeline if not ok]
    assert bad
    assert faults.T_ON / 1e6 <= min(bad) < faults.T_ON / 1e6 + 5
