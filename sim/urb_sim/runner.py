"""Run the SensoRHex experiments, one after the other or in parallel worker processes.

Every experiment builds its own simulated worlds from its own seed and writes only into its own
folder, so running several at once changes no number: the results are the same, byte for byte, for
any number of workers. Workers are started with "spawn" (a fresh interpreter each), so nothing of
the parent (the progress bar's thread, loaded libraries) leaks into them; each worker then runs one
task after another, as `--jobs 1` runs them all in the calling process.
"""

from __future__ import annotations

import contextlib
import faulthandler
import multiprocessing
import multiprocessing.connection
import os
import signal
import sys
import traceback
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any, NamedTuple

from .experiments import RAN_TO_COMPLETION, Progress, Result

#: Every experiment, in report order, with its rough wall time relative to the others (measured,
#: full run): in parallel runs the longest start first, so that the last one to finish starts early
#: (longest-processing-time order).
EXPERIMENTS = {"fig15": 1.9, "fig16": 1.9, "table1": 5.0, "fig18_19": 28.0, "fig20": 3.3, "bandwidth": 7.0,
               "faults": 1.0, "traces": 60.0, "can": 1.0, "rs485": 1.0}
#: the experiments of each `--downlink` choice of `urb sim sensorhex` (sim/README.md, "Downlinks")
DOWNLINK_EXPERIMENTS = {"i2c": [k for k in EXPERIMENTS if k not in ("can", "rs485")], "can": ["can"],
                        "rs485": ["rs485"], "all": list(EXPERIMENTS)}


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


def split_key(key: str) -> tuple[str, str]:
    """A task key is an experiment, or `<experiment>@<profile>` for a hardware profile other than the
    default (sim/profiles): (experiment, profile)."""
    from .profiles import DEFAULT

    name, at, profile = key.partition("@")
    return name, (profile if at else DEFAULT)


def task_key(name: str, profile: str) -> str:
    """The key of experiment `name` run under `profile` (the inverse of split_key)."""
    from .profiles import DEFAULT

    return name if profile == DEFAULT else f"{name}@{profile}"


def experiment(key: str) -> Callable[..., Result]:
    """The function that runs experiment `key` (a sensitivity point for `sens:...` keys)."""
    from .experiments import bandwidth, control, downlinks, faults, gait, latency, sync, traces

    key = split_key(key)[0]
    if key.startswith("sens:"):
        from . import sensitivity

        return sensitivity.point_function(key)

    table: dict[str, Callable[..., Result]] = {"fig15": latency.fig15, "fig16": latency.fig16, "table1": sync.table1,
                                               "fig18_19": control.figs18_19, "fig20": gait.fig20,
                                               "bandwidth": bandwidth.bandwidth, "faults": faults.faults,
                                               "traces": traces.traces, "can": downlinks.can_variant,
                                               "rs485": downlinks.rs485_variant}
    return table[key]


def run_experiments(keys: Sequence[str], out: Path, *, quick: bool, seed: int, jobs: int,
                    progress: Progress) -> list[Result]:
    """Run the experiments `keys` into out/<key>/ with at most `jobs` at a time; results in the order
    of `keys`. An experiment that raises (a bug: a failed criterion is a FAIL result, not an
    exception) gives a failed Result whose check "ran to completion" names the exception, with the
    traceback in out/<key>/error.txt; the other experiments still run. Ctrl-C stops the whole run."""
    return run_tasks([Task(key, out, seed) for key in keys], quick=quick, jobs=jobs, progress=progress)


class Task(NamedTuple):
    """One run of one experiment: `key` with base seed `seed`, writing into out/<key>/."""

    key: str
    out: Path
    seed: int


