"""A node whose mailbox sizes the bridge's table does not hold (here: the 33rd node on one bridge,
past URB_BRIDGE_MAX_NODES) is identified before each request goes to the bus. With the real node
library, a write shorter than the inbox used to be acknowledged byte by byte, dropped by the node at
the STOP, and answered OK by the bridge: a write reported done that nothing stored (Bridge.tla
WriteStatusTruthful). The node's own mailbox trace tells what it stored."""

from __future__ import annotations

import json
from pathlib import Path

from urb.errors import Status
from urb.managers.base import Transfer
from urb_sim.native import App, Trace
from urb_sim.system import NS_PER_MS, System

ADDRESSES = list(range(0x08, 0x08 + 33))  # one more node than the bridge's table holds (32)
INBOX = 4                                 # the probe nodes' inbox 1


# lobster-trace: urb.ERR_002, urb.ERR_003
def test_short_write_to_a_node_past_the_table_is_refused(tmp_path: Path) -> None:
    trace = tmp_path / "mailbox.ndjson"
    system = System(seed=1, probe_out=6, probe_in=INBOX)
    bridge = system.bridge("rs232")
    for i, a in enumerate(ADDRESSES):
        system.node(bridge, App.PROBE, a, index=i)
    system.world.trace(trace, Trace.MAILBOX)
    system.start()
    manager = system.managers[bridge]
    done: dict[tuple[int, int], Transfer] = {}
    for address in (ADDRESSES[0], ADDRESSES[-1]):  # in the table, past it
        for length in (INBOX - 2, INBOX):
            key = (address, length)
            manager.submit(Transfer(address, 1, False, length, data=bytes([0xA0 + length] * length),
                                    on_done=lambda t, k=key: done.__setitem__(k, t)))
            system.host.run_until(lambda k=key: k in done, system.host.now_ns() + 500 * NS_PER_MS)
            system.host.advance(5 * NS_PER_MS)
    system.world.flush_trace()
    system.close()
    for address in (ADDRESSES[0], ADDRESSES[-1]):
        assert done[(address, INBOX - 2)].status == Status.SIZE_MISMATCH, hex(address)
        assert done[(address, INBOX)].status == Status.OK, hex(address)
    events = [json.loads(line) for line in trace.read_text().splitlines()]
    for address in (ADDRESSES[0], ADDRESSES[-1]):
        inbox = [e["ev"] for e in events
                 if e["dev"].endswith(f"/n{address}") and e.get("box") == 1 and e["ev"] in ("wbegin", "commit", "abort")]
        assert inbox == ["wbegin", "commit"], (hex(address), inbox)  # only the full-length write reached it
