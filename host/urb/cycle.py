"""`Cycle`: the requests of one control tick (reads and writes of the mailboxes of many nodes),
built once and submitted together every tick, completing with one callback per tick.

    cycle = Cycle()
    feedback = [cycle.read(m, MotorFeedback) for m in motors]      # CycleItem, built once
    command = [cycle.write(m, MotorCommand) for m in motors]
    cycle.set_callback(on_tick)                                     # on_tick(cycle), once per tick

    every tick:
        for item, volts in zip(command, plan):
            item.set(MotorCommand(voltage=volts))                   # the payload of its next submission
        cycle.submit()                                              # every item at once

    def on_tick(cycle: Cycle) -> None:                              # after the last item completed
        if cycle.ok:
            fb = feedback[0].message()                              # decoded when asked, typed
        for item in cycle.failures():
            print(item.error)                                       # e.g. "MotorDriver:1 outbox 1: ..."

Every item of a submission ends in exactly one outcome, as a `NodeRequest` would (the same flags,
bridge status, data, sequence numbers and times on the same trace): its response, a timeout, the
bridge's loss, or a host refusal (UNKNOWN_NODE, FINGERPRINT_MISMATCH, HOST_SIZE_MISMATCH). The
outcome is read from the items after completion, lazily: nothing is built for an item nobody asks.

On the C core (`urb.managers.native`), a real-time or simulated manager gives the cycle a
`CycleState` of the extension (`_native_cycle.c`): one submission hands all the items of a bridge
to the core in one call, the outcomes stay in C until asked for, and the manager's dispatcher runs
one completion per bridge and tick instead of one per request. On the Python cores the items are
submitted as single transfers, with the same outcomes; tests/host/test_cycle.py compares the two.
host/urb/README.md ("Control cycles") is the manual.
"""

from __future__ import annotations

import threading
from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, TypeVar

from urb_msgs import DecodeError, Message
from urb_msgs.urb_core import Status

from .api import MISMATCH, NodeAccessor
from .errors import ErrorFlag, RequestFailed, URBError, hint
from .managers.base import NS_PER_S, BusManager, Transfer, decode_message, encode_message
from .managers.native import _FLAG_OF, _STATUS_OF

if TYPE_CHECKING:
    from .managers._native import CycleState

M = TypeVar("M", bound=Message)
CycleCallback = Callable[["Cycle"], object]

POLL_SLICE_S = 0.0005
"""How often `wait` looks at a polled cycle (whose completion wakes no thread)."""

IN_FLIGHT = ("the cycle is still in flight ({pending}): a cycle is submitted again once its callback has "
             "started (from inside it) or returned; wait() for it, or use a second Cycle for overlapping ticks")


class CycleBusy(RuntimeError):
    """`Cycle.submit` while the previous submission has not completed: nothing was submitted, the
    one in flight goes on."""


