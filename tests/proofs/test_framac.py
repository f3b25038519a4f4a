"""Frama-C proofs (proofs/framac/, tools/proofs_framac.py).

Layout checks run without Frama-C: every unit folder is complete, its mutant still applies to the
current sources, its expected counts hold 100 % of the WP goals, and every recorded Eva alarm is
explained in eva_alarms.md. The runner's verdicts are checked on crafted reports (a count that
moves, an unproved goal, a new or vanished alarm must each fail). The end-to-end test replays the
committed WP cache offline for the generated runtime and its mutant: the unit must prove, the
mutant must be rejected, and a missing cache entry fails instead of silently running provers.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from repo_tools import load_module

ROOT = Path(__file__).resolve().parents[2]
UNITS = ROOT / "proofs" / "framac"
FOLDERS = sorted(p.parent for p in UNITS.glob("*/unit.json"))


def _runner() -> ModuleType:
    return load_module("proofs_framac", Path("tools/proofs_framac.py"))


RUNNER = _runner()


def _unit(name: str) -> Any:
    return RUNNER.load_unit(UNITS / name)


def test_units_cover_the_codecs_the_mailbox_and_the_fifo() -> None:
    names = {p.name for p in FOLDERS}
    assert {"gen_runtime", "gen_core", "gen_sensorhex", "mailbox", "fifo"} <= names
    assert any(n.startswith("eva_node_") for n in names)


@pytest.mark.parametrize("folder", FOLDERS, ids=[f.name for f in FOLDERS])
def test_unit_folder_is_complete(folder: Path) -> None:
    unit = RUNNER.load_unit(folder)  # PURPOSE is one line, sources exist, mutant names unique
    assert (folder / "expected.json").is_file(), "record it with tools/proofs_framac.py --record"
    assert unit.mutants, "every unit needs a seeded mutant that the same run must reject"
    for mutant in unit.mutants:
        for key in ("name", "why", "file", "find", "replace"):
            assert mutant.get(key), f"mutant.{key} missing"
        text = (ROOT / mutant["file"]).read_text(encoding="utf-8")
        assert text.count(mutant["find"]) == 1, f"mutant {mutant['name']} no longer applies to the current source"
        assert mutant["find"] != mutant["replace"]


@pytest.mark.parametrize("folder", [f for f in FOLDERS if json.loads((f / "unit.json").read_text())["tool"] == "wp"],
                         ids=lambda f: f.name)
def test_wp_expectations_are_complete_proofs(folder: Path) -> None:
    expected = json.loads((folder / "expected.json").read_text())["functions"]
    assert expected, "no function recorded"
    for fn, counts in expected.items():
        assert counts["total"] > 0, fn
        assert counts["proved"] == counts["total"], f"{fn}: expected.json records an incomplete proof"


def test_generated_codecs_are_all_under_wp() -> None:
    """Every function defined in gen/c has a WP row: a new message cannot slip past the proofs."""
    import re

    recorded: set[str] = set()
    for name in ("gen_runtime", "gen_core", "gen_sensorhex", "gen_downlinks"):
        recorded |= set(json.loads((UNITS / name / "expected.json").read_text())["functions"])
    defined = set()
    for src in (ROOT / "gen" / "c").glob("*.c"):
        defined |= set(re.findall(r"^\w[\w\s\*]*?\b(urb_\w+)\(", src.read_text(encoding="utf-8"), re.MULTILINE))
    assert defined and defined <= recorded, f"without WP results: {sorted(defined - recorded)}"


def test_recorded_eva_alarms_are_reviewed() -> None:
    reviewed = RUNNER.read_alarm_list()
    for folder in FOLDERS:
        if json.loads((folder / "unit.json").read_text())["tool"] != "eva":
            continue
        alarms = json.loads((folder / "expected.json").read_text())["alarms"]
        missing = [a for a in alarms if a not in reviewed]
        assert not missing, f"{folder.name}: explain these in proofs/framac/eva_alarms.md: {missing}"


# ----------------------------------------------------------------------------- verdicts


def _wp_run(functions: dict[str, tuple[int, int]]) -> Any:
    report: dict[str, Any] = {"wp:functions": {}}
    for fn, (valid, total) in functions.items():
        props = {"wp:section": {"wp:main": {"total": total, "valid": valid}}}
        props[f"{fn}_ensures"] = {"wp:main": {"total": total, "valid": valid}}
        report["wp:functions"][fn] = props
    return RUNNER.FramacRun(True, 1.0, "[wp] [Qed] Goal typed_f_ensures : Valid (12ms)\n", report)


def _wp_unit(expected: dict[str, tuple[int, int]]) -> Any:
    unit = _unit("gen_runtime")
    unit.expected = {"functions": {f: {"proved": p, "total": t} for f, (p, t) in expected.items()}}
    return unit


def test_wp_verdicts() -> None:
    unit = _wp_unit({"f": (3, 3)})
    rows, _ = RUNNER.check_wp(unit, _wp_run({"f": (3, 3)}), record=False, cache="update")
    assert [r.result for r in rows] == ["proved"] and rows[0].expected
    assert rows[0].time_s == pytest.approx(0.012)
    rows, _ = RUNNER.check_wp(unit, _wp_run({"f": (2, 3)}), record=False, cache="update")
    assert rows[0].result == "UNPROVED" and not rows[0].expected and "f_ensures" in rows[0].detail
    rows, _ = RUNNER.check_wp(unit, _wp_run({"f": (4, 4)}), record=False, cache="update")
    assert rows[0].result == "COUNT CHANGED" and not rows[0].expected
    rows, _ = RUNNER.check_wp(unit, _wp_run({}), record=False, cache="update")
    assert rows[0].result == "MISSING" and not rows[0].expected
    rows, _ = RUNNER.check_wp(unit, _wp_run({"f": (3, 3), "g": (1, 1)}), record=False, cache="update")
    assert not next(r for r in rows if r.function == "g").expected  # a new function must be recorded
    rows, _ = RUNNER.check_wp(unit, RUNNER.FramacRun(False, 1.0, "boom"), record=False, cache="update")
    assert rows[0].result == "ERROR" and not rows[0].expected


def _eva_report(tmp_path: Path, props: list[tuple[str, str, str]]) -> Path:
    lines = ["directory\tfile\tline\tfunction\tproperty kind\tstatus\tproperty"]
    lines += [f"firmware/node\turb_i2c.c\t10\t{fn}\t{kind}\tUnknown\t{prop}" for fn, kind, prop in props]
    lines.append("firmware/node\turb_i2c.c\t11\tf\tprecondition of g\tUnknown\tn < 8")  # contract: WP's
    path = tmp_path / "r.csv"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    RUNNER.red_report(path).write_text(RED_HEADER + "\n", encoding="utf-8")
    return path


RED_HEADER = "directory\tfile\tline\tfunction\tkind\tname\t#contexts\tstatus\tproperty"


def test_eva_verdicts(tmp_path: Path) -> None:
    unit = _unit("eva_node_i2c")
    key = "urb_i2c.c:f: mem_access: \\valid(p)"
    report = _eva_report(tmp_path, [("f", "mem_access", "\\valid(p)")])
    assert RUNNER.eva_alarms(report) == [key]
    ok = RUNNER.FramacRun(True, 1.0, "")
    unit.expected = {"alarms": [key]}
    rows, _ = RUNNER.check_eva(unit, ok, report, record=False, reviewed={key})
    assert rows[0].expected and rows[0].result == "reviewed alarms"
    rows, _ = RUNNER.check_eva(unit, ok, report, record=False, reviewed=set())
    assert not rows[0].expected and "NEW ALARM" in rows[0].detail  # listed but not explained
    unit.expected = {"alarms": []}
    rows, _ = RUNNER.check_eva(unit, ok, report, record=False, reviewed={key})
    assert not rows[0].expected and rows[0].result == "ALARM"
    unit.expected = {"alarms": [key, "urb_i2c.c:g: mem_access: \\valid(q)"]}
    rows, _ = RUNNER.check_eva(unit, ok, report, record=False, reviewed={key})
    assert not rows[0].expected and "no longer raised" in rows[0].detail
    bad = RUNNER.FramacRun(True, 1.0, "[eva] NON TERMINATING FUNCTION eva_main")
    rows, _ = RUNNER.check_eva(unit, bad, report, record=False, reviewed={key})
    assert rows[0].result == "ERROR" and not rows[0].expected
    # a contract Eva finds false is no alarm of its own but cuts the paths behind it: rejected
    lines = report.read_text(encoding="utf-8").splitlines()
    lines.append("firmware/node\turb_i2c.c\t12\tf\tprecondition of g\tInvalid or unreachable\t\\valid(p)")
    report.write_text("\n".join(lines) + "\n", encoding="utf-8")
    rows, _ = RUNNER.check_eva(unit, ok, report, record=False, reviewed={key})
    assert rows[0].result == "INVALID" and not rows[0].expected and "precondition of g" in rows[0].detail
    # a postcondition false at one call site only: the report says Unknown, the red list says it
    report.write_text("\n".join(lines[:-1]) + "\n", encoding="utf-8")
    unit.expected = {"alarms": [key]}
    rows, _ = RUNNER.check_eva(unit, ok, report, record=False, reviewed={key})
    assert rows[0].expected
    RUNNER.red_report(report).write_text(RED_HEADER + "\n.\turb_i2c.c\t4\th\tProperty\tpostcondition\t1\tUnknown\t"
                                         "r_small: \\result < 5\n", encoding="utf-8")
    rows, _ = RUNNER.check_eva(unit, ok, report, record=False, reviewed={key})
    assert rows[0].result == "INVALID" and not rows[0].expected and "r_small" in rows[0].detail
    # the same red postcondition in a named behavior whose assumes Eva could not decide there
    undecided = RUNNER.FramacRun(True, 1.0, "[eva:alarm] urb_i2c.c:4: Warning: \n  function h, behavior b: postcondition "
                                 "'r_small' got status invalid. (Behavior may be inactive, no reduction performed.)\n")
    rows, _ = RUNNER.check_eva(unit, undecided, report, record=False, reviewed={key})
    assert rows[0].expected and rows[0].data["red"]["undecided"] and "1 behavior postconditions undecided" in \
        rows[0].properties
    RUNNER.red_report(report).unlink()
    rows, _ = RUNNER.check_eva(unit, ok, report, record=False, reviewed={key})
    assert rows[0].result == "ERROR" and "red properties" in rows[0].detail


def test_eva_unit_with_a_false_precondition_is_rejected(tmp_path: Path) -> None:
    """End to end, the bridge's former pattern: `\\valid` required of a const pointer is false in
    ACSL, Eva stops the analysis at the call without an alarm, and the runner must say so."""
    assert shutil.which("frama-c"), "frama-c missing: run tools/setup.sh"
    src = tmp_path / "main.c"
    src.write_text("""typedef struct { int n; } S;
