"""tools/proofs.py without ESBMC: the results contract, the summary merger, verdict parsing.

The merger is what makes `make proofs` fail, so it must reject a missing part, a malformed row and
any row whose result is not the expected one (a surviving mutant, a failed proof).
"""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from repo_tools import load_module

ROOT = Path(__file__).resolve().parents[2]


def _runner() -> ModuleType:
    return load_module("urb_tools_proofs", Path("tools/proofs.py"))


P = _runner()


def _write(out: Path, part: str, rows: list[dict[str, Any]]) -> None:
    P.write_part(part, rows, out)


def _good(out: Path) -> None:
    _write(out, "bmc", [
        P.make_row("urb_motor_command_decode", "ESBMC", "bounds", "unwind 9", "proved", True, 1.5, "", 400, 1080),
        P.make_row("urb_motor_command_decode [mutant field-offset]", "ESBMC", "seeded bug", "unwind 9", "killed", True, 2.0),
    ])
    _write(out, "framac", [P.make_row("urb_motor_command_decode", "Frama-C WP", "12/12 goals", "-wp-rte", "proved", True, 3.0)])
    _write(out, "fuzz", [P.make_row("urb_core decoders", "libFuzzer", "ASan+UBSan", "60 s", "no crash", True, 60.0)])


def test_merge_accepts_complete_expected_parts(tmp_path: Path) -> None:
    _good(tmp_path)
    status, problems = P.merge(["bmc", "framac", "fuzz"], tmp_path)
    assert (status, problems) == (0, [])
    md = (tmp_path / "summary.md").read_text(encoding="utf-8")
    assert "| function | tool | properties | bound | result | time (s) |" in md
    assert "| urb_motor_command_decode [mutant field-offset] | ESBMC |" in md
    # the cycle table is generated from the rows: 400 cycles at 48 MHz = 8.33 us, 37 % of 1080
    assert "| urb_motor_command_decode | 400 | 8.33 | 1080 | 37 % |" in md
    suites = ET.parse(tmp_path / "junit.xml").getroot()
    assert suites.tag == "testsuites"
    assert [s.get("name") for s in suites] == ["proofs.bmc", "proofs.framac", "proofs.fuzz"]
    assert sum(int(s.get("failures", "0")) for s in suites) == 0


def test_merge_rejects_a_missing_part(tmp_path: Path) -> None:
    _good(tmp_path)
    (tmp_path / "fuzz" / "summary.json").unlink()
    status, problems = P.merge(["bmc", "framac", "fuzz"], tmp_path)
    assert status == 1
    assert any("part fuzz" in p and "missing" in p and "make fuzz" in p for p in problems)
    assert "## Problems" in (tmp_path / "summary.md").read_text(encoding="utf-8")
    failures = [c for c in ET.parse(tmp_path / "junit.xml").getroot().iter("failure")]
    assert failures, "the merged JUnit fails too"


def test_merge_rejects_an_unexpected_row(tmp_path: Path) -> None:
    _good(tmp_path)
    _write(tmp_path, "bmc", [P.make_row("urb_get_le [mutant overrun]", "ESBMC", "seeded bug", "unwind 5", "SURVIVED",
                                        False, 2.0, "passed all 1 runs")])
    status, problems = P.merge(["bmc", "framac", "fuzz"], tmp_path)
    assert status == 1
    assert any("urb_get_le [mutant overrun]" in p and "SURVIVED" in p for p in problems)
    assert "**(unexpected)**" in (tmp_path / "summary.md").read_text(encoding="utf-8")


@pytest.mark.parametrize("breakage", ["no-expected", "string-expected", "wrong-part", "no-rows", "not-json"])
def test_merge_rejects_malformed_parts(tmp_path: Path, breakage: str) -> None:
    _good(tmp_path)
    path = tmp_path / "framac" / "summary.json"
    data = json.loads(path.read_text(encoding="utf-8"))
    if breakage == "no-expected":
        del data["rows"][0]["expected"]
    elif breakage == "string-expected":
        data["rows"][0]["expected"] = "true"
    elif breakage == "wrong-part":
        data["part"] = "bmc"
    elif breakage == "no-rows":
        data["rows"] = []
    path.write_text("{" if breakage == "not-json" else json.dumps(data), encoding="utf-8")
    status, problems = P.merge(["bmc", "framac", "fuzz"], tmp_path)
    assert status == 1 and any("part framac" in p for p in problems), problems


