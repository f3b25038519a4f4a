"""The CAN and RS485 downlink models (sim/urb_sim/fieldbus): bit stuffing on hand-computed frames,
arbitration, fault confinement, RS485 silences and turnaround, agreement with the firmware's cores.
Each check is a function returning what it found wrong, run on the model (nothing wrong) and on a
seeded bug (something wrong), so that every test is shown able to fail."""

from __future__ import annotations

import random
from collections.abc import Callable, Sequence

import pytest

from urb_sim.fieldbus import can, cores, cycle, measure, rs485

# ----- bit stuffing --------------------------------------------------------------------------------

#: SOF .. DLC of identifier 0x7ff without data, stuffed by hand: SOF 0, five ones, stuff 0, five
#: ones, stuff 0, the eleventh one, then RTR, IDE, r0 and DLC 0000 (seven zeros): a stuff 1 after five
HEAD_7FF = [0, 1, 1, 1, 1, 1, 0, 1, 1, 1, 1, 1, 0, 1, 0, 0, 0, 0, 0, 1, 0, 0]


def stuffing_errors(stuffer: Callable[[Sequence[int]], list[int]]) -> list[str]:
    """What `stuffer` gets wrong on frames stuffed by hand."""
    wrong = []
    # identifier 0, no data: 34 zeros (CRC-15 of zeros is 0); a stuff 1 after every five zeros, six in all
    zeros = can.unstuffed_bits(0, b"")
    if zeros != [0] * 34:
        wrong.append("frame 0x000 is not 34 zeros before stuffing")
    out = stuffer(zeros)
    if [i for i, b in enumerate(out) if b] != [5, 11, 17, 23, 29, 35] or len(out) != 40:
        wrong.append(f"frame 0x000: stuff bits at {[i for i, b in enumerate(out) if b]}, {len(out)} bits")
    head = stuffer(can.unstuffed_bits(0x7FF, b""))[:22]
    if head != HEAD_7FF:
        wrong.append(f"frame 0x7ff: {head}")
    # alternating bits need no stuffing at all
    alt = [i & 1 for i in range(40)]
    if stuffer(alt) != alt:
        wrong.append("alternating bits were stuffed")
    return wrong


def test_stuffing_matches_hand_computed_frames() -> None:
    assert stuffing_errors(can.stuff) == []
    assert can.Frame(0, b"", "b").bits() == 53  # 47 + 6 stuff bits


def test_stuffing_check_rejects_a_six_bit_run() -> None:
    assert stuffing_errors(lambda bits: can.stuff(bits, run=6))


def _destuff(bits: Sequence[int]) -> list[int]:
    """A receiver's view, written apart from the model as an oracle: the inverse of `stuff`: drops every bit after five equal ones; raises ValueError on a stuff error
    (a sixth equal bit)."""
    out: list[int] = []
    last, count, skip = -1, 0, False
    for i, b in enumerate(bits):
        if skip:
            if b == last:
                raise ValueError(f"stuff error at bit {i}: six equal bits")
            last, count, skip = b, 1, False
            continue
        out.append(b)
        if b == last:
            count += 1
        else:
            last, count = b, 1
        skip = count == 5
    return out


def test_destuff_inverts_stuff_and_finds_stuff_errors() -> None:
    rng = random.Random(3)
    for _ in range(200):
        frame = can.unstuffed_bits(rng.randrange(0x800), bytes(rng.randrange(256) for _ in range(rng.randrange(9))))
        assert _destuff(can.stuff(frame)) == frame
    with pytest.raises(ValueError, match="stuff error"):
        _destuff([0] * 6)


def test_crc15_is_can_s() -> None:
    """The CRC catalogue's check value of CRC-15/CAN over ASCII 123456789."""
    assert can.crc15([int(b) for c in b"123456789" for b in format(c, "08b")]) == 0x059E


