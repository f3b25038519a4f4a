"""What the ESBMC and Frama-C result caches share (proofs/bmc/bmc_cache.py, tools/framac_cache.py).

A run's key is the SHA-256 of a header naming the cache, its format and the tools, then the
argument list and each file the run reads (name and bytes), with the repository's path replaced by
`<repo>` everywhere so that every clone of a commit has the same keys. Entries are gzip'd JSON with
sorted keys and gzip mtime 0, so recording an unchanged run again writes the same bytes."""

from __future__ import annotations

import gzip
import hashlib
import json
import os
import subprocess
import tempfile
from pathlib import Path
from typing import Any

REPO_TOKEN = "<repo>"


def normalize(text: str, repo: str) -> str:
    """`text` with the repository's path written as <repo>."""
    return text.replace(repo, REPO_TOKEN)


def content_key(header: str, args: list[str], repo: str, files: list[Path]) -> str:
    """SHA-256 over `header`, the arguments after the program name and each file's name and bytes
    (repository path normalised in all of them)."""
    h = hashlib.sha256()
    h.update(header.encode())
    h.update(json.dumps([normalize(a, repo) for a in args[1:]]).encode())
    for f in files:
        h.update(b"\0file " + normalize(str(f), repo).encode() + b"\n")
        h.update(f.read_bytes().replace(repo.encode(), REPO_TOKEN.encode()))
    return h.hexdigest()


def git_commit(repo: str) -> str:
    """The commit a run is recorded on (`-dirty` with uncommitted changes), or "unknown"."""
    out = subprocess.run(["git", "-C", repo, "describe", "--always", "--dirty", "--abbrev=12"],
                         capture_output=True, text=True)
    return out.stdout.strip() if out.returncode == 0 else "unknown"


def spot_checked(key: str, seed: str, per_mille: int) -> bool:
    """Whether the seeded draw re-runs this key for real (per_mille of the keys; make check seeds it
    with the commit, so each commit checks another sample)."""
    return per_mille > 0 and int(hashlib.sha256(f"{seed}:{key}".encode()).hexdigest()[:8], 16) % 1000 < per_mille


def write_entry(path: Path, entry: dict[str, Any]) -> None:
    """Writes `entry` atomically (parallel runs record at once) as gzip'd JSON with stable bytes."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-")
    with os.fdopen(fd, "wb") as raw, gzip.GzipFile(fileobj=raw, mode="wb", mtime=0) as fh:
        fh.write(json.dumps(entry, indent=1, sort_keys=True).encode("utf-8"))
    os.chmod(tmp, 0o644)  # mkstemp's 0600 would differ from the checkout's files
    os.replace(tmp, path)
