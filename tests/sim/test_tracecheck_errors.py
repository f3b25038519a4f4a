"""A TLC run that does not finish (killed, out of memory, an error in a specification) is neither an
accepted nor a rejected trace: it raises TraceCheckError, so a crashed check can never pass as a
rejected mutant. TLC is replaced by a script that behaves like the failing run."""

from __future__ import annotations

import stat
from pathlib import Path

import pytest

from urb_sim import tracebatch
from urb_sim.tracecheck import Event, TraceCheckError, check_bridge, check_inbox, check_outbox

TRACE = [Event("req", addr=0x10, box=1, op="read", length=6, seq=1),
         Event("resp", addr=0x10, box=1, op="read", length=6, seq=1, status=0)]

#: What the fake TLC prints before it stops, and how it stops.
KILLED = 'echo \'<<"visited", 1, 1>>\'; kill -9 $$'
SPEC_ERROR = "echo 'Error: Parsing or semantic analysis failed.'; exit 150"
FINISHED = "echo 'Model checking completed. No error has been found.'; exit 0"
#: The batch module prints every new state's trace and matched prefix; a full match violates nothing.
FINISHED_ALL_MATCHED = ("echo '<<\"visited\", 1, 0>>'; echo '<<\"visited\", 1, 1>>'; echo '<<\"visited\", 1, 2>>'; "
                        "echo 'Model checking completed. No error has been found.'; exit 0")
#: An invariant of the specification violated on the way: neither accepted nor rejected.
INVARIANT = ("echo '<<\"visited\", 1, 2>>'; echo 'Error: Invariant AppReadNotTorn is violated.'; "
             "echo 'State 1: <Initial predicate>'; echo '/\\ t = 1'; exit 12")


def _fake_tlc(monkeypatch: pytest.MonkeyPatch, tmp_path: Path, body: str) -> None:
    java = tmp_path / "java"
    java.write_text("#!/bin/sh\n" + body + "\n")
    java.chmod(java.stat().st_mode | stat.S_IEXEC)
    monkeypatch.setattr(tracebatch, "find_tlc", lambda: (str(java), tmp_path / "tla2tools.jar"))


@pytest.mark.parametrize("body, cause", [(KILLED, "killed by signal 9"), (SPEC_ERROR, "Parsing or semantic"),
                                         (INVARIANT, r"in trace 1 of 1 \(Trace\w+\): Error: Invariant AppReadNotTorn "
                                                     "is violated")],
                         ids=["killed", "spec-error", "invariant"])
def test_a_check_that_does_not_finish_is_an_error(monkeypatch: pytest.MonkeyPatch, tmp_path: Path, body: str,
                                                  cause: str) -> None:
    _fake_tlc(monkeypatch, tmp_path, body)
    for check in (lambda: check_bridge(TRACE, {0x10: {1: 6}}),
                  lambda: check_outbox([{"ev": "release"}], 4),
                  lambda: check_inbox([{"ev": "wnack"}], 4)):
        with pytest.raises(TraceCheckError, match=cause):
            check()


def test_finished_runs_give_a_verdict(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    _fake_tlc(monkeypatch, tmp_path, FINISHED)
    assert not check_bridge(TRACE, {0x10: {1: 6}}).accepted
    assert not check_outbox([{"ev": "release"}], 4).accepted
    _fake_tlc(monkeypatch, tmp_path, FINISHED_ALL_MATCHED)
    for check in (lambda trace: check_bridge(trace, {0x10: {1: 6}}),
                  lambda trace: check_outbox([{"ev": "release"}] * len(trace), 4),
                  lambda trace: check_inbox([{"ev": "wnack"}] * len(trace), 4)):
        r = check(TRACE)
        assert r.accepted and r.matched_prefix == len(TRACE) and r.states == 3
        r = check(TRACE + TRACE)  # the same run is 2 of 4 events for a longer trace
        assert not r.accepted and r.matched_prefix == 2 and "up to event 2 of 4" in r.message