def test_worst_case_formula_bounds_every_simulated_frame() -> None:
    """55 + 10s bounds the actual stuffed length (47 + 8s is the floor) of random frames, of frames
    of repeated bytes (the most stuffing) and of every frame of the firmware's segmenter; the largest
    count of stuff bits is reached (the witness)."""
    rng = random.Random(1)
    frames = [(rng.randrange(0x800), bytes(rng.randrange(256) for _ in range(rng.randrange(9)))) for _ in range(3000)]
    frames += [(i, bytes([v]) * n) for i in (0, 0x7FF, 0x555) for v in (0, 0xFF, 0x0F, 0x3C) for n in range(9)]
    frames += [(cores.can_id(a, 1, True, cores.RESPONSE), d)
               for a in (1, 63) for n in range(33) for d in cores.can_transfer(bytes(range(n)), 7)]
    most = 0
    for can_id, data in frames:
        bits = can.Frame(can_id, data, "n").bits()
        assert can.bits_min(len(data)) <= bits <= can.bits_max(len(data)) == cores.frame_bits_max(len(data))
        most = max(most, bits - can.bits_min(len(data)))
    assert most >= 8  # frames of repeated bytes reach many stuff bits


def test_frame_within_formula_rejects_a_frame_too_long() -> None:
    f = can.Frame(0x10, bytes(8), "n")
    assert measure.frame_within_formula(can.Delivery(0, f.bits(), f, True, 0))
    assert not measure.frame_within_formula(can.Delivery(0, can.bits_max(8) + 1, f, True, 0))


# ----- arbitration -----------------------------------------------------------------------------------

def arbitration_errors(bus: can.CanBus) -> list[str]:
    """Three senders start together: the lowest identifier goes first, the losers retry in order."""
    for name in ("a", "b", "c"):
        bus.attach(name)
    bus.send(can.Frame(0x123, b"\x01", "a"), 0)
    bus.send(can.Frame(0x122, b"\x02", "b"), 0)
    bus.send(can.Frame(0x300, b"", "c"), 0)
    log = bus.run_until(1000)
    wrong = []
    if [d.frame.can_id for d in log] != [0x122, 0x123, 0x300]:
        wrong.append(f"order {[hex(d.frame.can_id) for d in log]}")
    lost = {n: c.arbitration_lost for n, c in bus.controllers.items()}
    if lost != {"a": 1, "b": 0, "c": 2}:
        wrong.append(f"arbitration lost {lost}")
    if any(later.start != earlier.end for earlier, later in zip(log, log[1:])):
        wrong.append("a loser did not retry as soon as the bus was free")
    return wrong


def test_lower_identifier_wins_and_losers_retry() -> None:
    assert arbitration_errors(can.CanBus(1_000_000, random.Random(0))) == []


def test_arbitration_check_rejects_the_highest_identifier_winning() -> None:
    assert arbitration_errors(can.CanBus(1_000_000, random.Random(0), mutant_high_id_wins=True))


def test_a_frame_queued_during_another_waits_for_the_intermission() -> None:
    bus = can.CanBus(500_000, random.Random(0))
    bus.attach("a")
    bus.attach("b")
    bus.send(can.Frame(0x400, bytes(8), "a"), 0)
    bus.send(can.Frame(0x001, b"", "b"), bus.ns(10))  # a higher priority, but the bus is taken
    first, second = bus.run_until(2000)
    assert first.frame.can_id == 0x400 and second.start == first.end


# ----- fault confinement -----------------------------------------------------------------------------

class _TecByOne(can.Controller):
    """Seeded bug: a transmit error adds 1."""

    def transmit_error(self) -> None:
        self.tec += 1
        self.update_state()


def confinement_errors(make: Callable[[str], can.Controller]) -> list[str]:
    """ISO 11898-1's transitions on one controller."""
    wrong = []
    c = make("n")
    for _ in range(16):
        c.transmit_error()
    if (c.tec, c.state) != (128, can.PASSIVE):
        wrong.append(f"16 transmit errors: TEC {c.tec}, {c.state}")
    for _ in range(16):
        c.transmit_error()
    if c.state != can.BUS_OFF:
        wrong.append(f"32 transmit errors: {c.state}")
    c.recessive(can.RECOVERY_OCCURRENCES * can.RECESSIVE_RUN - 1)
    if c.state != can.BUS_OFF:
        wrong.append("recovered before 128 x 11 recessive bits")
    c.recessive(1)
    if (c.state, c.tec, c.rec) != (can.ACTIVE, 0, 0):
        wrong.append(f"after 128 x 11 recessive bits: {c.state}, TEC {c.tec}, REC {c.rec}")
    r = make("r")
    for _ in range(128):
        r.receive_error()
    if r.state != can.PASSIVE:
        wrong.append(f"REC 128: {r.state}")
    r.receive_ok()
    if (r.rec, r.state) != (119, can.ACTIVE):
        wrong.append(f"a good frame at REC 128: REC {r.rec}, {r.state}")
    return wrong


