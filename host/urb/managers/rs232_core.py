"""The host side of the URB uplink protocol as a pure state machine (no threads, no I/O).

`Rs232Core` is fed received bytes and timestamps and asked for request frames to send. It
implements, for one bridge:

* the request FIFO matched by order *and* 4-bit sequence number (spec/tla/Bridge.tla: responses
  leave in request order and echo the request's sequence number);
* the host window: at most `window` (< 16) requests outstanding, the rest queued on the host and
  sent as responses free the window (Bridge.tla `SubmitAndAdmit`: ``Len(sent) - Len(out) <
  HostWindow``), so the 4-bit number cannot alias;
* RS232 resynchronisation by hunting (spec/schema/README.md): a candidate response starts with a
  byte whose sequence number is pending and whose status is valid; its length follows from the
  matched request and the status (data only in an OK read); a candidate that fails its check
  loses its first byte and the hunt goes on at the next byte. A response that echoes a *later*
  pending request proves the earlier ones were lost (the bridge is a FIFO): they complete at once
  with UPLINK_CHECKSUM (corrupt bytes were seen in their place) or UPLINK_TIMEOUT (nothing was);
* a per-request timeout (UPLINK_TIMEOUT), and an idle-gap rule: a partial candidate that
  receives no byte for `resync_gap_ns` loses its first byte, so a corrupt header cannot stall
  the hunt;
* bridge-lost detection: the bridge is declared lost only when it really stopped answering,
  that is when not one byte was received for `lost_after_ns` and either requests were
  outstanding all that time (continuous traffic), or a request has just timed out and it was
  the `lost_after_timeouts`-th in a row (sparse traffic, where the in-flight list keeps
  emptying). A burst of requests lost together (a line glitch) times out together, well within
  `lost_after_ns`: those requests complete UPLINK_TIMEOUT and the bridge stays usable. Or
  `link_lost()` called by the runtime (port closed, I/O error). Every pending and queued request
  then completes with BRIDGE_LOST, and so does every later one until `reset()`.

Callers serialise access (the real-time runtime holds a lock; the simulation is single-threaded).
"""

from __future__ import annotations

from collections import deque

from urb_msgs import DecodeError
from urb_msgs.urb_core import Status, UplinkReadRequest, UplinkResponse, UplinkWriteRequest

from ..errors import ErrorFlag
from .base import NS_PER_MS, Transfer, finish

SEQ_MOD = 16
MAX_WINDOW = SEQ_MOD - 1
_STATUS_MAX = max(int(s) for s in Status)


def encode_request(t: Transfer) -> bytes:
    """The uplink request frame for `t` (its `seq` already set)."""
    if t.read:
        return UplinkReadRequest(address=t.address, mailbox=t.mailbox, seq=t.seq, length=t.length).encode()
    return UplinkWriteRequest(address=t.address, mailbox=t.mailbox, seq=t.seq, data=t.data).encode()


class ResponseMatcher:
    """Matches a byte stream of responses to the requests in flight (order + sequence number),
    hunting past corrupt bytes. Shared by the RS232 and the USB cores."""

    def __init__(self) -> None:
        self.inflight: deque[Transfer] = deque()
        self.rx = bytearray()
        self.stray_bytes = 0
        self.completed: list[Transfer] = []

    def lost_before(self, k: int, now: int) -> None:
        """The k oldest in-flight requests got no response: complete them."""
        for _ in range(k):
            t = self.inflight.popleft()
            self.completed.append(finish(t, now, ErrorFlag.UPLINK_CHECKSUM if t.garbage else ErrorFlag.UPLINK_TIMEOUT))

    def fail_all(self, queued: deque[Transfer], now: int, reason: str | None = None) -> None:
        """The uplink is gone: every request in flight, then every queued one, completes BRIDGE_LOST."""
        for t in list(self.inflight) + list(queued):
            self.completed.append(finish(t, now, ErrorFlag.BRIDGE_LOST))
            t.lost_reason = reason
        self.inflight.clear()
        queued.clear()
        self.rx.clear()

    def _discard(self, n: int) -> None:
        del self.rx[:n]
        self.stray_bytes += n
        if self.inflight:
            self.inflight[0].garbage = True

    def parse(self, now: int) -> bool:
        """Match every complete response in `rx`; True when a partial candidate is left waiting."""
        while self.rx:
            if not self.inflight:
                self._discard(len(self.rx))  # nothing is pending: these bytes answer nothing
                return False
            head = self.rx[0]
            seq, status = head & 0x0F, head >> 4
            k = next((i for i, t in enumerate(self.inflight) if t.seq == seq), -1)
            if k < 0 or status > _STATUS_MAX:
                self._discard(1)
                continue
            t = self.inflight[k]
            n = t.response_size(Status(status))
            if len(self.rx) < n:
                return True
            try:
                resp = UplinkResponse.decode(bytes(self.rx[:n]))
            except DecodeError:
                self._discard(1)
                continue
            del self.rx[:n]
            self.lost_before(k, now)
            self.inflight.popleft()
            data = bytes(resp.data) if t.read and resp.status == Status.OK else None
            self.completed.append(finish(t, now, ErrorFlag.from_status(resp.status), resp.status, data))
        return False


