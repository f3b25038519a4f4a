"""Fixtures of the simulation tests: the native library is built once per session (and only when
stale), so collecting tests/sim never needs a prior `make`."""

from __future__ import annotations

from pathlib import Path

import pytest

from urb_sim.build import ensure_library


@pytest.fixture(scope="session", autouse=True)
def simlib() -> Path:
    """build/sim/liburbsim.so, up to date."""
    return ensure_library()