def test_error_counters_passive_bus_off_and_recovery() -> None:
    assert confinement_errors(can.Controller) == []


def test_confinement_check_rejects_a_transmit_error_counted_as_one() -> None:
    assert confinement_errors(_TecByOne)


def test_error_passive_sender_suspends_and_error_frames_cost_bits() -> None:
    bus = can.CanBus(1_000_000, random.Random(5))
    tx = bus.attach("tx", tx_fault=1.0)
    bus.attach("rx")
    bus.send(can.Frame(0x10, bytes(2), "tx"), 0)
    log = bus.run_until(20_000)
    # bus-off after the 32nd error (its frame dropped), error-active again 128 x 11 idle bits later
    assert all(not d.ok for d in log) and tx.bus_off_count == 1 and tx.recoveries == 1 and tx.state == can.ACTIVE
    # 32 attempts: 16 while error-active, 16 error-passive, each of those followed by 8 bits of suspension
    assert len(log) == 32
    gaps = [b.start - a.end for a, b in zip(log, log[1:])]
    assert gaps[:15] == [0] * 15 and set(gaps[16:]) == {can.SUSPEND_BITS}
    assert bus.controllers["rx"].rec == 32


def test_bus_off_is_reached_and_recovered_and_reported_as_no_node() -> None:
    """The witness: a node with a faulty transceiver goes bus-off and comes back, and the bridge
    reports its reads as I2C's NO_NODE or TIMEOUT while the other nodes' all succeed."""
    d = cycle.CanDownlink(1_000_000, random.Random(2), (1, 2, 3), tx_fault={2: 0.6})
    seen: dict[int, set[str]] = {1: set(), 2: set(), 3: set()}
    for k in range(200):
        for a in (1, 2, 3):
            seen[a].add(d.transact(k * 1000.0, cycle.Txn(a, 1, True, bytes(6))).status)
    node = d.nodes[2]
    assert node.bus_off_count >= 2 and node.recoveries >= 2
    assert d.slaves[2].aborts() >= node.bus_off_count  # the firmware's slave dropped its answer each time
    assert seen[1] == seen[3] == {"OK"} and seen[2] <= {"OK", "NO_NODE", "TIMEOUT"} and "NO_NODE" in seen[2]


def test_same_seed_same_trace() -> None:
    def trace(seed: int) -> list[tuple[int, int, int, bool]]:
        d = cycle.CanDownlink(500_000, random.Random(seed), (1, 2), ber=3e-4, tx_fault={2: 0.2})
        for k in range(100):
            d.transact(k * 2000.0, cycle.Txn(1 + k % 2, 0, False, bytes([k & 0xFF, 7])))
        return [(x.start, x.end, x.frame.can_id, x.ok) for x in d.bus.log]

    assert trace(4) == trace(4)
    assert trace(4) != trace(5)


# ----- RS485 ----------------------------------------------------------------------------------------

def silence_errors(line: rs485.Rs485Line) -> list[str]:
    """A read at 1 Mb/s: the node answers only after the request's t3.5 (+ one character, its view),
    within the turnaround allowance; a stall over t1.5 inside the answer breaks it."""
    node = line.node(3, cycle.DEFAULT_APP)
    wrong = []
    o = line.poll(3, 1, True, bytes(6), node)
    if o.status != "OK" or o.answer_start_us is None:
        return [f"a clean read: {o.status}"]
    wait = o.answer_start_us - o.request_end_us
    least = line.tm.t35_us + line.char_us
    if not least <= wait <= least + line.tm.turnaround_us:
        wrong.append(f"answer {wait:.1f} us after the request, not within {least:.0f}..{least + line.tm.turnaround_us:.0f}")
    short = line.poll(3, 1, True, bytes(6), node, stall_us=line.tm.t15_us - line.char_us - 2).status
    if short != "OK":
        wrong.append(f"a gap under t1.5: {short}")
    long = line.poll(3, 1, True, bytes(6), node, stall_us=line.tm.t15_us + 2).status
    if long != "TIMEOUT":
        wrong.append(f"a gap over t1.5: {long}")
    return wrong


