"""SimManager wakes the simulated host at its earliest deadline only, as one timer thread would,
and a timer whose deadline was superseded (a response came, the RS232 resync-gap deadline moved with
the next byte) does nothing: nothing is due then. The manager before that armed a timer per new
deadline and polled at each (a wake-up per RS232 chunk received). On every fault scenario, and on
an RS232 bridge that falls silent (where the timers decide the timeouts), both give the same
outcomes, trace and firmware counters; the new one with far fewer host steps.

Not a proof that they always agree: a superseded timer of the old manager could wake the host
between a later deadline and the OS tick after it, and apply that deadline a tick early. No such
case shows here, nor in every experiment's files at seeds 2 and 3 (sim/README.md, "Host CPU")."""

from __future__ import annotations

from pathlib import Path

import pytest

from urb.managers.sim import SimManager
from urb_sim.experiments import faults


def _arm_every_deadline(self: SimManager, deadline: int | None) -> None:
    """The manager before: a timer for every new deadline."""
    if deadline is not None and deadline not in self._timer_at:
        self._timer_at.add(deadline)
        self.clock.call_at(deadline, lambda: self._on_timer(deadline))


def _poll_at_every_timer(self: SimManager, when: int) -> None:
    """The manager before: every timer polls."""
    self._timer_at.discard(when)
    self.core.poll(self.clock.now_ns())
    self._after_step()


#: Lost responses to a running loop are noticed by the next response (`ResponseMatcher.lost_before`),
#: not by a timer: the timers decide only when the bridge falls silent, as here.
RS232_BRIDGE_RESET = faults.Scenario(
    "rs232_bridge_reset", "rs232", "the RS232 bridge resets (off 200 ms, then a cold start)",
    faults.F.UPLINK_TIMEOUT | faults.F.UPLINK_CHECKSUM | faults.F.BUSY | faults.F.BRIDGE_LOST,
    lambda s, b, n: s.world.bridge_power(b, False), lambda s, b, n: s.world.bridge_power(b, True),
    lambda s, b, n, o: ("", True))


def _run(sc: faults.Scenario, trace: Path, monkeypatch: pytest.MonkeyPatch) -> tuple[faults.Outcome, int]:
    """The scenario's outcome (its trace written to `trace`) and how many timers fired."""
    fired = [0]
    on_timer = SimManager._on_timer

    def counted(self: SimManager, when: int) -> None:
        fired[0] += 1
        on_timer(self, when)

    with monkeypatch.context() as m:
        m.setattr(SimManager, "_on_timer", counted)
        outcome = faults.run_scenario(sc, 7, trace=trace)
    return outcome, fired[0]


@pytest.mark.parametrize("sc", [*faults.scenarios(), RS232_BRIDGE_RESET], ids=lambda sc: sc.key)
def test_one_timer_at_the_earliest_deadline_changes_nothing(sc: faults.Scenario, tmp_path: Path,
                                                            monkeypatch: pytest.MonkeyPatch) -> None:
    now, now_timers = _run(sc, tmp_path / "now.ndjson", monkeypatch)
    monkeypatch.setattr(SimManager, "_arm", _arm_every_deadline)
    monkeypatch.setattr(SimManager, "_on_timer", _poll_at_every_timer)
    before, before_timers = _run(sc, tmp_path / "before.ndjson", monkeypatch)
    assert now == before
    assert (tmp_path / "now.ndjson").read_bytes() == (tmp_path / "before.ndjson").read_bytes()
    if sc.uplink == "rs232":
        assert now_timers < before_timers / 2
    else:
        assert now_timers <= before_timers
