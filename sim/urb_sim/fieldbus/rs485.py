"""A half-duplex RS485 line polled by a bridge, character by character.

Each end's receiver is the firmware's (`cores.Rs485Receiver`: `urb_rs485_rx_*`), fed with the stop
bit's instant of every character, so the silence rules are the C core's: a frame ends after t3.5
of silence (seen t3.5 + one character after its last byte), a silence over t1.5 inside a frame
discards it. What the line adds (sim/README.md, "Downlinks"):

* characters of 10 bits (8N1) back to back from a UART with a FIFO, or with gaps when a node's
  transmit interrupt is late (`gap_us`, drawn per character; a stalled node, `stall_us`, breaks its
  answer);
* the node's answer starts when its receiver ends the request (its deadline), after its interrupt
  latency and its driver-enable time (`turnaround`, drawn per answer), which the bridge allows up to
  `urb_rs485_timing`'s turnaround figure;
* a character is corrupted with probability 1 - (1 - ber)^10, which its frame's check then fails;
* Modbus RTU's fixed silences (1750 / 750 us above 19200 Bd) when `modbus_fixed`, for comparison:
  URB keeps 3.5 / 1.5 characters at every rate (spec/schema/README.md, "RS485 downlink").
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field, replace

from . import cores

CHAR_BITS = 10
MODBUS_T35_US, MODBUS_T15_US = 1750, 750
#: a transceiver's driver enable to a valid line, us (min, max); a UART FIFO refilled late, us per character
DRIVER_ENABLE_US, GAP_US = (0.1, 1.0), (0.0, 0.5)
#: MailboxSelect's read bit (a read request)
READ_BIT = 0x80
STATUS_CHECKSUM = 2
#: the statuses a node's answer carries (urb_status_t), as the bridge reports them
STATUS_NAMES = {0: "OK", 2: "CHECKSUM", 5: "SIZE_MISMATCH", 6: "BAD_REQUEST", 8: "NODE_BUSY"}


def timing(baud: int, modbus_fixed: bool = False) -> cores.Rs485Timing:
    """The firmware's timing at `baud`; with `modbus_fixed` Modbus RTU's fixed silences above 19200 Bd."""
    t = cores.rs485_timing(baud)
    if modbus_fixed and baud > 19200:
        t = replace(t, t15_us=MODBUS_T15_US, t35_us=MODBUS_T35_US)
    return t


@dataclass
class Outcome:
    """One poll as the bridge saw it: the status it reports (as urb_rs485_master does) and instants (us)."""

    status: str
    start_us: float
    request_end_us: float
    answer_start_us: float | None
    done_us: float


@dataclass
class Rs485Line:
    """One RS485 segment: the bridge and its nodes' receivers, the line's time (us, float)."""

    baud: int
    rng: random.Random
    ber: float = 0.0
    modbus_fixed: bool = False
    #: interrupt latency of a node before it enables its driver, us (min, max), drawn per answer
    node_latency_us: tuple[float, float] = (2.0, 10.0)
    #: driver enable (DE) to a valid line, us (min, max): the transceiver's enable time
    driver_enable_us: tuple[float, float] = DRIVER_ENABLE_US
    #: extra gap before each character a node sends, us (min, max): its transmit FIFO is refilled late
    gap_us: tuple[float, float] = GAP_US
    #: a seeded bug for the tests: the node answers as soon as the request's last character is in,
    #: without waiting for t3.5 of silence
    mutant_answer_early: bool = False
    now_us: float = 0.0
    broken: int = 0
    corrupted: int = 0
    statuses: dict[str, int] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.tm = timing(self.baud, self.modbus_fixed)
        self.char_us = CHAR_BITS * 1e6 / self.baud
        self.bridge_rx = cores.Rs485Receiver(self.tm, 0)

    def _corrupt(self, frame: bytes) -> bytes:
        p = 1.0 - (1.0 - self.ber) ** CHAR_BITS if self.ber > 0 else 0.0
        out = bytearray(frame)
        for i in range(len(out)):
            if p > 0 and self.rng.random() < p:
                out[i] ^= 1 << self.rng.randrange(8)
                self.corrupted += 1
        return bytes(out)

    def _send(self, frame: bytes, start: float, receivers: list[cores.Rs485Receiver],
              gaps: tuple[float, float], stall_at: int | None = None, stall_us: float = 0.0) -> float:
        """Put `frame` on the line from `start`; every receiver gets each byte at its stop bit's end.
        Returns the instant the last stop bit ends."""
        t = start
        wire = self._corrupt(frame)
        for i, byte in enumerate(wire):
            t += self.rng.uniform(*gaps) if i else 0.0
            if stall_at is not None and i == stall_at:
                t += stall_us
            t += self.char_us
            for rx in receivers:
                ev = rx.byte(byte, int(t))
                if ev & cores.EV_BROKEN and rx is self.bridge_rx:
                    self.broken += 1
        return t

    def wait_silent(self) -> float:
        """The first instant the bridge may send: its receiver has seen t3.5 of silence."""
        t = max(self.now_us, 0.0)
        while not self.bridge_rx.silent(int(t)):
            t = max(t + 1.0, float(self.bridge_rx.deadline()))
        return t

    def broadcast(self, frame: bytes, node_rx: list[cores.Rs485Receiver]) -> tuple[float, float]:
        """A frame nobody answers (SYNC): (first byte's stop bit, end of the frame's t3.5)."""
        start = self.wait_silent()
        first = start + self.char_us
        end = self._send(frame, start, [self.bridge_rx, *node_rx], (0.0, 0.0))
        self.now_us = float(self.bridge_rx.deadline())
        self.bridge_rx.poll(int(self.now_us))
        for rx in node_rx:
            rx.poll(int(self.now_us))
        return first, end

    def poll(self, request: bytes, answer: bytes | None, node_rx: cores.Rs485Receiver,
             stall_us: float = 0.0) -> Outcome:
        """The bridge sends `request`; the node (receiver `node_rx`) answers `answer` (None: nobody
        there). `stall_us` holds the node's answer that long before its second character."""
        start = self.wait_silent()
        req_end = self._send(request, start, [self.bridge_rx, node_rx], (0.0, 0.0))
        node_end = float(node_rx.deadline())
        got = node_rx.poll(int(node_end)) & cores.EV_END
        heard = node_rx.last()
        self.bridge_rx.poll(int(node_end))
        if answer is None or not got or heard.n != len(request):
            # the answer's deadline: t3.5 + the turnaround allowance + one character after the request's end
            done = req_end + self.tm.t35_us + self.tm.turnaround_us + self.char_us
            return self._finish(Outcome("NO_NODE", start, req_end, None, done))
        if not heard.check_ok:
            answer = cores.rs485_response(STATUS_CHECKSUM, answer[0] >> 4 & 7)  # the node refuses it
        ready = req_end if self.mutant_answer_early else node_end
        ans_start = ready + self.rng.uniform(*self.node_latency_us) + self.rng.uniform(*self.driver_enable_us)
        if ans_start - req_end > self.tm.t35_us + self.tm.turnaround_us + self.char_us:
            done = req_end + self.tm.t35_us + self.tm.turnaround_us + self.char_us
            return self._finish(Outcome("NO_NODE", start, req_end, None, done))
        broken_before = self.broken
        ans_end = self._send(answer, ans_start, [self.bridge_rx, node_rx], self.gap_us,
                             stall_at=1 if stall_us > 0 else None, stall_us=stall_us)
        done = float(self.bridge_rx.deadline())
        ended = self.bridge_rx.poll(int(done)) & cores.EV_END
        node_rx.poll(int(done))
        got_back = self.bridge_rx.last()
        if self.broken > broken_before or not ended:
            status = "TIMEOUT"
        elif got_back.n != len(answer):
            status = "CHECKSUM"  # the request and its answer ran together into one frame
        elif not got_back.check_ok:
            status = "CHECKSUM" if request[1] & READ_BIT else "TIMEOUT"
        else:
            status = STATUS_NAMES.get(answer[0] & 0x0F, "BAD_REQUEST")
        return self._finish(Outcome(status, start, req_end, ans_start, max(done, ans_end)))

    def _finish(self, o: Outcome) -> Outcome:
        self.now_us = o.done_us
        self.statuses[o.status] = self.statuses.get(o.status, 0) + 1
        return o
