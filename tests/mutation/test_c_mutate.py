"""The C mutation tool (tools/c_mutate.py): its operators on crafted code, its determinism and
sample, the explanations file, and the verdict logic (an unexplained survivor, a stale explanation
and a run where nothing is killed must each fail). The real runs are `make proofs-mutation`
(the sample, in make check) and `make mutation-c-full`."""

from __future__ import annotations

import collections
import json
import re
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from repo_tools import load_module

ROOT = Path(__file__).resolve().parents[2]


def _tool() -> ModuleType:
    return load_module("c_mutate", Path("tools/c_mutate.py"))


CM = _tool()
ALL = CM.generate()

FIXTURE = """#include "urb_node_internal.h"
static int f(urb_node_t *node, uint8_t n, uint8_t k)
{
    urb_node_inbox_t *ib = &node->inbox[n];
    if (k >= ib->size) {
        return URB_NODE_ERR_ARGUMENT;
    }
    ib->isr_idx = 1u;
    ib->front = ib->isr_idx;
    notify(node);
#ifdef URB_MUTANT_FIXTURE
    ib->front = 7u;
#endif
    return 0;
}
"""


def _fixture_mutants() -> list[Any]:
    comp = CM.Component("fixture", (("firmware/node/fixture.c", None),))
    return list(CM._mutants_of(comp, "firmware/node/fixture.c", FIXTURE, CM.Fields()))


def test_each_operator_on_crafted_code() -> None:
    got = {(m.operator, " ".join(m.original.split()), " ".join(m.replacement.split())) for m in _fixture_mutants()}
    assert ("ror", ">=", ">") in got
    assert ("bound", "ib->size", "ib->size - 1") in got
    assert ("del-return", "return URB_NODE_ERR_ARGUMENT;", ";") in got
    assert ("del-store", "ib->isr_idx = 1u;", ";") in got
    assert ("del-call", "notify(node);", ";") in got
    assert ("swap", "ib->isr_idx = 1u; ib->front = ib->isr_idx;", "ib->front = ib->isr_idx; ib->isr_idx = 1u;") in got
    assert ("field", "size", "front") in got or ("field", "isr_idx", "app_idx") in got
    assert not any("7u" in o for _, o, _ in got), "the URB_MUTANT_ branch is dead code: nothing to mutate there"
    assert not any(op == "del-return" and o == "return 0;" for op, o, _ in got), "the final return is no guard"


def test_mutants_apply_to_their_source_and_ids_are_unique() -> None:
    ids = [m.id for m in ALL]
    assert len(ids) == len(set(ids))
    for m in ALL[::37]:
        text = (ROOT / m.file).read_text(encoding="utf-8")
        assert text[m.start:m.end] == m.original and m.apply(text) != text


def test_generation_is_deterministic() -> None:
    again = _tool().generate()
    assert [(m.id, m.start, m.replacement) for m in again] == [(m.id, m.start, m.replacement) for m in ALL]


def test_every_component_has_the_five_kinds() -> None:
    kinds = collections.defaultdict(set)
    for m in ALL:
        kinds[m.component].add(m.kind)
    assert set(kinds) == {c.name for c in CM.COMPONENTS if c.mutated}
    for comp, found in kinds.items():
        assert {"off-by-one", "order", "missing-effect", "field", "error"} <= found, comp


def test_the_sample_is_fixed_bounded_and_covers_every_kind() -> None:
    chosen = CM.sample(ALL)
    assert {m.id for m in chosen} == {m.id for m in CM.sample(list(reversed(ALL)))}, "independent of order"
    groups = collections.Counter((m.component, m.kind) for m in chosen)
    assert max(groups.values()) <= CM.SAMPLE_PER_KIND
    assert {(m.component, m.kind) for m in ALL} == set(groups)


def test_no_mutant_touches_what_tests_cannot_observe() -> None:
    hook = re.compile(r"\s*(URB_NODE_BARRIER|URB_STEP|mark)\s*\(")
    for m in ALL:
        if m.operator in ("del-call", "swap"):  # neither deleted nor moved (inside a moved block is fine)
            lines = [ln for ln in m.original.strip().splitlines() if ln.strip()]
            assert not hook.match(lines[0]) and not hook.match(lines[-1]), m.id


def test_the_suites_match_the_makefiles() -> None:
    node = (ROOT / "mk" / "firmware_node.mk").read_text()
    bridge = (ROOT / "mk" / "firmware_bridge.mk").read_text()
    tests = re.search(r"^FWN_TESTS := (.*)$", node, re.MULTILINE)
    lib = re.search(r"^FWB_LIB_SRC := (.*)$", bridge, re.MULTILINE)
    assert tests and lib
    assert set(CM.SUITES["node"].programs) == set(tests.group(1).split())
    assert set(CM.SUITES["bridge"].library) == set(lib.group(1).split())
    for comp in CM.COMPONENTS:
        for path in comp.files() if comp.mutated else []:
            assert CM.suite_of(path), path


def test_explanations_are_complete_and_current() -> None:
    entries = json.loads(CM.EQUIVALENTS.read_text(encoding="utf-8"))
    assert all(len(e["why"]) > 30 for e in entries), "an explanation says why, in words"
    assert CM.stale_explanations(ALL, CM.load_equivalents()) == []


