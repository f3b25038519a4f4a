"""Build urb_msgs._accel, the accelerated codecs of the Python message classes (`make accel`).

    python3 -m urb_codegen.build_accel           # build if a source is newer than the module; print its path
    python3 -m urb_codegen.build_accel --force   # rebuild

Compiles the generated glue gen/python/urb_msgs/_accel.c with the generated C codecs gen/c/*.c (the
same sources the firmware links, strict warnings, -Werror) into gen/python/urb_msgs/_accel<EXT_SUFFIX>,
the extension module of the interpreter running this (its EXT_SUFFIX and include folder from
sysconfig; Debian's python3-dev provides the headers, tools/setup.sh installs it). -flto lets the
compiler inline the codecs into their Python entry points. The module is a build product: git and
`urb gen --check` ignore it, and urb_msgs._codec refuses one built from other generated sources.
The flags, the atomic compile step and the command line are urb_codegen.ext_build's (shared with
`make host-c-py`).
"""

from __future__ import annotations

import sys
from pathlib import Path

from urb_codegen.ext_build import CFLAGS, BuildError, compile_module, compiler, main as builder_main, python_include
from urb_codegen.ext_build import module_path as ext_module_path

REPO = Path(__file__).resolve().parents[2]
C_DIR = REPO / "gen" / "c"
PY_DIR = REPO / "gen" / "python" / "urb_msgs"
SOURCE = PY_DIR / "_accel.c"

def module_path() -> Path:
    return ext_module_path(PY_DIR, "_accel")


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
    include = python_include()
    return compile_module(out, "urb_msgs._accel", lambda partial: [
        compiler(), *CFLAGS, "-I", include, "-I", str(C_DIR), *map(str, sources()), "-o", str(partial)])


def main(argv: list[str] | None = None) -> int:
    return builder_main("build_accel", __doc__, build, REPO, argv)


if __name__ == "__main__":
    sys.exit(main())
