"""The evidence record format (report/urb_report/records.py): what every activity writes."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from urb_report.records import Item, RecordError, is_stale, read_record, read_records, tree_state, write_record


def _items() -> list[Item]:
    return [Item(id="tlc:MCBridge", kind="model", verdict="pass", expected="223004 states", measured="223004 states"),
            Item(id="tlc-mutant:Bridge_DropWhenFull", kind="mutant", verdict="fail",
                 expected="refuted by NoSilentDrop", measured="passed", data={"states": 12})]


def test_a_record_reads_back_with_provenance(tmp_path: Path) -> None:
    path = write_record("tlc", _items(), {"TLC": "2.15"}, config={"workers": 2}, seed=7, out_dir=tmp_path)
    rec = read_record(path)
    assert rec.activity == rec.name == "tlc"
    assert [i.id for i in rec.items] == ["tlc:MCBridge", "tlc-mutant:Bridge_DropWhenFull"]
    assert rec.items[1].verdict == "fail" and rec.items[1].data == {"states": 12}
    assert rec.tools == {"TLC": "2.15"} and rec.config == {"workers": 2}
    prov = rec.provenance
    assert prov["seed"] == 7 and len(prov["commit"]) == 40 and prov["machine"]["cores"] >= 1
    assert isinstance(prov["clean"], bool) and prov["date"].endswith("Z")
    assert read_records(tmp_path)[0].items == rec.items


def test_duplicate_ids_and_bad_verdicts_are_refused(tmp_path: Path) -> None:
    with pytest.raises(RecordError, match="used twice"):
        write_record("tlc", _items() + _items()[:1], {}, out_dir=tmp_path)
    with pytest.raises(RecordError, match="verdict"):
        Item(id="x:y", kind="test", verdict="ok")  # type: ignore[arg-type]
    with pytest.raises(RecordError, match="kind of evidence"):
        Item(id="nocolon", kind="test", verdict="pass")


def test_staleness_names_the_other_commit_or_edit(tmp_path: Path) -> None:
    rec = read_record(write_record("tlc", _items(), {}, out_dir=tmp_path))
    now = tree_state()
    assert is_stale(rec, now) == ""
    assert "not" in is_stale(rec, {**now, "commit": "0" * 40})
    assert "uncommitted" in is_stale(rec, {**now, "changes": "feedfacefeedface"})


def test_a_foreign_or_broken_file_is_a_clear_error(tmp_path: Path) -> None:
    (tmp_path / "a.json").write_text(json.dumps({"schema": "other"}))
    with pytest.raises(RecordError, match="not a urb-evidence/1 record"):
        read_records(tmp_path)
    (tmp_path / "a.json").write_text("{")
    with pytest.raises(RecordError, match="cannot read"):
        read_records(tmp_path)
