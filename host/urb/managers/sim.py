"""SimManager: the protocol cores driven by a `Clock` instead of threads (virtual time).

The simulation (sim/, issue 6) plugs its simulated buses in through the two transport
interfaces of `base.py`; until then, and for unit tests, this module provides a `VirtualClock`
and loopback transports that put a `BridgeModel` at the other end of a simulated RS232 line
(with byte times at the configured baud rate) or USB pipe (1-ms frames).

Everything runs on the clock's thread: callbacks are invoked from the event loop, never nested
inside `submit` (they are queued and run once the current step is over). As with the real-time
managers, a blocking call inside a callback raises `RuntimeError` (it would run the clock from
inside the callback, where no other callback can run).
"""

from __future__ import annotations

import heapq
import itertools
from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING

from ..errors import ErrorFlag
from .base import (
    BLOCKING_IN_CALLBACK,
    NS_PER_MS,
    NS_PER_S,
    BusManager,
    ByteTransport,
    Clock,
    DrivableClock,
    FrameTransport,
    ManagerStats,
    Transfer,
    cycle_state_of,
    finish,
)
from .loopback import BridgeModel
from .native import new_rs232_core, new_usb_core
from .rs232_core import PLACEHOLDER_NS, Rs232Core
from .usb_core import UsbCore

if TYPE_CHECKING:
    from ._native import CycleState


class VirtualClock:
    """A discrete-event clock: `call_at` queues, `run_until` / `run_for` advance time."""

    def __init__(self, start_ns: int = 0) -> None:
        self._now = start_ns
        self._events: list[tuple[int, int, Callable[[], None]]] = []
        self._order = itertools.count()

    def now_ns(self) -> int:
        return self._now

    def call_at(self, when_ns: int, fn: Callable[[], None]) -> None:
        heapq.heappush(self._events, (max(when_ns, self._now), next(self._order), fn))

    def step(self) -> bool:
        """Run the next event (advancing time to it); False when none is queued."""
        if not self._events:
            return False
        when, _, fn = heapq.heappop(self._events)
        self._now = when
        fn()
        return True

    def run_until(self, predicate: Callable[[], bool], limit_ns: int) -> bool:
        while not predicate():
            if not self._events or self._events[0][0] > limit_ns:
                self._now = max(self._now, limit_ns)
                return predicate()
            self.step()
        return True

    def run_for(self, duration_ns: int) -> None:
        """Run every event up to now + duration_ns and leave the clock there."""
        end = self._now + duration_ns
        self.run_until(lambda: False, end)


# --------------------------------------------------------------------------------------------
# Loopback transports: a BridgeModel at the far end
# --------------------------------------------------------------------------------------------

class LoopbackByteTransport:
    """A simulated RS232 line (8N1 at `baud`, full duplex) to a `BridgeModel`.

    Fault injection: `corrupt_response(index, xor)` flips bits in a byte of the response stream
    (counted from now), `drop_requests(n)` loses the next n request frames, `unplug()` stops the
    bridge answering (a cable pulled)."""

    def __init__(self, clock: Clock, bridge: BridgeModel, baud: int | None = 115200) -> None:
        self.clock = clock
        self.bridge = bridge
        self.byte_ns = 10 * NS_PER_S // baud if baud else 0
        self._receiver: Callable[[bytes], None] | None = None
        self._tx_free = 0  # host -> bridge line busy until
        self._rx_free = 0  # bridge -> host line busy until
        self._corrupt: dict[int, int] = {}
        self._resp_bytes = 0
        self._drop = 0
        self.connected = True

    def set_receiver(self, receiver: Callable[[bytes], None]) -> None:
        self._receiver = receiver

    def send(self, data: bytes) -> None:
        now = self.clock.now_ns()
        start = max(now, self._tx_free)
        self._tx_free = start + len(data) * self.byte_ns
        if self._drop:
            self._drop -= 1
            return
        self.clock.call_at(self._tx_free, lambda: self._at_bridge(data))

    def corrupt_response(self, index: int = 0, xor: int = 0x01) -> None:
        self._corrupt[self._resp_bytes + index] = xor

    def drop_requests(self, n: int = 1) -> None:
        self._drop += n

    def unplug(self) -> None:
        self.connected = False

    def plug(self) -> None:
        self.connected = True

    def _at_bridge(self, data: bytes) -> None:
        if not self.connected:
            return
        self.bridge.receive(data, self.clock.now_ns())
        self._bridge_step()

    def _bridge_step(self) -> None:
        now = self.clock.now_ns()
        out = bytearray(self.bridge.process(now))
        for i in range(len(out)):
            xor = self._corrupt.pop(self._resp_bytes + i, 0)
            out[i] ^= xor
        self._resp_bytes += len(out)
        if out and self.connected:
            start = max(now, self._rx_free)
            self._rx_free = start + len(out) * self.byte_ns
            payload = bytes(out)
            self.clock.call_at(self._rx_free, lambda: self._deliver(payload))
        nxt = self.bridge.next_event_ns()
        if nxt is not None:
            self.clock.call_at(max(nxt, now + 1), self._bridge_step)

    def _deliver(self, data: bytes) -> None:
        if self._receiver is not None and self.connected:
            self._receiver(data)