def test_summary_command_exit_status(tmp_path: Path) -> None:
    _good(tmp_path)
    assert P.main(["summary", "--out", str(tmp_path), "--parts", "bmc framac fuzz"]) == 0
    assert P.main(["summary", "--out", str(tmp_path), "--parts", "bmc,framac,fuzz,extra"]) == 1


def test_verdicts_come_only_from_esbmc_verdict_lines() -> None:
    ok = P.parse_esbmc("...\nVERIFICATION SUCCESSFUL\n", 1.0)
    assert ok.outcome == "pass"
    failed = P.parse_esbmc("Violated property:\n  file harness.c line 3 column 5 function harness\n  cost: within the "
                           "bus budget\n  x <= 5\n\n  urb_proof_cost_seen = 612 (0000)\nVERIFICATION FAILED\n", 1.0)
    assert (failed.outcome, failed.violated, failed.cost_seen) == ("fail", "cost: within the bus budget", 612)
    assert P.parse_esbmc("ERROR: Timed out\n", 1.0).outcome == "timeout"
    assert P.parse_esbmc("harness.c:3: error: unknown type\n", 1.0).outcome == "error"


def test_a_mutant_is_killed_only_by_a_verification_failure(tmp_path: Path) -> None:
    proof = P.Proof("urb_x", tmp_path, {"fast_sweep": "", "sweep": ""}, "purpose",
                    [{"name": "m", "why": "bug", "expect": "violated"}], None, "", 3)
    for outcome, result, expected in (("fail", "killed", True), ("pass", "SURVIVED", False),
                                      ("timeout", "TIMEOUT", False), ("error", "ERROR", False)):
        from concurrent.futures import Future
        done: Future[Any] = Future()
        done.set_result(P.Run("pass", 1.0))
        mutant: Future[Any] = Future()
        mutant.set_result([("", P.Run(outcome, 1.0, "violated"))])
        plan = P.Plan(proof, {"": done}, {"m": mutant})
        rows = P.collect(plan, "fast")
        assert rows[0]["result"] == "proved" and rows[0]["expected"]
        assert (rows[1]["result"], rows[1]["expected"]) == (result, expected)


def _mutant_row(mutant: dict[str, Any], run: Any, tmp_path: Path, item: str = "") -> dict[str, Any]:
    """The summary row of one mutant whose (last) run is `run`, as collect() judges it."""
    from concurrent.futures import Future
    proof = P.Proof("urb_x", tmp_path, {"fast_sweep": "", "sweep": ""}, "purpose", [mutant], None, "", 3)
    done: Future[Any] = Future()
    done.set_result(P.Run("pass", 1.0))
    tries: Future[Any] = Future()
    tries.set_result([(item, run)])
    rows = P.collect(P.Plan(proof, {"": done}, {mutant["name"]: tries}), "fast")
    row: dict[str, Any] = rows[1]
    return row


_LONG = ("Violated property:\n  file harness.c line 80 column 9 function harness\n  decode: a frame longer than the "
         "longest is LONG\n  length <= 6 || r == -2\n\nVERIFICATION FAILED\n")
_BUDGET = ("Violated property:\n  file harness.c line 66 column 5 function harness\n  cost: within the bus budget\n"
           "  urb_proof_cost_seen <= 540u\n\nVERIFICATION FAILED\n")


def test_a_mutant_is_killed_only_on_the_property_it_expects(tmp_path: Path) -> None:
    """A failure on the property the mutant's "expect" names is a kill; a failure on any other property
    (here the cost bound, for a bug the length contract should catch) is an unexpected weak kill."""
    mutant = {"name": "no-long-check", "why": "a frame with trailing bytes is accepted",
              "expect": "a frame longer than the longest is LONG"}
    killed = _mutant_row(mutant, P.parse_esbmc(_LONG, 1.0), tmp_path)
    assert (killed["result"], killed["expected"]) == ("killed", True)
    assert killed["detail"].endswith("run: decode: a frame longer than the longest is LONG")
    elsewhere = _mutant_row(mutant, P.parse_esbmc(_BUDGET, 1.0), tmp_path, "PART=1,LEN=32")
    assert (elsewhere["result"], elsewhere["expected"]) == ("KILLED ELSEWHERE", False)
    assert 'PART=1,LEN=32: failed on "cost: within the bus budget", expected "a frame longer than the longest is ' \
           'LONG"' in elsewhere["detail"], elsewhere["detail"]
    # a list of alternatives: any of them is a kill, and the detail names them all
    either = dict(mutant, expect=["array bounds violated", "cost: within the bus budget"])
    assert _mutant_row(either, P.parse_esbmc(_BUDGET, 1.0), tmp_path)["result"] == "killed"
    neither = _mutant_row(either, P.parse_esbmc(_LONG, 1.0), tmp_path)
    assert neither["result"] == "KILLED ELSEWHERE"
    assert 'expected "array bounds violated" or "cost: within the bus budget"' in neither["detail"]
    # the expect is matched against the violated property, not against the rest of the log
    assert _mutant_row(dict(mutant, expect="VERIFICATION FAILED"), P.parse_esbmc(_LONG, 1.0), tmp_path)["expected"] is False


