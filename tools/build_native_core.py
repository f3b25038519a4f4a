"""Build urb.managers._native, the Python host library's protocol cores on host/c/core (`make host-c-py`).

    python3 tools/build_native_core.py           # build if the module is missing or its sources changed
    python3 tools/build_native_core.py --force   # rebuild

Compiles the glue host/urb/managers/_native.c (and _native_attrs.c), its cycle state _native_cycle.c
(urb.cycle's requests submitted at once), its pumps _native_pump.c and _native_pump_rs232.c (the
uplink's I/O on a C thread), the C protocol core host/c/core/*.c, the port hand-over record host/c/port/handover.c and
the generated codecs it uses (gen/c, the same sources as build/host_c/liburbhost.a; strict warnings,
-Werror, -O2 -flto so the core inlines into its entry points) into
host/urb/managers/_native<EXT_SUFFIX> for the interpreter running this. The module carries the
digest of its sources (`urb.managers.native.source_fingerprint`): the library refuses a module
built from other sources and runs the Python cores instead, saying why (`native.REASON`).
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

REPO = Path(__file__).resolve().parents[1]
OUT_DIR = REPO / "host" / "urb" / "managers"
CC = os.environ.get("CC", "gcc")
CFLAGS = ["-std=c11", "-O2", "-flto", "-fPIC", "-shared", "-fvisibility=hidden", "-Wall", "-Wextra", "-Werror",
          "-Wno-missing-field-initializers", "-D_DEFAULT_SOURCE", "-D_GNU_SOURCE", "-pthread"]  # PyVarObject_HEAD_INIT leaves members out
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
    suffix = sysconfig.get_config_var("EXT_SUFFIX")
    if not isinstance(suffix, str):
        raise RuntimeError("this interpreter reports no EXT_SUFFIX for extension modules")
    return OUT_DIR / ("_native" + suffix)


def sources() -> list[Path]:
    return [OUT_DIR / "_native.c", OUT_DIR / "_native_attrs.c", OUT_DIR / "_native_pump.c", OUT_DIR / "_native_pump_rs232.c",
            OUT_DIR / "_native_cycle.c",
            *sorted((REPO / "host" / "c" / "core").glob("*.c")),
            REPO / "host" / "c" / "port" / "handover.c", *(REPO / "gen" / "c" / name for name in GEN_SOURCES)]


def compile_command(srcs: list[Path], out: Path, digest: str) -> list[str]:
    """The compiler command that builds the module `out` from `srcs` (the glue first)."""
    include = sysconfig.get_paths()["include"]
    if not (Path(include) / "Python.h").exists():
        raise RuntimeError(f"no Python.h in {include}: install the interpreter's headers (Debian: python3-dev, "
                           "which `make setup` installs)")
    return [CC, *CFLAGS, f'-DURB_NATIVE_FINGERPRINT="{digest}"', "-I", include,
            "-I", str(OUT_DIR), "-I", str(REPO / "host" / "c" / "include"), "-I", str(REPO / "host" / "c" / "core"),
            "-I", str(REPO / "gen" / "c"), *map(str, srcs), "-o", str(out)]


def build(force: bool = False) -> Path:
    out = module_path()
    digest = fingerprint()
    stamp = out.with_suffix(".fingerprint")
    if not force and out.exists() and stamp.exists() and stamp.read_text() == digest:
        return out
    with tempfile.TemporaryDirectory(prefix="urb-native-", dir=OUT_DIR) as tmp:
        partial = Path(tmp) / out.name
        cmd = compile_command(sources(), partial, digest)
        done = subprocess.run(cmd, capture_output=True, text=True, check=False)
        if done.returncode != 0:
            raise RuntimeError(f"building urb.managers._native failed:\n{shlex.join(cmd)}\n{done.stdout}{done.stderr}")
        partial.replace(out)  # atomic: a process importing meanwhile sees the old or the new module
    stamp.write_text(digest)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    ap.add_argument("--force", action="store_true", help="rebuild even when up to date")
    args = ap.parse_args(argv)
    try:
        out = build(args.force)
    except RuntimeError as exc:
        print(f"build_native_core: {exc}", file=sys.stderr)
        return 1
    print(out.relative_to(REPO))
    return 0


if __name__ == "__main__":
    sys.exit(main())
