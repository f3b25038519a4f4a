"""The requirements of spec/requirements/, read with TRLC (typed and checked by urb.rsl).

TRLC does the parsing and the type and field checks; a file it rejects raises RequirementsError
with TRLC's own messages (file, line, what is wrong), so the gate never works on half-read
requirements. Each requirement's tag is `urb.<NAME>`, as the source markers cite it.
"""

from __future__ import annotations

import io
from contextlib import redirect_stdout
from dataclasses import dataclass
from pathlib import Path

from .records import ROOT

REQUIREMENTS_DIR = ROOT / "spec" / "requirements"


class RequirementsError(Exception):
    """The requirement files do not parse or break a check of urb.rsl; the message has TRLC's report."""


@dataclass(frozen=True)
class Requirement:
    tag: str              # "urb.MBX_001"
    name: str             # "MBX_001"
    statement: str
    criterion: str        # "" when the statement is the criterion
    rationale: str
    source_kind: str      # "Paper" | "Design_Decision"
    source: str
    methods: tuple[str, ...]
    category: str
    version: int
    verified_by: tuple[str, ...]
    file: str             # repository-relative path
    line: int

    @property
    def text(self) -> str:
        """Statement and criterion as one text: what the baseline and the history compare."""
        return self.statement + (f" | criterion: {self.criterion}" if self.criterion else "")


@dataclass(frozen=True)
class Change:
    requirement: str      # tag
    from_version: int
    to_version: int
    old_text: str
    new_text: str
    reason: str
    date: str
    file: str
    line: int


@dataclass(frozen=True)
class Catalogue:
    requirements: tuple[Requirement, ...]
    changes: tuple[Change, ...]
    categories: dict[str, str]   # enum literal -> description, in declaration order
    methods: dict[str, str]

    def by_tag(self) -> dict[str, Requirement]:
        return {r.tag: r for r in self.requirements}


def _rel(path: str) -> str:
    p = Path(path).resolve()
    try:
        return str(p.relative_to(ROOT))
    except ValueError:
        return str(p)


def load(directory: Path | None = None) -> Catalogue:
    """Every Requirement and Change record under `directory` (default spec/requirements/)."""
    from trlc import ast  # type: ignore[import-untyped]
    from trlc.errors import Message_Handler  # type: ignore[import-untyped]
    from trlc.trlc import Source_Manager  # type: ignore[import-untyped]

    d = directory or REQUIREMENTS_DIR
    if not d.is_dir():
        raise RequirementsError(f"{d}: no requirements folder; spec/requirements/README.md says what goes there")
    out = io.StringIO()
    mh = Message_Handler(out=out)  # TRLC's diagnostics, kept for the error message
    with redirect_stdout(out):  # the source manager's own progress messages
        sm = Source_Manager(mh)
        sm.register_directory(str(d))
        symbols = sm.process()
    if symbols is None or mh.errors:
        raise RequirementsError(f"TRLC rejects the requirement files in {_rel(str(d))}:\n{out.getvalue().rstrip()}\n"
                                f"fix them (spec/requirements/README.md: how to write a requirement)")
    reqs: list[Requirement] = []
    changes: list[Change] = []
    categories: dict[str, str] = {}
    methods: dict[str, str] = {}
    for obj in symbols.iter_record_objects():
        v = obj.to_python_dict()
        loc = obj.location
        if obj.n_typ.name == "Requirement":
            reqs.append(Requirement(
                tag=obj.fully_qualified_name(), name=obj.name, statement=_flat(v["statement"]),
                criterion=_flat(v.get("criterion") or ""), rationale=_flat(v["rationale"]),
                source_kind=str(v["source_kind"]), source=str(v["source"]),
                methods=tuple(str(m) for m in v["method"]), category=str(v["category"]),
                version=int(v["version"]), verified_by=tuple(str(e) for e in v["verified_by"]),
                file=_rel(loc.file_name), line=int(loc.line_no)))
        elif obj.n_typ.name == "Change":
            changes.append(Change(
                requirement=_ref_name(v["requirement"]), from_version=int(v["from_version"]),
                to_version=int(v["to_version"]), old_text=_flat(v["old_text"]), new_text=_flat(v["new_text"]),
                reason=_flat(v["reason"]), date=str(v["date"]), file=_rel(loc.file_name), line=int(loc.line_no)))
    if not reqs:
        raise RequirementsError(f"{_rel(str(d))}: no Requirement records; a gate over no requirements proves nothing")
    pkg = symbols.lookup_assuming(mh, "urb", ast.Package)
    for enum_name, target in (("Category", categories), ("Method", methods)):
        enum = pkg.symbols.lookup_assuming(mh, enum_name, ast.Enumeration_Type)
        for lit in sorted(enum.literals.values(), key=lambda lit: lit.location.line_no):
            target[lit.name] = lit.description or lit.name
    reqs.sort(key=lambda r: (list(categories).index(r.category) if r.category in categories else 99, r.name))
    changes.sort(key=lambda c: (c.requirement, c.from_version))
    return Catalogue(tuple(reqs), tuple(changes), categories, methods)


def _flat(text: object) -> str:
    """One line: TRLC keeps the line breaks of a triple-quoted string, the report does not need them."""
    return " ".join(str(text).split())


def _ref_name(value: object) -> str:
    """A record reference as to_python_dict gives it ("urb.MBX_001" or "MBX_001") -> the tag."""
    s = str(value)
    return s if "." in s else f"urb.{s}"
