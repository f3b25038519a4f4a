"""The fault scenarios' reaction checks measure the firmware's and the host library's reaction, so
each can fail: a fault that hits nothing, or a reaction that is not the designed one, is a FAIL
(sim/urb_sim/experiments/faults.py). One scenario per test, to stay fast."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from urb.errors import ErrorFlag
from urb.managers import native, rs232_core
from urb.managers.base import Transfer, finish
from urb.managers.sim import SimManager
from urb_sim.experiments import faults


def _scenario(key: str, **change: Any) -> faults.Scenario:
    sc = next(sc for sc in faults.scenarios() if sc.key == key)
    return dataclasses.replace(sc, **change)


def test_uart_bit_errors_that_corrupt_nothing_fail() -> None:
    """At a bit error rate that flips nothing in the 200-ms window, the scenario tested nothing:
    both the reaction check and the flags check (no failure at all) say so."""
    out = faults.run_scenario(_scenario("uart_bit_errors", inject=faults._uart(ber=1e-9)), seed=1)
    assert faults.accounting(out.submitted, out.called_back)[1] and out.recovered
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
    monkeypatch.setattr(native, "BACKEND", "python")  # the seeded bug is in the reference core: run it
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


def test_accounting_matches_callbacks_to_requests_one_by_one() -> None:
    """Each request number once: a lost callback and a doubled one leave the totals equal and fail;
    so does a callback for a request never submitted."""
    assert faults.accounting(3, [2, 0, 1]) == ("3 callbacks for 3 requests, each request exactly once", True)
    measured, passed = faults.accounting(3, [0, 2, 2])
    assert not passed
    assert measured == ("3 callbacks for 3 requests: 1 request never called back (#1); 1 request called back "
                        "more than once (#2)")
    assert not faults.accounting(2, [0, 1, -1])[1]
    assert faults.lose_one_double_another([0, 1, 2, 3]) == [0, 1, 3, 3]


def test_a_lost_callback_and_a_doubled_one_fail_the_accounted_check(monkeypatch: pytest.MonkeyPatch,
                                                                    tmp_path: Path) -> None:
    """A seeded bug in the host library (the manager hands the 50th completed request to no
    callback and the 51st to its callback twice) passes a comparison of totals; the accounted check
    names both requests. The experiment's own seeded bug (MUTANT_CHECK) is rejected on the
    scenario's real callbacks, and the check is met without the bug."""
    sc = _scenario("node_power_loss")
    monkeypatch.setattr(faults, "scenarios", lambda: [sc])
    clean = faults.faults(tmp_path / "clean")
    assert {c.name: c.passed for c in clean.checks}[f"{sc.key}: accounted"]
    real = SimManager._queue_completed
    handed = [0]

    def lose_one_double_next(self: SimManager, core: Any, put: Callable[[Any], None]) -> None:
        def faulty(item: Any) -> None:
            if isinstance(item, Transfer):
                handed[0] += 1
                if handed[0] == 50:
                    return
                if handed[0] == 51:
                    put(item)
            put(item)
        real(self, core, faulty)

    monkeypatch.setattr(SimManager, "_queue_completed", lose_one_double_next)
    res = faults.faults(tmp_path / "bug")
    checks = {c.name: c for c in res.checks}
    accounted = checks[f"{sc.key}: accounted"]
    assert not accounted.passed
    [(total, submitted)] = [(int(w[0]), int(w[3])) for w in [accounted.measured.split()]]
    assert total == submitted  # the totals agree: only the one-by-one match sees the bug
    assert "1 request never called back" in accounted.measured
    assert "1 request called back more than once" in accounted.measured
    assert checks[faults.MUTANT_CHECK].passed
