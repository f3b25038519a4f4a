"""The TLA+ mutation tool without TLC: the generator's operators on a small module, the real
modules' mutants (five kinds each), the classification of TLC runs, the explanations check and
the committed record. TLC runs the mutants in `make modelcheck` (the sample) and in
`make modelcheck-mutate` (all of them)."""

from __future__ import annotations

import importlib
import json
from pathlib import Path
from typing import Any

import pytest

from repo_tools import load_module

ROOT = Path(__file__).resolve().parents[2]

mc: Any = load_module("modelcheck", Path("tools/modelcheck.py"))
gen: Any = load_module("tla_mutagen", Path("tools/tla_mutagen.py"))
mut: Any = load_module("tla_mutate", Path("tools/tla_mutate.py"))

MINI = r"""---------------------------- MODULE Mini ----------------------------
EXTENDS Naturals, Sequences
CONSTANT N
VARIABLES q, n, r   \* a queue, a counter, a record
vars == <<q, n, r>>
TypeOK == n \in 0..N
Init == q = <<>> /\ n = 0 /\ r = [a |-> 0, b |-> 1]
(* Put < and 7 in a comment are not mutated; nor is "a < 7" in a string *)
Put == /\ n < N
       /\ q' = Append(q, n)
       /\ n' = n + 1
       /\ UNCHANGED r
Get == /\ q # <<>> /\ r.a >= 0
       /\ q' = Tail(q) /\ r' = [r EXCEPT !.a = Head(q)]
       /\ n' = IF n > 2 THEN n ELSE 0
Next == Put \/ Get
Spec == Init /\ [][Next]_vars /\ WF_vars(Get)
Unused == n > 7
-----------------------------------------------------------------------------
Inv == n <= N
=============================================================================
"""


def _by_id() -> dict[str, Any]:
    return {m.id: m for m in gen.generate(MINI)}


def test_each_operator_on_a_small_module() -> None:
    ms = _by_id()
    expect = {
        "Mini/Put/drop-guard#1": ("/\\ n < N", "(removed)"),
        "Mini/Put/cmp#1": ("<", "<="),
        "Mini/Put/literal#1": ("1", "2"),
        "Mini/Put/literal#2": ("1", "0"),
        "Mini/Put/append-front#1": ("Append(q, n)", "<<n>> \\o q"),
        "Mini/Put/unchanged#1": ("Append(q, n)", "q"),
        "Mini/Put/unchanged#2": ("n + 1", "n"),
        "Mini/Get/drop-guard#1": ("q # <<>> /\\", "(removed)"),
        "Mini/Get/negate#1": ("#", "="),
        "Mini/Get/head-last#1": ("Head(q)", "q[Len(q)]"),
        "Mini/Get/swap-if#1": ("n ELSE 0", "0 ELSE n"),
        "Mini/Get/unchanged#2": ("[r EXCEPT !.a = Head(q)]", "r"),
        "Mini/Get/field#1": ("a", "b"),
        "Mini/Next/drop-disjunct#2": ("\\/ Get", "(removed)"),
        "Mini/Spec/drop-guard#1": ("/\\ WF_vars(Get)", "(removed)"),
    }
    for mid, (original, mutated) in expect.items():
        assert mid in ms, f"{mid} not generated; got {sorted(ms)}"
        assert (ms[mid].original, ms[mid].mutated) == (original, mutated), mid
    kinds = {m.kind for m in ms.values()}
    assert kinds == {"bound", "guard", "order", "publish", "field", "error"}


def test_what_is_not_mutated() -> None:
    ms = _by_id()
    defs = {m.definition for m in ms.values()}
    # the type invariant, the variables' tuple, a definition the behaviour does not use, the properties
    assert not defs & {"TypeOK", "vars", "Unused", "Inv"}
    # Init's conjuncts assign: no guard dropped, no comparison negated; UNCHANGED is never dropped
    assert not [m for m in ms.values() if m.definition == "Init" and m.operator in ("drop-guard", "negate")]
    assert not [m for m in ms.values() if "UNCHANGED" in m.original]
    # comments and strings are left alone: one `<` in Put (its guard), no 7 anywhere
    assert [m.id for m in ms.values() if m.definition == "Put" and m.operator == "cmp"] == ["Mini/Put/cmp#1"]
    assert not [m for m in ms.values() if "7" in m.original]
    # a mutant changes exactly its site
    m = ms["Mini/Put/cmp#1"]
    assert m.text.replace("/\\ n <= N", "/\\ n < N", 1) == MINI


