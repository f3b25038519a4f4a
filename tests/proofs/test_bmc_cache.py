"""proofs/bmc/bmc_cache.py: an ESBMC run is replayed only when nothing it reads has changed.

A fake ESBMC (a shell script that counts its runs) stands in for the real one, so each test shows
when ESBMC runs and when its recorded answer is replayed."""

from __future__ import annotations

import gzip
import json
import shutil
from pathlib import Path

import pytest

from tests.repo_tools import ROOT, load_module

cache = load_module("bmc_cache", ROOT / "proofs" / "bmc" / "bmc_cache.py")

FAKE = """#!/bin/sh
if [ "$1" = --version ]; then echo "ESBMC version {version} fake"; exit 0; fi
echo run >> "{count}"
echo "Unwinding loop 1 iteration 1   file {repo}/h.c line 3"
echo "Parsing {repo}/h.c"
if grep -q BUG {repo}/inc/x.h; then
  printf 'Violated property:\\n  file h.c line 3 column 1 function harness\\n  seeded: the bug\\n\\nVERIFICATION FAILED\\n'; exit 1
fi
{tail}
"""


def make_repo(root: Path, version: str = "8.4.0", tail: str = 'echo "VERIFICATION SUCCESSFUL"') -> Path:
    repo = root / "repo"
    (repo / "inc").mkdir(parents=True)
    (repo / "h.c").write_text('#include "x.h"\nint harness(void) { return X; }\n', encoding="utf-8")
    (repo / "inc" / "x.h").write_text("#define X 1\n", encoding="utf-8")
    (repo / "inc" / "unused.h").write_text("#define Y 2\n", encoding="utf-8")
    esbmc = root / "esbmc"
    esbmc.write_text(FAKE.format(version=version, count=root / "count", repo=repo, tail=tail), encoding="utf-8")
    esbmc.chmod(0o755)
    return repo


def run(root: Path, repo: Path, capsys: pytest.CaptureFixture[str], *flags: str) -> tuple[int, str]:
    status = cache.main(["--repo", str(repo), "--cache", str(root / "cache"), "--proof", "p", "--",
                         str(root / "esbmc"), f"{repo}/h.c", "--unwind", "3", f"-I{repo}/inc", *flags])
    return status, capsys.readouterr().out


def esbmc_runs(root: Path) -> int:
    return len((root / "count").read_text().splitlines()) if (root / "count").exists() else 0


