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
* a per-request timeout (UPLINK_TIMEOUT) that does not free the request's sequence number: the
  bridge may still hold the request and answer it late (a node stretching the clock, a slow
  downlink), so a timed-out request stays in the in-flight list as a *placeholder* (see
  `ResponseMatcher`), counted in the window, until its own late response arrives (discarded and
  counted in `late_responses`), a response to a later request proves its response lost, or its
  lifetime `placeholder_ns` (counted from when it was sent; `PLACEHOLDER_NS`) expires.
  Freeing the number at the timeout let a late response be matched to a newer request with the
  same 4-bit number (spec/tla/Bridge.tla `NoSeqAliasing`, mutant `Bridge_TimeoutFreesSeq`);
* a draining close (`start_drain`): nothing new is sent, and the requests in flight are matched
  until none is left or the newest one's lifetime is over, so that their late responses cannot
  reach the next process to open the bridge (it numbers its requests from 1 again);
* a hand-over (`hand_over`): a new user of the port sends nothing before the instant the late
  responses to the previous process's requests are over (`handover.PortHandover`; Bridge.tla
  `HostRestart`); what arrives before answers none of its requests and is discarded;
* an idle-gap rule: a partial candidate that
  receives no byte for `resync_gap_ns` loses its first byte, so a corrupt header cannot stall
  the hunt;
* bridge-lost detection: the bridge is declared lost only when it really stopped answering,
  that is when not one byte was received for `lost_after_ns` and either requests were
  outstanding all that time (continuous traffic; placeholders count, and so do requests queued
  behind a window full of them), or a request has just timed out and it was
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
from .base import CLOSED_REASON, NS_PER_MS, Transfer, finish

SEQ_MOD = 16
MAX_WINDOW = SEQ_MOD - 1

# How long the bridge firmware can still hold a request after the host sent it, at the slowest
# downlink rate the project supports (I2C standard mode, 100 kb/s). Per request, worst case
# (firmware/bridge/bridge.c, i2c_master.c): an identification read of a node whose sizes the
# bridge does not know, then the request's own transaction, each ended by the downlink timeout
# (urb_i2c_master_timeout_us(100) = 6720 us: twice the 336 bit times of the longest transaction,
# so clock stretching included) and a bus clear (21 steps of clear_half_us = 5 us), then the
# response on the uplink (35 bytes, the longest, at 115200 Bd 8N1: 3038 us; a USB response
# leaves within a frame).
DOWNLINK_TIMEOUT_100KBPS_US = 6720
BUS_CLEAR_US = 21 * 5
LONGEST_RESPONSE_RS232_US = (35 * 10 * 1_000_000 + 115_199) // 115_200
REQUEST_WORST_US = 2 * (DOWNLINK_TIMEOUT_100KBPS_US + BUS_CLEAR_US) + LONGEST_RESPONSE_RS232_US  # 16688 us
LONGEST_REQUEST_RS232_US = (37 * 10 * 1_000_000 + 115_199) // 115_200  # the request's own bytes: 3212 us
# The bridge serves its ring in arrival order. Since a timed-out request keeps its place in the
# window (a placeholder), the bridge never holds more than the window (<= MAX_WINDOW = 15) of the
# host's requests: the request a placeholder stands for waits behind at most 14 others, so it is
# answered within LONGEST_REQUEST_RS232_US + 15 * REQUEST_WORST_US = 253.5 ms of being sent. (The
# ring's URB_BRIDGE_RING_MAX = 32 slots are only reachable by a host that sends beyond its window,
# which placeholders prevent: 32 * REQUEST_WORST_US = 534 ms would exceed the default
# `lost_after` of 500 ms, and then one lost request followed by silence would look like a dead
# bridge.) Rounded up to 300 ms, which leaves ~46 ms for heartbeat SYNCs interleaved with the
# requests. A bridge SCAN command (one per discovery) can take longer: every present address is
# identified, 127 * (6720 + 105) us at 100 kb/s in the worst case.
PLACEHOLDER_WORST_US = LONGEST_REQUEST_RS232_US + MAX_WINDOW * REQUEST_WORST_US
PLACEHOLDER_NS = 300 * NS_PER_MS
assert PLACEHOLDER_WORST_US * 1000 <= PLACEHOLDER_NS
# A SCAN command is answered when the scan is over (firmware/bridge/bridge.c `scan_done`): every
# address 1..127 probed by reading its identification, at worst each read ending with the downlink
# timeout and a bus clear (a node holding SCL low), 127 * (6720 + 105) us = 866.8 ms at 100 kb/s.
# The heartbeat's SYNC broadcasts go between the probes: at most one per heartbeat tick (1 ms),
# each (address, command, check: 4 bytes of 9 bits and the start and stop) 380 us at 100 kb/s,
# so at most 38 % more. After the requests ahead of it (PLACEHOLDER_NS covers a full window).
SCAN_WORST_US = 127 * (DOWNLINK_TIMEOUT_100KBPS_US + BUS_CLEAR_US)
SYNC_SHARE = 0.38
SCAN_ANSWER_NS = 1500 * NS_PER_MS
assert PLACEHOLDER_NS + SCAN_WORST_US * (1 + SYNC_SHARE) * 1000 <= SCAN_ANSWER_NS
_STATUS_MAX = max(int(s) for s in Status)