def test_rs485_silence_and_turnaround() -> None:
    assert silence_errors(rs485.Rs485Line(1_000_000, random.Random(1))) == []


def test_rs485_check_rejects_an_answer_without_the_t35_silence() -> None:
    assert silence_errors(rs485.Rs485Line(1_000_000, random.Random(1), mutant_answer_early=True))


def test_rs485_a_node_slower_than_the_allowance_is_no_node() -> None:
    line = rs485.Rs485Line(1_000_000, random.Random(1), node_latency_us=(200.0, 200.0))
    node = line.node(3, cycle.DEFAULT_APP)
    assert line.poll(3, 1, True, bytes(6), node).status == "NO_NODE"
    assert line.poll(4, 1, True, bytes(6), None).status == "NO_NODE"  # nobody at that address


def test_rs485_timing_is_the_firmware_s_and_modbus_fixes_it_above_19200() -> None:
    assert (rs485.timing(115200).t15_us, rs485.timing(115200).t35_us) == (131, 304)
    assert (rs485.timing(1_000_000).t15_us, rs485.timing(1_000_000).t35_us) == (15, 35)
    assert (rs485.timing(115200, modbus_fixed=True).t15_us, rs485.timing(115200, modbus_fixed=True).t35_us) == (750, 1750)
    assert rs485.timing(19200, modbus_fixed=True) == rs485.timing(19200)


def test_rs485_errors_give_checksum_or_timeout() -> None:
    line = rs485.Rs485Line(1_000_000, random.Random(7), ber=1e-3)
    node = line.node(2, cycle.DEFAULT_APP)
    for k in range(300):
        read = bool(k & 1)
        line.poll(2, 1, read, bytes(6) if read else b"\x05\x06", node)
    # a corrupted address reaches no node: nobody answers, NO_NODE (the firmware's slave stays silent)
    assert set(line.statuses) <= {"OK", "CHECKSUM", "TIMEOUT", "NO_NODE"} and line.statuses.get("CHECKSUM", 0) > 0
    assert line.corrupted > 0


# ----- the firmware's frames and the derived bounds -----------------------------------------------

def test_frames_are_the_firmware_s() -> None:
    """A 32-byte transfer is 5 frames with the transfer CRC; SYNC is identifier 0; every bridge frame
    outranks every node frame."""
    frames = cores.can_transfer(bytes(range(32)), 3)
    assert [len(f) for f in frames] == [8, 8, 8, 8, 7]  # 32 bytes and the CRC: 4 x 7 + 6
    assert frames[0][-1] == 0xA3 and frames[-1][-1] & 0x40  # start + toggle + tid 3; end of transfer
    assert cores.can_id(63, 7, True, cores.REQUEST) < cores.can_id(1, 0, False, cores.RESPONSE)
    assert cores.can_sync(7, 0)[0] == 7


def test_simulated_reads_stay_within_their_derived_bounds() -> None:
    for kind, rate in (("can", 250_000), ("rs485", 115_200)):
        rows, _ = measure.latency(kind, rate, [1, 8, 31], 5, seed=3)
        assert all(r.within for r in rows), [(r.payload, min(r.samples), max(r.samples), r.lo, r.hi) for r in rows]


def _probes() -> dict[int, cores.App]:
    """Node n (1..32) is the probe with n bytes in outbox 1 and in inbox 1."""
    return {n: cores.App("probe", out_size=n, in_size=n) for n in range(1, 33)}


