"""Unit tests of the sans-IO protocol cores: bytes and timestamps in, bytes and completions out."""

from __future__ import annotations

import pytest

from urb.errors import ErrorFlag
from urb.managers.base import NS_PER_MS, Transfer
from urb.managers.rs232_core import Rs232Core
from urb.managers.usb_core import UsbCore
from urb_msgs.urb_core import Status, UplinkReadRequest, UplinkResponse, UsbBatchHeader


def read(addr: int = 8, box: int = 1, n: int = 6) -> Transfer:
    return Transfer(addr, box, True, n)


def ok(t: Transfer, data: bytes | None = None) -> bytes:
    return UplinkResponse(seq=t.seq, status=Status.OK, data=data if data is not None else bytes(t.length)).encode()


# lobster-trace: urb.HOST_003
def test_window_bounds_requests_in_flight_and_sequence_numbers_count_from_one() -> None:
    core = Rs232Core(window=3)
    ts = [read() for _ in range(5)]
    for t in ts:
        core.submit(t, 0)
    frames = core.frames_to_send(0)
    assert len(frames) == 3 and [t.seq for t in ts[:3]] == [1, 2, 3]
    assert UplinkReadRequest.decode(frames[0]) == UplinkReadRequest(address=8, mailbox=1, seq=1, length=6)
    assert core.frames_to_send(0) == []
    core.receive(ok(ts[0]), 10)
    assert [t.seq for t in core.take_completed()] == [1]
    assert len(core.frames_to_send(10)) == 1 and ts[3].seq == 4
    with pytest.raises(ValueError, match="alias"):
        Rs232Core(window=16)


def test_response_split_anywhere_and_two_in_one_chunk() -> None:
    core = Rs232Core()
    a, b = read(), read(n=25)
    core.submit(a, 0)
    core.submit(b, 0)
    core.frames_to_send(0)
    stream = ok(a, b"abcdef") + ok(b, bytes(range(25)))
    for i in range(len(stream)):
        core.receive(stream[i:i + 1], i)
    done = core.take_completed()
    assert [t.response for t in done] == [b"abcdef", bytes(range(25))]
    assert len(ok(b, bytes(range(25)))) == 28  # 1 + 25 + CRC-16


# lobster-trace: urb.ERR_001
def test_error_response_has_no_data_and_names_the_status() -> None:
    core = Rs232Core()
    t = read()
    core.submit(t, 0)
    core.frames_to_send(0)
    core.receive(UplinkResponse(seq=t.seq, status=Status.NO_NODE).encode(), 5)
    (done,) = core.take_completed()
    assert done.flags == ErrorFlag.NO_NODE and done.status == Status.NO_NODE and done.response is None


# lobster-trace: urb.CRC_005
def test_hunting_skips_a_corrupt_response_and_a_later_seq_proves_the_earlier_lost() -> None:
    core = Rs232Core()
    a, b, c = read(), read(), read()
    for t in (a, b, c):
        core.submit(t, 0)
    core.frames_to_send(0)
    bad = bytearray(ok(a))
    bad[3] ^= 0x40
    core.receive(bytes(bad) + ok(b, b"BBBBBB"), 1)
    done = core.take_completed()
    assert [(t is a, t.flags) for t in done] == [(True, ErrorFlag.UPLINK_CHECKSUM), (False, ErrorFlag.NONE)]
    assert done[1].response == b"BBBBBB"
    # c's request was lost on the way (no response, no garbage): its timeout
    core.poll(100 * NS_PER_MS)
    (late,) = core.take_completed()
    assert late is c and late.flags == ErrorFlag.UPLINK_TIMEOUT


def test_stray_bytes_with_nothing_pending_are_counted_and_dropped() -> None:
    core = Rs232Core()
    core.receive(b"\x00\xff\x10", 0)
    assert core.stray_bytes == 3
    t = read()
    core.submit(t, 1)
    core.frames_to_send(1)
    core.receive(ok(t), 2)
    assert core.take_completed()[0].ok


