"""A process that opens a port after another one ended without a draining close (killed, crashed,
`close(drain=False)` after Ctrl-C) never takes that one's late responses as its own.

The late response of a request to a node stretching the clock echoes sequence number 1, which the
new process gives its own first request. The port's record (host/urb/managers/handover.py) tells
the new process until when such responses may come; it sends nothing before (RS232), and on USB
also fetches and discards the bridge's IN buffers until one is empty (spec/tla/Bridge.tla
`HostRestart`, mutant `Bridge_RestartWithoutHandover`).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from bridge_proc import BridgeProc, fake_bridge  # noqa: F401 (fixture)

from urb.managers import LoopbackFrameTransport, RS232Manager, Rs232Core, SimManager, UsbCore, VirtualClock
from urb.managers import handover as handover_mod, rs232
from urb.managers.base import NS_PER_MS, Transfer
from urb.managers.handover import AHEAD_NS, MAX_WAIT_NS, PortHandover
from urb.managers.loopback import BridgeModel, fake_node
from urb.managers.rs232_core import PLACEHOLDER_NS
from urb_msgs.urb_core import Identification, Status, UplinkResponse, UsbBatchHeader

MS = NS_PER_MS
SLOW, FAST = 8, 9
HOST = Path(__file__).resolve().parents[2] / "host"


def read_ident(address: int) -> Transfer:
    return Transfer(address=address, mailbox=0, read=True, length=Identification.SIZE)


def index_of(t: Transfer) -> int:
    assert t.ok and t.response is not None, t
    return Identification.decode(t.response).index


def ident_response(seq: int, index: int) -> bytes:
    ident = Identification(class_id=1, index=index).encode()
    return UplinkResponse(seq=seq, status=Status.OK, data=ident).encode()


# -- the record ------------------------------------------------------------------------------

def test_no_record_means_no_predecessor(tmp_path: Path) -> None:
    assert PortHandover("/dev/ttyS0", tmp_path).predecessor_until(5 * MS) is None


def test_record_is_written_ahead_and_read_back_by_the_next_process(tmp_path: Path) -> None:
    mine = PortHandover("/dev/ttyS0", tmp_path)
    now = time.monotonic_ns()
    mine.cover(now + 300 * MS, now)
    first = mine.path.stat().st_mtime_ns
    mine.cover(now + 900 * MS, now)  # within what the record already says: not written again
    assert mine.path.stat().st_mtime_ns == first
    until = PortHandover("/dev/ttyS0", tmp_path).predecessor_until(now)
    assert until is not None and abs(until - (now + 300 * MS + AHEAD_NS)) < 50 * MS


def test_a_reader_that_read_its_clock_earlier_still_gets_the_instant_written(tmp_path: Path) -> None:
    """The record's instant does not move earlier by the time since the reader read its clock (a
    new process's start reads the clock, reopens its core, then the record: once 0.9 ms early)."""
    mine = PortHandover("/dev/ttyS0", tmp_path)
    now = time.monotonic_ns()
    mine.settle(now + 300 * MS, now)
    until = PortHandover("/dev/ttyS0", tmp_path).predecessor_until(now - 50 * MS)
    assert until is not None and until >= now + 300 * MS - 1 * MS


def test_settle_writes_the_exact_end_or_removes_the_record(tmp_path: Path) -> None:
    mine = PortHandover("/dev/ttyS0", tmp_path)
    now = time.monotonic_ns()
    mine.cover(now + 300 * MS, now)
    mine.settle(now + 300 * MS, now)  # close(drain=False): no write-ahead margin
    until = PortHandover("/dev/ttyS0", tmp_path).predecessor_until(now)
    assert until is not None and abs(until - (now + 300 * MS)) < 50 * MS
    mine.settle(None, now)  # a drained close: nothing left
    assert not mine.path.exists()
    assert PortHandover("/dev/ttyS0", tmp_path).predecessor_until(now) is None


def test_records_are_per_port(tmp_path: Path) -> None:
    now = time.monotonic_ns()
    PortHandover("/dev/ttyS0", tmp_path).cover(now + 300 * MS, now)
    assert PortHandover("/dev/ttyS1", tmp_path).predecessor_until(now) is None
    assert PortHandover("/dev/ttyS0", tmp_path).predecessor_until(now) is not None


def test_damaged_or_far_records_are_bounded(tmp_path: Path) -> None:
    h = PortHandover("/dev/ttyS0", tmp_path)
    h.path.write_text("not a time\n")
    assert h.predecessor_until(7) == 7 + PLACEHOLDER_NS
    h.path.write_text(f"{time.time_ns() + 3600 * 10**9}\n")  # a wall clock set back an hour since
    assert h.predecessor_until(7) == 7 + MAX_WAIT_NS


