"""tools/framac_cache.py through tools/proofs_framac.py's run_cached: a Frama-C run is replayed only
when nothing it reads has changed.

A fake frama-c (a shell script that counts its runs and writes Eva's two CSV reports, with an alarm
when the header holds BUG) stands in for the real one, so each test shows when Frama-C runs and when
its recorded run is replayed."""

from __future__ import annotations

import gzip
import json
import shutil
from pathlib import Path
from typing import Any

import pytest

from repo_tools import load_module

RUNNER = load_module("proofs_framac", Path("tools/proofs_framac.py"))
CACHE = RUNNER.framac_cache

FAKE = r"""#!/bin/sh
case "$1" in
  -version) echo "{version}"; exit 0;;
  -print-share-path) echo "{share}"; exit 0;;
esac
echo run >> "{count}"
prev=""
for a in "$@"; do
  case "$prev" in -eva-report-red-statuses) red="$a";; -report-csv) csv="$a";; esac
  prev="$a"
done
echo "[kernel] Parsing {repo}/m.c"
{tail}
printf 'directory\tfile\tline\tfunction\tproperty kind\tstatus\tproperty\n' > "$csv"
if grep -q BUG "{repo}/inc/x.h"; then
  printf '{repo}\tm.c\t3\tf\tAlarm\tUnknown\tmem_access: \\valid(p)\n' >> "$csv"
fi
printf 'directory\tfile\tline\tfunction\tkind\tname\tstatus\t#contexts\tproperty\n' > "$red"
"""


def make_repo(root: Path, version: str = "25.0 (fake)", tail: str = "") -> Path:
    repo = root / "repo"
    (repo / "inc").mkdir(parents=True)
    (repo / "m.c").write_text('#include "x.h"\nint f(int *p) { return *p + X; }\n', encoding="utf-8")
    (repo / "inc" / "x.h").write_text("#define X 1\n", encoding="utf-8")
    (repo / "inc" / "unused.h").write_text("#define Y 2\n", encoding="utf-8")
    (root / "share" / "libc").mkdir(parents=True, exist_ok=True)
    (root / "bin").mkdir(exist_ok=True)
    fake = root / "bin" / "frama-c"
    fake.write_text(FAKE.format(version=version, share=root / "share", count=root / "count", repo=repo, tail=tail),
                    encoding="utf-8")
    fake.chmod(0o755)
    return repo


