"""A Dask cluster on this machine's loopback (127.0.0.1): a scheduler and single-threaded worker
processes, started and stopped around a sweep (issue #40). The test of the Dask backend and the
opt-in `make sim-sweep-dask` (200 seeds) run through it; on real machines start `dask scheduler`
and `dask worker ADDRESS --nthreads 1 --nworkers N` instead (sim/README.md).

    python3 -m urb_sim.loopback --workers 2 -- --seeds 0-4179/21 --only fig15,fig16 --quick
        # = urb sim sweep ARGS --scheduler tcp://127.0.0.1:PORT on a cluster started for it
"""

from __future__ import annotations

import argparse
import contextlib
import os
import signal
import socket
import subprocess
import sys
from collections.abc import Iterator


def free_port() -> int:
    """A TCP port nothing listens on now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@contextlib.contextmanager
def cluster(workers: int) -> Iterator[str]:
    """While inside: a scheduler and `workers` worker processes of one thread each on 127.0.0.1; yields
    the scheduler's address. Each runs in its own session and is stopped (SIGTERM, then SIGKILL after
    20 s) with every process it started when the block ends."""
    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL, "start_new_session": True}
    procs = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                               "--port", str(port), "--no-dashboard"], **quiet)]  # type: ignore[call-overload]
    try:
        procs.append(subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address, "--nworkers",
                                       str(workers), "--nthreads", "1", "--no-dashboard", "--host", "127.0.0.1"],
                                      **quiet))  # type: ignore[call-overload]
        yield address
    finally:
        for p in reversed(procs):
            with contextlib.suppress(ProcessLookupError):
                os.killpg(p.pid, signal.SIGTERM)
        for p in reversed(procs):
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(p.pid, signal.SIGKILL)
                p.wait()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description="Run `urb sim sweep ARGS` on a Dask cluster started on loopback for it")
    ap.add_argument("--workers", type=int, default=max(1, len(os.sched_getaffinity(0))),
                    help="worker processes (default: the CPUs available)")
    ap.add_argument("sweep", nargs=argparse.REMAINDER, help="-- then the arguments of urb sim sweep")
    args = ap.parse_args(argv)
    rest = args.sweep[1:] if args.sweep[:1] == ["--"] else args.sweep
    if args.workers < 1:
        print("urb_sim.loopback: --workers must be 1 or more", file=sys.stderr)
        return 2
    from urb.cli import main as urb_main

    with cluster(args.workers) as address:
        print(f"loopback Dask cluster: scheduler {address}, {args.workers} worker process(es)", flush=True)
        return urb_main(["sim", "sweep", *rest, "--scheduler", address])


if __name__ == "__main__":
    sys.exit(main())
