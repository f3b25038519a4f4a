"""Classic CAN 2.0 (11-bit identifiers) to the bit: frame bits, stuffing, CRC-15, arbitration,
error frames and fault confinement (ISO 11898-1; CAN 2.0 part A).

Time is counted in bit times from 0; `CanBus` turns it into nanoseconds at its bit rate. One frame
on the wire, in order: SOF, identifier (MSB first), RTR, IDE, r0, DLC, data (MSB first), CRC-15:
these 34 + 8s bits are stuffed (after five equal bits the complement is inserted, and counts in the
next run); then CRC delimiter, ACK slot, ACK delimiter, 7 bits of end of frame and the 3-bit
intermission: 13 bits never stuffed. So a frame is 47 + 8s bits plus its stuff bits, at most
55 + 10s (spec/schema/README.md, "CAN downlink").

Model assumptions (each stated in sim/README.md, "Downlinks"): a disturbance is seen by every node
(the transmitter is charged 8, every receiver 1); an error is detected at the bit it hits and the
error flag starts at the next bit; the other nodes' flags superpose 0..6 bits (drawn); no error
hits the last bit of the end of frame (the duplicate-frame case, handled by the cores' duplicate
filter, is not modelled); bus-off drops the controller's pending frames (the master then sees
bus-off and reports BUS_STUCK, as `urb_can_master.c` does); propagation delay is ignored for the
arbitration (a short bus: well under one bit at 1 Mb/s).
"""

from __future__ import annotations

import random
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field

#: bits after the stuffed part: CRC delimiter, ACK slot, ACK delimiter, end of frame (7), intermission (3)
TAIL_BITS = 13
#: an error frame after the flag: the error delimiter (8 recessive bits) and the intermission (3)
ERROR_DELIMITER_BITS = 8
INTERMISSION_BITS = 3
ERROR_FLAG_BITS = 6
#: an error-passive transmitter waits this long more before it may send again
SUSPEND_BITS = 8
#: bus-off recovery: 128 occurrences of 11 consecutive recessive bits
RECOVERY_OCCURRENCES = 128
RECESSIVE_RUN = 11
CRC15_POLY = 0x4599

ACTIVE, PASSIVE, BUS_OFF = "error-active", "error-passive", "bus-off"


def crc15(bits: Sequence[int]) -> int:
    """CAN's CRC-15 (polynomial 0x4599, initial 0) over a bit sequence, MSB first."""
    crc = 0
    for b in bits:
        top = ((crc >> 14) & 1) ^ b
        crc = (crc << 1) & 0x7FFF
        if top:
            crc ^= CRC15_POLY
    return crc


def _bits(value: int, width: int) -> list[int]:
    return [(value >> (width - 1 - i)) & 1 for i in range(width)]


def unstuffed_bits(can_id: int, data: bytes) -> list[int]:
    """SOF .. CRC of a standard data frame, before stuffing (34 + 8 len(data) bits)."""
    if not 0 <= can_id <= 0x7FF:
        raise ValueError(f"CAN identifier {can_id:#x} is not an 11-bit identifier (0..0x7ff)")
    if len(data) > 8:
        raise ValueError(f"a classic CAN frame carries at most 8 data bytes, not {len(data)}")
    head = [0, *_bits(can_id, 11), 0, 0, 0, *_bits(len(data), 4)]
    for byte in data:
        head += _bits(byte, 8)
    return head + _bits(crc15(head), 15)


def stuff(bits: Sequence[int], run: int = 5) -> list[int]:
    """The bits as sent: after `run` equal bits the complement is inserted (and starts the next run).
    `run` is a parameter only so that tests can show a wrong run length being caught."""
    out: list[int] = []
    last, count = -1, 0
    for b in bits:
        out.append(b)
        if b == last:
            count += 1
        else:
            last, count = b, 1
        if count == run:
            stuffed = 1 - b
            out.append(stuffed)
            last, count = stuffed, 1
    return out


@dataclass(frozen=True)
class Frame:
    """One data frame: identifier, data, and who sent it (`tag` is the caller's, e.g. a transaction)."""

    can_id: int
    data: bytes
    sender: str
    tag: object = None

    def wire(self) -> list[int]:
        """Its stuffed bits, SOF .. CRC."""
        return stuff(unstuffed_bits(self.can_id, self.data))

    def bits(self) -> int:
        """Bit times it occupies, intermission included."""
        return len(self.wire()) + TAIL_BITS