/*@ requires \\valid(s); assigns \\nothing; */
static int get(const S *s) { return s->n; }
static S g;
int eva_main(void) { g.n = 1; return get(&g); }
""", encoding="utf-8")
    unit = RUNNER.Unit("fixture", tmp_path, "eva", "fixture", [str(src)], [], ["-main", "eva_main"], [],
                       {"alarms": []})
    report = tmp_path / "r.csv"
    cmd = RUNNER.framac_command(unit, unit.sources, [], [], report, 1, "offline", RUNNER.CACHE_DIR)
    run = RUNNER.run_framac(cmd, tmp_path / "fixture.log", report)
    rows, _ = RUNNER.check_eva(unit, run, report, record=False, reviewed=set())
    assert rows[0].result == "INVALID" and not rows[0].expected, rows[0]
    assert "get" in rows[0].detail and "valid(s)" in rows[0].detail
    src.write_text(src.read_text(encoding="utf-8").replace("\\valid(s)", "\\valid_read(s)"), encoding="utf-8")
    run = RUNNER.run_framac(cmd, tmp_path / "fixture.log", report)
    rows, _ = RUNNER.check_eva(unit, run, report, record=False, reviewed=set())
    assert rows[0].expected and rows[0].result == "no alarm", rows[0]


def _eva_fixture(tmp_path: Path, source: str) -> Any:
    """An Eva unit over one fixture file, with its Row after a real Frama-C run."""
    src = tmp_path / "main.c"
    src.write_text(source, encoding="utf-8")
    unit = RUNNER.Unit("fixture", tmp_path, "eva", "fixture", [str(src)], [], ["-main", "eva_main"], [],
                       {"alarms": []})
    report = tmp_path / "r.csv"
    cmd = RUNNER.framac_command(unit, unit.sources, [], [], report, 1, "offline", RUNNER.CACHE_DIR)
    run = RUNNER.run_framac(cmd, tmp_path / "fixture.log", report)
    rows, _ = RUNNER.check_eva(unit, run, report, record=False, reviewed=set())
    return rows[0]


INVALID_AT_ONE_CALL_SITE = """#include "__fc_builtin.h"
/*@ ensures small: \\result < 5; */
static int h(int x) { return x; }
int eva_main(void) {
  int s = 0;
  while (Frama_C_nondet(0, 1)) {
    s += h(1);
    if (Frama_C_nondet(0, 1)) s += h(7);
    s &= 0xff;
  }
  return s;
}
"""


def test_eva_postcondition_invalid_at_one_call_site_is_rejected(tmp_path: Path) -> None:
    """Seeded case of issue #37: `small` holds at h(1) and is false at h(7). Eva's consolidated
    status is Unknown (so it was neither an alarm nor an invalid property for the old runner); the
    red-status list names it, and the unit fails."""
    assert shutil.which("frama-c"), "frama-c missing: run tools/setup.sh"
    row = _eva_fixture(tmp_path, INVALID_AT_ONE_CALL_SITE)
    assert row.result == "INVALID" and not row.expected, row
    assert "small" in row.detail and "consolidated status Unknown" in row.detail
    assert RUNNER.eva_invalid(tmp_path / "r.csv") == [], "the report alone does not show it"
    row = _eva_fixture(tmp_path, INVALID_AT_ONE_CALL_SITE.replace("h(7)", "h(3)"))
    assert row.expected and row.result == "no alarm", row
    assert row.data["contracts"]["valid"] == 1  # the postcondition, counted


UNDECIDED_BEHAVIORS = """#include "__fc_builtin.h"
int t[2];
/*@ behavior zero: assumes t[n] == 0; ensures \\result == -3;
    behavior other: assumes t[n] != 0; ensures \\result == 0;
    complete behaviors; disjoint behaviors; */
