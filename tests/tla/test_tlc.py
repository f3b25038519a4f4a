"""urb_sim.tlc: the one way the model checks and the trace checks find TLC and read its counts."""

from __future__ import annotations

from pathlib import Path

import pytest

from urb_sim import tlc, tracecheck


def test_state_counts_come_from_the_last_progress_line() -> None:
    log = ("Progress(3) at 2026-11-25: 1,204 states generated, 640 distinct states found, 12 states left on queue.\n"
           "1,051,377 states generated, 223,004 distinct states found, 0 states left on queue.\n")
    assert tlc.state_counts(log) == (1_051_377, 223_004)
    assert tlc.state_counts("Error: Parsing or semantic analysis failed.") is None


def test_a_jar_named_by_the_environment_must_exist(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("TLA2TOOLS_JAR", str(tmp_path / "missing.jar"))
    with pytest.raises(tlc.TlcSetupError, match="TLA2TOOLS_JAR=.*missing.jar is not a file"):
        tlc.find_jar()
    # the trace checks find TLC the same way, and say so in their own error
    with pytest.raises(tracecheck.TraceCheckError, match="TLA2TOOLS_JAR"):
        tracecheck.find_tlc()
    jar = tmp_path / "tla2tools.jar"
    jar.write_bytes(b"")
    monkeypatch.setenv("TLA2TOOLS_JAR", str(jar))
    assert tlc.find_jar() == jar


def test_no_java_says_what_to_install(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(tlc.shutil, "which", lambda _name: None)
    with pytest.raises(tracecheck.TraceCheckError, match="default-jre-headless"):
        tracecheck.find_tlc()