def test_no_mutant_of_a_let_head_or_an_except_path() -> None:
    """Neither drops the head of a LET definition written on one line with a conjunction
    (`ok == a /\\ b`: no `ok ==` left) nor negates the `=` of an EXCEPT path with a field after
    a key (`![s].f = e`): both would not parse (CanTransfer's first mutation run had 3 such)."""
    text = MINI.replace(
        "Get == /\\ q # <<>> /\\ r.a >= 0\n       /\\ q' = Tail(q) /\\ r' = [r EXCEPT !.a = Head(q)]",
        "Get == LET x == 0\n           ok == q # <<>> /\\ r.a >= x\n       IN  /\\ ok\n"
        "           /\\ q' = Tail(q) /\\ r' = [r EXCEPT ![1].a = Head(q)]")
    assert text != MINI
    ms = {m.id: m for m in gen.generate(text)}
    get = [m for m in ms.values() if m.definition == "Get"]
    assert not [m for m in get if m.operator == "drop-guard" and "==" in m.original]
    assert "/\\ r.a >= x" in [m.original for m in get if m.operator == "drop-guard"]
    # the only `=`/`#` negated is the guard's `#`: not the EXCEPT path's `=`, nor the primed ones
    assert [(m.original, m.mutated) for m in get if m.operator == "negate"] == [("#", "=")]


def test_ids_are_stable_under_comment_edits() -> None:
    edited = MINI.replace("(* Put < and 7", "(* A longer comment: Put < and 7")
    assert [m.id for m in gen.generate(edited)] == [m.id for m in gen.generate(MINI)]


def test_every_module_gets_five_kinds_of_bugs() -> None:
    plan = mut.load_plan()
    mutants = mut.generate(plan)
    ids = [m.id for m in mutants]
    assert len(ids) == len(set(ids)), "mutant ids must be unique"
    for module in plan.models:
        kinds = {m.kind for m in mutants if m.module == module}
        assert len(kinds) >= 5, f"{module}: only {sorted(kinds)}"
        assert {"bound", "guard", "publish", "error"} <= kinds, f"{module}: {sorted(kinds)}"
    assert {m.kind for m in mutants} >= {"bound", "guard", "order", "publish", "field", "error"}


def test_sample_is_fixed_and_spread_over_modules() -> None:
    plan = mut.load_plan()
    mutants = mut.generate(plan)
    a = [m.id for m in mut.sample(mutants, plan.sample_per_module)]
    b = [m.id for m in mut.sample(list(reversed(mutants)), plan.sample_per_module)]
    assert a == b
    assert len(a) == plan.sample_per_module * len(plan.models)


def _run(outcome: str, violated: str | None = None, message: str = "", log: str = "",
         witnesses: list[str] | None = None, reached: set[str] | None = None) -> Any:
    entry = mc.Entry(name="M", module="M.tla", config="M.cfg", kind="model", witnesses=witnesses or [])
    run = mc.RunOutcome(entry, mc.TlcResult(outcome, violated=violated, message=message), 1.0, log)  # type: ignore[arg-type]
    run.reached = reached or set()
    return run


def test_classify_runs() -> None:
    assert mut.classify(_run("invariant", "NoSilentDrop")) == ("killed", "invariant NoSilentDrop")
    assert mut.classify(_run("property", "EveryRequestAnswered"))[0] == "killed"
    assert mut.classify(_run("deadlock")) == ("killed", "deadlock")
    assert mut.classify(_run("error", message="timeout after 300 s"))[0] == "timeout"
    parse = _run("error", message="Parsing or semantic analysis failed.",
                 log="Error: Parsing or semantic analysis failed.")
    assert mut.classify(parse)[0] == "invalid"
    assert mut.classify(_run("error", message="Attempted to apply Head to <<>>"))[0] == "killed"
    assert mut.classify(_run("pass", witnesses=["ReachA", "ReachB"], reached={"ReachA"})) == ("killed", "witness ReachB")
    assert mut.classify(_run("pass", witnesses=["ReachA"], reached={"ReachA"})) == (None, "")


def _row(status: str, original: str = "<", mutated: str = "<=") -> dict[str, Any]:
    return {"status": status, "original": original, "mutated": mutated, "line": 3, "module": "M", "kind": "bound"}


def test_explanations_are_enforced() -> None:
    results = {"M/A/cmp#1": _row("survived"), "M/A/cmp#2": _row("killed"), "M/B/cmp#1": _row("timeout")}
    problems = mut.check_explanations(results, {})
    assert len(problems) == 2 and all("unexplained" in p for p in problems)
    ok = {"M/A/cmp#1": {"original": "<", "mutated": "<=", "why": "equivalent: n never equals N here"},
          "M/B/cmp#1": {"original": "<", "mutated": "<=", "why": "the state space grows without bound"}}
    assert mut.check_explanations(results, ok) == []
    moved = {**ok, "M/A/cmp#1": {"original": ">", "mutated": ">=", "why": "x"}}
    assert "another change" in mut.check_explanations(results, moved)[0]
    stale = {**ok, "M/A/cmp#2": {"original": "<", "mutated": "<=", "why": "x"}}
    assert any("stale explanation" in p and "now killed" in p for p in mut.check_explanations(results, stale))
    assert "no reason" in mut.check_explanations(results, {**ok, "M/A/cmp#1": {**ok["M/A/cmp#1"], "why": " "}})[0]
    # a module not run yet: its explanations wait for its run
    assert mut.check_explanations(results, {**ok, "N/A/cmp#1": {"original": "<", "mutated": "<=", "why": "x"}}) == []


