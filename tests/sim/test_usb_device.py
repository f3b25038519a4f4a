"""The bridge's USB device as the Cortex-M0+ port runs it (firmware/hal/cortex-m0plus/bridge_port.c):
the SOF, the OUT hand-over and the arming of the IN buffer happen in the main loop, and the USB
controller answers an IN token with what was armed before it, or NAK (firmware/hal/sim/bridge_hal_sim.c).

Each check reads the simulation's trace of one rig (a USB bridge, a probe node, a 1-kHz read loop):
bus "sof", "in", "in_nak" (the host controller, dev "usb"), the bridge's "usb_sof" (its main loop
took the SOF), "in_arm" (it armed the IN buffer: len, count) and "resp" (a response left at an IN
token). Each returns the violations it found, so that the last test can show every check failing
for the seeded bug URBSIM_MUTANT_USB_IN_AT_TOKEN: the firmware swapping at the SOF instant and
filling the IN transfer at the token, as the simulation did before (as if it ran inside the USB
controller).

    python3 tests/sim/test_usb_device.py   # every check's violations, as JSON (the mutant test runs it)
"""

from __future__ import annotations

import bisect
import json
import os
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from urb.api import NodeRequest
from urb_sim.native import App, Trace
from urb_sim.system import NS_PER_MS, Loop, System

#: The SOF packet (35 bits at 12 Mb/s, like a token): the device sees the SOF at its end.
SOF_NS = 2917
#: The frame's first token: after the SOF packet and the inter-packet gap (35 + 8 bits).
FIRST_TOKEN_NS = 3583
#: The bridge's USB interrupt at an SOF, from the device seeing it to the handler's return: entry
#: latency (bridge.irq_cycles 15) and handler (bridge.usb_isr_cycles 200) at 48 MHz. The main loop
#: cannot take the SOF before.
SOF_HANDLER_NS = 4479
#: The USB batch header (UsbBatchHeader): a batch without responses.
HEADER = 4
DEV = "usb0"


@dataclass
class Rig:
    latencies_ms: list[float]
    stats: dict[str, float]
    start_ns: int  #: the reads start (virtual time)
    events: list[dict[str, Any]] = field(default_factory=list)

    def of(self, cat: str, ev: str, dev: str = DEV) -> list[dict[str, Any]]:
        return [e for e in self.events if e["cat"] == cat and e["ev"] == ev and e["dev"] == dev]

    def bus(self, ev: str) -> list[dict[str, Any]]:
        """Host controller events of the bridge's device (index 0; the line names the controller "usb"
        first, then the device, and json keeps the last)."""
        return [e for e in self.events if e["cat"] == "bus" and e["ev"] == ev and e["dev"] == 0]

    def sofs(self) -> list[int]:
        """Start of every frame (the SOF packet)."""
        return [e["t"] for e in self.events if e["cat"] == "bus" and e["ev"] == "sof"]


def rig(params: dict[str, float], reads: int = 60, idle_ms: int = 0) -> Rig:
    """A USB bridge with a probe node, `reads` reads of 4 bytes at 1 kHz after `idle_ms` of idle
    bus (after discovery), traced from power-on; the statistics count from the reads' start."""
    s = System(seed=16, probe_out=4, params=dict(params))
    b = s.bridge("usb")
    s.node(b, App.PROBE, 0x10, 0)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "t.ndjson"
        s.world.trace(path, Trace.BUS | Trace.FRAME | Trace.BRIDGE)
        s.start()
        s.host.advance(idle_ms * NS_PER_MS)
        node = s.urb.find_node(0x7E, 0)
        done: list[NodeRequest] = []
        names = ("usb_responses_sent", "usb_responses_late", "usb_naks")
        before = {n: s.world.stat("bridge." + n, b) for n in names}
        start = s.world.now

        def tick() -> None:
            node.submit_request(node.new_request().read(1, 4).set_callback(done.append))

        Loop(s.host, NS_PER_MS, tick, count=reads)
        s.host.advance((reads + 10) * NS_PER_MS)
        s.world.flush_trace()
        events = [json.loads(line) for line in path.read_text().splitlines()
                  if '"dev":"usb' in line and '"dev":"usb0/i2c"' not in line]
    stats = {n: s.world.stat("bridge." + n, b) - before[n] for n in names}
    lat = [r.latency_ns / 1e6 for r in done if r.ok and r.latency_ns is not None]
    s.close()
    assert len(lat) == reads, f"{reads - len(lat)} of {reads} reads failed"
    return Rig(lat, stats, start, events)


