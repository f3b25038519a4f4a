"""report/urb_report/quality.py: how findings meet their justifications and deviations.

This matching is what makes `make coverage`, `make misra` and `make static` fail, so each way it must
fail is shown here: a finding no entry explains, an entry that explains nothing (stale), an anchor or
token that matches nothing, two entries for one finding, and malformed entries.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from urb_report.quality import (Finding, QualityError, SourceIndex, finding_items, function_spans, load_entries, match,
                                path_matches)

SOURCE = """\
#include "x.h"
#define MAX(a, b) ((a) > (b) ? (a) : (b)) /* { not a body */

static const int table[2] = {1, 2};
typedef struct { int a; } pair_t;

/* a comment with a brace { and a paren ( */
static int
helper(int a,
       int b)
{
    const char *s = "}";
    if (a > b) {
        return a;
    }
    return b + (int)s[0];
}

__attribute__((weak)) void hook(void) {}

int pll_run(int pll)
{
    return pll + table[0];
}
"""


def _index(tmp_path: Path, text: str = SOURCE) -> SourceIndex:
    (tmp_path / "src").mkdir(exist_ok=True)
    (tmp_path / "src" / "a.c").write_text(text)
    return SourceIndex(tmp_path)


def _toml(tmp_path: Path, body: str) -> Path:
    p = tmp_path / "entries.toml"
    p.write_text(body)
    return p


def test_function_spans_skip_initialisers_types_comments_and_strings() -> None:
    spans = function_spans(SOURCE)
    assert spans == [("helper", 8, 17), ("hook", 19, 19), ("pll_run", 21, 24)]


def test_the_index_names_the_enclosing_function_and_the_token_at_a_column(tmp_path: Path) -> None:
    idx = _index(tmp_path)
    assert idx.function_at("src/a.c", 14) == "helper"
    assert idx.function_at("src/a.c", 4) == ""
    assert idx.token_at("src/a.c", 21, 17) == "pll"
    assert idx.token_at("src/a.c", 21, 5) == "pll_run"
    assert idx.token_at("src/a.c", 23, 12) == "pll"
    assert idx.token_at("src/a.c", 23, 16) == "+"


def test_globs_stay_in_a_directory_unless_doubled() -> None:
    assert path_matches("firmware/node/a.c", ["firmware/node/*.c"])
    assert not path_matches("firmware/node/sub/a.c", ["firmware/node/*.c"])
    assert path_matches("firmware/node/sub/a.c", ["firmware/**/*.c"])
    assert path_matches("firmware/a.c", ["firmware/**/*.c"])
    assert not path_matches("gen/c/a.h", ["gen/c/*.c"])


ENTRIES = """
[[deviation]]
id = "early-return"
rule = "15.5"
files = ["src/*.c"]
function = "helper"
anchors = ["return a;"]
reason = "guard clause with its own documented result"

[[deviation]]
id = "pll-name"
rule = "7.3"
files = ["src/*.c"]
tokens = ["pll"]
reason = "the token is an identifier, not a literal suffix"
"""


def test_findings_are_explained_by_function_anchor_and_token(tmp_path: Path) -> None:
    idx = _index(tmp_path)
    entries = load_entries(_toml(tmp_path, ENTRIES), "deviation", rule_key="rule")
    findings = [Finding("src/a.c", 14, "15.5", 9), Finding("src/a.c", 21, "7.3", 17), Finding("src/a.c", 23, "7.3", 12)]
    m = match(findings, entries, idx, what="entries.toml")
    assert m.ok and not m.unjustified and len(m.justified) == 3
    assert [f.line for f in m.used["pll-name"]] == [21, 23]
    items = finding_items(findings, m, idx, prefix="misra", rerun="make misra", expected="x")
    assert [i.id for i in items] == ["misra:15.5@src/a.c:14", "misra:7.3@src/a.c:21", "misra:7.3@src/a.c:23"]
    assert all(i.verdict == "pass" for i in items) and "guard clause" in items[0].measured


def test_a_finding_without_an_entry_fails(tmp_path: Path) -> None:
    idx = _index(tmp_path)
    entries = load_entries(_toml(tmp_path, ENTRIES), "deviation", rule_key="rule")
    seeded = Finding("src/a.c", 16, "15.5", 5)  # `return b + ...;` is not anchored
    m = match([Finding("src/a.c", 14, "15.5", 9), Finding("src/a.c", 21, "7.3", 17), seeded], entries, idx, what="e")
    assert not m.ok and m.unjustified == [seeded]
    items = finding_items([seeded], m, idx, prefix="misra", rerun="", expected="")
    assert items[0].verdict == "fail" and items[0].data["function"] == "helper"


def test_an_entry_an_anchor_or_a_token_that_explains_nothing_is_stale(tmp_path: Path) -> None:
    idx = _index(tmp_path)
    entries = load_entries(_toml(tmp_path, ENTRIES + """
[[deviation]]
id = "two-anchors"
rule = "2.7"
files = ["src/*.c"]
anchors = ["int b)", "no such text"]
reason = "an unused parameter kept for the callback signature"
"""), "deviation", rule_key="rule")
    m = match([Finding("src/a.c", 14, "15.5", 9), Finding("src/a.c", 10, "2.7", 8)], entries, idx, what="e")
    assert not m.unjustified and not m.ok
    assert set(m.stale) == {"pll-name", "two-anchors"}
    assert "explains no finding" in m.stale["pll-name"][0]
    assert "'no such text' matches no finding" in m.stale["two-anchors"][0]


def test_two_entries_for_one_finding_conflict(tmp_path: Path) -> None:
    idx = _index(tmp_path)
    entries = load_entries(_toml(tmp_path, """
[[deviation]]
id = "a"
rule = "15.5"
files = ["src/*.c"]
reason = "every early return in this file is a guard clause"
[[deviation]]
id = "b"
rule = "*"
files = ["src/a.c"]
function = "helper"
reason = "helper is a leaf function that returns its larger argument"
"""), "deviation", rule_key="rule")
    m = match([Finding("src/a.c", 14, "15.5", 9)], entries, idx, what="e")
    assert not m.ok and m.conflicts and "keep one" in m.conflicts[0]


@pytest.mark.parametrize("body, message", [
    ('[[deviation]]\nid = "Bad Id"\nrule = "1.1"\nfiles = ["a"]\nreason = "a b c d e f"\n', "lowercase name"),
    ('[[deviation]]\nid = "x"\nrule = "1.1"\nfiles = ["a"]\nreason = "because"\n', "in a sentence"),
    ('[[deviation]]\nid = "x"\nfiles = ["a"]\nreason = "a reason of five words"\n', "`rule` is missing"),
    ('[[deviation]]\nid = "x"\nrule = "1.1"\nreason = "a reason of five words"\n', "`files` is missing"),
    ('[[deviation]]\nid = "x"\nrule = "1.1"\nfiles = [1]\nreason = "a reason of five words"\n', "list of non-empty"),
    ('[[deviation]]\nid = "x"\nrule = "1.1"\nfiles = ["a"]\nreason = "a reason of five words"\n' * 2, "used twice"),
    ('deviation = 3\n', "array of tables"),
    ('[[deviation]]\nid = "x"\nrule = "1.1"\nfiles = ["a"]\nanchor = "typo"\nreason = "a reason of five words"\n',
     "unknown key"),
    ('[[deviation\n', "cannot read"),
])
def test_malformed_entries_are_clear_errors(tmp_path: Path, body: str, message: str) -> None:
    with pytest.raises(QualityError, match=message):
        load_entries(_toml(tmp_path, body), "deviation", rule_key="rule")
