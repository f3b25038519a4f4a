"""The TLA+ actions and the production firmware that implements them name each other
(tools/tla_xref.py). Each check is shown failing on a seeded case: the sources are the real
firmware with one file added or changed."""

from __future__ import annotations

from pathlib import Path
from types import ModuleType

from repo_tools import load_module

REPO = Path(__file__).resolve().parents[2]


def _xref() -> ModuleType:
    return load_module("tla_xref", Path("tools/tla_xref.py"))


def _with(path: str, text: str) -> dict[str, str]:
    """The firmware sources with `path` added (or replaced by `text`)."""
    sources: dict[str, str] = _xref().c_sources()
    sources[path] = text
    return sources


def _edited(path: str, old: str, new: str) -> dict[str, str]:
    sources: dict[str, str] = _xref().c_sources()
    assert sources[path].count(old) == 1, f"{old!r} no longer in {path}: update the test"
    sources[path] = sources[path].replace(old, new)
    return sources


def test_every_citation_resolves_and_every_action_has_one_production_implementation() -> None:
    assert _xref().problems() == []


def test_the_citations_without_a_colon_are_seen() -> None:
    """Witness: urb_i2c.c's references (no colon) are parsed, and so are the mailbox's citations."""
    found = _xref().citations()
    i2c = [c for c in found if c.path == "firmware/node/urb_i2c.c"]
    assert {c.name for c in i2c} >= {"IsrWriteAbort", "IsrWriteCommit", "IsrWriteBegin", "IsrReadEnd", "IsrReadByte"}
    assert all(c.kind == "refers" for c in i2c)
    assert any(c.kind == "implements" and c.function == "urb_isr_write_begin" for c in found)


def test_a_misspelt_reference_without_a_colon_fails() -> None:
    old = "/* MailboxInbox.tla IsrWriteCommit */"
    bad = _xref().problems(_edited("firmware/node/urb_i2c.c", old, "/* MailboxInbox.tla IsrWriteComit */"))
    assert len(bad) == 1 and "urb_i2c.c" in bad[0] and "IsrWriteComit" in bad[0] and "misspelt" in bad[0]


def test_a_misspelt_implementation_citation_fails() -> None:
    xref = _xref()
    bad = xref.problems(_with("firmware/node/extra.c", "void f(void)\n{\n    x = 1; /* MailboxInbox.tla: IsrWriteTwice */\n}\n"))
    assert any("IsrWriteTwice" in p and "misspelt" in p for p in bad)


def test_a_citation_that_cannot_be_read_fails() -> None:
    xref = _xref()
    for text in ("/* MailboxInbox.tla: isrWriteBegin */", "/* see MailboxInbox.tla:\n */", "/* MailboxInbx.tla: IsrWriteBegin */"):
        bad = xref.problems(_with("firmware/node/extra.c", text + "\n"))
        assert len(bad) == 1 and bad[0].startswith("firmware/node/extra.c:1: "), (text, bad)


def test_an_implementation_citation_of_an_operator_fails() -> None:
    bad = _xref().problems(_edited("firmware/bridge/bridge.c", "/* Bridge.tla FirstPending, in O(1)",
                                   "/* Bridge.tla: FirstPending, in O(1)"))
    assert len(bad) == 1 and "an operator, not an action" in bad[0]


def test_a_citation_across_a_line_break_is_read() -> None:
    xref = _xref()
    found = xref.citations({"firmware/node/x.c": "/* text\n * (MailboxInbox.tla\n * IsrWriteAbrt) */\n"})
    assert [(c.kind, c.name, c.line) for c in found] == [("refers", "IsrWriteAbrt", 2)]


def test_a_test_double_is_not_counted() -> None:
    """The hosted fake I2C bus cites the node's actions it mimics: checked, never an implementation."""
    xref = _xref()
    found = xref.citations()
    fake = [c for c in found if c.path == "firmware/hal/hosted/bridge_fake_i2c.c"]
    assert fake, "witness: the fake bus cites mailbox actions"
    assert "bridge_fake_i2c" not in xref.table()
    # A test double whose citation would be the only implementation does not satisfy the action.
    sources = _edited("firmware/node/urb_mailbox.c", "/* MailboxOutbox.tla: IsrReadEnd */", "/* MailboxOutbox.tla IsrReadEnd */")
    sources["firmware/hal/hosted/fake.c"] = "void g(void)\n{\n    y = 0; /* MailboxOutbox.tla: IsrReadEnd */\n}\n"
    bad = xref.problems(sources)
    assert bad == ["spec/tla/MailboxOutbox.tla: action IsrReadEnd has no production C citing `MailboxOutbox.tla: "
                   "IsrReadEnd` (nor is it listed as the application's or environment's)"]


def test_production_code_outside_the_models_home_is_not_an_implementation() -> None:
    """The bridge's master observes the node's IsrWriteBegin: as an implementation citation it fails."""
    bad = _xref().problems(_edited("firmware/bridge/i2c_master.c", "the node's MailboxInbox.tla IsrWriteBegin NACKs",
                                   "MailboxInbox.tla: IsrWriteBegin NACKs"))
    assert len(bad) == 1 and "outside firmware/node/" in bad[0]


def test_a_hook_id_enum_in_a_header_is_not_an_implementation() -> None:
    bad = _xref().problems(_edited("firmware/node/urb_node_internal.h", "/* step AppLockPick of MailboxOutbox.tla */",
                                   "/* MailboxOutbox.tla: AppLockPick */"))
    assert len(bad) == 1 and "in a header" in bad[0]


