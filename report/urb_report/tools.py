"""The tool qualification record: report/data/tools.json, with versions filled from the records.

Each tool entry names the keys (`match`) under which the evidence records list it in their
`tools` field; the version shown is the one the records were produced with. A tool that no record
names (the report's own tools, provers behind another tool) is asked at report time with its
`command`, and the row says so.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from .records import ROOT, Record, command_version

TOOLS_FILE = ROOT / "report" / "data" / "tools.json"


@dataclass(frozen=True)
class ToolRow:
    name: str
    version: str
    version_source: str
    configuration: str
    trusted_for: str
    limitations: tuple[str, ...]
    mitigations: tuple[str, ...]


def load(records: Sequence[Record], extra: dict[str, str] | None = None, path: Path = TOOLS_FILE) -> list[ToolRow]:
    """The rows of the tool list; `extra` adds versions known at report time (LOBSTER, TRLC)."""
    data = json.loads(path.read_text(encoding="utf-8"))
    rows = []
    for t in data["tools"]:
        found: dict[str, list[str]] = {}
        for rec in records:
            for key, version in rec.tools.items():
                if any(m.lower() == key.lower() or m.lower() in key.lower() for m in t["match"]):
                    found.setdefault(f"{key} {version}", []).append(rec.name)
        for key, version in (extra or {}).items():
            if any(m.lower() == key.lower() for m in t["match"]):
                found.setdefault(version, []).append("report")
        if found:
            version = "; ".join(sorted(found))
            source = "from the records " + ", ".join(sorted({n for ns in found.values() for n in ns}))
        elif t.get("command"):
            version = command_version(t["command"])
            source = "installed, asked at report time (no record names it)"
        else:
            version = "not recorded"
            source = "no record of this run names it"
        rows.append(ToolRow(t["name"], version, source, t["configuration"], t["trusted_for"],
                            tuple(t["limitations"]), tuple(t["mitigations"])))
    return rows
