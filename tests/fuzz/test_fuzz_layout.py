"""The fuzzing set-up stays consistent without running a fuzzer (make fuzz runs them): every
mutant still applies to the current sources, the committed seeds match the vectors they come
from, each target has a corpus, and make proofs pulls the fuzz part in."""

from __future__ import annotations

import json
import re
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from repo_tools import load_module

ROOT = Path(__file__).resolve().parents[2]


def _fuzz() -> ModuleType:
    return load_module("urb_fuzz_tool", Path("tools/fuzz.py"))


FUZZ = _fuzz()
MUTANTS: list[dict[str, Any]] = json.loads((ROOT / "tests" / "fuzz" / "mutants.json").read_text(encoding="utf-8"))


@pytest.mark.parametrize("mutant", MUTANTS, ids=[m["name"] for m in MUTANTS])
def test_mutant_applies_to_current_sources(mutant: dict[str, Any]) -> None:
    assert mutant["target"] in FUZZ.TARGETS
    assert mutant["why"]
    if "define" in mutant:
        name = mutant["define"]
        sources = [ROOT / s for s in FUZZ.TARGETS[mutant["target"]].sources]
        assert any(re.search(rf"\b{name}\b", p.read_text(encoding="utf-8")) for p in sources), name
    else:
        text = (ROOT / mutant["file"]).read_text(encoding="utf-8")
        assert text.count(mutant["find"]) >= 1, f"{mutant['name']}: find text gone from {mutant['file']}"
        assert mutant["find"] != mutant["replace"]


def test_every_target_has_a_corpus_and_every_mutant_target_exists() -> None:
    for name in FUZZ.TARGETS:
        corpus = ROOT / "tests" / "fuzz" / "corpus" / name
        assert corpus.is_dir() and any(corpus.iterdir()), f"no corpus for {name}"
        assert (ROOT / "tests" / "fuzz" / f"{name}.c").is_file()
    assert {m["target"] for m in MUTANTS} == set(FUZZ.TARGETS), "every target has a mutant it must catch"


def test_committed_seeds_are_up_to_date(tmp_path: Path) -> None:
    FUZZ.seed(tmp_path)
    for fresh in sorted(tmp_path.rglob("seed-*")):
        committed = ROOT / "tests" / "fuzz" / "corpus" / fresh.relative_to(tmp_path)
        assert committed.is_file(), f"{committed} missing: run python3 tools/fuzz.py seed"
        assert committed.read_bytes() == fresh.read_bytes(), f"{committed} stale: run python3 tools/fuzz.py seed"
    committed_seeds = {p.relative_to(ROOT / "tests" / "fuzz" / "corpus") for p in (ROOT / "tests" / "fuzz" / "corpus").rglob("seed-*")}
    assert committed_seeds == {p.relative_to(tmp_path) for p in tmp_path.rglob("seed-*")}


def test_make_proofs_includes_fuzzing() -> None:
    mk = (ROOT / "mk" / "fuzz.mk").read_text(encoding="utf-8")
    assert re.search(r"^PROOF_PARTS \+= fuzz$", mk, re.MULTILINE)
    assert re.search(r"^fuzz: ", mk, re.MULTILINE)
