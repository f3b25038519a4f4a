"""Shared fixtures: reference vectors and message lookup."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import pytest

VECTORS = Path(__file__).parent / "vectors"

# The tests that run ESBMC test the checker itself (a seeded harness must fail): they run it for real
# and never replay or record proofs/bmc/cache (tests/proofs/test_bmc_cache.py tests the cache).
os.environ["BMC_CACHE"] = "off"
# Likewise for Frama-C (tools/framac_cache.py; tests/proofs/test_framac_cache.py tests the cache).
os.environ["FRAMAC_RESULT_CACHE"] = "off"


def load_vectors(kind: str) -> list[dict[str, Any]]:
    """Valid vectors (kind 'valid') or error vectors (kind 'error') from tests/vectors/*.json."""
    out: list[dict[str, Any]] = []
    for path in sorted(VECTORS.glob("*.json")):
        for v in json.loads(path.read_text()):
            if ("error" in v) == (kind == "error"):
                out.append(v)
    return out


@pytest.fixture(scope="session")
def repo() -> Path:
    return Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def tlc_installed() -> None:
    """Fail (not skip) when TLC cannot run: `make check` installs java and tla2tools.jar, and the
    trace checks (tests/sim/test_trace_*.py) must not pass without their model checker; a bare
    checkout says what is missing."""
    from urb_sim.tracecheck import TraceCheckError, find_tlc

    try:
        find_tlc()
    except TraceCheckError as exc:
        pytest.fail(str(exc))


@pytest.fixture(autouse=True)
def port_handover_records(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Each test keeps its managers' port hand-over records (host/urb/managers/handover.py) in a
    directory of its own: a pty number reused by a later test must not inherit a record."""
    where = tmp_path_factory.mktemp("urb-state")
    monkeypatch.setenv("URB_STATE_DIR", str(where))
    return where
