"""Build urb_msgs._accel, the accelerated codecs of the Python message classes (`make accel`).

    python3 -m urb_codegen.build_accel           # build if a source is newer than the module; print its path
    python3 -m urb_codegen.build_accel --force   # rebuild

Compiles the generated glue gen/python/urb_msgs/_accel.c with the generated C codecs gen/c/*.c (the
same sources the firmware links, strict warnings, -Werror) into gen/python/urb_msgs/_accel<EXT_SUFFIX>,
the extension module of the interpreter running this (its EXT_SUFFIX and include folder from
sysconfig; Debian's python3-dev provides the headers, tools/setup.sh installs it). -flto lets the
compiler inline the codecs into their Python entry points. The module is a build product: git and
`urb gen --check` ignore it, and urb_msgs._codec refuses one built from other generated sources.
"""

from __future__ import annotations

import argparse
import os
import shlex
import subprocess
import sys
import sysconfig
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
C_DIR = REPO / "gen" / "c"
PY_DIR = REPO / "gen" / "python" / "urb_msgs"
SOURCE = PY_DIR / "_accel.c"
CC = os.environ.get("CC", "gcc")
CFLAGS = ["-std=c11", "-O2", "-flto", "-fPIC", "-shared", "-fvisibility=hidden", "-Wall", "-Wextra", "-Werror",
          "-Wno-missing-field-initializers"]  # PyVarObject_HEAD_INIT and PyModuleDef_HEAD_INIT leave members out


class BuildError(RuntimeError):
    """The compiler failed, or the interpreter has no headers; the message says what to do."""


def module_path() -> Path:
    suffix = sysconfig.get_config_var("EXT_SUFFIX")
    if not isinstance(suffix, str):
        raise BuildError("this interpreter reports no EXT_SUFFIX for extension modules")
    return PY_DIR / ("_accel" + suffix)


def sources() -> list[Path]:
    """What the module is compiled from: the glue and the codecs (test support excluded)."""
    return [SOURCE, *sorted(C_DIR.glob("*.c"))]


def stale(out: Path) -> bool:
    if not out.exists():
        return True
    built = out.stat().st_mtime
    inputs = [*sources(), *C_DIR.glob("*.h"), Path(__file__)]
    return any(p.stat().st_mtime > built for p in inputs)


def build(force: bool = False) -> Path:
    """The module, compiled first when it is missing or older than a source."""
    out = module_path()
    if not force and not stale(out):
        return out
    if not SOURCE.exists():
        raise BuildError(f"{SOURCE.relative_to(REPO)} is missing: run `urb gen`")
    include = sysconfig.get_paths()["include"]
    if not (Path(include) / "Python.h").exists():
        raise BuildError(f"no Python.h in {include}: install the interpreter's headers (Debian: python3-dev, "
                         "which `make setup` installs)")
    with tempfile.TemporaryDirectory(prefix="urb-accel-", dir=PY_DIR) as tmp:
        partial = Path(tmp) / out.name
        cmd = [CC, *CFLAGS, "-I", include, "-I", str(C_DIR), *map(str, sources()), "-o", str(partial)]
        done = subprocess.run(cmd, capture_output=True, text=True, check=False)
        if done.returncode != 0:
            raise BuildError(f"building urb_msgs._accel failed:\n{shlex.join(cmd)}\n{done.stdout}{done.stderr}")
        partial.replace(out)  # atomic: a process importing meanwhile sees the old or the new module
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    ap.add_argument("--force", action="store_true", help="rebuild even when up to date")
    args = ap.parse_args(argv)
    try:
        out = build(args.force)
    except BuildError as exc:
        print(f"build_accel: {exc}", file=sys.stderr)
        return 1
    print(out.relative_to(REPO))
    return 0


if __name__ == "__main__":
    sys.exit(main())
