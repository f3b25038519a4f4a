"""The TLA+ actions and the firmware that implements them name each other (tools/tla_xref.py)."""

from __future__ import annotations

from pathlib import Path
from types import ModuleType

from repo_tools import load_module

REPO = Path(__file__).resolve().parents[2]


def _xref() -> ModuleType:
    return load_module("tla_xref", Path("tools/tla_xref.py"))


def test_every_citation_resolves_and_every_mailbox_action_is_implemented() -> None:
    assert _xref().problems() == []


def test_mailbox_actions_are_found() -> None:
    xref = _xref()
    assert xref.actions("MailboxInbox")[:4] == ["IsrWriteBegin", "IsrWriteByte", "IsrWriteCommit", "IsrWriteAbort"]
    assert "AppLockCheckFront" in xref.actions("MailboxInbox")


def test_a_stale_citation_is_reported(tmp_path: Path) -> None:
    xref = _xref()
    bad = tmp_path / "bad.c"
    bad.write_text("x = 1; /* MailboxInbox.tla: IsrWriteTwice */\n")
    xref.C_DIRS = [*xref.C_DIRS, tmp_path]
    assert any("IsrWriteTwice" in p for p in xref.problems())


def test_readme_table_is_current() -> None:
    readme = (REPO / "spec" / "tla" / "README.md").read_text()
    begin, end = "<!-- xref:begin -->\n", "<!-- xref:end -->"
    current = readme[readme.index(begin) + len(begin): readme.index(end)]
    assert current == _xref().table(), "run `python3 tools/tla_xref.py --table` and paste it into spec/tla/README.md"


def test_actions_of_every_specification_are_listed() -> None:
    """Bridge.tla's SpecReconnect and SpecReset add actions outside Next: they are actions too."""
    actions = _xref().actions("Bridge")
    assert {"HostLinkLost", "HostReopen", "BridgeReset"} <= set(actions)
    assert "ReconnectNext" not in actions and "Next" not in actions
