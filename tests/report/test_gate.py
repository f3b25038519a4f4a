"""The report gate (report/urb_report/gate.py) on fixture records: it passes when every cited item
passed on this tree, and deleting any one test, proof or mutant a requirement relies on, or the
marker of a test, makes it fail with a message naming that requirement."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from urb_report import gate, markers, records, requirements
from urb_report.junit import cmocka_group_sources
from urb_report.records import ROOT, Item
from report_fixtures import baseline, catalogue, real_markers, state, write_records  # noqa: F401  (pytest fixtures)

WriteRecords = Any  # conftest.write_records: (drop=, verdicts=, skip_activities=, extra=) -> records


def _analyse(cat: requirements.Catalogue, recs: list[records.Record], state: dict[str, Any],
             marks: list[markers.Marker], baseline: dict[str, dict[str, object]],
             lobster_dir: Path | None = None) -> gate.Analysis:
    return gate.analyse(cat, recs, state, marks, baseline, lobster_dir, group_sources=cmocka_group_sources(),
                        html=False)


def _lines(a: gate.Analysis) -> list[str]:
    return [p.line() for p in a.problems]


def test_every_cited_item_passing_passes_the_gate_and_lobster(
        catalogue: requirements.Catalogue, real_markers: list[markers.Marker], baseline: dict[str, dict[str, object]],
        state: dict[str, Any], write_records: WriteRecords, tmp_path: Path) -> None:
    a = _analyse(catalogue, write_records(), state, real_markers, baseline, tmp_path / "lobster")
    assert a.ok, "\n".join(_lines(a)[:20])
    assert a.lobster is not None and a.lobster.ok
    assert all(a.requirement_status(r.tag) == "pass" for r in catalogue.requirements)


@pytest.mark.parametrize("evidence,requirement", [
    ("tlc-mutant:Bridge_DropWhenFull", "urb.ORD_001"),          # a must-fail mutant deleted
    ("tla:MailboxInbox.NoAbortedDelivered", "urb.MBX_008"),     # a TLA+ property no longer checked
    ("bmc:fw_node_pll_update", "urb.SYN_005"),                  # a proof folder deleted
    ("pytest:tests/host/test_seq_alias.py::test_default_lifetime_covers_the_firmware_worst_case", "urb.HOST_002"),
    ("cmocka:node_i2c/bad_check_nacked", "urb.CRC_004"),        # a cmocka test deleted
    ("sim:fig16/bounded-by-the-derived-frames", "urb.LAT_003"),       # a simulation criterion dropped
    ("wp:node_i2c/rx_byte", "urb.MEM_002"),
    ("fuzz-mutant:fuzz_node/node-commit-bad-check", "urb.CRC_004"),
])
def test_deleting_an_item_a_requirement_relies_on_fails_naming_it(
        evidence: str, requirement: str, catalogue: requirements.Catalogue, real_markers: list[markers.Marker],
        baseline: dict[str, dict[str, object]], state: dict[str, Any], write_records: WriteRecords) -> None:
    a = _analyse(catalogue, write_records(drop=[evidence]), state, real_markers, baseline)
    hits = [p for p in a.problems if p.requirement == requirement and evidence in p.message]
    assert hits and "missing" in hits[0].message, _lines(a)
    assert a.requirement_status(requirement) == "fail"


def test_a_requirement_left_without_any_result_is_untraced_for_lobster(
        catalogue: requirements.Catalogue, real_markers: list[markers.Marker], baseline: dict[str, dict[str, object]],
        state: dict[str, Any], write_records: WriteRecords, tmp_path: Path) -> None:
    req = catalogue.by_tag()["urb.LAT_005"]          # cites a single simulation criterion
    a = _analyse(catalogue, write_records(drop=req.verified_by), state, real_markers, baseline, tmp_path / "lob")
    assert a.lobster is not None and not a.lobster.ok
    trace = [p for p in a.problems if p.check == "trace"]
    assert [p.requirement for p in trace] == ["urb.LAT_005"], _lines(a)
    assert "missing reference to Verification" in trace[0].message


def test_an_activity_without_record_is_named_and_fails_every_requirement_citing_it(
        catalogue: requirements.Catalogue, real_markers: list[markers.Marker], baseline: dict[str, dict[str, object]],
        state: dict[str, Any], write_records: WriteRecords) -> None:
    a = _analyse(catalogue, write_records(skip_activities=["sim"]), state, real_markers, baseline)
    citing = {r.tag for r in catalogue.requirements if any(e.startswith("sim:") for e in r.verified_by)}
    named = {p.requirement for p in a.problems if "no record for activity sim" in p.message}
    assert named == citing and citing


def test_failed_and_erroneous_results_fail(catalogue: requirements.Catalogue, real_markers: list[markers.Marker],
                                           baseline: dict[str, dict[str, object]], state: dict[str, Any],
                                           write_records: WriteRecords) -> None:
    recs = write_records(verdicts={"tla:Bridge.NoSeqAliasing": "fail", "bmc:fw_bridge_fifo": "error"},
                         extra={"pytest": [Item(id="pytest:tests/x.py::test_uncited", kind="test", verdict="fail")]})
    a = _analyse(catalogue, recs, state, real_markers, baseline)
    lines = _lines(a)
    assert any(ln.startswith("urb.HOST_002 [evidence] tla:Bridge.NoSeqAliasing: fail") for ln in lines), lines
    assert any(ln.startswith("urb.ORD_001 [evidence] bmc:fw_bridge_fifo: error") for ln in lines), lines
    assert any("pytest:tests/x.py::test_uncited failed" in ln for ln in lines), lines


def test_a_record_of_another_commit_or_other_changes_is_stale(
        catalogue: requirements.Catalogue, real_markers: list[markers.Marker], baseline: dict[str, dict[str, object]],
        state: dict[str, Any], write_records: WriteRecords, tmp_path: Path) -> None:
    write_records()
    path = tmp_path / "evidence" / "tlc.json"
    data = json.loads(path.read_text())
    data["provenance"]["commit"] = "0" * 40
    path.write_text(json.dumps(data))
    a = _analyse(catalogue, records.read_records(tmp_path / "evidence"), state, real_markers, baseline)
    assert any(p.requirement == "urb.MBX_001" and "tla:MailboxOutbox.IsrWaitFree: stale" in p.message
               for p in a.problems)
    assert any(p.check == "record" and "tlc.json is stale" in p.message for p in a.problems)
    data["provenance"]["commit"] = state["commit"]
    data["provenance"]["changes"] = "someotheredit"
    path.write_text(json.dumps(data))
    a = _analyse(catalogue, records.read_records(tmp_path / "evidence"), state, real_markers, baseline)
    assert any("other uncommitted changes" in p.message for p in a.problems if p.requirement == "urb.MBX_001")


def _without_marker(marks: list[markers.Marker], rel: str, test: str) -> list[markers.Marker]:
    """The markers as a scan would find them after deleting `test`'s marker in a copy of `rel`."""
    lines = (ROOT / rel).read_text().splitlines()
    i = next(n for n, line in enumerate(lines) if f"def {test}(" in line or f"void {test}(" in line or
             line.startswith(f"{test} =="))
    while "lobster-trace:" not in lines[i]:
        i -= 1
    del lines[i]
    return [m for m in marks if m.file != rel] + markers.scan_text(rel, "\n".join(lines))