static int f(int n) { if (t[n] == 0) return -3; return 0; }
int eva_main(void) {
  int s = 0;
  t[0] = 0; t[1] = 5;
  while (Frama_C_nondet(0, 1)) { s += f(Frama_C_interval(0, 1)); s &= 0xff; }
  return s;
}
"""


def test_eva_behaviors_it_cannot_tell_apart_are_not_invalid(tmp_path: Path) -> None:
    """A correct contract with behaviors, called with an argument Eva keeps as {0, 1}: Eva checks
    each behavior's postcondition in a state where its assumes is undecided and lists both as red
    ("Behavior may be inactive"). Not a violation; counted, never failing."""
    assert shutil.which("frama-c"), "frama-c missing: run tools/setup.sh"
    row = _eva_fixture(tmp_path, UNDECIDED_BEHAVIORS)
    assert row.expected and row.result == "no alarm", row
    assert len(row.data["red"]["undecided"]) == 2 and row.data["red"]["invalid"] == []
    row = _eva_fixture(tmp_path, UNDECIDED_BEHAVIORS.replace("return -3; return 0;", "return -3; return 1;"))
    assert not row.expected, row  # `other` really is false (in every context where it applies)


def test_an_eva_mutant_that_breaks_a_contract_is_killed() -> None:
    unit = _unit("eva_node_i2c")
    broken = RUNNER.Row("eva_node_i2c", "frama-c eva", "1 properties invalid in some context", "-", "INVALID", False,
                        1.0, "invalid at some call site: x", "eva_node_i2c")
    row = RUNNER.mutant_row(unit, unit.mutants[0], [broken])
    assert row.result == "killed" and row.expected
    assert row.data["kind"] == "off-by-one" and row.data["mutated_function"]


def test_a_cache_miss_says_new_or_changed_and_the_command_for_the_verdict() -> None:
    unit = RUNNER.Unit("u", ROOT, "wp", "u", [], [], [], [],
                       {"functions": {"f": {"proved": 2, "total": 2, "goals": ["a", "b"]}}})
    run = _wp_verdicts_run({"a": {"wp:main": {"total": 1, "unknown": 1}},
                            "c": {"wp:main": {"total": 1, "unknown": 1}}})
    rows, _ = RUNNER.check_wp(unit, run, record=False, cache="offline")
    assert rows[0].result == "CACHE MISS"
    assert "a (changed)" in rows[0].detail and "c (new)" in rows[0].detail
    assert "`.venv/bin/python tools/proofs_framac.py --cache update --unit u --no-mutants`" in rows[0].detail
    rows, _ = RUNNER.check_wp(unit, run, record=False, cache="offline", mutant="m")
    assert "--unit u --mutant m --mutants-only`" in rows[0].detail
    unit.expected = {"functions": {"f": {"proved": 2, "total": 2}}}
    rows, _ = RUNNER.check_wp(unit, run, record=False, cache="offline")
    assert "new or changed (expected.json records no goal names" in rows[0].detail


def test_unit_and_mutant_selection_is_exact() -> None:
    assert [u.name for u in RUNNER.discover([], ["node_i2c"])] == ["node_i2c"]
    assert {u.name for u in RUNNER.discover(["node_i2c"])} == {"node_i2c", "eva_node_i2c"}
    with pytest.raises(RUNNER.SetupError, match="no unit named"):
        RUNNER.discover([], ["node"])


def test_the_evidence_record_holds_goals_alarms_and_mutants(tmp_path: Path) -> None:
    wp = RUNNER.Row("f", "frama-c wp", "3/3 goals", "-", "proved", True, 1.0, "", "u",
                    {"total": 3, "proved": 3, "by": {"qed": 1, "z3": 2, "cvc4": 1}, "unproved": [], "cache_misses": []})
    key = "urb_i2c.c:f: mem_access: \\valid(p)"
    eva = RUNNER.Row("e", "frama-c eva", "1 alarms", "-", "reviewed alarms", True, 1.0, "", "e",
                     {"alarms": [key], "new": [], "contracts": {"valid": 4, "unknown": 1, "invalid": 0}})
    unit = _unit("fifo")
    mutant = RUNNER.mutant_row(unit, unit.mutants[0], [RUNNER.Row("slot_index", "frama-c wp", "", "", "UNPROVED",
                                                                  False, 1.0, "g", "fifo")])
    items = {i.id: i for i in RUNNER.evidence_items([wp, eva, mutant], {key: "why not a bug"})}
    assert items["wp:u/f"].data["goals"]["by"] == {"qed": 1, "z3": 2, "cvc4": 1, "cvc5": 0, "script": 0}
    assert items["wp:u/f"].data["goals"]["justified"] == [] and items["wp:u/f"].verdict == "pass"
    assert items["eva:e"].data["alarms"] == [{"alarm": key, "review": "why not a bug", "status": "reviewed"}]
    assert items["eva:e"].data["contracts"]["valid"] == 4
    m = items[f"framac-mutant:fifo/{unit.mutants[0]['name']}"]
    assert m.verdict == "pass" and m.data["kind"] and m.data["file"] == unit.mutants[0]["file"]


def test_every_mutant_has_a_kind_of_the_score() -> None:
    from urb_report.mutation import kind_of

    for folder in FOLDERS:
        for mutant in RUNNER.load_unit(folder).mutants:
            assert mutant.get("kind"), f"{folder.name}/{mutant['name']}: give it a kind (mutation score)"
            assert kind_of(mutant["kind"]) != "other" or mutant["kind"] == "other", mutant["kind"]


def test_mutant_that_applies_twice_is_refused(tmp_path: Path) -> None:
    unit = _unit("gen_runtime")
    with pytest.raises(RUNNER.SetupError, match="occurs"):
        RUNNER.apply_mutant(unit, dict(unit.mutants[0], find="uint8_t"), tmp_path)


def test_a_wp_mutant_is_killed_only_by_a_goal_of_the_function_it_mutates() -> None:
    """A WP mutant's run proves its `-wp-fct`; an unproved goal of another function (a unit whose
    own proof is incomplete, a prover timeout) is not the seeded bug's doing and kills nothing."""
    unit = _unit("gen_runtime")
    mutant = unit.mutants[0]
    target = sorted(RUNNER.mutant_targets(mutant))[0]

    def row(fn: str, result: str) -> Any:
        return RUNNER.Row(fn, "frama-c wp", "1/2 goals", "-", result, False, 1.0, "a goal", unit.name)

    elsewhere = RUNNER.mutant_row(unit, mutant, [row(target, "proved"), row("some_other_function", "UNPROVED")])
    assert elsewhere.result == "SURVIVED" and not elsewhere.expected
    own = RUNNER.mutant_row(unit, mutant, [row(target, "UNPROVED"), row("some_other_function", "UNPROVED")])
    assert own.result == "killed" and own.expected and "some_other_function" not in own.detail
    assert RUNNER.mutant_targets({"args": ["-wp-fct", "a, b"]}) == {"a", "b"}
    assert RUNNER.mutant_targets({"args": []}) is None


