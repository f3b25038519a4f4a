"""Build urb.managers._native, the Python host library's protocol cores on host/c/core (`make host-c-py`).

    python3 tools/build_native_core.py           # build if the module is missing or its sources changed
    python3 tools/build_native_core.py --force   # rebuild

Compiles the glue host/urb/managers/_native.c (and _native_attrs.c, _native_xfer.c), its cycle state _native_cycle.c
(urb.cycle's requests submitted at once), its pumps _native_pump.c and _native_pump_rs232.c (the
uplink's I/O on a C thread), the C protocol core host/c/core/*.c, the port hand-over record host/c/port/handover.c and
the generated codecs it uses (gen/c, the same sources as build/host_c/liburbhost.a; strict warnings,
-Werror, -O2 -flto so the core inlines into its entry points) into
host/urb/managers/_native<EXT_SUFFIX> for the interpreter running this. The module carries the
digest of its sources (`urb.managers.native.source_fingerprint`): the library refuses a module
built from other sources and runs the Python cores instead, saying why (`native.REASON`).
The flags, the atomic compile step and the command line are urb_codegen.ext_build's (shared with
`make accel`).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from urb_codegen.ext_build import CFLAGS as EXT_CFLAGS
from urb_codegen.ext_build import compile_module, compiler, main as builder_main, python_include
from urb_codegen.ext_build import module_path as ext_module_path

REPO = Path(__file__).resolve().parents[1]
OUT_DIR = REPO / "host" / "urb" / "managers"
CFLAGS = [*EXT_CFLAGS, "-D_DEFAULT_SOURCE", "-D_GNU_SOURCE", "-pthread"]  # the pumps' threads and eventfd
GEN_SOURCES = ("urb_core.c", "urb_runtime.c", "urb_sensorhex.c")


def fingerprint() -> str:
    sys.path.insert(0, str(REPO / "host"))
    try:
        os.environ["URB_PURE_PYTHON"] = "1"  # the fingerprint only: do not load a stale module meanwhile
        from urb.managers.native import source_fingerprint
    finally:
        sys.path.pop(0)
    digest = source_fingerprint(REPO)
    assert digest is not None
    return digest


def module_path() -> Path:
    return ext_module_path(OUT_DIR, "_native")


def sources() -> list[Path]:
    return [OUT_DIR / "_native.c", OUT_DIR / "_native_attrs.c", OUT_DIR / "_native_xfer.c", OUT_DIR / "_native_pump.c",
            OUT_DIR / "_native_pump_rs232.c", OUT_DIR / "_native_cycle.c",
            *sorted((REPO / "host" / "c" / "core").glob("*.c")),
            REPO / "host" / "c" / "port" / "handover.c", *(REPO / "gen" / "c" / name for name in GEN_SOURCES)]


def compile_command(srcs: list[Path], out: Path, digest: str) -> list[str]:
    """The compiler command that builds the module `out` from `srcs` (the glue first)."""
    include = python_include()
    return [compiler(), *CFLAGS, f'-DURB_NATIVE_FINGERPRINT="{digest}"', "-I", include,
            "-I", str(OUT_DIR), "-I", str(REPO / "host" / "c" / "include"), "-I", str(REPO / "host" / "c" / "core"),
            "-I", str(REPO / "gen" / "c"), *map(str, srcs), "-o", str(out)]


def build(force: bool = False) -> Path:
    out = module_path()
    digest = fingerprint()
    stamp = out.with_suffix(".fingerprint")
    if not force and out.exists() and stamp.exists() and stamp.read_text() == digest:
        return out
    compile_module(out, "urb.managers._native", lambda partial: compile_command(sources(), partial, digest))
    stamp.write_text(digest)
    return out


def main(argv: list[str] | None = None) -> int:
    return builder_main("build_native_core", __doc__, build, REPO, argv)


if __name__ == "__main__":
    sys.exit(main())
