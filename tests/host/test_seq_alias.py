"""Sequence-number aliasing after host timeouts (spec/tla/README.md, "Sequence-number wrap").

A slow bridge (a node stretching the clock, a full FIFO at a low downlink rate) may answer a
request after the host's timeout. The request completes UPLINK_TIMEOUT at its timeout, but its
4-bit sequence number stays reserved (a *placeholder* in the in-flight list, counted in the
window) until its own late response arrives (discarded, `late_responses`), a response to a later
request releases it (the bridge answers in order), or its lifetime (`placeholder_ns`) expires.
Freeing the number at the timeout (the old code; Bridge.tla's must-fail mutant
`Bridge_TimeoutFreesSeq`) let the late response be matched to a newer request with the same
number. Every test runs on both cores (RS232 and USB).
"""

from __future__ import annotations

import pytest

from urb.errors import ErrorFlag
from urb.managers.base import NS_PER_MS, Transfer
from urb.managers.rs232_core import PLACEHOLDER_NS, PLACEHOLDER_WORST_US, Rs232Core
from urb.managers.usb_core import HEADER_SIZE, UsbCore
from urb_msgs.urb_core import Status, UplinkResponse, UsbBatchHeader

MS = NS_PER_MS


class Harness:
    """One core behind a uniform face: send what may be sent, deliver responses, poll."""

    def __init__(self, kind: str, **kw: int) -> None:
        self.kind = kind
        self.core: Rs232Core | UsbCore
        if kind == "rs232":
            self.core = Rs232Core(**kw)
        else:
            self.core = UsbCore(max_batch=14, **kw)
        self.frame = 1

    def submit(self, ts: list[Transfer], now: int) -> None:
        for t in ts:
            self.core.submit(t, now)
        self.send(now)

    def send(self, now: int) -> None:
        if isinstance(self.core, Rs232Core):
            self.core.frames_to_send(now)
        else:
            while self.core.has_queued:
                self.core.frame_out(now)

    def answer(self, responses: list[bytes], now: int) -> None:
        if isinstance(self.core, Rs232Core):
            self.core.receive(b"".join(responses), now)
        else:
            header = UsbBatchHeader(frame=self.frame, count=len(responses)).encode()
            assert len(header) == HEADER_SIZE
            self.core.receive_batch(header + b"".join(responses), now)
        self.send(now)

    def poll(self, now: int) -> None:
        self.core.poll(now)
        self.send(now)


CORES = ["rs232", "usb"]
TIMEOUT = {"rs232": 100 * MS, "usb": 50 * MS}


def _reads(n: int) -> list[Transfer]:
    return [Transfer(address=8, mailbox=1, read=True, length=2) for _ in range(n)]


def _ok(t: Transfer, data: bytes = b"\x01\x02") -> bytes:
    return UplinkResponse(seq=t.seq, status=Status.OK, data=data).encode()


def _late_answer(old: Transfer) -> bytes:
    return _ok(old, b"\xaa\xbb")


def _all_timed_out(ts: list[Transfer]) -> bool:
    return all(t.done and t.flags == ErrorFlag.UPLINK_TIMEOUT for t in ts)


# lobster-trace: urb.HOST_002
def test_default_lifetime_covers_the_firmware_worst_case() -> None:
    assert PLACEHOLDER_WORST_US * 1000 <= PLACEHOLDER_NS < 500 * MS  # below the default lost_after
    assert Rs232Core().placeholder_ns == UsbCore().placeholder_ns == PLACEHOLDER_NS


