"""Traceability with BMW's LOBSTER: the requirements (lobster-trlc), the code markers and the
evidence (written here in LOBSTER's documented JSON: lobster-imp-trace and lobster-act-trace,
version 3), then lobster-report with spec/requirements/lobster.conf, lobster-ci-report as the
tracing gate and lobster-html-report for the tracing view.

Everything runs in build/report/lobster/, where lobster.conf's relative sources are written.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from .evidence import Resolution, activity_of
from .markers import Marker
from .records import ROOT
from .requirements import REQUIREMENTS_DIR

CONFIG = REQUIREMENTS_DIR / "lobster.conf"
TRLC_CONFIG = REQUIREMENTS_DIR / "lobster-trlc.yaml"
GENERATOR = "urb_report"
FRAMEWORK = {"tlc": "TLC", "bmc": "ESBMC", "framac": "Frama-C", "fuzz": "libFuzzer", "pytest": "pytest",
             "cmocka": "cmocka", "sim": "urb sim", "coverage": "gcovr/llvm-cov", "misra": "cppcheck",
             "static": "static analysis", "size": "arm-none-eabi-size",
             "mutation": "c_mutate", "tlc-mutation": "TLC"}


@dataclass(frozen=True)
class LobsterResult:
    ok: bool                 # lobster-ci-report exited 0
    messages: tuple[str, ...]   # its complaints, one per line (file: message)
    report: Path             # report.lobster
    html: Path | None        # lobster-html-report's page, when it could be written
    versions: Mapping[str, str]


def _tool(name: str) -> str:
    """The LOBSTER or TRLC command next to this interpreter (the .venv), else on PATH."""
    local = Path(sys.executable).parent / name
    return str(local) if local.exists() else name


def _location(file: str, line: int | None) -> dict[str, object]:
    return {"kind": "file", "file": str(ROOT / file) if file else "", "line": line, "column": None} if file \
        else {"kind": "void"}


def _item(tag: str, refs: Iterable[str], location: dict[str, object], name: str) -> dict[str, object]:
    return {"tag": tag, "location": location, "name": name, "messages": [], "just_up": [], "just_down": [],
            "just_global": [], "refs": sorted({f"req {r}" for r in refs})}


def code_items(markers: Sequence[Marker]) -> list[dict[str, object]]:
    """One implementation item per function (or file) carrying markers, with every tag it names."""
    grouped: dict[str, tuple[Marker, set[str]]] = {}
    for m in markers:
        if m.is_activity:
            continue
        key = f"{m.file}:{m.item}" if m.item else m.file
        first, tags = grouped.setdefault(key, (m, set()))
        tags.update(m.requirements)
    out = []
    for key, (m, tags) in sorted(grouped.items()):
        item = _item(f"imp {key}", tags, _location(m.file, m.line), m.item or m.file)
        item.update({"language": m.language, "kind": "Function" if m.item else "File"})
        out.append(item)
    return out


def evidence_items(cited: Mapping[str, Sequence[str]], resolutions: Mapping[str, Resolution],
                   markers: Sequence[Marker]) -> list[dict[str, object]]:
    """One activity item per evidence id that has a result (any verdict) and traces to a requirement:
    the requirements citing it and the markers in its source. An id with no result is left out, so
    a requirement whose evidence all lacks results is untraced for LOBSTER too."""
    refs: dict[str, set[str]] = {e: set(tags) for e, tags in cited.items()}
    where: dict[str, tuple[str, int]] = {}
    for m in markers:
        if m.is_activity:
            refs.setdefault(m.evidence, set()).update(m.requirements)
            where.setdefault(m.evidence, (m.file, m.line))
    out = []
    for evidence, tags in sorted(refs.items()):
        res = resolutions.get(evidence)
        if res is None or res.status == "missing" or not tags:
            continue
        file, line = where.get(evidence, ("", 0))
        if not file and res.hits:
            src = res.hits[0][1].source
            file, _, ln = src.partition(":")
            line = int(ln) if ln.isdigit() else 0
            if file and not (ROOT / file).exists():
                file = ""
        kind = evidence.split(":", 1)[0]
        item = _item(f"evidence {evidence}", tags, _location(file, line or None), evidence)
        item.update({"framework": FRAMEWORK.get(activity_of(kind) or kind, kind), "kind": kind,
                     "status": {"pass": "ok"}.get(res.status, res.status)})
        out.append(item)
    return out


def _write(path: Path, schema: str, items: list[dict[str, object]]) -> None:
    data = {"data": items, "generator": GENERATOR, "schema": schema, "version": 3}
    path.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")


def run(out_dir: Path, code: list[dict[str, object]], evidence: list[dict[str, object]],
        html: bool = True) -> LobsterResult:
    """Write the three sources, run lobster-report and lobster-ci-report (and the HTML view)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    for stale in ("report.lobster", "requirements.lobster", "tracing.html"):
        (out_dir / stale).unlink(missing_ok=True)
    shutil.copy(CONFIG, out_dir / "lobster.conf")
    _write(out_dir / "code.lobster", "lobster-imp-trace", code)
    _write(out_dir / "evidence.lobster", "lobster-act-trace", evidence)
    messages: list[str] = []
    trlc = subprocess.run([_tool("lobster-trlc"), "--config", str(TRLC_CONFIG), "--out",
                           str(out_dir / "requirements.lobster"), str(REQUIREMENTS_DIR)],
                          cwd=ROOT, capture_output=True, text=True, check=False)
    if trlc.returncode != 0:
        return LobsterResult(False, tuple(_lines(trlc) or ["lobster-trlc failed"]), out_dir / "report.lobster", None,
                             versions())
    rep = subprocess.run([_tool("lobster-report"), "--lobster-config", "lobster.conf", "--out", "report.lobster"],
                         cwd=out_dir, capture_output=True, text=True, check=False)
    if rep.returncode != 0:
        return LobsterResult(False, tuple(_lines(rep) or ["lobster-report failed"]), out_dir / "report.lobster", None,
                             versions())
    ci = subprocess.run([_tool("lobster-ci-report"), "report.lobster"], cwd=out_dir, capture_output=True, text=True,
                        check=False)
    messages = _lines(ci)
    page: Path | None = None
    if html:
        h = subprocess.run([_tool("lobster-html-report"), "report.lobster", "--out", "tracing.html"], cwd=out_dir,
                           capture_output=True, text=True, check=False)
        page = out_dir / "tracing.html" if h.returncode == 0 and (out_dir / "tracing.html").is_file() else None
    return LobsterResult(ci.returncode == 0, tuple(messages), out_dir / "report.lobster", page, versions())


def _lines(proc: subprocess.CompletedProcess[str]) -> list[str]:
    root = str(ROOT) + "/"
    return [ln.replace(root, "") for ln in (proc.stdout + proc.stderr).splitlines() if ln.strip()]


def versions() -> dict[str, str]:
    from .records import package_version

    return {"LOBSTER": f"bmw-lobster {package_version('bmw-lobster')}", "TRLC": f"trlc {package_version('trlc')}"}


def tracing_status(report: Path) -> dict[str, str]:
    """Each requirement tag ("urb.X") -> LOBSTER's tracing status (OK, MISSING, ...), from report.lobster."""
    try:
        data = json.loads(report.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError):
        return {}
    out = {}
    for level in data.get("levels", []):
        if level.get("kind") != "requirements":
            continue
        for item in level.get("items", []):
            tag = str(item.get("tag", "")).split(" ", 1)[-1].split("@", 1)[0]
            out[tag] = str(item.get("tracing_status", ""))
    return out