class LoopbackFrameTransport:
    """A simulated USB pipe to a `BridgeModel`: each bulk-OUT runs the batch at once; the
    bulk-IN issued by its completion returns the bridge's previous buffer `in_delay_ns` later
    (within the same 1-ms frame)."""

    def __init__(self, clock: Clock, bridge: BridgeModel, in_delay_ns: int = NS_PER_MS // 2) -> None:
        self.clock = clock
        self.bridge = bridge
        self.in_delay_ns = in_delay_ns
        self._receiver: Callable[[bytes], None] | None = None
        self.connected = True
        self.corrupt_next_in = False

    def set_batch_receiver(self, receiver: Callable[[bytes], None]) -> None:
        self._receiver = receiver

    def write_batch(self, data: bytes) -> None:
        if not self.connected:
            return
        now = self.clock.now_ns()
        self.bridge.usb_out(data, now)
        self.clock.call_at(now + self.in_delay_ns, self._read)

    def _read(self) -> None:
        data = self.bridge.usb_in()
        if data is None or self._receiver is None or not self.connected:
            return
        if self.corrupt_next_in:
            self.corrupt_next_in = False
            data = bytes([data[0] ^ 0x10]) + data[1:]
        self._receiver(data)


# --------------------------------------------------------------------------------------------
# SimManager
# --------------------------------------------------------------------------------------------

class SimManager(BusManager):
    """A bus manager driven by a `Clock` (virtual time), over a `ByteTransport` (RS232 core) or
    a `FrameTransport` (USB core, one batch per 1-ms frame)."""

    def __init__(self, clock: Clock, transport: ByteTransport | FrameTransport, *, name: str = "sim",
                 window: int = 4, timeout_ns: int | None = None, lost_after_ns: int = 500 * NS_PER_MS,
                 placeholder_ns: int = PLACEHOLDER_NS) -> None:
        """`placeholder_ns`: how long a timed-out request keeps its sequence number and window
        slot (`rs232_core.PLACEHOLDER_NS`); the other parameters as the real-time managers'."""
        self.name = name
        self.clock = clock
        self.transport = transport
        self.stats = ManagerStats()
        # The transport's kind is decided once: isinstance against a runtime-checkable Protocol
        # costs microseconds, too much for the per-step path.
        self._frames: FrameTransport | None = None
        self._bytes: ByteTransport | None = None
        if isinstance(transport, FrameTransport):
            self._frames = transport
        else:
            self._bytes = transport
        self._rs232_core: Rs232Core | None = None
        self._usb_core: UsbCore | None = None
        if self._frames is not None:
            self._usb_core = new_usb_core(timeout_ns=timeout_ns or 50 * NS_PER_MS, lost_after_ns=lost_after_ns,
                                     placeholder_ns=placeholder_ns)
        else:
            self._rs232_core = new_rs232_core(window=window, timeout_ns=timeout_ns or 100 * NS_PER_MS,
                                         lost_after_ns=lost_after_ns, placeholder_ns=placeholder_ns)
        self._pending_cb: deque[Transfer | Callable[[], None]] = deque()
        self._put_completed = self._pending_cb.append  # bound once: _after_step runs at every step
        self._dispatching = False
        self._ticking = False
        self._timer_at: set[int] = set()
        self._started = False

    @property
    def core(self) -> Rs232Core | UsbCore:
        core = self._usb_core if self._usb_core is not None else self._rs232_core
        assert core is not None
        return core

    # -- BusManager ---------------------------------------------------------------------------
    def start(self) -> None:
        self._reopen_core(self.core, self.clock.now_ns())  # started again after close()
        if self._started:
            return
        self._started = True
        if self._frames is not None:
            self._frames.set_batch_receiver(self._on_batch)
        else:
            assert self._bytes is not None
            self._bytes.set_receiver(self._on_bytes)

    def close(self, *, drain: bool = True) -> None:
        """`BusManager.close`: the drain runs the clock (virtual time) until nothing is in flight
        or the newest request's lifetime is over; `drain=False` skips it, and so does a close
        made inside a callback or with a clock that cannot be driven (as a blocking call would
        raise there)."""
        if drain:
            self._drain()
        self._close_core(self.core, self.clock.now_ns())
        self._after_step()

    def _drain(self) -> None:
        """Run the clock until the requests in flight are answered or their lifetime is over
        (`MatchingCore.start_drain`), then apply the timeouts due by then."""
        deadline = self.core.start_drain(self.clock.now_ns())
        self._after_step()
        if deadline is None or self._dispatching or not isinstance(self.clock, DrivableClock):
            return
        self.clock.run_until(self.core.drained, deadline)
        self.core.poll(self.clock.now_ns())
        self._after_step()

    def now_ns(self) -> int:
        return self.clock.now_ns()

    @property
    def lost_reason(self) -> str | None:
        return self.core.lost_reason

    def set_window(self, window: int) -> None:
        self.core.set_window(max(1, min(window, 15)))

    def submit(self, t: Transfer) -> None:
        now = self.clock.now_ns()
        t.submitted_ns = now
        self.stats.submitted += 1
        self.core.submit(t, now)
        self._after_step()

    def new_cycle_state(self, specs: tuple[tuple[int, int, bool, int], ...]) -> CycleState | None:
        return cycle_state_of(self.core, specs)

    def submit_cycle(self, state: CycleState, refusals: tuple[int, ...] | None) -> None:
        self.stats.submitted += state.size
        self.core._cycle_submit(state, self.clock.now_ns(), refusals)  # type: ignore[union-attr]
        self._after_step()

    def reject(self, t: Transfer, flags: ErrorFlag) -> None:
        """Complete `t` on the host without sending it (queued like any completion)."""
        now = self.clock.now_ns()
        t.submitted_ns = now
        self.stats.submitted += 1
        self.stats.completed += 1
        self.stats.failed += 1
        self._pending_cb.append(finish(t, now, flags))
        self._after_step()

    def wait_until(self, predicate: Callable[[], bool], timeout_s: float) -> bool:
        if self._dispatching:
            raise RuntimeError(BLOCKING_IN_CALLBACK)
        if predicate():
            return True
        if isinstance(self.clock, DrivableClock):
            return self.clock.run_until(predicate, self.clock.now_ns() + int(timeout_s * NS_PER_S))
        raise RuntimeError("this clock cannot be driven from a blocking call; use callbacks "
                           "(URBInterface.start_discovery, NodeRequest.set_callback) in the simulation")

    def reconnect(self) -> None:
        self.core.reset(self.clock.now_ns())
        self._after_step()

    # -- driving the core ---------------------------------------------------------------------
    def _on_bytes(self, data: bytes) -> None:
        assert self._rs232_core is not None
        self._rs232_core.receive(data, self.clock.now_ns())
        self._after_step()

    def _on_batch(self, data: bytes) -> None:
        assert self._usb_core is not None
        self._usb_core.receive_batch(data, self.clock.now_ns())
        self._after_step()

    def _on_timer(self, when: int) -> None:
        self._timer_at.discard(when)
        now = self.clock.now_ns()
        deadline = self.core.next_deadline()
        if deadline is None or deadline > now:
            # Superseded (a response came, the resync-gap deadline moved): nothing is due, so `poll`
            # and `_after_step` would change nothing but arm the deadline now due.
            self._arm(deadline)
            return
        self.core.poll(now)
        self._after_step()

    def _arm(self, deadline: int | None) -> None:
        """Wake the host at `deadline` unless a timer is armed at or before it. One timer at the
        earliest deadline, as one timer thread would sleep: when it wakes, it arms the deadline then
        due. (A timer per new deadline woke the simulated host once per RS232 chunk received, since
        the resync-gap deadline moves with every byte heard: fig18_19 ran ~20 % slower.)"""
        if deadline is not None and (not self._timer_at or deadline < min(self._timer_at)):
            self._timer_at.add(deadline)
            self.clock.call_at(deadline, lambda: self._on_timer(deadline))

    def _frame_tick(self) -> None:
        assert self._usb_core is not None and self._frames is not None
        now = self.clock.now_ns()
        self._usb_core.poll(now)
        out = self._usb_core.frame_out(now)
        if out is not None:
            self._frames.write_batch(out)
        self._ticking = False
        self._after_step()

    def _after_step(self) -> None:
        """Send what may be sent, arm timers, run callbacks (never nested)."""
        now = self.clock.now_ns()
        rs232 = self._rs232_core
        if rs232 is not None:
            assert self._bytes is not None
            for frame in rs232.frames_to_send(now):
                self._bytes.send(frame)
            core: Rs232Core | UsbCore = rs232
        else:
            usb = self._usb_core
            assert usb is not None
            if not self._ticking and usb.busy():
                self._ticking = True
                nxt = (now // NS_PER_MS + 1) * NS_PER_MS  # the next 1-ms frame boundary
                self.clock.call_at(nxt, self._frame_tick)
            core = usb
        self._arm(core.next_deadline())
        self._queue_completed(core, self._put_completed)
        if self._dispatching:
            return
        self._dispatching = True
        try:
            while self._pending_cb:
                item = self._pending_cb.popleft()
                if isinstance(item, Transfer):
                    if item.on_done is not None:
                        item.on_done(item)
                else:
                    item()
        finally:
            self._dispatching = False
