"""Fast checks of the TLA+ suite's bookkeeping and of the TLC output parser.

TLC itself runs once, in `make modelcheck` (tools/modelcheck.py), not here: these tests make sure
the manifest matches the files on disk, that every invariant and property has a must-fail mutant,
and that the parser recognises success, each kind of violation and errors (so a broken parser
cannot turn a failure into a pass).
"""

from __future__ import annotations

import re
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from repo_tools import load_module

ROOT = Path(__file__).resolve().parents[2]
SPEC = ROOT / "spec" / "tla"


def _load_runner() -> ModuleType:
    return load_module("modelcheck", Path("tools/modelcheck.py"))


mc: Any = _load_runner()


def _invariants(cfg: Path) -> list[str]:
    return [w for line in cfg.read_text().splitlines() if line.startswith("INVARIANT")
            for w in line.split()[1:]]


def _properties(cfg: Path) -> list[str]:
    return [w for line in cfg.read_text().splitlines() if line.startswith("PROPERT")
            for w in line.split()[1:]]


@pytest.fixture(scope="module")
def manifest() -> Any:
    data, entries = mc.load_manifest()
    return data, entries


# ------------------------------------------------------------------ manifest against files


def test_manifest_lists_every_file_and_only_existing_ones(manifest: Any) -> None:
    _, entries = manifest
    listed: set[str] = set()
    for e in entries:
        for rel in (e.module, e.config):
            assert (SPEC / rel).is_file(), f"{e.name}: {rel} does not exist"
            listed.add(rel)
    data, _ = manifest
    for rows in data["mutation"]["modules"].values():
        for row in rows:
            if isinstance(row, dict):
                assert (SPEC / row["config"]).is_file(), f"mutation config {row['config']} does not exist"
                listed.add(row["config"])
    on_disk = {p.relative_to(SPEC).as_posix() for p in SPEC.rglob("*") if p.suffix in {".tla", ".cfg"}}
    # Base modules are used through their MC module or a mutant that EXTENDS them.
    extended = set()
    for rel in listed:
        if rel.endswith(".tla"):
            extended |= {f"{m.strip()}.tla" for m in
                         re.findall(r"^EXTENDS\s+(.+)$", (SPEC / rel).read_text(), re.M)[0].split(",")}
    orphans = on_disk - listed - extended
    assert not orphans, f"files in spec/tla not in the manifest (orphans): {sorted(orphans)}"


def test_mutation_configs_check_what_their_model_checks(manifest: Any) -> None:
    """A smaller configuration for the mutation run may change constants, never the checks."""
    data, entries = manifest
    models = {e.name: e for e in entries if e.kind == "model"}
    for rows in data["mutation"]["modules"].values():
        for row in rows:
            if isinstance(row, dict):
                mine, theirs = SPEC / row["config"], SPEC / models[row["model"]].config
                assert _invariants(mine) == _invariants(theirs), row
                assert _properties(mine) == _properties(theirs), row
                spec = [ln for ln in mine.read_text().splitlines() if ln.startswith("SPECIFICATION")]
                assert spec == [ln for ln in theirs.read_text().splitlines() if ln.startswith("SPECIFICATION")]


def test_names_are_unique_and_models_have_counts(manifest: Any) -> None:
    _, entries = manifest
    names = [e.name for e in entries]
    assert len(names) == len(set(names))
    for e in entries:
        if e.kind == "model" and not e.optional:
            assert isinstance(e.distinct_states, int) and e.distinct_states > 0, e.name
            assert isinstance(e.depth, int) and e.depth > 0, e.name


def test_every_mutant_targets_exactly_its_expected_violation(manifest: Any) -> None:
    _, entries = manifest
    for e in entries:
        if e.kind != "mutant":
            continue
        cfg = SPEC / e.config
        targets = [n for n in _invariants(cfg) + _properties(cfg) if n != "TypeOK"]
        if e.expect_violation == mc.ASSUMPTION:
            # refuted by its own ASSUME, before any state: the cfg must not check anything else
            assert targets == [], f"{e.name}: an ASSUME mutant's cfg checks {targets}"
            assert re.search(r"^ASSUME ", (SPEC / e.module).read_text(), re.M), f"{e.name}: no ASSUME"
        else:
            assert targets == [e.expect_violation], f"{e.name}: cfg checks {targets}"
        text = (SPEC / e.module).read_text()
        assert f"Expected: {e.expect_violation.removeprefix('Mut')}" in text, (
            f"{e.name}: the mutant's comment must say which violation it expects")


def test_every_invariant_and_property_has_a_must_fail_mutant(manifest: Any) -> None:
    _, entries = manifest
    covered = {e.covers for e in entries if e.kind == "mutant"}
    missing = []
    for e in entries:
        if e.kind != "model":
            continue
        spec = e.raw["spec"]
        cfg = SPEC / e.config
        for name in _invariants(cfg) + _properties(cfg):
            if name != "TypeOK" and f"{spec}.{name}" not in covered:
                missing.append(f"{spec}.{name}")
    assert not missing, f"invariants/properties without a must-fail mutant: {sorted(set(missing))}"


