"""Result cache of whole Frama-C runs (tools/proofs_framac.py): a run whose inputs are byte-identical
to a recorded run's replays the recorded log and report files instead of running Frama-C.

The design is proofs/bmc/bmc_cache.py's (ESBMC). A run is identified by a key: the SHA-256 of the
Frama-C version and Debian package (which ships every plugin), for WP also the why3, z3 and cvc4
versions and the bytes of every entry of WP's prover-answer cache (proofs/framac/cache), the
argument list and the bytes of every file the run reads (the .c files given, and every header the
preprocessor pulls in for them with the run's -D/-I/-U options, listed by `cc -MM` the way Frama-C
preprocesses: its own libc, __FRAMAC__ and the machdep defined). The repository's own path is
replaced by `<repo>` in the arguments, the file names, the file contents and the recorded outputs,
so two clones of one commit give the same keys and replay the same verdicts.

Modes (environment variable FRAMAC_RESULT_CACHE):
  on       (default) a recorded key replays its log and report files; a new key runs Frama-C and,
           when the run gave a verdict (the caller decides: Frama-C exited normally, wrote its
           reports and, for WP, every goal had an answer), records it under
           proofs/framac/results/<unit>/<key>.json.gz (commit the new files to reuse them)
  off      always run Frama-C; record nothing (the tests of the checker itself run so)
  refresh  always run Frama-C and record the verdict, replacing any recorded one

Spot checks: with FRAMAC_RESULT_CACHE_VERIFY=N (0 to 1000) and FRAMAC_RESULT_CACHE_SEED=S, a
recorded run whose key falls in N per mille of the keys (SHA-256 of S and the key) is run again
for real when its recorded CPU time is under FRAMAC_RESULT_CACHE_VERIFY_MAX_CPU seconds (default
30); the caller fails the unit when the verdicts differ. make check sets S to the commit.
"""

from __future__ import annotations

import datetime
import gzip
import hashlib
import json
import os
import shlex
import subprocess
import threading
from dataclasses import dataclass
from pathlib import Path

from tools.result_cache import REPO_TOKEN, content_key, git_commit, normalize, spot_checked, write_entry

FORMAT = 1
MODES = ("on", "off", "refresh")
ENV = "FRAMAC_RESULT_CACHE"
MACHDEP_DEFINE = "-D__FC_MACHDEP_X86_32"  # Frama-C defines its machdep's macro (tools/proofs_framac.py MACHDEP)


class CacheError(Exception):
    """The cache cannot decide (no preprocessor listing, no tool version); the caller runs Frama-C."""


def mode() -> str:
    """FRAMAC_RESULT_CACHE (default on); raises CacheError naming the valid modes."""
    value = os.environ.get(ENV, "on")
    if value not in MODES:
        raise CacheError(f"{ENV}={value!r} is not one of {', '.join(MODES)}")
    return value


def _first_line(cmd: list[str]) -> str:
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.SubprocessError) as e:
        raise CacheError(f"cannot run {' '.join(cmd)}: {e}") from None
    if out.returncode != 0:
        raise CacheError(f"`{' '.join(cmd)}` failed: {(out.stdout + out.stderr).strip()[:200]}")
    return (out.stdout.strip().splitlines() or [""])[0]


_LOCK = threading.Lock()
_MEMO: dict[str, str] = {}


def tool_identity(tool: str) -> str:
    """What the answers of a `tool` ("eva" or "wp") run depend on besides its inputs: the Frama-C
    version and package, and for WP the prover stack. Computed once per process."""
    with _LOCK:
        if tool in _MEMO:
            return _MEMO[tool]
    parts = [f"frama-c {_first_line(['frama-c', '-version'])}"]
    try:
        parts.append("frama-c-base " + _first_line(["dpkg-query", "-W", "-f", "${Version}", "frama-c-base"]))
    except CacheError:
        parts.append("frama-c-base unknown (not a Debian package)")
    if tool == "wp":
        parts += [_first_line(["why3", "--version"]), _first_line(["z3", "--version"]),
                  _first_line(["cvc4", "--version"])]
    identity = " / ".join(parts)
    with _LOCK:
        _MEMO[tool] = identity
    return identity


def folder_digest(folder: Path) -> str:
    """SHA-256 of every file's name and bytes in `folder` (WP's prover-answer cache). Computed once
    per process and folder: the caller uses it only when no prover adds entries (offline)."""
    name = f"folder {folder}"
    with _LOCK:
        if name in _MEMO:
            return _MEMO[name]
    h = hashlib.sha256()
    for f in sorted(p for p in folder.iterdir() if p.is_file()):
        h.update(b"\0" + f.name.encode() + b"\n" + f.read_bytes())
    digest = h.hexdigest()
    with _LOCK:
        _MEMO[name] = digest
    return digest


