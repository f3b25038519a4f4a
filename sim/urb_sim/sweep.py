"""`urb sim sweep`: the paper's experiments over many seeds, for how often each criterion holds.

One seed is one sample of the clock errors, drifts, interrupt latencies and host phases the
simulation draws (sim/README.md). A criterion that holds at seed 1 may fail at another: a sweep
runs every chosen experiment at every seed, in parallel worker processes, and tells which seeds
failed which check, each with the command that reproduces it alone.

The runs are tasks (urb_sim.tasks): on local worker processes (runner.run_tasks), on a Dask
cluster (`scheduler`), or one shard of the plan (`shard`, merged later by `merge_shards`); each
gives a record, and the sweep's hash over all records does not depend on which.

Output, in the folder given:
  checks.csv    one row per seed, experiment and check: what was required and measured, pass or not
  runs.csv      one row per seed and experiment: verdict, simulated and wall seconds
  summary.json  per check: runs, failures and the failing seeds; the totals; the records' hash
  shard-K-of-N.json  with `shard`: the shard's records and their hash, for `urb sim merge`
  runs/seed-N/<experiment>/   the CSV and PNG files of every run that did not pass (of every run
                with keep=True), to look at next to the reproduction command's report
"""

from __future__ import annotations

import json
import shutil
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .experiments import SEED_SPAN, Progress, Result, write_csv
from .runner import Task, run_tasks
from .tasks import merge, merged_hash, plan, record, results_of, run_dask, write_shard
from .tasks import shard as pick_shard

#: More seeds than this in one sweep is a typing error more likely than a plan (1e5 full runs of
#: the fastest experiment take days on one core).
MAX_SEEDS = 100_000


def parse_seeds(text: str, seed_max: int) -> list[int]:
    """The seeds of a list such as "1-100", "7", "0-2079/21" (every 21st) or "1-10,20,30-32", in
    the order given, each once. Raises ValueError saying what is wrong."""
    seeds: list[int] = []
    seen: set[int] = set()
    for part in text.split(","):
        part = part.strip()
        if not part:
            raise ValueError(f"empty item in the seed list {text!r}: write it as 1-100 or 1,5,9")
        span, slash, step_text = part.partition("/")
        lo_text, dash, hi_text = span.partition("-")
        try:
            lo = int(lo_text)
            hi = int(hi_text) if dash else lo
            step = int(step_text) if slash else 1
        except ValueError:
            raise ValueError(f"{part!r} is not a seed or a range of seeds: write it as 7, 1-100 or 0-2079/21") from None
        if not 0 <= lo <= hi <= seed_max:
            raise ValueError(f"{part!r}: seeds go from 0 to {seed_max}, and a range from low to high")
        if step < 1 or (slash and not dash):
            raise ValueError(f"{part!r}: a step follows a range and is 1 or more, as in 0-2079/21")
        if len(seeds) + (hi - lo) // step + 1 > MAX_SEEDS:
            raise ValueError(f"{text!r} names more than {MAX_SEEDS} seeds: split the sweep into several")
        for seed in range(lo, hi + 1, step):
            if seed not in seen:
                seen.add(seed)
                seeds.append(seed)
    return seeds


def closest_pair(seeds: Sequence[int]) -> tuple[int, int] | None:
    """Two of `seeds` less than SEED_SPAN apart (their runs share simulated worlds), or None."""
    ordered = sorted(seeds)
    for a, b in zip(ordered, ordered[1:]):
        if b - a < SEED_SPAN:
            return a, b
    return None


def overlap_note(seeds: Sequence[int]) -> str | None:
    """What to tell a user whose seeds are not independent samples (None when they are)."""
    pair = closest_pair(seeds)
    if pair is None:
        return None
    a, b = pair
    first = min(seeds)
    return (f"note: seeds {a} and {b} (and maybe others) are less than {SEED_SPAN} apart, and an experiment at "
            f"seed s also runs worlds at s+1 .. s+{SEED_SPAN - 1} (table1, faults, traces): their runs share "
            f"worlds and are not independent samples. For independent ones take seeds {SEED_SPAN} apart, "
            f"e.g. --seeds {first}-{first + SEED_SPAN * (len(seeds) - 1)}/{SEED_SPAN}")


