"""The mutation score: which seeded bugs each verification tool catches, per firmware component.

Sources (machine-readable results, never rerun here):

* ESBMC: build/proofs/bmc/summary.json, rows `<folder> [mutant <name>]`; the mutant's file,
  function and `kind` from proofs/bmc/<folder>/mutants.json;
* Frama-C: build/proofs/framac/summary.json, rows `<unit> mutant <name>` with `file` and `kind`
  (written by tools/proofs_framac.py from proofs/framac/<unit>/unit.json);
* fuzzing: build/proofs/fuzz/summary.json, rows naming the mutants of tests/fuzz/mutants.json;
* unit tests: build/proofs/mutation/c.json, the generated mutants of tools/c_mutate.py;
* TLC: build/proofs/mutation/tlc.json, written by the TLA+ mutation run:
  `{"mutants": [{"name", "module" (a spec/tla module) or "component", "kind", "killed": bool,
  "explained": "why a survivor is equivalent" (optional)}]}`.

A mutant without a kind counts as "other" until its source says. A tool whose results are missing
gets "not run" cells, never zeros. The table's cells are killed/total per kind, then the survivors:
explained ones by their labels (E1, E2, ...) and unexplained ones apart (U1, ...), each label a
footnote under the table with the survivor's explanation, so a reviewer sees in the table which
survivors there are and below it why each is acceptable. An unexplained survivor is a problem (the
summary fails on it).
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable

from urb_report import c_source
from urb_report.records import Item, command_version, write_record

ROOT = Path(__file__).resolve().parents[2]

# The kinds of the score, in table order, and the names they are shown with.
KINDS = {"off-by-one": "off-by-one in a bound", "order": "wrong order", "missing-effect": "missing publish or free",
         "field": "wrong field", "error": "dropped error", "other": "other"}
TOOLS = ("TLC", "ESBMC", "Frama-C", "fuzzing", "unit tests")
SHORT = {"off-by-one": "off-by-one", "order": "order", "missing-effect": "publish/free", "field": "field",
         "error": "error", "other": "other"}  # the kinds in the table's cells


@dataclass(frozen=True)
class Component:
    """A part of the firmware: files, each with the functions that belong to the component (None:
    the whole file). `mutated`: tools/c_mutate.py seeds bugs into it."""

    name: str
    parts: tuple[tuple[str, tuple[str, ...] | None], ...]
    mutated: bool = True
    modules: tuple[str, ...] = ()  # the TLA+ models of it (for TLC mutants)

    def files(self) -> list[str]:
        return [f for f, _ in self.parts]

    def functions(self, path: str) -> tuple[str, ...] | None:
        return next((fns for f, fns in self.parts if f == path), None)


_BRIDGE_FIFO = ("ring_index", "slot_index", "store_slot", "admit", "admission_status", "urbb_frame", "first_pending",
                "oldest_pending", "complete", "served", "activity_done", "start_next", "emit_entry", "emit",
                "urb_bridge_outstanding", "urb_bridge_idle")
_BRIDGE_DISCOVERY = ("set_present", "node_forget", "node_learn", "known_size", "start_scan", "identification_begin",
                     "scan_begin", "scan_done", "probed", "needs_identification", "identified", "urb_bridge_present")
_NODE_INBOX0 = ("run_command", "reset_application")
_NODE_PLL = ("run_update", "acq_sample", "urb_node_mark_acquired")

COMPONENTS: list[Component] = [
    Component("node mailbox", (("firmware/node/urb_mailbox.c", None),), modules=("MailboxInbox", "MailboxOutbox")),
    Component("node I2C", (("firmware/node/urb_i2c.c", None),)),
    Component("inbox-0 commands", (("firmware/node/urb_node.c", _NODE_INBOX0),)),
    Component("PLL", (("firmware/node/urb_pll.c", None), ("firmware/node/urb_node.c", _NODE_PLL))),
    Component("bridge FIFO", (("firmware/bridge/bridge.c", _BRIDGE_FIFO),), modules=("Bridge",)),
    Component("uplink parsers", (("firmware/bridge/bridge_uplink.c", None),), modules=("UsbUplink",)),
    Component("downlink master", (("firmware/bridge/i2c_master.c", None),)),
    Component("bridge discovery", (("firmware/bridge/bridge.c", _BRIDGE_DISCOVERY),), mutated=False,
              modules=("Discovery",)),
    Component("bridge, other", (("firmware/bridge/bridge.c", None),), mutated=False),
    Component("node, other", (("firmware/node/urb_node.c", None), ("firmware/node/urb_observe.c", None),
                              ("firmware/node/urb_single.c", None)), mutated=False),
    Component("generated codecs", (("gen/c/urb_core.c", None), ("gen/c/urb_runtime.c", None),
                                   ("gen/c/urb_sensorhex.c", None)), mutated=False),
]


def kind_of(raw: Any) -> str:
    """A mutant's kind in the score's words: the five kinds (synonyms accepted), else "other"."""
    text = str(raw or "").lower()
    for key, pattern in (("off-by-one", r"off.?by.?one|bound"), ("order", r"order|swap"),
                         ("missing-effect", r"publish|free|missing|effect|flag"), ("field", r"field"),
                         ("error", r"error|check")):
        if re.search(pattern, text):
            return key
    return "other"


def component_of(path: str, function: str = "") -> str:
    """The component a file (and function) belongs to: the first whose part names the function,
    else the first holding the whole file, else the file's folder."""
    for comp in COMPONENTS:
        fns = [f for f_path, f in comp.parts if f_path == path]
        if fns and fns[0] is not None and function in fns[0]:
            return comp.name
    for comp in COMPONENTS:
        if any(f_path == path and fns is None for f_path, fns in comp.parts):
            return comp.name
    return str(Path(path).parent) or path