@pytest.mark.parametrize("rel,test,requirement", [
    ("tests/host/test_seq_alias.py", "test_default_lifetime_covers_the_firmware_worst_case", "urb.HOST_002"),
    ("tests/firmware/node/test_i2c.c", "bad_check_nacked", "urb.CRC_004"),
    ("spec/tla/Bridge.tla", "NoSilentDrop", "urb.ORD_001"),
])
def test_deleting_a_marker_from_a_copy_of_a_source_fails_naming_the_requirement(
        rel: str, test: str, requirement: str, catalogue: requirements.Catalogue, real_markers: list[markers.Marker],
        baseline: dict[str, dict[str, object]], state: dict[str, Any], write_records: WriteRecords) -> None:
    marks = _without_marker(real_markers, rel, test)
    assert len(marks) < len(real_markers)
    a = _analyse(catalogue, write_records(), state, marks, baseline)
    hits = [p for p in a.problems if p.requirement == requirement and p.check == "marker"]
    assert hits and test in hits[0].message and f"lobster-trace: {requirement}" in hits[0].message, _lines(a)


def test_a_marker_citing_an_unknown_requirement_or_an_uncited_item_fails(
        catalogue: requirements.Catalogue, real_markers: list[markers.Marker], baseline: dict[str, dict[str, object]],
        state: dict[str, Any], write_records: WriteRecords) -> None:
    extra = markers.scan_text("tests/host/test_fake.py", "# lobster-trace: urb.NOPE_001\ndef test_a():\n    pass\n"
                                                          "# lobster-trace: urb.MBX_001\ndef test_b():\n    pass\n")
    a = _analyse(catalogue, write_records(), state, [*real_markers, *extra], baseline)
    lines = _lines(a)
    assert any(ln.startswith("urb.NOPE_001 [marker] tests/host/test_fake.py:1 cites urb.NOPE_001, which is no "
                             "requirement") for ln in lines), lines
    assert any(ln.startswith("urb.MBX_001 [marker] tests/host/test_fake.py:4 marks "
                             "pytest:tests/host/test_fake.py::test_b as verifying urb.MBX_001") for ln in lines), lines