def test_an_unwritable_state_dir_warns_once_and_the_uplink_goes_on(tmp_path: Path,
                                                                   capsys: pytest.CaptureFixture[str]) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    h = PortHandover("/dev/ttyS0", blocker / "sub")  # a directory below a file cannot exist
    h.cover(10 * MS, 0)
    h.cover(5 * AHEAD_NS, 0)
    err = capsys.readouterr().err
    assert err.count("cannot write") == 1 and "URB_STATE_DIR" in err


def test_state_dir_follows_the_environment(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("URB_STATE_DIR", str(tmp_path / "a"))
    assert handover_mod.state_dir() == tmp_path / "a"
    monkeypatch.delenv("URB_STATE_DIR")
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path / "run"))
    assert handover_mod.state_dir() == tmp_path / "run" / "urb"


# -- the cores, in exact time ----------------------------------------------------------------

def test_rs232_core_sends_nothing_during_the_hand_over_and_discards_what_comes() -> None:
    core = Rs232Core(lost_after_ns=500 * MS)
    core.reset(0)
    core.hand_over(800 * MS)
    t = read_ident(FAST)
    core.submit(t, 0)
    assert core.frames_to_send(799 * MS) == []
    core.receive(ident_response(1, 0), 300 * MS)  # the previous process's late response
    core.poll(799 * MS)  # queued 799 ms with the bridge silent since 300: not lost, it waits
    assert core.lost_reason is None and not t.done
    assert core.next_deadline() == 800 * MS
    frames = core.frames_to_send(800 * MS)
    assert len(frames) == 1 and t.seq == 1
    core.receive(ident_response(1, 1), 810 * MS)
    assert [index_of(x) for x in core.take_completed()] == [1]
    assert core.stray_bytes == len(ident_response(1, 0))


def test_rs232_core_silence_rule_counts_from_the_end_of_the_hand_over() -> None:
    core = Rs232Core(timeout_ns=2000 * MS, lost_after_ns=500 * MS)
    core.reset(0)
    core.hand_over(800 * MS)
    core.submit(read_ident(FAST), 0)
    core.frames_to_send(800 * MS)
    core.poll(1299 * MS)
    assert core.lost_reason is None
    core.poll(1300 * MS)
    assert core.lost_reason is not None


def batch(count: int, body: bytes = b"") -> bytes:
    return UsbBatchHeader(frame=1, count=count).encode() + body


def test_usb_core_fetches_and_discards_until_an_empty_buffer_after_the_lifetime() -> None:
    core = UsbCore()
    core.reset(0)
    core.hand_over(5 * MS)
    t = read_ident(FAST)
    core.submit(t, 0)
    for ms in range(8):
        out = core.frame_out(ms * MS)
        assert out == UsbBatchHeader(frame=ms + 1, count=0).encode()
        if ms == 2:
            core.receive_batch(batch(1, ident_response(1, 0)), ms * MS)  # held since the kill
        elif ms == 4:
            core.receive_batch(batch(0), ms * MS)  # empty, but before the lifetime's end: go on
        elif ms == 5:
            core.receive_batch(batch(1, ident_response(2, 0)), ms * MS)
        elif ms == 6:
            core.receive_batch(batch(0), ms * MS)  # filled partly before the lifetime's end: go on
        elif ms == 7:
            core.receive_batch(batch(0), ms * MS)  # filled after it: the bridge holds nothing old
    out = core.frame_out(8 * MS)
    header = len(batch(0))
    assert out is not None and UsbBatchHeader.decode(out[:header]).count == 1 and t.seq == 1
    core.receive_batch(batch(1, ident_response(1, 1)), 10 * MS)
    assert [index_of(x) for x in core.take_completed()] == [1]
    assert core.stray_bytes == 2 * len(ident_response(1, 0))