def test_a_recorded_run_is_replayed_with_its_verdict_and_this_clones_paths(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("BMC_CACHE", "on")
    repo = make_repo(tmp_path)
    status, first = run(tmp_path, repo, capsys)
    assert status == 0 and "VERIFICATION SUCCESSFUL" in first and "urb-bmc-cache: recorded" in first
    status, second = run(tmp_path, repo, capsys)
    assert status == 0 and esbmc_runs(tmp_path) == 1, "the second run is a replay"
    assert second.startswith("urb-bmc-cache: hit ") and "VERIFICATION SUCCESSFUL" in second
    assert f"Parsing {repo}/h.c" in second, "recorded paths are this clone's again"
    assert "Unwinding loop" not in second, "per-iteration lines are not recorded"
    # A clone elsewhere (another repository path) has the same keys.
    moved = tmp_path / "elsewhere"
    moved.mkdir()
    shutil.copytree(repo, moved / "repo")
    shutil.copytree(tmp_path / "cache", moved / "cache")
    shutil.copy(tmp_path / "esbmc", moved / "esbmc")
    status, third = run(moved, moved / "repo", capsys)
    assert third.startswith("urb-bmc-cache: hit ") and f"Parsing {moved}/repo/h.c" in third
    assert not (moved / "count").exists(), "the moved clone replays"


@pytest.mark.parametrize("change", ["header byte", "flag", "esbmc version"])
def test_any_change_to_what_the_run_reads_runs_esbmc_again(
        change: str, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("BMC_CACHE", "on")
    repo = make_repo(tmp_path)
    run(tmp_path, repo, capsys)
    flags: tuple[str, ...] = ()
    if change == "header byte":
        (repo / "inc" / "x.h").write_text("#define X 1 /* BUG */\n", encoding="utf-8")
    elif change == "flag":
        flags = ("-DURB_OTHER=1",)
    else:
        make_repo(tmp_path / "v2", version="8.5.0")
        shutil.copy(tmp_path / "v2" / "esbmc", tmp_path / "esbmc")
    status, out = run(tmp_path, repo, capsys, *flags)
    assert "urb-bmc-cache: hit" not in out
    if change == "header byte":
        assert status == 1 and "VERIFICATION FAILED" in out and esbmc_runs(tmp_path) == 2
    elif change == "flag":
        assert status == 0 and esbmc_runs(tmp_path) == 2
    else:
        assert status == 0 and esbmc_runs(tmp_path / "v2") + esbmc_runs(tmp_path) == 2


def test_a_header_the_run_does_not_include_leaves_the_key_alone(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("BMC_CACHE", "on")
    repo = make_repo(tmp_path)
    run(tmp_path, repo, capsys)
    (repo / "inc" / "unused.h").write_text("#define Y 3\n", encoding="utf-8")
    _, out = run(tmp_path, repo, capsys)
    assert out.startswith("urb-bmc-cache: hit") and esbmc_runs(tmp_path) == 1


def test_a_run_without_a_verdict_is_never_recorded(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("BMC_CACHE", "on")
    repo = make_repo(tmp_path, tail='echo "ERROR: Timed out"; exit 6')
    for _ in range(2):
        status, out = run(tmp_path, repo, capsys)
        assert status == 6 and "recorded" not in out
    assert esbmc_runs(tmp_path) == 2 and not (tmp_path / "cache").exists()


def test_a_multi_property_run_cut_by_its_timeout_is_never_recorded(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    """A cover run (--multi-property) that runs out of time prints VERIFICATION FAILED for the points it
    refuted before (seen 2026-11-29: fw_bridge_rs232_parser at load 15, recorded, then replayed as
    VACUOUS): no verdict for the rest, so never recorded."""
    monkeypatch.setenv("BMC_CACHE", "on")
    repo = make_repo(tmp_path, tail='printf "  cover: a-point\\nERROR: Timed out\\nVERIFICATION FAILED\\n"; exit 1')
    for _ in range(2):
        status, out = run(tmp_path, repo, capsys)
        assert status == 1 and "VERIFICATION FAILED" in out and "recorded" not in out
    assert esbmc_runs(tmp_path) == 2 and not (tmp_path / "cache").exists()


def test_off_and_refresh(tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    repo = make_repo(tmp_path)
    monkeypatch.setenv("BMC_CACHE", "off")
    run(tmp_path, repo, capsys)
    assert not (tmp_path / "cache").exists(), "off records nothing"
    monkeypatch.setenv("BMC_CACHE", "on")
    run(tmp_path, repo, capsys)
    monkeypatch.setenv("BMC_CACHE", "refresh")
    _, out = run(tmp_path, repo, capsys)
    assert "urb-bmc-cache: recorded" in out and esbmc_runs(tmp_path) == 3
    monkeypatch.setenv("BMC_CACHE", "sometimes")
    assert run(tmp_path, repo, capsys)[0] == 2


def test_the_spot_check_catches_a_wrong_recorded_verdict(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    """A seeded wrong entry (a failed run recorded as proved) is replayed as it is without a spot
    check, and rejected when the spot check picks it."""
    monkeypatch.setenv("BMC_CACHE", "on")
    repo = make_repo(tmp_path)
    (repo / "inc" / "x.h").write_text("#define X 1 /* BUG */\n", encoding="utf-8")
    status, _ = run(tmp_path, repo, capsys)
    assert status == 1
    [entry_file] = (tmp_path / "cache" / "p").glob("*.json.gz")
    with gzip.open(entry_file, "rt", encoding="utf-8") as fh:
        entry = json.load(fh)
    entry["status"], entry["output"] = 0, "VERIFICATION SUCCESSFUL\n"
    cache.write_entry(entry_file, entry)
    assert run(tmp_path, repo, capsys)[0] == 0, "replayed as recorded: what the spot check is for"
    monkeypatch.setenv("BMC_CACHE_VERIFY", "1000")
    status, out = run(tmp_path, repo, capsys)
    assert status == 3 and "SPOT CHECK FAILED" in out and esbmc_runs(tmp_path) == 2
    # A correct entry passes its spot check.
    failed = "Violated property:\n  file h.c line 3 column 1 function harness\n  seeded: the bug\n\nVERIFICATION FAILED\n"
    cache.write_entry(entry_file, dict(entry, status=1, output=failed))
    status, out = run(tmp_path, repo, capsys)
    assert status == 1 and "spot-checked" in out


def test_the_spot_check_compares_each_cover_point_of_a_multi_property_run(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    """A cover run's record that says a point was reached when ESBMC now finds it unreachable has the
    same overall verdict (FAILED on the reach assertion); its spot check still fails on the point."""
    monkeypatch.setenv("BMC_CACHE", "on")
    table = ('printf "Violated property:\\n  file r.c line 1 column 1 function urb_reach\\n  reach: end\\n\\n'
             '  FAILED  [urb_reach.assertion.1]  line 1  reach: end\\n'
             '  PASSED  [harness.assertion.2]  line 9  cover: a-point\\nVERIFICATION FAILED\\n"; exit 1')
    repo = make_repo(tmp_path, tail=table)
    assert run(tmp_path, repo, capsys)[0] == 1
    [entry_file] = (tmp_path / "cache" / "p").glob("*.json.gz")
    with gzip.open(entry_file, "rt", encoding="utf-8") as fh:
        entry = json.load(fh)
    assert cache.verdict_of(entry["output"]) == ("FAILED", "reach: end", ("reach: end",))
    cache.write_entry(entry_file, dict(entry, output=entry["output"].replace("  PASSED  [harness", "  FAILED  [harness")))
    monkeypatch.setenv("BMC_CACHE_VERIFY", "1000")
    status, out = run(tmp_path, repo, capsys)
    assert status == 3 and "SPOT CHECK FAILED" in out and "cover: a-point" in out


def test_spot_check_sample_follows_the_seed() -> None:
    keys = [f"{i:064x}" for i in range(2000)]
    picked = [k for k in keys if cache.spot_checked(k, "abc", 20)]
    assert 15 <= len(picked) <= 70
    assert picked != [k for k in keys if cache.spot_checked(k, "abd", 20)]
    assert not any(cache.spot_checked(k, "abc", 0) for k in keys)
