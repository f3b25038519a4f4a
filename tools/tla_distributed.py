"""TLC's distributed mode (TLCServer and TLCWorker over Java RMI) for the large configurations.

The server holds the queue of states to explore and the set of seen states; each worker fetches
states, computes their successors with its own threads and checks the invariants. On one machine
everything talks over loopback, which RMI only does when told the host name
(`-Djava.rmi.server.hostname=127.0.0.1`): otherwise a worker registers under the machine's name
and the server calls back an address that may not answer.

What distributed TLC checks: invariants and action properties (`[][A]_v`); it ignores temporal
(liveness) properties without a word, and it does not support TLCGet/TLCSet (so no reachability
witnesses). The runner therefore removes the liveness properties from the server's copy of the
configuration and reports them as not checked, rather than letting a pass claim them.

    python3 tools/modelcheck.py --optional --only Large --distributed            # loopback
    python3 tools/modelcheck.py --optional --exact MCBridgeLarge --distributed \
        --host 10.0.0.5 --port 10997 --local-workers 0      # wait for workers on other machines

On every other machine (the same tla2tools.jar; the worker fetches the modules from the server):

    java -Djava.rmi.server.hostname=WORKER_IP -Dtlc2.tool.distributed.TLCServer.port=10997 \
         -cp tla2tools.jar tlc2.tool.distributed.TLCWorker SERVER_IP
"""

from __future__ import annotations

import re
import socket
import subprocess
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

#: Java system properties TLC reads (tlc2.tool.distributed.TLCServer / TLCWorker).
PORT_PROPERTY = "tlc2.tool.distributed.TLCServer.port"
THREADS_PROPERTY = "tlc2.tool.distributed.TLCWorker.threadCount"
DEFAULT_PORT = 10997

_READY_RE = re.compile(r"TLC server at .* is ready")
_PROPERTY_SECTION = {"PROPERTY", "PROPERTIES"}
CFG_KEYWORDS = {
    "SPECIFICATION", "INIT", "NEXT", "INVARIANT", "INVARIANTS", "PROPERTY", "PROPERTIES",
    "CONSTANT", "CONSTANTS", "SYMMETRY", "VIEW", "CONSTRAINT", "CONSTRAINTS",
    "ACTION_CONSTRAINT", "ACTION_CONSTRAINTS",
}


class DistributedError(Exception):
    """The server or the workers could not be started or did not finish; the message says why."""


def is_action_property(name: str, tla_texts: list[str]) -> bool:
    """True when `name` is defined as `[][...]_v` (an action property: distributed TLC checks
    it); False for any other (temporal) property."""
    pattern = re.compile(rf"^{re.escape(name)}\s*==\s*\[\]\[", re.MULTILINE)
    return any(pattern.search(t) for t in tla_texts)


def split_config(cfg_text: str, tla_texts: list[str]) -> tuple[str, list[str], list[str]]:
    """(the configuration without its liveness properties, the action properties kept, the
    liveness properties removed)."""
    kept_lines: list[str] = []
    props: list[str] = []
    section: str | None = None
    for raw in cfg_text.splitlines():
        line = raw.split("\\*", 1)[0].strip()
        words = line.split()
        if words and words[0] in CFG_KEYWORDS:
            section = words[0]
            if section in _PROPERTY_SECTION:
                props.extend(words[1:])
                continue
        elif section in _PROPERTY_SECTION and words:
            props.extend(words)
            continue
        kept_lines.append(raw)
    action = [p for p in props if is_action_property(p, tla_texts)]
    liveness = [p for p in props if p not in action]
    if action:
        kept_lines.append("PROPERTIES " + " ".join(action))
    return "\n".join(kept_lines) + "\n", action, liveness


