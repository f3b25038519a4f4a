"""Build the simulation's native library, build/sim/liburbsim.so.

One list of sources for every caller: `make sim-lib` (mk/sim.mk), the pytest fixtures of
tests/sim/ and `urb sim` all call `ensure_library()`, which recompiles only when a source or
header is newer than the library. The library holds the C core (sim/core), the simulation HALs
(firmware/hal/sim), the firmware under test (node library, SensoRHex apps, bridge) and the
generated codecs (gen/c), compiled for the host.

    python3 -m urb_sim.build            # build if stale, print the path
    python3 -m urb_sim.build --force    # rebuild
"""

from __future__ import annotations

import argparse
import hashlib
import io
import os
import shlex
import subprocess
import sys
import tarfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
BUILD = REPO / "build" / "sim"
LIBRARY = BUILD / "liburbsim.so"

#: Folders whose *.c files make up the library (missing folders are skipped: the firmware lands
#: in stages), and folders searched for headers.
SOURCE_DIRS = [
    "sim/core",
    "sim/world",
    "firmware/hal/sim",
    "firmware/node",
    "firmware/bridge",
    "firmware/apps/sensorhex",
    "gen/c",
]
INCLUDE_DIRS = ["sim/core", "sim/world", "firmware/include", "firmware/hal/sim", "firmware/node", "firmware/bridge",
                "firmware/apps/sensorhex", "gen/c"]
#: Files the simulation does not link: programs (`*main.c`, e.g. firmware/bridge/hosted_main.c)
#: and the single-node adapter of the paper's global-function style (firmware/node/urb_single.c:
#: one global node, calls app_* functions), which cannot serve many nodes in one process.
EXCLUDE_SUFFIX = "main.c"
EXCLUDE_NAMES = {"urb_single.c"}

#: Folders the simulation compiles but does not own. By default they come from the working tree, so
#: the simulation runs the firmware as you edit it. URBSIM_SOURCES=head builds from their COMMITTED
#: versions instead (exported to build/sim/snapshot/): useful when several people share one working
#: tree and a file half-way through an edit must not break a long simulation run.
FOREIGN_DIRS = ["firmware/include", "firmware/node", "firmware/bridge", "firmware/apps/sensorhex", "gen/c"]

CC = os.environ.get("CC", "gcc")
#: -flto lets the compiler inline the core's small functions (event scheduling, clock conversions)
#: into the HALs and the firmware callbacks that call them hundreds of thousands of times per
#: simulated second; -fno-semantic-interposition lets it do so for the library's exported symbols
#: too (nothing interposes them). Together ~15 % faster, same results: -ffp-contract=off keeps
#: every floating-point operation as written, whatever gets inlined where.
CFLAGS = ["-std=c99", "-O3", "-ffp-contract=off", "-flto=auto", "-fno-semantic-interposition", "-g", "-fPIC",
          "-Wall", "-Wextra", "-Werror", "-fvisibility=default"]


class BuildError(RuntimeError):
    """The compiler failed; the message holds its command line and output."""


def _git(*args: str) -> str | None:
    try:
        proc = subprocess.run(["git", *args], cwd=REPO, capture_output=True, text=True, check=False)
    except OSError:
        return None
    return proc.stdout.strip() if proc.returncode == 0 else None


def _snapshot() -> tuple[Path, str] | None:
    """Export the committed versions of FOREIGN_DIRS into build/sim/snapshot/<key>/; returns the
    folder and its key (the git tree ids); None (build from the working tree) unless
    URBSIM_SOURCES=head, or outside git."""
    if os.environ.get("URBSIM_SOURCES") != "head":
        return None
    trees = []
    for d in FOREIGN_DIRS:
        tid = _git("rev-parse", f"HEAD:{d}")
        trees.append((d, tid))
    if all(t is None for _, t in trees) or _git("rev-parse", "HEAD") is None:
        return None
    key = hashlib.sha256(repr(trees).encode()).hexdigest()[:16]
    dest = BUILD / "snapshot" / key
    if not (dest / ".complete").exists():
        dest.mkdir(parents=True, exist_ok=True)
        present = [d for d, t in trees if t is not None]
        archive = subprocess.run(["git", "archive", "--format=tar", "HEAD", "--", *present], cwd=REPO,
                                 capture_output=True, check=True).stdout
        with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
            tar.extractall(dest, filter="data")
        (dest / ".complete").write_text(repr(trees))
    return dest, key