def test_a_wp_mutant_proves_only_its_own_functions() -> None:
    """frama-c adds a repeated -wp-fct to the list: the mutant's must replace the unit's, or each
    mutant proves the whole unit again (uplink_parsers: ~80 s a mutant instead of a few)."""
    unit = _unit("usb_batch")
    mutant = next(m for m in unit.mutants if m["name"] == "usb_sof_keeps_length")
    cmd = RUNNER.framac_command(unit, unit.sources, unit.cpp, list(mutant["args"]), Path("r.json"), 1, "offline", RUNNER.CACHE_DIR)
    selected = [cmd[i + 1] for i, arg in enumerate(cmd[:-1]) if arg == "-wp-fct"]
    assert selected == ["urb_bridge_usb_sof"]
    assert "-rte-no-pointer-call" in cmd  # the unit's other options stay
    whole = RUNNER.framac_command(unit, unit.sources, unit.cpp, [], Path("r.json"), 1, "offline", RUNNER.CACHE_DIR)
    assert [whole[i + 1] for i, arg in enumerate(whole[:-1]) if arg == "-wp-fct"] == [unit.args[1]]


HAL_HYPOTHESES = {"uart_kick", "mark"}  # proofs/framac/README.md, "HAL contracts (WP hypotheses)"


def _wp_functions(args: list[str]) -> set[str]:
    return {f.strip() for i, a in enumerate(args[:-1]) if a == "-wp-fct" for f in args[i + 1].split(",")}