def locate(path: str, find: str) -> str:
    """The function of `path` whose body holds the text `find` (a mutant's find/replace), or ""."""
    try:
        text = (ROOT / path).read_text(encoding="utf-8")
    except OSError:
        return ""
    at = text.find(find) if find else -1
    return c_source.function_at(c_source.code_of(text), at) if at >= 0 else ""


def locate_define(define: str) -> tuple[str, str]:
    """(file, function) of a hand-seeded `URB_MUTANT_X` branch in firmware/, or ("", "")."""
    name = define.removeprefix("-D")
    for path in sorted((ROOT / "firmware").rglob("*.c")):
        text = path.read_text(encoding="utf-8", errors="replace")
        at = text.find(name)
        if at >= 0:
            rel = str(path.relative_to(ROOT))
            return rel, c_source.function_at(c_source.code_of(text), at)
    return "", ""


# =============================================================================== results


@dataclass
class Seeded:
    """One seeded bug and whether a tool caught it."""

    tool: str
    name: str
    component: str
    kind: str
    killed: bool
    explained: str = ""  # why a survivor is equivalent (or does not matter), from its source
    detail: str = ""


@dataclass
class Loaded:
    seeded: list[Seeded] = field(default_factory=list)
    missing: dict[str, str] = field(default_factory=dict)  # tool -> why it has no results
    problems: list[str] = field(default_factory=list)


def _read_json(path: Path) -> Any:
    return json.loads(path.read_text(encoding="utf-8"))


def _rows(path: Path) -> list[dict[str, Any]]:
    data = _read_json(path)
    rows = data.get("rows") if isinstance(data, dict) else None
    if not isinstance(rows, list):
        raise ValueError(f"{path} holds no rows")
    return [r for r in rows if isinstance(r, dict)]


def _esbmc(out_root: Path, found: Loaded) -> None:
    path = out_root / "bmc" / "summary.json"
    if not path.is_file():
        found.missing["ESBMC"] = "not run (build/proofs/bmc/summary.json missing: make proofs-bmc)"
        return
    for r in _rows(path):
        m = re.fullmatch(r"(\S+) \[mutant (.+)\]", str(r.get("function", "")))
        if not m:
            continue
        folder, name = m.groups()
        spec = ROOT / "proofs" / "bmc" / folder / "mutants.json"
        entries: list[dict[str, Any]] = _read_json(spec) if spec.is_file() else []
        entry: dict[str, Any] = next((e for e in entries if e.get("name") == name), {})
        file = str(entry.get("file", ""))
        function = str(entry.get("function", "")) or locate(file, str(entry.get("find", "")))
        found.seeded.append(Seeded("ESBMC", f"{folder}/{name}", component_of(file, function) if file else folder,
                                   kind_of(r.get("kind", entry.get("kind"))), r.get("result") == "killed",
                                   detail=str(r.get("result", ""))))


