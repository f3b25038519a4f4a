"""TLC's classes from a class-data-sharing archive (`urb_sim.tlc.class_archive`): the first run
writes it, the later ones map TLC's classes from it, and a damaged or missing archive only costs
the speed (the JVM loads the classes from the jar as before)."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from urb_sim.tlc import TlcSetupError, class_archive, find_jar, find_java

SPEC = """---- MODULE Count ----
EXTENDS Naturals
VARIABLE x
Init == x = 0
Next == x < 3 /\\ x' = x + 1
====
"""


def _tlc(java: str, jar: Path, options: list[str], spec_dir: Path) -> subprocess.CompletedProcess[str]:
    """A TLC run of a 4-state model that logs where tlc2.TLC's class came from."""
    return subprocess.run([java, "-XX:+UseSerialGC", "-XX:TieredStopAtLevel=1", *options, "-Xlog:class+load=info",
                           "-cp", str(jar), "tlc2.TLC", "-deadlock", "-workers", "1", "-config", "Count.cfg",
                           "-metadir", str(spec_dir / "meta"), "Count.tla"],
                          cwd=spec_dir, capture_output=True, text=True, check=False)


def _tlc_class_source(log: str) -> str:
    return next(line for line in log.splitlines() if " tlc2.TLC source: " in line).split(" source: ", 1)[1]


@pytest.fixture
def tlc(tmp_path: Path) -> tuple[str, Path, Path]:
    try:
        java, jar = find_java(), find_jar()
    except TlcSetupError as exc:
        pytest.fail(f"TLC is part of the environment (tools/setup.sh): {exc}")
    spec_dir = tmp_path / "spec"
    spec_dir.mkdir()
    (spec_dir / "Count.tla").write_text(SPEC)
    (spec_dir / "Count.cfg").write_text("INIT Init\nNEXT Next\n")
    return java, jar, spec_dir


def test_the_first_run_writes_the_archive_and_the_next_maps_tlc_from_it(tlc: tuple[str, Path, Path],
                                                                       tmp_path: Path) -> None:
    java, jar, spec_dir = tlc
    cds = tmp_path / "cds"
    with class_archive(java, jar, cds) as first:
        assert len(first) == 2 and first[1].startswith("-XX:ArchiveClassesAtExit=")
        run = _tlc(java, jar, first, spec_dir)
        assert run.returncode == 0 and "No error has been found" in run.stdout
        assert _tlc_class_source(run.stdout).endswith("tla2tools.jar")
    archives = list(cds.iterdir())
    assert len(archives) == 1 and archives[0].suffix == ".jsa"  # in place, no partial file left
    with class_archive(java, jar, cds) as second:
        assert second == ["-XX:+IgnoreUnrecognizedVMOptions", f"-XX:SharedArchiveFile={archives[0]}"]
        run = _tlc(java, jar, second, spec_dir)
    assert run.returncode == 0 and "No error has been found" in run.stdout
    assert _tlc_class_source(run.stdout) == "shared objects file (top)"


def test_a_damaged_archive_costs_only_the_speed(tlc: tuple[str, Path, Path], tmp_path: Path) -> None:
    """The seeded fault: an archive overwritten with garbage. The witness above (tlc2.TLC from the
    shared file) fails, and TLC still runs and finishes, loading its classes from the jar."""
    java, jar, spec_dir = tlc
    cds = tmp_path / "cds"
    with class_archive(java, jar, cds) as first:
        _tlc(java, jar, first, spec_dir)
    archive = next(cds.iterdir())
    archive.chmod(0o644)
    archive.write_bytes(b"not a CDS archive" * 100)
    with class_archive(java, jar, cds) as options:
        run = _tlc(java, jar, options, spec_dir)
    assert run.returncode == 0 and "No error has been found" in run.stdout
    assert _tlc_class_source(run.stdout).endswith("tla2tools.jar")


def test_no_options_without_a_readable_jar_or_a_writable_folder(tlc: tuple[str, Path, Path], tmp_path: Path) -> None:
    java, jar, _ = tlc
    with class_archive(java, tmp_path / "missing.jar", tmp_path / "cds") as options:
        assert options == []
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    with class_archive(java, jar, blocker / "cds") as options:
        assert options == []
