"""Firmware and host-library proofs (proofs/bmc/fw_*/, host_*/): their mutants and views stay applicable.

Checks, without running ESBMC, that the seeded mutants and proof views of every firmware proof
still apply to the current sources (they never go stale silently) and that make check runs the
firmware proofs. The folder conventions of every proof, firmware ones included, are checked by
test_bmc_proofs.py.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from repo_tools import load_module

ROOT = Path(__file__).resolve().parents[2]
BMC = ROOT / "proofs" / "bmc"
# the host library's proofs (host_*) seed their bugs the same way
FOLDERS = sorted(p for p in [*BMC.glob("fw_*"), *BMC.glob("host_*")] if p.is_dir())


def _prepare() -> ModuleType:
    return load_module("prepare", BMC / "prepare.py")


def _source_dirs(folder: Path) -> list[str]:
    out = subprocess.run(["make", "-s", "-C", str(folder), "print-config", "TIER=fast"], capture_output=True,
                         text=True, timeout=60, check=True)
    dirs: list[str] = json.loads(out.stdout.strip().splitlines()[-1])["source_dirs"].split()
    return dirs


def test_there_are_firmware_proofs() -> None:
    names = {p.name for p in FOLDERS}
    assert {"fw_mailbox_outbox", "fw_mailbox_inbox"} <= names


@pytest.mark.parametrize("folder", FOLDERS, ids=[p.name for p in FOLDERS])
def test_mutants_and_views_apply(folder: Path, tmp_path: Path) -> None:
    prep = _prepare()
    dirs = _source_dirs(folder)
    mutants: list[dict[str, Any]] = json.loads((folder / "mutants.json").read_text(encoding="utf-8"))
    assert len(mutants) >= 1, "every proof has at least one seeded bug"
    names = [m["name"] for m in mutants]
    assert len(names) == len(set(names))
    views = folder / "views.json"
    for m in mutants:
        assert {"name", "file", "function", "find", "replace", "why"} <= set(m)
        assert m.get("tier", "fast") in ("fast", "full"), f"{m['name']}: tier is fast (default) or full"
        assert m["find"] != m["replace"]
        work = tmp_path / m["name"]
        src = prep.prepare(work, dirs, folder / "mutants.json", m["name"], views_file=views if views.exists() else None)
        assert (src / m["file"]).read_text(encoding="utf-8").count(m["replace"]) >= 1
        shutil.rmtree(work)
    if views.exists():
        src = prep.prepare(tmp_path / "base", dirs, None, None, views_file=views)  # views apply to the unmutated sources
        for view in json.loads(views.read_text(encoding="utf-8")):
            assert view.get("why"), "every view says why it keeps the meaning"
            assert view["replace"] in (src / view["file"]).read_text(encoding="utf-8")


def test_a_view_that_no_longer_matches_is_an_error(tmp_path: Path) -> None:
    prep = _prepare()
    stale = tmp_path / "views.json"
    stale.write_text(json.dumps([{"file": "firmware/node/urb_mailbox.c", "function": "urb_lock_inbox_any",
                                  "find": "no such code;", "replace": "x;", "why": "test"}]), encoding="utf-8")
    with pytest.raises(prep.PrepareError, match="update views.json"):
        prep.prepare(tmp_path / "out", ["firmware/include", "firmware/node", "gen/c"], None, None, views_file=stale)


def test_full_tier_mutants_are_left_to_the_full_tier() -> None:
    """A seeded bug that needs a bound only the full tier has would survive the fast tier."""
    proofs = load_module("proofs", ROOT / "tools" / "proofs.py")
    rs232 = proofs.load(BMC / "fw_bridge_rs232_parser", "fast")
    fast = {m["name"] for m in rs232.mutants_of("fast")}
    full = {m["name"] for m in rs232.mutants_of("full")}
    assert {"flush-drops-frames", "budget-not-spent"} <= full - fast
    assert fast < full
    items = rs232.items("full")
    for m in rs232.mutants:
        if m.get("tier") == "full":
            assert m["item"] in items and m["item"] not in rs232.items("fast"), m["name"]


def test_make_check_runs_the_firmware_proofs() -> None:
    # make check -> make proofs -> make proofs-bmc -> tools/proofs.py, which runs every folder with a harness
    mk = (ROOT / "mk" / "proofs.mk").read_text(encoding="utf-8")
    assert re.search(r"^CHECK_TARGETS \+= proofs$", mk, re.MULTILINE)
    runner = (ROOT / "tools" / "proofs.py").read_text(encoding="utf-8")
    assert 'BMC_DIR.iterdir() if p.is_dir() and (p / "harness.c").is_file()' in runner
