"""`World.run_take` (urbsim_run_take + urbsim_host_take_more: one call into the world per host
wake-up) hands the host exactly what `run` followed by `host_take` until None hands it: the same
items, in the same order, at the same instants, so the host library's run is the same."""

from __future__ import annotations

import pytest

from urb_sim.host import SimHost
from urb_sim.native import World
from urb_sim.sensorhex_load import sensorhex_tick, wire_sensorhex
from urb_sim.system import NS_PER_MS, Loop, System

Delivery = tuple[int, int, int, bytes]  # (wake-up number, virtual ns, bridge, bytes)


class TakeByItem(SimHost):
    """The host loop as it was before run_take: `run`, then `host_take` until it finds nothing."""

    def step(self, limit_v: int) -> bool:
        t_py = self._events[0][0] if self._events else (1 << 64) - 1
        target = min(t_py, limit_v)
        if self.world.run(target):
            items = []
            while (item := self.world.host_take()) is not None:
                items.append(item)
            self._deliver(items)
            return True
        return super().step(target) if t_py <= target else False


class FirstItemOnly(SimHost):
    """A seeded bug: each wake-up hands over the first ready item only (run_take's `more` ignored)."""

    def step(self, limit_v: int) -> bool:
        t_py = self._events[0][0] if self._events else (1 << 64) - 1
        target = min(t_py, limit_v)
        if self.world.run(target):
            item = self.world.host_take()
            self._deliver([] if item is None else [item])
            return True
        return super().step(target) if t_py <= target else False


#: read threads that wake 3 ms after their data (instead of 20-50 us): a USB read thread then finds
#: several IN transfers waiting, and the wake-ups of the later ones find nothing left
SLOW_READER = {"cpu.io_wake_us": 3000.0}


def sensorhex_deliveries(host_kind: type[SimHost], params: dict[str, float],
                         ms: int = 150) -> tuple[list[Delivery], int, int]:
    """Every item the host's read threads receive in `ms` of the SensoRHex topology (two USB bridges
    with three motors each, every motor read and commanded each ms; an RS232 bridge with the
    sensors read at 100 Hz): the deliveries, the wake-ups that received several items, and those
    that received none."""
    s = System(seed=7, params=params)
    s.host = host_kind(s.world)
    wire_sensorhex(s)
    got: list[Delivery] = []
    per_wake: dict[int, int] = {}
    deliver = s.host._deliver

    def recording(items: list[tuple[int, bytes]]) -> None:
        wake = s.host.wakeups
        per_wake[wake] = len(items)
        got.extend((wake, s.world.now, b, d) for b, d in items)
        deliver(items)

    s.host._deliver = recording  # type: ignore[method-assign]
    s.start()
    Loop(s.host, NS_PER_MS, sensorhex_tick(s), count=ms)
    s.host.advance((ms + 20) * NS_PER_MS)
    s.close()
    return got, sum(1 for n in per_wake.values() if n > 1), sum(1 for n in per_wake.values() if n == 0)


RIGS = {"as modelled": {}, "slow read threads": SLOW_READER}
_reference: dict[str, tuple[list[Delivery], int, int]] = {}


def reference(rig: str) -> tuple[list[Delivery], int, int]:
    if rig not in _reference:
        _reference[rig] = sensorhex_deliveries(TakeByItem, RIGS[rig])
    return _reference[rig]


@pytest.mark.parametrize("rig", list(RIGS))
def test_run_take_hands_over_what_run_and_host_take_do(rig: str) -> None:
    got, several, none = sensorhex_deliveries(SimHost, RIGS[rig])
    ref, ref_several, ref_none = reference(rig)
    assert len(ref) > 300
    assert got == ref
    assert (several, none) == (ref_several, ref_none)
    if rig == "slow read threads":
        # witnesses: wake-ups that found several items ready (run_take's `more`, host_take_more)
        # and wake-ups that found none (run_take's bridge -1)
        assert several > 0 and none > 0
    else:
        # as modelled, a read thread wakes 20-50 us after its data: one item per wake-up
        assert several == 0 and none == 0


@pytest.mark.parametrize("rig", list(RIGS))
def test_a_host_loop_that_drops_items_is_caught(rig: str) -> None:
    """The seeded bug (`more` ignored) changes what the host receives where a wake-up finds several
    items; as modelled none does, so there it goes unseen: the slow rig is the one that catches it."""
    got, _, _ = sensorhex_deliveries(FirstItemOnly, RIGS[rig])
    assert (got != reference(rig)[0]) == (rig == "slow read threads")


def test_run_take_at_the_limit_and_on_a_closed_world() -> None:
    w = World(1)
    w.add_bridge(0)
    w.start()
    assert w.run_take(1_000_000) is None  # nothing for the host before the limit
    assert w.now == 1_000_000
    w.close()
    with pytest.raises(RuntimeError, match="closed"):
        w.run_take(2_000_000)


def test_run_take_before_start_is_refused() -> None:
    w = World(1)
    with pytest.raises(RuntimeError, match="start"):
        w.run_take(1)
    w.close()
