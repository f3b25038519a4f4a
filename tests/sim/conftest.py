"""Fixtures of the simulation tests."""

from __future__ import annotations

import pytest

from urb_sim.tracecheck import TraceCheckError, find_tlc


@pytest.fixture(scope="session")
def tlc_installed() -> None:
    """Fail (not skip) when TLC cannot run: `make check` installs java and tla2tools.jar, and the
    trace checks must not pass without their model checker; a bare checkout says what is missing."""
    try:
        find_tlc()
    except TraceCheckError as exc:
        pytest.fail(str(exc))
