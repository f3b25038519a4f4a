"""Build variants of the simulation library (sim/urb_sim/build.py): the sanitized and seeded-bug
builds live beside the normal one and never replace it."""

from __future__ import annotations

import pytest

from urb.cli import main
from urb_sim import build


@pytest.fixture(autouse=True)
def _no_variant(monkeypatch: pytest.MonkeyPatch) -> None:
    for name in ("URBSIM_SANITIZE", "URBSIM_MUTANT", "LD_PRELOAD"):
        monkeypatch.delenv(name, raising=False)


def test_the_normal_build_is_optimised() -> None:
    assert build.library_path() == build.LIBRARY
    flags = build.variant_flags()
    assert "-O3" in flags and not any(f.startswith("-fsanitize") for f in flags)


def test_a_sanitized_build_has_its_own_folder_and_no_optimiser_flags(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("URBSIM_SANITIZE", "1")
    assert build.library_path() == build.BUILD / "san" / "liburbsim.so"
    flags = build.variant_flags()
    assert "-fsanitize=address,undefined" in flags and "-fno-sanitize-recover=all" in flags
    assert not build.SPEED_FLAGS & set(flags)
    assert "-Werror" in flags  # warnings still stop the build


def test_a_seeded_bug_is_compiled_in_and_kept_apart(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("URBSIM_MUTANT", "LOG_WRAP")
    assert build.library_path() == build.BUILD / "mutant-LOG_WRAP" / "liburbsim.so"
    assert "-DURBSIM_MUTANT_LOG_WRAP" in build.variant_flags()
    monkeypatch.setenv("URBSIM_SANITIZE", "1")
    assert build.library_path() == build.BUILD / "san-mutant-LOG_WRAP" / "liburbsim.so"


def test_a_mutant_name_cannot_inject_flags(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("URBSIM_MUTANT", "X -O0")
    with pytest.raises(build.BuildError, match="expected a name"):
        build.variant_flags()


def test_the_stamp_records_the_flags(monkeypatch: pytest.MonkeyPatch) -> None:
    # a library built with other flags is stale even when no source changed
    normal = build._stamp_text(None)
    monkeypatch.setenv("URBSIM_SANITIZE", "1")
    assert build._stamp_text(None) != normal


def test_a_sanitized_library_is_refused_without_its_runtimes(monkeypatch: pytest.MonkeyPatch,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setenv("URBSIM_SANITIZE", "1")
    with pytest.raises(build.BuildError, match="--preload"):
        build.check_loadable()
    # the CLI says so before it builds or runs anything
    assert main(["sim", "sensorhex", "--only", "fig16"]) == 2
    assert "needs the sanitizer runtimes preloaded" in capsys.readouterr().err
    monkeypatch.setenv("LD_PRELOAD", build.sanitizer_preload())
    build.check_loadable()
    assert "libasan" in build.sanitizer_preload() and "libubsan" in build.sanitizer_preload()


def test_the_committed_sources_are_exported_as_committed(monkeypatch: pytest.MonkeyPatch) -> None:
    """URBSIM_SOURCES=head builds the foreign folders from HEAD's versions: the snapshot holds each
    committed file's bytes (on Debian 12's Python 3.11.2 too, whose tarfile has no extraction filters)."""
    import subprocess

    monkeypatch.setenv("URBSIM_SOURCES", "head")
    snap = build._snapshot()
    assert snap is not None
    folder, key = snap
    assert (folder / ".complete").exists() and key in str(folder)
    listed = subprocess.run(["git", "ls-files", "--", *build.FOREIGN_DIRS], cwd=build.REPO, capture_output=True,
                            text=True, check=True).stdout.split()
    assert listed  # the witness: there are committed files to compare
    for path in listed:
        committed = subprocess.run(["git", "show", f"HEAD:{path}"], cwd=build.REPO, capture_output=True,
                                   check=True).stdout
        assert (folder / path).read_bytes() == committed, path
    monkeypatch.delenv("URBSIM_SOURCES")
    assert build._snapshot() is None  # the working tree, by default