def _framac(out_root: Path, found: Loaded) -> None:
    path = out_root / "framac" / "summary.json"
    if not path.is_file():
        found.missing["Frama-C"] = "not run (build/proofs/framac/summary.json missing: make proofs-framac)"
        return
    for r in _rows(path):
        m = re.fullmatch(r"(\S+) mutant (.+)", str(r.get("function", "")))
        if not m:
            continue
        file = str(r.get("file", ""))
        function = str(r.get("mutated_function", ""))
        found.seeded.append(Seeded("Frama-C", f"{m.group(1)}/{m.group(2)}",
                                   component_of(file, function) if file else m.group(1), kind_of(r.get("kind")),
                                   r.get("result") == "killed", detail=str(r.get("result", ""))))


def _fuzz(out_root: Path, found: Loaded) -> None:
    path = out_root / "fuzz" / "summary.json"
    if not path.is_file():
        found.missing["fuzzing"] = "not run (build/proofs/fuzz/summary.json missing: make fuzz)"
        return
    spec_path = ROOT / "tests" / "fuzz" / "mutants.json"
    entries = {str(e.get("name")): e for e in (_read_json(spec_path) if spec_path.is_file() else [])}
    for r in _rows(path):
        m = re.fullmatch(r"(\S+) mutant (\S+)", str(r.get("function", "")))
        if not m:
            continue
        name = m.group(2)
        e = entries.get(name, {"target": m.group(1)})
        if e.get("file"):
            file, function = str(e["file"]), locate(str(e["file"]), str(e.get("find", "")))
        else:
            file, function = locate_define(str(e.get("define", "")))
        found.seeded.append(Seeded("fuzzing", f"{e.get('target', '')}/{name}",
                                   component_of(file, function) if file else str(e.get("target", "")),
                                   kind_of(r.get("kind", e.get("kind"))), r.get("result") == "killed",
                                   detail=str(r.get("result", ""))))


def _unit_tests(out_root: Path, found: Loaded) -> None:
    path = out_root / "mutation" / "c.json"
    if not path.is_file():
        found.missing["unit tests"] = "not run (build/proofs/mutation/c.json missing: make proofs-mutation)"
        return
    data = _read_json(path)
    for m in data.get("mutants", []):
        if m.get("result") == "stillborn":
            continue
        found.seeded.append(Seeded("unit tests", str(m["id"]), str(m["component"]), kind_of(m.get("kind")),
                                   m.get("result") == "killed", explained=str(m.get("explained", "")),
                                   detail=str(m.get("killed_by", ""))))
        verdicts = m.get("esbmc") or {}
        if verdicts:  # a unit-test survivor also run through the component's BMC proofs (--esbmc)
            killed = any(str(v).startswith("killed") for v in verdicts.values())
            found.seeded.append(Seeded("ESBMC", f"c:{m['id']}", str(m["component"]), kind_of(m.get("kind")), killed,
                                       explained="" if killed else str(m.get("explained", "")),
                                       detail="; ".join(f"{f}: {v}" for f, v in verdicts.items())))


def _tlc(out_root: Path, found: Loaded) -> None:
    """TLA+ mutants: {"mutants": [...]} (or a proof-part {"rows": [...]}, or a bare list), each with a
    name ("name", "id" or "function"), the model ("module", "model" or "component"), "kind", and its
    outcome ("killed": bool, or "result": "killed", or "verdict": "pass"), optionally "explained"."""
    path = out_root / "mutation" / "tlc.json"
    if not path.is_file():
        found.missing["TLC"] = "not run (build/proofs/mutation/tlc.json missing: the TLA+ mutation run writes it)"
        return
    data = _read_json(path)
    entries = data if isinstance(data, list) else next(
        (data[k] for k in ("mutants", "rows", "items") if isinstance(data, dict) and isinstance(data.get(k), list)), None)
    if entries is None or not all(isinstance(e, dict) for e in entries):
        found.problems.append(f"{path}: no list of mutants (\"mutants\": [...]): see urb_report/mutation.py, _tlc")
        found.missing["TLC"] = "unreadable (build/proofs/mutation/tlc.json)"
        return
    by_module = {mod: c.name for c in COMPONENTS for mod in c.modules}
    for m in entries:
        module = str(m.get("module") or m.get("model") or "")
        comp = str(m.get("component") or by_module.get(module, module or "TLA+"))
        killed = m.get("killed") is True or str(m.get("result", "")).lower() == "killed" or m.get("verdict") == "pass"
        found.seeded.append(Seeded("TLC", str(m.get("name") or m.get("id") or m.get("function") or "?"), comp,
                                   kind_of(m.get("kind")), killed, explained=str(m.get("explained", "") or "")))