class CycleItem:
    """One request of a `Cycle` (a read of an outbox or a write of an inbox of one node), and the
    outcome of its last submission. Made by `Cycle.read` / `Cycle.write`."""

    __slots__ = ("cycle", "node", "mailbox", "is_read", "size", "message_type", "_size_refusal", "_group", "_slot",
                 "_has_data")

    def __init__(self, cycle: Cycle, node: NodeAccessor, mailbox: int, is_read: bool, size: int,
                 message_type: type[Message] | None, size_refusal: ErrorFlag) -> None:
        self.cycle = cycle
        self.node = node
        self.mailbox = mailbox
        self.is_read = is_read
        self.size = size
        """Bytes read or written (the schema's size unless given otherwise)."""
        self.message_type = message_type
        """The schema's message of this mailbox (None when the schema has no such mailbox)."""
        self._size_refusal = size_refusal
        self._group: _Group | None = None
        self._slot = -1
        self._has_data = is_read

    # -- writes -------------------------------------------------------------------------------
    def set(self, data: bytes | Message) -> CycleItem:
        """The payload of this write from the next submission on (a message is encoded here).
        Bytes of another length than the item's size raise ValueError; the previous payload stays.
        May be called while the cycle is in flight (the submission in flight keeps its payload)."""
        if self.is_read:
            raise ValueError(f"{self._where()}: a read takes no data")
        payload = data if data.__class__ is bytes else encode_message(data) if isinstance(data, Message) else bytes(data)
        if len(payload) != self.size:
            raise ValueError(f"{self._where()}: {len(payload)} data bytes, this item writes {self.size} "
                             f"(its previous data stay)")
        group = self._group
        if group is None:
            self.cycle._early_data[self] = payload
        else:
            group.set_data(self._slot, payload)
        if not self._has_data:
            self._has_data = True
            self.cycle._writes_without_data -= 1
        return self

    # -- outcome of the last submission --------------------------------------------------------
    def _outcome(self) -> _Group:
        group = self._group
        if group is None or not self.cycle._submissions:
            raise RuntimeError(f"{self._where()}: the cycle was never submitted")
        return group

    @property
    def flags(self) -> ErrorFlag:
        """`ErrorFlag.NONE` on success, else the one flag naming the failure (NONE while pending)."""
        return self._outcome().flags(self._slot)

    @property
    def ok(self) -> bool:
        g = self._outcome()
        return g.completed(self._slot) and g.flags(self._slot) == ErrorFlag.NONE

    @property
    def status(self) -> Status | None:
        """The bridge's status, when the bridge answered."""
        return self._outcome().status(self._slot)

    @property
    def data(self) -> bytes | None:
        """Outbox contents of a successful read (None otherwise)."""
        return self._outcome().data(self._slot)

    @property
    def seq(self) -> int:
        """Its sequence number on the uplink (-1: never sent)."""
        return self._outcome().seq(self._slot)

    @property
    def sent_ns(self) -> int | None:
        return self._outcome().sent_ns(self._slot)

    @property
    def completed_ns(self) -> int | None:
        """When the response was matched (or the failure decided), manager clock."""
        return self._outcome().completed_ns(self._slot)

    @property
    def error(self) -> str | None:
        """What went wrong and what to do, or None on success (or while pending)."""
        g = self._outcome()
        flags = g.flags(self._slot)
        if not flags:
            return None
        reason = g.lost_reason(self._slot)
        why = f" ({reason})" if reason else ""
        return f"{self._where()}: {flags.describe()}{why}: {hint(flags)}"

    def message(self, cls: type[M] | None = None) -> Any:
        """The read data decoded with the schema's message of this outbox (or `cls`). Raises
        `RequestFailed` when the read failed, `URBError` when the data do not decode."""
        data = self.data
        if data is None:
            raise RequestFailed(self.error or f"{self._where()}: no data (a write, or not completed)", self.flags)
        target = cls if cls is not None else self.message_type
        if target is None:
            raise URBError(f"{self._where()}: the schema has no message for it; read raw bytes (.data)")
        try:
            return decode_message(target, data)
        except DecodeError as exc:
            raise URBError(f"{self._where()}: the data do not decode as {target.NAME}: {exc}") from None

    def raise_for_error(self) -> CycleItem:
        if not self.ok:
            raise RequestFailed(self.error or f"{self._where()}: not completed", self.flags)
        return self

    def _where(self) -> str:
        return f"{self.node.label} {'outbox' if self.is_read else 'inbox'} {self.mailbox}"

    def __repr__(self) -> str:
        kind = "read" if self.is_read else "write"
        return f"<CycleItem {self.node.label} {kind} {self.mailbox}>"


