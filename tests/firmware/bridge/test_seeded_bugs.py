"""Seeded bugs the bridge's cmocka tests must catch, as find/replace edits of a copy of the sources
(tests/firmware/bridge/mutants.json), for bugs the firmware has no URB_MUTANT_* switch for (those
run in `make test-firmware-bridge`, mk/firmware_bridge.mk FWB_MUTANTS). Each copy is built like a
mutant build there (gcc -O0, no sanitizers), must FAIL, and must fail in the tests its
"expect_failed" names: the tests written for that bug, so a bug caught only by accident elsewhere
does not count. The same seeded bug "frame-max-one-short" is killed by the BMC uplink proofs and
the fuzz oracle (tests/proofs/test_bmc_proofs.py checks the three entries agree)."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[3]
HERE = Path(__file__).resolve().parent
MUTANTS: list[dict[str, Any]] = json.loads((HERE / "mutants.json").read_text(encoding="utf-8"))
KINDS = ("off-by-one", "wrong-order", "missing-publish-or-free", "wrong-field", "dropped-error", "other")


def _make_list(name: str) -> list[str]:
    """A source list of mk/firmware_bridge.mk (FWB_LIB_SRC, FWB_GEN_SRC, FWB_HOSTED_SRC)."""
    mk = (ROOT / "mk" / "firmware_bridge.mk").read_text(encoding="utf-8")
    m = re.search(rf"^{name} := (.*)$", mk, re.MULTILINE)
    assert m, f"{name} missing from mk/firmware_bridge.mk"
    return m.group(1).split()


def _test_sources() -> list[str]:
    return sorted(str(p.relative_to(ROOT)) for p in HERE.glob("*.c") if p.name != "cost_driver.c")


def test_every_seeded_bug_applies_and_names_its_tests() -> None:
    names = {m["name"] for m in MUTANTS}
    assert len(names) == len(MUTANTS)
    sources = "\n".join((HERE / s).read_text(encoding="utf-8") for s in [p.name for p in HERE.glob("*.c")])
    for m in MUTANTS:
        assert m["kind"] in KINDS, m["name"]
        assert m["find"] != m["replace"] and m["why"]
        assert (ROOT / m["file"]).read_text(encoding="utf-8").count(m["find"]) == 1, f"{m['name']}: find text"
        for test in m["expect_failed"]:
            assert re.search(rf"\bcmocka_unit_test\w*\({test}\b", sources), f"{m['name']}: no test {test}"


@pytest.mark.parametrize("mutant", MUTANTS, ids=[m["name"] for m in MUTANTS])
def test_the_bridge_tests_catch_the_seeded_bug(mutant: dict[str, Any], tmp_path: Path) -> None:
    for folder in ("firmware", "gen/c", "tests/firmware/bridge"):
        shutil.copytree(ROOT / folder, tmp_path / folder, ignore=shutil.ignore_patterns("*.py", "__pycache__"))
    target = tmp_path / mutant["file"]
    text = target.read_text(encoding="utf-8")
    target.write_text(text.replace(mutant["find"], mutant["replace"], 1), encoding="utf-8")
    sources = [*_make_list("FWB_LIB_SRC"), *_make_list("FWB_GEN_SRC"), *_make_list("FWB_HOSTED_SRC"), *_test_sources()]
    includes = [f"-I{tmp_path / d}" for d in ("firmware/include", "gen/c", "firmware/hal/hosted", "firmware/bridge")]
    binary = tmp_path / "bridge-tests"
    build = subprocess.run(["gcc", "-std=c99", "-D_DEFAULT_SOURCE", "-g", "-O0", *includes,
                            *(str(tmp_path / s) for s in sources), "-lcmocka", "-o", str(binary)],
                           capture_output=True, text=True, timeout=300)
    assert build.returncode == 0, build.stderr[-3000:]
    run = subprocess.run([str(binary)], capture_output=True, text=True, timeout=300,
                         env={"CMOCKA_MESSAGE_OUTPUT": "stdout", "PATH": "/usr/bin:/bin"})
    failed = set(re.findall(r"^\[  FAILED  \] (\w+)$", run.stdout, re.MULTILINE))
    assert run.returncode != 0, f"{mutant['name']} SURVIVED: the bridge tests pass with the seeded bug"
    missing = set(mutant["expect_failed"]) - failed
    assert not missing, f"{mutant['name']}: killed by {sorted(failed)}, but not by {sorted(missing)}"