def test_summary_counts_and_score() -> None:
    results = {"M/A/cmp#1": _row("survived"), "M/A/cmp#2": _row("killed"), "M/A/cmp#3": _row("killed"),
               "M/B/cmp#1": _row("invalid")}
    s = mut.summarise(results)
    assert s["total"]["generated"] == 4 and s["total"]["killed"] == 2 and s["total"]["invalid"] == 1
    assert s["total"]["score"] == pytest.approx(2 / 3, abs=1e-4)
    assert s["modules"]["M"]["by_kind"]["bound"]["survived"] == 1


def test_committed_record_matches_the_generator_and_every_survivor_is_explained() -> None:
    """What `make modelcheck` checks before it reruns the sample, without TLC: the record covers
    whole modules (a run per module), each exactly as the generator makes it today."""
    record = json.loads(mut.RECORD.read_text(encoding="utf-8"))
    explained = json.loads(mut.EXPLAINED.read_text(encoding="utf-8"))
    mutants = mut.generate(mut.load_plan())
    assert mut.recorded_modules(record["mutants"]), "the record holds no module"
    assert mut.stale_modules(mutants, record["mutants"]) == [], \
        "the specs changed since the mutation run: run `make modelcheck-mutate` and commit"
    assert mut.check_explanations(record["mutants"], explained) == []
    assert not [k for k, r in record["mutants"].items() if r["status"] == "invalid"], \
        "the generator should not produce mutants that do not parse"
    assert set(record["module_runtime_s"]) == mut.recorded_modules(record["mutants"])


def _mutant(module: str, ident: str, original: str = "<", mutated: str = "<=") -> Any:
    return gen.Mutant(id=f"{module}/{ident}", module=module, definition=ident.split("/")[0], operator="cmp",
                      kind="bound", line=3, original=original, mutated=mutated, text="")


def test_a_module_not_in_the_record_is_not_run_and_a_changed_one_is_stale() -> None:
    recorded = {"M/A/cmp#1": _row("killed")}
    mutants = [_mutant("M", "A/cmp#1"), _mutant("N", "B/cmp#1"), _mutant("N", "B/cmp#2")]
    assert mut.stale_modules(mutants, recorded) == []
    assert mut.not_run(mutants, recorded) == {"N": 2}
    moved = [_mutant("M", "A/cmp#1", ">", ">="), *mutants[1:]]
    assert "specifications of M changed" in mut.stale_modules(moved, recorded)[0]
    more = [*mutants, _mutant("M", "A/cmp#2")]
    assert "M/A/cmp#2" in mut.stale_modules(more, recorded)[0]


def test_table_rows_are_what_the_mutation_table_reads() -> None:
    """report/urb_report/mutation.py reads {"mutants": [{"name", "module", "kind", "killed", "explained"}]}."""
    results = {"M/A/cmp#1": _row("survived"), "M/A/cmp#2": _row("killed"), "M/B/cmp#1": _row("invalid")}
    explained = {"M/A/cmp#1": {"original": "<", "mutated": "<=", "why": "equivalent"}}
    hand = [{"name": "Bridge_BusyOffByOne", "kind": "mutant", "ok": True, "covers": "Bridge.BusyOnlyWhenFull"},
            {"name": "MCBridge", "kind": "model", "ok": True}]
    rows = mut.table_rows(results, explained, hand)
    assert [(r["name"], r["module"], r["kind"], r["killed"], r["explained"]) for r in rows] == [
        ("Bridge_BusyOffByOne", "Bridge", "hand-written", True, ""),
        ("M/A/cmp#1", "M", "off-by-one", False, "equivalent"),
        ("M/A/cmp#2", "M", "off-by-one", True, "")]
    assert set(mut.TABLE_KINDS) == set(gen.KINDS.values())


def test_the_mutation_table_reads_the_rows(tmp_path: Path) -> None:
    """The rows go through report/urb_report/mutation.py as written: components, kinds, survivors."""
    table: Any = importlib.import_module("urb_report.mutation")  # report/ is on the path: tools/tla_mutate.py
    results = {"MailboxOutbox/A/cmp#1": {**_row("survived"), "module": "MailboxOutbox"},
               "Bridge/B/cmp#1": {**_row("killed"), "module": "Bridge"}}
    explained = {"MailboxOutbox/A/cmp#1": {"original": "<", "mutated": "<=", "why": "equivalent"}}
    (tmp_path / "mutation").mkdir()
    (tmp_path / "mutation" / "tlc.json").write_text(
        json.dumps({"mutants": mut.table_rows(results, explained, [])}), encoding="utf-8")
    found = table.load(tmp_path)
    tlc = sorted((s.name, s.component, s.kind, s.killed, s.explained) for s in found.seeded if s.tool == "TLC")
    assert tlc == [("Bridge/B/cmp#1", "bridge FIFO", "off-by-one", True, ""),
                   ("MailboxOutbox/A/cmp#1", "node mailbox", "off-by-one", False, "equivalent")]
    assert not [p for p in found.problems if "TLC" in p]