class Cycle:
    """A fixed set of requests submitted together, every control tick, completing with one
    callback (and one `wait`) per submission. Build it with `read` and `write` (any nodes, any
    bridges), then `submit` it every tick; the first submission fixes the items."""

    def __init__(self) -> None:
        self._items: list[CycleItem] = []
        self._groups: list[_Group] = []
        self._callback: CycleCallback | None = None
        self._lock = threading.Lock()
        self._early_data: dict[CycleItem, bytes] = {}
        self._writes_without_data = 0
        self._submissions = 0
        self._completions = 0
        """Submissions whose callback returned (or that completed without one)."""
        self._busy = False
        self._callback_thread: int | None = None
        self._groups_left = 0
        self.submitted_ns: int | None = None
        """When the last submission was made (the first bridge's manager clock)."""
        self.callback_ns: int | None = None
        """When its completion callback was invoked."""

    # -- building -------------------------------------------------------------------------------
    def read(self, node: NodeAccessor, what: type[Message] | int, size: int | None = None) -> CycleItem:
        """Read the outbox holding message `what` (found in the schema) or outbox number `what`;
        `size` defaults to the schema's (a size the schema does not give completes
        HOST_SIZE_MISMATCH at every submission, as `NodeRequest.read` does)."""
        box, schema_size, msg = self._mailbox(node, what, "outbox")
        if size is not None and not 1 <= size <= 32:
            raise ValueError(f"size = {size}: a mailbox holds 1..32 bytes")
        return self._add(node, box, True, size if size is not None else schema_size, schema_size, msg)

    def write(self, node: NodeAccessor, what: type[Message] | int, data: bytes | Message | None = None,
              size: int | None = None) -> CycleItem:
        """Write the inbox taking message `what` (found in the schema) or inbox number `what`.
        Its payload is set with `CycleItem.set` (or `data` here) before the first submission and
        whenever it changes; `size` (raw inboxes) defaults to the schema's size."""
        box, schema_size, msg = self._mailbox(node, what, "inbox")
        if size is not None and not 1 <= size <= 32:
            raise ValueError(f"size = {size}: a mailbox holds 1..32 bytes")
        length = size if size is not None else schema_size
        if length == 0:
            raise ValueError(f"{node.label} has no inbox {box} in the schema: give its size (size=)")
        item = self._add(node, box, False, length, schema_size, msg)
        if data is not None:
            item.set(data)
        return item

    def set_callback(self, fn: CycleCallback | None) -> Cycle:
        """`fn(cycle)` runs once per submission, after its last item completed, on the dispatcher
        of the manager that completed it (a cycle over several bridges: the last one's). Without
        a callback the cycle is polled: its owner learns of the completion with `poll`, `wait` or
        the next `submit`, on its own thread, and no dispatcher wakes for it. Changed only while
        the cycle is not in flight (else `CycleBusy`)."""
        if self._busy:
            raise CycleBusy(IN_FLIGHT.format(pending="its mode changes between submissions"))
        self._callback = fn
        for g in self._groups:
            g.set_mode(fn is not None)
        return self

    @staticmethod
    def _mailbox(node: NodeAccessor, what: type[Message] | int, direction: str) -> tuple[int, int, type[Message] | None]:
        if isinstance(what, int):
            if not 0 <= what <= 7:
                raise ValueError(f"mailbox {what!r}: mailboxes are numbered 0..7")
            box = what
        else:
            box = node.mailbox_of(what, direction)
        mb = node.info.mailbox(direction, box)
        return box, (mb.size if mb is not None else 0), (mb.message if mb is not None else None)

    def _add(self, node: NodeAccessor, box: int, read: bool, size: int, schema_size: int,
             msg: type[Message] | None) -> CycleItem:
        if self._groups:
            raise RuntimeError("the cycle's items are fixed by its first submission; build another Cycle")
        refusal = ErrorFlag.NONE if size == schema_size and size > 0 else ErrorFlag.HOST_SIZE_MISMATCH
        item = CycleItem(self, node, box, read, size, msg, refusal)
        self._items.append(item)
        if not read:
            self._writes_without_data += 1
        return item

    # -- submitting -----------------------------------------------------------------------------
    @property
    def items(self) -> tuple[CycleItem, ...]:
        return tuple(self._items)

    def submit(self) -> Cycle:
        """Submit every item (thread-safe against the dispatchers). Raises `CycleBusy` while the
        previous submission has not completed (unless called from its own callback), ValueError
        when a write item has no data yet; either way nothing is submitted."""
        if self._busy and self._callback is None:
            self.poll()
        if self._busy and self._callback_thread != threading.get_ident():
            pending = sum(g.pending() for g in self._groups)
            what = f"{pending} of {len(self._items)} items pending" if pending else "its callback is running"
            raise CycleBusy(IN_FLIGHT.format(pending=what))
        if self._writes_without_data:
            missing = ", ".join(repr(i) for i in self._items if not i._has_data)
            raise ValueError(f"write items without data: {missing}; give them data with item.set(...) first")
        groups = self._groups or self._freeze()
        self._submissions += 1
        self._busy = True
        self._groups_left = len(groups)
        self.submitted_ns = groups[0].manager.now_ns()
        for g in groups:
            g.submit()
        return self

    def _freeze(self) -> list[_Group]:
        if not self._items:
            raise ValueError("the cycle has no items: add some with read() and write() first")
        by_manager: dict[int, list[CycleItem]] = {}
        for item in self._items:
            by_manager.setdefault(id(item.node.manager), []).append(item)
        groups: list[_Group] = []
        for items in by_manager.values():
            manager = items[0].node.manager
            specs = tuple((i.node.address, i.mailbox, i.is_read, max(1, i.size)) for i in items)
            state = manager.new_cycle_state(specs)
            group: _Group = _NativeGroup(self, manager, items, state) if state is not None else _PythonGroup(self, manager, items)
            groups.append(group)
        for item, payload in self._early_data.items():
            assert item._group is not None
            item._group.set_data(item._slot, payload)
        self._early_data.clear()
        self._groups = groups
        return groups

    # lobster-trace: urb.HOST_001
    def _group_done(self) -> None:
        """A group's last item completed (on its manager's dispatcher)."""
        if self._callback is None:
            return  # polled: `poll` finishes it, on its owner's thread
        if len(self._groups) > 1:
            with self._lock:
                self._groups_left -= 1
                if self._groups_left:
                    return
        self._finish()

    def poll(self) -> bool:
        """A polled cycle (no callback): True once its last submission completed (counted and
        finished on this thread, at the first look that finds it so), False while items are
        pending; never blocks. A cycle with a callback: whether its callback returned (`done`)."""
        if not self._busy:
            return self._submissions > 0
        if self._callback is not None:
            return self.done
        for g in self._groups:
            if g.pending():
                g.manager.collect_completions()
                if g.pending():
                    return False
        self._finish()
        return True

    def _finish(self) -> None:
        """Every item of the last submission completed: the nodes' counters, then the callback."""
        generation = self._submissions
        self.callback_ns = self._groups[0].manager.now_ns()
        for g in self._groups:
            g.note_nodes()
        self._callback_thread = threading.get_ident()
        try:
            if self._callback is not None:
                self._callback(self)
        finally:
            self._callback_thread = None
            self._completions = generation
            if self._submissions == generation:  # not submitted again from the callback
                self._busy = False

    # -- outcome --------------------------------------------------------------------------------
    @property
    def done(self) -> bool:
        """The last submission completed and its callback (if any) returned."""
        return self._submissions > 0 and self._completions == self._submissions

    @property
    def in_flight(self) -> bool:
        return self._busy

    @property
    def submissions(self) -> int:
        return self._submissions

    @property
    def failed(self) -> int:
        """Items of the last completed submission that failed."""
        return sum(g.failed() for g in self._groups)

    @property
    def ok(self) -> bool:
        """Every item of the last submission completed successfully."""
        return self._submissions > 0 and not self._busy_items() and self.failed == 0

    def failures(self) -> list[CycleItem]:
        """The items of the last submission that failed, in the order they were added."""
        return [i for i in self._items if i.flags != ErrorFlag.NONE] if self.failed else []

    def raise_for_error(self) -> Cycle:
        """Raise `RequestFailed` (the first failure's) unless every item succeeded."""
        bad = self.failures()
        if bad:
            raise RequestFailed(f"{len(bad)} of {len(self._items)} cycle items failed; first: {bad[0].error}",
                                bad[0].flags)
        return self

    def wait(self, timeout_s: float = 1.0) -> bool:
        """Block until the last submission completed and its callback returned; False on timeout
        (RuntimeError inside a callback, as every blocking call of the API)."""
        if not self._submissions:
            raise RuntimeError("the cycle was never submitted")
        if self._callback is None:
            return self._wait_polled(timeout_s)
        generation = self._submissions
        managers: list[BusManager] = []
        for g in self._groups:
            if g.manager not in managers:
                managers.append(g.manager)
        for m in managers:
            if not m.wait_until(lambda: self._completions >= generation, timeout_s):
                return False
        return True

    def _wait_polled(self, timeout_s: float) -> bool:
        """`wait` of a polled cycle: a look every POLL_SLICE_S (its completion wakes nobody)."""
        m = self._groups[0].manager
        end = m.now_ns() + int(timeout_s * NS_PER_S)
        while not self.poll():
            left = end - m.now_ns()
            if left <= 0:
                return False
            m.wait_until(self.poll, min(left / NS_PER_S, POLL_SLICE_S))
        return True

    def _busy_items(self) -> int:
        return sum(g.pending() for g in self._groups)

    def __repr__(self) -> str:
        state = "in flight" if self._busy else ("done" if self.done else "not submitted")
        return f"<Cycle {len(self._items)} items, {self._submissions} submissions, {state}>"


