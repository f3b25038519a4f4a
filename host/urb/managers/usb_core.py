"""The host side of the pipelined USB uplink as a pure state machine (spec/tla/UsbUplink.tla).

Once per 1-ms frame the runtime calls `frame_out(now)` and sends what it returns as ONE bulk-OUT
transfer: a `UsbBatchHeader` (frame counter, count) and up to `max_batch` buffered requests back
to back (`UsbWrite`); requests that do not fit stay buffered for the next frame, never dropped.
Every bulk-IN transfer the transport completes goes to `receive_batch(data, now)`: the bridge's
*previous* response buffer (`UsbRead`: write n and read n-1 share a frame), whose header echoes
the frame counter of the batch it answers. Responses are matched to that batch's requests by
order and sequence number (`Callback`, `ResponsesMatched`); a request of an answered batch that
has no response in it completes at once (UPLINK_CHECKSUM if corrupt bytes stood in its place,
UPLINK_TIMEOUT otherwise), and a batch whose IN transfer never comes times out after
`timeout_ns`. A corrupt IN header fails the oldest awaiting batch with UPLINK_CHECKSUM.

Batch limits: `max_batch` requests (<= 15, so sequence numbers are unique within a batch), and
both the OUT transfer and the worst-case IN transfer within `USB_BATCH_MAX_BYTES` (512).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

from urb_msgs import DecodeError
from urb_msgs.urb_core import USB_BATCH_MAX_BYTES, Status, UsbBatchHeader

from ..errors import ErrorFlag
from .base import NS_PER_MS, Transfer, finish
from .rs232_core import SEQ_MOD, ResponseMatcher, encode_request

HEADER_SIZE = UsbBatchHeader.MAX_SIZE
MAX_BATCH = SEQ_MOD - 1


@dataclass
class _Batch:
    frame: int
    sent_ns: int
    transfers: list[Transfer] = field(default_factory=list)


class UsbCore:
    """Host protocol state machine for one bridge on a USB (per-frame) uplink."""

    def __init__(
        self,
        *,
        max_batch: int = 14,
        batch_bytes: int = USB_BATCH_MAX_BYTES,
        timeout_ns: int = 10 * NS_PER_MS,
        lost_after_ns: int = 500 * NS_PER_MS,
    ) -> None:
        """`max_batch`: requests per bulk-OUT transfer (1..15). `batch_bytes`: largest transfer in
        either direction. `timeout_ns`: a batch whose responses have not arrived this long after
        it was written completes UPLINK_TIMEOUT (3 frames is the paper's bound). `lost_after_ns`:
        no IN transfer for this long with batches awaiting declares the bridge lost."""
        self.max_batch = _check_batch(max_batch)
        self.batch_bytes = batch_bytes
        self.timeout_ns = timeout_ns
        self.lost_after_ns = lost_after_ns
        self.lost_reason: str | None = None
        self.frames_written = 0
        self.stray_bytes = 0
        self._queued: deque[Transfer] = deque()
        self._awaiting: deque[_Batch] = deque()
        self._completed: list[Transfer] = []
        self._frame = 0
        self._next_seq = 1  # the n-th request carries n mod 16, as Bridge.tla's Emit (id % SeqMod)
        self._last_in_ns = 0
        self._active_since = 0

    # -- inputs ------------------------------------------------------------------------------
    def submit(self, t: Transfer, now: int) -> None:
        """Buffer a request for the next bulk-OUT transfer (`Submit`)."""
        if self.lost_reason is not None:
            self._completed.append(finish(t, now, ErrorFlag.BRIDGE_LOST))
            return
        self._queued.append(t)

    def receive_batch(self, data: bytes, now: int) -> None:
        """One bulk-IN transfer: a header echoing the frame it answers, then its responses."""
        self._last_in_ns = now
        if self.lost_reason is not None or not data:
            return
        try:
            header = UsbBatchHeader.decode(data[:HEADER_SIZE])
        except DecodeError:
            self.stray_bytes += len(data)
            if self._awaiting:
                self._fail_batch(self._awaiting.popleft(), now, ErrorFlag.UPLINK_CHECKSUM)
            return
        k = next((i for i, b in enumerate(self._awaiting) if b.frame == header.frame), -1)
        if k < 0:
            if header.count:  # an empty batch's echo answers nothing and is expected
                self.stray_bytes += len(data)  # stale or duplicated: answers nothing we wait for
            return
        for _ in range(k):  # older batches whose IN transfer never came
            self._fail_batch(self._awaiting.popleft(), now, ErrorFlag.UPLINK_TIMEOUT)
        batch = self._awaiting.popleft()
        m = ResponseMatcher()
        m.inflight.extend(batch.transfers)
        m.rx += data[HEADER_SIZE:]
        m.parse(now)
        m.lost_before(len(m.inflight), now)  # the batch is complete: what is missing is lost
        self.stray_bytes += len(m.rx) + m.stray_bytes
        self._completed.extend(m.completed)

    def poll(self, now: int) -> None:
        """Time out batches whose responses never came; detect a silent bridge."""
        if self.lost_reason is not None:
            return
        while self._awaiting and now - self._awaiting[0].sent_ns >= self.timeout_ns:
            self._fail_batch(self._awaiting.popleft(), now, ErrorFlag.UPLINK_TIMEOUT)
        if self._awaiting and now - max(self._last_in_ns, self._active_since) >= self.lost_after_ns:
            ms = (now - max(self._last_in_ns, self._active_since)) // NS_PER_MS
            self.link_lost(now, f"the bridge returned no USB transfer for {ms} ms")

    def link_lost(self, now: int, reason: str) -> None:
        """The uplink is gone: everything pending and queued completes BRIDGE_LOST."""
        if self.lost_reason is not None:
            return
        self.lost_reason = reason
        for b in self._awaiting:
            self._fail_batch(b, now, ErrorFlag.BRIDGE_LOST)
        self._awaiting.clear()
        for t in self._queued:
            self._completed.append(finish(t, now, ErrorFlag.BRIDGE_LOST))
        self._queued.clear()

    def reset(self, now: int) -> None:
        """Forget the lost state (after the uplink was reopened)."""
        self.link_lost(now, "reset")
        self.lost_reason = None
        self._last_in_ns = now

    def set_window(self, window: int) -> None:
        """Requests per batch (the bridge runs a whole batch from its FIFO)."""
        self.max_batch = _check_batch(window)

    # -- outputs -----------------------------------------------------------------------------
    def frame_out(self, now: int) -> bytes | None:
        """The bulk-OUT transfer for this frame, or None when there is nothing to send or fetch.

        An empty batch (count 0) is still sent while earlier batches await their responses: it
        is what makes the bridge hand over its previous response buffer.
        """
        if self.lost_reason is not None or not (self._queued or self._awaiting):
            return None
        batch = _Batch(frame=self._frame, sent_ns=now)
        out_bytes = in_bytes = HEADER_SIZE
        frames: list[bytes] = []
        while self._queued and len(batch.transfers) < self.max_batch:
            t = self._queued[0]
            req, resp = t.request_size(), t.response_size(Status.OK)
            if out_bytes + req > self.batch_bytes or in_bytes + resp > self.batch_bytes:
                break  # stays buffered for the next frame
            self._queued.popleft()
            out_bytes, in_bytes = out_bytes + req, in_bytes + resp
            t.seq = self._next_seq
            self._next_seq = (self._next_seq + 1) % SEQ_MOD
            t.sent_ns = now
            batch.transfers.append(t)
            frames.append(encode_request(t))
        if batch.transfers:
            if not self._awaiting:
                self._active_since = now
            self._awaiting.append(batch)
        self._frame = (self._frame + 1) & 0xFFFF
        self.frames_written += 1
        return UsbBatchHeader(frame=batch.frame, count=len(batch.transfers)).encode() + b"".join(frames)

    def take_completed(self) -> list[Transfer]:
        done, self._completed = self._completed, []
        return done

    def next_deadline(self) -> int | None:
        if self.lost_reason is not None or not self._awaiting:
            return None
        return min(self._awaiting[0].sent_ns + self.timeout_ns,
                   max(self._last_in_ns, self._active_since) + self.lost_after_ns)

    def busy(self) -> bool:
        return bool(self._queued or self._awaiting)

    # -- helpers -----------------------------------------------------------------------------
    def _fail_batch(self, batch: _Batch, now: int, flag: ErrorFlag) -> None:
        for t in batch.transfers:
            self._completed.append(finish(t, now, flag))


def _check_batch(n: int) -> int:
    if not 1 <= n <= MAX_BATCH:
        raise ValueError(f"max_batch = {n}: must be 1..{MAX_BATCH} (sequence numbers unique within a batch)")
    return n
