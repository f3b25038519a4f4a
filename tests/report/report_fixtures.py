"""Fixtures of the report's tests (imported by each test module: a conftest.py here would shadow
tests/conftest.py, which tests/test_vectors.py imports by name): the real requirements, markers and baseline, and fixture records
(written with records.write_record) in which every cited item passed on this tree."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import pytest

from urb_report import history, markers, records, requirements
from urb_report.evidence import activity_of
from urb_report.records import Item, Record


@pytest.fixture(scope="session")
def catalogue() -> requirements.Catalogue:
    return requirements.load()


@pytest.fixture(scope="session")
def real_markers() -> list[markers.Marker]:
    return markers.scan()


@pytest.fixture(scope="session")
def baseline() -> dict[str, dict[str, object]]:
    return history.read_baseline()


@pytest.fixture(scope="session")
def state() -> dict[str, Any]:
    return records.tree_state()


def passing_items(cat: requirements.Catalogue) -> dict[str, list[Item]]:
    """Per activity, one passing item for every evidence id a requirement cites."""
    out: dict[str, list[Item]] = {}
    for e in sorted({e for r in cat.requirements for e in r.verified_by}):
        kind, _, name = e.partition(":")
        if kind == "record":
            out.setdefault(name, []).append(Item(id=f"{name}:summary", kind="summary", verdict="pass"))
            continue
        out.setdefault(activity_of(kind) or kind, []).append(
            Item(id=e, kind="fixture", verdict="pass", expected="passes", measured="passed", rerun="true"))
    return out


WriteRecords = Callable[..., list[Record]]


@pytest.fixture
def write_records(tmp_path: Path, catalogue: requirements.Catalogue, state: dict[str, Any],
                  monkeypatch: pytest.MonkeyPatch) -> WriteRecords:
    """write_records(drop=[ids], verdicts={id: verdict}, skip_activities=[...], commit=None) -> the
    records, as every activity would have written them on this tree, changed as asked."""

    monkeypatch.setattr(records, "tree_state", lambda: dict(state))  # the tree did not change: skip git

    def make(drop: Iterable[str] = (), verdicts: dict[str, str] | None = None,
             skip_activities: Iterable[str] = (), extra: dict[str, list[Item]] | None = None) -> list[Record]:
        out_dir = tmp_path / "evidence"
        dropped, skipped, v = set(drop), set(skip_activities), verdicts or {}
        items = passing_items(catalogue)
        for activity, more in (extra or {}).items():
            items.setdefault(activity, []).extend(more)
        for activity, its in items.items():
            if activity in skipped:
                continue
            kept = [Item(id=i.id, kind=i.kind, verdict=v.get(i.id, i.verdict), expected=i.expected,  # type: ignore[arg-type]
                         measured=i.measured, rerun=i.rerun) for i in its if i.id not in dropped]
            records.write_record(activity, kept, {"fixture": "1.0"}, out_dir=out_dir, seed=0)
        return records.read_records(out_dir)

    return make
