"""TraceDiscovery.tla on the host library's discovery in the simulation: accepted as it is, and
rejected where a seeded bug in the host library shows: at the system table when duplicates are
flagged on one row only or a foreign layout is not flagged, at the scan of the second bridge's
duplicate when duplicate rows are merged (the host then has no row for what that scan found)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from urb import api
from urb.api import DUPLICATE, URBInterface
from urb_sim.experiments.traces import record_discovery
from urb_sim.tracecheck import check_discovery


pytestmark = pytest.mark.usefixtures("tlc_installed")


TABLE_AT = 2 * 127  #: index of the table event: two bridges' scans of 127 addresses come first
DUPLICATE_SCAN_AT = 127 + 0x10 - 1  #: the second bridge's scan of address 0x10 (record_discovery's wiring)


def test_discovery_trace_is_accepted() -> None:
    t = record_discovery(21)
    assert t.events[TABLE_AT].ev == "table"
    r = check_discovery(t)
    assert r.accepted, r.message
    assert r.matched_prefix == len(t.events)


def _flag_one_duplicate(self: URBInterface) -> None:
    """Seeded bug: of the rows sharing a class and index, only the later ones are flagged."""
    seen: set[tuple[int, int]] = set()
    for r in self._records:
        key = (r.class_id, r.index)
        if key in seen:
            r.flags.add(DUPLICATE)
        seen.add(key)


@pytest.fixture(params=["one duplicate flagged", "mismatch not flagged", "duplicates merged"])
def host_bug(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> Iterator[tuple[str, int]]:
    """A seeded bug in the host library, and the index of the event where the trace must be rejected."""
    if request.param == "one duplicate flagged":
        monkeypatch.setattr(URBInterface, "_flag_duplicates", _flag_one_duplicate)
        yield request.param, TABLE_AT
    elif request.param == "mismatch not flagged":
        monkeypatch.setattr(api, "MISMATCH", "MISMATCH-unreported")  # flagged under a name nobody checks
        yield request.param, TABLE_AT
    else:
        merge = URBInterface._merge

        def merging(self: URBInterface, report: api.BridgeReport) -> None:
            known = {(r.class_id, r.index) for r in self._records}
            report.records = [r for r in report.records if (r.class_id, r.index) not in known]
            merge(self, report)

        monkeypatch.setattr(URBInterface, "_merge", merging)
        yield request.param, DUPLICATE_SCAN_AT


def test_host_bugs_are_rejected_where_they_show(host_bug: tuple[str, int]) -> None:
    name, at = host_bug
    r = check_discovery(record_discovery(21))
    assert not r.accepted, name
    assert r.matched_prefix == at, r.message
