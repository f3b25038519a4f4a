"""Build and talk to the C codec driver (tests/c/codec_driver.c): the generated C codecs in a process.

The driver reads one command per line and answers one line; its protocol is documented at the top
of tests/c/codec_driver.c. The demo and the differential tests use it to put Python-encoded frames
through the C decoders and encoders.
"""

from __future__ import annotations

import json
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[2]
DRIVER_SOURCE = REPO / "tests" / "c" / "codec_driver.c"
SANITIZE = ["-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer"]


class DriverError(RuntimeError):
    """The driver could not be built or stopped answering (a crash: the sanitizers abort on UB)."""


def build_driver(c_dir: Path, out: Path, cc: str = "gcc") -> Path:
    """Compile the driver against the codecs in `c_dir` (with sanitizers) into `out`."""
    sources = [DRIVER_SOURCE, *sorted(c_dir.glob("*.c")), *sorted((c_dir / "test").glob("*.c"))]
    out.parent.mkdir(parents=True, exist_ok=True)
    cmd = [cc, "-std=c99", "-O1", "-g", *SANITIZE, f"-I{c_dir}", f"-I{c_dir / 'test'}", *map(str, sources), "-o", str(out)]
    try:
        done = subprocess.run(cmd, capture_output=True, text=True)
    except FileNotFoundError:
        raise DriverError(f"{cc} not found; run `make setup` (or apt-get install {cc})") from None
    if done.returncode != 0:
        raise DriverError(f"building the codec driver failed:\n{' '.join(cmd)}\n{done.stderr}")
    return out


@dataclass(frozen=True)
class Answer:
    """One driver answer: ok, the frame it produced, the decoded fields (D/I), or the error name."""

    ok: bool
    frame: bytes
    fields: dict[str, Any]
    error: str


class CodecDriver:
    """A running driver process; use as a context manager."""

    def __init__(self, exe: Path) -> None:
        self.proc = subprocess.Popen([str(exe)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, text=True)

    def __enter__(self) -> CodecDriver:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Stop the driver."""
        if self.proc.stdin is not None:
            self.proc.stdin.close()
        self.proc.wait(timeout=10)

    def _ask(self, line: str) -> str:
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()
        answer = self.proc.stdout.readline().strip()
        if not answer:
            err = self.proc.stderr.read() if self.proc.stderr is not None else ""
            raise DriverError(f"codec driver stopped answering after {line!r}:\n{err}")
        return answer

    def roundtrip(self, message: str, frame: bytes, prefix: bytes | None = None) -> Answer:
        """Decode `frame` in C and encode the result again."""
        data = frame.hex() or "-"
        line = f"I {message} {prefix.hex() or '-'} {data}" if prefix is not None else f"D {message} {data}"
        parts = self._ask(line).split(" ", 2)
        if parts[0] == "OK":
            return Answer(True, bytes.fromhex(parts[1]) if parts[1] != "-" else b"", json.loads(parts[2]), "")
        if parts[0] == "ERR":
            return Answer(False, b"", {}, parts[1])
        raise DriverError(f"driver refused {line!r}: {' '.join(parts)}")