def test_hal_contracts_stay_hypotheses() -> None:
    """The contracts of the HAL wrappers state what the port does; WP cannot prove them (the call
    goes through a pointer into the port). They are assumed, never proved: no unit and no mutant may
    select them, or WP would report goals it cannot meet as if the port's code were checked."""
    for folder in FOLDERS:
        unit = RUNNER.load_unit(folder)
        if unit.tool != "wp":
            continue
        selected = _wp_functions(unit.args)
        for mutant in unit.mutants:
            selected |= _wp_functions(list(mutant.get("args", [])))
        assert not selected & HAL_HYPOTHESES, folder.name
    uplink = (ROOT / "firmware" / "bridge" / "bridge_uplink.c").read_text(encoding="utf-8")
    assert "uart_kick(b);" in uplink and "b->hal->uart_tx_kick(b->hal->ctx);" in uplink
    assert uplink.count("uart_tx_kick(") == 1  # the wrapper is the only caller of the kick


def test_mutants_need_distinct_names(tmp_path: Path) -> None:
    folder = tmp_path / "u"
    shutil.copytree(UNITS / "gen_runtime", folder)
    cfg = json.loads((folder / "unit.json").read_text())
    cfg["mutant"] = cfg["mutants"][0]  # the same name twice, once per spelling
    (folder / "unit.json").write_text(json.dumps(cfg))
    with pytest.raises(RUNNER.SetupError, match="share a name"):
        RUNNER.load_unit(folder)


def test_eva_unit_options_follow_the_defaults() -> None:
    """A unit's own Eva options (precision, partitioning) refine the runner's -eva-precision."""
    unit = _unit("eva_node_i2c")
    unit.args = unit.args + ["-eva-precision", "5"]
    cmd = RUNNER.framac_command(unit, unit.sources, unit.cpp, [], Path("r.csv"), 1, "offline", RUNNER.CACHE_DIR)
    last = len(cmd) - 1 - cmd[::-1].index("-eva-precision")
    assert cmd[last + 1] == "5" and last < cmd.index("-then")


