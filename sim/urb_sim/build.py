"""Build the simulation's native library, build/sim/liburbsim.so.

One list of sources for every caller: `make sim-lib` (mk/sim.mk), the pytest fixtures of
tests/sim/ and `urb sim` all call `ensure_library()`, which recompiles only when a source or
header is newer than the library. The library holds the C core (sim/core), the simulation HALs
(firmware/hal/sim), the firmware under test (node library, SensoRHex apps, bridge), the
downlink models' CAN and RS485 ports (sim/downlink: their bridges' masters and their nodes, which run
the same node library and application objects as the I2C world's nodes), the generated codecs
(gen/c) and the C host library's sans-IO core (host/c/core, driven by sim/world/sim_host_c.c),
compiled for the host.

    python3 -m urb_sim.build            # build if stale, print the path
    python3 -m urb_sim.build --force    # rebuild

Two environment variables select another build of the same sources, in its own folder, so that
it never replaces the normal library:
    URBSIM_SANITIZE=1   AddressSanitizer and UndefinedBehaviorSanitizer, stopping at the first
                        error (build/sim/san/). The process must preload the sanitizer runtimes:
                        LD_PRELOAD="$(python3 -m urb_sim.build --preload)" (tools/sim_sanitized.py
                        does all of this).
    URBSIM_MUTANT=NAME  compiled with -DURBSIM_MUTANT_NAME and -DURB_MUTANT_NAME: a seeded bug of the
                        simulation or of the firmware, for showing that a check catches it
                        (build/sim/mutant-NAME/, or build/sim/san-mutant-NAME/).
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
    "firmware/downlink/can",
    "firmware/downlink/rs485",
    "sim/downlink",
    "gen/c",
    "host/c/core",
]
INCLUDE_DIRS = ["sim/core", "sim/world", "firmware/include", "firmware/hal/sim", "firmware/node", "firmware/bridge",
                "firmware/apps/sensorhex", "sim/downlink", "gen/c",
                "host/c/include", "host/c/core"]
#: Files the simulation does not link: programs (`*main.c`, e.g. firmware/bridge/hosted_main.c)
#: and the single-node adapter of the paper's global-function style (firmware/node/urb_single.c: one
#: global node, calls app_* functions), which cannot serve many nodes in one process. The node library's
#: CAN and RS485 adapters (firmware/node/urb_node_can.c, urb_node_rs485.c) link the downlink cores,
#: hence firmware/downlink in SOURCE_DIRS; sim/downlink's nodes use them.
EXCLUDE_SUFFIX = "main.c"
EXCLUDE_NAMES = {"urb_single.c"}

#: Folders the simulation compiles but does not own. By default they come from the working tree, so
#: the simulation runs the firmware as you edit it. URBSIM_SOURCES=head builds from their COMMITTED
#: versions instead (exported to build/sim/snapshot/): useful when several people share one working
#: tree and a file half-way through an edit must not break a long simulation run.
FOREIGN_DIRS = ["firmware/include", "firmware/node", "firmware/bridge", "firmware/apps/sensorhex",
                "firmware/downlink/can", "firmware/downlink/rs485", "gen/c", "host/c/core", "host/c/include"]

CC = os.environ.get("CC", "gcc")
#: -flto lets the compiler inline the core's small functions (event scheduling, clock conversions)
#: into the HALs and the firmware callbacks that call them hundreds of thousands of times per
#: simulated second; -fno-semantic-interposition lets it do so for the library's exported symbols
#: too (nothing interposes them). Together ~15 % faster, same results: -ffp-contract=off keeps
#: every floating-point operation as written, whatever gets inlined where.
CFLAGS = ["-std=c99", "-O3", "-ffp-contract=off", "-flto=auto", "-fno-semantic-interposition", "-g", "-fPIC",
          "-Wall", "-Wextra", "-Werror", "-fvisibility=default"]


#: URBSIM_SANITIZE=1 builds with these in place of the optimisation flags: every memory error and
#: every undefined behaviour stops the process with a report (slower; results are the same).
SANITIZE_FLAGS = ["-O1", "-fno-omit-frame-pointer", "-fsanitize=address,undefined", "-fno-sanitize-recover=all"]
SPEED_FLAGS = {"-O3", "-flto=auto", "-fno-semantic-interposition"}


class BuildError(RuntimeError):
    """The compiler failed; the message holds its command line and output."""


def variant() -> tuple[bool, str | None]:
    """(sanitized, mutant name) asked for by URBSIM_SANITIZE and URBSIM_MUTANT."""
    sanitize = os.environ.get("URBSIM_SANITIZE", "") not in ("", "0")
    mutant = os.environ.get("URBSIM_MUTANT") or None
    if mutant is not None and not mutant.replace("_", "").isalnum():
        raise BuildError(f"URBSIM_MUTANT={mutant!r}: expected a name such as LOG_WRAP (letters, digits, _)")
    return sanitize, mutant


def library_path() -> Path:
    """Where the library of the build variant selected by the environment lives."""
    sanitize, mutant = variant()
    if not sanitize and mutant is None:
        return LIBRARY
    folder = "-".join((["san"] if sanitize else []) + ([f"mutant-{mutant}"] if mutant else []))
    return BUILD / folder / LIBRARY.name


def variant_flags() -> list[str]:
    """Compiler flags of the selected variant, in place of CFLAGS."""
    sanitize, mutant = variant()
    flags = [f for f in CFLAGS if not (sanitize and f in SPEED_FLAGS)]
    if sanitize:
        flags += SANITIZE_FLAGS
    if mutant is not None:
        # the simulation's seeded bugs are URBSIM_MUTANT_*, the firmware's URB_MUTANT_* (e.g. urb_node_dl.c's
        # NODE_DL_FRONT_BUFFER): no name is both, so one switch selects either
        flags += [f"-DURBSIM_MUTANT_{mutant}", f"-DURB_MUTANT_{mutant}"]
    return flags


def unpreloaded_env() -> dict[str, str]:
    """This process's environment without LD_PRELOAD, for the programs it starts (the compiler,
    TLC's JVM): a process running the sanitized library has the sanitizer runtimes preloaded, and
    they are not meant to run under them."""
    return {k: v for k, v in os.environ.items() if k != "LD_PRELOAD"}


def sanitizer_preload() -> str:
    """The LD_PRELOAD value a process needs before it loads a sanitized library: the runtimes must
    come first in the process, and Python is not built with them."""
    names = []
    for runtime in ("libasan.so", "libubsan.so"):
        proc = subprocess.run([CC, f"-print-file-name={runtime}"], capture_output=True, text=True, check=False,
                              env=unpreloaded_env())
        found = proc.stdout.strip()
        if proc.returncode != 0 or not os.path.isabs(found):
            raise BuildError(f"{CC} has no {runtime}: install the compiler's sanitizer runtimes "
                             "(Debian: libasan8 libubsan1, pulled in by gcc)")
        names.append(found)
    return ":".join(names)


def check_loadable() -> None:
    """Raise BuildError unless this process can load the selected library: a sanitized one needs
    the runtimes preloaded, or ASan ends the whole process from inside ctypes.CDLL."""
    if variant()[0] and "libasan" not in os.environ.get("LD_PRELOAD", ""):
        raise BuildError("URBSIM_SANITIZE=1 needs the sanitizer runtimes preloaded: run with "
                         'LD_PRELOAD="$(python3 -m urb_sim.build --preload)", or use tools/sim_sanitized.py')


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
            if hasattr(tarfile, "data_filter"):  # Python >= 3.11.4; Debian 12's 3.11.2 has no filters
                tar.extractall(dest, filter="data")
            else:  # our own `git archive` of HEAD: regular files and folders under the listed paths
                tar.extractall(dest)
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
    return f"sources={snap[1] if snap else 'worktree'}\nflags={' '.join(variant_flags())}\n"


def is_stale(lib: Path | None = None, snap: tuple[Path, str] | None = None) -> bool:
    """True when the library is missing, was built from other committed firmware, or is older than
    any of the simulation's own sources (or, building from the working tree, any source)."""
    lib = lib or library_path()
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
    return [CC, *variant_flags(), *(extra or []), "-shared", "-Wl,--no-undefined", *incs, *map(str, sources(snap)), "-lm",
            "-o", str(out)]


