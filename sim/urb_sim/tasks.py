"""One (experiment, seed, profile) task, its record, and the backends that run many (issue #40).

`run_task` runs one task in this process and returns its record: a JSON-able dict with the task's
key, seed and settings and every acceptance check (name, required, measured, passed), its verdict,
deviations and simulated seconds. Wall times are kept apart (`wall_s`) and left out of the digest.
Every backend ends in the same records: the local process pool (`runner.run_tasks`, whose Results
`record` turns into records), deterministic shards (`shard`: task i belongs to shard i mod N, so a
Slurm job array or a CI matrix runs the same sweep without any engine) and Dask distributed
(`run_dask`: `run_task` on the cluster's workers).

Records merge by key, (key, seed). The sweep's hash is order-independent: the SHA-256 of the
sorted lines "<key> <seed> <digest of the record>", so one sweep run locally, in shards or on a
cluster has one hash; `merge` refuses shards that overlap, disagree, or leave tasks out.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .experiments import Check, Progress, Result

#: A shard file's format (urb sim sweep --shard K/N writes it, urb sim merge reads it).
SHARD_SCHEMA = "urb-sim-shard/1"


class MergeError(ValueError):
    """Shards that cannot be merged into one sweep; the message says which and why."""


def record(result: Result, *, seed: int, quick: bool, wall_s: float | None = None) -> dict[str, Any]:
    """The record of one task's Result."""
    from .runner import split_key

    name, profile = split_key(result.key)
    return {"key": result.key, "experiment": name, "profile": profile, "seed": seed, "quick": quick,
            "title": result.title, "paper": result.paper, "verdict": result.verdict,
            "checks": [{"name": c.name, "required": c.required, "measured": c.measured, "passed": c.passed}
                       for c in result.checks],
            "deviations": list(result.deviations), "table": _plain(result.table),
            "sim_s": round(result.sim_s, 6), "wall_s": round(result.wall_s if wall_s is None else wall_s, 3)}