def test_a_stale_explanation_is_reported() -> None:
    m = next(x for x in ALL if x.operator == "ror")
    entry = {"id": m.id, "original": m.original, "replacement": m.replacement, "why": "x" * 40}
    assert CM.stale_explanations(ALL, {m.id: entry}) == []
    assert "not what was reviewed" in CM.stale_explanations(ALL, {m.id: dict(entry, replacement="!=")})[0]
    assert "no such mutant" in CM.stale_explanations(ALL, {"x:y:ror:9": dict(entry, id="x:y:ror:9")})[0]


class _FakeBuilder:
    """Verdicts without compiling: `outcomes` maps a mutant id to its result."""

    outcomes: dict[str, str] = {}

    def __init__(self, work: Path) -> None:
        self.work = work

    controlled: set[str] | None = None

    def control(self, jobs: int, suites: set[str] | None = None) -> dict[str, float]:
        _FakeBuilder.controlled = suites
        return {}

    def check(self, mutant: Any) -> dict[str, str]:
        result = self.outcomes.get(mutant.id, "killed")
        return {"result": result, **({"killed_by": "test_x: t"} if result == "killed" else {})}


def _run_with(monkeypatch: pytest.MonkeyPatch, tmp_path: Path, mutants: list[Any], outcomes: dict[str, str],
              equivalents: list[dict[str, str]]) -> tuple[int, dict[str, Any]]:
    tool = _tool()
    eq = tmp_path / "eq.json"
    eq.write_text(json.dumps(equivalents), encoding="utf-8")
    _FakeBuilder.outcomes = outcomes
    monkeypatch.setattr(tool, "Builder", _FakeBuilder)
    monkeypatch.setattr(tool, "EQUIVALENTS", eq)
    monkeypatch.setattr(tool, "OUT", tmp_path / "out")
    status = tool.run(mutants, 1, "selection")
    summary = json.loads((tmp_path / "out" / "summary.json").read_text(encoding="utf-8"))
    return status, summary


def test_an_unexplained_survivor_fails_and_an_explained_one_passes(monkeypatch: pytest.MonkeyPatch,
                                                                    tmp_path: Path) -> None:
    mutants = [m for m in ALL if m.component == "node mailbox"][:4]
    survivor = mutants[1]
    status, summary = _run_with(monkeypatch, tmp_path, mutants, {survivor.id: "survived"}, [])
    row = next(r for r in summary["rows"] if r["function"].startswith("node mailbox"))
    assert status == 1 and not row["expected"] and survivor.id in row["detail"]
    why = {"id": survivor.id, "original": survivor.original, "replacement": survivor.replacement,
           "why": "equivalent in this fixture: nothing reads the field after the change"}
    status, summary = _run_with(monkeypatch, tmp_path, mutants, {survivor.id: "survived"}, [why])
    assert status == 0 and all(r["expected"] for r in summary["rows"])
    data = json.loads((tmp_path / "out" / "c.json").read_text(encoding="utf-8"))
    assert next(m for m in data["mutants"] if m["id"] == survivor.id)["explained"] == why["why"]


def test_a_run_where_no_mutant_dies_fails(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """If the tests never fail (not built, not run), every mutant would "survive": with each one
    explained that would pass, so a component without a single kill is an error of its own."""
    mutants = [m for m in ALL if m.component == "PLL"][:4]
    why = [{"id": m.id, "original": m.original, "replacement": m.replacement, "why": "y" * 40} for m in mutants]
    status, summary = _run_with(monkeypatch, tmp_path, mutants, {m.id: "survived" for m in mutants}, why)
    assert status == 1 and any(r["result"] == "NO KILL" for r in summary["rows"])


def test_a_mutant_as_a_bmc_proof_entry_makes_the_same_change(tmp_path: Path) -> None:
    """--esbmc hands a mutant to a proof folder as a mutants.json entry (find, replace, occurrence
    inside a function), which proofs/bmc/prepare.py applies: the result must be the mutant's own."""
    prepare = load_module("bmc_prepare", Path("proofs/bmc/prepare.py"))
    for m in CM.sample(ALL)[::3]:
        entry = CM.as_bmc_mutant(m, "x")
        text = (ROOT / m.file).read_text(encoding="utf-8")
        copy = tmp_path / m.file
        copy.parent.mkdir(parents=True, exist_ok=True)
        copy.write_text(text, encoding="utf-8")
        prepare._rewrite(tmp_path, entry, m.id, "-")
        assert copy.read_text(encoding="utf-8") == m.apply(text), m.id


def test_a_run_builds_only_the_suites_of_its_mutants(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    tool = _tool()
    pll = [m for m in ALL if m.component == "PLL"]
    master = [m for m in ALL if m.component == "downlink master"]
    assert tool.control_suites(pll) == {"node"} and tool.control_suites(master) == {"bridge"}
    assert tool.control_suites(pll[:1] + master[:1]) == {"node", "bridge"}
    _run_with(monkeypatch, tmp_path, master[:3], {}, [])
    assert _FakeBuilder.controlled == {"bridge"}