def test_a_corrupt_header_claiming_a_long_frame_is_abandoned_after_the_idle_gap() -> None:
    core = Rs232Core(resync_gap_ns=NS_PER_MS)
    long_read, short = read(n=25), read()
    core.submit(long_read, 0)
    core.submit(short, 0)
    core.frames_to_send(0)
    # a single noise byte that looks like an OK response header for the 25-byte read
    core.receive(bytes([long_read.seq]), 10)
    core.poll(10 + NS_PER_MS // 2)
    assert core.take_completed() == []
    core.poll(10 + NS_PER_MS)
    core.receive(ok(long_read) + ok(short), 2 * NS_PER_MS)
    assert [t.flags for t in core.take_completed()] == [ErrorFlag.NONE, ErrorFlag.NONE]


# lobster-trace: urb.FLT_004
def test_silent_bridge_is_declared_lost_and_everything_fails_until_reset() -> None:
    core = Rs232Core(timeout_ns=10 * NS_PER_MS, lost_after_ns=50 * NS_PER_MS, lost_after_timeouts=1000,
                     placeholder_ns=40 * NS_PER_MS)  # below lost_after, as it must be
    now = 0
    while core.lost_reason is None and now < NS_PER_MS * 1000:  # a 1-kHz stream to a dead bridge
        core.submit(read(), now)
        core.frames_to_send(now)
        now += NS_PER_MS
        core.poll(now)
    assert core.lost_reason is not None and "sent nothing" in core.lost_reason
    assert 50 * NS_PER_MS <= now <= 61 * NS_PER_MS
    flags = [t.flags for t in core.take_completed()]
    assert set(flags) == {ErrorFlag.UPLINK_TIMEOUT, ErrorFlag.BRIDGE_LOST} and flags[-1] == ErrorFlag.BRIDGE_LOST
    late = read()
    core.submit(late, now)
    assert core.take_completed() == [late] and late.flags == ErrorFlag.BRIDGE_LOST
    core.reset(now)
    again = read()
    core.submit(again, now)
    # the bridge was not reset: the requests in flight at the loss keep their numbers until
    # their lifetime (placeholder_ns from their sending) is over, and hold the window until then
    assert core.frames_to_send(now) == [] and core.lost_reason is None and core.placeholders == 4
    core.poll(now + 40 * NS_PER_MS)
    assert len(core.frames_to_send(now + 40 * NS_PER_MS)) == 1 and core.placeholders == 0


def test_sparse_requests_to_a_dead_bridge_declare_it_lost_after_n_timeouts() -> None:
    core = Rs232Core(timeout_ns=10 * NS_PER_MS, lost_after_timeouts=3)
    flags = []
    for k in range(5):  # one request a second: the in-flight list empties between them
        now = k * 1000 * NS_PER_MS
        t = read()
        core.submit(t, now)
        core.frames_to_send(now)
        core.poll(now + 10 * NS_PER_MS)
        flags += [x.flags for x in core.take_completed()]
    assert flags == [ErrorFlag.UPLINK_TIMEOUT] * 3 + [ErrorFlag.BRIDGE_LOST] * 2
    assert core.lost_reason is not None and "3 requests in a row" in core.lost_reason


def test_timeouts_in_a_row_count_as_loss_only_after_lost_after_of_silence() -> None:
    """A burst of lost requests times out together one `timeout` after it was sent: that alone
    is not a lost bridge. Timeouts in a row declare it lost only once the bridge has also sent
    nothing for `lost_after` (the same silence the continuous-traffic rule needs)."""
    # window 15: the 9 timed-out requests keep their numbers (placeholders) and fit in it
    core = Rs232Core(timeout_ns=10 * NS_PER_MS, lost_after_ns=50 * NS_PER_MS, lost_after_timeouts=3, window=15)
    answered = read()
    core.submit(answered, 0)
    core.frames_to_send(0)
    core.receive(ok(answered), NS_PER_MS)  # the last byte from the bridge: t = 1 ms
    core.take_completed()
    for burst_at, lost in ((2, False), (30, False), (45, True)):  # 3 lost requests per burst
        now = burst_at * NS_PER_MS
        for _ in range(3):
            core.submit(read(), now)
        core.frames_to_send(now)
        core.poll(now + 10 * NS_PER_MS)
        assert [t.flags for t in core.take_completed()] == [ErrorFlag.UPLINK_TIMEOUT] * 3
        assert (core.lost_reason is not None) == lost, burst_at
    assert core.lost_reason is not None and "9 requests in a row" in core.lost_reason and "54 ms" in core.lost_reason


# lobster-trace: urb.FLT_004
def test_one_lost_request_among_answered_ones_is_not_a_lost_bridge() -> None:
    core = Rs232Core(timeout_ns=10 * NS_PER_MS, lost_after_timeouts=2)
    for k in range(10):
        now = k * 20 * NS_PER_MS
        t = read()
        core.submit(t, now)
        core.frames_to_send(now)
        if k % 2:
            core.receive(ok(t), now + NS_PER_MS)
        core.poll(now + 15 * NS_PER_MS)
    assert core.lost_reason is None


def test_link_lost_fails_pending_and_queued_at_once() -> None:
    core = Rs232Core(window=1)
    a, b = read(), read()
    core.submit(a, 0)
    core.submit(b, 0)
    core.frames_to_send(0)
    core.link_lost(5, "EIO")
    assert [t.flags for t in core.take_completed()] == [ErrorFlag.BRIDGE_LOST] * 2
    assert core.next_deadline() is None


# --- USB core ---------------------------------------------------------------------------------

def usb_in(frame: int, *responses: bytes) -> bytes:
    return UsbBatchHeader(frame=frame, count=len(responses)).encode() + b"".join(responses)


# lobster-trace: urb.PKT_006
def test_usb_batches_respect_count_window_and_512_byte_limits() -> None:
    core = UsbCore(max_batch=14, window=15)
    ts = [read(n=32) for _ in range(20)]  # 35-byte responses: 14 fit in 512 with the header
    for t in ts:
        core.submit(t, 0)
    out = core.frame_out(0)
    assert out is not None and UsbBatchHeader.decode(out[:4]) == UsbBatchHeader(frame=1, count=14) and len(out) <= 512
    out2 = core.frame_out(NS_PER_MS)  # the window (15 in flight) allows one more
    assert out2 is not None and UsbBatchHeader.decode(out2[:4]) == UsbBatchHeader(frame=2, count=1)
    core.receive_batch(usb_in(1, *(ok(t) for t in ts[:14])), 2 * NS_PER_MS)
    assert len(core.take_completed()) == 14
    out3 = core.frame_out(2 * NS_PER_MS)
    assert out3 is not None and UsbBatchHeader.decode(out3[:4]).count == 5


def test_usb_responses_are_a_stream_across_in_transfers() -> None:
    """A batch whose downlink work outlasts its frame: the rest of its responses come in the
    next IN buffer (labelled with a later frame), and an idle frame-0 buffer is just empty."""
    core = UsbCore()
    ts = [read() for _ in range(4)]
    for t in ts:
        core.submit(t, 0)
    assert core.frame_out(0) is not None
    core.receive_batch(usb_in(0), NS_PER_MS // 2)  # an idle buffer from before the first OUT
    core.receive_batch(usb_in(1, ok(ts[0]), ok(ts[1])), NS_PER_MS + 500_000)
    assert [t.ok for t in core.take_completed()] == [True, True]
    assert core.frame_out(2 * NS_PER_MS) is not None  # empty OUT: fetch the rest
    core.receive_batch(usb_in(2, ok(ts[2]), ok(ts[3])), 2 * NS_PER_MS + 500_000)
    assert [t.ok for t in core.take_completed()] == [True, True]
    assert core.stray_bytes == 0 and core.frame_out(3 * NS_PER_MS) is None


def test_usb_missing_response_is_proven_lost_by_the_next_and_corrupt_bytes_are_named() -> None:
    core = UsbCore()
    ts = [read() for _ in range(4)]
    for t in ts:
        core.submit(t, 0)
    core.frame_out(0)
    bad = bytearray(ok(ts[2]))
    bad[2] ^= 0x08
    core.receive_batch(usb_in(1, ok(ts[0]), bytes(bad), ok(ts[3])), NS_PER_MS)  # ts[1] missing
    flags = [t.flags for t in core.take_completed()]
    lost = {ErrorFlag.UPLINK_TIMEOUT, ErrorFlag.UPLINK_CHECKSUM}
    assert flags[0] == flags[3] == ErrorFlag.NONE and {flags[1], flags[2]} <= lost
    assert ErrorFlag.UPLINK_CHECKSUM in flags  # the corrupt bytes are reported (on the oldest pending)


def test_usb_corrupt_in_header_still_delivers_the_checked_responses() -> None:
    core = UsbCore()
    t = read()
    core.submit(t, 0)
    core.frame_out(0)
    data = bytearray(usb_in(1, ok(t)))
    data[1] ^= 0xFF
    core.receive_batch(bytes(data), NS_PER_MS)
    assert core.take_completed() == [t] and t.ok and core.bad_headers == 1


def test_usb_timeout_and_silent_bridge() -> None:
    core = UsbCore(timeout_ns=5 * NS_PER_MS, lost_after_ns=20 * NS_PER_MS)
    t = read()
    core.submit(t, 0)
    core.frame_out(0)
    core.poll(5 * NS_PER_MS)
    assert core.take_completed() == [t] and t.flags == ErrorFlag.UPLINK_TIMEOUT
    now = 6 * NS_PER_MS
    while core.lost_reason is None and now < 100 * NS_PER_MS:
        core.submit(read(), now)
        core.frame_out(now)
        now += NS_PER_MS
        core.poll(now)
    assert core.lost_reason is not None and "no USB transfer" in core.lost_reason


def test_usb_idle_core_sends_nothing_but_keeps_fetching_while_requests_are_in_flight() -> None:
    core = UsbCore()
    assert core.frame_out(0) is None
    t = read()
    core.submit(t, 0)
    assert core.frame_out(0) is not None
    empty = core.frame_out(NS_PER_MS)
    assert empty is not None and UsbBatchHeader.decode(empty).count == 0
    for _ in range(70000):  # the frame counter wraps from 65535 to 1, never 0
        out = core.frame_out(NS_PER_MS)
        assert out is not None and UsbBatchHeader.decode(out[:4]).frame != 0


def test_usb_sparse_requests_to_a_silent_bridge_declare_it_lost() -> None:
    """One request a second to a bridge that returns nothing: the in-flight list empties at every
    timeout, so only timeouts in a row with no IN transfer for `lost_after` can tell."""
    core = UsbCore(timeout_ns=10 * NS_PER_MS, lost_after_ns=50 * NS_PER_MS, lost_after_timeouts=3)
    flags = []
    for k in range(5):
        now = k * 1000 * NS_PER_MS
        core.submit(read(), now)
        core.frame_out(now)
        core.poll(now + 10 * NS_PER_MS)
        flags += [x.flags for x in core.take_completed()]
    assert flags == [ErrorFlag.UPLINK_TIMEOUT] * 3 + [ErrorFlag.BRIDGE_LOST] * 2
    assert core.lost_reason is not None and "3 requests in a row" in core.lost_reason


def test_usb_burst_lost_in_a_glitch_is_not_a_lost_bridge() -> None:
    """Requests lost together time out together, well within `lost_after` of the last IN
    transfer: UPLINK_TIMEOUT, and the bridge stays usable."""
    core = UsbCore(timeout_ns=10 * NS_PER_MS, lost_after_ns=50 * NS_PER_MS, lost_after_timeouts=3)
    answered = read()
    core.submit(answered, 0)
    core.frame_out(0)
    core.receive_batch(usb_in(1, ok(answered)), NS_PER_MS)
    core.take_completed()
    for _ in range(4):
        core.submit(read(), 2 * NS_PER_MS)
    core.frame_out(2 * NS_PER_MS)
    core.poll(12 * NS_PER_MS)
    assert [t.flags for t in core.take_completed()] == [ErrorFlag.UPLINK_TIMEOUT] * 4
    assert core.lost_reason is None