@dataclass
class CheckTally:
    """How one check of one experiment fared over the seeds."""

    experiment: str
    check: str
    runs: int = 0
    failed_seeds: list[int] = field(default_factory=list)


@dataclass
class Sweep:
    """What a sweep found (or one shard of it: `shard` (K, N))."""

    seeds: list[int]
    keys: list[str]
    quick: bool
    results: dict[tuple[str, int], Result]
    wall_s: float = 0.0
    #: the runs' records (urb_sim.tasks.record) and their order-independent hash
    records: list[dict[str, Any]] = field(default_factory=list)
    shard: tuple[int, int] | None = None

    @property
    def hash(self) -> str:
        return merged_hash(self.records)

    @property
    def passed(self) -> bool:
        return all(r.passed for r in self.results.values())

    @property
    def sim_s(self) -> float:
        return sum(r.sim_s for r in self.results.values())

    @property
    def tallies(self) -> list[CheckTally]:
        """One tally per (experiment, check name), in the order the checks first appear."""
        tallies: dict[tuple[str, str], CheckTally] = {}
        for key, seed, res in self.runs():
            for c in res.checks:
                t = tallies.setdefault((key, c.name), CheckTally(key, c.name))
                t.runs += 1
                if not c.passed:
                    t.failed_seeds.append(seed)
        return list(tallies.values())

    def runs(self) -> list[tuple[str, int, Result]]:
        """(experiment, seed, result) of every run, by experiment then seed (a shard's runs only)."""
        return [(k, s, self.results[(k, s)]) for k in self.keys for s in self.seeds if (k, s) in self.results]

    def failed_runs(self) -> list[tuple[str, int, Result]]:
        """(experiment, seed, result) of every run that did not pass, by experiment then seed."""
        return [(k, s, r) for k, s, r in self.runs() if not r.passed]

    def reproduce(self, key: str, seed: int) -> str:
        """The command that runs one failed run again alone, with its report."""
        from .runner import split_key
        from .profiles import DEFAULT

        name, profile = split_key(key)
        if name.startswith("sens:"):
            return f"urb sim sensitivity --seed {seed} --only {name[5:]}" + (" --quick" if self.quick else "")
        from .profiles import PROFILE_EXPERIMENTS

        where = "" if profile == DEFAULT else f" --profile {profile}"
        alone = " --compare none" if name in PROFILE_EXPERIMENTS else ""
        return f"urb sim sensorhex --seed {seed} --only {name}{where}{alone}" + (" --quick" if self.quick else "")


def run_dir(out: Path, seed: int) -> Path:
    """The folder whose <experiment>/ subfolders hold the files of the runs at `seed`."""
    return out / "runs" / f"seed-{seed}"


def run_sweep(keys: Sequence[str], seeds: Sequence[int], out: Path, *, quick: bool, jobs: int, keep: bool,
              progress: Progress, scheduler: str | None = None, shard: tuple[int, int] | None = None,
              connect_timeout_s: float = 30.0) -> Sweep:
    """Run experiments `keys` (task keys: an experiment, @profile for another hardware profile) at
    every seed of `seeds` into `out`, write checks.csv, runs.csv and summary.json there (with the
    records' order-independent hash), and return the tallies. Locally at most `jobs` at once; on
    the Dask cluster at `scheduler` instead; only shard K of N of the plan with `shard` (which also
    writes shard-K-of-N.json for `urb sim merge`). out/runs/ is emptied first; the files of a run
    that passed are removed as soon as it ends unless `keep` (on a cluster, where the workers run)."""
    specs = plan(keys, seeds)
    if shard is not None:
        specs = pick_shard(specs, *shard)
    shutil.rmtree(out / "runs", ignore_errors=True)  # an earlier sweep's failures are not this one's
    t0 = time.perf_counter()
    if scheduler is not None:
        records = run_dask(specs, scheduler=scheduler, quick=quick, out=out, progress=progress,
                           connect_timeout_s=connect_timeout_s)
        if not keep:
            for rec in records:
                if rec["verdict"] == "PASS":
                    shutil.rmtree(run_dir(out, rec["seed"]) / rec["key"], ignore_errors=True)
    else:
        tasks = [Task(s.key, run_dir(out, s.seed), s.seed) for s in specs]

        def tidy(task: Task, res: Result) -> None:
            if res.passed and not keep:
                # only the run's own folder: another worker may be creating one beside it right now
                shutil.rmtree(task.out / task.key, ignore_errors=True)

        results = run_tasks(tasks, quick=quick, jobs=jobs, progress=progress, on_result=tidy)
        records = [record(r, seed=t.seed, quick=quick) for t, r in zip(tasks, results)]
    sweep = Sweep(list(seeds), list(keys), quick, results_of(records), wall_s=time.perf_counter() - t0,
                  records=records, shard=shard)
    for seed in seeds:
        _remove_if_empty(run_dir(out, seed))
    _remove_if_empty(out / "runs")
    write(sweep, out)
    if shard is not None:
        write_shard(shard_path(out, *shard), records, k=shard[0], n=shard[1], keys=keys, seeds=seeds, quick=quick)
    return sweep


