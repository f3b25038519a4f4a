"""Layout of the firmware proofs (proofs/bmc/fw_*/) and of the fuzzing set-up (tests/fuzz/).

Checks, without running ESBMC or a fuzzer, that every firmware proof folder follows the proofs/bmc
conventions, that its seeded mutants and proof views still apply to the current sources (they
never go stale silently), that harnesses use only the tool-neutral vocabulary of urb_verify.h,
and that make check runs the firmware proofs.
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
BUILTINS = re.compile(r"__(ESBMC|CPROVER|VERIFIER)_\w+|\bnondet_\w+\s*\(")


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
def test_folder_convention(folder: Path) -> None:
    for name in ("harness.c", "Makefile", "PURPOSE", "mutants.json"):
        assert (folder / name).is_file(), f"{folder.name}: {name} missing"
    purpose = (folder / "PURPOSE").read_text(encoding="utf-8").strip()
    assert purpose and "\n" not in purpose, "PURPOSE is one line"
    makefile = (folder / "Makefile").read_text(encoding="utf-8")
    assert re.search(r"^include \.\./Makefile\.common$", makefile, re.MULTILINE), "includes ../Makefile.common"
    assert re.search(r"^UNWIND = \d+$", makefile, re.MULTILINE), "sets UNWIND (unwinding assertions stay on)"
    assert "--no-unwinding-assertions" not in makefile and "--partial-loops" not in makefile
    harness = (folder / "harness.c").read_text(encoding="utf-8")
    assert re.search(r"^void harness\(void\)$", harness, re.MULTILINE)
    assert '#include "urb_verify.h"' in harness
    code = re.sub(r"/\*.*?\*/", "", harness, flags=re.DOTALL)
    assert not BUILTINS.search(code), "harnesses use URB_ASSUME/URB_ASSERT/URB_NONDET_* only"


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
