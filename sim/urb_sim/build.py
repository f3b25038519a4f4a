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
import os
import shlex
import subprocess
import sys
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

CC = os.environ.get("CC", "gcc")
CFLAGS = ["-std=c99", "-O2", "-g", "-fPIC", "-Wall", "-Wextra", "-Werror", "-fvisibility=default"]


class BuildError(RuntimeError):
    """The compiler failed; the message holds its command line and output."""


def sources() -> list[Path]:
    """Every C file compiled into the library, in a stable order."""
    out: list[Path] = []
    for d in SOURCE_DIRS:
        folder = REPO / d
        if folder.is_dir():
            out.extend(p for p in sorted(folder.glob("*.c"))
                       if not p.name.endswith(EXCLUDE_SUFFIX) and p.name not in EXCLUDE_NAMES)
    return out


def _inputs() -> list[Path]:
    files = sources()
    for d in INCLUDE_DIRS:
        folder = REPO / d
        if folder.is_dir():
            files.extend(sorted(folder.glob("*.h")))
    files.append(Path(__file__))
    return files


def is_stale(lib: Path = LIBRARY) -> bool:
    """True when the library is missing or older than any source, header or this script."""
    if not lib.exists():
        return True
    built = lib.stat().st_mtime
    return any(p.stat().st_mtime > built for p in _inputs())


def compile_command(out: Path, extra: list[str] | None = None) -> list[str]:
    """The compiler command line that builds `out`."""
    incs = [f"-I{REPO / d}" for d in INCLUDE_DIRS]
    # --no-undefined: a missing source (or a stray adapter) fails here, naming the symbol, instead
    # of when Python loads the library.
    return [CC, *CFLAGS, *(extra or []), "-shared", "-Wl,--no-undefined", *incs, *map(str, sources()), "-lm",
            "-o", str(out)]


def ensure_library(force: bool = False) -> Path:
    """Build build/sim/liburbsim.so when stale (or when `force`); return its path.

    Raises BuildError with the compiler output when compilation fails."""
    if not force and not is_stale():
        return LIBRARY
    BUILD.mkdir(parents=True, exist_ok=True)
    tmp = LIBRARY.with_suffix(f".so.tmp{os.getpid()}")
    cmd = compile_command(tmp)
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=REPO)
    if proc.returncode != 0:
        tmp.unlink(missing_ok=True)
        raise BuildError(
            "building the simulation library failed:\n  " + shlex.join(cmd) + "\n" + proc.stdout + proc.stderr
            + "\nFix the error above (or run `make sim-lib` to see it again)."
        )
    tmp.replace(LIBRARY)  # atomic: concurrent test workers never load a half-written library
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