def bits_max(length: int) -> int:
    """Davis et al.'s worst case, 55 + 10 s (11-bit identifier, intermission included)."""
    return 55 + 10 * length


def bits_min(length: int) -> int:
    """No stuff bit at all: 47 + 8 s."""
    return 47 + 8 * length


@dataclass
class Controller:
    """One node's CAN controller: its transmit queue and its fault-confinement counters."""

    name: str
    tec: int = 0
    rec: int = 0
    state: str = ACTIVE
    queue: deque[tuple[int, Frame]] = field(default_factory=deque)
    suspend_until: int = 0
    recovery_seen: int = 0
    recessive_run: int = 0
    #: probability that a frame this controller sends is disturbed (a faulty transceiver); per frame
    tx_fault: float = 0.0
    bus_off_count: int = 0
    recoveries: int = 0
    arbitration_lost: int = 0

    def update_state(self) -> None:
        if self.state == BUS_OFF:
            return
        if self.tec > 255:
            self.state = BUS_OFF
            self.bus_off_count += 1
            self.recovery_seen = self.recessive_run = 0
            self.queue.clear()
            return
        self.state = PASSIVE if self.tec > 127 or self.rec > 127 else ACTIVE

    def transmit_error(self) -> None:
        self.tec += 8
        self.update_state()

    def receive_error(self) -> None:
        if self.state != BUS_OFF:
            self.rec = min(self.rec + 1, 255)
            self.update_state()

    def transmit_ok(self) -> None:
        self.tec = max(0, self.tec - 1)
        self.update_state()

    def receive_ok(self) -> None:
        if self.state == BUS_OFF:
            return
        if self.rec > 127:
            self.rec = 119  # ISO 11898-1: a value between 119 and 127
        elif self.rec > 0:
            self.rec -= 1
        self.update_state()

    def recessive(self, bits: int) -> None:
        """`bits` consecutive recessive bits seen; a bus-off controller counts occurrences of 11."""
        if self.state != BUS_OFF:
            return
        self.recessive_run += bits
        self.recovery_seen += self.recessive_run // RECESSIVE_RUN
        self.recessive_run %= RECESSIVE_RUN
        if self.recovery_seen >= RECOVERY_OCCURRENCES:
            self.state, self.tec, self.rec = ACTIVE, 0, 0
            self.recovery_seen = self.recessive_run = 0
            self.recoveries += 1

    def dominant(self) -> None:
        """A dominant bit breaks a run of recessive ones."""
        self.recessive_run = 0


@dataclass(frozen=True)
class Delivery:
    """A frame that went through (start and end in bit times; end after the intermission), or an
    attempt that ended in an error frame (`ok` False)."""

    start: int
    end: int
    frame: Frame
    ok: bool
    stuff_bits: int