# ----------------------------------------------------------------------------------------------
# The items of one bridge: submitted to the C core at once, or one by one to a Python core
# ----------------------------------------------------------------------------------------------

class _Group(ABC):
    """The items of a cycle on one manager."""

    def __init__(self, cycle: Cycle, manager: BusManager, items: list[CycleItem]) -> None:
        self.cycle = cycle
        self.manager = manager
        self.items = items
        for slot, item in enumerate(items):
            item._group, item._slot = self, slot
        self._static_refusals = tuple(int(i._size_refusal) for i in items)
        self._static_refused = any(self._static_refusals)
        self._nodes: list[NodeAccessor] = []
        for i in items:
            if i.node not in self._nodes:
                self._nodes.append(i.node)
        self._per_node = [(n, sum(1 for i in items if i.node is n)) for n in self._nodes]

    def refusals(self) -> tuple[int, ...] | None:
        """The host's refusal of each item (the rules of `NodeAccessor.submit_request`), or None: none."""
        for node in self._nodes:
            rec = node.record
            if not rec.active or (rec.flags and MISMATCH in rec.flags and not node.own_layout):
                break
        else:
            return self._static_refusals if self._static_refused else None
        out = []
        for i, static in zip(self.items, self._static_refusals):
            rec = i.node.record
            if not rec.active:
                out.append(int(ErrorFlag.UNKNOWN_NODE))
            elif MISMATCH in rec.flags and not i.node.own_layout:
                out.append(int(ErrorFlag.FINGERPRINT_MISMATCH))
            else:
                out.append(static)
        return tuple(out)

    def set_mode(self, callback: bool) -> None:
        """With a callback the group's completion runs on the dispatcher; without, it is polled."""

    def note_nodes(self) -> None:
        """The nodes' completion counters (`NodeAccessor.completed`, `.failed`)."""
        if not self.failed():
            for node, n in self._per_node:
                with node._stats_lock:
                    node.completed += n
            return
        for node, n in self._per_node:
            bad = sum(1 for s, i in enumerate(self.items) if i.node is node and self.flags(s))
            with node._stats_lock:
                node.completed += n
                node.failed += bad

    # the outcome of slot i, kept by the subclasses
    @abstractmethod
    def submit(self) -> None:
        """Submit every item of the group (the refusals decided now)."""

    @abstractmethod
    def set_data(self, i: int, payload: bytes) -> None:
        """The payload of write slot `i` from the next submission on."""

    @abstractmethod
    def pending(self) -> int:
        """Items of the current submission not completed yet."""

    @abstractmethod
    def failed(self) -> int:
        """Items of the last submission that failed."""

    @abstractmethod
    def completed(self, i: int) -> bool:
        """Slot `i` of the last submission completed."""

    @abstractmethod
    def flags(self, i: int) -> ErrorFlag:
        """Slot `i`'s flags (NONE while pending)."""

    @abstractmethod
    def status(self, i: int) -> Status | None:
        """Slot `i`'s bridge status, when the bridge answered."""

    @abstractmethod
    def data(self, i: int) -> bytes | None:
        """Slot `i`'s data, for a successful read."""

    @abstractmethod
    def seq(self, i: int) -> int:
        """Slot `i`'s sequence number (-1: never sent)."""

    @abstractmethod
    def sent_ns(self, i: int) -> int | None:
        """When slot `i` was sent."""

    @abstractmethod
    def completed_ns(self, i: int) -> int | None:
        """When slot `i` completed."""

    @abstractmethod
    def lost_reason(self, i: int) -> str | None:
        """Why the bridge was lost, for a BRIDGE_LOST slot."""


