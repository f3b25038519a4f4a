"""Shared fixtures: reference vectors and message lookup."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

VECTORS = Path(__file__).parent / "vectors"


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
