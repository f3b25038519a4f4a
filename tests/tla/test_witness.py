"""Reachability witnesses, TLC's distributed mode and the evidence record, without TLC: the
wrapper module, the bookkeeping of the manifest's witness lists, the server's configuration and
the record's items."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

from repo_tools import load_module

ROOT = Path(__file__).resolve().parents[2]
SPEC = ROOT / "spec" / "tla"

mc: Any = load_module("modelcheck", Path("tools/modelcheck.py"))
wit: Any = load_module("tla_witness", Path("tools/tla_witness.py"))
dist: Any = load_module("tla_distributed", Path("tools/tla_distributed.py"))
ev: Any = load_module("tla_evidence", Path("tools/tla_evidence.py"))


def test_wrapper_prints_each_witness_once_and_is_always_true() -> None:
    name, text = wit.wrapper_module("MCBridge", ["ReachBusyAnswer", "ReachRingFull"])
    assert name == "MCBridge_Witnesses"
    assert "EXTENDS MCBridge, TLC" in text
    assert "ASSUME TLCSet(100, FALSE) /\\ TLCSet(101, FALSE)" in text
    assert ('IF TLCGet(100) THEN TRUE ELSE IF ReachBusyAnswer THEN TLCSet(100, TRUE) /\\ '
            'PrintT(<<"urb-reached", "ReachBusyAnswer">>) ELSE TRUE') in text
    assert text.count("ELSE TRUE") == 2
    assert wit.wrapper_config("SPECIFICATION Spec\nINVARIANT TypeOK\n").endswith("INVARIANT WitnessesReached\n")
    log = 'x\n<<"urb-reached", "ReachRingFull">>\n<<"urb-reached", "ReachRingFull">>\n<<"other", "ReachX">>\n'
    assert wit.reached(log) == {"ReachRingFull"}


def test_wrapper_refuses_a_name_that_is_not_an_identifier() -> None:
    try:
        wit.wrapper_module("M", ["Reach X"])
    except wit.WitnessError as exc:
        assert "Reach X" in str(exc)
    else:
        raise AssertionError("a bad witness name must be refused")


def test_every_witness_is_defined_listed_and_every_default_model_has_some() -> None:
    _, entries = mc.load_manifest()
    models = [e for e in entries if e.kind == "model"]
    used: dict[str, set[str]] = {}
    for e in models:
        defined = wit.defined_witnesses((SPEC / f"{e.spec}.tla").read_text())
        unknown = set(e.witnesses) - defined
        assert not unknown, f"{e.name}: witnesses not defined in {e.spec}.tla: {sorted(unknown)}"
        assert len(e.witnesses) == len(set(e.witnesses)), e.name
        if not e.optional:
            assert len(e.witnesses) >= 3, \
                f"{e.name} must list its reachability witnesses"
        used.setdefault(e.spec, set()).update(e.witnesses)
    for spec, names in used.items():
        orphans = wit.defined_witnesses((SPEC / f"{spec}.tla").read_text()) - names
        assert not orphans, f"{spec}.tla defines witnesses no model lists: {sorted(orphans)}"


def test_judge_fails_a_model_that_misses_a_witness() -> None:
    entry = mc.Entry(name="M", module="M.tla", config="M.cfg", kind="model", distinct_states=5,
                     witnesses=["ReachA", "ReachB"])
    result = mc.TlcResult("pass", distinct_states=5, depth=3)
    run = mc.RunOutcome(entry, result, 1.0, "")
    run.witnesses_checked, run.reached = True, {"ReachA"}
    mc.judge(run, update=False)
    assert not run.ok and "ReachB" in run.problems[0]
    run = mc.RunOutcome(entry, result, 1.0, "")
    run.witnesses_checked, run.reached = True, {"ReachA", "ReachB"}
    mc.judge(run, update=False)
    assert run.ok


def test_distributed_server_keeps_action_properties_and_drops_liveness() -> None:
    tla = ["Live == <>(x = 3)\nStep == [][x' > x => x < 3]_x\n"]
    cfg = "SPECIFICATION Spec\nINVARIANTS TypeOK Inv\nPROPERTIES Live\n  Step\n"
    text, action, liveness = dist.split_config(cfg, tla)
    assert (action, liveness) == (["Step"], ["Live"])
    assert "Live" not in text and "PROPERTIES Step" in text and "INVARIANTS TypeOK Inv" in text
    assert dist.free_port() > 0


def test_the_loopback_check_runs_a_default_model_with_several_workers() -> None:
    _, entries = mc.load_manifest()
    d = [e for e in entries if e.kind == "distributed"]
    assert d, "make modelcheck must test TLC's distributed mode on loopback"
    for e in d:
        assert e.workers >= 2 and isinstance(e.distinct_states, int)


def test_action_property_message_of_this_tlc() -> None:
    r = mc.parse_tlc_output("Error: Action property LockBusyOnlyWhenReading is violated.\n", 12)
    assert (r.outcome, r.violated) == ("property", "LockBusyOnlyWhenReading")


def test_evidence_items(tmp_path: Path) -> None:
    model = mc.Entry(name="MCMailboxOutbox", module="MailboxOutbox.tla", config="MCMailboxOutbox.cfg",
                     kind="model", spec="MailboxOutbox", distinct_states=336, witnesses=["ReachLockRefused"])
    mutant = mc.Entry(name="MailboxOutbox_NoBusyCheck", module="mutants/MailboxOutbox_NoBusyCheck.tla",
                      config="mutants/MailboxOutbox_NoBusyCheck.cfg", kind="mutant",
                      expect_violation="AppLockExclusive", covers="MailboxOutbox.AppLockExclusive")
    good = mc.RunOutcome(model, mc.TlcResult("pass", distinct_states=336, depth=35), 1.0,
                         "TLC2 Version 2.15 of Day Month 20??\n")
    good.witnesses_checked, good.reached = True, {"ReachLockRefused"}
    refuted = mc.RunOutcome(mutant, mc.TlcResult("invariant", violated="AppLockExclusive"), 1.0, "")
    for r in (good, refuted):
        mc.judge(r, update=False)
    path = ev.write([good, refuted], [model, mutant], tmp_path / "tlc.json", selection={"only": None})
    data = json.loads(path.read_text())
    items = {i["id"]: i for i in data["items"]}
    assert items["tlc:MCMailboxOutbox"]["verdict"] == "pass"
    assert items["tlc-reach:MCMailboxOutbox/ReachLockRefused"]["verdict"] == "pass"
    assert items["tlc-mutant:MailboxOutbox_NoBusyCheck"]["verdict"] == "pass"
    assert items["tla:MailboxOutbox.AppLockExclusive"]["verdict"] == "pass"
    assert items["tla:MailboxOutbox.WritesPublished"]["verdict"] == "pass"
    assert data["tools"]["TLC"].startswith("2.15")
    assert re.match(r"python3 tools/modelcheck.py --exact MCMailboxOutbox", items["tlc:MCMailboxOutbox"]["rerun"])
    # a model that failed fails every invariant it checks
    bad = mc.RunOutcome(model, mc.TlcResult("invariant", violated="AppLockExclusive"), 1.0, "")
    mc.judge(bad, update=False)
    items = {i.id: i for i in ev.items([bad, refuted], [model, mutant])}
    assert items["tla:MailboxOutbox.AppLockExclusive"].verdict == "fail"
    assert items["tlc:MCMailboxOutbox"].verdict == "fail"