def test_transfers_between_the_firmware_s_master_and_the_node_library() -> None:
    """Every read and write of 1..32 bytes goes through the bus between the firmware's master and a
    URB node (urb_can_master.c; the node library on urb_can_slave.c, running the probe): each read
    returns the outbox buffer the node library latched, each write is what the probe's next lock
    sees; a mailbox the application did not set up is the master's BAD_REQUEST, another length
    SIZE_MISMATCH; a SYNC reaches the node library with its time stamp."""
    d = cycle.CanDownlink(1_000_000, random.Random(9), tuple(range(1, 33)), apps=_probes())
    assert d.transact(0.0, cycle.Txn(5, 2, True, bytes(5))).status == "BAD_REQUEST"
    assert d.transact(1000.0, cycle.Txn(5, 1, True, bytes(6))).status == "SIZE_MISMATCH"
    for n in range(1, 33):
        r = d.transact(n * 3000.0, cycle.Txn(n, 1, True, bytes(n)))
        assert r.status == "OK" and r.data == d.slaves[n].last_read(1, n)[0] and r.data[:1] != b"", n
        assert d.transact(n * 3000.0 + 1500, cycle.Txn(n, 1, False, bytes(range(n)))).status == "OK", n
    assert d.mismatches == [] and d.verified == 64
    assert d.slaves[32].inbox(1, 32) == (bytes(range(32)), 1)
    t = d.sync(200_000.0, 7)
    assert t is not None and d.slaves[5].syncs() == (1, int(t))


def test_the_transfer_check_catches_a_node_that_holds_other_data() -> None:
    """verify() is the check behind "transactions carry the node library's mailboxes": data the
    node library did not latch, or a write the application would not see, are reported."""
    d = cycle.CanDownlink(1_000_000, random.Random(9), (4,), apps={4: cores.App("probe", 4, 4)})
    assert d.transact(0.0, cycle.Txn(4, 1, False, b"\x01\x02\x03\x04")).status == "OK"
    node = d.slaves[4]
    assert cycle.verify(b"", cycle.Txn(4, 1, False, b"\x01\x02\x03\x04"), node, "CAN") is None
    assert "the application sees" in str(cycle.verify(b"", cycle.Txn(4, 1, False, b"\x09\x02\x03\x04"), node, "CAN"))
    r = d.transact(2000.0, cycle.Txn(4, 1, True, bytes(4)))
    assert cycle.verify(r.data, cycle.Txn(4, 1, True, bytes(4)), node, "CAN") is None
    assert "node sent" in str(cycle.verify(bytes(x ^ 1 for x in r.data), cycle.Txn(4, 1, True, bytes(4)), node, "CAN"))


def test_a_bridge_that_goes_bus_off_reports_timeout_then_bus_stuck_and_recovers() -> None:
    """The witness of the master's bus-off path (urb_can_master.c): a bridge whose own frames are
    disturbed goes bus-off inside a request (TIMEOUT: not all sent); the next request, begun while it
    is still off, is BUS_STUCK (not executed) after the recovery; then requests succeed again."""
    d = cycle.CanDownlink(1_000_000, random.Random(0), (1,), tx_fault={0: 0.7})
    for _ in range(300):
        d.transact(0.0, cycle.Txn(1, 1, True, bytes(6)))
    assert {"OK", "TIMEOUT", "BUS_STUCK"} <= set(d.statuses) <= {"OK", "TIMEOUT", "BUS_STUCK"}
    assert d.master.recoveries() == d.statuses["BUS_STUCK"] and d.bridge.recoveries == d.bridge.bus_off_count > 0


def test_rs485_transfers_between_the_firmware_s_master_and_the_node_library() -> None:
    """Reads and writes of 1..32 bytes between urb_rs485_master.c and URB nodes on urb_rs485_slave.c
    (the probe): the data are the node library's; a SYNC reaches every node library."""
    d = cycle.Rs485Downlink(1_000_000, random.Random(3), tuple(range(1, 33)), apps=_probes())
    for n in range(1, 33):
        assert d.transact(0.0, cycle.Txn(n, 1, True, bytes(n))).status == "OK", n
        assert d.transact(0.0, cycle.Txn(n, 1, False, bytes(range(n)))).status == "OK", n
    assert d.mismatches == [] and d.verified == 64
    assert d.nodes[32].inbox(1, 32) == (bytes(range(32)), 1)
    d.sync(d.now_us() + 100.0, 9)
    assert d.nodes[5].syncs()[0] == d.nodes[6].syncs()[0] == 1
