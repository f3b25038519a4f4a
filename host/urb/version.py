"""What `urb --version` says: the package version, the commit it was run from, and the schema
layout fingerprint of the codecs it carries; the provenance a report or a bug report needs.

The commit is read from git only when this package is the `host/urb` of a git checkout (an
editable install, or `python3 -m urb` in the tree); an installed copy that happens to sit inside
some other checkout (a virtual environment in a clone) says "unknown commit" rather than name a
commit it was not built from.

The schema layout fingerprint hashes, with the codegen's own `fingerprint_of` (the first four
bytes of SHA-256, little-endian), the canonical layout text of every message and every node type
of the bundled schemas (`urb_msgs`), sorted by name: two hosts with the same fingerprint put the
same bits on the wire.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import urb_msgs
from urb_codegen.model import fingerprint_of

from . import __version__

PACKAGE_DIR = Path(__file__).resolve().parent
PACKAGE_IN_CHECKOUT = Path("host") / "urb"
"""Where this package lives in the repository."""


def _git(cwd: Path, *args: str) -> str | None:
    """git's output, or None when git is missing or fails."""
    try:
        proc = subprocess.run(["git", "-C", str(cwd), *args], capture_output=True, text=True, timeout=10, check=False)
    except (OSError, subprocess.SubprocessError):
        return None
    return proc.stdout.strip() if proc.returncode == 0 else None


def source_commit(package_dir: Path = PACKAGE_DIR) -> tuple[str, bool] | None:
    """(commit, whether the tree has uncommitted changes) of the checkout this package is the
    `host/urb` of; None when it is not one (an installed copy, no git)."""
    top = _git(package_dir, "rev-parse", "--show-toplevel")
    if top is None:
        return None
    expected = Path(top) / PACKAGE_IN_CHECKOUT
    try:
        if not expected.is_dir() or not expected.samefile(package_dir):
            return None
    except OSError:
        return None
    commit = _git(package_dir, "rev-parse", "HEAD")
    if not commit:
        return None
    status = _git(Path(top), "status", "--porcelain")
    return commit, bool(status)


def schema_layout_text() -> str:
    """The canonical layout of every bundled message and node type, sorted by name."""
    messages = [urb_msgs.MESSAGES[name].LAYOUT for name in sorted(urb_msgs.MESSAGES)]
    nodes = [urb_msgs.NODES[name].layout for name in sorted(urb_msgs.NODES)]
    return "".join(messages + nodes)


def schema_layout_fingerprint() -> int:
    """The fingerprint of `schema_layout_text()`."""
    return fingerprint_of(schema_layout_text())


def version_text(package_dir: Path = PACKAGE_DIR) -> str:
    """e.g. 'urb 0.1.0, commit 519dc6a... (with uncommitted changes), schema layout fingerprint 1a2b3c4d'."""
    found = source_commit(package_dir)
    if found is None:
        commit = "unknown commit (not run from a git checkout)"
    else:
        commit = f"commit {found[0]}" + (" (with uncommitted changes)" if found[1] else "")
    return f"urb {__version__}, {commit}, schema layout fingerprint {schema_layout_fingerprint():08x}"
