"""`NodeRequest`: one read or write of one mailbox of one node, and its outcome (the API's
request object; `urb.api` is the entry point)."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, TypeVar

from urb_msgs import DecodeError, Message
from urb_msgs.urb_core import Status

from .errors import ErrorFlag, RequestFailed, URBError, hint
from .managers.base import Transfer, decode_message, encode_message

if TYPE_CHECKING:
    from .api import NodeAccessor

M = TypeVar("M", bound=Message)
Callback = Callable[["NodeRequest"], object]


class NodeRequest:
    """One read or write of one mailbox of one node, and (once complete) its outcome.

    Build it with `read`/`write` (or the typed `read_message`/`write_message`), optionally
    `set_callback`, then `NodeAccessor.submit_request`. A request is submitted once; make a new
    one for the next cycle (`NodeAccessor.new_request`). In the callback, `ok` tells success;
    otherwise `flags` holds exactly one `ErrorFlag` and `error` explains it.
    """

    def __init__(self, node: NodeAccessor) -> None:
        self.node = node
        self._mailbox: int | None = None
        self._read = True
        self._size = 0
        self._payload = b""
        self._callback: Callback | None = None
        self._transfer: Transfer | None = None
        self._finished = False
        self.callback_ns: int | None = None
        """When the callback was invoked (manager clock)."""

    # -- building -----------------------------------------------------------------------------
    def read(self, mbox: int, size: int | None = None) -> NodeRequest:
        """Read outbox `mbox`; `size` defaults to the schema's size (a different size is refused
        with HOST_SIZE_MISMATCH when submitted)."""
        _check_mbox(mbox)
        if size is not None and not 1 <= size <= 32:
            raise ValueError(f"size = {size}: a mailbox holds 1..32 bytes")
        self._mailbox, self._read = mbox, True
        # an outbox the schema does not have: size 0, refused with HOST_SIZE_MISMATCH on submission
        self._size = size if size is not None else (self.node.schema_size(True, mbox) or 0)
        return self

    def write(self, mbox: int, data: bytes | Message) -> NodeRequest:
        """Write inbox `mbox` with raw bytes or a message (encoded here)."""
        _check_mbox(mbox)
        payload = encode_message(data) if isinstance(data, Message) else bytes(data)
        if not 1 <= len(payload) <= 32:
            raise ValueError(f"{len(payload)} data bytes: a mailbox holds 1..32 bytes")
        self._mailbox, self._read, self._size, self._payload = mbox, False, len(payload), payload
        return self

    def read_message(self, cls: type[Message], mbox: int | None = None) -> NodeRequest:
        """Read the outbox that holds `cls` (found in the schema when `mbox` is omitted)."""
        return self.read(self.node.mailbox_of(cls, "outbox") if mbox is None else mbox)

    def write_message(self, msg: Message, mbox: int | None = None) -> NodeRequest:
        """Write `msg` to the inbox that takes its type (found in the schema when omitted)."""
        return self.write(self.node.mailbox_of(type(msg), "inbox") if mbox is None else mbox, msg)

    def set_callback(self, fn: Callback | None) -> NodeRequest:
        """`fn(request)` runs once when the request completes (on the manager's dispatcher)."""
        self._callback = fn
        return self

    # -- outcome ------------------------------------------------------------------------------
    @property
    def mailbox(self) -> int:
        if self._mailbox is None:
            raise ValueError("the request has no mailbox yet: call read() or write() first")
        return self._mailbox

    @property
    def is_read(self) -> bool:
        return self._read

    @property
    def size(self) -> int:
        return self._size

    @property
    def done(self) -> bool:
        """The request completed and its callback (if any) has returned."""
        return self._finished

    @property
    def flags(self) -> ErrorFlag:
        """`ErrorFlag.NONE` on success, else the one flag naming the failure."""
        return self._transfer.flags if self._transfer is not None and self._transfer.done else ErrorFlag.NONE

    @property
    def ok(self) -> bool:
        return self._transfer is not None and self._transfer.done and self._transfer.flags == ErrorFlag.NONE

    @property
    def status(self) -> Status | None:
        """The bridge's status, when the bridge answered."""
        return self._transfer.status if self._transfer is not None else None

    @property
    def error(self) -> str | None:
        """What went wrong and what to do, or None on success."""
        if self._transfer is None or not self._transfer.done or self.ok:
            return None
        why = f" ({self._transfer.lost_reason})" if self._transfer.lost_reason else ""
        return (f"{self.node.label} {'outbox' if self._read else 'inbox'} {self._mailbox}: "
                f"{self.flags.describe()}{why}: {hint(self.flags)}")

    @property
    def data(self) -> bytes | None:
        """Outbox contents of a successful read (None otherwise)."""
        return self._transfer.response if self._transfer is not None else None

    def message(self, cls: type[M] | None = None) -> Any:
        """The read data decoded with the schema's message for this outbox (or `cls`).

        Typed use: ``req.message(MotorFeedback)`` returns a `MotorFeedback`. Raises
        `RequestFailed` when the request failed and `URBError` when the data do not decode."""
        if not self.ok or self.data is None:
            raise RequestFailed(self.error or "the request has not completed", self.flags)
        target: type[Message]
        if cls is not None:
            target = cls
        else:
            mb = self.node.info.mailbox("outbox", self.mailbox)
            if mb is None:
                raise URBError(f"{self.node.label} has no outbox {self.mailbox} in the schema; read raw bytes (.data)")
            target = mb.message
        try:
            return decode_message(target, self.data)
        except DecodeError as exc:
            raise URBError(f"{self.node.label} outbox {self.mailbox}: the data do not decode as {target.NAME}: {exc}") from None

    # timestamps (manager clock, ns)
    @property
    def submitted_ns(self) -> int | None:
        return self._transfer.submitted_ns if self._transfer is not None else None

    @property
    def sent_ns(self) -> int | None:
        return self._transfer.sent_ns if self._transfer is not None else None

    @property
    def completed_ns(self) -> int | None:
        """When the response was received and matched (or the failure decided)."""
        return self._transfer.completed_ns if self._transfer is not None else None

    @property
    def latency_ns(self) -> int | None:
        """Round trip as the paper measures it: submission to callback invocation."""
        t = self._transfer
        if t is None or self.callback_ns is None:
            return None
        return self.callback_ns - t.submitted_ns

    @property
    def response_latency_ns(self) -> int | None:
        """Submission to response received (without the dispatcher hand-off)."""
        t = self._transfer
        if t is None or t.completed_ns is None:
            return None
        return t.completed_ns - t.submitted_ns

    def wait(self, timeout_s: float = 1.0) -> bool:
        """Block until the request is done (callback returned); False on timeout."""
        return self.node.manager.wait_until(lambda: self._finished, timeout_s)

    def raise_for_error(self) -> NodeRequest:
        """Raise `RequestFailed` unless the request succeeded."""
        if not self.ok:
            raise RequestFailed(self.error or f"{self.node.label}: request not complete", self.flags)
        return self

    def __repr__(self) -> str:
        kind = "read" if self._read else "write"
        state = self.flags.describe() if self._transfer is not None and self._transfer.done else "pending"
        return f"<NodeRequest {self.node.label} {kind} {self._mailbox} {state}>"

    # -- internal -----------------------------------------------------------------------------
    def _make_transfer(self, address: int) -> Transfer:
        """The request's transfer to downlink `address` (its node's, read once by the caller)."""
        if self._mailbox is None:
            raise ValueError("call read() or write() on the request before submitting it")
        if self._transfer is not None:
            raise RuntimeError("this NodeRequest was already submitted; make a new one with node.new_request()")
        t = Transfer(address=address, mailbox=self._mailbox, read=self._read,
                     length=self._size, data=self._payload, on_done=self._on_done, owner=self)
        self._transfer = t
        return t

    def _on_done(self, t: Transfer) -> None:
        node = self.node
        self.callback_ns = node.record.bridge.now_ns()  # node.manager
        try:
            node._note(t.flags == ErrorFlag.NONE)
            cb = self._callback or node._default_callback
            if cb is not None:
                cb(self)
        finally:
            self._finished = True


def _check_mbox(mbox: int) -> None:
    if not isinstance(mbox, int) or not 0 <= mbox <= 7:
        raise ValueError(f"mailbox {mbox!r}: mailboxes are numbered 0..7")
