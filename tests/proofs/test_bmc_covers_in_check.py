"""make check judges the BMC cover points (issue #37): `make proofs-bmc` runs tools/proofs.py with
--covers, replaying the recorded cover runs from proofs/bmc/cache/, so every folder gets a judged
[cover] row; a folder whose cover runs are not recorded must be listed, with its reason, in
proofs/bmc/covers_deferred.json (its row then says "deferred"), never pass or run for minutes silently.
"""

from __future__ import annotations

import re
from concurrent.futures import Future
from pathlib import Path
from typing import Any

import pytest

from repo_tools import load_module

ROOT = Path(__file__).resolve().parents[2]
BMC = ROOT / "proofs" / "bmc"
FOLDERS = sorted(p for p in BMC.iterdir() if p.is_dir() and (p / "harness.c").is_file())
proofs = load_module("proofs", ROOT / "tools" / "proofs.py")
ev = proofs.bmc_evidence


def test_make_check_runs_the_cover_points_with_the_deferral_file() -> None:
    """make check's BMC target is the one that judges covers: --covers with the deferral file."""
    mk = (ROOT / "mk" / "proofs.mk").read_text(encoding="utf-8")
    recipe = re.search(r"^proofs-bmc:\n\t(.*)$", mk, re.MULTILINE)
    assert recipe is not None
    args = recipe.group(1).split()
    assert "tools/proofs.py" in args and args[args.index("--tier") + 1] == "fast"
    assert "--covers" in args and "--no-mutants" not in args
    assert args[args.index("--covers-deferred") + 1] == ev.DEFERRED_FILE
    assert re.search(r"^CHECK_TARGETS \+= proofs$", mk, re.MULTILINE)


def _fake_runner(monkeypatch: Any, calls: list[tuple[str, str, tuple[str, ...]]]) -> None:
    def fake_run_make(proof: Any, target: str, tier: str, out: Path, item: str = "", mutant: str = "",
                      extra: tuple[str, ...] = (), tag: str = "") -> Any:
        calls.append((proof.name, target, extra))
        if target != "reach":
            return proofs.Run("pass", 1.0)
        covers = "COVERS=0" not in extra
        claims = {ev.REACH_CLAIM: True, **({"cover: a-point": True} if covers else {})}
        return proofs.Run("fail", 1.0, claims=claims, points=["a-point"] if covers else [])

    monkeypatch.setattr(proofs, "run_make", fake_run_make)
    monkeypatch.setattr(proofs, "cover_points", lambda *a: ["a-point"])


def _proof(name: str) -> Any:
    return proofs.Proof(name, Path("."), {"fast_sweep": "PART=1", "sweep": ""}, "purpose", [], None, "", 1)


def test_a_deferred_folder_says_so_and_every_other_folder_is_judged(monkeypatch: Any) -> None:
    """With --covers-deferred the listed folder runs the plain vacuity check (COVERS=0) and its [cover]
    row is "deferred" with its reason; the others run their points and are judged (reached here)."""
    calls: list[tuple[str, str, tuple[str, ...]]] = []
    _fake_runner(monkeypatch, calls)
    reason = "its cover runs are not recorded yet: 283 s of CPU"
    rows = {r["function"]: r for r in proofs.bmc([_proof("fw_a"), _proof("fw_b")], "fast", 1, False, Path("."),
                                                 covers=True, deferred={"fw_b": reason})}
    reach = {name: extra for name, target, extra in calls if target == "reach"}
    assert "COVERS=0" not in reach["fw_a"] and "COVERS=0" in reach["fw_b"]
    assert (rows["fw_a [cover]"]["result"], rows["fw_a [cover]"]["expected"]) == ("reached", True)
    deferred = rows["fw_b [cover]"]
    assert (deferred["result"], deferred["expected"]) == ("deferred", True)
    assert reason in deferred["detail"] and ev.DEFERRED_FILE in deferred["detail"]
    # without --covers the deferral changes nothing: no [cover] row at all
    calls.clear()
    rows = {r["function"]: r for r in proofs.bmc([_proof("fw_b")], "fast", 1, False, Path("."), covers=False,
                                                 deferred={"fw_b": reason})}
    assert "fw_b [cover]" not in rows


def test_a_deferral_needs_a_written_reason(tmp_path: Path) -> None:
    path = tmp_path / "covers_deferred.json"
    path.write_text('{"fw_x": {"reason": ""}}', encoding="utf-8")
    with pytest.raises(ValueError, match="fw_x: give a written \"reason\""):
        ev.load_deferred(path)
    path.write_text('["fw_x"]', encoding="utf-8")
    with pytest.raises(ValueError, match="JSON object"):
        ev.load_deferred(path)
    path.write_text('{"fw_x": {"reason": "recording its covers takes 900 s of CPU", "cover_cpu_s": 900}}',
                    encoding="utf-8")
    assert ev.load_deferred(path) == {"fw_x": "recording its covers takes 900 s of CPU (recording them: about 900 s "
                                              "of CPU)"}


def test_the_runner_rejects_a_deferral_without_reason(tmp_path: Path, capsys: Any) -> None:
    """A bad deferral file stops the run before any proof runs (exit 2, what to write)."""
    path = tmp_path / "covers_deferred.json"
    path.write_text('{"urb_get_bits": {}}', encoding="utf-8")
    status = proofs.main(["--covers", "--covers-deferred", str(path), "--only", "urb_get_bits", "--no-mutants"])
    assert status == 2 and 'urb_get_bits: give a written "reason"' in capsys.readouterr().err


def _first_items_per_part(folder: Path) -> dict[str, str]:
    """The item of each harness part that the runner's cover run checks first (largest first), skipping
    the items that compile no cover point (proofs.run_reach_part runs those with COVERS=0: the plain
    vacuity check, as fw_rs485_master's PART=1,OP=0,AFTER=4, which goes before PART=1,OP=0)."""
    proof = proofs.load(folder, "fast")
    firsts: dict[str, str] = {}
    for item in proofs.item_order(proof.items("fast")):
        part = ev.part_of(item)
        if part not in firsts and proofs.cover_points(proof, "fast", item) != []:
            firsts[part] = item
    return firsts


def test_every_folder_has_its_cover_runs_recorded_or_a_written_deferral() -> None:
    """A folder not in proofs/bmc/covers_deferred.json has, for every harness part, the cover run of the
    part's first item recorded in proofs/bmc/cache/ (make check replays it instead of spending the
    cover run's minutes); a deferred folder exists and says why. A new proof folder fails here until its
    cover runs are recorded (python3 tools/proofs.py --covers --no-mutants --only <folder>, then
    git add proofs/bmc/cache) or it is deferred with a reason."""
    deferred = ev.load_deferred(ROOT / ev.DEFERRED_FILE)
    names = {f.name for f in FOLDERS}
    assert not set(deferred) - names, f"deferred folders that do not exist: {sorted(set(deferred) - names)}"
    missing: list[str] = []
    for folder in FOLDERS:
        if folder.name in deferred:
            continue
        recorded = ev.recorded_cover_runs(BMC / "cache", folder.name)
        for part, item in sorted(_first_items_per_part(folder).items()):
            if ev.variant_of(item) not in recorded:
                missing.append(f"{folder.name} {part or 'the harness'} ({item or 'run'})")
    assert not missing, ("cover runs not recorded in proofs/bmc/cache (record them: python3 tools/proofs.py --covers "
                         f"--no-mutants --only <folder>; or defer the folder in {ev.DEFERRED_FILE} with a reason): "
                         + "; ".join(missing))
