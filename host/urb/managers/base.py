"""What every bus manager shares: the transfer record, the clock and transport interfaces, the
manager interface `URBInterface` talks to, and the threaded runtime used by the real-time managers.

Layering (see host/urb/README.md):

* protocol cores (`rs232_core.Rs232Core`, `usb_core.UsbCore`): pure state machines, fed bytes and
  timestamps, asked for bytes to send; no threads, no I/O, no clock of their own;
* runtime adapters: `RS232Manager` and `USBManager` drive a core in real time with threads;
  `SimManager` drives it from a `Clock` (virtual time in the simulation).
"""

from __future__ import annotations

import functools
import queue
import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol, TypeVar, cast, runtime_checkable

from urb_msgs import Message
from urb_msgs.urb_core import Status

from ..errors import ErrorFlag, PortError
from .handover import PortHandover

if TYPE_CHECKING:
    from ._native import CycleState

NS_PER_MS = 1_000_000
NS_PER_S = 1_000_000_000

BLOCKING_IN_CALLBACK = ("a blocking URB call inside a callback would deadlock the dispatcher; "
                        "submit a request with a callback instead")
"""The `RuntimeError` text of a blocking call (`NodeAccessor.read`, `NodeRequest.wait`, ...) made
inside a callback, by every manager."""

CLOSED_REASON = "closed by the application"
"""`lost_reason` of a manager after `close()` (requests submitted then complete BRIDGE_LOST)."""

DISPATCH_BATCH = 16
"""Callbacks the dispatcher runs back to back before it wakes the blocking calls waiting (a USB
frame answers up to 15 requests)."""

BATCH_WAIT_S = 0.01
"""The longest the dispatcher of a manager whose I/O runs in C waits between two looks at the core
(completions wake it at once; this bounds how late a draining close learns it is drained)."""

M = TypeVar("M", bound=Message)


def encode_message(msg: Message) -> bytes:
    """`msg.encode()`, typed (the generated classes define it; the base class does not)."""
    out = getattr(msg, "encode")()
    assert isinstance(out, bytes)
    return out


def decode_message(cls: type[M], data: bytes) -> M:
    """`cls.decode(data)`, typed; raises the codec's `DecodeError` subclasses."""
    out = getattr(cls, "decode")(data)
    assert isinstance(out, cls)
    return out


# --------------------------------------------------------------------------------------------
# The transfer: one uplink request and, once complete, its outcome
# --------------------------------------------------------------------------------------------

@dataclass(eq=False)
class Transfer:
    """One uplink request (read or write of one mailbox at one downlink address) and its outcome.

    Created by the API (`NodeRequest`) or by discovery; owned by a core from `submit` until it
    completes, then handed back through the manager's completion path. Times are nanoseconds of
    the manager's clock (`time.monotonic_ns()` for the real-time managers, virtual time in the
    simulation).
    """

    address: int
    mailbox: int
    read: bool
    length: int
    data: bytes = b""
    """Write payload (empty for reads)."""
    on_done: Callable[[Transfer], None] | None = None
    """Called once, on the manager's dispatcher, when the transfer completes."""
    owner: Any = None
    """Opaque back-reference for the API (the `NodeRequest`)."""

    seq: int = -1
    """4-bit sequence number, set when the request is put on the wire."""
    submitted_ns: int = 0
    sent_ns: int | None = None
    completed_ns: int | None = None
    flags: ErrorFlag = ErrorFlag.NONE
    status: Status | None = None
    """The bridge's status, when a response arrived."""
    response: bytes | None = None
    """Mailbox contents of a successful read."""
    lost_reason: str | None = None
    """For BRIDGE_LOST: why the bridge was considered lost when this transfer failed."""
    done: bool = False
    answer_within_ns: int = 0
    """How long the bridge may take to answer this request when that is longer than the core's
    timeout and lifetime (a bridge SCAN command: `rs232_core.SCAN_ANSWER_NS`); 0: the usual.
    Requests sent while it is in flight wait behind it, and their clocks start after it."""
    due_ns: int | None = field(default=None, repr=False)
    """Internal: when it completes UPLINK_TIMEOUT without a response (set when sent)."""
    expires_ns: int | None = field(default=None, repr=False)
    """Internal: when the bridge no longer holds it, its placeholder's end (set when sent)."""
    garbage: bool = field(default=False, repr=False)
    """Internal: corrupt bytes were seen while this transfer was the oldest one pending."""

    @property
    def ok(self) -> bool:
        """Completed without error."""
        return self.done and self.flags == ErrorFlag.NONE

    def response_size(self, status: Status) -> int:
        """Bytes of the response frame answering this request with `status` (wire rule: data
        only for an OK read; a 1-byte check up to 14 covered bytes, else 2)."""
        covered = 1 + (self.length if self.read and status == Status.OK else 0)
        return covered + (1 if covered <= 14 else 2)

    def request_size(self) -> int:
        """Bytes of the request frame."""
        covered = 3 + (0 if self.read else self.length)
        return covered + (1 if covered <= 14 else 2)


