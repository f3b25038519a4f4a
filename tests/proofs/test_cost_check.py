"""Where a proof folder's COST is checked (COST_CHECK in proofs/bmc/Makefile.common; proofs/README.md,
"COST and the cache"), without ESBMC.

COST_CHECK = proof (the default, every folder recorded before it): every proof, reach and probe run is
compiled with -DURB_COST_BOUND=COST, and only the full tier adds the witness. COST_CHECK = separate: no
proof, mutant, reach or probe run carries COST, so recording a COST keeps every recorded run's cache
key (the argument list is the one of the folder without COST); COST is checked by a probe at COST on
every item of the tier (must pass) and, in the full tier, the witness on COST's item (must fail on
"tight:"). The runner plans, judges and records those runs; a probe above COST or a witness not
reached fails the folder with a message that says what to do.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from concurrent.futures import Future
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from repo_tools import load_module

ROOT = Path(__file__).resolve().parents[2]
BMC = ROOT / "proofs" / "bmc"
FOLDERS = sorted(p for p in BMC.iterdir() if p.is_dir() and (p / "harness.c").is_file())
P: ModuleType = load_module("urb_tools_proofs_cost", ROOT / "tools" / "proofs.py")


def _proof(folder: Path, cost_check: str, cost: int | None = 300, cost_item: str = "PART=3") -> Any:
    config = {"fast_sweep": "PART=1 PART=2", "sweep": "PART=1 PART=2 PART=3", "budget_cycles": "480"}
    if cost_check:
        config["cost_check"] = cost_check
    return P.Proof("fw_x", folder, config, "purpose", [], cost, cost_item, 3)


def _done(run: Any) -> Future[Any]:
    fut: Future[Any] = Future()
    fut.set_result(run)
    return fut


# ----------------------------------------------------------------------------- planning


def test_a_separate_folder_probes_cost_on_every_item_and_witnesses_it_in_the_full_tier(tmp_path: Path) -> None:
    sep = _proof(tmp_path, "separate")
    probes = [(c.target, c.item, c.extra) for c in P.cost_runs(sep, "fast")]
    assert probes == [("probe", "PART=1", ("COST_PROBE=300",)), ("probe", "PART=2", ("COST_PROBE=300",))]
    full = [(c.target, c.item, c.extra) for c in P.cost_runs(sep, "full")]
    assert full == [("probe", f"PART={n}", ("COST_PROBE=300",)) for n in (1, 2, 3)] + [("tight", "PART=3", ())]
    # the probe at COST is the run --update-costs makes (same target, item, COST_PROBE and log tag)
    assert P.cost_runs(sep, "fast")[0].tag == "-probe300"
    assert P.cost_runs(_proof(tmp_path, "separate", cost=None), "full") == [], "no COST file: nothing to check"


def test_a_legacy_folder_gets_the_same_runs_as_before(tmp_path: Path) -> None:
    """COST_CHECK unset (print-config of an older Makefile.common) or "proof": the proof runs assert COST,
    so no probe; the full tier's witness on COST's item (or the first item in item order without one)."""
    for check in ("", "proof"):
        legacy = _proof(tmp_path, check)
        assert legacy.cost_check() == "proof"
        assert P.cost_runs(legacy, "fast") == []
        assert [(c.target, c.item, c.extra) for c in P.cost_runs(legacy, "full")] == [("tight", "PART=3", ())]
    assert [c.item for c in P.cost_runs(_proof(tmp_path, "proof", cost_item=""), "full")] == ["PART=3"]


def _planned(monkeypatch: Any, proof: Any, tier: str) -> list[tuple[str, str, tuple[str, ...]]]:
    calls: list[tuple[str, str, tuple[str, ...]]] = []

    def fake_run_make(proof: Any, target: str, tier: str, out: Path, item: str = "", mutant: str = "",
                      extra: tuple[str, ...] = (), tag: str = "") -> Any:
        calls.append((target, item, tuple(extra)))
        if target == "reach":
            return P.Run("fail", 1.0, claims={P.bmc_evidence.REACH_CLAIM: True})
        if target == "tight":
            return P.Run("fail", 1.0, "tight: cost: the recorded worst case is reached")
        return P.Run("pass", 1.0)

    monkeypatch.setattr(P, "run_make", fake_run_make)
    rows = P.bmc([proof], tier, 1, False, Path("."))
    assert all(r["expected"] for r in rows), rows
    return calls


def test_the_runner_submits_the_planned_runs(monkeypatch: Any, tmp_path: Path) -> None:
    sep = _proof(tmp_path, "separate")
    fast = _planned(monkeypatch, sep, "fast")
    assert [c for c in fast if c[0] == "proof"] == [("proof", "PART=1", ()), ("proof", "PART=2", ())]
    assert [c for c in fast if c[0] == "probe"] == [("probe", "PART=1", ("COST_PROBE=300",)),
                                                   ("probe", "PART=2", ("COST_PROBE=300",))]
    assert not [c for c in fast if c[0] == "tight"]
    full = _planned(monkeypatch, sep, "full")
    assert len([c for c in full if c[0] == "probe"]) == 3 and [c for c in full if c[0] == "tight"] == [("tight", "PART=3", ())]
    legacy = _planned(monkeypatch, _proof(tmp_path, "proof"), "full")
    assert sorted({c[0] for c in legacy}) == ["proof", "reach", "tight"], "a legacy folder runs no probe"


# ----------------------------------------------------------------------------- judgement


def _rows(proof: Any, probes: dict[str, Any], tight: Any = None) -> dict[str, dict[str, Any]]:
    plan = P.Plan(proof, covers=False)
    plan.runs = {item: _done(P.Run("pass", 1.0)) for item in proof.items("full" if tight else "fast")}
    plan.cost_probes = {item: _done(run) for item, run in probes.items()}
    if tight is not None:
        plan.tight = _done(tight)
    rows = P.collect(plan, "full" if tight else "fast")
    return {r["function"].removeprefix(proof.name).strip() or "proof": r for r in rows}


def test_probes_within_cost_and_a_reached_witness_pass_and_are_recorded(tmp_path: Path) -> None:
    (tmp_path / "harness.c").write_text("\n" * 40 + "    URB_COST_END(FW_X_BUDGET);\n", encoding="utf-8")
    sep = _proof(tmp_path, "separate")
    witness = P.parse_esbmc("Violated property:\n  file harness.c line 41 column 5 function harness\n  tight: cost: "
                            "the recorded worst case is reached\n  !(urb_proof_cost_seen == 300)\n\nVERIFICATION FAILED\n",
                            2.0)
    assert witness.violated_at == "harness.c line 41 (harness)"
    rows = _rows(sep, {f"PART={n}": P.Run("pass", 1.0) for n in (1, 2, 3)}, witness)
    assert (rows["[cost probe]"]["result"], rows["[cost probe]"]["expected"]) == ("within COST", True)
    assert (rows["[worst case]"]["result"], rows["[worst case]"]["expected"]) == ("reached", True)
    assert "at harness.c line 41 (harness): URB_COST_END(FW_X_BUDGET)" in rows["[worst case]"]["detail"], \
        "the witness names the entry that reaches COST and the budget it asserts"
    # the cycle table reads the proof row as for a legacy folder: COST against the folder's budget
    assert (rows["proof"]["cycles"], rows["proof"]["budget_cycles"]) == (300, 480)
    plan_evidence = _evidence(sep, {"PART=1": P.Run("pass", 1.0)})
    assert plan_evidence["data"]["worst_case_probe"] == "within COST" and plan_evidence["verdict"] == "pass"
    assert plan_evidence["data"]["worst_case_cycles"] == 300 and "COST probes" in plan_evidence["expected"]


def _evidence(proof: Any, probes: dict[str, Any]) -> dict[str, Any]:
    plan = P.Plan(proof, covers=False)
    plan.runs = {item: _done(P.Run("pass", 1.0)) for item in proof.items("fast")}
    plan.cost_probes = {item: _done(run) for item, run in probes.items()}
    P.collect(plan, "fast")
    assert plan.evidence is not None
    item: dict[str, Any] = P.bmc_evidence.proof_items(plan.evidence)[0]
    return item


def test_a_probe_above_cost_fails_the_folder_and_says_what_to_do(tmp_path: Path) -> None:
    sep = _proof(tmp_path, "separate")
    above = P.parse_esbmc("Violated property:\n  file harness.c line 9 column 5 function harness\n  cost probe\n"
                          "  urb_proof_cost_seen <= 300\n  urb_proof_cost_seen = 312 (0)\n\nVERIFICATION FAILED\n", 1.0)
    rows = _rows(sep, {"PART=1": P.Run("pass", 1.0), "PART=2": above})
    row = rows["[cost probe]"]
    assert (row["result"], row["expected"]) == ("ABOVE COST", False)
    assert "PART=2: an entry costs 312 cycles than COST 300 allows at harness.c line 9" in row["detail"]
    assert "--update-costs --tier full --only fw_x" in row["detail"]
    assert rows["proof"]["expected"], "the proof itself holds; the COST row fails"
    assert _evidence(sep, {"PART=1": above})["verdict"] == "fail", "the folder's evidence item fails with it"
    timeout = _rows(sep, {"PART=1": P.Run("timeout", 1.0)})["[cost probe]"]
    assert (timeout["result"], timeout["expected"]) == ("TIMEOUT", False) and "COST is not checked" in timeout["detail"]


def test_a_witness_that_does_not_fail_on_tight_fails_the_folder(tmp_path: Path) -> None:
    sep = _proof(tmp_path, "separate")
    probes = {f"PART={n}": P.Run("pass", 1.0) for n in (1, 2, 3)}
    not_reached = _rows(sep, probes, P.Run("pass", 1.0))["[worst case]"]
    assert (not_reached["result"], not_reached["expected"]) == ("NOT REACHED", False)
    assert "the worst case is lower" in not_reached["detail"]
    assert "--update-costs --tier full --only fw_x" in not_reached["detail"]
    elsewhere = _rows(sep, probes, P.Run("fail", 1.0, "cost: within the bus budget"))["[worst case]"]
    assert (elsewhere["result"], elsewhere["expected"]) == ("FAILED", False)
    assert 'failed on "cost: within the bus budget", not on the witness' in elsewhere["detail"]
    legacy = _rows(_proof(tmp_path, "proof"), {}, P.Run("pass", 1.0))
    assert "[cost probe]" not in legacy and legacy["[worst case]"]["result"] == "NOT REACHED"


def test_update_costs_records_a_separate_folders_cost_only_over_the_full_tier(monkeypatch: Any, tmp_path: Path,
                                                                              capsys: Any) -> None:
    (tmp_path / "harness.c").write_text("URB_COST_END(FW_X_BUDGET);\n", encoding="utf-8")

    def no_run(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError("a fast-tier search of a separate folder")

    monkeypatch.setattr(P, "run_make", no_run)
    assert P.update_costs([_proof(tmp_path, "separate", cost=None)], 1, "fast", tmp_path) == 0
    assert not (tmp_path / "COST").exists()
    assert "--update-costs --tier full --only fw_x" in capsys.readouterr().out


# ----------------------------------------------------------------------------- the Makefile's argument lists


def _copy(tmp_path: Path, folder: str) -> Path:
    copy = tmp_path / folder
    shutil.copytree(BMC / folder, copy)
    (copy / "COST").unlink(missing_ok=True)
    makefile = (copy / "Makefile").read_text(encoding="utf-8")
    makefile = re.sub(r"^COST_CHECK *=.*\n", "", makefile, flags=re.MULTILINE)
    (copy / "Makefile").write_text(makefile.replace("include ../Makefile.common", f"include {BMC}/Makefile.common"),
                                   encoding="utf-8")
    return copy


def _esbmc_args(folder: Path, *args: str) -> str:
    """The argument list `make` gives bmc_cache.py (so ESBMC) for one run, nothing run (make -n)."""
    out = subprocess.run(["make", "-n", "-s", "-C", str(folder), *args, f"PYTHON={sys.executable}"],
                         capture_output=True, text=True, timeout=120)
    lines = [ln for ln in out.stdout.splitlines() if "bmc_cache.py" in ln]
    assert len(lines) == 1, out.stdout + out.stderr
    return lines[0].split(" -- ", 1)[1]


def test_separate_keeps_every_runs_argument_list_when_a_cost_is_recorded(tmp_path: Path) -> None:
    """The point of COST_CHECK = separate: the proof, mutant, reach and probe runs of a folder with a
    COST are the runs of the folder without one (same arguments, so the same cache keys); the witness
    carries COST; a legacy folder still compiles COST into its proof, reach and probe runs."""
    copy = _copy(tmp_path, "fw_rs485_frame")
    item = "SWEEP_ITEM=PART=1,N=2"
    mutant = "MUTANT=" + json.loads((copy / "mutants.json").read_text(encoding="utf-8"))[0]["name"]
    targets = [("proof", item), ("mutant", item, mutant), ("reach-run", item, "BASE_KIND=reach"),
               ("probe", item, "COST_PROBE=300")]
    without = {t: _esbmc_args(copy, *t, "TIER=fast") for t in targets}
    assert not any("URB_COST_BOUND" in a for a in without.values())
    (copy / "COST").write_text("300 PART=2\n", encoding="utf-8")
    legacy = {t: _esbmc_args(copy, *t, "TIER=fast") for t in targets}
    for t in targets:
        assert ("-DURB_COST_BOUND=300u" in legacy[t]) == (t[0] != "mutant"), t
    assert "-DURB_COST_BOUND=300u" in _esbmc_args(copy, "tight", "SWEEP_ITEM=PART=2")
    makefile = (copy / "Makefile").read_text(encoding="utf-8")
    (copy / "Makefile").write_text(makefile.replace(f"include {BMC}", f"COST_CHECK = separate\ninclude {BMC}"), encoding="utf-8")
    separate = {t: _esbmc_args(copy, *t, "TIER=fast") for t in targets}
    assert separate == without, "recording a COST changed a separate folder's run"
    tight = _esbmc_args(copy, "tight", "SWEEP_ITEM=PART=2")
    assert "-DURB_COST_BOUND=300u" in tight and "-DURB_VERIFY_TIGHT" in tight
    config = json.loads(subprocess.run(["make", "-s", "-C", str(copy), "print-config"], capture_output=True, text=True,
                                       timeout=60).stdout.strip().splitlines()[-1])
    assert (config["cost_check"], config["cost_bound"]) == ("separate", "300")
    bad = subprocess.run(["make", "-s", "-C", str(copy), "print-config", "COST_CHECK=proofs"], capture_output=True,
                         text=True, timeout=60)
    assert bad.returncode != 0 and "COST_CHECK must be proof or separate" in bad.stderr


@pytest.mark.parametrize("folder", [p for p in FOLDERS if (p / "COST").exists()], ids=lambda p: p.name)
def test_a_recorded_cost_names_a_full_tier_item_to_witness(folder: Path) -> None:
    """The witness runs on COST's item: it must be one of the full tier's (else the runner falls back to
    the first item in item order, which need not reach COST)."""
    out = subprocess.run(["make", "-s", "-C", str(folder), "print-config", "TIER=full"], capture_output=True,
                         text=True, timeout=60)
    config = json.loads(out.stdout.strip().splitlines()[-1])
    parts = (folder / "COST").read_text(encoding="utf-8").split()
    sweep = config["sweep"].split()
    if sweep and config.get("cost_check") == "separate":
        assert len(parts) == 2 and parts[1] in sweep, f"{folder.name}: COST {parts} names no item of SWEEP"
    elif len(parts) > 1:
        assert parts[1] in sweep, f"{folder.name}: COST's item {parts[1]} is not in SWEEP"
