"""The rewrites the CAN proof views share (can_master_view.py, can_slave_view.py): struct members
taken out of a header and declared as globals, their uses in the source renamed, and the prepared
copy's files rewritten once. Each rewrite finds its text exactly or raises the view's `stale` error
(a view never goes stale silently)."""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from pathlib import Path

Stale = Callable[[str], SystemExit]


def remove_members(text: str, members: Sequence[str], include: str, declarations: str, header: str,
                   stale: Stale) -> str:
    """`text` (the header named `header`) without the member lines `members`, with `declarations`
    after its `include` line; each member line and the include must stand exactly once."""
    for line in (*members, include.rstrip("\n")):
        if text.count(line + "\n") != 1:
            raise stale(f"{line.strip()!r} not found once in {header}")
    for member in members:
        text = text.replace(member + "\n", "")
    return text.replace(include, include + "\n" + declarations)


def rename_members(text: str, moved: Sequence[tuple[str, str]], source: str, stale: Stale) -> str:
    """`text` (the source named `source`) with every use of each member access (`p->frame`, not
    `p->frames_sent`) replaced by its global; each must be used."""
    for member, name in moved:
        pattern = re.compile(re.escape(member) + r"(?!\w)")
        if not pattern.search(text):
            raise stale(f"{member} not used in {source}")
        text = pattern.sub(name, text)
    return text


def rewrite_once(views: Sequence[tuple[Path, Callable[[str], str]]], viewed: Callable[[str], bool]) -> None:
    """Applies each view to its file unless the file already is `viewed` (prepare copies afresh, so a
    second run on a viewed copy changes nothing)."""
    for path, view in views:
        text = path.read_text(encoding="utf-8")
        if not viewed(text):
            path.write_text(view(text), encoding="utf-8")