def cycle_state_of(core: object, specs: tuple[tuple[int, int, bool, int], ...]) -> CycleState | None:
    """A `CycleState` of `core`'s extension module when `core` is the C core and not traced (its
    trace records Python transfers), else None."""
    make = getattr(core, "_new_cycle_state", None)
    if make is None or getattr(core, "trace", None) is not None:
        return None
    state: CycleState = make(specs)
    return state


def finish(t: Transfer, now: int, flags: ErrorFlag, status: Status | None = None, data: bytes | None = None) -> Transfer:
    """Mark `t` complete (exactly once) and return it."""
    assert not t.done, "a transfer completes exactly once (Bridge.tla AtMostOneResponse)"
    t.done = True
    t.completed_ns = now
    t.flags = flags
    t.status = status
    t.response = data
    return t


# --------------------------------------------------------------------------------------------
# Interfaces the runtime adapters need (documented in host/urb/README.md)
# --------------------------------------------------------------------------------------------

@runtime_checkable
class Clock(Protocol):
    """A source of time and of timed callbacks (virtual time in the simulation).

    `call_at` may run `fn` late but never early; the managers treat every wake-up as a hint and
    re-check their deadlines, so spurious or duplicate wake-ups are harmless and nothing needs
    cancelling.
    """

    def now_ns(self) -> int:
        """Current time in nanoseconds."""
        ...

    def call_at(self, when_ns: int, fn: Callable[[], None]) -> None:
        """Run `fn()` once, at `when_ns` or as soon as possible after it."""
        ...


@runtime_checkable
class DrivableClock(Clock, Protocol):
    """A clock the caller may run forward (for blocking calls in virtual time)."""

    def run_until(self, predicate: Callable[[], bool], limit_ns: int) -> bool:
        """Process events until `predicate()` holds (True) or time reaches `limit_ns` (False)."""
        ...


@runtime_checkable
class ByteTransport(Protocol):
    """A full-duplex byte stream: an RS232 uplink.

    `send` puts one request frame on the line, its bytes back to back (one `write()`); received
    bytes are pushed to the receiver in arrival order, in chunks of any size.
    """

    def send(self, data: bytes) -> None:
        ...

    def set_receiver(self, receiver: Callable[[bytes], None]) -> None:
        ...


@runtime_checkable
class FrameTransport(Protocol):
    """A per-frame transfer pipe: a USB uplink.

    Once per 1-ms frame the manager calls `write_batch` with one bulk-OUT transfer (a
    `UsbBatchHeader` and its requests); the transport pushes every bulk-IN transfer it completes
    (the bridge's previous response buffer: write n and read n-1 share a frame) to the receiver.
    """

    def write_batch(self, data: bytes) -> None:
        ...

    def set_batch_receiver(self, receiver: Callable[[bytes], None]) -> None:
        ...


class Core(Protocol):
    """What the runtimes need from a protocol core (implemented by Rs232Core and UsbCore)."""

    lost_reason: str | None

    def submit(self, t: Transfer, now: int) -> None: ...
    def poll(self, now: int) -> None: ...
    def next_deadline(self) -> int | None: ...
    def take_completed(self) -> list[Transfer]: ...
    def link_lost(self, now: int, reason: str) -> None: ...
    def reset(self, now: int) -> None: ...
    def set_window(self, window: int) -> None: ...
    def busy(self) -> bool: ...
    def start_drain(self, now: int) -> int | None: ...
    def drained(self) -> bool: ...
    def hand_over(self, until_ns: int) -> None: ...
    def busy_until(self) -> int | None: ...
    @property
    def late_responses(self) -> int: ...
    @property
    def stray_bytes(self) -> int: ...


