"""Seeded bugs the Cortex-M0+ port tests must catch (tests/firmware/cm0hal/mutants.json): each is a
find/replace edit of a copy of one port source (urb_cm0_fdcan.c, urb_cm0_usart485.c); the copy is
built into the test program the entry names, as mk/node_downlinks_cm0.mk builds it (gcc -O0, no
sanitizers, the strict warning set, so a seeded bug that does not compile cleanly is an error of the
entry), and that program must FAIL, in the tests "expect_failed" names."""

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
STRICT = ["-std=c99", "-Wall", "-Wextra", "-Wconversion", "-Wsign-conversion", "-Wpedantic", "-Werror"]


def _make_list(name: str) -> list[str]:
    """A source list of mk/node_downlinks_cm0.mk (CM0HAL_SRC_<program>, with continuation lines)."""
    mk = (ROOT / "mk" / "node_downlinks_cm0.mk").read_text(encoding="utf-8").replace("\\\n", " ")
    m = re.search(rf"^{name} := (.*)$", mk, re.MULTILINE)
    assert m, f"{name} missing from mk/node_downlinks_cm0.mk"
    return m.group(1).split()


def test_every_seeded_bug_applies_and_names_its_tests() -> None:
    names = {m["name"] for m in MUTANTS}
    assert len(names) == len(MUTANTS)
    for m in MUTANTS:
        assert m["kind"] in KINDS, m["name"]
        assert m["find"] != m["replace"] and m["why"]
        assert (ROOT / m["file"]).read_text(encoding="utf-8").count(m["find"]) == 1, f"{m['name']}: find text"
        source = (HERE / f"{m['program']}.c").read_text(encoding="utf-8")
        for test in m["expect_failed"]:
            assert re.search(rf"\bcmocka_unit_test\w*\({test}\b", source), f"{m['name']}: no test {test}"


@pytest.mark.parametrize("mutant", MUTANTS, ids=[m["name"] for m in MUTANTS])
def test_the_port_tests_catch_the_seeded_bug(mutant: dict[str, Any], tmp_path: Path) -> None:
    for folder in ("firmware", "gen/c", "tests/firmware/cm0hal"):
        shutil.copytree(ROOT / folder, tmp_path / folder, ignore=shutil.ignore_patterns("*.py", "__pycache__"))
    target = tmp_path / mutant["file"]
    text = target.read_text(encoding="utf-8")
    target.write_text(text.replace(mutant["find"], mutant["replace"], 1), encoding="utf-8")
    sources = _make_list(f"CM0HAL_SRC_{mutant['program']}")
    includes = [f"-I{tmp_path / d}" for d in ("firmware/include", "firmware/node", "firmware/hal/cortex-m0plus",
                                               "firmware/apps/echo", "gen/c", "tests/firmware/cm0hal")]
    binary = tmp_path / mutant["program"]
    build = subprocess.run(["gcc", *STRICT, "-D_DEFAULT_SOURCE", "-DURB_CM0_USART_TEST_HOOK", "-g", "-O0", *includes,
                            *(str(tmp_path / s) for s in sources), "-lcmocka", "-o", str(binary)],
                           capture_output=True, text=True, timeout=300)
    assert build.returncode == 0, build.stderr[-3000:]
    run = subprocess.run([str(binary)], capture_output=True, text=True, timeout=300,
                         env={"CMOCKA_MESSAGE_OUTPUT": "stdout", "PATH": "/usr/bin:/bin"})
    failed = set(re.findall(r"^\[  FAILED  \] (\w+)$", run.stdout, re.MULTILINE))
    assert run.returncode != 0, f"{mutant['name']} SURVIVED: {mutant['program']} passes with the seeded bug"
    missing = set(mutant["expect_failed"]) - failed
    assert not missing, f"{mutant['name']}: killed by {sorted(failed)}, but not by {sorted(missing)}"