def free_port(host: str = "127.0.0.1") -> int:
    """A TCP port nobody listens on now (the loopback test must not collide with another run)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        port: int = s.getsockname()[1]
        return port


@dataclass
class DistributedRun:
    """What one distributed run printed: the server's log (the verdict and the counts), the
    workers' logs, the server's exit code, and the properties it could not check."""

    server_log: str
    worker_logs: list[str]
    returncode: int
    unchecked: list[str]
    runtime_s: float


def _wait_ready(log: Path, proc: subprocess.Popen[bytes], timeout: float) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if _READY_RE.search(log.read_text(encoding="utf-8", errors="replace")):
            return
        if proc.poll() is not None:
            raise DistributedError(
                "the TLC server stopped before it was ready:\n" + log.read_text(encoding="utf-8")[-2000:])
        time.sleep(0.2)
    raise DistributedError(f"the TLC server was not ready after {timeout:.0f} s")


def run_distributed(
    java: str, jar: Path, jvm: list[str], work: Path, module: str, config: str, tla_texts: list[str], *,
    local_workers: int = 1, threads: int = 1, host: str = "127.0.0.1", port: int | None = None,
    timeout: float = 3600.0,
) -> DistributedRun:
    """Run TLCServer on `module`/`config` (files in `work`, a scratch copy of the modules) and
    `local_workers` TLCWorkers on this machine; wait for the verdict. With local_workers = 0
    the server waits (up to `timeout`) for workers started by hand elsewhere."""
    cfg_text, _action, liveness = split_config((work / config).read_text(encoding="utf-8"), tla_texts)
    server_cfg = f"{Path(config).stem}_Server.cfg"
    (work / server_cfg).write_text(cfg_text, encoding="utf-8")
    port = port or free_port(host)
    props = [f"-Djava.rmi.server.hostname={host}", f"-D{PORT_PROPERTY}={port}"]
    (work / "java-tmp").mkdir(exist_ok=True)
    tmpdir = f"-Djava.io.tmpdir={work / 'java-tmp'}"
    server_log = work / "server.log"
    start = time.monotonic()
    workers: list[subprocess.Popen[bytes]] = []
    worker_logs: list[Path] = []
    with server_log.open("wb") as out:
        server = subprocess.Popen(
            [java, *jvm, tmpdir, *props, "-cp", str(jar), "tlc2.tool.distributed.TLCServer",
             "-config", server_cfg, "-metadir", str(work / "meta"), module],
            cwd=work, stdout=out, stderr=subprocess.STDOUT)
    try:
        _wait_ready(server_log, server, timeout=120.0)
        if local_workers == 0:
            print(f"TLC server ready on {host}:{port}; start workers with:\n"
                  f"  java -Djava.rmi.server.hostname=WORKER_IP -D{PORT_PROPERTY}={port} "
                  f"-cp tla2tools.jar tlc2.tool.distributed.TLCWorker {host}", flush=True)
        for k in range(local_workers):
            wlog = work / f"worker{k}.log"
            worker_logs.append(wlog)
            wdir = Path(tempfile.mkdtemp(prefix=f"worker{k}-", dir=work))
            with wlog.open("wb") as out:
                workers.append(subprocess.Popen(
                    [java, *jvm, f"-Djava.io.tmpdir={wdir}", *props, f"-D{THREADS_PROPERTY}={threads}",
                     "-cp", str(jar), "tlc2.tool.distributed.TLCWorker", host],
                    cwd=wdir, stdout=out, stderr=subprocess.STDOUT))
        try:
            rc = server.wait(timeout=timeout)
        except subprocess.TimeoutExpired as exc:
            raise DistributedError(f"the TLC server had no verdict after {timeout:.0f} s") from exc
        for w in workers:
            try:
                w.wait(timeout=30)
            except subprocess.TimeoutExpired:
                w.kill()
                w.wait()
    finally:
        for p in (server, *workers):
            if p.poll() is None:
                p.kill()
                p.wait()
    return DistributedRun(
        server_log=server_log.read_text(encoding="utf-8", errors="replace"),
        worker_logs=[w.read_text(encoding="utf-8", errors="replace") for w in worker_logs],
        returncode=rc, unchecked=liveness, runtime_s=time.monotonic() - start)