def test_readme_maps_every_invariant(manifest: Any) -> None:
    _, entries = manifest
    readme = (SPEC / "README.md").read_text()
    for e in entries:
        if e.kind == "mutant":
            assert e.name in readme, f"README does not mention mutant {e.name}"
            assert e.covers.split(".")[1] in readme


# ------------------------------------------------------------------ TLC output parser

SUCCESS = """\
TLC2 Version 2.15 of Day Month 20?? (rev: d5b5a7f)
Computing initial states...
Finished computing initial states: 1 distinct state generated at 2026-11-21 23:36:22.
Model checking completed. No error has been found.
  Estimates of the probability that TLC did not check all reachable states
  calculated (optimistic):  val = 1.6E-12
10,827 states generated, 5,485 distinct states found, 0 states left on queue.
The depth of the complete state graph search is 33.
Finished in 00s at (2026-11-21 23:36:23)
"""

INVARIANT = """\
TLC2 Version 2.15 of Day Month 20?? (rev: d5b5a7f)
Error: Invariant NoAbortedDelivered is violated.
Error: The behavior up to this point is:
State 1: <Initial predicate>
/\\ front = 0
505 states generated, 312 distinct states found, 40 states left on queue.
The depth of the complete state graph search is 12.
"""

TEMPORAL = """\
Checking 4 branches of temporal properties for the complete state space with 5902 total distinct states
Error: Temporal properties were violated.

Error: The following behavior constitutes a counter-example:
State 1: <Initial predicate>
State 6: Stuttering
12000 states generated, 5902 distinct states found, 0 states left on queue.
"""

DEADLOCK = """\
Error: Deadlock reached.
Error: The behavior up to this point is:
State 1: <Initial predicate>
76436 states generated, 36106 distinct states found, 9636 states left on queue.
"""

ASSUMPTION = """\
Error: Assumption line 9, col 8 to line 9, col 52 of module Bridge_OrderSkipsLastPair is false.
Finished in 00s at (2026-11-25 12:20:01)
"""

PARSE_ERROR = """\
Unknown operator: `b'.
Error: Parsing or semantic analysis failed.
"""


def test_parse_success() -> None:
    r = mc.parse_tlc_output(SUCCESS, 0)
    assert (r.outcome, r.distinct_states, r.generated_states, r.depth) == ("pass", 5485, 10827, 33)


def test_success_text_with_bad_exit_code_is_not_a_pass() -> None:
    assert mc.parse_tlc_output(SUCCESS, 1).outcome == "error"


def test_parse_invariant_violation() -> None:
    r = mc.parse_tlc_output(INVARIANT, 12)
    assert (r.outcome, r.violated, r.distinct_states) == ("invariant", "NoAbortedDelivered", 312)


def test_parse_temporal_violation_names_the_single_property() -> None:
    cfg = "CONSTANTS A = 1\nSPECIFICATION MutSpec\nPROPERTIES EveryRequestAnswered\n"
    r = mc.parse_tlc_output(TEMPORAL, 13, cfg)
    assert (r.outcome, r.violated) == ("property", "EveryRequestAnswered")


def test_parse_temporal_violation_with_several_properties_is_ambiguous() -> None:
    cfg = "SPECIFICATION Spec\nPROPERTIES P1 P2\n"
    r = mc.parse_tlc_output(TEMPORAL, 13, cfg)
    assert r.outcome == "property" and r.violated is None and "P1, P2" in r.message


def test_parse_false_assumption() -> None:
    r = mc.parse_tlc_output(ASSUMPTION, 12)
    assert (r.outcome, r.violated) == ("assumption", mc.ASSUMPTION)
    assert "module Bridge_OrderSkipsLastPair" in r.message


def test_judge_assumption_mutant() -> None:
    run = mc.RunOutcome(_entry("mutant", expect_violation=mc.ASSUMPTION), mc.parse_tlc_output(ASSUMPTION, 12), 1.0, "")
    mc.judge(run, update=False)
    assert run.ok
    run = mc.RunOutcome(_entry("mutant", expect_violation=mc.ASSUMPTION), mc.parse_tlc_output(INVARIANT, 12), 1.0, "")
    mc.judge(run, update=False)
    assert not run.ok and "wrong violation" in run.problems[0]
    run = mc.RunOutcome(_entry("model", distinct_states=1), mc.parse_tlc_output(ASSUMPTION, 12), 1.0, "")
    mc.judge(run, update=False)
    assert not run.ok and "assumption" in run.problems[0], "a false ASSUME fails a good model"


def test_parse_deadlock_and_errors() -> None:
    assert mc.parse_tlc_output(DEADLOCK, 11).outcome == "deadlock"
    r = mc.parse_tlc_output(PARSE_ERROR, 150)
    assert r.outcome == "error" and "Parsing or semantic analysis failed" in r.message
    assert mc.parse_tlc_output("", 1).outcome == "error"