class Rs232Core:
    """Host protocol state machine for one bridge on a byte-stream uplink (RS232)."""

    def __init__(
        self,
        *,
        window: int = 4,
        timeout_ns: int = 100 * NS_PER_MS,
        resync_gap_ns: int = 20 * NS_PER_MS,
        lost_after_ns: int = 500 * NS_PER_MS,
        lost_after_timeouts: int = 8,
    ) -> None:
        """`window`: requests outstanding on the bridge (1..15; raised or lowered after
        discovery from BridgeInfo.fifo_depth). `timeout_ns`: a response not received this long
        after its request was sent completes UPLINK_TIMEOUT. `resync_gap_ns`: idle time after
        which a partial response candidate is abandoned. `lost_after_ns`: silence with requests
        outstanding after which the bridge is declared lost; `lost_after_timeouts`: so many
        requests timing out in a row declare it lost too (sparse traffic, where the in-flight
        list keeps emptying), but only once not one byte was received for `lost_after_ns`
        either: a burst lost in a glitch is not a lost bridge."""
        self.window = _check_window(window)
        self.timeout_ns = timeout_ns
        self.resync_gap_ns = resync_gap_ns
        self.lost_after_ns = lost_after_ns
        self.lost_after_timeouts = lost_after_timeouts
        self._silent_timeouts = 0
        self.lost_reason: str | None = None
        self._queued: deque[Transfer] = deque()
        self._m = ResponseMatcher()
        self._next_seq = 1  # the n-th request carries n mod 16, as Bridge.tla's Emit (id % SeqMod)
        self._last_rx_ns = 0
        self._active_since = 0
        """When the in-flight list last went from empty to non-empty."""
        self._partial = False

    # -- inputs ------------------------------------------------------------------------------
    def submit(self, t: Transfer, now: int) -> None:
        """Queue a request (sent by `frames_to_send` when the window allows)."""
        if self.lost_reason is not None:
            self._m.completed.append(finish(t, now, ErrorFlag.BRIDGE_LOST))
            t.lost_reason = self.lost_reason
            return
        self._queued.append(t)

    def receive(self, data: bytes, now: int) -> None:
        """Bytes from the uplink, in arrival order."""
        if not data:
            return
        self._last_rx_ns = now
        self._silent_timeouts = 0
        if self.lost_reason is not None:
            self._m.stray_bytes += len(data)
            return
        self._m.rx += data
        self._partial = self._m.parse(now)

    def poll(self, now: int) -> None:
        """Apply timeouts, the idle-gap rule and bridge-lost detection at time `now`."""
        if self.lost_reason is not None:
            return
        m = self._m
        if self._partial and now - self._last_rx_ns >= self.resync_gap_ns:
            m._discard(1)
            self._partial = m.parse(now)
        timed_out = False
        while m.inflight and m.inflight[0].sent_ns is not None and now - m.inflight[0].sent_ns >= self.timeout_ns:
            m.lost_before(1, now)
            self._silent_timeouts += 1
            timed_out = True
            self._partial = m.parse(now)
        quiet_ns = now - self._last_rx_ns
        if timed_out and self._silent_timeouts >= self.lost_after_timeouts and quiet_ns >= self.lost_after_ns:
            self.link_lost(now, f"{self._silent_timeouts} requests in a row got no response and the bridge "
                                f"sent nothing for {quiet_ns // NS_PER_MS} ms")
            return
        silent_since = max(self._last_rx_ns, self._active_since)
        if m.inflight and now - silent_since >= self.lost_after_ns:
            ms = (now - silent_since) // NS_PER_MS
            self.link_lost(now, f"the bridge sent nothing for {ms} ms with requests outstanding")

    def link_lost(self, now: int, reason: str) -> None:
        """The runtime lost the uplink (or `poll` found the bridge silent): fail everything."""
        if self.lost_reason is not None:
            return
        self.lost_reason = reason
        self._m.fail_all(self._queued, now, reason)
        self._partial = False

    def reset(self, now: int) -> None:
        """Forget the lost state and any partial input (after the uplink was reopened)."""
        self.link_lost(now, "the uplink was reset (reconnect)")
        self.lost_reason = None
        self._last_rx_ns = now
        self._silent_timeouts = 0

    def set_window(self, window: int) -> None:
        self.window = _check_window(window)

    # -- outputs -----------------------------------------------------------------------------
    def frames_to_send(self, now: int) -> list[bytes]:
        """Request frames that may go on the wire now (each to be written with one write())."""
        out: list[bytes] = []
        while self._queued and len(self._m.inflight) < self.window and self.lost_reason is None:
            t = self._queued.popleft()
            t.seq = self._next_seq
            self._next_seq = (self._next_seq + 1) % SEQ_MOD
            t.sent_ns = now
            t.garbage = False
            if not self._m.inflight:
                self._active_since = now
            self._m.inflight.append(t)
            out.append(encode_request(t))
        return out

    def take_completed(self) -> list[Transfer]:
        """Transfers completed since the last call, in completion (= request) order."""
        done, self._m.completed = self._m.completed, []
        return done

    def next_deadline(self) -> int | None:
        """When `poll` next has something to do (None: nothing pending)."""
        if self.lost_reason is not None or not self._m.inflight:
            return None
        times: list[int] = []
        head = self._m.inflight[0]
        if head.sent_ns is not None:
            times.append(head.sent_ns + self.timeout_ns)
        if self._partial:
            times.append(self._last_rx_ns + self.resync_gap_ns)
        times.append(max(self._last_rx_ns, self._active_since) + self.lost_after_ns)
        return min(times)

    def busy(self) -> bool:
        """Requests queued or in flight."""
        return bool(self._queued or self._m.inflight)

    @property
    def has_queued(self) -> bool:
        return bool(self._queued) and len(self._m.inflight) < self.window and self.lost_reason is None

    @property
    def in_flight(self) -> int:
        return len(self._m.inflight)

    @property
    def stray_bytes(self) -> int:
        return self._m.stray_bytes


def _check_window(window: int) -> int:
    if not 1 <= window <= MAX_WINDOW:
        raise ValueError(f"window = {window}: must be 1..{MAX_WINDOW} so the 4-bit sequence number cannot alias")
    return window