class _NativeGroup(_Group):
    """On the C core: one `_cycle_submit` per tick, the outcomes in the `CycleState`."""

    def __init__(self, cycle: Cycle, manager: BusManager, items: list[CycleItem], state: CycleState) -> None:
        super().__init__(cycle, manager, items)
        self.state = state
        self.set_mode(cycle._callback is not None)

    def set_mode(self, callback: bool) -> None:
        self.state.on_done = self.cycle._group_done if callback else None

    def submit(self) -> None:
        self.manager.submit_cycle(self.state, self.refusals())

    def set_data(self, i: int, payload: bytes) -> None:
        self.state.set_data(i, payload)

    def pending(self) -> int:
        return self.state.pending

    def failed(self) -> int:
        return self.state.failed

    def completed(self, i: int) -> bool:
        return self.state.completed_ns(i) is not None

    def flags(self, i: int) -> ErrorFlag:
        return _FLAG_OF[self.state.flags(i)]

    def status(self, i: int) -> Status | None:
        s = self.state.status(i)
        return _STATUS_OF[s] if s >= 0 else None

    def data(self, i: int) -> bytes | None:
        return self.state.data(i)

    def seq(self, i: int) -> int:
        return self.state.seq(i)

    def sent_ns(self, i: int) -> int | None:
        return self.state.sent_ns(i)

    def completed_ns(self, i: int) -> int | None:
        return self.state.completed_ns(i)

    def lost_reason(self, i: int) -> str | None:
        return self.state.lost_reason(i)


