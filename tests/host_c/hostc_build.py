"""Builds the host C library's test programs for the Python tests of tests/host_c/ (through
mk/host_c.mk, so the tests and `make` compile the same way). A build failure fails the test that
needed it: nothing is skipped."""

from __future__ import annotations

import fcntl
import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
BUILD = REPO / "build" / "host_c"


def build(target: str) -> Path:
    """`make -f mk/host_c.mk <target>` (under a lock: pytest-xdist workers may ask at once); the
    built file's path."""
    BUILD.mkdir(parents=True, exist_ok=True)
    with open(BUILD / ".build.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        proc = subprocess.run(["make", "-s", "-f", "mk/host_c.mk", target], cwd=REPO, capture_output=True, text=True)
    if proc.returncode != 0:
        raise AssertionError(f"make -f mk/host_c.mk {target} failed:\n{proc.stdout}\n{proc.stderr}")
    return REPO / target