# lobster-trace: urb.HOST_002
@pytest.mark.parametrize("kind", CORES)
def test_late_response_to_a_timed_out_request_is_not_given_to_a_newer_one(kind: str) -> None:
    """The reproducer of the finding: 15 requests time out on the host while the bridge still
    holds them; the window stays full (placeholders), so no newer request can take number 1."""
    h = Harness(kind, window=15, timeout_ns=TIMEOUT[kind])
    old = _reads(15)
    h.submit(old, 0)
    h.poll(TIMEOUT[kind] + 2 * MS)
    assert _all_timed_out(old)
    new = _reads(2)
    h.submit(new, TIMEOUT[kind] + 3 * MS)
    assert [t.seq for t in new] == [-1, -1] and h.core.in_flight == 15 == h.core.placeholders
    h.answer([_late_answer(old[0])], TIMEOUT[kind] + 4 * MS)  # the bridge answers the oldest request
    # What the host relies on (Bridge.tla NoSeqAliasing): that response is old[0]'s, discarded.
    assert not new[0].done and not new[1].done and h.core.late_responses == 1
    assert new[0].seq == 0 and new[1].seq == -1  # old[0]'s slot went to new[0], with number 0
    h.answer([_late_answer(old[1])], TIMEOUT[kind] + 5 * MS)
    assert new[1].seq == 1 and not new[1].done  # number 1 again, but old[0]'s answer is long gone
    # the bridge answers the rest in order, then the new requests
    h.answer([_late_answer(t) for t in old[2:]], TIMEOUT[kind] + 6 * MS)
    h.answer([_ok(new[0], b"N0"), _ok(new[1], b"N1")], TIMEOUT[kind] + 7 * MS)
    assert [t.response for t in new] == [b"N0", b"N1"] and all(t.ok for t in new)
    assert h.core.late_responses == 15 and h.core.in_flight == 0
    assert [t.flags for t in old] == [ErrorFlag.UPLINK_TIMEOUT] * 15  # completed once, at the timeout


@pytest.mark.parametrize("kind", CORES)
def test_placeholder_released_by_a_later_response(kind: str) -> None:
    h = Harness(kind, window=4, timeout_ns=TIMEOUT[kind])
    a = _reads(2)
    h.submit(a, 0)
    h.poll(TIMEOUT[kind])
    assert _all_timed_out(a) and h.core.placeholders == 2
    b = _reads(1)
    h.submit(b, TIMEOUT[kind] + MS)
    h.answer([_ok(b[0], b"BB")], TIMEOUT[kind] + 2 * MS)  # a's responses were lost: b's proves it
    assert b[0].ok and b[0].response == b"BB"
    assert h.core.in_flight == 0 and h.core.late_responses == 0 and h.core.released_placeholders == 2


@pytest.mark.parametrize("kind", CORES)
def test_placeholder_released_by_its_lifetime_and_window_counts_placeholders(kind: str) -> None:
    h = Harness(kind, window=2, timeout_ns=TIMEOUT[kind], placeholder_ns=200 * MS)
    a = _reads(2)
    h.submit(a, 0)
    h.poll(TIMEOUT[kind])
    assert _all_timed_out(a)
    b = _reads(1)
    h.submit(b, TIMEOUT[kind] + MS)
    assert b[0].seq == -1 and h.core.in_flight == 2  # the window is full of placeholders
    assert h.core.next_deadline() == 200 * MS  # the first placeholder's lifetime
    h.poll(200 * MS - 1)
    assert b[0].seq == -1
    h.poll(200 * MS)
    assert b[0].seq == 3 and h.core.placeholders == 0 and h.core.released_placeholders == 2
    assert not b[0].done  # a timed-out request is never completed twice
    h.answer([_ok(b[0])], 201 * MS)
    assert b[0].ok


@pytest.mark.parametrize("kind", CORES)
def test_placeholder_lifetime_at_most_the_timeout_frees_the_number_at_the_timeout(kind: str) -> None:
    h = Harness(kind, window=2, timeout_ns=TIMEOUT[kind], placeholder_ns=0)
    a = _reads(2)
    h.submit(a, 0)
    h.poll(TIMEOUT[kind])
    assert _all_timed_out(a) and h.core.in_flight == 0


@pytest.mark.parametrize("kind", CORES)
def test_timed_out_request_is_not_timed_out_again(kind: str) -> None:
    h = Harness(kind, window=4, timeout_ns=TIMEOUT[kind])
    a = _reads(1)
    h.submit(a, 0)
    for k in range(4):
        h.poll(TIMEOUT[kind] + k * 40 * MS)  # within its lifetime (PLACEHOLDER_NS)
    assert _all_timed_out(a) and h.core.placeholders == 1
    assert len(h.core.take_completed()) == 1