def ensure_library(force: bool = False) -> Path:
    """Build build/sim/liburbsim.so (or the variant the environment selects) when stale (or when
    `force`); return its path.

    Raises BuildError with the compiler output when compilation fails."""
    library = library_path()
    library.parent.mkdir(parents=True, exist_ok=True)
    snap = _snapshot()
    if not force and not is_stale(library, snap=snap):
        return library
    tmp = library.with_suffix(f".so.tmp{os.getpid()}")
    cmd = compile_command(tmp, snap=snap)
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=REPO, env=unpreloaded_env())
    if proc.returncode != 0:
        tmp.unlink(missing_ok=True)
        raise BuildError(
            "building the simulation library failed:\n  " + shlex.join(cmd) + "\n" + proc.stdout + proc.stderr
            + "\nFix the error above (or run `make sim-lib` to see it again)."
        )
    tmp.replace(library)  # atomic: concurrent test workers never load a half-written library
    library.with_suffix(".stamp").write_text(_stamp_text(snap))
    return library


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python3 -m urb_sim.build", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--force", action="store_true", help="rebuild even when up to date")
    parser.add_argument("--preload", action="store_true",
                        help="print the LD_PRELOAD value a sanitized library needs, and build nothing")
    args = parser.parse_args(argv)
    try:
        print(sanitizer_preload() if args.preload else ensure_library(force=args.force))
    except BuildError as exc:
        print(exc, file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
