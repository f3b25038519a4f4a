"""Run the SensoRHex experiments, one after the other or in parallel worker processes.

Every experiment builds its own simulated worlds from its own seed and writes only into its own
folder, so running several at once changes no number: the results are the same, byte for byte, for
any number of workers. Workers are started with "spawn" (a fresh interpreter each), so nothing of
the parent (the progress bar's thread, loaded libraries) leaks into them.
"""

from __future__ import annotations

import multiprocessing
import os
import queue
import signal
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from .experiments import Progress, Result

#: Every experiment, in report order, with its rough wall time relative to the others (measured,
#: full run): in parallel runs the longest start first, so that the last one to finish starts early
#: (longest-processing-time order).
EXPERIMENTS = {"fig15": 1.9, "fig16": 1.9, "table1": 5.0, "fig18_19": 28.0, "fig20": 3.3, "bandwidth": 7.0,
               "faults": 1.0, "traces": 60.0}


def available_cpus() -> int:
    """CPUs this process may run on (its affinity mask, not the machine's total)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def experiment(key: str) -> Callable[..., Result]:
    """The function that runs experiment `key`."""
    from .experiments import bandwidth, control, faults, gait, latency, sync, traces

    table: dict[str, Callable[..., Result]] = {"fig15": latency.fig15, "fig16": latency.fig16, "table1": sync.table1,
                                               "fig18_19": control.figs18_19, "fig20": gait.fig20,
                                               "bandwidth": bandwidth.bandwidth, "faults": faults.faults,
                                               "traces": traces.traces}
    return table[key]


def run_experiments(keys: Sequence[str], out: Path, *, quick: bool, seed: int, jobs: int,
                    progress: Progress) -> list[Result]:
    """Run the experiments `keys` into out/<key>/ with at most `jobs` at a time; results in the order
    of `keys`. An experiment that raises (a bug: a failed criterion is a FAIL result, not an
    exception) stops the run: the other workers are terminated and the exception propagates."""
    if jobs <= 1 or len(keys) <= 1:
        return _serial(keys, out, quick=quick, seed=seed, progress=progress)
    return _parallel(keys, out, quick=quick, seed=seed, jobs=min(jobs, len(keys)), progress=progress)


def _serial(keys: Sequence[str], out: Path, *, quick: bool, seed: int, progress: Progress) -> list[Result]:
    results = []
    for i, key in enumerate(keys):
        def step(frac: float, msg: str, i: int = i) -> None:
            progress((i + frac) / len(keys), msg)

        res = experiment(key)(out / key, quick=quick, seed=seed, progress=step)
        results.append(res)
        progress((i + 1) / len(keys), _verdict(res))
    return results


#: In a worker: where its experiments report progress (set by _worker_init).
_reports: Any = None


def _worker_init(reports: Any) -> None:
    global _reports
    _reports = reports
    # Pool.terminate() (the parent was interrupted, or another experiment raised) sends SIGTERM: exit
    # through an exception, so that subprocess.run kills the TLC process it waits for.
    signal.signal(signal.SIGTERM, lambda signum, frame: sys.exit(128 + signum))


def _run_in_worker(key: str, out: Path, quick: bool, seed: int) -> Result:
    def step(frac: float, msg: str) -> None:
        _reports.put((key, frac, msg))

    return experiment(key)(out / key, quick=quick, seed=seed, progress=step)


def _parallel(keys: Sequence[str], out: Path, *, quick: bool, seed: int, jobs: int,
              progress: Progress) -> list[Result]:
    ctx = multiprocessing.get_context("spawn")
    reports = ctx.Queue()
    done_frac = dict.fromkeys(keys, 0.0)
    results: dict[str, Result] = {}
    order = sorted(keys, key=lambda k: -EXPERIMENTS.get(k, 1.0))
    # Leaving the with block (normally, or through an exception or Ctrl-C) terminates the workers.
    with ctx.Pool(processes=jobs, initializer=_worker_init, initargs=(reports,)) as pool:
        running = {k: pool.apply_async(_run_in_worker, (k, out, quick, seed)) for k in order}
        while running:
            next(iter(running.values())).wait(0.2)
            _drain(reports, done_frac, progress)
            for key in [k for k, r in running.items() if r.ready()]:
                res: Result = running.pop(key).get()  # re-raises the worker's exception
                results[key] = res
                done_frac[key] = 1.0
                progress(sum(done_frac.values()) / len(keys), _verdict(res))
    return [results[k] for k in keys]


def _verdict(res: Result) -> str:
    return f"{res.key}: {'PASS' if res.passed else 'FAIL'}"


def _drain(reports: Any, done_frac: dict[str, float], progress: Progress) -> None:
    """Fold the workers' progress reports into the overall fraction."""
    while True:
        try:
            key, frac, msg = reports.get_nowait()
        except queue.Empty:
            return
        done_frac[key] = max(done_frac[key], min(frac, 1.0))
        progress(sum(done_frac.values()) / len(done_frac), msg)
