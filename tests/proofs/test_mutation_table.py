"""The mutation score table of build/proofs/summary.md (report/urb_report/mutation.py), on crafted
results: tools without results show "not run" (never 0/0), mutants without a kind count as
"other", every tool's mutants land in the component of the code they change, and an unexplained
survivor of any tool is a problem that fails the summary."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from urb_report import mutation
from urb_report.records import read_record


def _write(path: Path, data: Any) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data), encoding="utf-8")


def _results(root: Path) -> Path:
    out = root / "proofs"
    _write(out / "bmc" / "summary.json", {"part": "bmc", "rows": [
        {"function": "fw_mailbox_inbox [mutant no-nack]", "result": "killed"},
        {"function": "fw_bridge_fifo", "result": "proved"}]})
    _write(out / "framac" / "summary.json", {"part": "framac", "rows": [
        {"function": "fifo mutant slot_wrap_off_by_one", "result": "killed", "file": "firmware/bridge/bridge.c",
         "mutated_function": "slot_index", "kind": "off-by-one"},
        {"function": "mailbox mutant commit_without_fresh", "result": "SURVIVED", "file": "firmware/node/urb_mailbox.c",
         "mutated_function": "urb_isr_write_commit", "kind": "missing publish or free"}]})
    _write(out / "mutation" / "c.json", {"mutants": [
        {"id": "urb_i2c:f:ror:1", "component": "node I2C", "kind": "off-by-one", "result": "killed"},
        {"id": "urb_i2c:f:swap:1", "component": "node I2C", "kind": "order", "result": "survived",
         "explained": "the two stores are to unrelated locals"},
        {"id": "urb_i2c:f:swap:2", "component": "node I2C", "kind": "order", "result": "stillborn"}]})
    return out


def test_cells_kinds_components_and_missing_tools(tmp_path: Path) -> None:
    found = mutation.load(_results(tmp_path))
    assert set(found.missing) == {"TLC", "fuzzing"}
    by = {(s.tool, s.name): s for s in found.seeded}
    assert by[("ESBMC", "fw_mailbox_inbox/no-nack")].component == "node mailbox"
    assert by[("ESBMC", "fw_mailbox_inbox/no-nack")].kind in mutation.KINDS  # from mutants.json, or "other"
    assert by[("Frama-C", "fifo/slot_wrap_off_by_one")].component == "bridge FIFO"
    assert by[("Frama-C", "mailbox/commit_without_fresh")].kind == "missing-effect"
    assert ("unit tests", "urb_i2c:f:swap:2") not in by, "a mutant that does not compile is not counted"
    md = "\n".join(mutation.markdown(found))
    # each survivor is named in its cell by a footnote label, explained (E) and unexplained (U) apart
    assert "| node I2C | not run | - | - | not run | off-by-one 1/1<br>order 0/1 (+1 explained: E1) |" in md
    assert ("| node mailbox | not run | error 1/1 | publish/free 0/1 (**1 unexplained: U1**) | not run | - |"
            in md)
    assert "0/0" not in md
    assert found.problems == ["mutation table: Frama-C mutant mailbox/commit_without_fresh (node mailbox, missing "
                              "publish or free) survived unexplained: SURVIVED"]
    # ... and the footnote under the table says why it is acceptable, or that it is not
    assert ("- **E1** unit tests `urb_i2c:f:swap:1` (node I2C, wrong order): the two stores are to unrelated locals"
            in md)
    assert "- **U1** Frama-C `mailbox/commit_without_fresh` (node mailbox, missing publish or free): **UNEXPLAINED**" in md
    assert "Unexplained survivors: 1 (each is a problem: the summary fails)." in md
    assert "unit tests 1/2 killed, 1 explained, 0 unexplained" in md and "Frama-C 1/2 killed, 0 explained, 1 unexplained" in md


def test_footnote_labels_of_many_survivors_are_ranges() -> None:
    found = mutation.Loaded([mutation.Seeded("TLC", f"M/A/literal#{i}", "node mailbox", "off-by-one", False,
                                             explained=f"why {i}") for i in range(1, 5)]
                            + [mutation.Seeded("TLC", "M/B/swap#1", "node mailbox", "order", False)])
    md = "\n".join(mutation.markdown(found))
    assert "off-by-one 0/4 (+4 explained: E1–E4)<br>order 0/1 (**1 unexplained: U1**)" in md
    assert [line.split(" ", 2)[1] for line in md.splitlines() if line.startswith("- **")] == [
        "**U1**", "**E1**", "**E2**", "**E3**", "**E4**"]
    assert mutation._labels([1, 2, 3, 5, 7, 8], "E") == "E1–E3, E5, E7–E8"


def test_tlc_results_and_a_malformed_file(tmp_path: Path) -> None:
    out = _results(tmp_path)
    _write(out / "mutation" / "tlc.json", {"mutants": [
        {"name": "Bridge_ServeAny", "module": "Bridge", "kind": "wrong order", "killed": True},
        {"name": "Inbox_NoUnclaim", "module": "MailboxInbox", "killed": False, "explained": "stutter-equivalent"}]})
    found = mutation.load(out)
    tlc = {s.name: s for s in found.seeded if s.tool == "TLC"}
    assert (tlc["Bridge_ServeAny"].component, tlc["Bridge_ServeAny"].kind) == ("bridge FIFO", "order")
    assert (tlc["Inbox_NoUnclaim"].component, tlc["Inbox_NoUnclaim"].kind) == ("node mailbox", "other")
    assert "TLC" not in found.missing
    _write(out / "mutation" / "tlc.json", [1, 2])
    found = mutation.load(out)
    assert found.missing["TLC"].startswith("unreadable") and any("tlc.json" in p for p in found.problems)


def test_the_summary_section_writes_the_evidence_record(tmp_path: Path) -> None:
    problems: list[str] = []
    md = mutation.summary_section(_results(tmp_path), problems, tmp_path / "evidence")
    assert md[0] == "## Mutation score" and len(problems) == 1
    record = read_record(tmp_path / "evidence" / "mutation.json")
    items = {i.id: i for i in record.items}
    assert items["mutation:node mailbox/Frama-C"].verdict == "fail"
    assert items["mutation:node I2C/unit tests"].data["kinds"]["order"] == {"killed": 0, "explained": 1, "total": 1}
    assert items["c-mutant:urb_i2c:f:swap:1"].verdict == "pass"
    assert record.config["sources"]["TLC"].startswith("not run")


def test_components_name_every_mutated_file_once_per_function() -> None:
    for comp in mutation.COMPONENTS:
        for path in comp.files():
            assert (mutation.ROOT / path).is_file(), path
    assert mutation.component_of("firmware/bridge/bridge.c", "admit") == "bridge FIFO"
    assert mutation.component_of("firmware/bridge/bridge.c", "scan_done") == "bridge discovery"
    assert mutation.component_of("firmware/bridge/bridge.c", "urb_bridge_poll") == "bridge, other"
    assert mutation.component_of("firmware/node/urb_node.c", "run_command") == "inbox-0 commands"
    assert mutation.kind_of(None) == "other" and mutation.kind_of("Off-by-one") == "off-by-one"


def test_results_without_mutants_are_not_a_zero(tmp_path: Path) -> None:
    """A part run without its mutants (--no-mutants) has results but no seeded bug: its cells say
    so, and the totals do not print 0/0."""
    out = _results(tmp_path)
    _write(out / "framac" / "summary.json", {"part": "framac", "rows": [{"function": "f", "result": "proved"}]})
    found = mutation.load(out)
    assert found.missing["Frama-C"].startswith("no mutant")
    md = "\n".join(mutation.markdown(found))
    assert "Frama-C 0/0" not in md and "| no mutant in its results |" in md