def test_two_production_implementations_fail() -> None:
    sources = _with("firmware/node/extra.c", "void h(void)\n{\n    z = 2; /* MailboxInbox.tla: IsrWriteByte */\n}\n")
    bad = _xref().problems(sources)
    assert len(bad) == 1 and "2 production implementations" in bad[0]


def test_an_action_without_implementation_fails() -> None:
    bad = _xref().problems(_edited("firmware/bridge/bridge.c", "/* Bridge.tla: BridgeReset (the queue starts empty) */",
                                   "/* the queue starts empty */"))
    assert len(bad) == 1 and "action BridgeReset has no production C" in bad[0]


def test_an_unclassified_firmware_file_fails() -> None:
    bad = _xref().problems(_with("firmware/hal/newport/x.c", "int x;\n"))
    assert bad == ["firmware/hal/newport/x.c: not classified as production or test double "
                   "(tools/tla_xref.py PRODUCTION, TEST_DOUBLES)"]


def test_mailbox_actions_are_found() -> None:
    xref = _xref()
    assert xref.actions("MailboxInbox")[:4] == ["IsrWriteBegin", "IsrWriteByte", "IsrWriteCommit", "IsrWriteAbort"]
    assert "AppLockCheckFront" in xref.actions("MailboxInbox")


def test_readme_table_is_current() -> None:
    readme = (REPO / "spec" / "tla" / "README.md").read_text()
    begin, end = "<!-- xref:begin -->\n", "<!-- xref:end -->"
    current = readme[readme.index(begin) + len(begin): readme.index(end)]
    assert current == _xref().table(), "run `python3 tools/tla_xref.py --table` and paste it into spec/tla/README.md"
    assert "firmware/hal" not in current and "nobody" not in current


def test_actions_of_every_specification_are_listed() -> None:
    """Bridge.tla's SpecReconnect and SpecReset add actions outside Next: they are actions too."""
    actions = _xref().actions("Bridge")
    assert {"HostLinkLost", "HostReopen", "BridgeReset"} <= set(actions)
    assert "ReconnectNext" not in actions and "Next" not in actions


def test_operator_parameters_and_fixed_actions_are_read() -> None:
    """CanTransfer.tla's `SendFrameBy(s, R(_, _)) ==` is a definition (an operator parameter's
    parentheses inside the parameter list), and Rs485Poll.tla's `SendEnd == SendEndWith(FALSE)`, an
    action fixed from a parameterised one, is the action under the name the next-state relation uses."""
    xref = _xref()
    assert {"SendFrameBy", "DuplicateBy", "NextBy"} <= set(xref.definitions("CanTransfer"))
    assert xref.actions("CanTransfer") == ["SendStart", "SendFrame", "Lose", "Duplicate", "ErrorFrame", "Recover"]
    rs485 = xref.actions("Rs485Poll")
    assert {"SendEnd", "Silence", "BabbleStart"} <= set(rs485)
    assert not {"SendEndWith", "SilenceWith", "BabbleStartWith"} & set(rs485)


def test_a_downlink_action_cited_in_the_other_downlink_fails() -> None:
    """The downlinks have their own homes: the CAN master citing the RS485 poll is no implementation."""
    problems = _xref().problems(_edited("firmware/downlink/can/urb_can_master.c",
                                        "/* CanTransfer.tla SendStart */", "/* Rs485Poll.tla: Poll */"))
    assert any("outside firmware/downlink/rs485/" in p for p in problems)


def test_the_host_actions_are_implemented_once_in_the_host_library() -> None:
    """Witness: the native host library's citations are read and name its functions."""
    xref = _xref()
    impl = xref.implementations(xref.citations())
    for module, acts in xref.BY_HOST.items():
        for action in acts:
            files = impl.get((module, action), {})
            assert len(files) == 1 and next(iter(files)).startswith("host/c/"), (module, action, files)
    assert impl[("Bridge", "HostExpire")] == {"host/c/core/matcher.c": ["urb_matcher_expire"]}


def test_a_host_action_without_its_host_citation_fails() -> None:
    bad = _xref().problems(_edited("host/c/core/matcher.c", "/* Bridge.tla: HostExpire */", "/* expiry */"))
    assert bad == ["spec/tla/Bridge.tla: action HostExpire has no production C citing `Bridge.tla: HostExpire` "
                   "(nor is it listed as the application's or environment's)"]


def test_a_second_host_file_implementing_a_host_action_fails() -> None:
    bad = _xref().problems(_edited("host/c/port/loop.c", "/* Bridge.tla HostReopen */", "/* Bridge.tla: HostReopen */"))
    assert len(bad) == 1 and "action HostReopen has 2 production implementations" in bad[0]


def test_a_host_action_in_the_firmware_and_a_bridge_action_in_the_host_library_fail() -> None:
    sources = _with("firmware/bridge/extra.c", "void f(void)\n{\n    x = 1; /* Bridge.tla: HostTimeout */\n}\n")
    sources["host/c/core/extra.c"] = "void g(void)\n{\n    y = 2; /* Bridge.tla: Emit */\n}\n"
    bad = _xref().problems(sources)
    assert len(bad) == 2
    assert "firmware/bridge/extra.c:3" in bad[0] and "outside host/c/" in bad[0]
    assert "host/c/core/extra.c:3" in bad[1] and "outside firmware/bridge/" in bad[1]
