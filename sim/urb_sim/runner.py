"""Run the SensoRHex experiments, one after the other or in parallel worker processes.

Every experiment builds its own simulated worlds from its own seed and writes only into its own
folder, so running several at once changes no number: the results are the same, byte for byte, for
any number of workers. Workers are started with "spawn" (a fresh interpreter each), so nothing of
the parent (the progress bar's thread, loaded libraries) leaks into them.
"""

from __future__ import annotations

import contextlib
import faulthandler
import multiprocessing
import os
import queue
import signal
import sys
import traceback
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

from .experiments import RAN_TO_COMPLETION, Progress, Result

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


def select(only: str | None) -> list[str]:
    """The experiments a comma-separated `--only` list names (None: all, in report order). Raises
    ValueError saying what is wrong when it names none or one that does not exist."""
    if only is None:
        return list(EXPERIMENTS)
    keys = [k.strip() for k in only.split(",") if k.strip()]
    choices = ", ".join(EXPERIMENTS)
    if not keys:
        raise ValueError(f"--only names no experiment; choose from {choices} (or leave --only out to run them all)")
    unknown = [k for k in keys if k not in EXPERIMENTS]
    if unknown:
        raise ValueError(f"unknown experiment(s) {', '.join(unknown)}; choose from {choices}")
    repeated = sorted({k for k in keys if keys.count(k) > 1})
    if repeated:
        # two workers would write one folder at once, and the report would list the experiment twice
        raise ValueError(f"--only names {', '.join(repeated)} more than once; name each experiment once")
    return keys


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
    exception) gives a failed Result whose check "ran to completion" names the exception, with the
    traceback in out/<key>/error.txt; the other experiments still run. Ctrl-C stops the whole run."""
    if jobs <= 1 or len(keys) <= 1:
        return _serial(keys, out, quick=quick, seed=seed, progress=progress)
    return _parallel(keys, out, quick=quick, seed=seed, jobs=min(jobs, len(keys)), progress=progress)


def run_one(key: str, out: Path, *, quick: bool, seed: int, progress: Progress) -> Result:
    """Run experiment `key` into out/<key>/; an exception becomes a failed Result (see run_experiments)."""
    try:
        return experiment(key)(out / key, quick=quick, seed=seed, progress=progress)
    except Exception as exc:  # noqa: BLE001 - reported in the Result; KeyboardInterrupt still stops the run
        return crashed(key, out, exc)


def crashed(key: str, out: Path, exc: BaseException) -> Result:
    """The Result of experiment `key` that stopped with `exc`: one failed check naming it, the
    traceback in out/<key>/error.txt."""
    trace = "".join(traceback.format_exception(exc))
    path = out / key / "error.txt"
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(trace, encoding="utf-8")
        where, files = "The traceback is in error.txt", [path]
    except OSError as write_error:
        where, files = f"The traceback could not be written to {path} ({write_error}):\n{trace}", []
    res = Result(key, f"{key}: stopped with an error", "", files=files,
                 notes=["The experiment raised an exception: a bug in the simulation or in the firmware under test "
                        f"(a criterion that is not met is a FAIL, not an exception). {where}; "
                        f"run it alone with `urb sim sensorhex --only {key} --jobs 1` to debug it."])
    first_line = next(iter(str(exc).splitlines()), "")  # the rest (a crash stack) is in error.txt
    res.check(RAN_TO_COMPLETION, "no exception", f"{type(exc).__name__}: {first_line}", False)
    return res


def _serial(keys: Sequence[str], out: Path, *, quick: bool, seed: int, progress: Progress) -> list[Result]:
    results = []
    with stack_on_crash():
        for i, key in enumerate(keys):
            def step(frac: float, msg: str, i: int = i) -> None:
                progress((i + frac) / len(keys), msg)

            res = run_one(key, out, quick=quick, seed=seed, progress=step)
            results.append(res)
            progress((i + 1) / len(keys), _verdict(res))
    return results


@contextlib.contextmanager
def stack_on_crash() -> Iterator[None]:
    """While inside, a fatal signal in this process (a SIGSEGV in the firmware under test, with
    `--jobs 1`) prints the Python stack to the standard error before the process dies: there is
    no worker whose death could be reported."""
    if faulthandler.is_enabled() or sys.__stderr__ is None:
        yield  # already printed (python3 -X faulthandler, pytest), or nowhere to print it
        return
    try:
        faulthandler.enable(file=sys.__stderr__)
    except (ValueError, OSError):
        yield  # the standard error has no usable descriptor: the signal still ends the process
        return
    try:
        yield
    finally:
        faulthandler.disable()


class WorkerDied(RuntimeError):
    """A worker process ended without returning its experiment's result (a crash in native code,
    killed by the operating system)."""


#: A worker that dies of a fatal signal leaves its Python stack at that moment here (out/<key>/).
CRASH_LOG = "crash.txt"


@contextlib.contextmanager
def crash_log(out: Path, key: str) -> Iterator[None]:
    """While inside, a fatal signal (SIGSEGV in the firmware under test, SIGABRT, SIGBUS...) writes the
    Python stack of this process to out/<key>/crash.txt before the process dies; the file is
    removed again when nothing was written."""
    path = out / key / CRASH_LOG
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        log = open(path, "w", encoding="utf-8")  # noqa: SIM115 - must stay open until the process ends
    except OSError:
        yield  # no crash log; the exit status still says what happened
        return
    faulthandler.enable(file=log)
    try:
        yield
    finally:
        faulthandler.disable()
        empty = os.fstat(log.fileno()).st_size == 0
        log.close()
        if empty:
            path.unlink(missing_ok=True)


def _crash_text(out: Path, key: str) -> str:
    try:
        return (out / key / CRASH_LOG).read_text(encoding="utf-8", errors="replace").strip()
    except OSError:
        return ""


def _worker(key: str, out: Path, quick: bool, seed: int, reports: Any) -> None:
    """Body of a worker process: run one experiment, sending progress and then its Result."""
    # Ctrl-C is the parent's to handle: it terminates the workers. terminate() sends SIGTERM: exit
    # through an exception, so that subprocess.run kills the TLC process it waits for.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, lambda signum, frame: sys.exit(128 + signum))

    def step(frac: float, msg: str) -> None:
        reports.put((key, frac, msg))

    with crash_log(out, key):
        reports.put((key, 1.0, run_one(key, out, quick=quick, seed=seed, progress=step)))


def _parallel(keys: Sequence[str], out: Path, *, quick: bool, seed: int, jobs: int, progress: Progress,
              target: Callable[..., None] = _worker) -> list[Result]:
    """One spawned process per experiment, at most `jobs` at a time, longest first. A process that
    ends without sending its Result (a segmentation fault in the firmware under test, the OOM
    killer) gives that experiment an ERROR; the others go on. `target` is the worker body (tests)."""
    ctx = multiprocessing.get_context("spawn")
    reports = ctx.Queue()
    done_frac = dict.fromkeys(keys, 0.0)
    results: dict[str, Result] = {}
    pending = sorted(keys, key=lambda k: -EXPERIMENTS.get(k, 1.0))
    running: dict[str, Any] = {}

    def record(key: str, frac: float, item: str | Result) -> None:
        """A progress message or the final Result of experiment `key`."""
        done_frac[key] = max(done_frac[key], min(frac, 1.0))
        if isinstance(item, Result):
            results[key] = item
        progress(sum(done_frac.values()) / len(keys), _verdict(item) if isinstance(item, Result) else item)

    def receive(timeout: float) -> None:
        """Fold in what the workers sent, waiting up to `timeout` for the first message."""
        while True:
            try:
                record(*reports.get(timeout=timeout))
            except queue.Empty:
                return
            timeout = 0.0

    try:
        while pending or running:
            while pending and len(running) < jobs:
                key = pending.pop(0)
                running[key] = ctx.Process(target=target, args=(key, out, quick, seed, reports),
                                           name=f"urb-sim-{key}", daemon=True)
                running[key].start()
            receive(0.2)
            for key, proc in list(running.items()):
                if proc.is_alive():
                    continue
                if key not in results:
                    receive(0.5)  # what it sent just before it ended may still be on its way
                if key not in results:
                    stack = _crash_text(out, key)
                    died = WorkerDied(f"the worker process ended with {_exit_status(proc.exitcode)} and no result"
                                      + (f"; its Python stack when it died ({CRASH_LOG}):\n{stack}" if stack else ""))
                    record(key, 1.0, crashed(key, out, died))
                proc.join()
                del running[key]
    finally:
        # Normally empty; after Ctrl-C or an error here, stop what still runs.
        for proc in running.values():
            proc.terminate()
        for proc in running.values():
            proc.join()
    return [results[k] for k in keys]


def _exit_status(code: int) -> str:
    if code >= 0:
        return f"exit status {code}"
    try:
        return f"signal {-code} ({signal.Signals(-code).name})"
    except ValueError:
        return f"signal {-code}"


def _verdict(res: Result) -> str:
    return f"{res.key}: {res.verdict}"
