"""The host CPU of a simulated world: the `Clock` the host library's `SimManager` runs on, and
the RS232 / USB transports that connect it to the simulated bridges.

CPU model (sim/README.md, "Host CPU"): application threads that sleep wake on the 1-kHz OS tick
(`call_at` returns at the first tick at or after the requested time, plus scheduling jitter);
threads blocked on I/O wake when the data arrives, after an interrupt-to-thread latency. Both are
computed by the C world (urbsim_host_timer, urbsim_run's wake-ups) from the world's seed, so the
Python side stays deterministic: it only ever runs at the virtual instants the C side names.

Clock time (`now_ns`) is the simulated computer's CLOCK_MONOTONIC: its crystal has its own error,
like every other device's.
"""

from __future__ import annotations

import heapq
import itertools
from collections.abc import Callable

from .native import World

NEVER = (1 << 64) - 1


class SimHost:
    """The simulated host computer: a `DrivableClock` for `SimManager`, plus the event loop that
    interleaves the C world with host threads."""

    def __init__(self, world: World) -> None:
        self.world = world
        self._events: list[tuple[int, int, Callable[[], None]]] = []
        self._seq = itertools.count()
        self._receivers: dict[int, Callable[[bytes], None]] = {}
        self.wakeups = 0
        self.timer_runs = 0

    # -- Clock / DrivableClock ------------------------------------------------------------------
    def now_ns(self) -> int:
        """The host's CLOCK_MONOTONIC (its own crystal), ns."""
        return self.world.host_local()

    def call_at(self, when_ns: int, fn: Callable[[], None]) -> None:
        """Run `fn` in a thread that sleeps until host time `when_ns`: at the next OS tick."""
        heapq.heappush(self._events, (self.world.host_timer(when_ns), next(self._seq), fn))

    def call_soon(self, fn: Callable[[], None]) -> None:
        """Run `fn` at the current virtual instant, after what is running now."""
        heapq.heappush(self._events, (self.world.now, next(self._seq), fn))

    def run_until(self, predicate: Callable[[], bool], limit_ns: int) -> bool:
        """Advance until `predicate()` holds or host time reaches `limit_ns`."""
        limit_v = self.world.now + max(0, limit_ns - self.now_ns())
        while not predicate():
            if not self.step(limit_v):
                return predicate()
        return True

    # -- event loop -----------------------------------------------------------------------------
    def step(self, limit_v: int) -> bool:
        """Run the C world to the next host activity (a timer or an I/O wake-up) no later than
        virtual time `limit_v` and perform it. False when `limit_v` was reached with nothing to do."""
        t_py = self._events[0][0] if self._events else NEVER
        target = min(t_py, limit_v)
        items = self.world.run_take(target)
        if items is not None:
            self._deliver(items)
            return True
        if t_py <= target:
            now = self.world.now
            while self._events and self._events[0][0] <= now:
                _, _, fn = heapq.heappop(self._events)
                self.timer_runs += 1
                fn()
            return True
        return False

    def advance_to(self, t_v: int) -> None:
        """Run everything up to virtual time `t_v` and stop there."""
        while self.step(t_v):
            pass

    def advance(self, duration_ns: int) -> None:
        self.advance_to(self.world.now + duration_ns)

    def _deliver(self, items: list[tuple[int, bytes]]) -> None:
        """A read thread's wake-up: the items the world handed over, each to its bridge's receiver."""
        self.wakeups += 1
        for bridge, data in items:
            receiver = self._receivers.get(bridge)
            if receiver is not None:
                receiver(data)

    # -- transports -----------------------------------------------------------------------------
    def rs232(self, bridge: int) -> SimRs232Transport:
        return SimRs232Transport(self, bridge)

    def usb(self, bridge: int) -> SimUsbTransport:
        return SimUsbTransport(self, bridge)


class SimRs232Transport:
    """`ByteTransport` to a simulated RS232 bridge: `send` is one write() to the host's UART."""

    def __init__(self, host: SimHost, bridge: int) -> None:
        self.host = host
        self.bridge = bridge

    def send(self, data: bytes) -> None:
        self.host.world.host_send(self.bridge, data)

    def set_receiver(self, receiver: Callable[[bytes], None]) -> None:
        self.host._receivers[self.bridge] = receiver


class SimUsbTransport:
    """`FrameTransport` to a simulated USB bridge: `write_batch` hands one bulk-OUT transfer to
    the simulated kernel driver (Fig. 9); IN transfers arrive through the batch receiver."""

    def __init__(self, host: SimHost, bridge: int) -> None:
        self.host = host
        self.bridge = bridge

    def write_batch(self, data: bytes) -> None:
        self.host.world.host_send(self.bridge, data)

    def set_batch_receiver(self, receiver: Callable[[bytes], None]) -> None:
        self.host._receivers[self.bridge] = receiver