def _entry(kind: str, **kw: object) -> Any:
    base: dict[str, object] = {"name": "X", "module": "X.tla", "config": "X.cfg", "kind": kind}
    base.update(kw)
    return mc.Entry(**base)


def test_judge_model_state_count_and_verdicts() -> None:
    good = mc.parse_tlc_output(SUCCESS, 0)
    run = mc.RunOutcome(_entry("model", distinct_states=5485, depth=33), good, 1.0, SUCCESS)
    mc.judge(run, update=False)
    assert run.ok
    run = mc.RunOutcome(_entry("model", distinct_states=5484, depth=33), good, 1.0, SUCCESS)
    mc.judge(run, update=False)
    assert not run.ok and "distinct states changed" in run.problems[0]
    run = mc.RunOutcome(_entry("model", distinct_states=5485, depth=30), good, 1.0, SUCCESS)
    mc.judge(run, update=False)
    assert run.ok and run.notes, "depth is recorded but may vary with several workers"
    run = mc.RunOutcome(_entry("model", distinct_states=312), mc.parse_tlc_output(INVARIANT, 12), 1.0, "")
    mc.judge(run, update=False)
    assert not run.ok and "NoAbortedDelivered" in run.problems[0]


def test_judge_mutant_must_fail_with_the_expected_name() -> None:
    viol = mc.parse_tlc_output(INVARIANT, 12)
    run = mc.RunOutcome(_entry("mutant", expect_violation="NoAbortedDelivered"), viol, 1.0, "")
    mc.judge(run, update=False)
    assert run.ok
    run = mc.RunOutcome(_entry("mutant", expect_violation="AppReadNotTorn"), viol, 1.0, "")
    mc.judge(run, update=False)
    assert not run.ok and "wrong violation" in run.problems[0]
    run = mc.RunOutcome(_entry("mutant", expect_violation="AppReadNotTorn"),
                        mc.parse_tlc_output(SUCCESS, 0), 1.0, "")
    mc.judge(run, update=False)
    assert not run.ok and "not refuted" in run.problems[0]


def test_junit_is_written(tmp_path: Path) -> None:
    viol = mc.parse_tlc_output(INVARIANT, 12)
    ok = mc.RunOutcome(_entry("mutant", expect_violation="NoAbortedDelivered"), viol, 1.0, "")
    bad = mc.RunOutcome(_entry("model", distinct_states=1), viol, 2.0, "log text")
    for r in (ok, bad):
        mc.judge(r, update=False)
    out = tmp_path / "junit.xml"
    mc.write_junit([ok, bad], out)
    text = out.read_text()
    assert 'tests="2"' in text and 'failures="1"' in text and "log text" in text


def test_missing_java_is_a_clear_setup_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(mc.shutil, "which", lambda _name: None)
    with pytest.raises(mc.SetupError, match="default-jre-headless"):
        mc.find_java()
    monkeypatch.setenv("PATH", "")
    assert mc.main(["--only", "MCMailboxOutbox"]) == 2


def test_tlc_runs_map_their_classes_from_the_class_archive(manifest: Any, monkeypatch: pytest.MonkeyPatch,
                                                          tmp_path: Path) -> None:
    """Witness that modelcheck's JVMs get urb_sim.tlc.class_archive's options (the archive's own
    behaviour, a damaged one costing only speed, is tests/sim/test_tlc_cds.py's): the first run
    asks the JVM to write the archive, a later one to map it."""
    import subprocess

    try:
        java, jar = mc.find_java(), mc.find_jar()
    except mc.SetupError as exc:
        pytest.fail(f"TLC is part of the environment (tools/setup.sh): {exc}")
    from urb_sim import tlc

    archive_dir = tmp_path / "cds"
    real_archive = tlc.class_archive
    monkeypatch.setattr(mc, "class_archive", lambda j, p: real_archive(j, p, archive_dir))
    commands: list[list[str]] = []

    def fake_run(cmd: list[str], **_kw: Any) -> subprocess.CompletedProcess[str]:
        commands.append(cmd)
        written = [a.split("=", 1)[1] for a in cmd if a.startswith("-XX:ArchiveClassesAtExit=")]
        for path in written:  # what the JVM does at exit
            Path(path).write_bytes(b"archive")
        return subprocess.CompletedProcess(cmd, 0, "Model checking completed. No error has been found.\n", "")

    monkeypatch.setattr(mc.subprocess, "run", fake_run)
    entry = next(e for e in manifest[1] if e.name == "MCMailboxOutbox")
    mc.run_tlc(entry, java, jar, 1)
    mc.run_tlc(entry, java, jar, 1)
    options = [[a for a in cmd if a.startswith("-XX:") and "Archive" in a] for cmd in commands]
    assert [len(o) for o in options] == [1, 1], f"no class archive options in {commands}"
    assert [o[0].split("=", 1)[0] for o in options] == ["-XX:ArchiveClassesAtExit", "-XX:SharedArchiveFile"]
    assert options[1][0] == f"-XX:SharedArchiveFile={next(archive_dir.glob('*.jsa'))}"
