"""The port hand-over (host/urb/managers/handover.py) against the real bridge firmware.

A host process sends a full window of identification reads to one probe node and is killed at
once (its core stops reading); the next process on the same uplink reads the other node with
sequence number 1. The bridge still holds the four old requests and answers them first, in
order: without the hand-over the new process takes the answer to the old request 1 as its own
(the other node's identification), with it the old answers are discarded and it gets its own.
On USB the old answers come in the IN transfer of the new process's first frames (the simulated
driver's IN URB is still pending), on RS232 as bytes after its request went out.
"""

from __future__ import annotations

import pytest

from urb.managers.base import Transfer
from urb.managers.sim import SimManager
from urb_msgs.urb_core import Identification, Status
from urb_sim.native import App
from urb_sim.system import System

OLD, NEW = 0x10, 0x11
"""Two probe nodes, identification index 0 and 1."""


def ident_read(address: int) -> Transfer:
    return Transfer(address=address, mailbox=0, read=True, length=Identification.SIZE)


def next_process_reads(uplink: str, handed_over: bool) -> tuple[Transfer, SimManager]:
    s = System(seed=3, probe_out=4)
    b = s.bridge(uplink)
    s.node(b, App.PROBE, OLD, 0)
    s.node(b, App.PROBE, NEW, 1)
    s.start(discover=False)
    try:
        first = s.managers[b]
        olds = [ident_read(OLD) for _ in range(4)]
        for t in olds:
            first.submit(t)
        assert first.wait_until(lambda: all(t.sent_ns is not None for t in olds), 0.01)
        until = first.core.busy_until()  # what its record would say
        assert until is not None
        first.core.link_lost(s.host.now_ns(), "killed")
        second = SimManager(s.host, s.host.usb(b) if uplink == "usb" else s.host.rs232(b))
        second.start()
        if handed_over:
            second.core.hand_over(until)
        new = ident_read(NEW)
        second.submit(new)
        assert second.wait_until(lambda: new.done, 1.0)
        assert new.seq == olds[0].seq == 1
        return new, second
    finally:
        s.close()


# lobster-trace: urb.HOST_006
@pytest.mark.parametrize("uplink", ["rs232", "usb"])
def test_the_next_process_gets_its_own_answer(uplink: str) -> None:
    new, second = next_process_reads(uplink, handed_over=True)
    assert new.ok and new.response is not None and Identification.decode(new.response).index == 1
    assert second.core.stray_bytes == 4 * ident_read(OLD).response_size(Status.OK)  # the 4 old answers


# lobster-trace: urb.HOST_006
@pytest.mark.parametrize("uplink", ["rs232", "usb"])
def test_without_the_hand_over_it_takes_an_old_answer(uplink: str) -> None:
    """The mutant: what the host did before (and what Bridge_RestartWithoutHandover refutes)."""
    new, _ = next_process_reads(uplink, handed_over=False)
    assert new.ok and new.response is not None and Identification.decode(new.response).index == 0