def load(out_root: Path) -> Loaded:
    """Every tool's seeded bugs from the results under out_root (build/proofs)."""
    found = Loaded()
    for tool, reader in zip(TOOLS, (_tlc, _esbmc, _framac, _fuzz, _unit_tests)):
        try:
            reader(out_root, found)
        except (OSError, ValueError, KeyError, TypeError) as exc:
            found.problems.append(f"mutation table: cannot read the results of {reader.__name__.strip('_')}: {exc}")
            found.missing[tool] = f"unreadable results ({exc})"
        if tool not in found.missing and not any(s.tool == tool for s in found.seeded):
            found.missing[tool] = "no mutant in its results (a run without mutants?)"
    for s in found.seeded:
        if not s.killed and not s.explained:
            found.problems.append(f"mutation table: {s.tool} mutant {s.name} ({s.component}, {KINDS[s.kind]}) "
                                  f"survived unexplained{': ' + s.detail if s.detail else ''}")
    return found


# =============================================================================== table


def _labels(numbers: list[int], prefix: str) -> str:
    """Footnote labels, consecutive runs as ranges: [1, 2, 3, 5] -> "E1–E3, E5"."""
    runs: list[list[int]] = []
    for n in sorted(numbers):
        if runs and n == runs[-1][-1] + 1:
            runs[-1].append(n)
        else:
            runs.append([n])
    return ", ".join(f"{prefix}{r[0]}" if len(r) == 1 else f"{prefix}{r[0]}–{prefix}{r[-1]}" for r in runs)


@dataclass
class Footnotes:
    """The survivors in table order, numbered: explained ones E1, E2, ..., unexplained ones U1, ..."""

    explained: list[Seeded] = field(default_factory=list)
    unexplained: list[Seeded] = field(default_factory=list)

    def label(self, s: Seeded) -> str:
        if s.explained:
            return f"E{next(i for i, x in enumerate(self.explained, 1) if x is s)}"
        return f"U{next(i for i, x in enumerate(self.unexplained, 1) if x is s)}"


def footnotes(found: Loaded, comps: list[str]) -> Footnotes:
    notes = Footnotes()
    order = {c: i for i, c in enumerate(comps)}
    kinds = list(KINDS)
    survivors = sorted((s for s in found.seeded if not s.killed),
                       key=lambda s: (order.get(s.component, len(order)), TOOLS.index(s.tool), kinds.index(s.kind)))
    for s in survivors:
        (notes.explained if s.explained else notes.unexplained).append(s)
    return notes


def _cell(group: Iterable[Seeded], notes: Footnotes) -> str:
    by_kind: dict[str, list[Seeded]] = {}
    for s in group:
        by_kind.setdefault(s.kind, []).append(s)
    if not by_kind:
        return "-"
    parts = []
    for kind in KINDS:
        items = by_kind.get(kind, [])
        if items:
            killed = sum(s.killed for s in items)
            explained = [int(notes.label(s)[1:]) for s in items if not s.killed and s.explained]
            unexplained = [int(notes.label(s)[1:]) for s in items if not s.killed and not s.explained]
            text = f"{SHORT[kind]} {killed}/{len(items)}"
            if explained:
                text += f" (+{len(explained)} explained: {_labels(explained, 'E')})"
            if unexplained:
                text += f" (**{len(unexplained)} unexplained: {_labels(unexplained, 'U')}**)"
            parts.append(text)
    return "<br>".join(parts)


def _one_line(text: str) -> str:
    return " ".join(text.split()).replace("|", "\\|")


