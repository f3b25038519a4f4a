"""The host side of the pipelined USB uplink as a pure state machine (spec/tla/UsbUplink.tla).

Once per 1-ms frame the runtime calls `frame_out(now)` and sends what it returns as ONE bulk-OUT
transfer (`UsbWrite`): a `UsbBatchHeader` (frame counter, count) and the buffered requests that
fit, back to back; requests that do not fit stay buffered for a later frame, never dropped. While
responses are outstanding an OUT transfer goes out every frame, empty if need be, because each
OUT is what makes the driver issue the bulk-IN read of the bridge's previous buffer (write n and
read n-1 share a frame, Fig. 9).

Every bulk-IN transfer goes to `receive_batch(data, now)`. Its header carries the frame counter
of the last OUT the bridge had received and is informational: the bridge fills a buffer with the
responses it emitted during a frame, so when a batch's downlink work outlasts its frame, the rest
of its responses arrive in the next buffer. The body is therefore matched as one in-order
response stream, exactly as `UsbUplink!Callback` matches `Head(hostRx)` with `Head(expect)`
(and as the RS232 core does): by order and 4-bit sequence number. A USB transfer never splits a
response, so bytes left unmatched at the end of a transfer are discarded at once. A request
without a response completes when a later response proves it lost (UPLINK_TIMEOUT, or
UPLINK_CHECKSUM when corrupt bytes stood in its place) or after `timeout_ns`; one that timed out
keeps its sequence number and window slot as a placeholder until a response releases it or its
lifetime `placeholder_ns` is over (as in the RS232 core: `rs232_core.ResponseMatcher`).

Limits per batch: `max_batch` requests, both the OUT transfer and the worst-case IN contribution
within `USB_BATCH_MAX_BYTES` (512); in flight at most `window` (<= 15, Bridge.tla `HostWindow <
SeqMod`: the sequence number cannot alias).

Hand-over (`hand_over`, after a process that ended without a draining close): responses the bridge
could not send because nobody read its IN buffers wait there for the next reader, however old.
So besides sending no request before the previous process's lifetime is over (as the RS232
core), the core sends empty OUT transfers, discarding what the IN transfers bring, until an IN
transfer carries no response that the bridge filled wholly after that instant (one received two
frames after it or later): the bridge then holds nothing of the previous process (Bridge.tla
`HostRestart`'s premise).

Latency: the paper's three frames (Fig. 16; UsbUplink.tla `StrictLatency`) hold while at most
window / 2 requests (7 with the usual window of 15) are submitted per frame. The OUT transfer of
frame n goes out before the IN transfer that completes batch n-1, so two frames' requests are in
flight at once; more per frame fills the window, and the requests beyond it wait for a later frame
(TLC: MaxBatch = MaxSubmit = 2 with Window = 3 calls a request back in its fourth frame).
"""

from __future__ import annotations

from urb_msgs import DecodeError
from urb_msgs.urb_core import USB_BATCH_MAX_BYTES, Status, UsbBatchHeader

from .base import NS_PER_MS, Transfer
from .rs232_core import MAX_WINDOW, PLACEHOLDER_NS, MatchingCore, check_window

HEADER_SIZE = UsbBatchHeader.MAX_SIZE
FRAME_NS = NS_PER_MS

#: One step of the pipeline as UsbUplink.tla names it, for trace validation
#: (sim/urb_sim/tracecheck.py): ("submit" | "write" | "read" | "callback", now, transfers). A write
#: holds its batch, a read the requests whose responses its IN transfer carried, in order; a
#: callback event the completed transfers handed out together (now: the last one's completion).
UsbTraceEvent = tuple[str, int, tuple[Transfer, ...]]


