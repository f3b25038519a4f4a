"""Versioned requirements: a changed statement or acceptance criterion is never silent.

spec/requirements/baseline.json holds, per requirement, the version and text (statement and
criterion) that were last accepted; spec/requirements/history.trlc holds one Change per version
step with the old and the new text and the reason. The gate fails when a requirement's text or
version differs from the baseline; `urb report --update-baseline` accepts the current texts, but
only when every difference is explained by a chain of Changes from the baseline's version and text
to the current ones. The report shows every Change.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from .requirements import REQUIREMENTS_DIR, Catalogue, Change, Requirement

BASELINE = REQUIREMENTS_DIR / "baseline.json"
HOW = ("raise its version by one, add a Change to spec/requirements/history.trlc (old text, new text, reason, "
       "date), then run `urb report --update-baseline` and commit both")


@dataclass(frozen=True)
class Finding:
    requirement: str
    message: str


def read_baseline(path: Path = BASELINE) -> dict[str, dict[str, object]]:
    if not path.is_file():
        return {}
    data = json.loads(path.read_text(encoding="utf-8"))
    if not isinstance(data, dict):
        raise ValueError(f"{path}: not a baseline (a JSON object of requirement tags)")
    return {str(k): dict(v) for k, v in data.items()}


def _chain(changes: list[Change], tag: str, start: int, end: int) -> list[Change] | None:
    steps = {c.from_version: c for c in changes if c.requirement == tag}
    out = []
    v = start
    while v < end:
        c = steps.get(v)
        if c is None:
            return None
        out.append(c)
        v = c.to_version
    return out


def check(cat: Catalogue, baseline: dict[str, dict[str, object]]) -> list[Finding]:
    """Why the current requirements do not match the baseline, one finding per requirement."""
    findings = []
    changes = list(cat.changes)
    tags = {r.tag for r in cat.requirements}
    for c in changes:
        if c.requirement not in tags:
            findings.append(Finding(c.requirement, f"{c.file}:{c.line}: a Change of an unknown requirement"))
    for req in cat.requirements:
        msg = _explain(req, baseline.get(req.tag), changes)
        if msg:
            findings.append(Finding(req.tag, msg))
    for tag in sorted(set(baseline) - tags):
        findings.append(Finding(tag, "is in baseline.json but no longer a requirement: a removal is accepted by "
                                     "`urb report --update-baseline` (commit it with the reason)"))
    return findings


def _explain(req: Requirement, base: dict[str, object] | None, changes: list[Change]) -> str:
    mine = [c for c in changes if c.requirement == req.tag]
    for a, b in zip(mine, mine[1:]):
        if a.to_version == b.from_version and a.new_text != b.old_text:
            return (f"history.trlc: the change to version {a.to_version} ends with another text than the change "
                    f"from it starts with")
    last = [c for c in mine if c.to_version == req.version]
    if last and last[0].new_text != req.text:
        return (f"the text of version {req.version} differs from the new text its Change in history.trlc records: "
                f"a second change needs a new version ({HOW})")
    if base is None:
        if req.version != 1:
            return f"new requirement at version {req.version}: a new requirement starts at version 1"
        return f"new requirement, not yet in baseline.json: run `urb report --update-baseline` and commit it"
    bver, btext = int(str(base.get("version", 0))), str(base.get("text", ""))
    if bver == req.version and btext == req.text:
        return ""
    if bver == req.version:
        return f"its statement or criterion changed without a version step (still version {req.version}): {HOW}"
    if req.version < bver:
        return f"its version went down from {bver} to {req.version}"
    chain = _chain(changes, req.tag, bver, req.version)
    if chain is None:
        return (f"version {bver} -> {req.version} without a Change for every step in history.trlc "
                f"(old text, new text, reason): {HOW}")
    if chain[0].old_text != btext:
        return (f"the Change from version {bver} records another old text than the baseline's "
                f"({btext[:80]!r}...)")
    return (f"changed from version {bver} to {req.version} with its reasons in history.trlc, but baseline.json is "
            f"not updated: run `urb report --update-baseline` and commit it")


def update(cat: Catalogue, path: Path = BASELINE) -> list[Finding]:
    """Write the current texts as the baseline when every difference is explained; otherwise write
    nothing and return what is unexplained."""
    baseline = read_baseline(path)
    blocking = [f for f in check(cat, baseline)
                if not (f.message.startswith("changed from version") or f.message.startswith("new requirement, not yet")
                        or f.message.startswith("is in baseline.json but no longer"))]
    if blocking:
        return blocking
    data = {r.tag: {"version": r.version, "text": r.text} for r in cat.requirements}
    path.write_text(json.dumps(data, indent=1, sort_keys=True, ensure_ascii=False) + "\n", encoding="utf-8")
    return []