def markdown(found: Loaded) -> list[str]:
    """The mutation score section of build/proofs/summary.md."""
    comps = [c.name for c in COMPONENTS if c.mutated]  # always shown; others when a tool seeded bugs there
    comps += [c.name for c in COMPONENTS if not c.mutated and any(s.component == c.name for s in found.seeded)]
    comps += sorted({s.component for s in found.seeded} - {c.name for c in COMPONENTS})
    notes = footnotes(found, comps)
    md = ["## Mutation score", "",
          "Seeded bugs per component (rows) and tool (columns): killed/total per kind (off-by-one: in a bound; "
          "order: wrong order; publish/free: a missing publish or free; field: wrong field; error: dropped error; "
          "other), then the survivors of that kind: \"explained\" names the footnotes (E1, ...) under the table "
          "that say why each is acceptable (equivalent, or outside what the check is about); \"unexplained\" "
          "ones (U1, ...) fail the summary. Sources: urb_report/mutation.py, tests/mutation/README.md.", "",
          "| component | " + " | ".join(TOOLS) + " |", "|---|" + "---|" * len(TOOLS)]
    for comp in comps:
        cells = []
        for tool in TOOLS:
            if tool in found.missing:
                cells.append(found.missing[tool].split(" (")[0])  # "not run", "no mutant in its results", ...
            else:
                cells.append(_cell((s for s in found.seeded if s.tool == tool and s.component == comp), notes))
        md.append(f"| {comp} | " + " | ".join(cells) + " |")

    def total(tool: str) -> str:
        if tool in found.missing:
            return f"{tool} {found.missing[tool]}"
        own = [s for s in found.seeded if s.tool == tool]
        return (f"{tool} {sum(s.killed for s in own)}/{len(own)} killed, "
                f"{sum(not s.killed and bool(s.explained) for s in own)} explained, "
                f"{sum(not s.killed and not s.explained for s in own)} unexplained")
    md += ["", "Totals: " + "; ".join(total(tool) for tool in TOOLS) + ".", "",
           f"Unexplained survivors: {len(notes.unexplained)}"
           + (" (each is a problem: the summary fails)." if notes.unexplained else "."), ""]
    md += ["### Survivors", ""]
    if not notes.explained and not notes.unexplained:
        md.append("None.")
    for s in notes.unexplained:
        md.append(f"- **{notes.label(s)}** {s.tool} `{s.name}` ({s.component}, {KINDS[s.kind]}): **UNEXPLAINED**"
                  + (f" ({_one_line(s.detail)})" if s.detail else "") + ": kill it with a new check or explain it")
    for s in notes.explained:
        md.append(f"- **{notes.label(s)}** {s.tool} `{s.name}` ({s.component}, {KINDS[s.kind]}): "
                  f"{_one_line(s.explained)}")
    return md + [""]


# =============================================================================== evidence


def evidence_items(found: Loaded) -> list[Item]:
    """One item per table cell (`mutation:<component>/<tool>`) and one per generated C mutant
    (`c-mutant:<id>`; the other tools' mutants are items of their own records)."""
    items: list[Item] = []
    cells: dict[tuple[str, str], list[Seeded]] = {}
    for s in found.seeded:
        cells.setdefault((s.component, s.tool), []).append(s)
    for (comp, tool), group in sorted(cells.items()):
        unexplained = [s.name for s in group if not s.killed and not s.explained]
        per_kind = {k: {"killed": sum(s.killed for s in group if s.kind == k),
                        "explained": sum(not s.killed and bool(s.explained) for s in group if s.kind == k),
                        "total": sum(s.kind == k for s in group)} for k in KINDS if any(s.kind == k for s in group)}
        items.append(Item(f"mutation:{comp}/{tool}", "mutation-score", "fail" if unexplained else "pass",
                          "every seeded bug killed or explained as equivalent",
                          f"{sum(s.killed for s in group)}/{len(group)} killed", "", "",
                          {"kinds": per_kind, "unexplained": unexplained,
                           "survivors": [{"name": s.name, "kind": s.kind, "explained": s.explained}
                                         for s in group if not s.killed]}))
    for s in found.seeded:
        if s.tool == "unit tests":
            items.append(Item(f"c-mutant:{s.name}", "mutant", "pass" if s.killed or s.explained else "fail",
                              "killed by the component's unit tests, or explained as equivalent",
                              "killed" if s.killed else ("equivalent" if s.explained else "SURVIVED"),
                              "tools/c_mutate.py", f"python3 tools/c_mutate.py run --id {s.name}",
                              {"component": s.component, "kind": s.kind, "killed_by": s.detail,
                               "explained": s.explained}))
    return items


def summary_section(out_root: Path, problems: list[str], evidence_dir: Path | None = None) -> list[str]:
    """For tools/proofs.py summary: the mutation score section of summary.md; appends the score's
    problems (unexplained survivors, unreadable results) and writes build/evidence/mutation.json."""
    found = load(out_root)
    problems.extend(found.problems)
    sources = {tool: found.missing.get(tool, "read") for tool in TOOLS}
    write_record("mutation", evidence_items(found), {"c_mutate": "tools/c_mutate.py",
                                                     "gcc": command_version(["gcc", "--version"])},
                 config={"results": str(out_root), "sources": sources}, out_dir=evidence_dir)
    return markdown(found)