def armed_before_taken(r: Rig) -> list[str]:
    """Every IN token that carries data takes the batch the main loop armed strictly before it (one
    arming per token: the same length, as many responses as leave at the token)."""
    out = []
    arms, ins = r.of("frame", "in_arm"), r.bus("in")
    resp_at: dict[int, int] = {}
    for e in r.of("bridge", "resp"):
        resp_at[e["t"]] = resp_at.get(e["t"], 0) + 1
    arm_t = [a["t"] for a in arms]
    prev = -1
    for tok in ins:
        i = bisect.bisect_left(arm_t, tok["t"]) - 1  # the last arming strictly before the token
        if i < 0 or i <= prev:
            out.append(f"IN at {tok['t']} ns: no arming since the previous IN")
            continue
        a = arms[i]
        if a["len"] != tok["len"] or a["count"] != resp_at.get(tok["t"], 0):
            out.append(f"IN at {tok['t']} ns carries {tok['len']} bytes, {resp_at.get(tok['t'], 0)} responses; "
                       f"armed at {a['t']}: {a['len']} bytes, {a['count']} responses")
        prev = i
    if not ins:
        out.append("no IN transfer with data")
    return out


def sof_taken_by_the_main_loop(r: Rig, min_lag_ns: int, since_ns: int = 0) -> list[str]:
    """The main loop takes each SOF (from `since_ns`) at least `min_lag_ns` after the device saw it
    (the end of the SOF packet), and the frame's data IN comes after the bridge took that SOF."""
    out = []
    sofs = r.sofs()
    takes = [e["t"] for e in r.of("frame", "usb_sof")]
    for t in (t for t in takes if t >= since_ns):
        i = bisect.bisect_right(sofs, t) - 1
        if i < 0:
            continue
        if t - (sofs[i] + SOF_NS) < min_lag_ns:
            out.append(f"SOF at {sofs[i]} ns taken {t - sofs[i] - SOF_NS} ns after the device saw it")
    for tok in r.bus("in"):
        i = bisect.bisect_right(sofs, tok["t"]) - 1
        j = bisect.bisect_left(takes, sofs[i])
        if j >= len(takes) or takes[j] >= tok["t"]:
            out.append(f"IN at {tok['t']} ns before the main loop took its frame's SOF ({sofs[i]} ns)")
    if not takes:
        out.append("the main loop took no SOF")
    return out


def in_first_nakked_then_retried(r: Rig) -> list[str]:
    """USB frames 0.1 ms after the OS tick: the driver's pending IN is the frame's first transaction,
    its token comes right after the SOF packet, before the bridge could arm anything: NAK, and the
    host controller retries it in the frame. No response goes out later than the frame after its
    batch (the paper's three frames hold)."""
    out = []
    naks = {e["t"] for e in r.bus("in_nak")}
    sofs = r.sofs()
    data = [e["t"] for e in r.bus("in") if e["t"] >= r.start_ns]
    firsts = [t + FIRST_TOKEN_NS for t in sofs if any(t < d < t + 1_000_000 for d in data)]
    nakked = sum(1 for t in firsts if t in naks)
    if nakked < len(firsts):
        out.append(f"{len(firsts) - nakked} of {len(firsts)} frames' first IN tokens (right after the SOF packet) "
                   "were not NAKed")
    if r.stats["usb_responses_late"]:
        out.append(f"{r.stats['usb_responses_late']:.0f} responses a frame late")
    if not 2.1 < min(r.latencies_ms) <= max(r.latencies_ms) < 2.3:
        out.append(f"latency {min(r.latencies_ms):.3f}..{max(r.latencies_ms):.3f} ms, not 2.1..2.3")
    return out


def stale_batch_goes_first(r: Rig) -> list[str]:
    """The paper's own driver (a read only after each write, usb.read_always 0): during the idle
    frames the bridge armed a batch without responses, which nobody reads. The first IN after the
    reads start takes it, although the first response was due in that frame; the response goes at
    the next IN, and every response of the burst a frame late (about 3.15 ms at this phase, 2.15
    before)."""
    out = []
    ins = [e for e in r.bus("in") if e["t"] >= r.start_ns]
    if not ins or ins[0]["len"] != HEADER:
        out.append(f"the first IN carries {ins[0]['len'] if ins else 'nothing'}, not the idle batch")
    resps = [e for e in r.of("bridge", "resp") if e["t"] >= r.start_ns]
    if not resps or len(ins) < 2 or resps[0]["t"] != ins[1]["t"]:
        out.append(f"the first response left at {resps[0]['t']} ns, not at the second IN ({ins[1]['t']} ns)")
    if r.stats["usb_responses_late"] != r.stats["usb_responses_sent"]:
        out.append(f"{r.stats['usb_responses_late']:.0f} of {r.stats['usb_responses_sent']:.0f} responses late")
    if not 3.1 < min(r.latencies_ms) <= max(r.latencies_ms) < 3.2:
        out.append(f"latency {min(r.latencies_ms):.3f}..{max(r.latencies_ms):.3f} ms, not 3.1..3.2")
    return out