class UsbCore(MatchingCore):
    """Host protocol state machine for one bridge on a USB (per-frame) uplink."""

    SILENCE = "the bridge returned no USB transfer"

    def __init__(
        self,
        *,
        max_batch: int = 14,
        window: int = MAX_WINDOW,
        batch_bytes: int = USB_BATCH_MAX_BYTES,
        timeout_ns: int = 50 * NS_PER_MS,
        lost_after_ns: int = 500 * NS_PER_MS,
        lost_after_timeouts: int = 8,
        placeholder_ns: int = PLACEHOLDER_NS,
    ) -> None:
        """`max_batch`: requests per bulk-OUT transfer. `window`: requests in flight (1..15),
        timed-out requests the bridge may still answer included. `batch_bytes`: largest transfer
        in either direction. `timeout_ns`: a request without response this long after its batch
        was written completes UPLINK_TIMEOUT. `placeholder_ns`: how long after its sending a
        timed-out request keeps its sequence number and window slot (unless a response releases
        them first); the default and the rules are Rs232Core's (`rs232_core.PLACEHOLDER_NS`).
        `lost_after_ns`: no IN transfer for this long with requests in flight declares the bridge
        lost; so do `lost_after_timeouts` requests timing out in a row with no IN transfer for
        `lost_after_ns` either (sparse traffic, where the in-flight list keeps emptying; the
        same rule as Rs232Core's)."""
        super().__init__(window=window, timeout_ns=timeout_ns, lost_after_ns=lost_after_ns,
                         lost_after_timeouts=lost_after_timeouts, placeholder_ns=placeholder_ns)
        self.max_batch = check_window(max_batch, "max_batch")
        self.batch_bytes = batch_bytes
        self.frames_written = 0
        self.transfers_in = 0
        self.bad_headers = 0
        self._frame = 1  # 0 is what an idle bridge labels its buffers with before the first OUT
        self._flushing = False
        """`hand_over`: fetching and discarding IN transfers until an empty one comes..."""
        self._flush_empty_from = 0
        """... received at this instant or later."""
        self.trace: list[UsbTraceEvent] | None = None
        """Set to a list to log every Submit, UsbWrite, UsbRead and Callback (UsbTraceEvent)."""

    # -- inputs ------------------------------------------------------------------------------
    def submit(self, t: Transfer, now: int) -> None:
        """Buffer a request for the next bulk-OUT transfer (`Submit`)."""
        super().submit(t, now)
        if self.trace is not None and self.lost_reason is None:
            self.trace.append(("submit", now, (t,)))

    def hand_over(self, until_ns: int) -> None:
        """As `MatchingCore.hand_over`, and until an IN transfer received two frames after
        `until_ns` or later (its buffer was filled after it) carries no response."""
        super().hand_over(until_ns)
        self._flushing = True
        self._flush_empty_from = max(self._flush_empty_from, until_ns + 2 * FRAME_NS)

    def _handing_over(self, now: int) -> bool:
        return self._handover_wait(now) or self._flushing

    # lobster-trace: urb.HOST_004
    def receive_batch(self, data: bytes, now: int) -> None:
        """One bulk-IN transfer: a header, then responses back to back (`UsbRead`)."""
        self._heard(now)
        if self.lost_reason is not None or not data:
            return
        self.transfers_in += 1
        try:
            header = UsbBatchHeader.decode(data[:HEADER_SIZE])
        except DecodeError:
            header = None
            self.bad_headers += 1  # the responses carry their own checks: match them anyway
        if self._flushing:  # the previous process's responses: none of ours is in flight
            self._m.stray_bytes += max(0, len(data) - HEADER_SIZE)
            if header is not None and header.count == 0 and now >= self._flush_empty_from:
                self._flushing = False
            return
        m = self._m
        done_before = len(m.completed)
        m.rx += data[HEADER_SIZE:]
        m.parse(now)
        self._matched()
        if m.rx:  # a response never spans two transfers: the rest is garbage
            m._discard(len(m.rx))
        if self.trace is not None:
            answered = tuple(t for t in m.completed[done_before:] if t.status is not None)
            self.trace.append(("read", now, answered))

    def poll(self, now: int) -> None:
        """Time out requests whose responses never came; detect a silent bridge."""
        if self.lost_reason is None:
            self._lost_if_silent(now, self._time_out(now))

    # -- outputs -----------------------------------------------------------------------------
    # lobster-trace: urb.LAT_001, urb.LAT_002
    def frame_out(self, now: int) -> bytes | None:
        """The bulk-OUT transfer for this frame, or None when there is nothing to send or fetch."""
        m = self._m
        if self.lost_reason is not None:
            return None
        flushing = self._handing_over(now)  # then fetch the previous process's responses, send nothing
        if not (self._queued or m.inflight or flushing):
            return None
        if self._queued:
            m.expire(now)  # whatever the polling cadence
        out_bytes = in_bytes = HEADER_SIZE
        frames: list[bytes] = []
        batch: list[Transfer] = []
        while not flushing and self._queued and len(batch) < self.max_batch and len(m.inflight) < self.window:
            t = self._queued[0]
            req, resp = t.request_size(), t.response_size(Status.OK)
            if out_bytes + req > self.batch_bytes or in_bytes + resp > self.batch_bytes:
                break  # stays buffered for the next frame
            self._queued.popleft()
            out_bytes, in_bytes = out_bytes + req, in_bytes + resp
            frames.append(self._send(t, now))
            batch.append(t)
        header = UsbBatchHeader(frame=self._frame, count=len(batch)).encode()
        self._frame = self._frame % 0xFFFF + 1  # 1..65535, never 0
        self.frames_written += 1
        if self.trace is not None:
            self.trace.append(("write", now, tuple(batch)))
        return header + b"".join(frames)

    def take_completed(self) -> list[Transfer]:
        done = super().take_completed()
        if self.trace is not None and done:
            self.trace.append(("callback", done[-1].completed_ns or 0, tuple(done)))
        return done