class _PythonGroup(_Group):
    """On a Python core (the reference): a `Transfer` per item and tick, submitted one by one."""

    def __init__(self, cycle: Cycle, manager: BusManager, items: list[CycleItem]) -> None:
        super().__init__(cycle, manager, items)
        self._payloads = [b""] * len(items)
        self._transfers: list[Transfer] = []
        self._left = 0

    def submit(self) -> None:
        refusals = self.refusals()
        ts = [Transfer(i.node.address, i.mailbox, i.is_read, max(1, i.size), data=p, on_done=self._one_done)
              for i, p in zip(self.items, self._payloads)]
        self._transfers = ts
        self._left = len(ts)
        for k, t in enumerate(ts):
            flag = refusals[k] if refusals is not None else 0
            if flag:
                self.manager.reject(t, _FLAG_OF[flag])
            else:
                self.manager.submit(t)

    def _one_done(self, t: Transfer) -> None:
        self._left -= 1
        if not self._left:
            self.cycle._group_done()

    def set_data(self, i: int, payload: bytes) -> None:
        self._payloads[i] = payload

    def pending(self) -> int:
        return self._left

    def failed(self) -> int:
        return sum(1 for t in self._transfers if t.done and t.flags)

    def completed(self, i: int) -> bool:
        return self._transfers[i].done

    def flags(self, i: int) -> ErrorFlag:
        t = self._transfers[i]
        return t.flags if t.done else ErrorFlag.NONE

    def status(self, i: int) -> Status | None:
        return self._transfers[i].status

    def data(self, i: int) -> bytes | None:
        t = self._transfers[i]
        return t.response if t.done else None

    def seq(self, i: int) -> int:
        return self._transfers[i].seq

    def sent_ns(self, i: int) -> int | None:
        return self._transfers[i].sent_ns

    def completed_ns(self, i: int) -> int | None:
        return self._transfers[i].completed_ns

    def lost_reason(self, i: int) -> str | None:
        t = self._transfers[i]
        return t.lost_reason if t.flags & ErrorFlag.BRIDGE_LOST else None
