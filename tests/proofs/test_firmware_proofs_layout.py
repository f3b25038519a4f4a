"""Firmware proofs (proofs/bmc/fw_*/): their mutants and views stay applicable.

Checks, without running ESBMC, that the seeded mutants and proof views of every firmware proof
still apply to the current sources (they never go stale silently) and that make check runs the
firmware proofs. The folder conventions of every proof, firmware ones included, are checked by
test_bmc_proofs.py.
"""

from __future__ import annotations

import importlib.util
import json
import re
import shutil
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[2]
BMC = ROOT / "proofs" / "bmc"
FOLDERS = sorted(p for p in BMC.glob("fw_*") if p.is_dir())


def _runner() -> ModuleType:
    spec = importlib.util.spec_from_file_location("proofs_firmware", ROOT / "tools" / "proofs_firmware.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["proofs_firmware"] = module  # dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def test_there_are_firmware_proofs() -> None:
    names = {p.name for p in FOLDERS}
    assert {"fw_mailbox_outbox", "fw_mailbox_inbox"} <= names


@pytest.mark.parametrize("folder", FOLDERS, ids=[p.name for p in FOLDERS])
def test_mutants_and_views_apply(folder: Path, tmp_path: Path) -> None:
    runner = _runner()
    proof = runner.load_proof(folder, "fast")
    mutants: list[dict[str, Any]] = json.loads((folder / "mutants.json").read_text(encoding="utf-8"))
    assert len(mutants) >= 1, "every proof has at least one seeded bug"
    names = [m["name"] for m in mutants]
    assert len(names) == len(set(names))
    for m in mutants:
        assert {"name", "file", "function", "find", "replace", "why"} <= set(m)
        assert m["find"] != m["replace"]
        work = tmp_path / m["name"]
        src = runner.prepare(proof, work, m)
        assert (src / m["file"]).read_text(encoding="utf-8").count(m["replace"]) >= 1
        shutil.rmtree(work)
    runner.prepare(proof, tmp_path / "base", None)  # views apply to the unmutated sources


def test_make_check_runs_the_firmware_proofs() -> None:
    # make check -> make proofs -> make proofs-bmc -> tools/proofs.py, which runs every folder with a harness
    mk = (ROOT / "mk" / "proofs.mk").read_text(encoding="utf-8")
    assert re.search(r"^CHECK_TARGETS \+= proofs$", mk, re.MULTILINE)
    runner = (ROOT / "tools" / "proofs.py").read_text(encoding="utf-8")
    assert 'BMC_DIR.iterdir() if p.is_dir() and (p / "harness.c").is_file()' in runner