def test_implementation_markers_belong_to_one_function_each(
        catalogue: requirements.Catalogue, real_markers: list[markers.Marker], baseline: dict[str, dict[str, object]],
        state: dict[str, Any], write_records: WriteRecords) -> None:
    impl = [m for m in real_markers if not m.is_activity]
    assert {m.file.split("/")[1] for m in impl if m.file.startswith("firmware/")} >= {"node", "bridge"}
    assert any(m.file.startswith("host/urb/") for m in impl)
    stray = markers.scan_text("firmware/node/urb_fake.c", "/* lobster-trace: urb.MBX_001 */\nstatic int x;\n\n"
                                                          "/* lobster-trace: urb.MBX_002 */\nvoid f(void)\n{\n"
                                                          "    /* lobster-trace: urb.MBX_002 */\n}\n")
    a = _analyse(catalogue, write_records(), state, [*real_markers, *stray], baseline)
    assert {(p.requirement, "no function" in p.message, "twice" in p.message) for p in a.problems} == {
        ("urb.MBX_001", True, False), ("urb.MBX_002", False, True)}, _lines(a)


def test_uncovered_lines_and_misra_findings_without_reason_fail_naming_the_requirement(
        catalogue: requirements.Catalogue, real_markers: list[markers.Marker], baseline: dict[str, dict[str, object]],
        state: dict[str, Any], write_records: WriteRecords) -> None:
    recs = write_records(extra={
        "coverage": [Item(id="coverage:firmware/node/urb_i2c.c", kind="coverage", verdict="fail",
                          measured="line 120 and decision 133:1 uncovered, no justification")],
        "misra": [Item(id="misra:15.5@firmware/node/urb_i2c.c:88", kind="finding", verdict="fail",
                       measured="new finding, no deviation record")]})
    a = _analyse(catalogue, recs, state, real_markers, baseline)
    review = [p for p in a.problems if p.check == "review"]
    assert {p.requirement for p in review} == {"urb.MEM_005", "urb.MEM_004"}, _lines(a)
    assert any("line 120" in p.message and "justification" in p.message for p in review)
    assert any("misra:15.5@firmware/node/urb_i2c.c:88" in p.message and "deviation" in p.message for p in review)


def test_every_requirement_of_the_old_tla_table_is_migrated(catalogue: requirements.Catalogue) -> None:
    """Every TLC mutant and the property it covers are cited by some requirement (spec/tla/manifest.json)."""
    cited = {e for r in catalogue.requirements for e in r.verified_by}
    manifest = json.loads((ROOT / "spec" / "tla" / "manifest.json").read_text())
    for m in manifest["mutants"]:
        assert f"tlc-mutant:{m['name']}" in cited, m["name"]
        if m["covers"] not in ("Bridge.DistinctIds", "Bridge.IdsInOrder"):   # MCBridge's ASSUME FormsAgree
            assert f"tla:{m['covers']}" in cited, m["covers"]
    readme = (ROOT / "spec" / "tla" / "README.md").read_text()
    assert "spec/requirements" in readme.split("## Requirements", 1)[1][:600]
    table = readme.split("<!-- requirements:begin", 1)[1].split("<!-- requirements:end -->", 1)[0]
    rows = [ln.split("|")[1:-1] for ln in table.splitlines() if ln.startswith("| ") and "`" in ln]
    assert len(rows) == len({m["covers"] for m in manifest["mutants"]})
    by_tag = catalogue.by_tag()
    for _, _, mutants, reqs in rows:
        for tag in reqs.replace("`", "").split(","):
            cites = by_tag[tag.strip()].verified_by
            assert any(f"tlc-mutant:{m.strip(' `')}" in cites for m in mutants.split(",")), (tag, mutants)


def test_the_gate_is_a_fresh_check_of_this_tree(catalogue: requirements.Catalogue,
                                                real_markers: list[markers.Marker],
                                                baseline: dict[str, dict[str, object]],
                                                write_records: WriteRecords) -> None:
    """Records pass only against the tree state they were written on."""
    recs = write_records()
    a = _analyse(catalogue, recs, {"commit": "f" * 40, "clean": True, "changes": ""}, real_markers, baseline)
    assert not a.ok and all(p.check in ("evidence", "record") for p in a.problems)


def test_urb_report_gate_exits_non_zero_naming_the_requirement_of_a_deleted_item(
        write_records: WriteRecords, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """End to end, as `make report-gate` runs it (the same records with every item pass the gate in
    test_every_cited_item_passing_passes_the_gate_and_lobster): without one bounded-model-checking
    proof it exits 1 with a line naming the requirement, the item and the make target that writes it."""
    from urb.cli import main

    write_records(drop=["bmc:fw_node_pll_update"])
    args = ["report", "--gate", "--no-pdf", "--evidence", str(tmp_path / "evidence"), "--out", str(tmp_path / "out")]
    assert main(args) == 1
    out = capsys.readouterr().out
    assert "GATE FAIL urb.SYN_005 [evidence] bmc:fw_node_pll_update: missing: no item with this id" in out, out[-3000:]
    assert "report gate: FAILED" in out and "urb.SYN_005" in out.splitlines()[-1]