# --------------------------------------------------------------------------------------------
# The manager interface URBInterface uses
# --------------------------------------------------------------------------------------------

@dataclass
class ManagerStats:
    """Counters a manager keeps (all since start or the last reconnect; `late_responses` since the
    manager was made)."""

    submitted: int = 0
    completed: int = 0
    failed: int = 0
    stray_bytes: int = 0
    """Received bytes that answered no request in flight (corrupt, or a previous process's late
    responses during a hand-over), discarded (since the manager was made)."""
    late_responses: int = 0
    """Responses that came after their request had completed UPLINK_TIMEOUT: the bridge answered
    late (a slow downlink); discarded, never given to another request (since the manager was
    made)."""


LostListener = Callable[["BusManager", str], None]
"""`fn(manager, reason)`: told once per loss that the manager found its bridge lost."""


class BusManager(ABC):
    """One bridge, reached through one uplink. Register it with `URBInterface.add_bus_manager`."""

    name: str
    """How the bridge is named in tables and messages (the port path for RS232)."""
    stats: ManagerStats
    _lost_listeners: list[LostListener]
    _lost_noted: bool = False
    """The current loss has been handed to the lost listeners (or must not be: `close()`)."""

    def add_lost_listener(self, fn: LostListener) -> None:
        """Call `fn(manager, reason)` when the manager detects that its bridge is lost (an I/O
        error, silence, timeouts in a row; see host/urb/README.md), once per loss, on the
        dispatcher (the clock's thread for SimManager), before the callbacks of the requests
        that loss fails. Not for `close()`; a failed `reconnect()` of a bridge already lost is
        the same loss (the caller gets the exception). Registering `fn` twice has no effect."""
        listeners = self._listeners()
        if fn not in listeners:
            listeners.append(fn)

    def _listeners(self) -> list[LostListener]:
        try:
            return self._lost_listeners
        except AttributeError:
            self._lost_listeners = []
            return self._lost_listeners

    def _loss_notice(self, reason: str | None) -> Callable[[], None] | None:
        """Called with the core's `lost_reason` after every step: when the bridge has just been
        found lost, the notice that tells the lost listeners (to run on the dispatcher)."""
        if reason is None:
            self._lost_noted = False
            return None
        if self._lost_noted:
            return None
        self._lost_noted = True
        return functools.partial(self._notify_lost, reason)

    # lobster-trace: urb.HOST_005
    def _queue_completed(self, core: Core, put: Callable[[Transfer | Callable[[], None]], None]) -> bool:
        """Count the transfers `core` completed and hand them to `put` (the dispatcher's queue);
        when the core has just found the bridge lost, the lost listeners' notice goes first,
        before the callbacks of the requests that loss failed. The stats take the core's count
        of late responses and stray bytes. Returns whether anything was handed to `put`."""
        done = core.take_completed()
        self.stats.late_responses = core.late_responses
        self.stats.stray_bytes = core.stray_bytes
        notice = self._loss_notice(core.lost_reason)
        put_any = False
        for t in done:
            if t.__class__ is not Transfer:  # the C core's CycleState: every item of a cycle completed
                state = cast("CycleState", t)  # take_completed's list holds them among the transfers
                if notice is not None and state.lost:
                    put(notice)
                    notice = None
                    put_any = True
                self.stats.completed += state.size
                self.stats.failed += state.failed
                if state.on_done is not None:  # else a polled cycle: its owner looks (Cycle.poll)
                    put(state.on_done)
                    put_any = True
                continue
            put_any = True
            if notice is not None and t.flags & ErrorFlag.BRIDGE_LOST:
                put(notice)
                notice = None
            self.stats.completed += 1
            if t.flags:
                self.stats.failed += 1
            put(t)
        if notice is not None:
            put(notice)
            return True
        return put_any

    def _close_core(self, core: Core, now: int) -> None:
        """The start of `close()`: `core` completes every outstanding request BRIDGE_LOST (reason
        CLOSED_REASON), and the lost listeners are not told: closing is not a loss to report."""
        self._lost_noted = True
        core.link_lost(now, CLOSED_REASON)

    def _reopen_core(self, core: Core, now: int) -> None:
        """In `start()`: a core closed before (or lost) is reset, and its next loss is reported."""
        if core.lost_reason is not None:
            core.reset(now)
            self._lost_noted = False

    def _notify_lost(self, reason: str) -> None:
        for fn in list(self._listeners()):
            try:
                fn(self, reason)
            except Exception as exc:  # a listener must not kill the dispatcher
                _report_callback_error(exc)

    @abstractmethod
    def start(self) -> None:
        """Open the uplink and start the runtime; raises `PortError` with a hint on failure."""

    @abstractmethod
    def close(self, *, drain: bool = True) -> None:
        """Drain, then stop the runtime and close the uplink.

        Draining: while requests are in flight (sent and unanswered, placeholders of timed-out
        ones included) the uplink stays open and responses are matched as usual, until none is
        left or the newest one's lifetime is over (its sending + `placeholder_ns`, 300 ms by
        default, `rs232_core.PLACEHOLDER_NS`, or + its timeout if longer); live requests complete
        as usual (their response, or UPLINK_TIMEOUT). Without it, a late response could reach the
        next process to open the bridge, whose sequence numbers start again at 1, as the answer
        to its own request. A close with nothing in flight, or of a lost manager, does not wait.
        Requests queued but not sent, those still outstanding after the drain, and every request
        submitted from the start of `close` on (until `start` or `reconnect`) complete
        BRIDGE_LOST.
        `drain=False` skips the wait (e.g. when the process will not reopen the bridge soon)."""

    @abstractmethod
    def submit(self, t: Transfer) -> None:
        """Queue one transfer (thread-safe). Its `on_done` runs exactly once, on the dispatcher;
        after `close()` (no dispatcher) it completes BRIDGE_LOST at once and `on_done` runs
        inside `submit`."""

    @abstractmethod
    def reject(self, t: Transfer, flags: ErrorFlag) -> None:
        """Complete `t` with `flags` without sending it (host-side refusal); `on_done` still runs
        on the dispatcher, like any completion."""

    @abstractmethod
    def now_ns(self) -> int:
        """The manager's clock."""

    @abstractmethod
    def wait_until(self, predicate: Callable[[], bool], timeout_s: float) -> bool:
        """Block until `predicate()` holds or `timeout_s` passes (virtual time for SimManager)."""

    @abstractmethod
    def reconnect(self) -> None:
        """Reopen the uplink after the bridge was lost (or restarted) and reset the protocol.
        Either it succeeds, or it raises (`PortError`) and leaves the manager lost, its
        `lost_reason` saying why the reconnect failed: requests complete BRIDGE_LOST at once and
        `reconnect` may be called again later."""

    @property
    @abstractmethod
    def lost_reason(self) -> str | None:
        """Why the bridge is considered lost, or None while it is usable."""

    def set_window(self, window: int) -> None:
        """Bound the requests outstanding on the bridge (learnt from BridgeInfo.fifo_depth)."""

    cyclic: bool = False
    """The application services this manager (`service()`, made with `cyclic=True`): no thread of
    the manager runs; callbacks run inside `service()` on the caller's thread."""

    def service(self) -> int:
        """One pass of a cyclic manager's I/O without waiting (see `ThreadedManager.service`);
        returns the callbacks run. A manager that runs its own threads has nothing to do: 0."""
        return 0

    def new_cycle_state(self, specs: tuple[tuple[int, int, bool, int], ...]) -> CycleState | None:
        """The C core's record of a cycle's requests on this bridge (`urb.cycle.Cycle`; `specs`:
        (address, mailbox, read, length) per item), or None when this manager's core takes single
        transfers only (the Python cores; a traced C core): the cycle then submits its items one by
        one, with the same outcomes."""
        return None

    def collect_completions(self) -> None:
        """Take what the core completed now, on the calling thread (the completions of polled cycles,
        which wake no dispatcher: `urb.cycle.Cycle.poll`); thread-safe."""

    def submit_cycle(self, state: CycleState, refusals: tuple[int, ...] | None) -> None:
        """Submit every item of `state` (from `new_cycle_state`) at once, thread-safe; those with a
        non-zero flag in `refusals` complete with it at once, unsent. `state.on_done` runs once, on
        the dispatcher, when the last item completed (inside this call after `close()`)."""
        raise NotImplementedError(f"{type(self).__name__} gives no cycle states; submit the items one by one")

    def __enter__(self) -> BusManager:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


