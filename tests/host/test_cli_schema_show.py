"""`urb schema show`: a message's rules are part of its layout (issue #35)."""

from __future__ import annotations

from pathlib import Path

import pytest

from cli_run import run


def test_show_lists_a_message_s_rules_with_their_doc(capsys: pytest.CaptureFixture[str],
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("COLUMNS", "200")
    code, out, _ = run(capsys, "schema", "show", "UplinkResponse")
    assert code == 0
    assert "require status == OK or len(data) == 0" in out and "on the frame" in out
    assert "Only a successful read carries data" in out


def test_show_counts_the_rules_in_the_list_and_omits_the_table_without_rules(
        capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("COLUMNS", "200")
    (tmp_path / "t.urbs").write_text(
        'schema t "rules test"\n'
        'message Pair "two counters" {\n'
        '    a: u8 "first"\n'
        '    b: u8 "second"\n'
        '    require a <= b "the first never passes the second"\n'
        '}\n'
        'message Plain "one byte" {\n'
        '    x: u8 "a byte"\n'
        '}\n')
    code, out, err = run(capsys, "schema", "show", "--schemas", str(tmp_path))
    assert code == 0, err
    pair = next(line for line in out.splitlines() if "│ Pair" in line)
    plain = next(line for line in out.splitlines() if "│ Plain" in line)
    assert [c.strip() for c in pair.split("│")][5] == "1"
    assert [c.strip() for c in plain.split("│")][5] == ""
    code, out, _ = run(capsys, "schema", "show", "--schemas", str(tmp_path), "Pair")
    assert code == 0 and "require a <= b" in out and "the first never passes the second" in out
    code, out, _ = run(capsys, "schema", "show", "--schemas", str(tmp_path), "Plain")
    assert code == 0 and "rules a valid message meets" not in out