def run_tasks(tasks: Sequence[Task], *, quick: bool, jobs: int, progress: Progress,
              on_result: Callable[[Task, Result], None] | None = None) -> list[Result]:
    """Run `tasks` with at most `jobs` at a time (in worker processes when jobs > 1); results in
    task order. `on_result(task, result)` is called in this process as each one ends. Errors are
    handled as run_experiments describes. No two tasks may share a key and an out folder."""
    if len({(t.key, t.out) for t in tasks}) != len(tasks):
        raise ValueError("two tasks would write the same folder: give each (key, out) once")
    # progress names a run by its experiment, and by its seed too when the seeds differ (a sweep)
    one_seed = len({t.seed for t in tasks}) <= 1
    labels = [t.key if one_seed else f"{t.key} seed {t.seed}" for t in tasks]
    if jobs <= 1 or len(tasks) <= 1:
        return _serial(tasks, labels, quick=quick, progress=progress, on_result=on_result)
    return _pool(tasks, labels, quick=quick, jobs=min(jobs, len(tasks)), progress=progress, on_result=on_result)


def run_one(key: str, out: Path, *, quick: bool, seed: int, progress: Progress) -> Result:
    """Run experiment `key` into out/<key>/ under its hardware profile (split_key); an exception
    becomes a failed Result (see run_experiments)."""
    from . import profiles

    try:
        with profiles.applied(profiles.load(split_key(key)[1])):
            res = experiment(key)(out / key, quick=quick, seed=seed, progress=progress)
        res.key = key  # the task's key: the experiment, with its profile when not the default
        return res
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


def _serial(tasks: Sequence[Task], labels: Sequence[str], *, quick: bool, progress: Progress,
            on_result: Callable[[Task, Result], None] | None) -> list[Result]:
    results = []
    with stack_on_crash():
        for i, task in enumerate(tasks):
            def step(frac: float, msg: str, i: int = i) -> None:
                progress((i + frac) / len(tasks), msg)

            res = run_one(task.key, task.out, quick=quick, seed=task.seed, progress=step)
            results.append(res)
            if on_result is not None:
                on_result(task, res)
            progress((i + 1) / len(tasks), f"{labels[i]}: {res.verdict}")
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


def _worker(index: int, key: str, out: Path, quick: bool, seed: int, reports: Any) -> None:
    """Run task `index` (experiment `key` into out/<key>/) in a worker process, sending progress and
    then its Result, each tagged with `index`, on the connection `reports`."""
    def step(frac: float, msg: str) -> None:
        reports.send((index, frac, msg))

    with crash_log(out, key):
        reports.send((index, 1.0, run_one(key, out, quick=quick, seed=seed, progress=step)))


def _serve(conn: Any, quick: bool, target: Callable[..., None]) -> None:
    """Body of a worker process: run the tasks the parent sends on `conn`, one at a time, until it
    sends None, and send their reports back on it. The interpreter, the library and matplotlib load
    once for all of them (a fresh process per task cost more than a quick experiment's run)."""
    # Ctrl-C is the parent's to handle: it terminates the workers. terminate() sends SIGTERM: exit
    # through an exception, so that subprocess.run kills the TLC process it waits for.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, lambda signum, frame: sys.exit(128 + signum))
    while (order := conn.recv()) is not None:
        index, key, out, seed = order
        target(index, key, out, quick, seed, conn)


def _parallel(keys: Sequence[str], out: Path, *, quick: bool, seed: int, jobs: int, progress: Progress,
              target: Callable[..., None] = _worker) -> list[Result]:
    """The experiments `keys` in worker processes (see _pool); `target` is the task body (tests)."""
    tasks = [Task(key, out, seed) for key in keys]
    return _pool(tasks, list(keys), quick=quick, jobs=jobs, progress=progress, on_result=None, target=target)


