"""Same seed, same trace byte for byte; another seed, another trace (issue 6: determinism).

Two runs of a seed must agree both in one process (no state outlives a world: the library has no
globals) and in two processes (nothing depends on the process: its id, addresses, environment).
Each comparison is shown to fail for a seeded bug that only it catches, built into its own
library variant (URBSIM_MUTANT, sim/urb_sim/build.py):
  SHARED_JITTER  one interrupt-latency stream for every clock of the process (sim/core/clock.c)
  PID_SEED       the process id salts the world's seed (sim/world/world.c)

    python3 tests/sim/test_determinism.py SEED RUNS   # RUNS runs of SEED here, as JSON
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from urb_sim import profiles
from urb_sim.native import App, Trace
from urb_sim.system import Loop, System

NS_PER_MS = 1_000_000
Run = tuple[int, int, int]  #: trace hash, trace lines, events


def run(seed: int, trace: Path | None = None, profile: str | None = None) -> Run:
    """A small two-bridge system with host traffic for 150 ms, under hardware `profile` (None: the
    parameters' defaults); returns (hash, lines, events)."""
    with profiles.applied(profiles.load(profile) if profile else None):
        return _run(seed, trace)


def _run(seed: int, trace: Path | None) -> Run:
    s = System(seed=seed, probe_out=4)
    rs = s.bridge("rs232")
    usb = s.bridge("usb")
    s.node(rs, App.PROBE, 0x10, 0)
    s.node(usb, App.PROBE, 0x20, 1)
    s.node(usb, App.PROBE, 0x21, 2)
    s.world.trace(trace, Trace.ALL)
    s.start()
    nodes = [s.urb.find_node(0x7E, i) for i in range(3)]

    def tick() -> None:
        for n in nodes:
            n.submit_request(n.new_request().read(1, 4))

    Loop(s.host, NS_PER_MS, tick, count=100)
    s.host.advance(150 * NS_PER_MS)
    s.world.flush_trace()
    out = (s.world.trace_hash, s.world.trace_lines, s.world.events)
    s.close()
    return out


def test_same_seed_same_trace_bytes(tmp_path: Path) -> None:
    a, b = tmp_path / "a.ndjson", tmp_path / "b.ndjson"
    ha = run(7, a)
    hb = run(7, b)
    assert ha == hb
    assert hashlib.sha256(a.read_bytes()).digest() == hashlib.sha256(b.read_bytes()).digest()
    assert ha[1] > 5_000  # the trace really covers the bus traffic


def test_other_seed_other_trace() -> None:
    assert run(7)[0] != run(8)[0]


def test_hash_does_not_depend_on_writing_the_file(tmp_path: Path) -> None:
    assert run(3)[0] == run(3, tmp_path / "t.ndjson")[0]


@pytest.mark.parametrize("profile", ["cortex-m0plus", "paper"])
def test_same_seed_same_trace_per_profile(profile: str, tmp_path: Path) -> None:
    """Each hardware profile is deterministic too, in this process and in another one."""
    a, b = tmp_path / "a.ndjson", tmp_path / "b.ndjson"
    first = run(7, a, profile)
    assert run(7, b, profile) == first
    assert a.read_bytes() == b.read_bytes()
    assert runs_in_a_new_process(7, 1, profile=profile) == [first]


def test_a_profile_changes_the_world() -> None:
    """Witness that the profiles reach the model: the Cortex-M0+ profile's edges, masked sections and
    wait states change the trace from the defaults', and its per-node draws differ by seed."""
    ideal, m0 = run(7), run(7, profile="cortex-m0plus")
    assert ideal[0] != m0[0]
    assert run(8, profile="cortex-m0plus")[0] != m0[0]


def runs_in_a_new_process(seed: int, runs: int, mutant: str | None = None, profile: str | None = None) -> list[Run]:
    """`runs` runs of `seed`, one after the other in a new Python process, with the library built
    with the seeded bug `mutant` (None: the real library)."""
    env = {k: v for k, v in os.environ.items() if k not in ("URBSIM_MUTANT", "URBSIM_SANITIZE")}
    if mutant is not None:
        env["URBSIM_MUTANT"] = mutant
    proc = subprocess.run([sys.executable, __file__, str(seed), str(runs), profile or ""], capture_output=True,
                          text=True, env=env, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return [(h, lines, events) for h, lines, events in json.loads(proc.stdout)]


def test_same_seed_same_trace_in_another_process() -> None:
    """This process has run other worlds before; the new one has not."""
    assert runs_in_a_new_process(7, 1) == [run(7)]


def test_state_shared_between_worlds_is_caught_in_one_process() -> None:
    first, second = runs_in_a_new_process(7, 2, "SHARED_JITTER")
    assert first != second  # what test_same_seed_same_trace_bytes compares
    # ...and only there: every new process starts the shared stream from the same state.
    assert runs_in_a_new_process(7, 1, "SHARED_JITTER") == [first]


def test_a_dependence_on_the_process_is_caught_across_processes() -> None:
    first, second = runs_in_a_new_process(7, 2, "PID_SEED")
    assert first == second  # one process cannot see it...
    assert runs_in_a_new_process(7, 1, "PID_SEED") != [first]  # ...another process does


if __name__ == "__main__":
    seed, runs = int(sys.argv[1]), int(sys.argv[2])
    chosen = sys.argv[3] if len(sys.argv) > 3 and sys.argv[3] else None
    print(json.dumps([run(seed, profile=chosen) for _ in range(runs)]))