def share_libc() -> Path:
    """Frama-C's own libc headers (what it preprocesses with instead of the system's)."""
    with _LOCK:
        if "share" in _MEMO:
            return Path(_MEMO["share"]) / "libc"
    share = _first_line(["frama-c", "-print-share-path"])
    with _LOCK:
        _MEMO["share"] = share
    return Path(share) / "libc"


def cpp_options(cmd: list[str]) -> list[str]:
    """The preprocessor options of a frama-c command (its -cpp-extra-args)."""
    options: list[str] = []
    for arg in cmd:
        if arg.startswith("-cpp-extra-args="):
            options += shlex.split(arg.split("=", 1)[1])
    return options


def dependencies(cmd: list[str], cwd: Path, framac_libc: Path) -> list[Path]:
    """Every file the run reads: its .c files and the headers `cc -MM` finds with its options.
    Frama-C's own libc is a system directory here (not listed: the Frama-C version covers it)."""
    sources = [a for a in cmd[1:] if a.endswith(".c") and not a.startswith("-")]
    options = [a for a in cpp_options(cmd) if a.startswith(("-D", "-I", "-U")) and len(a) > 2]
    if not sources:
        raise CacheError("no .c file in the frama-c command")
    out = subprocess.run(["cc", "-MM", "-nostdinc", "-isystem", str(framac_libc), "-D__FRAMAC__", MACHDEP_DEFINE,
                          *options, *sources], cwd=cwd, capture_output=True, text=True)
    if out.returncode != 0:
        raise CacheError(f"`cc -MM` failed: {out.stderr.strip()[:400]}")
    files = {(cwd / token).resolve() for token in out.stdout.replace("\\\n", " ").split() if not token.endswith(":")}
    files.update((cwd / s).resolve() for s in sources)
    return sorted(files)


def run_key(cmd: list[str], repo: str, identity: str, files: list[Path], extra: str = "") -> str:
    """SHA-256 over the format, the tools, the arguments, `extra` (WP: its answer cache's digest) and
    each file's name and bytes (repository path normalised)."""
    return content_key(f"urb-framac-cache {FORMAT}\n{identity}\n{extra}\n", cmd, repo, files)


@dataclass
class Recorded:
    """A recorded run: Frama-C's output and the report files it wrote, repository path restored."""
    key: str
    log: str
    outputs: dict[str, str]  # file name (in the report folder) -> text
    cpu_s: float
    wall_s: float
    commit: str
    date: str
    path: Path


def entry_path(cache: Path, unit: str, key: str) -> Path:
    return cache / unit / f"{key}.json.gz"


def load(cache: Path, unit: str, key: str, repo: str) -> Recorded | None:
    """The recorded run of `key`, or None (none recorded, or an unreadable or older-format entry)."""
    path = entry_path(cache, unit, key)
    try:
        with gzip.open(path, "rt", encoding="utf-8") as fh:
            entry = json.load(fh)
    except (OSError, ValueError):
        return None
    if not isinstance(entry, dict) or entry.get("format") != FORMAT or entry.get("key") != key:
        return None
    outputs = {str(k): str(v).replace(REPO_TOKEN, repo) for k, v in dict(entry.get("outputs", {})).items()}
    return Recorded(key, str(entry.get("log", "")).replace(REPO_TOKEN, repo), outputs, float(entry.get("cpu_s", 0.0)),
                    float(entry.get("wall_s", 0.0)), str(entry.get("commit", "?")), str(entry.get("date", "?")), path)


def record(cache: Path, unit: str, label: str, key: str, repo: str, cmd: list[str], log: str,
           outputs: dict[str, str], cpu_s: float, wall_s: float) -> Path:
    """Writes the entry (gzip'd JSON, same bytes for the same entry: mtime 0, sorted keys)."""
    path = entry_path(cache, unit, key)
    entry = {"format": FORMAT, "key": key, "unit": unit, "label": label, "cpu_s": round(cpu_s, 2),
             "wall_s": round(wall_s, 2), "commit": git_commit(repo),
             "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
             "command": shlex.join(["frama-c", *(normalize(a, repo) for a in cmd[1:])]),
             "log": normalize(log, repo), "outputs": {k: normalize(v, repo) for k, v in sorted(outputs.items())}}
    write_entry(path, entry)
    return path


def spot_check_settings() -> tuple[int, str, float]:
    """FRAMAC_RESULT_CACHE_VERIFY (per mille), _SEED and _VERIFY_MAX_CPU (seconds)."""
    try:
        per_mille = int(os.environ.get(f"{ENV}_VERIFY", "0") or 0)
        max_cpu = float(os.environ.get(f"{ENV}_VERIFY_MAX_CPU", "30") or 30)
    except ValueError as e:
        raise CacheError(f"{ENV}_VERIFY must be an integer per mille and {ENV}_VERIFY_MAX_CPU seconds: {e}") from None
    return per_mille, os.environ.get(f"{ENV}_SEED", ""), max_cpu