def shard_path(out: Path, k: int, n: int) -> Path:
    """Where shard K of N writes its records."""
    return out / f"shard-{k}-of-{n}.json"


def merge_shards(paths: Sequence[Path], out: Path) -> Sweep:
    """The sweep of shard files (urb_sim.tasks.merge: every shard once, none disagreeing), written into
    `out` like a sweep run in one piece."""
    define, records = merge(paths)
    sweep = Sweep(list(define["seeds"]), list(define["keys"]), bool(define["quick"]), results_of(records),
                  wall_s=sum(float(r["wall_s"]) for r in records), records=records)
    write(sweep, out)
    return sweep


def _remove_if_empty(folder: Path) -> None:
    try:
        folder.rmdir()
    except OSError:
        pass  # not empty (a run kept its files), or already gone


def write(sweep: Sweep, out: Path) -> None:
    """checks.csv, runs.csv and summary.json of `sweep` in `out`."""
    write_csv(out / "checks.csv", ["seed", "experiment", "check", "passed", "required", "measured"],
              ([seed, key, c.name, int(c.passed), c.required, c.measured]
               for key, seed, r in sweep.runs() for c in r.checks))
    write_csv(out / "runs.csv", ["seed", "experiment", "verdict", "sim_s", "wall_s"],
              ([seed, key, r.verdict, f"{r.sim_s:.3f}", f"{r.wall_s:.3f}"] for key, seed, r in sweep.runs()))
    summary = {
        "passed": sweep.passed,
        "quick": sweep.quick,
        "experiments": sweep.keys,
        "seeds": sweep.seeds,
        "runs": len(sweep.results),
        "failed_runs": [{"experiment": k, "seed": s, "verdict": r.verdict, "reproduce": sweep.reproduce(k, s)}
                        for k, s, r in sweep.failed_runs()],
        "checks": [{"experiment": t.experiment, "check": t.check, "runs": t.runs, "failed": len(t.failed_seeds),
                    "failed_seeds": t.failed_seeds} for t in sweep.tallies],
        "sim_s": round(sweep.sim_s, 3),
        "wall_s": round(sweep.wall_s, 3),
        "shard": list(sweep.shard) if sweep.shard else None,
        "hash": sweep.hash,
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=1) + "\n", encoding="utf-8")


def format_table(sweep: Sweep, max_seeds_shown: int = 10) -> list[str]:
    """The console summary: one line per check with its pass count and first failing seeds, then a
    reproduction command per failed run (the first few)."""
    tallies = sweep.tallies
    width = max((len(f"{t.experiment} {t.check}") for t in tallies), default=0)
    lines = []
    for t in tallies:
        ok = t.runs - len(t.failed_seeds)
        line = f"{'PASS' if not t.failed_seeds else 'FAIL':<5} {t.experiment + ' ' + t.check:<{width}}  {ok}/{t.runs}"
        if t.failed_seeds:
            shown = ", ".join(map(str, t.failed_seeds[:max_seeds_shown]))
            more = f" and {len(t.failed_seeds) - max_seeds_shown} more" if len(t.failed_seeds) > max_seeds_shown else ""
            line += f"  failed at seed {shown}{more}"
        lines.append(line)
    failed = sweep.failed_runs()
    for key, seed, res in failed[:max_seeds_shown]:
        lines.append(f"  {res.verdict} {key} seed {seed}: {sweep.reproduce(key, seed)}")
    if len(failed) > max_seeds_shown:
        lines.append(f"  ... {len(failed) - max_seeds_shown} more failed runs in summary.json")
    return lines