def encode_request(t: Transfer) -> bytes:
    """The uplink request frame for `t` (its `seq` already set)."""
    if t.read:
        return UplinkReadRequest(address=t.address, mailbox=t.mailbox, seq=t.seq, length=t.length).encode()
    return UplinkWriteRequest(address=t.address, mailbox=t.mailbox, seq=t.seq, data=t.data).encode()


# lobster-trace: urb.HOST_002, urb.HOST_004
class ResponseMatcher:
    """Matches a byte stream of responses to the requests in flight (order + sequence number),
    hunting past corrupt bytes. Shared by the RS232 and the USB cores.

    `inflight` holds, in sending order, the requests that are live (not complete) and the
    *placeholders*: requests already completed (`done`: timed out, or failed when the bridge was
    lost) that the bridge may still answer. A placeholder keeps its sequence number reserved and
    its place in the window; a response echoing its number is its late response and is
    discarded (`late_responses`); a response to a later request releases it (the bridge answers
    in order: its response was lost); `expire` releases it once its lifetime is over."""

    def __init__(self) -> None:
        self.inflight: deque[Transfer] = deque()
        self.rx = bytearray()
        self.stray_bytes = 0
        self.late_responses = 0
        """Responses to requests that had already timed out (placeholders), discarded."""
        self.released_placeholders = 0
        """Placeholders released without their late response: passed by a later response, or
        expired."""
        self.completed: list[Transfer] = []

    def lost_before(self, k: int, now: int) -> None:
        """The k oldest in-flight requests got no response: complete the live ones, release the
        placeholders."""
        for _ in range(k):
            t = self.inflight.popleft()
            if t.done:
                self.released_placeholders += 1
            else:
                self._unanswered(t, now)

    def time_out(self, now: int) -> int:
        """Complete UPLINK_TIMEOUT every live request due by `now` (`due_ns`); it stays in flight
        as a placeholder unless its lifetime (`expires_ns`) is over too. Returns how many timed
        out."""
        n = 0
        for t in self.inflight:
            if not t.done and t.due_ns is not None and now >= t.due_ns:
                self._unanswered(t, now)
                n += 1
        self.expire(now)
        return n

    # lobster-trace: urb.FLT_005
    def expire(self, now: int) -> None:
        """Release the placeholders whose lifetime is over by `now` (`expires_ns`): the bridge no
        longer holds their requests."""
        for t in self.inflight:  # a plain loop: this runs several times per request
            if t.done and now >= (t.expires_ns or 0):
                break
        else:
            return
        keep = deque(t for t in self.inflight if not (t.done and now >= (t.expires_ns or 0)))
        self.released_placeholders += len(self.inflight) - len(keep)
        self.inflight = keep

    def _unanswered(self, t: Transfer, now: int) -> None:
        """A live request got no response: UPLINK_CHECKSUM when corrupt bytes stood in its place,
        else UPLINK_TIMEOUT."""
        self.completed.append(finish(t, now, ErrorFlag.UPLINK_CHECKSUM if t.garbage else ErrorFlag.UPLINK_TIMEOUT))

    def next_event(self) -> int | None:
        """When the first live request times out or the first placeholder expires."""
        times = [(t.expires_ns if t.done else t.due_ns) or 0 for t in self.inflight]
        return min(times) if times else None

    def long_until(self) -> int:
        """Until when a request in flight with a long answer time (`answer_within_ns`) may hold
        the bridge: its lifetime (0: none)."""
        until = 0
        for t in self.inflight:
            if t.answer_within_ns and (t.expires_ns or 0) > until:
                until = t.expires_ns or 0
        return until

    # lobster-trace: urb.FLT_004, urb.HOST_001
    def fail_all(self, queued: deque[Transfer], now: int, reason: str | None = None) -> None:
        """The uplink is gone: every live request in flight, then every queued one, completes
        BRIDGE_LOST. The requests in flight stay as placeholders: a bridge reached again through a
        reopened uplink was not reset and may still answer them (their numbers stay reserved
        until then, or until their lifetime is over)."""
        for t in [t for t in self.inflight if not t.done] + list(queued):
            self.lose(t, now, reason)
        queued.clear()
        self.rx.clear()

    def lose(self, t: Transfer, now: int, reason: str | None) -> None:
        """Complete `t` BRIDGE_LOST, saying why."""
        self.completed.append(finish(t, now, ErrorFlag.BRIDGE_LOST))
        t.lost_reason = reason

    def _discard(self, n: int) -> None:
        del self.rx[:n]
        self.stray_bytes += n
        live = next((t for t in self.inflight if not t.done), None)
        if live is not None:
            live.garbage = True

    def parse(self, now: int) -> bool:
        """Match every complete response in `rx`; True when a partial candidate is left waiting."""
        while self.rx:
            if not self.inflight:
                self._discard(len(self.rx))  # nothing is pending: these bytes answer nothing
                return False
            head = self.rx[0]
            seq, status = head & 0x0F, head >> 4
            k = -1
            for i, t in enumerate(self.inflight):
                if t.seq == seq:
                    k = i
                    break
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
            if t.done:  # the late response to a request that timed out: its number is free now
                self.late_responses += 1
                continue
            data = bytes(resp.data) if t.read and resp.status == Status.OK else None
            self.completed.append(finish(t, now, ErrorFlag.from_status(resp.status), resp.status, data))
        return False


