"""One sweep, three ways to run it, one hash (issue #40; urb_sim.tasks, urb_sim.sweep): local worker
processes, deterministic shards merged afterwards, and a Dask cluster on loopback that the test
starts and stops. The hash covers every record (checks, verdicts, figures) and not their order; the
merge refuses shards that are missing, doubled, changed or from another sweep."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import pytest

from urb.cli import main
from urb_sim import loopback, sweep, tasks
from urb_sim.experiments import no_progress

KEYS = ["fig16", "fig16@paper"]  # the default profile and another: the key carries the profile
SEEDS = [1, 22]


@pytest.fixture(scope="module")
def local(tmp_path_factory: pytest.TempPathFactory) -> sweep.Sweep:
    out = tmp_path_factory.mktemp("local")
    return sweep.run_sweep(KEYS, SEEDS, out, quick=True, jobs=1, keep=False, progress=no_progress)


def test_the_hash_covers_every_record_and_not_their_order(local: sweep.Sweep) -> None:
    records = local.records
    assert len(records) == len(KEYS) * len(SEEDS) and all(r["verdict"] == "PASS" for r in records)
    assert tasks.merged_hash(list(reversed(records))) == local.hash
    slower = [dict(r, wall_s=r["wall_s"] + 5) for r in records]
    assert tasks.merged_hash(slower) == local.hash  # wall time is not a result
    timed = [dict(r, table=[dict(row, **{"TLC wall s": 1.0 + i}) for row in r["table"]]) for i, r in enumerate(records)]
    assert tasks.merged_hash(timed) == local.hash  # nor a wall-time column of its table (traces' TLC seconds)
    changed = json.loads(json.dumps(records))
    changed[0]["checks"][0]["measured"] += " "
    assert tasks.merged_hash(changed) != local.hash  # any measured value is


def test_shards_merge_to_the_local_hash(local: sweep.Sweep, tmp_path: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    shards = []
    for k in (1, 2):
        out = tmp_path / f"node{k}"
        assert main(["sim", "sweep", "--seeds", ",".join(map(str, SEEDS)), "--only", "fig16", "--profiles",
                     "cortex-m0plus,paper", "--quick", "--jobs", "1", "--shard", f"{k}/2", "--out", str(out),
                     "--no-progress"]) == 0
        shards.append(sweep.shard_path(out, k, 2))
    part = json.loads(shards[0].read_text())
    assert [(r["key"], r["seed"]) for r in part["records"]] == [("fig16", 1), ("fig16@paper", 1)]  # every 2nd
    merged = tmp_path / "merged"
    capsys.readouterr()
    assert main(["sim", "merge", *map(str, reversed(shards)), "--out", str(merged)]) == 0
    assert f"hash of all records: {local.hash}" in capsys.readouterr().out
    assert json.loads((merged / "summary.json").read_text())["hash"] == local.hash
    # 4 per run (the last: the run repeated on the other host library agrees), and the paper profile's Fig. 16 target
    checks = sum(len(r["checks"]) for r in local.records)
    assert (merged / "checks.csv").read_text().count("\n") == 1 + checks and checks == 2 * 4 + 2 * 5


def test_the_merge_refuses_shards_it_cannot_trust(local: sweep.Sweep, tmp_path: Path) -> None:
    specs = tasks.plan(KEYS, SEEDS)
    by_key = {(r["key"], r["seed"]): r for r in local.records}

    def write(k: int, n: int, name: str, records: list[dict[str, Any]] | None = None) -> Path:
        path = tmp_path / name
        chosen = records if records is not None else [by_key[(s.key, s.seed)] for s in tasks.shard(specs, k, n)]
        tasks.write_shard(path, chosen, k=k, n=n, keys=KEYS, seeds=SEEDS, quick=True)
        return path

    one, two = write(1, 2, "a.json"), write(2, 2, "b.json")
    assert tasks.merged_hash(tasks.merge([one, two])[1]) == local.hash
    with pytest.raises(tasks.MergeError, match=r"missing \[2\]"):
        tasks.merge([one])
    with pytest.raises(tasks.MergeError, match=r"given twice \[1\]"):
        tasks.merge([one, one, two])
    with pytest.raises(tasks.MergeError, match="belongs to another sweep"):
        tasks.merge([one, write(2, 3, "c.json")])
    tampered = json.loads(two.read_text())
    tampered["records"][0]["verdict"] = "FAIL"
    (tmp_path / "d.json").write_text(json.dumps(tampered))
    with pytest.raises(tasks.MergeError, match="do not give the hash it states"):
        tasks.merge([one, tmp_path / "d.json"])
    short = write(2, 2, "e.json", [by_key[("fig16", 22)]])
    with pytest.raises(tasks.MergeError, match="1 task\\(s\\) missing from the shards: fig16@paper seed 22"):
        tasks.merge([one, short])
    first = [by_key[(s.key, s.seed)] for s in tasks.shard(specs, 1, 2)] + [by_key[("fig16", 22)]]
    other = dict(by_key[("fig16", 22)], verdict="FAIL")
    with pytest.raises(tasks.MergeError, match="fig16 at seed 22 differs between shards"):
        tasks.merge([write(1, 2, "f.json", first), write(2, 2, "g.json", [other, by_key[("fig16@paper", 22)]])])
    with pytest.raises(tasks.MergeError, match="not a shard file"):
        (tmp_path / "h.json").write_text("{}")
        tasks.merge([tmp_path / "h.json"])


def test_a_sweep_on_a_loopback_dask_cluster_gives_the_local_hash(local: sweep.Sweep, tmp_path: Path) -> None:
    t0 = time.perf_counter()
    with loopback.cluster(workers=2) as address:
        on_cluster = sweep.run_sweep(KEYS, SEEDS, tmp_path, quick=True, jobs=1, keep=False, progress=no_progress,
                                     scheduler=address)
    assert on_cluster.hash == local.hash
    assert [(r["key"], r["seed"]) for r in on_cluster.records] == [(s.key, s.seed) for s in tasks.plan(KEYS, SEEDS)]
    assert json.loads((tmp_path / "summary.json").read_text())["hash"] == local.hash
    print(f"loopback Dask sweep: {len(on_cluster.records)} runs, {time.perf_counter() - t0:.1f} s with the cluster")


def test_an_unreachable_scheduler_is_a_clear_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    address = f"tcp://127.0.0.1:{loopback.free_port()}"
    assert main(["sim", "sweep", "--seeds", "1", "--only", "fig16", "--quick", "--scheduler", address, "--out",
                 str(tmp_path), "--no-progress", "--connect-timeout", "2"]) == 2
    assert f"cannot reach the Dask scheduler at {address}" in capsys.readouterr().err


def test_a_bad_shard_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "sweep", "--seeds", "1", "--only", "fig16", "--shard", "3/2"]) == 2
    assert "--shard '3/2': write K/N with 1 <= K <= N" in capsys.readouterr().err