def _plain(rows: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Table rows as JSON values (numbers, strings), for the record and its digest."""
    return json.loads(json.dumps(list(rows), default=str))  # type: ignore[no-any-return]


def result_of(rec: Mapping[str, Any]) -> Result:
    """A Result with a record's checks and figures (no files: they stay where the task ran)."""
    res = Result(str(rec["key"]), str(rec["title"]), str(rec["paper"]),
                 checks=[Check(str(c["name"]), str(c["required"]), str(c["measured"]), bool(c["passed"]))
                         for c in rec["checks"]],
                 table=list(rec.get("table", [])), deviations=list(rec["deviations"]))
    res.sim_s, res.wall_s = float(rec["sim_s"]), float(rec["wall_s"])
    return res


def digest(rec: Mapping[str, Any]) -> str:
    """SHA-256 of a record without its wall times (its wall_s, and every table column whose name says
    "wall", as traces' "TLC run wall s"): what the same task gives anywhere, byte for byte."""
    kept: dict[str, Any] = {k: v for k, v in rec.items() if k != "wall_s"}
    kept["table"] = [{k: v for k, v in row.items() if "wall" not in k} for row in rec.get("table", [])]
    return hashlib.sha256(json.dumps(kept, sort_keys=True, separators=(",", ":")).encode()).hexdigest()


def merged_hash(records: Iterable[Mapping[str, Any]]) -> str:
    """The order-independent hash of a sweep's records."""
    lines = sorted(f"{r['key']} {r['seed']} {digest(r)}" for r in records)
    return hashlib.sha256("\n".join(lines).encode()).hexdigest()


@dataclass(frozen=True)
class Spec:
    """One task to run: experiment key (with its profile), seed."""

    key: str
    seed: int


def plan(keys: Sequence[str], seeds: Sequence[int]) -> list[Spec]:
    """A sweep's tasks in their one deterministic order: by key as given, then seed."""
    return [Spec(k, s) for k in keys for s in seeds]


def parse_shard(text: str) -> tuple[int, int]:
    """"K/N" -> (K, N), 1 <= K <= N; raises ValueError saying what is wrong."""
    k_text, slash, n_text = text.partition("/")
    try:
        k, n = int(k_text), int(n_text)
    except ValueError:
        k, n = 0, 0
    if not slash or not 1 <= k <= n:
        raise ValueError(f"--shard {text!r}: write K/N with 1 <= K <= N, e.g. 2/8 for the second of eight shards "
                         "(a Slurm array passes $SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT)")
    return k, n


def shard(specs: Sequence[Spec], k: int, n: int) -> list[Spec]:
    """The tasks of shard k of n (1-based): every n-th task of the plan, starting at the k-th."""
    return [s for i, s in enumerate(specs) if i % n == k - 1]


def run_task(key: str, seed: int, quick: bool, out: str) -> dict[str, Any]:
    """Run one task in this process, writing its files under out/runs/seed-N/, and return its record.
    What a Dask worker runs (the module is imported there: the workers need this checkout, or an
    installed urb_sim, and its simulation library)."""
    from .runner import run_one
    from .sweep import run_dir

    res = run_one(key, run_dir(Path(out), seed), quick=quick, seed=seed, progress=lambda frac, msg: None)
    return record(res, seed=seed, quick=quick)


def run_dask(specs: Sequence[Spec], *, scheduler: str, quick: bool, out: Path, progress: Progress,
             connect_timeout_s: float = 30.0) -> list[dict[str, Any]]:
    """Run `specs` on the Dask cluster at `scheduler` (tcp://HOST:PORT) with run_task; records in
    the order of `specs`. A task whose worker failed is an ERROR record naming the exception."""
    try:
        from distributed import Client, as_completed
    except ImportError as exc:  # the dev extra installs it
        raise RuntimeError("--scheduler needs Dask distributed: pip install -c constraints.txt -e .[dev]") from exc
    try:
        client = Client(scheduler, timeout=connect_timeout_s)  # type: ignore[no-untyped-call]  # default client
    except OSError as exc:
        raise RuntimeError(f"cannot reach the Dask scheduler at {scheduler}: {exc}; start one with "
                           "`dask scheduler` and workers with `dask worker ADDRESS` (sim/README.md)") from exc
    records: dict[int, dict[str, Any]] = {}
    try:
        if not client.scheduler_info()["workers"]:
            try:
                client.wait_for_workers(1, timeout=connect_timeout_s)
            except TimeoutError as exc:
                raise RuntimeError(f"no Dask worker joined the scheduler at {scheduler} within {connect_timeout_s:g} s: "
                                   "start some with `dask worker ADDRESS --nthreads 1`") from exc
        threaded = {w: info.get("nthreads", 1) for w, info in client.scheduler_info()["workers"].items()
                    if info.get("nthreads", 1) != 1}
        if threaded:
            raise RuntimeError(f"Dask workers with more than one thread ({', '.join(sorted(threaded))}): start them "
                               "with `dask worker ADDRESS --nthreads 1 --nworkers N` (an experiment draws with "
                               "matplotlib, which is not thread-safe)")
        futures = {client.submit(run_task, s.key, s.seed, quick, str(out), pure=False,
                                 key=f"urb-sim-{s.key}-{s.seed}-{os.getpid()}-{i}"): i
                   for i, s in enumerate(specs)}
        for done, fut in enumerate(as_completed(list(futures)), 1):  # type: ignore[no-untyped-call]
            i = futures[fut]
            try:
                records[i] = fut.result()
            except Exception as exc:  # noqa: BLE001 - the task's ERROR, the others go on
                from .runner import crashed

                records[i] = record(crashed(specs[i].key, out, exc), seed=specs[i].seed, quick=quick)
            progress(done / len(specs), f"{specs[i].key} seed {specs[i].seed}: {records[i]['verdict']}")
    finally:
        client.close()  # type: ignore[no-untyped-call]
    return [records[i] for i in range(len(specs))]


def write_shard(path: Path, records: Sequence[Mapping[str, Any]], *, k: int, n: int, keys: Sequence[str],
                seeds: Sequence[int], quick: bool) -> None:
    """One shard's records with what defines its sweep (keys, seeds, quick, N), for `merge`."""
    path.parent.mkdir(parents=True, exist_ok=True)
    doc = {"schema": SHARD_SCHEMA, "shard": k, "shards": n, "keys": list(keys), "seeds": list(seeds), "quick": quick,
           "hash": merged_hash(records), "records": list(records)}
    path.write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")


def merge(paths: Sequence[Path]) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """The sweep of shard files: (its definition, every record in plan order). Raises MergeError when
    a file is not a shard, the shards belong to different sweeps, one is missing or given twice, a
    shard's records do not match its own hash, or a task is missing."""
    docs = []
    for p in paths:
        try:
            doc = json.loads(Path(p).read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError) as exc:
            raise MergeError(f"{p}: not a readable shard file ({exc})") from exc
        if not isinstance(doc, dict) or doc.get("schema") != SHARD_SCHEMA:
            raise MergeError(f"{p}: not a shard file of `urb sim sweep --shard` ({SHARD_SCHEMA})")
        if merged_hash(doc["records"]) != doc["hash"]:
            raise MergeError(f"{p}: its records do not give the hash it states: the file was changed or truncated")
        docs.append((p, doc))
    if not docs:
        raise MergeError("no shard files given")
    first = docs[0][1]
    define = {k: first[k] for k in ("shards", "keys", "seeds", "quick")}
    for p, doc in docs[1:]:
        other = {k: doc[k] for k in define}
        if other != define:
            raise MergeError(f"{p} belongs to another sweep than {docs[0][0]} (shards, experiments, seeds or --quick "
                             "differ): merge the shards of one sweep")
    got = sorted(doc["shard"] for _, doc in docs)
    if got != list(range(1, define["shards"] + 1)):
        missing = sorted(set(range(1, define["shards"] + 1)) - set(got))
        twice = sorted({k for k in got if got.count(k) > 1})
        raise MergeError(f"shards of {define['shards']}: " + (f"missing {missing}" if missing else "")
                         + ("; " if missing and twice else "") + (f"given twice {twice}" if twice else ""))
    by_key: dict[tuple[str, int], dict[str, Any]] = {}
    for p, doc in docs:
        for rec in doc["records"]:
            key = (rec["key"], rec["seed"])
            if key in by_key and digest(by_key[key]) != digest(rec):
                raise MergeError(f"{rec['key']} at seed {rec['seed']} differs between shards")
            by_key[key] = rec
    specs = plan(define["keys"], define["seeds"])
    absent = [f"{s.key} seed {s.seed}" for s in specs if (s.key, s.seed) not in by_key]
    if absent:
        raise MergeError(f"{len(absent)} task(s) missing from the shards: {', '.join(absent[:5])}")
    return define, [by_key[(s.key, s.seed)] for s in specs]


def results_of(records: Sequence[Mapping[str, Any]]) -> dict[tuple[str, int], Result]:
    """(key, seed) -> Result, for the sweep's tables."""
    return {(str(r["key"]), int(r["seed"])): result_of(r) for r in records}