def test_summary_and_junit_follow_the_results_contract(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(RUNNER, "OUT_DIR", tmp_path)
    rows = [RUNNER.Row("f", "frama-c wp", "3/3 goals", "b", "proved", True, 0.1, "", "u"),
            RUNNER.Row("u mutant m", "frama-c eva", "why", "b", "SURVIVED", False, 0.2, "d", "u")]
    RUNNER.write_outputs(rows, 1.0)
    data = json.loads((tmp_path / "summary.json").read_text())
    assert data["part"] == "framac"
    for row in data["rows"]:
        assert {"function", "tool", "properties", "bound", "result", "expected", "time_s", "detail"} <= set(row)
        assert row["tool"] in ("frama-c wp", "frama-c eva")
    junit = (tmp_path / "junit.xml").read_text()
    assert junit.count("<testcase") == 2 and junit.count("<failure") == 1


def test_make_wires_the_part() -> None:
    mk = (ROOT / "mk" / "proofs_framac.mk").read_text()
    assert "proofs-framac:" in mk and "PROOF_PARTS += framac" in mk
    assert "CHECK_TARGETS" not in mk  # mk/proofs.mk pulls the part in


# ----------------------------------------------------------------------------- ACSL pitfalls

_ACSL_FN_RE = re.compile(r"/\*@((?:(?!\*/).)*)\*/\s*(?:static\s+)?[\w\s\*]*?\b(\w+)\(([^)]*)\)\s*\{", re.DOTALL)
_PRED_RE = re.compile(r"predicate\s+(\w+)\s*\(\s*[\w\s]+\*\s*(\w+)[^)]*\)\s*=((?:(?!predicate|logic|\*/).)*)", re.DOTALL)


def _const_valid_contracts(text: str) -> list[str]:
    """Functions whose `requires` apply \\valid (directly or through a predicate of the file) to a
    parameter declared pointer-to-const."""
    valid_preds = {name for name, param, body in _PRED_RE.findall(text)
                   if re.search(r"\\valid\(\s*" + param + r"\s*[)+]", body)}
    found = []
    for contract, fn, params in _ACSL_FN_RE.findall(text):
        requires = " ".join(c for c in contract.split(";") if c.strip().startswith("requires"))
        for p in re.findall(r"\bconst\s+\w+\s*\*\s*(\w+)", params):
            hit = re.search(r"\\valid\(\s*" + p + r"\s*[)+]", requires) or \
                any(re.search(r"\b" + pred + r"\(\s*" + p + r"\s*[),]", requires) for pred in valid_preds)
            if hit:
                found.append(f"{fn}({p})")
    return found


def test_const_valid_detector_flags_the_pattern() -> None:
    text = """/*@ predicate ok(S *s) = \\valid(s) && s->x >= 0; */
/*@ requires ok(s); assigns \\nothing; */
static int f(const S *s) { return s->x; }
/*@ requires \\valid_read(s); assigns \\nothing; */
static int g(const S *s) { return s->x; }
"""
    assert _const_valid_contracts(text) == ["f(s)"]


def test_no_valid_precondition_on_a_const_pointer() -> None:
    """\\valid(p) is false when *p is const-qualified (ACSL: only \\valid_read holds). Such a precondition
    makes the contract vacuous by the language's definition; WP ignores const and proves it anyway,
    while Eva takes it as invalid at every call and silently stops the analysis of that path (the
    runner only filters contract statuses, so no alarm shows)."""
    found = []
    for src in sorted((ROOT / "firmware").rglob("*.c")) + sorted((ROOT / "gen" / "c").glob("*.c")):
        found += [f"{src.relative_to(ROOT)}: {f}" for f in _const_valid_contracts(src.read_text(encoding="utf-8"))]
    assert not found, found


# ----------------------------------------------------------------------------- end to end


def test_runtime_replays_from_the_committed_cache_and_its_mutant_is_rejected(tmp_path: Path) -> None:
    missing = [c for c in ("frama-c", "why3", "z3", "cvc4") if shutil.which(c) is None]
    assert not missing, f"{missing} missing: run tools/setup.sh (installs frama-c-base, why3, z3, cvc4)"
    out = subprocess.run([sys.executable, str(ROOT / "tools" / "proofs_framac.py"), "--only", "gen_runtime",
                          "--cache", "offline", "--jobs", "1"], cwd=ROOT, capture_output=True, text=True,
                         timeout=900)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-2000:]
    rows = json.loads((ROOT / "build" / "proofs" / "framac" / "summary.json").read_text())["rows"]
    units = [r for r in rows if " mutant " not in r["function"]]
    mutants = [r for r in rows if " mutant " in r["function"]]
    assert len(units) >= 10 and all(r["result"] == "proved" and r["expected"] for r in units)
    assert len(mutants) == len(_unit("gen_runtime").mutants)
    assert all(m["result"] == "killed" and m["expected"] for m in mutants)


def _wp_verdicts_run(verdicts: dict[str, Any]) -> Any:
    """A WP report of one function `f` with one property per entry of `verdicts`."""
    props = dict(verdicts)
    valid = sum(v["wp:main"].get("valid", 0) for v in verdicts.values())
    props["wp:section"] = {"wp:main": {"total": len(verdicts), "valid": valid}}
    return RUNNER.FramacRun(ok=True, seconds=1.0, log="", report={"wp:functions": {"f": props}})