class MatchingCore:
    """What the RS232 and USB cores share around their `ResponseMatcher`: the queue, the window,
    the sequence numbers, the placeholders, and how a silent bridge is declared lost."""

    #: How the core says the bridge was silent, in a lost reason ("... for N ms").
    SILENCE = "the bridge sent nothing"

    def __init__(self, *, window: int, timeout_ns: int, lost_after_ns: int, lost_after_timeouts: int,
                 placeholder_ns: int) -> None:
        self.window = check_window(window)
        self.timeout_ns = timeout_ns
        self.lost_after_ns = lost_after_ns
        self.lost_after_timeouts = lost_after_timeouts
        self.placeholder_ns = placeholder_ns
        self.lost_reason: str | None = None
        self._queued: deque[Transfer] = deque()
        self._closing = False
        """`start_drain` was called: nothing more is sent until `reset`."""
        self._m = ResponseMatcher()
        self._next_seq = 1  # the n-th request carries n mod 16, as Bridge.tla's Emit (id % SeqMod)
        self._silent_timeouts = 0
        self._last_heard_ns = 0
        """When the bridge last sent something (a byte on RS232, an IN transfer on USB)."""
        self._active_since = 0
        """When the host last went from nothing outstanding (no request in flight, placeholders
        included, none queued) to something: requests queued behind a window full of
        placeholders keep the host outstanding, so their expiry is no gap in the silence."""
        self._handover_until: int | None = None
        """`hand_over`: nothing is sent before this instant."""
        self._quiet_until = 0
        """Until when the bridge may be silent because a request with a long answer time holds
        it (`Transfer.answer_within_ns`), unless it answered that request before."""

    @property
    def _lifetime_ns(self) -> int:
        return max(self.placeholder_ns, self.timeout_ns)

    def busy_until(self) -> int | None:
        """When the last response the bridge may still send to this core's requests is due at
        the latest (the latest lifetime in flight), or None when nothing is in flight."""
        return max((t.expires_ns or 0 for t in self._m.inflight), default=None)

    def hand_over(self, until_ns: int) -> None:
        """This core is a new user of the port: send nothing before `until_ns`, when the late
        responses to the previous process's requests are over (`handover.PortHandover`;
        Bridge.tla `HostRestart`). Until then nothing is in flight, so whatever arrives is
        discarded, and requests submitted wait in the queue (their timeouts run from their
        sending); the silence rule does not count the wait."""
        self._handover_until = max(until_ns, self._handover_until or until_ns)

    def _handover_wait(self, now: int) -> bool:
        """Before the hand-over's instant at `now`; once it has come, the silence rule counts
        from it."""
        if self._handover_until is not None and now >= self._handover_until:
            self._active_since = max(self._active_since, self._handover_until)
            self._handover_until = None
        return self._handover_until is not None

    def _handing_over(self, now: int) -> bool:
        """Nothing may be sent at `now` (the hand-over goes on)."""
        return self._handover_wait(now)

    # -- inputs ------------------------------------------------------------------------------
    # lobster-trace: urb.HOST_001, urb.HOST_003
    def submit(self, t: Transfer, now: int) -> None:
        """Queue a request (it goes out when the window allows); a lost bridge, or a closing
        one, fails it at once."""
        if self.lost_reason is not None or self._closing:
            self._m.lose(t, now, self.lost_reason or CLOSED_REASON)
            return
        self._m.expire(now)
        if not self._queued and not self._m.inflight:
            self._active_since = now
        self._queued.append(t)

    def link_lost(self, now: int, reason: str) -> None:
        """The runtime lost the uplink (or `poll` found the bridge silent): everything in flight
        and queued completes BRIDGE_LOST."""
        if self.lost_reason is not None:
            return
        self.lost_reason = reason
        self._m.fail_all(self._queued, now, reason)

    # lobster-trace: urb.FLT_005
    def reset(self, now: int) -> None:
        """Forget the lost state (after the uplink was reopened). The placeholders stay:
        reopening the uplink does not reset the bridge, which may still answer them; they are
        released as usual (a response, or their lifetime)."""
        self.link_lost(now, "the uplink was reset (reconnect)")
        self.lost_reason = None
        self._closing = False
        self._last_heard_ns = now
        self._active_since = now
        self._silent_timeouts = 0
        self._m.expire(now)

    def start_drain(self, now: int) -> int | None:
        """The start of a draining close: queued requests (never sent) complete BRIDGE_LOST, and
        so does every later submission, while the requests in flight, placeholders included, go
        on being matched and timed out as usual. Returns when the drain ends at the latest: the
        newest request in flight's lifetime (from its sending; by then `poll` has released them
        all), or None when nothing is in flight or the bridge is lost (nothing to wait for).
        Draining keeps their late responses from reaching the next user of the bridge (a new
        process numbers its requests from 1 again)."""
        self._closing = True
        for t in self._queued:
            self._m.lose(t, now, CLOSED_REASON)
        self._queued.clear()
        if self.drained():
            return None
        return self.busy_until()

    def drained(self) -> bool:
        """Nothing left to wait for after `start_drain`: nothing in flight, or the bridge lost."""
        return self.lost_reason is not None or not self._m.inflight

    def set_window(self, window: int) -> None:
        """Requests in flight, placeholders included (learnt from BridgeInfo.fifo_depth)."""
        self.window = check_window(window)

    def _heard(self, now: int) -> None:
        """The bridge sent something: it is alive."""
        self._last_heard_ns = now
        self._silent_timeouts = 0

    def _silent_since(self) -> int:
        """Whence silence counts: the bridge's last sign of life, the start of the host's
        outstanding work, the end of a hand-over, or the end of a long request's answer time (no
        answer is due before it)."""
        return max(self._last_heard_ns, self._active_since, self._handover_until or 0, self._quiet_until)

    def _matched(self) -> None:
        """After received responses were matched: a long request answered no longer excuses
        silence."""
        if self._quiet_until:
            self._quiet_until = min(self._quiet_until, self._m.long_until())

    def _time_out(self, now: int) -> int:
        """Complete the requests whose time is over; how many timed out."""
        n = self._m.time_out(now)
        self._silent_timeouts += n
        return n

    # lobster-trace: urb.FLT_004
    def _lost_if_silent(self, now: int, timed_out: int) -> None:
        """Declare a silent bridge lost: `lost_after_timeouts` requests in a row timed out (the
        last `timed_out` of them now) with nothing heard for `lost_after_ns`, or `lost_after_ns`
        of silence with requests outstanding."""
        quiet_ns = now - self._last_heard_ns
        if timed_out and self._silent_timeouts >= self.lost_after_timeouts and quiet_ns >= self.lost_after_ns:
            self.link_lost(now, f"{self._silent_timeouts} requests in a row got no response and "
                                f"{self.SILENCE} for {quiet_ns // NS_PER_MS} ms")
            return
        silent_since = self._silent_since()
        if (self._m.inflight or self._queued) and now - silent_since >= self.lost_after_ns:
            self.link_lost(now, f"{self.SILENCE} for {(now - silent_since) // NS_PER_MS} ms with requests "
                                f"outstanding")

    # -- outputs -----------------------------------------------------------------------------
    def _send(self, t: Transfer, now: int) -> bytes:
        """Give the next queued request its sequence number and put it in flight; its frame."""
        t.seq = self._next_seq
        self._next_seq = (self._next_seq + 1) % SEQ_MOD
        t.sent_ns = now
        start = max(now, self._m.long_until())  # served after a long request ahead of it
        t.due_ns = start + max(self.timeout_ns, t.answer_within_ns)
        t.expires_ns = start + max(self._lifetime_ns, t.answer_within_ns)
        if t.answer_within_ns:
            self._quiet_until = max(self._quiet_until, start + t.answer_within_ns)
        t.garbage = False
        self._m.inflight.append(t)
        return encode_request(t)

    def take_completed(self) -> list[Transfer]:
        """Transfers completed since the last call, in completion (= request) order."""
        done, self._m.completed = self._m.completed, []
        return done

    def next_deadline(self) -> int | None:
        """When `poll` next has something to do (None: nothing pending)."""
        if self._handover_until is not None and self._queued and self.lost_reason is None:
            return self._handover_until
        if self.lost_reason is not None or not self._m.inflight:
            return None
        times = [self._silent_since() + self.lost_after_ns]
        nxt = self._m.next_event()
        if nxt is not None:
            times.append(nxt)
        return min(times)

    # -- state -------------------------------------------------------------------------------
    def busy(self) -> bool:
        """Requests queued or in flight (placeholders included: their late responses are
        fetched)."""
        return bool(self._queued or self._m.inflight)

    @property
    def has_queued(self) -> bool:
        """Requests buffered that the window lets go out (once a hand-over is over)."""
        return bool(self._queued) and len(self._m.inflight) < self.window and self.lost_reason is None

    @property
    def in_flight(self) -> int:
        """Requests in flight, placeholders included (what the window counts)."""
        return len(self._m.inflight)

    @property
    def placeholders(self) -> int:
        """Timed-out requests whose sequence numbers stay reserved (the bridge may answer them)."""
        return sum(1 for t in self._m.inflight if t.done)

    @property
    def stray_bytes(self) -> int:
        return self._m.stray_bytes

    @property
    def late_responses(self) -> int:
        """Responses that came after their request had timed out (discarded)."""
        return self._m.late_responses

    @property
    def released_placeholders(self) -> int:
        """Placeholders released without their late response (a later response passed them, or
        their lifetime expired)."""
        return self._m.released_placeholders