@pytest.mark.parametrize("entry, ok", [
    ({"name": "m", "why": "w", "expect": "array bounds violated"}, True),
    ({"name": "m", "why": "w", "expect": ["a", "b"]}, True),
    ({"name": "m", "why": "w"}, False),
    ({"name": "m", "why": "w", "expect": ""}, False),
    ({"name": "m", "why": "w", "expect": []}, False),
    ({"name": "m", "why": "w", "expect": ["a", ""]}, False),
    ({"name": "m", "why": "w", "expect": 3}, False),
])
def test_mutant_entries_need_an_expect(entry: dict[str, Any], ok: bool) -> None:
    problem = P.mutant_problem(entry)
    assert (problem == "") == ok, problem
    if not ok:
        assert '"expect"' in problem and "proofs/README.md" in problem


def test_a_mutant_without_expect_is_a_broken_proof_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                          capsys: pytest.CaptureFixture[str]) -> None:
    """The runner refuses the folder before running anything (exit 2) and says what to add."""
    folder = tmp_path / "urb_x"
    folder.mkdir()
    for name in ("harness.c", "Makefile", "PURPOSE"):
        (folder / name).write_text("x\n", encoding="utf-8")
    (folder / "mutants.json").write_text(json.dumps([{"name": "off-by-one", "file": "gen/c/x.c", "function": "f",
                                                      "find": "<", "replace": "<=", "why": "reads past"}]),
                                         encoding="utf-8")
    with pytest.raises(P.SetupError, match=r"urb_x/mutants.json: mutant 'off-by-one' has no \"expect\": add"):
        P.load(folder, "fast")
    monkeypatch.setattr(P, "BMC_DIR", tmp_path)
    assert P.main(["--list"]) == 2
    assert "off-by-one' has no \"expect\"" in capsys.readouterr().err


def test_firmware_budgets_are_read_from_fw_budgets_h() -> None:
    # half an I2C fast-mode byte time (9 bits at 400 kb/s) at 48 MHz
    assert P.fw_budget("FW_I2C_EVENT_BUDGET") == 540
    assert P.fw_budget("NO_SUCH_BUDGET") is None


@pytest.mark.parametrize("why", ["", "Equivalent: the initial value is overwritten before any read."])
def test_an_unexplained_survivor_fails_the_summary(tmp_path: Path, why: str) -> None:
    """Seeded: a generated TLA+ mutant that survived without an explanation makes the merge (the end
    of `make proofs`, so of `make check`) fail, and the table counts it apart from the explained
    ones; the same survivor with an explanation passes, and its footnote gives the reason."""
    _good(tmp_path)
    (tmp_path / "mutation").mkdir()
    (tmp_path / "mutation" / "tlc.json").write_text(json.dumps({"mutants": [
        {"name": "MailboxInbox/Init/literal#9", "module": "MailboxInbox", "kind": "off-by-one", "killed": False,
         "explained": why},
        {"name": "MailboxInbox/Init/literal#1", "module": "MailboxInbox", "kind": "off-by-one", "killed": True,
         "explained": ""}]}), encoding="utf-8")
    status, problems = P.merge(["bmc", "framac", "fuzz"], tmp_path)
    md = (tmp_path / "summary.md").read_text(encoding="utf-8")
    if why:
        assert (status, problems) == (0, [])
        assert "off-by-one 1/2 (+1 explained: E1)" in md and "Unexplained survivors: 0." in md
        assert f"- **E1** TLC `MailboxInbox/Init/literal#9` (node mailbox, off-by-one in a bound): {why}" in md
    else:
        assert status == 1 and any("MailboxInbox/Init/literal#9" in p and "unexplained" in p for p in problems)
        assert "off-by-one 1/2 (**1 unexplained: U1**)" in md and "Unexplained survivors: 1 " in md
        assert "- **U1** TLC `MailboxInbox/Init/literal#9`" in md and "**UNEXPLAINED**" in md
        assert any(c.find("failure") is not None for c in ET.parse(tmp_path / "junit.xml").getroot().iter("testcase"))