def test_a_cached_prover_failure_is_unproved_and_an_unanswered_goal_offline_is_a_cache_miss() -> None:
    unit = RUNNER.Unit("u", ROOT, "wp", "u", [], [], [], [], {"functions": {"f": {"proved": 1, "total": 2}}})
    answered = _wp_verdicts_run({"a": {"wp:main": {"total": 1, "valid": 1}, "qed": {"total": 1, "valid": 1}},
                                 "b": {"wp:main": {"total": 1, "unknown": 1}, "Z3:4.8.12": {"total": 1, "unknown": 1}}})
    rows, _ = RUNNER.check_wp(unit, answered, record=False, cache="offline")
    assert [(r.result, r.detail) for r in rows] == [("UNPROVED", "b")]
    unanswered = _wp_verdicts_run({"a": {"wp:main": {"total": 1, "valid": 1}, "qed": {"total": 1, "valid": 1}},
                                   "b": {"wp:main": {"total": 1, "unknown": 1}}})
    rows, _ = RUNNER.check_wp(unit, unanswered, record=False, cache="offline")
    assert rows[0].result == "CACHE MISS" and not rows[0].expected
    assert "--unit u" in rows[0].detail and "commit" in rows[0].detail
    rows, _ = RUNNER.check_wp(unit, unanswered, record=False, cache="update")  # a prover ran and gave up
    assert rows[0].result == "UNPROVED"


@pytest.mark.parametrize("verdicts, answered", [
    ({"qed": {"total": 1, "unknown": 1}}, False),
    ({"script": {"total": 1, "unknown": 1}}, False),  # -wp-auto wp:split, both provers missed
    ({"Z3:4.8.12": {"total": 1, "failed": 1}, "script": {"total": 1, "unknown": 1}}, False),
    ({"Z3:4.8.12": {"total": 1, "failed": 1}, "CVC4:1.8": {"total": 1, "unknown": 1}}, True),
    ({"Z3:4.8.12": {"total": 1, "timeout": 1, "rank": 3}}, True),
])
def test_which_verdicts_are_a_prover_answer(verdicts: dict[str, Any], answered: bool) -> None:
    """The shapes WP 25 gives an unproved goal offline (seen in its reports): a miss leaves no
    prover verdict, or a prover's "failed" (a lookup that found nothing)."""
    goal = {"wp:main": {"total": 1, "unknown": 1}, **verdicts}
    assert RUNNER._no_prover_answer(goal) is not answered


def _replay_from_an_empty_cache(unit: Any, extra: list[str], tmp_path: Path) -> list[Any]:
    """The unit's WP rows, replayed offline from the empty cache tmp_path."""
    report = tmp_path / "r.json"
    cmd = RUNNER.framac_command(unit, unit.sources, unit.cpp, extra, report, 2, "offline", tmp_path)
    run = RUNNER.run_framac(cmd, tmp_path / f"{unit.name}.log", report)
    rows, _ = RUNNER.check_wp(unit, run, record=False, cache="offline")
    return list(rows)


def test_offline_replay_without_the_cache_kills_no_mutant(tmp_path: Path) -> None:
    """The frame unit replayed offline from an empty cache: its prover goals are cache misses, and
    a mutant whose function has one is not counted as killed (no prover said anything about it)."""
    unit = _unit("frame")
    rows = _replay_from_an_empty_cache(unit, [], tmp_path)
    missed = [r for r in rows if r.result == "CACHE MISS"]
    assert [r.function for r in missed] == ["urbb_frame"]
    assert not any(r.result == "UNPROVED" for r in rows)
    row = RUNNER.mutant_row(unit, unit.mutants[0], rows)
    assert (row.result, row.expected) == ("CACHE MISS", False)


def test_offline_replay_without_the_cache_is_a_cache_miss_under_a_strategy(tmp_path: Path) -> None:
    """node_i2c proves with `-wp-auto wp:split`: there a goal whose provers both missed the cache is
    reported as the strategy's "unknown", and must still be a miss, not a kill of its mutant."""
    unit = _unit("node_i2c")
    mutant = next(m for m in unit.mutants if m["name"] == "addr_write_skips_select")
    rows = _replay_from_an_empty_cache(unit, list(mutant["args"]), tmp_path)
    assert [(r.function, r.result) for r in rows if r.function == "addr_write"] == [("addr_write", "CACHE MISS")]
    row = RUNNER.mutant_row(unit, mutant, rows)
    assert (row.result, row.expected) == ("CACHE MISS", False)


def _cache_with(tmp_path: Path, n: int) -> tuple[Path, Path]:
    cache, scratch = tmp_path / "cache", tmp_path / "scratch"
    cache.mkdir()
    scratch.mkdir()
    for k in range(n):
        (cache / f"{k}.json").write_text("{}")
    return cache, scratch


