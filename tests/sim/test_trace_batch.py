"""Traces of several specifications in one TLC run (urb_sim.tracebatch): each trace gets the verdict,
matched prefix and state count a run of its own gives, and a corrupted trace among good ones is
rejected, named and stopped where its corruption is, while the good ones around it pass."""

from __future__ import annotations

import pytest

from urb_sim.tracebatch import TraceResult, batch_module, check_jobs, declared_variables
from urb_sim.tracecheck import Event, bridge_job, inbox_job, outbox_job

pytestmark = pytest.mark.usefixtures("tlc_installed")

PRESENT = {0x10: {1: 6}}


def _reads(n: int) -> list[Event]:
    out: list[Event] = []
    for seq in range(1, n + 1):
        out += [Event("req", 0x10, 1, "read", 6, seq), Event("resp", seq=seq, status=0)]
    return out


def _outbox(writes: int) -> list[dict[str, int | str]]:
    """Releases of writes 1..n, each read whole (6 bytes) by the bridge after it."""
    out: list[dict[str, int | str]] = []
    for w in range(1, writes + 1):
        byte: dict[str, int | str] = {"ev": "byte", "tag": w}
        out += [{"ev": "release"}, {"ev": "begin"}, *[byte] * 6, {"ev": "end"}]
    return out


def _inbox_write_read(value_write: int) -> list[dict[str, int | str]]:
    """A committed 2-byte write into buffer 1, then the application's lock, read and release of it."""
    return ([{"ev": "wbegin", "buf": 1}, {"ev": "wbyte", "index": 0}, {"ev": "wbyte", "index": 1}, {"ev": "commit"},
             {"ev": "lock", "buf": 1}, {"ev": "rbyte", "index": 0, "tag": value_write},
             {"ev": "rbyte", "index": 1, "tag": value_write}, {"ev": "release"}])


def _key(r: TraceResult) -> tuple[bool, int, int, int | None]:
    return r.accepted, r.events, r.matched_prefix, r.states


def test_one_run_gives_every_trace_its_own_verdict() -> None:
    corrupted = _reads(3)
    corrupted[3].seq = 3  # the second response names the third request: event 4 matches nothing
    jobs = [bridge_job(_reads(3), PRESENT, name="good bridge"),
            outbox_job(_outbox(2), 6, name="good outbox"),
            bridge_job(corrupted, PRESENT, name="corrupted bridge"),
            inbox_job(_inbox_write_read(1), 2, name="good inbox"),
            inbox_job(_inbox_write_read(0), 2, name="inbox read of a byte no write stored")]
    together = check_jobs(jobs)
    assert [r.batch for r in together] == [len(jobs)] * len(jobs)
    assert [r.accepted for r in together] == [True, True, False, True, False]
    assert together[2].matched_prefix == 3 and "matches up to event 3 of 6" in together[2].message
    assert together[4].matched_prefix == 5  # the read of byte 0 (event 6) is where it stops
    alone = [check_jobs([job])[0] for job in jobs]
    assert [_key(r) for r in together] == [_key(r) for r in alone]
    assert all(r.states is not None and r.states > 0 for r in together)


def test_the_batch_module_keeps_each_trace_in_its_own_states() -> None:
    """The witness that the traces do not mix: each instance's steps keep t, and the variables of the
    other specifications stay at their placeholder."""
    module, cfg = batch_module([bridge_job(_reads(1), PRESENT), outbox_job(_outbox(1), 6)])
    assert "T1 == INSTANCE TraceBridge WITH" in module and "T2 == INSTANCE TraceOutbox WITH" in module
    assert "(t = 1 /\\ T1!TraceNext /\\ t' = 1 /\\ UNCHANGED <<" in module
    assert "INVARIANTS Visited TypeOK" in cfg and "NoSilentDrop" in cfg and "IsrReadFresh" in cfg


def test_declared_variables_skip_comments() -> None:
    text = ("(* VARIABLE hidden *)\nVARIABLES a,   \\* first, with a comma\n  b \\* second\n\n"
            "Foo == 1\nVARIABLE c\n")
    assert declared_variables(text) == ["a", "b", "c"]