@dataclass
class CanBus:
    """A CAN bus of controllers, advanced in bit times.

    `ber`: the probability that a bit on the wire is disturbed (every node sees it). Each
    controller's `tx_fault` adds disturbances of its own frames only. Draws come from `rng` in the
    order the bus advances, so the same seed gives the same trace."""

    bitrate: int
    rng: random.Random
    ber: float = 0.0
    #: the stuff run length used to send; 5 in CAN (a seeded bug in tests sets 6)
    stuff_run: int = 5
    #: a seeded bug: the highest identifier wins arbitration (tests show the model is checked)
    mutant_high_id_wins: bool = False
    controllers: dict[str, Controller] = field(default_factory=dict)
    now: int = 0
    log: list[Delivery] = field(default_factory=list)
    errors: int = 0

    def attach(self, name: str, tx_fault: float = 0.0) -> Controller:
        if name in self.controllers:
            raise ValueError(f"a controller named {name!r} is already on this bus")
        c = Controller(name, tx_fault=tx_fault)
        self.controllers[name] = c
        return c

    def ns(self, bits: int) -> int:
        """Nanoseconds of `bits` bit times."""
        return bits * 1_000_000_000 // self.bitrate

    def bit_at(self, t_ns: int) -> int:
        """The first bit boundary at or after t_ns."""
        return -(-t_ns * self.bitrate // 1_000_000_000)

    def send(self, frame: Frame, at_ns: int) -> bool:
        """Queue `frame` at its sender from time at_ns on; False (nothing queued) when the sender is bus-off."""
        c = self.controllers[frame.sender]
        if c.state == BUS_OFF:
            return False
        c.queue.append((max(self.bit_at(at_ns), self.now), frame))
        return True

    def _contenders(self) -> list[Controller]:
        return [c for c in self.controllers.values()
                if c.state != BUS_OFF and c.queue and c.queue[0][0] <= self.now and c.suspend_until <= self.now]

    def _idle(self, bits: int) -> None:
        for c in self.controllers.values():
            c.recessive(bits)
        self.now += bits

    def next_ready(self) -> int | None:
        """The earliest bit at which a queued frame may start, or None when nothing is queued."""
        times = [max(c.queue[0][0], c.suspend_until) for c in self.controllers.values()
                 if c.state != BUS_OFF and c.queue]
        return min(times) if times else None

    def step(self, until: int) -> Delivery | None:
        """Advance to the end of the next frame or error frame that starts before bit `until`, or to
        `until` if none does. Returns that frame's delivery, or None."""
        ready = self.next_ready()
        if ready is None or ready >= until:
            self._idle(max(0, until - self.now))
            return None
        if ready > self.now:
            self._idle(ready - self.now)
        contenders = self._contenders()
        winner = self._arbitrate(contenders)
        for c in contenders:
            if c is not winner:
                c.arbitration_lost += 1
        return self._transmit(winner)

    def run_until(self, until: int) -> list[Delivery]:
        out: list[Delivery] = []
        while self.now < until:
            d = self.step(until)
            if d is not None:
                out.append(d)
        return out

    def _arbitrate(self, contenders: list[Controller]) -> Controller:
        """Bitwise arbitration on the stuffed wire bits: the bus carries the AND of what everyone
        sends (0 is dominant); a sender of a recessive bit that reads a dominant one stops."""
        alive = list(contenders)
        wires = {c.name: c.queue[0][1].wire() for c in alive}
        pos = 0
        while len(alive) > 1:
            bus_bit = min(wires[c.name][pos] for c in alive)
            if self.mutant_high_id_wins:
                bus_bit = max(wires[c.name][pos] for c in alive)
            alive = [c for c in alive if wires[c.name][pos] == bus_bit]
            pos += 1
            if pos >= 13 + 4 and len(alive) > 1:  # identical identifiers: a collision in the data
                raise ValueError(f"two controllers sent identifier {alive[0].queue[0][1].can_id:#x} at once: "
                                 "URB never lets two senders share one")
        return alive[0]

    def _error_at(self, n_bits: int, extra: float) -> int | None:
        """The bit (0-based) of the frame where the first disturbance falls, or None."""
        p = 1.0 - (1.0 - self.ber) ** n_bits if self.ber > 0 else 0.0
        p = 1.0 - (1.0 - p) * (1.0 - extra)
        if p <= 0.0 or self.rng.random() >= p:
            return None
        # where: uniform over the frame's bits but its last (the EOF's last bit is not modelled)
        return self.rng.randrange(n_bits - 1)

    def _transmit(self, tx: Controller) -> Delivery:
        start = self.now
        at, frame = tx.queue[0]
        wire = stuff(unstuffed_bits(frame.can_id, frame.data), self.stuff_run)
        stuff_bits = len(wire) - (34 + 8 * len(frame.data))
        n = len(wire) + TAIL_BITS
        hit = self._error_at(n, tx.tx_fault)
        receivers = [c for c in self.controllers.values() if c is not tx and c.state != BUS_OFF]
        for c in self.controllers.values():
            c.dominant()
        if hit is None:
            self.now += n
            tx.queue.popleft()
            tx.transmit_ok()
            for c in receivers:
                c.receive_ok()
            for c in self.controllers.values():
                if c is not tx:
                    c.recessive(RECESSIVE_RUN)  # ACK delimiter, end of frame, intermission
            if tx.state == PASSIVE:
                tx.suspend_until = self.now + SUSPEND_BITS
            d = Delivery(start, self.now, frame, True, stuff_bits)
        else:
            self.errors += 1
            superposed = self.rng.randint(0, ERROR_FLAG_BITS)
            self.now += hit + 1 + ERROR_FLAG_BITS + superposed + ERROR_DELIMITER_BITS + INTERMISSION_BITS
            was_passive = tx.state == PASSIVE
            tx.transmit_error()
            for c in receivers:
                c.receive_error()
            for c in self.controllers.values():
                c.recessive(ERROR_DELIMITER_BITS + INTERMISSION_BITS)
            if was_passive and tx.state != BUS_OFF:
                tx.suspend_until = self.now + SUSPEND_BITS
            d = Delivery(start, self.now, frame, False, stuff_bits)
        self.log.append(d)
        return d