def _pool(tasks: Sequence[Task], labels: Sequence[str], *, quick: bool, jobs: int, progress: Progress,
          on_result: Callable[[Task, Result], None] | None, target: Callable[..., None] = _worker) -> list[Result]:
    """`jobs` spawned worker processes run the tasks, longest experiments first. A worker that dies
    without sending its task's Result (a segmentation fault in the firmware under test, the OOM
    killer) gives that task an ERROR and is replaced; the other tasks go on.

    Each worker has its own pipe, for its orders and its reports. A shared multiprocessing.Queue
    would not do: its writers share one lock, and a worker killed while its queue thread held it
    (a crash just after a report) blocked every other worker's reports for ever."""
    ctx = multiprocessing.get_context("spawn")
    done_frac = [0.0] * len(tasks)
    done = [0.0]  # sum(done_frac), kept as it changes: a sweep has thousands of tasks
    results: dict[int, Result] = {}
    # stable: a sweep keeps its seeds in order within each experiment
    pending = sorted(range(len(tasks)), key=lambda i: -EXPERIMENTS.get(split_key(tasks[i].key)[0], 1.0))
    workers: list[tuple[Any, Any]] = []     # (process, the parent's end of its pipe)
    busy: dict[int, int] = {}               # worker number -> the task it runs

    def record(index: int, frac: float, item: str | Result) -> None:
        """A progress message or the final Result of task `index`."""
        frac = max(done_frac[index], min(frac, 1.0))
        done[0] += frac - done_frac[index]
        done_frac[index] = frac
        if isinstance(item, Result) and index not in results:
            results[index] = item
            if on_result is not None:
                on_result(tasks[index], item)
        progress(done[0] / len(tasks), f"{labels[index]}: {item.verdict}" if isinstance(item, Result) else item)

    def receive(conn: Any) -> None:
        """Fold in every report the worker at `conn` has sent so far. A worker that died while
        sending leaves an incomplete report: its end of the pipe is closed, and that is read as the
        end of its reports."""
        try:
            while conn.poll():
                record(*conn.recv())
        except (EOFError, OSError):
            pass

    def start_worker() -> tuple[Any, Any]:
        mine, theirs = ctx.Pipe()
        proc = ctx.Process(target=_serve, args=(theirs, quick, target), name="urb-sim-worker", daemon=True)
        proc.start()
        theirs.close()  # the worker's end lives in the worker only: its death closes the pipe
        return proc, mine

    try:
        workers = [start_worker() for _ in range(min(jobs, len(tasks)))]
        while pending or busy:
            for w, (proc, conn) in enumerate(workers):
                if w in busy or not pending:
                    continue
                if not proc.is_alive():  # died between tasks: nothing lost, start another
                    proc.join()
                    conn.close()
                    workers[w] = start_worker()
                    proc, conn = workers[w]
                i = pending.pop(0)
                try:
                    conn.send((i, tasks[i].key, tasks[i].out, tasks[i].seed))
                except OSError:  # it ended just now: the task waits for the next worker
                    pending.insert(0, i)
                    continue
                busy[w] = i
            # only busy workers report; an ended worker's pipe and sentinel stay ready, and waiting on
            # an idle one that ended would make this loop spin while the others run
            running = [workers[w] for w in busy]
            multiprocessing.connection.wait([c for _, c in running] + [p.sentinel for p, _ in running], timeout=1.0)
            for w, i in list(busy.items()):
                proc, conn = workers[w]
                ended = not proc.is_alive()  # before reading: what it sent before it ended is then all there
                receive(conn)
                if i not in results and ended:
                    task = tasks[i]
                    stack = _crash_text(task.out, task.key)
                    died = WorkerDied(f"the worker process ended with {_exit_status(proc.exitcode)} and no result"
                                      + (f"; its Python stack when it died ({CRASH_LOG}):\n{stack}" if stack else ""))
                    record(i, 1.0, crashed(task.key, task.out, died))
                if i in results:
                    del busy[w]  # idle: gets the next task above (a new process if this one ended)
    finally:
        # Normally idle: told to stop. After Ctrl-C or an error here, stop what still runs.
        for w, (proc, conn) in enumerate(workers):
            if w in busy:
                proc.terminate()
            elif proc.is_alive():
                with contextlib.suppress(OSError, ValueError):
                    conn.send(None)
        for proc, conn in workers:
            proc.join(timeout=10)
            if proc.is_alive():
                proc.terminate()
                proc.join()
            conn.close()
    return [results[i] for i in range(len(tasks))]


def _exit_status(code: int) -> str:
    if code >= 0:
        return f"exit status {code}"
    try:
        return f"signal {-code} ({signal.Signals(-code).name})"
    except ValueError:
        return f"signal {-code}"