@pytest.fixture(autouse=True)
def fake_tools(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("PATH", f"{tmp_path / 'bin'}:/usr/bin:/bin")
    monkeypatch.setenv(CACHE.ENV, "on")
    for name in (f"{CACHE.ENV}_VERIFY", f"{CACHE.ENV}_SEED", f"{CACHE.ENV}_VERIFY_MAX_CPU"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(CACHE, "_MEMO", {})  # tool versions are looked up once per process


def use_repo(repo: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(RUNNER, "ROOT", repo)
    monkeypatch.setattr(RUNNER, "RESULTS_DIR", repo / "results")
    monkeypatch.setattr(CACHE, "_MEMO", {})


def run_eva(repo: Path, *flags: str) -> Any:
    unit = RUNNER.Unit("u", repo, "eva", "purpose", ["m.c"], ["-Iinc", *flags], [], [], {})
    report = repo / "build" / "u.csv"
    report.parent.mkdir(exist_ok=True)
    cmd = RUNNER.framac_command(unit, unit.sources, unit.cpp, [], report, 1, "offline", RUNNER.CACHE_DIR)
    run = RUNNER.run_cached(unit, "unit", cmd, repo / "build" / "u.log", report, "offline", RUNNER.CACHE_DIR)
    run.alarms = RUNNER.eva_alarms(report) if report.is_file() else None
    return run


def framac_runs(root: Path) -> int:
    return len((root / "count").read_text().splitlines()) if (root / "count").exists() else 0


def entries(repo: Path) -> list[Path]:
    return sorted((repo / "results").glob("*/*.json.gz"))


def test_a_recorded_run_is_replayed_with_its_reports_and_this_clones_paths(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    repo = make_repo(tmp_path)
    (repo / "inc" / "x.h").write_text("#define X 1 /* BUG */\n", encoding="utf-8")
    use_repo(repo, monkeypatch)
    first = run_eva(repo)
    assert first.cache_note.startswith("recorded results/u/") and not first.replayed
    assert first.alarms == ["m.c:f: Alarm: mem_access: \\valid(p)"]
    [entry] = entries(repo)
    assert str(repo) not in gzip.decompress(entry.read_bytes()).decode(), "the entry names <repo>, not this clone"
    second = run_eva(repo)
    assert second.replayed and framac_runs(tmp_path) == 1, "the second run is a replay"
    assert second.alarms == first.alarms and f"Parsing {repo}/m.c" in second.log
    assert "urb-framac-cache: hit" in (repo / "build" / "u.log").read_text()
    # A clone elsewhere (another repository path) has the same keys and gets its own paths back.
    moved = tmp_path / "elsewhere" / "repo"
    shutil.copytree(repo, moved)
    use_repo(moved, monkeypatch)
    third = run_eva(moved)
    assert third.replayed and framac_runs(tmp_path) == 1 and f"Parsing {moved}/m.c" in third.log
    assert f"{moved}\tm.c" in (moved / "build" / "u.csv").read_text()


@pytest.mark.parametrize("change", ["header byte", "flag", "frama-c version"])
def test_any_change_to_what_the_run_reads_runs_framac_again(
        change: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    repo = make_repo(tmp_path)
    use_repo(repo, monkeypatch)
    assert run_eva(repo).alarms == []
    flags: tuple[str, ...] = ()
    if change == "header byte":
        (repo / "inc" / "x.h").write_text("#define X 1 /* BUG */\n", encoding="utf-8")
    elif change == "flag":
        flags = ("-DURB_OTHER=1",)
    else:
        shutil.rmtree(repo)
        make_repo(tmp_path, version="26.0 (fake)")
        use_repo(repo, monkeypatch)
    again = run_eva(repo, *flags)
    assert not again.replayed and framac_runs(tmp_path) == 2
    assert again.alarms == (["m.c:f: Alarm: mem_access: \\valid(p)"] if change == "header byte" else [])
    assert len(entries(repo)) == (1 if change == "frama-c version" else 2)


def test_a_header_the_run_does_not_include_leaves_the_key_alone(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    repo = make_repo(tmp_path)
    use_repo(repo, monkeypatch)
    run_eva(repo)
    (repo / "inc" / "unused.h").write_text("#define Y 3\n", encoding="utf-8")
    assert run_eva(repo).replayed and framac_runs(tmp_path) == 1


def test_a_run_without_a_verdict_is_never_recorded(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    repo = make_repo(tmp_path, tail='echo "[kernel] User Error: boom"; exit 1')
    use_repo(repo, monkeypatch)
    for _ in range(2):
        run = run_eva(repo)
        assert not run.ok and not run.replayed and not run.cache_note
    assert framac_runs(tmp_path) == 2 and not entries(repo)


def _wp_run(answer: dict[str, Any]) -> Any:
    props = {"wp:section": {"wp:main": {"total": 1, "valid": int("valid" in answer.get("z3", {}))}},
             "f_assert": {"wp:main": {"total": 1, **({"valid": 1} if "valid" in answer.get("z3", {}) else {})},
                          "qed": {"total": 1}, **answer}}
    return RUNNER.FramacRun(True, 1.0, "", {"wp:functions": {"f": props}})


def test_a_wp_run_with_a_goal_no_prover_answered_has_no_verdict(tmp_path: Path) -> None:
    """Offline, a goal missing from proofs/framac/cache has no answer (CACHE MISS): never recorded."""
    assert RUNNER.outcome("wp", _wp_run({}), tmp_path / "r.json") is None
    answered = RUNNER.outcome("wp", _wp_run({"z3": {"total": 1, "valid": 1}}), tmp_path / "r.json")
    assert answered == {"f": {"proved": 1, "total": 1, "unproved": [], "goals": ["f_assert"], "by": {"z3": 1}}}
    assert RUNNER.outcome("wp", RUNNER.FramacRun(False, 1.0, "killed"), tmp_path / "r.json") is None


def test_wp_runs_use_the_cache_only_offline_on_the_committed_answers(tmp_path: Path,
                                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    """In update mode provers may add answers during the run, and --prune-cache replays from copies:
    both run Frama-C for real and record nothing."""
    repo = make_repo(tmp_path)
    use_repo(repo, monkeypatch)
    unit = RUNNER.Unit("w", repo, "wp", "purpose", ["m.c"], ["-Iinc"], [], [], {})
    calls: list[str] = []
    monkeypatch.setattr(RUNNER, "run_framac", lambda *a: calls.append("real") or RUNNER.FramacRun(False, 0.0, ""))
    for cache, folder in (("update", RUNNER.CACHE_DIR), ("offline", tmp_path / "copies")):
        run = RUNNER.run_cached(unit, "unit", ["frama-c", "m.c"], repo / "w.log", repo / "w.json", cache, folder)
        assert not run.cache_note
    assert calls == ["real", "real"] and not entries(repo)


def test_off_and_refresh(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    repo = make_repo(tmp_path)
    use_repo(repo, monkeypatch)
    monkeypatch.setenv(CACHE.ENV, "off")
    assert not run_eva(repo).cache_note and not entries(repo), "off records nothing"
    monkeypatch.setenv(CACHE.ENV, "on")
    run_eva(repo)
    monkeypatch.setenv(CACHE.ENV, "refresh")
    run = run_eva(repo)
    assert run.cache_note.startswith("recorded") and not run.replayed and framac_runs(tmp_path) == 3
    monkeypatch.setenv(CACHE.ENV, "sometimes")
    with pytest.raises(CACHE.CacheError, match="not one of on, off, refresh"):
        CACHE.mode()


def test_the_spot_check_catches_a_wrong_recorded_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A seeded wrong entry (the alarm dropped from the recorded report) is replayed as it is without
    a spot check, and rejected when the spot check picks it; a correct entry passes its check."""
    repo = make_repo(tmp_path)
    (repo / "inc" / "x.h").write_text("#define X 1 /* BUG */\n", encoding="utf-8")
    use_repo(repo, monkeypatch)
    assert run_eva(repo).alarms
    [entry_file] = entries(repo)
    with gzip.open(entry_file, "rt", encoding="utf-8") as fh:
        entry = json.load(fh)
    good = dict(entry["outputs"])
    entry["outputs"]["u.csv"] = entry["outputs"]["u.csv"].splitlines()[0] + "\n"
    entry_file.write_bytes(gzip.compress(json.dumps(entry).encode()))
    assert run_eva(repo).alarms == [], "replayed as recorded: what the spot check is for"
    monkeypatch.setenv(f"{CACHE.ENV}_VERIFY", "1000")
    monkeypatch.setenv(f"{CACHE.ENV}_VERIFY_MAX_CPU", "-1")
    assert run_eva(repo).replayed, "runs over the CPU limit are never spot-checked"
    monkeypatch.setenv(f"{CACHE.ENV}_VERIFY_MAX_CPU", "30")
    checked = run_eva(repo)
    assert "SPOT CHECK FAILED" in checked.cache_wrong and framac_runs(tmp_path) == 2
    assert checked.alarms, "the unit is judged on the real run"
    entry_file.write_bytes(gzip.compress(json.dumps(dict(entry, outputs=good)).encode()))
    checked = run_eva(repo)
    assert not checked.cache_wrong and checked.cache_note.startswith("spot-checked")


def test_spot_check_sample_follows_the_seed() -> None:
    keys = [f"{i:064x}" for i in range(2000)]
    picked = [k for k in keys if CACHE.spot_checked(k, "abc", 20)]
    assert 15 <= len(picked) <= 70
    assert picked != [k for k in keys if CACHE.spot_checked(k, "abd", 20)]
    assert not any(CACHE.spot_checked(k, "abc", 0) for k in keys)


def test_evidence_items_say_which_runs_were_replayed() -> None:
    cached = {"runs_replayed_from_cache": 1, "computed_on": "abc123 2026-11-29T06:50:00Z", "framac_cpu_s": 12.5,
              "result_cache": "hit"}
    rows = [RUNNER.Row("u", "frama-c eva", "0 alarms", "-", "no alarm", True, 0.1, "", "u", {"alarms": [], **cached}),
            RUNNER.Row("f", "frama-c wp", "1/1 goals", "-", "proved", True, 0.1, "", "w", {"total": 1, **cached}),
            RUNNER.Row("u mutant m", "frama-c eva", "why", "-", "killed", True, 0.1, "", "u",
                       {"mutant": "m", "file": "m.c", **cached})]
    items = RUNNER.evidence_items(rows, {})
    assert [i.id for i in items] == ["eva:u", "wp:w/f", "framac-mutant:u/m"]
    assert all(i.data["runs_replayed_from_cache"] == 1 and i.data["computed_on"].startswith("abc123") for i in items)


def test_prune_results_deletes_the_entries_no_run_used(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    repo = make_repo(tmp_path)
    use_repo(repo, monkeypatch)
    run_eva(repo)
    (repo / "inc" / "x.h").write_text("#define X 2\n", encoding="utf-8")
    current = run_eva(repo)
    assert len(entries(repo)) == 2 and current.key
    assert RUNNER.prune_results([current, RUNNER.FramacRun(True, 0.0, "")]) == (1, 1)
    assert [e.name for e in entries(repo)] == [f"{current.key}.json.gz"]
    assert run_eva(repo).replayed, "the entry of the current inputs stays"


def test_prune_results_needs_the_whole_offline_run() -> None:
    assert RUNNER.main(["--prune-results", "--only", "mailbox"]) == 2
    assert RUNNER.main(["--prune-results", "--cache", "update"]) == 2