def _root_of(d: str, snap: tuple[Path, str] | None) -> Path:
    return snap[0] if snap is not None and d in FOREIGN_DIRS else REPO


def sources(snap: tuple[Path, str] | None = None) -> list[Path]:
    """Every C file compiled into the library, in a stable order."""
    out: list[Path] = []
    for d in SOURCE_DIRS:
        folder = _root_of(d, snap) / d
        if folder.is_dir():
            out.extend(p for p in sorted(folder.glob("*.c"))
                       if not p.name.endswith(EXCLUDE_SUFFIX) and p.name not in EXCLUDE_NAMES)
    return out


def _includes(snap: tuple[Path, str] | None) -> list[Path]:
    return [_root_of(d, snap) / d for d in INCLUDE_DIRS]


def _own_inputs() -> list[Path]:
    files: list[Path] = []
    for d in SOURCE_DIRS + INCLUDE_DIRS:
        if d in FOREIGN_DIRS:
            continue
        folder = REPO / d
        if folder.is_dir():
            files.extend(sorted(folder.glob("*.[ch]")))
    files.append(Path(__file__))
    return files


def _stamp_text(snap: tuple[Path, str] | None) -> str:
    return f"sources={snap[1] if snap else 'worktree'}\n"


def is_stale(lib: Path = LIBRARY, snap: tuple[Path, str] | None = None) -> bool:
    """True when the library is missing, was built from other committed firmware, or is older than
    any of the simulation's own sources (or, building from the working tree, any source)."""
    stamp = lib.with_suffix(".stamp")
    if not lib.exists() or not stamp.exists() or stamp.read_text() != _stamp_text(snap):
        return True
    built = lib.stat().st_mtime
    inputs = _own_inputs()
    if snap is None:
        for d in FOREIGN_DIRS:
            folder = REPO / d
            if folder.is_dir():
                inputs.extend(folder.glob("*.[ch]"))
    return any(p.stat().st_mtime > built for p in inputs)


def compile_command(out: Path, extra: list[str] | None = None, snap: tuple[Path, str] | None = None) -> list[str]:
    """The compiler command line that builds `out`."""
    incs = [f"-I{p}" for p in _includes(snap)]
    # --no-undefined: a missing source (or a stray adapter) fails here, naming the symbol, instead
    # of when Python loads the library.
    return [CC, *CFLAGS, *(extra or []), "-shared", "-Wl,--no-undefined", *incs, *map(str, sources(snap)), "-lm",
            "-o", str(out)]


def ensure_library(force: bool = False) -> Path:
    """Build build/sim/liburbsim.so when stale (or when `force`); return its path.

    Raises BuildError with the compiler output when compilation fails."""
    BUILD.mkdir(parents=True, exist_ok=True)
    snap = _snapshot()
    if not force and not is_stale(snap=snap):
        return LIBRARY
    tmp = LIBRARY.with_suffix(f".so.tmp{os.getpid()}")
    cmd = compile_command(tmp, snap=snap)
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=REPO)
    if proc.returncode != 0:
        tmp.unlink(missing_ok=True)
        raise BuildError(
            "building the simulation library failed:\n  " + shlex.join(cmd) + "\n" + proc.stdout + proc.stderr
            + "\nFix the error above (or run `make sim-lib` to see it again)."
        )
    tmp.replace(LIBRARY)  # atomic: concurrent test workers never load a half-written library
    LIBRARY.with_suffix(".stamp").write_text(_stamp_text(snap))
    return LIBRARY


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python3 -m urb_sim.build", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--force", action="store_true", help="rebuild even when up to date")
    args = parser.parse_args(argv)
    try:
        print(ensure_library(force=args.force))
    except BuildError as exc:
        print(exc, file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