# --------------------------------------------------------------------------------------------
# Real-time runtime: core under a lock, a dispatcher thread for callbacks
# --------------------------------------------------------------------------------------------

class ThreadedManager(BusManager):
    """Shared real-time machinery: the core behind a lock, a dispatcher thread that runs
    callbacks in completion order, and a condition for the blocking conveniences.

    Without a dispatcher (after `close()`, or a failed `reconnect()` of a closed manager) the
    thread that submits runs the callbacks itself, inside `submit`/`reject`, so every `on_done`
    still runs exactly once."""

    def __init__(self, core: Core, name: str, *, cyclic: bool = False) -> None:
        self.name = name
        self._core = core
        self.cyclic = cyclic
        self._serviced = False
        """A cyclic manager between `start()` and `close()`: the application's `service()` does the
        I/O and runs the callbacks (no dispatcher, no I/O thread)."""
        self._service_lock = threading.Lock()
        """One `service()` at a time (the application's tick and a blocking call on another thread)."""
        self._calling_back: int | None = None
        """The thread (`threading.get_ident()`) running callbacks inside `service()` (a blocking
        call from it is refused)."""
        self._lock = threading.RLock()
        self._changed = threading.Condition(self._lock)
        self._dispatch_q: queue.SimpleQueue[Transfer | Callable[[], None] | None] = queue.SimpleQueue()
        self._dispatcher: threading.Thread | None = None
        self._running = False
        self._draining = False
        self.stats = ManagerStats()
        self._handover: PortHandover | None = None
        """The port's record for the next process (`handover.py`); set by a manager that opens
        a port by its path."""
        self._pumped = False
        """The uplink's I/O runs on the C core's pump (decided by the manager's `start`): the
        dispatcher then waits on the core (`_dispatch_batches`), not on its queue."""
        self._has_completed: Callable[[], bool] | None = getattr(core, "_has_completed", None)
        """The C core's cheap test for completions waiting (a submission that completed nothing
        then skips `_collect`); None for the Python cores."""

    # -- subclass hooks --------------------------------------------------------------------
    WAKES_IO = False
    """The manager has I/O to wake after a submission (`_wake_io`); False skips the call."""

    def _service_io(self) -> None:
        """A cyclic manager's I/O, one pass without waiting: what arrived, the deadlines, what is
        due to be sent (lock not held; `_collect` it)."""
        raise NotImplementedError

    def _wake_io(self) -> None:
        """Tell the I/O threads there may be something to send."""

    def _kick_dispatcher(self) -> None:
        """Wake the dispatcher for an item queued by another thread, when it waits on something
        other than its queue (the pump's core, `_dispatch_batches`)."""
        if self._pumped:
            self._core._pump_kick()  # type: ignore[attr-defined]

    # -- BusManager --------------------------------------------------------------------------
    now_ns = staticmethod(time.monotonic_ns)
    """The real-time managers' clock (the builtin itself: no Python frame per request)."""

    # lobster-trace: urb.HOST_005
    def service(self) -> int:
        """The cyclic runtime's one step (a manager made with `cyclic=True`; host/urb/README.md,
        "The cyclic runtime"): read what the uplink delivered since the last call, apply the
        deadlines, send what is due (a USB batch when a 1-ms boundary has passed since the last
        one), then run the callbacks of everything that completed, in completion order, on the
        calling thread. Never waits for the uplink. Returns the number of callbacks run (lost
        listeners' notices included). Call it once per control period, e.g. at every 1-ms tick;
        between calls nothing of the manager runs. Blocking calls (`read`, `NodeRequest.wait`,
        discovery, a draining `close`) service the manager themselves while they wait. Inside a
        callback it raises RuntimeError, as blocking calls do; on a manager that runs its own
        threads (`cyclic=False`) it is RuntimeError too. After `close()` it runs the callbacks left
        (none: close runs them) and returns."""
        if not self.cyclic:
            raise RuntimeError(f"{self.name}: service() drives a manager made with cyclic=True; this one runs "
                               "its own threads (nothing to call)")
        if self._calling_back == threading.get_ident():
            raise RuntimeError("service() inside a callback would run callbacks inside callbacks; "
                               "return from the callback and let the next service() run them")
        with self._service_lock:
            return self._service_locked()

    def _service_locked(self) -> int:
        if self._serviced:
            self._service_io()
        batch = self._take_batch()
        return self._run_callbacks(batch) if batch else 0

    def _take_batch(self) -> list[Transfer | Callable[[], None] | None]:
        """What is to run now, in order: the items other threads queued (older: refusals, notices,
        a stop), then the core's completions; wakes a draining close() once the core is drained."""
        batch: list[Transfer | Callable[[], None] | None] = []
        q = self._dispatch_q
        with self._lock:
            while not q.empty():
                batch.append(q.get_nowait())
            # always, not only when something completed: a loss with nothing in flight still
            # owes the lost listeners their notice, and the stats take the core's counters
            self._queue_completed(self._core, batch.append)
            if self._draining and self._core.drained():
                self._changed.notify_all()
        return batch

    def _run_callbacks(self, batch: list[Transfer | Callable[[], None] | None]) -> int:
        """Run `batch`'s callbacks and notices on the calling thread (marked as calling back, so
        that a blocking call from a callback is refused), then wake the blocking waiters once."""
        ran = 0
        previous, self._calling_back = self._calling_back, threading.get_ident()
        try:
            for item in batch:
                if item is not None:
                    _run_item(item)
                    ran += 1
        finally:
            self._calling_back = previous
        if ran:
            with self._changed:
                self._changed.notify_all()
        return ran

    @property
    def lost_reason(self) -> str | None:
        return self._core.lost_reason

    def set_window(self, window: int) -> None:
        with self._lock:
            self._core.set_window(window)
        self._wake_io()

    def submit(self, t: Transfer) -> None:
        now = self.now_ns()
        with self._lock:
            t.submitted_ns = now
            self.stats.submitted += 1
            self._core.submit(t, now)
            serviced = self._serviced  # a cyclic manager's service() collects what completed
            if not serviced and (self._has_completed is None or self._has_completed()):
                self._collect()
        if self.WAKES_IO:
            self._wake_io()
        if not serviced:
            self._complete_without_dispatcher()

    def new_cycle_state(self, specs: tuple[tuple[int, int, bool, int], ...]) -> CycleState | None:
        return cycle_state_of(self._core, specs)

    def collect_completions(self) -> None:
        with self._lock:
            if self._has_completed is None or self._has_completed():
                self._collect()
        self._complete_without_dispatcher()

    def submit_cycle(self, state: CycleState, refusals: tuple[int, ...] | None) -> None:
        now = self.now_ns()
        with self._lock:
            self.stats.submitted += state.size
            self._core._cycle_submit(state, now, refusals)  # type: ignore[attr-defined]
            if self._has_completed is None or self._has_completed():
                self._collect()
        self._wake_io()
        self._complete_without_dispatcher()

    def reject(self, t: Transfer, flags: ErrorFlag) -> None:
        now = self.now_ns()
        with self._lock:
            t.submitted_ns = now
            self.stats.submitted += 1
            self.stats.completed += 1
            self.stats.failed += 1
            self._dispatch_q.put(finish(t, now, flags))
        self._kick_dispatcher()
        self._complete_without_dispatcher()

    def wait_until(self, predicate: Callable[[], bool], timeout_s: float) -> bool:
        if threading.current_thread() is self._dispatcher or self._calling_back == threading.get_ident():
            raise RuntimeError(BLOCKING_IN_CALLBACK)
        if self._serviced:
            return self._service_until(predicate, timeout_s)
        deadline = time.monotonic() + timeout_s
        with self._changed:
            while not predicate():
                left = deadline - time.monotonic()
                if left <= 0:
                    return False
                self._changed.wait(min(left, 0.05))
        return True

    def _service_until(self, predicate: Callable[[], bool], timeout_s: float) -> bool:
        """`wait_until` of a cyclic manager: service it at every 1-ms boundary until `predicate()`
        holds (when another thread is in `service()`, wait for the callbacks it runs instead)."""
        deadline = time.monotonic_ns() + int(timeout_s * NS_PER_S)
        while not predicate():
            if self._serviced and self._service_lock.acquire(blocking=False):
                try:
                    self._service_locked()
                finally:
                    self._service_lock.release()
                if predicate():
                    break
            now = time.monotonic_ns()
            if now >= deadline:
                return False
            tick = min(deadline, (now // NS_PER_MS + 1) * NS_PER_MS)
            with self._changed:
                self._changed.wait((tick - now) / NS_PER_S)
        return True

    def _start_dispatcher(self) -> None:
        if self.cyclic:  # the application's service() runs the callbacks
            return
        self._running = True
        self._dispatcher = threading.Thread(target=self._dispatch_loop, name=f"urb-dispatch {self.name}", daemon=True)
        self._dispatcher.start()

    def _stop_dispatcher(self) -> None:
        self._running = False
        if self._dispatcher is not None:
            self._dispatch_q.put(None)
            self._kick_dispatcher()
            if threading.current_thread() is not self._dispatcher:
                self._dispatcher.join(timeout=2.0)
            self._dispatcher = None

    def _start_threads(self, start_io: Callable[[], None]) -> None:
        """The end of `start()`, once the uplink is open: the core reset if it was closed, then
        the dispatcher and the I/O threads."""
        with self._lock:
            now = self.now_ns()
            self._reopen_core(self._core, now)
            if self._handover is not None:
                until = self._handover.predecessor_until(now)
                if until is not None:
                    self._core.hand_over(until)
        self._start_dispatcher()
        start_io()

    def _note_sending(self, now: int) -> None:
        """Before a write to the uplink (a process killed right after it must leave a record
        that covers it): the port's record covers the lifetime of the requests in flight."""
        if self._handover is not None:
            with self._lock:
                until = self._core.busy_until()
            if until is not None:
                self._handover.cover(until, now)

    def _drain(self) -> None:
        """The start of a draining `close()`: wait, the I/O threads still running, until the
        requests in flight are answered or their lifetime is over (`MatchingCore.start_drain`),
        then apply the timeouts due by then, so that they complete with their usual error."""
        if self._serviced:
            self._drain_serviced()
            return
        with self._changed:
            deadline = self._core.start_drain(self.now_ns())
            self._collect()
            if deadline is None:
                return
            self._draining = True  # `_collect` notifies once drained
            try:
                while not self._core.drained() and deadline > self.now_ns():
                    self._changed.wait((deadline - self.now_ns()) / NS_PER_S)
                self._core.poll(self.now_ns())
                self._collect()
            finally:
                self._draining = False

    def _drain_serviced(self) -> None:
        """`_drain` of a cyclic manager: the closing thread services it until drained."""
        with self._lock:
            deadline = self._core.start_drain(self.now_ns())
            self._collect()
        if deadline is not None:
            def drained() -> bool:
                with self._lock:
                    return self._core.drained()
            self._service_until(drained, max(0, deadline - self.now_ns()) / NS_PER_S)
            with self._lock:
                self._core.poll(self.now_ns())
                self._collect()

    def _finish_close(self) -> None:
        """The end of `close()`, once the I/O threads are stopped: outstanding requests complete
        BRIDGE_LOST, the dispatcher stops, and the callbacks left run on the calling thread."""
        with self._lock:
            now = self.now_ns()
            self._close_core(self._core, now)
            self._collect()
            if self._handover is not None:
                self._handover.settle(self._core.busy_until(), now)
        self._stop_dispatcher()
        self._drain_completions_inline()

    def _stay_lost(self, text: str, uplink: str) -> PortError:
        """A reconnect whose uplink would not reopen: the manager stays lost, its `lost_reason`
        saying why, and requests complete BRIDGE_LOST at once. Returns the error to raise."""
        reason = f"reconnect failed: {text}"
        with self._lock:
            self._core.link_lost(self.now_ns(), reason)
            self._core.lost_reason = reason  # already lost: now lost because the uplink is gone
            self._collect()
        self._complete_without_dispatcher()
        return PortError(f"{text} The bridge stays lost (requests complete BRIDGE_LOST); call reconnect() again "
                         f"once the {uplink} is back.", detail=text)

    def _restart(self, start_io: Callable[[], None]) -> None:
        """A reconnect whose uplink reopened: reset the protocol and start the threads again."""
        with self._lock:
            self._core.reset(self.now_ns())
            self._collect()
        if self._dispatcher is None:
            self._start_dispatcher()
        start_io()

    def _collect(self) -> None:
        """Move completed transfers from the core to the dispatcher (lock held), and, when the
        core has just found the bridge lost, the lost listeners' notice: before the callbacks
        of the requests that loss failed."""
        if self._queue_completed(self._core, self._dispatch_q.put) and threading.current_thread() is not self._dispatcher:
            self._kick_dispatcher()
        if self._draining and self._core.drained():
            self._changed.notify_all()  # what a draining close() waits for

    def _dispatch_loop(self) -> None:
        if self._pumped:
            self._dispatch_batches(self._core._pump_wait)  # type: ignore[attr-defined]
            return
        q = self._dispatch_q
        while True:
            item = q.get()
            # Run what is queued (at most DISPATCH_BATCH), then wake the blocking waiters once:
            # a notify per callback cost more than the rest of the dispatch.
            ran = 0
            while item is not None:
                _run_item(item)
                ran += 1
                if ran == DISPATCH_BATCH:
                    break
                try:
                    item = q.get_nowait()
                except queue.Empty:
                    break
            with self._changed:
                self._changed.notify_all()
            if item is None:
                return

    def _dispatch_batches(self, wait: Callable[[float], bool]) -> None:
        """The dispatcher of a manager whose uplink I/O runs on a C thread (the native core's pump):
        `wait(timeout_s)` returns, with the GIL released meanwhile, once the core completed
        transfers or another thread queued something (`_kick_dispatcher`); then the whole batch is
        taken from the core at once and its callbacks run, and the blocking waiters are woken once.
        One wake-up of Python per batch, where the threaded runtime woke a frame thread, a reader
        and the dispatcher."""
        q = self._dispatch_q
        while True:
            wait(BATCH_WAIT_S)
            batch = self._take_batch()
            ran = 0
            for item in batch:
                if item is None:
                    if ran:
                        with self._changed:
                            self._changed.notify_all()
                    for later in batch[batch.index(None) + 1:]:  # queued after the stop: close() runs them
                        q.put(later)
                    return
                _run_item(item)
                ran += 1
            if ran:
                with self._changed:
                    self._changed.notify_all()

    def _drain_completions_inline(self) -> None:
        """Run the callbacks of completions queued while no dispatcher runs (during and after
        `close`), on the calling thread."""
        ran = False
        while True:
            try:
                item = self._dispatch_q.get_nowait()
            except queue.Empty:
                break
            if item is not None:
                _run_item(item)
                ran = True
        if ran:
            with self._changed:
                self._changed.notify_all()

    def _complete_without_dispatcher(self) -> None:
        """After a submission: without a dispatcher (closed), run its callback now. A completion
        queued before `close()` cleared `_dispatcher` is run by close()'s own drain. A cyclic
        manager's callbacks run in its next `service()` while it is open."""
        if self._dispatcher is None and not self._serviced:
            self._drain_completions_inline()


def _run_item(item: Transfer | Callable[[], None]) -> None:
    """Run one dispatcher item: a transfer's `on_done`, or a notice; exceptions are reported."""
    try:
        if isinstance(item, Transfer):
            on_done = item.on_done
            if on_done is not None:
                on_done(item)
        else:
            item()
    except Exception as exc:  # a user callback must not kill the dispatcher
        _report_callback_error(exc)


def _report_callback_error(exc: Exception) -> None:
    import sys
    import traceback

    print("urb: exception in a request callback (the dispatcher goes on):", file=sys.stderr)
    traceback.print_exception(exc, file=sys.stderr)
