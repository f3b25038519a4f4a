"""TraceInbox.tla on hand-written inbox traces: the matching of each logged event to its
MailboxInbox action, including the outcomes the simulation never produces (its application runs
between interrupts, so a write is never NACKed and a lock never gives up), and the provenance tags
of inbox_trace."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from urb_sim.experiments.traces import aborted_visible, torn_read
from urb_sim.tracecheck import check_inbox, inbox_trace

Ev = dict[str, int | str]


def _write(buf: int, size: int, end: str = "commit") -> list[Ev]:
    out: list[Ev] = [{"ev": "wbegin", "buf": buf}]
    return out + [{"ev": "wbyte", "index": k} for k in range(size)] + [{"ev": end}]


def _read(buf: int, tags: list[int]) -> list[Ev]:
    out: list[Ev] = [{"ev": "lock", "buf": buf}]
    return out + [{"ev": "rbyte", "index": k, "tag": t} for k, t in enumerate(tags)] + [{"ev": "release"}]


pytestmark = pytest.mark.usefixtures("tlc_installed")


# lobster-trace: urb.MBX_009
def test_nack_while_the_application_holds_the_other_buffer() -> None:
    # the app locks buffer 0; write 1 fills and commits buffer 1; write 2 would fill buffer 0,
    # which the app still holds: NACKed; the app still reads the zeroed setup (tag 0)
    lock: list[Ev] = [{"ev": "lock", "buf": 0}]
    rest: list[Ev] = [{"ev": "wnack"}, {"ev": "rbyte", "index": 0, "tag": 0}, {"ev": "rbyte", "index": 1, "tag": 0},
                      {"ev": "release"}]
    trace = lock + _write(1, 2) + rest + _read(1, [1, 1])
    assert check_inbox(trace, 2).accepted


def test_nack_without_a_reason_is_rejected() -> None:
    # at power-on front is 0: a lock can only claim buffer 0, so a write to buffer 1 is never refused
    assert not check_inbox([{"ev": "wnack"}], 2).accepted


# lobster-trace: urb.MBX_008
def test_reads_follow_commits_and_skip_aborts() -> None:
    ok = _write(1, 2) + _read(1, [1, 1]) + _write(0, 1, "abort") + _read(1, [1, 1])
    assert check_inbox(ok, 2).accepted
    assert not check_inbox(_write(1, 2) + _read(1, [1, 1]) + _write(0, 1, "abort") + _read(0, [2, 0]), 2).accepted
    assert not check_inbox(_write(0, 2), 2).accepted  # a write into the front buffer (single buffering)


# lobster-trace: urb.MBX_010
def test_busy_only_after_every_retry() -> None:
    assert not check_inbox([{"ev": "busy"}], 2).accepted  # nothing stops the first attempt
    assert not check_inbox([{"ev": "lock_error"}], 2).accepted  # a misused lock is no spec behaviour


def test_provenance_tags_and_mutants(tmp_path: Path) -> None:
    dev = "usb0/n16"
    def store(buf: int, value: int, end: str) -> list[dict[str, object]]:
        return ([{"ev": "wbegin", "buf": buf}] + [{"ev": "wbyte", "index": k, "value": value} for k in range(2)]
                + [{"ev": end}])

    def read(buf: int, values: list[int]) -> list[dict[str, object]]:
        return ([{"ev": "lock", "buf": buf, "new": 0}] + [{"ev": "rbyte", "index": k, "value": v}
                                                          for k, v in enumerate(values)] + [{"ev": "in_release"}])

    lines = read(0, [0, 0]) + store(1, 7, "commit") + read(1, [7, 7]) + store(0, 9, "abort") + read(1, [7, 8])
    path = tmp_path / "t.ndjson"
    path.write_text("".join(json.dumps({"t": i, "cat": "mailbox", "dev": dev, **e}, separators=(",", ":")) + "\n"
                            for i, e in enumerate(lines)))
    ev = inbox_trace(path, dev)
    assert [e.get("tag") for e in ev if e["ev"] == "rbyte"] == [0, 0, 1, 1, 1, -1]  # 8 was never stored there
    ev[-2]["tag"] = 1
    assert check_inbox(ev, 2).accepted
    seeded = aborted_visible(ev)
    assert [e.get("buf") for e in seeded if e["ev"] == "lock"] == [0, 1, 0]
    assert not check_inbox(seeded, 2).accepted
    torn = torn_read(ev)
    assert [e.get("tag") for e in torn if e["ev"] == "rbyte"] != [e.get("tag") for e in ev if e["ev"] == "rbyte"]
    assert not check_inbox(torn, 2).accepted
    with pytest.raises(ValueError):
        aborted_visible([e for e in ev if e["ev"] != "abort"])
    with pytest.raises(ValueError):
        check_inbox(ev, 1)  # MailboxInbox.tla needs messages of 2 bytes or more (tearing observable)