def test_prune_deletes_only_the_entries_whose_copy_was_not_read(tmp_path: Path) -> None:
    cache, scratch = _cache_with(tmp_path, 3)
    copies = RUNNER.copy_unread(cache, scratch)
    assert [c.name for c in copies] == ["0.json", "1.json", "2.json"]
    assert all(c.stat().st_atime_ns == 0 for c in copies)
    copies[1].read_text()  # what frama-c does with a cache hit
    assert RUNNER.prune_unread(copies, cache) == (1, 2)
    assert sorted(e.name for e in cache.iterdir()) == ["1.json"]


def test_prune_ignores_reads_of_the_entries_in_the_work_tree(tmp_path: Path) -> None:
    """`git status` rehashes every entry whose ctime changed, as marking the access times in place
    did: that read every entry and the prune of 2026-11-27 deleted nothing. Only the replay's
    reads of the copies count."""
    cache, scratch = _cache_with(tmp_path, 2)
    copies = RUNNER.copy_unread(cache, scratch)
    for entry in cache.iterdir():
        entry.read_text()
    copies[0].read_text()
    assert RUNNER.prune_unread(copies, cache) == (1, 1)
    assert sorted(e.name for e in cache.iterdir()) == ["0.json"]


def test_prune_refuses_when_nothing_was_read(tmp_path: Path) -> None:
    """A noatime file system looks like a run that read nothing: prune nothing and say why."""
    cache, scratch = _cache_with(tmp_path, 1)
    copies = RUNNER.copy_unread(cache, scratch)
    with pytest.raises(RUNNER.SetupError, match="access times"):
        RUNNER.prune_unread(copies, cache)
    assert (cache / "0.json").exists()


def test_prune_needs_the_whole_run(capsys: pytest.CaptureFixture[str]) -> None:
    assert RUNNER.main(["--prune-cache", "--only", "mailbox"]) == 2
    assert "needs the whole run" in capsys.readouterr().err


# ----------------------------------------------------------------------------- annotations


def _annotated_unit(before: str, acsl: str) -> Any:
    unit = _unit("dl_can_layout")
    unit.annotations = [{"file": "firmware/downlink/can/urb_can_transfer.c", "before": before, "acsl": acsl}]
    return unit


def test_loop_annotations_add_comments_only(tmp_path: Path) -> None:
    """dl_can_layout's copy of urb_can_transfer.c is the original with its loop annotations added."""
    unit = _unit("dl_can_layout")
    original = (ROOT / "firmware/downlink/can/urb_can_transfer.c").read_text(encoding="utf-8")
    sources, cpp = RUNNER.annotate_sources(unit, tmp_path)
    copy = (tmp_path / "urb_can_transfer.c").read_text(encoding="utf-8")
    assert cpp[0] == f"-I{tmp_path}" and sources == unit.sources
    assert len(unit.annotations) == 4 and all(n["acsl"] in copy for n in unit.annotations)
    assert copy.count("loop invariant") > original.count("loop invariant")
    stripped = copy
    for note in unit.annotations:
        stripped = stripped.replace(note["acsl"] + "\n", "")
    assert stripped == original


def test_annotation_anchor_must_start_exactly_one_line() -> None:
    with pytest.raises(RUNNER.SetupError, match="starts 0 lines"):
        RUNNER.annotated(_annotated_unit("no such line", "/*@ assert \\true; */"), "firmware/downlink/can/urb_can_transfer.c")
    with pytest.raises(RUNNER.SetupError, match="starts 2 lines"):
        RUNNER.annotated(_annotated_unit("    for (uint8_t i", "/*@ assert \\true; */"),
                         "firmware/downlink/can/urb_can_transfer.c")


def test_annotation_must_be_one_acsl_comment() -> None:
    with pytest.raises(RUNNER.SetupError, match="one /\\*@"):
        RUNNER.annotated(_annotated_unit("    do {", "left = 0;"), "firmware/downlink/can/urb_can_transfer.c")
    with pytest.raises(RUNNER.SetupError, match="one /\\*@"):
        RUNNER.annotated(_annotated_unit("    do {", "/*@ assert \\true; */ left = 0; /*@ assert \\true; */"),
                         "firmware/downlink/can/urb_can_transfer.c")


def test_annotation_inside_a_comment_is_refused() -> None:
    """Inserted inside the file's header comment, the annotation's `*/` would end that comment and
    turn the rest of it into code: the code check refuses it."""
    with pytest.raises(RUNNER.SetupError, match="change its code"):
        RUNNER.annotated(_annotated_unit(" * Seeded bugs for the mutant checks", "/*@ assert \\true; */"),
                         "firmware/downlink/can/urb_can_transfer.c")


def test_a_mutant_applies_to_the_annotated_copy(tmp_path: Path) -> None:
    unit = _unit("dl_can_layout")
    mutant = next(m for m in unit.mutants if m["name"] == "rx_stores_at_cap")
    sources, cpp = RUNNER.apply_mutant(unit, mutant, tmp_path)
    copy = (tmp_path / "urb_can_transfer.c").read_text(encoding="utf-8")
    assert mutant["replace"] in copy and "loop variant n - i;" in copy and cpp[0] == f"-I{tmp_path}"