def test_usb_hand_over_in_the_bridge_model() -> None:
    """A first manager is abandoned with its read of the slow node in flight and nobody reads
    the bridge's buffers any more; a second one on the same bridge, handed over, gets its own
    answer (without the hand-over it takes the slow node's)."""
    for handed_over, expected in ((True, 1), (False, 0)):
        clock = VirtualClock()
        nodes = dict(fake_node(spec) for spec in (f"MotorDriver:0@{SLOW}", f"MotorDriver:1@{FAST}"))
        nodes[SLOW].stretch_ns = 30 * MS  # answered within the 50-ms timeout of the next request
        transport = LoopbackFrameTransport(clock, BridgeModel(nodes))
        first = SimManager(clock, transport)
        first.start()
        old = read_ident(SLOW)
        first.submit(old)
        assert first.wait_until(lambda: old.sent_ns is not None, 0.01)
        first.core.link_lost(clock.now_ns(), "killed")  # it reads nothing from now on
        second = SimManager(clock, transport)
        second.start()
        assert old.sent_ns is not None
        if handed_over:
            second.core.hand_over(old.sent_ns + PLACEHOLDER_NS)
        new = read_ident(FAST)
        second.submit(new)
        assert second.wait_until(lambda: new.done, 1.0)
        assert new.seq == old.seq == 1
        assert index_of(new) == expected


# -- real processes: a killed one, then the next, over a pty to the fake bridge ---------------

KILLED_STRETCH_MS = 1200
"""How late the slow node answers the killed process: longer than a loaded machine takes to end the
killed process and start the next (300 ms was not, at load 4 on 2 cores: the answer came before the
next process opened the port, and the open discarded it), so the answer always comes while the
next process waits (or, without the record, while its request queues behind the slow one)."""

KILLED_CLIENT = f"""
import os, signal, sys, time
from urb.managers import RS232Manager
from urb.managers.base import Transfer
m = RS232Manager(sys.argv[1], timeout_s=0.1, placeholder_s={KILLED_STRETCH_MS / 1000 + 0.8}, lost_after_s=4.0)
m.start()
t = Transfer(address=int(sys.argv[2]), mailbox=0, read=True, length=int(sys.argv[3]))
m.submit(t)
deadline = time.monotonic() + 2
while t.sent_ns is None and time.monotonic() < deadline:
    time.sleep(0.001)
time.sleep(0.05)  # the writer thread writes the frame (the node answers KILLED_STRETCH_MS later)
print(t.seq, t.sent_ns, flush=True)
os.kill(os.getpid(), signal.SIGKILL)
"""


def killed_after_sending(link: Path) -> tuple[int, int]:
    """Run a process that sends a read of SLOW and is killed at once; its request's number and
    sending time (CLOCK_MONOTONIC, the same in every process)."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(HOST), os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.run([sys.executable, "-c", KILLED_CLIENT, str(link), str(SLOW), str(Identification.SIZE)],
                          capture_output=True, text=True, timeout=30, env=env)
    assert proc.returncode == -signal.SIGKILL, proc.stderr
    seq, sent_ns = proc.stdout.split()
    return int(seq), int(sent_ns)


def next_process_reads_fast(link: Path) -> tuple[Transfer, RS232Manager]:
    m = RS232Manager(str(link), timeout_s=3.0, placeholder_s=0.6, lost_after_s=4.0)  # above KILLED_STRETCH_MS
    m.start()
    try:
        t = read_ident(FAST)
        m.submit(t)
        assert m.wait_until(lambda: t.done, 5.0)
    finally:
        m.close()
    return t, m


# lobster-trace: urb.HOST_006
@pytest.mark.parametrize("handed_over", [True, False], ids=["handover", "mutant-no-handover"])
def test_killed_process_late_response_does_not_reach_the_next_one(
        fake_bridge: Callable[..., BridgeProc], monkeypatch: pytest.MonkeyPatch, handed_over: bool) -> None:
    """The `urb` CLI's case with `kill -9`. The mutant (the record ignored) shows the test
    failing the way the code did: the new process gets the slow node's identification."""
    bp = fake_bridge([f"MotorDriver:0@{SLOW}", f"MotorDriver:1@{FAST}"])
    bp.cmd(f"stretch {SLOW} {KILLED_STRETCH_MS}")
    if not handed_over:
        monkeypatch.setattr(PortHandover, "predecessor_until", lambda self, now_ns: None)
    old_seq, old_sent_ns = killed_after_sending(bp.link)
    new, m = next_process_reads_fast(bp.link)
    assert new.seq == old_seq == 1
    if handed_over:
        assert index_of(new) == 1
        assert m.stats.stray_bytes >= len(ident_response(1, 0))  # the late response, discarded
        assert new.sent_ns is not None and new.sent_ns - old_sent_ns >= KILLED_STRETCH_MS * MS  # waited for it
    else:
        assert index_of(new) == 0