def check_window(window: int, what: str = "window") -> int:
    """`window` (or another count of requests in flight) if 1..15, else ValueError."""
    if not 1 <= window <= MAX_WINDOW:
        raise ValueError(f"{what} = {window}: must be 1..{MAX_WINDOW} so the 4-bit sequence number cannot alias")
    return window


class Rs232Core(MatchingCore):
    """Host protocol state machine for one bridge on a byte-stream uplink (RS232)."""

    def __init__(
        self,
        *,
        window: int = 4,
        timeout_ns: int = 100 * NS_PER_MS,
        resync_gap_ns: int = 20 * NS_PER_MS,
        lost_after_ns: int = 500 * NS_PER_MS,
        lost_after_timeouts: int = 8,
        placeholder_ns: int = PLACEHOLDER_NS,
    ) -> None:
        """`window`: requests outstanding on the bridge (1..15; raised or lowered after
        discovery from BridgeInfo.fifo_depth), timed-out requests the bridge may still answer
        included. `timeout_ns`: a response not received this long after its request was sent
        completes UPLINK_TIMEOUT. `placeholder_ns`: how long after its sending a timed-out
        request keeps its sequence number and window slot (unless a response releases them
        first): the longest the bridge can still answer it (`PLACEHOLDER_NS`, 300 ms, derived
        from the firmware above); keep it below `lost_after_ns`, else a single lost request
        followed by silence declares the bridge lost. A value <= `timeout_ns` frees the number at
        the timeout, which is safe only for a bridge known to answer within `timeout_ns`.
        `resync_gap_ns`: idle time after which a partial response candidate is abandoned.
        `lost_after_ns`: silence with requests outstanding after which the bridge is declared
        lost; `lost_after_timeouts`: so many requests timing out in a row declare it lost too
        (sparse traffic, where the in-flight list keeps emptying), but only once not one byte was
        received for `lost_after_ns` either: a burst lost in a glitch is not a lost bridge."""
        super().__init__(window=window, timeout_ns=timeout_ns, lost_after_ns=lost_after_ns,
                         lost_after_timeouts=lost_after_timeouts, placeholder_ns=placeholder_ns)
        self.resync_gap_ns = resync_gap_ns
        self._partial = False

    # -- inputs ------------------------------------------------------------------------------
    def receive(self, data: bytes, now: int) -> None:
        """Bytes from the uplink, in arrival order."""
        if not data:
            return
        self._heard(now)
        if self.lost_reason is not None:
            self._m.stray_bytes += len(data)
            return
        self._m.rx += data
        self._partial = self._m.parse(now)
        self._matched()

    def poll(self, now: int) -> None:
        """Apply timeouts, the idle-gap rule and bridge-lost detection at time `now`."""
        if self.lost_reason is not None:
            return
        m = self._m
        if self._partial and now - self._last_heard_ns >= self.resync_gap_ns:
            m._discard(1)
            self._partial = m.parse(now)
        before = len(m.inflight)
        timed_out = self._time_out(now)
        if len(m.inflight) != before and m.rx:
            self._partial = m.parse(now)  # a released number no longer starts a candidate
        self._lost_if_silent(now, timed_out)

    def link_lost(self, now: int, reason: str) -> None:
        super().link_lost(now, reason)
        self._partial = False

    # -- outputs -----------------------------------------------------------------------------
    def frames_to_send(self, now: int) -> list[bytes]:
        """Request frames that may go on the wire now (each to be written with one write())."""
        out: list[bytes] = []
        if self._handing_over(now):
            return out
        if self._queued:
            self._m.expire(now)  # whatever the polling cadence
        while self._queued and len(self._m.inflight) < self.window and self.lost_reason is None:
            out.append(self._send(self._queued.popleft(), now))
        return out

    def next_deadline(self) -> int | None:
        nxt = super().next_deadline()
        if nxt is not None and self._partial:
            return min(nxt, self._last_heard_ns + self.resync_gap_ns)
        return nxt
