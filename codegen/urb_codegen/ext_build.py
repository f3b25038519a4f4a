"""Compile a CPython extension module from C sources: what `make accel` (urb_codegen.build_accel) and
`make host-c-py` (tools/build_native_core.py) share.

Both build one module for the interpreter running them (its EXT_SUFFIX and include folder from
sysconfig; Debian's python3-dev provides the headers, tools/setup.sh installs it) with the same
strict flags (-Werror) and -O2 -flto, into a temporary file next to the module that then replaces it
atomically. Each builder decides itself when its module is up to date. This module lives in the
codegen package because tools/ is type-checked as loose scripts (`make lint`) and may import it,
while the codegen package cannot import from tools/.
"""

from __future__ import annotations

import argparse
import os
import shlex
import subprocess
import sys
import sysconfig
import tempfile
from collections.abc import Callable
from pathlib import Path

CFLAGS = ("-std=c11", "-O2", "-flto", "-fPIC", "-shared", "-fvisibility=hidden", "-Wall", "-Wextra", "-Werror",
          "-Wno-missing-field-initializers")  # PyVarObject_HEAD_INIT and PyModuleDef_HEAD_INIT leave members out
"""The flags of every extension: C11, optimised across files (-flto inlines the C code into its
Python entry points), position independent, only the init function exported, every warning an error."""


class BuildError(RuntimeError):
    """The compiler failed, or the interpreter has no headers; the message says what to do."""


def compiler() -> str:
    """The C compiler: $CC, else gcc."""
    return os.environ.get("CC", "gcc")


def module_path(folder: Path, name: str) -> Path:
    """Where the extension module `name` of this interpreter goes in `folder`."""
    suffix = sysconfig.get_config_var("EXT_SUFFIX")
    if not isinstance(suffix, str):
        raise BuildError("this interpreter reports no EXT_SUFFIX for extension modules")
    return folder / (name + suffix)


def python_include() -> str:
    """The folder of this interpreter's Python.h (a BuildError saying what to install when it is missing)."""
    include = sysconfig.get_paths()["include"]
    if not (Path(include) / "Python.h").exists():
        raise BuildError(f"no Python.h in {include}: install the interpreter's headers (Debian: python3-dev, "
                         "which `make setup` installs)")
    return include


def compile_module(out: Path, what: str, command: Callable[[Path], list[str]]) -> Path:
    """Runs `command(partial)`, which compiles the module into `partial`, then replaces `out` with it;
    a failure (the compiler missing, or failing) raises a BuildError naming `what`, with the command
    and the compiler's output."""
    with tempfile.TemporaryDirectory(prefix="urb-build-", dir=out.parent) as tmp:
        partial = Path(tmp) / out.name
        cmd = command(partial)
        try:
            done = subprocess.run(cmd, capture_output=True, text=True, check=False)
        except OSError as exc:
            raise BuildError(f"building {what} failed: the C compiler {cmd[0]!r} cannot be run ({exc.strerror}): "
                             "install one (Debian: apt-get install gcc) or set CC to a C compiler") from exc
        if done.returncode != 0:
            raise BuildError(f"building {what} failed:\n{shlex.join(cmd)}\n{done.stdout}{done.stderr}")
        partial.replace(out)  # atomic: a process importing meanwhile sees the old or the new module
    return out


def main(name: str, doc: str | None, build: Callable[[bool], Path], repo: Path, argv: list[str] | None = None) -> int:
    """The command line of a builder: `--force` rebuilds even when up to date; prints the module's
    path relative to `repo`, or `name: <what failed>` on stderr and returns 1."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0] if doc else None)
    ap.add_argument("--force", action="store_true", help="rebuild even when up to date")
    args = ap.parse_args(argv)
    try:
        out = build(args.force)
    except BuildError as exc:
        print(f"{name}: {exc}", file=sys.stderr)
        return 1
    print(out.relative_to(repo))
    return 0