@pytest.mark.parametrize("kind", CORES)
def test_close_or_loss_fails_live_requests_and_reconnect_keeps_their_numbers(kind: str) -> None:
    """close()/a lost bridge: live requests complete BRIDGE_LOST and the manager sends nothing;
    the bridge (not reset by reopening the uplink) may still answer them, so after reset() their
    numbers stay reserved until a response or their lifetime releases them."""
    h = Harness(kind, window=3, timeout_ns=TIMEOUT[kind])
    a = _reads(1)
    h.submit(a, 0)
    h.poll(TIMEOUT[kind])
    b = _reads(2)
    h.submit(b, TIMEOUT[kind] + MS)
    h.core.link_lost(TIMEOUT[kind] + 2 * MS, "closed by the application")
    assert [t.flags for t in b] == [ErrorFlag.BRIDGE_LOST] * 2 and a[0].flags == ErrorFlag.UPLINK_TIMEOUT
    assert h.core.next_deadline() is None
    h.answer([_late_answer(a[0])], TIMEOUT[kind] + 3 * MS)  # while lost: stray, nothing matched
    assert h.core.late_responses == 0
    h.core.reset(TIMEOUT[kind] + 4 * MS)
    assert h.core.in_flight == 3 == h.core.placeholders
    c = _reads(1)
    h.submit(c, TIMEOUT[kind] + 5 * MS)
    assert c[0].seq == -1
    h.answer([_late_answer(b[0])], TIMEOUT[kind] + 6 * MS)  # b[0]'s late answer: a was lost
    assert h.core.late_responses == 1 and h.core.released_placeholders == 1
    assert c[0].seq == 4 and not c[0].done
    h.poll(TIMEOUT[kind] + 1 * MS + PLACEHOLDER_NS)  # b[1]'s lifetime is over
    assert h.core.placeholders == 0 or (h.core.placeholders == 1 and c[0].done)
    h.answer([_ok(c[0])], TIMEOUT[kind] + 2 * MS + PLACEHOLDER_NS)
    assert c[0].done


@pytest.mark.parametrize("kind", CORES)
def test_silent_bridge_is_still_declared_lost_after_lost_after(kind: str) -> None:
    """A 1-kHz stream to a dead bridge: the window fills with placeholders, and the bridge is
    declared lost `lost_after` after the first request (nothing received all that time while
    requests the bridge may hold were outstanding), not only once their lifetime is over."""
    h = Harness(kind, window=15, timeout_ns=TIMEOUT[kind], lost_after_ns=200 * MS)
    now = 0
    while h.core.lost_reason is None and now < 1000 * MS:
        h.submit(_reads(1), now)
        now += MS
        h.poll(now)
    assert h.core.lost_reason is not None and 200 * MS <= now <= 202 * MS


@pytest.mark.parametrize("kind", CORES)
def test_one_lost_request_then_silence_is_not_a_lost_bridge(kind: str) -> None:
    """The placeholder of a request lost on the way expires (PLACEHOLDER_NS) before the default
    lost_after (500 ms): silence after it is not taken for a dead bridge."""
    h = Harness(kind, window=4, timeout_ns=TIMEOUT[kind])
    a = _reads(1)
    h.submit(a, 0)
    now = 0
    while now < 2000 * MS:
        deadline = h.core.next_deadline()
        if deadline is None:
            break
        now = deadline
        h.poll(now)
    assert h.core.lost_reason is None and h.core.in_flight == 0 and _all_timed_out(a)
    b = _reads(1)
    h.submit(b, 2000 * MS)
    h.answer([_ok(b[0])], 2001 * MS)
    assert b[0].ok


def test_rs232_corrupt_late_response_does_not_stall_the_hunt() -> None:
    """Bytes of a placeholder's corrupt late response are hunted past; the next live response
    matches and releases the placeholder."""
    h = Harness("rs232", window=4, timeout_ns=100 * MS)
    a = _reads(1)
    h.submit(a, 0)
    h.poll(100 * MS)
    b = _reads(1)
    h.submit(b, 101 * MS)
    bad = bytearray(_late_answer(a[0]))
    bad[-1] ^= 0x55
    h.answer([bytes(bad), _ok(b[0], b"BB")], 102 * MS)
    assert b[0].ok and b[0].response == b"BB" and h.core.in_flight == 0

