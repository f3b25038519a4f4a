"""Misusing the simulation's World gives an error that names the cause, before the C world is
touched, and leaves the world as it was: a refused call loses nothing."""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator

import pytest

from urb_sim.native import RS232, USB, App, World

NS_PER_MS = 1_000_000


@pytest.fixture
def world() -> Iterator[World]:
    """Two bridges (USB 0, RS232 1), a motor node at 0x20 on the USB bridge, not started."""
    w = World(7)
    assert w.add_bridge(USB) == 0
    assert w.add_bridge(RS232) == 1
    assert w.add_node(0, App.MOTOR, 0x20, 0) == 0
    yield w
    w.close()


BUILDING: list[tuple[str, Callable[[World], object], type[Exception], str]] = [
    ("unknown uplink", lambda w: w.add_bridge(9), ValueError, "unknown uplink 9"),
    ("unknown bridge", lambda w: w.add_node(7, App.MOTOR, 0x21), ValueError, "no bridge 7: this world has 2"),
    ("unknown application", lambda w: w.add_node(0, 42, 0x21), ValueError,  # type: ignore[arg-type]
     "unknown application 42"),
    ("address out of range", lambda w: w.add_node(0, App.MOTOR, 0x90), ValueError, "address 144 is not a 7-bit"),
    ("address 0 (general call)", lambda w: w.add_node(0, App.MOTOR, 0), ValueError, "address 0 is not a 7-bit"),
    ("address taken", lambda w: w.add_node(0, App.IMU, 0x20, 1), ValueError,
     "address 0x20 on bridge 0 is taken by node 0"),
    ("index out of range", lambda w: w.add_node(0, App.MOTOR, 0x21, 64), ValueError, "node index 64"),
    ("running before start", lambda w: w.run(NS_PER_MS), RuntimeError, "run: call start() first"),
    ("fault before start", lambda w: w.i2c_ber(0, 1e-3), RuntimeError, "i2c_ber: call start() first"),
    ("native request without a native host", lambda w: w.native_request(0, 0x20, 1, True, 6), ValueError,
     "call native_host(0) first"),
    ("native host period", lambda w: w.native_host(0, 0), ValueError, "period_ticks must be at least 1"),
    ("unknown parameter", lambda w: w.set("no_such_parameter", 1.0), KeyError, "unknown simulation parameter"),
]

RUNNING: list[tuple[str, Callable[[World], object], type[Exception], str]] = [
    ("building after start", lambda w: w.add_node(0, App.MOTOR, 0x21), RuntimeError,
     "add_node: the world has started"),
    ("parameter after start", lambda w: w.set("i2c_bitrate", 1e5), RuntimeError, "set: the world has started"),
    ("starting twice", lambda w: w.start(), RuntimeError, "start: the world has started already"),
    ("bit error rate above 1", lambda w: w.i2c_ber(0, 2.0), ValueError, "ber must be a probability in [0, 1]"),
    ("bit error rate NaN", lambda w: w.i2c_ber(0, float("nan")), ValueError, "got nan"),
    ("negative loss", lambda w: w.usb_loss(0, -0.1), ValueError, "loss must be a probability"),
    ("UART fault on a USB bridge", lambda w: w.uart_fault(0, "up", ber=1e-3), ValueError,
     "bridge 0's uplink is USB; this fault needs a bridge whose uplink is RS232"),
    ("USB loss on an RS232 bridge", lambda w: w.usb_loss(1, 0.1), ValueError, "bridge 1's uplink is RS232"),
    ("UART direction", lambda w: w.uart_fault(1, "sideways"), ValueError, "unknown direction 'sideways'"),
    ("I2C line", lambda w: w.i2c_stuck(0, "sck"), ValueError, "unknown I2C line 'sck'"),
    ("unknown node", lambda w: w.node_power(5, False), ValueError, "no node 5: this world has 1"),
    ("fault on an unknown bridge", lambda w: w.bridge_power(3, False), ValueError, "no bridge 3"),
    ("babble address", lambda w: w.babble(0, 200, 0.1), ValueError, "address 200"),
    ("bytes to an unknown bridge", lambda w: w.host_send(4, b"\x01"), ValueError, "no bridge 4"),
]


@pytest.mark.parametrize("case", BUILDING, ids=[c[0] for c in BUILDING])
def test_a_misuse_while_building_names_its_cause_and_loses_nothing(
        world: World, case: tuple[str, Callable[[World], object], type[Exception], str]) -> None:
    _, call, exc, text = case
    with pytest.raises(exc, match=re.escape(text)):
        call(world)
    # the world is as it was: it can still be built, started and run
    assert world.add_node(1, App.IMU, 0x21, 0) == 1
    world.start()
    world.run(20 * NS_PER_MS)
    assert world.now == 20 * NS_PER_MS and world.events > 0


@pytest.mark.parametrize("case", RUNNING, ids=[c[0] for c in RUNNING])
def test_a_misuse_while_running_names_its_cause_and_loses_nothing(
        world: World, case: tuple[str, Callable[[World], object], type[Exception], str]) -> None:
    _, call, exc, text = case
    world.start()
    world.run(5 * NS_PER_MS)
    events = world.events
    with pytest.raises(exc, match=re.escape(text)):
        call(world)
    assert world.events == events and world.now == 5 * NS_PER_MS  # nothing ran, nothing was scheduled early
    world.run(20 * NS_PER_MS)
    assert world.now == 20 * NS_PER_MS and world.events > events


def test_a_closed_world_says_so() -> None:
    w = World(1)
    w.add_bridge(USB)
    w.start()
    w.close()
    w.close()  # closing twice is fine
    calls: list[Callable[[], object]] = [
        lambda: w.run(NS_PER_MS), lambda: w.node_status(0), lambda: w.plant(0), lambda: w.add_bridge(USB),
        lambda: w.native_request(0, 0x20, 1, True, 6), lambda: w.set("i2c.bitrate", 1e5),
        lambda: w.get("i2c.bitrate"), lambda: w.trace(None), lambda: w.now, lambda: w.events,
        lambda: w.trace_hash, lambda: w.trace_lines, lambda: w.flush_trace(), lambda: w.host_local(),
        lambda: w.host_timer(0), lambda: w.host_take(), lambda: w.host_send(0, b"\x01"),
        lambda: w.node_marks(0), lambda: w.bridge_marks(0), lambda: w.stat("i2c_bytes"),
        lambda: w.native_stat(0, "ok"), lambda: w.i2c_ber(0, 0.0), lambda: w.bridge_power(0, True),
        lambda: w.node_power(0, True), lambda: w.start()]
    for call in calls:
        with pytest.raises(RuntimeError, match="this World is closed"):
            call()


def test_the_same_address_on_two_downlinks_is_fine(world: World) -> None:
    assert world.add_node(1, App.IMU, 0x20, 0) == 1
