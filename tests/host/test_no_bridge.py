"""A device that is not a URB bridge (noise: what a wrong baud rate looks like) is never taken for
one: discovery believes a bridge only once its identification read came back OK and decodes as a
BridgeInfo that checks, and says the same thing whatever bytes came back. In virtual time
(SimManager), so that every seed gives the same bytes."""

from __future__ import annotations

import random
import re
from collections.abc import Callable

import pytest

from urb.api import URBInterface
from urb.errors import NoBridgeError
from urb.managers import SimManager, VirtualClock
from urb.managers.base import NS_PER_MS, NS_PER_S
from urb_msgs.urb_core import BridgeInfo, DownlinkKind, Status, UplinkReadRequest, UplinkResponse

BYTE_NS = 10 * NS_PER_S // 115200
NOISE_FOR_NS = 2 * NS_PER_S


class NoisyLine:
    """An RS232 line whose far end sends random bytes at 115200 Bd, back to back, whatever it is
    sent (a bridge at another baud rate, or another device)."""

    def __init__(self, clock: VirtualClock, seed: int) -> None:
        self.clock = clock
        self.rng = random.Random(seed)
        self._receiver: Callable[[bytes], None] | None = None
        self.sent = 0

    def set_receiver(self, receiver: Callable[[bytes], None]) -> None:
        self._receiver = receiver
        self.clock.call_at(self.clock.now_ns() + NS_PER_MS, self._chunk)

    def send(self, data: bytes) -> None:
        pass

    def _chunk(self) -> None:
        if self._receiver is None or self.clock.now_ns() > NOISE_FOR_NS:
            return
        chunk = bytes(self.rng.getrandbits(8) for _ in range(11))  # ~1 ms of bytes at 115200 Bd
        self.sent += len(chunk)
        self._receiver(chunk)
        self.clock.call_at(self.clock.now_ns() + len(chunk) * BYTE_NS, self._chunk)


class ScriptedLine:
    """An RS232 line whose far end answers every request frame with `answer(request)` (the
    bytes of one response frame), 1 ms later."""

    def __init__(self, clock: VirtualClock, answer: Callable[[UplinkReadRequest], bytes]) -> None:
        self.clock = clock
        self.answer = answer
        self._receiver: Callable[[bytes], None] | None = None

    def set_receiver(self, receiver: Callable[[bytes], None]) -> None:
        self._receiver = receiver

    def send(self, data: bytes) -> None:
        if data[0] & 1 == 0:  # a write request: the scripted device answers only reads
            return
        reply = self.answer(UplinkReadRequest.decode(data))
        self.clock.call_at(self.clock.now_ns() + NS_PER_MS, lambda: self._deliver(reply))

    def _deliver(self, data: bytes) -> None:
        assert self._receiver is not None
        self._receiver(data)


def discover(transport: NoisyLine | ScriptedLine, clock: VirtualClock) -> str:
    """Discovery on `transport`: the NoBridgeError's text (the test fails if a bridge is found)."""
    m = SimManager(clock, transport, name="/dev/ttyNOISE", timeout_ns=200 * NS_PER_MS, lost_after_ns=NS_PER_S)
    with pytest.raises(NoBridgeError) as exc:
        URBInterface().add_bus_manager(m, timeout_s=3.0)
    return str(exc.value)


def says_no_bridge(text: str) -> bool:
    """The diagnosis: no URB bridge, and what to check (baud rate, device)."""
    return text.startswith("no URB bridge answered on /dev/ttyNOISE (") and "baud rate" in text and "device" in text


@pytest.mark.parametrize("first_seed", range(0, 200, 50))
def test_noise_is_never_a_bridge_and_always_the_same_diagnosis(first_seed: int) -> None:
    """200 seeds of noise: about one run in four used to find a frame that passed its CRC-8 and
    reported that bridge's refusal (SIZE_MISMATCH, BAD_REQUEST ...) or a bridge that does not
    exist; every one must say, in the same words but for the count of bytes, that no URB bridge
    answered."""
    said: dict[str, int] = {}
    for seed in range(first_seed, first_seed + 50):
        clock = VirtualClock()
        line = NoisyLine(clock, seed)
        text = discover(line, clock)
        assert line.sent > 0  # the noise was there when the identification was read
        said.setdefault(re.sub(r"\d+ byte", "N byte", text), seed)
    assert len(said) == 1, said
    text = next(iter(said))
    assert says_no_bridge(text) and "N byte(s) came back, none of them a URB bridge's identification" in text, text


@pytest.mark.parametrize("status", [s for s in Status if s != Status.OK])
def test_a_refused_identification_read_is_no_bridge(status: Status) -> None:
    """A frame that checks, echoes the request's sequence number and carries a refusal: what noise
    produces about once in 8000 bytes (a matching sequence number, a refusal status, a CRC-8 that
    passes). It is no evidence of a bridge."""
    clock = VirtualClock()
    text = discover(ScriptedLine(clock, lambda req: UplinkResponse(seq=req.seq, status=status).encode()), clock)
    assert says_no_bridge(text) and status.name not in text, text


@pytest.mark.parametrize("info", [
    BridgeInfo(downlink=DownlinkKind.I2C, bitrate_kbps=400, fifo_depth=0, heartbeat_us=1000),
    BridgeInfo(downlink=DownlinkKind.CAN, bitrate_kbps=0, fifo_depth=8, heartbeat_us=1000),
], ids=["fifo-depth-0", "bit-rate-0"])
def test_an_identification_that_decodes_but_does_not_check_is_no_bridge(info: BridgeInfo) -> None:
    clock = VirtualClock()
    text = discover(ScriptedLine(clock, lambda req: UplinkResponse(seq=req.seq, status=Status.OK,
                                                                     data=info.encode()).encode()), clock)
    assert says_no_bridge(text), text


def test_a_silent_line_says_that_nothing_came_back() -> None:
    clock = VirtualClock()
    text = discover(ScriptedLine(clock, lambda req: b""), clock)
    assert says_no_bridge(text) and "(nothing came back)" in text, text


def test_a_bridge_that_checks_is_believed() -> None:
    """The witness that the checks pass a real answer: the scripted device answering a BridgeInfo
    that checks is a bridge (discovery goes on to its scan map, which it does not answer)."""
    info = BridgeInfo(downlink=DownlinkKind.I2C, bitrate_kbps=400, fifo_depth=8, heartbeat_us=1000)

    def answer(req: UplinkReadRequest) -> bytes:
        if req.address == 0 and req.mailbox == 0:
            return UplinkResponse(seq=req.seq, status=Status.OK, data=info.encode()).encode()
        return b""

    clock = VirtualClock()
    text = discover(ScriptedLine(clock, answer), clock)
    assert "reading the scan map of /dev/ttyNOISE failed" in text and "no URB bridge answered" not in text, text