def test_ctrl_c_close_without_drain_leaves_the_exact_lifetime(fake_bridge: Callable[..., BridgeProc]) -> None:
    """`close(drain=False)` (the CLI after Ctrl-C) records when its requests' lifetime ends,
    without the write-ahead margin: the next process waits exactly that long."""
    bp = fake_bridge([f"MotorDriver:0@{SLOW}", f"MotorDriver:1@{FAST}"])
    bp.cmd(f"stretch {SLOW} 300")
    m = RS232Manager(str(bp.link), timeout_s=0.1, placeholder_s=0.6, lost_after_s=1.5)
    m.start()
    t = read_ident(SLOW)
    m.submit(t)
    assert m.wait_until(lambda: t.sent_ns is not None, 2.0) and t.sent_ns is not None
    m.close(drain=False)
    until = PortHandover(str(bp.link)).predecessor_until(time.monotonic_ns())
    assert until is not None and abs(until - (t.sent_ns + 600 * MS)) < 20 * MS
    new, _ = next_process_reads_fast(bp.link)
    assert index_of(new) == 1 and new.sent_ns is not None and new.sent_ns >= until
    assert not PortHandover(str(bp.link)).path.exists()  # the second one drained: nothing left


def test_a_usb_device_path_has_one_user_at_a_time(tmp_path: Path) -> None:
    """The record assumes one process per port: a second open of the same device is refused with
    what to do, and works once the first one closed it."""
    from urb.errors import PortError
    from urb.managers import CharDeviceTransport

    device = tmp_path / "urb-usb0"
    device.write_bytes(b"")
    first, second = CharDeviceTransport(str(device)), CharDeviceTransport(str(device))
    first.open()
    try:
        with pytest.raises(PortError, match="in use by another program"):
            second.open()
    finally:
        first.close()
    second.open()
    second.close()


def test_the_record_covers_a_request_before_it_goes_out(fake_bridge: Callable[..., BridgeProc],
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """A process killed between writing a frame and noting it would leave no record: the record is
    written first. On the Python writer thread, whose writes this test sees (the C core's pump
    writes from C: tests/host_c/test_rs232_pump.py covers its record)."""
    monkeypatch.setattr(rs232, "USE_PUMP", False)
    bp = fake_bridge([f"MotorDriver:1@{FAST}"])
    m = RS232Manager(str(bp.link), timeout_s=0.5)
    m.start()
    ser = m._serial
    assert ser is not None
    written = ser.write
    records: list[int | None] = []

    def write(data: bytes) -> int | None:
        records.append(PortHandover(str(bp.link)).predecessor_until(time.monotonic_ns()))
        return written(data)

    ser.write = write  # type: ignore[method-assign]
    t = read_ident(FAST)
    m.submit(t)
    assert m.wait_until(lambda: t.done, 2.0) and index_of(t) == 1
    m.close()
    assert t.expires_ns is not None and len(records) == 1
    assert records[0] is not None and records[0] >= t.expires_ns - 20 * MS


def test_usb_manager_flushes_before_its_first_request(tmp_path: Path) -> None:
    """The threaded USB runtime with a record left by a killed process: its first frames are empty
    OUT transfers whose IN answers are discarded, then its request goes out and is answered."""
    from urb.managers import LoopbackUsbTransport, USBManager

    nodes = dict(fake_node(spec) for spec in (f"MotorDriver:1@{FAST}",))
    transport = LoopbackUsbTransport(BridgeModel(nodes))
    outs: list[bytes] = []
    write = transport.write_batch

    def counted(data: bytes) -> None:
        outs.append(data)
        write(data)

    transport.write_batch = counted  # type: ignore[method-assign]
    m = USBManager(transport, timeout_s=1.0)
    m._handover = PortHandover("/dev/urb-usb-test", tmp_path)
    now = time.monotonic_ns()
    m._handover.settle(now + 20 * MS, now)  # a Ctrl-C'd process's requests live 20 ms more
    m.start()
    try:
        t = read_ident(FAST)
        m.submit(t)
        assert m.wait_until(lambda: t.done, 2.0) and index_of(t) == 1
    finally:
        m.close()
    header = len(batch(0))
    assert t.sent_ns is not None and t.sent_ns >= now + 20 * MS
    counts = [UsbBatchHeader.decode(o[:header]).count for o in outs]
    # About 20 frames of fetching come first on a quiet machine; at load 20 the frame thread
    # oversleeps and sends fewer (3 of 3 runs failed a bound of 10, 2026-11-29). That the request
    # waits for the record is the assertion on sent_ns above; this one is that fetching happens.
    assert counts.index(1) >= 1 and sum(counts) == 1