def busy_loop_delays_the_swap(r: Rig) -> list[str]:
    """A main-loop iteration of 250 us (bridge.poll_cycles 12000): the SOF comes while the loop is
    busy and takes effect when the next iteration runs; until then the IN token is NAKed (and
    retried in the frame), so the round trip grows by about an iteration (3.05-3.1 ms at this
    phase with 200-cycle iterations) but no response misses its frame."""
    out = sof_taken_by_the_main_loop(r, min_lag_ns=200_000, since_ns=r.start_ns)
    if not r.stats["usb_naks"]:
        out.append("no IN token NAKed")
    if r.stats["usb_responses_late"]:
        out.append(f"{r.stats['usb_responses_late']:.0f} responses a frame late")
    if not 3.25 < min(r.latencies_ms):
        out.append(f"latency from {min(r.latencies_ms):.3f} ms: the iteration did not delay the batch")
    return out


CHECKS = ["armed before taken", "SOF taken by the main loop", "IN first: NAK, retried in the frame",
          "Fig. 9 driver: the idle batch goes first", "busy main loop"]


def violations() -> dict[str, list[str]]:
    """Every check on its rig."""
    in_first = rig({"usb.phase_us": 100})
    fig9 = rig({"usb.phase_us": 100, "usb.read_always": 0}, reads=20, idle_ms=10)
    busy = rig({"usb.phase_us": 999, "bridge.poll_cycles": 12000}, reads=30)
    return {
        "armed before taken": armed_before_taken(in_first) + armed_before_taken(fig9),
        "SOF taken by the main loop": sof_taken_by_the_main_loop(in_first, min_lag_ns=SOF_HANDLER_NS),
        "IN first: NAK, retried in the frame": in_first_nakked_then_retried(in_first),
        "Fig. 9 driver: the idle batch goes first": stale_batch_goes_first(fig9),
        "busy main loop": busy_loop_delays_the_swap(busy),
    }


def test_in_token_takes_only_what_the_main_loop_armed_before_it() -> None:
    r = rig({"usb.phase_us": 100})
    assert armed_before_taken(r) == []
    assert sof_taken_by_the_main_loop(r, min_lag_ns=SOF_HANDLER_NS) == []


def test_in_token_before_the_arming_is_nakked_and_retried_in_its_frame() -> None:
    assert in_first_nakked_then_retried(rig({"usb.phase_us": 100})) == []


def test_a_host_controller_retrying_only_in_the_next_frame_costs_every_response_a_frame() -> None:
    """usb.nak_next_frame 1: the NAKed first IN waits a frame, the bridge's batch with it; from then
    on the IN buffer always holds the previous frame's batch when the SOF comes (bridge_port.c arms
    the next batch as soon as the buffer is free), so every response is one frame late for good."""
    r = rig({"usb.phase_us": 100, "usb.nak_next_frame": 1})
    assert r.stats["usb_responses_late"] == r.stats["usb_responses_sent"] > 0
    assert 3.1 < min(r.latencies_ms) <= max(r.latencies_ms) < 3.3
    assert armed_before_taken(r) == []


def test_a_response_due_after_the_arming_waits_for_the_next_in() -> None:
    assert stale_batch_goes_first(rig({"usb.phase_us": 100, "usb.read_always": 0}, reads=20, idle_ms=10)) == []


def test_an_sof_while_the_main_loop_is_busy_takes_effect_when_the_loop_runs() -> None:
    assert busy_loop_delays_the_swap(rig({"usb.phase_us": 999, "bridge.poll_cycles": 12000}, reads=30)) == []


def test_the_main_loop_does_not_take_an_sof_inside_its_handler() -> None:
    """URBSIM_MUTANT_THREAD_OVER_ISR: a main-loop iteration due at an instant when a handler runs
    (here the SOF's own, started at the iteration's instant) runs over it; the SOF is then taken
    before its handler returned (2.4 us after the device saw it, at seed 16)."""
    env = {k: v for k, v in os.environ.items() if k not in ("URBSIM_MUTANT", "URBSIM_SANITIZE")}
    env["URBSIM_MUTANT"] = "THREAD_OVER_ISR"
    code = ("import json, test_usb_device as t; r = t.rig({'usb.phase_us': 100}); "
            "print(json.dumps(t.sof_taken_by_the_main_loop(r, min_lag_ns=t.SOF_HANDLER_NS)))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=600,
                          cwd=Path(__file__).parent)
    assert proc.returncode == 0, proc.stderr
    found = json.loads(proc.stdout)
    assert found and all("taken" in v for v in found), found


def test_every_check_fails_for_a_device_that_answers_at_the_token() -> None:
    """URBSIM_MUTANT_USB_IN_AT_TOKEN: the swap at the SOF instant and the IN transfer filled at the
    token (the trace still names both, at those instants)."""
    env = {k: v for k, v in os.environ.items() if k not in ("URBSIM_MUTANT", "URBSIM_SANITIZE")}
    env["URBSIM_MUTANT"] = "USB_IN_AT_TOKEN"
    proc = subprocess.run([sys.executable, __file__], capture_output=True, text=True, env=env, timeout=900)
    assert proc.returncode == 0, proc.stderr
    found = json.loads(proc.stdout)
    assert list(found) == CHECKS
    assert all(found[name] for name in found), {n: v for n, v in found.items() if not v}


if __name__ == "__main__":
    print(json.dumps({name: found[:3] for name, found in violations().items()}))
