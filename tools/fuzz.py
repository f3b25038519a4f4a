#!/usr/bin/env python3
"""Fuzz the C decoders, the bridge's uplink side and a node with libFuzzer, for a bounded time.

    python3 tools/fuzz.py run [--seconds 20]   build, fuzz every target from its committed corpus,
                                              then show each seeded mutant is caught (make fuzz)
    python3 tools/fuzz.py run --no-mutants --seconds 600 --target fuzz_decoders   a longer session
    python3 tools/fuzz.py merge               add the inputs the last run found that reach new
                                              coverage to tests/fuzz/corpus/ (then commit them)
    python3 tools/fuzz.py seed                rewrite the seed inputs from tests/vectors/*.json

Targets live in tests/fuzz/<target>.c (what each checks: tests/fuzz/README.md), built with clang
-fsanitize=fuzzer,address,undefined. A run starts from tests/fuzz/corpus/<target>/ (read only) and
writes what it finds to build/fuzz/<target>/found/. -seed is fixed, but a run bounded by time is not
reproducible input for input, so a mutant the fuzzer finds slowly keeps its reproducer in the
corpus (tests/fuzz/README.md).

Mutants (tests/fuzz/mutants.json) are seeded bugs, either a -D flag the firmware already knows
(URB_MUTANT_*) or a find/replace on a copy of the sources; the fuzzer must crash on each within
its time limit, else the run fails: a fuzzer that cannot find a planted bug proves little. Each
names its "kind" of bug (off-by-one, wrong-order, missing-publish-or-free, wrong-field,
dropped-error, other) for the mutation table.

Outputs: build/proofs/fuzz/summary.json and junit.xml (the proofs summary merges them), and the
evidence record build/evidence/fuzz.json (report/urb_report/records.py: items fuzz:<target> with
the inputs run, time, corpus size and seed, fuzz-mutant:<target>/<mutant> with its kind); a run of
only some targets or without mutants writes its record to build/fuzz/partial/fuzz.json instead.
Exit status: 0 all as expected, 1 a target crashed or a mutant survived, 2 setup problem.
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
FUZZ_DIR = ROOT / "tests" / "fuzz"
CORPUS = FUZZ_DIR / "corpus"
BUILD = ROOT / "build" / "fuzz"
OUT = ROOT / "build" / "proofs" / "fuzz"
CLANG = "clang"
CFLAGS = ["-std=c99", "-g", "-O1", "-fsanitize=fuzzer,address,undefined", "-fno-sanitize-recover=all"]
SEED = 1  # libFuzzer's -seed: fixes the mutation order, not the inputs a timed run reaches
LIBFUZZER_FLAGS = [f"-seed={SEED}", "-timeout=10", "-rss_limit_mb=2048", "-print_final_stats=1"]
MUTANT_KINDS = ("off-by-one", "wrong-order", "missing-publish-or-free", "wrong-field", "dropped-error", "other")
GEN = ["gen/c/urb_runtime.c", "gen/c/urb_core.c", "gen/c/urb_sensorhex.c", "gen/c/urb_can_wire.c", "gen/c/urb_rs485_wire.c"]


@dataclass(frozen=True)
class Target:
    name: str
    includes: tuple[str, ...]
    sources: tuple[str, ...]
    properties: str


TARGETS = {
    t.name: t
    for t in (
        Target(
            "fuzz_decoders",
            ("gen/c", "gen/c/test"),
            ("tests/fuzz/fuzz_decoders.c", *GEN, "gen/c/test/urb_test_support.c"),
            "ASan/UBSan clean on any bytes; an accepted frame re-encodes to the same bytes; "
            "CRC byte-wise == buffer",
        ),
        Target(
            "fuzz_bridge_uplink",
            ("firmware/include", "gen/c", "firmware/hal/hosted", "firmware/bridge"),
            (
                "tests/fuzz/fuzz_bridge_uplink.c",
                "firmware/bridge/bridge.c",
                "firmware/bridge/bridge_uplink.c",
                "firmware/bridge/i2c_master.c",
                *GEN,
                "firmware/hal/hosted/bridge_hosted.c",
                "firmware/hal/hosted/bridge_fake_i2c.c",
            ),
            "ASan/UBSan clean on any RS232 stream, USB transfer and node fault script; the bridge "
            "settles; every admitted request is answered",
        ),
        Target(
            "fuzz_node",
            ("firmware/include", "gen/c", "firmware/hal/hosted", "firmware/node"),
            (
                "tests/fuzz/fuzz_node.c",
                "firmware/node/urb_node.c",
                "firmware/node/urb_mailbox.c",
                "firmware/node/urb_i2c.c",
                "firmware/node/urb_pll.c",
                "firmware/node/urb_observe.c",
                *GEN,
                "firmware/hal/hosted/urb_hal_hosted.c",
            ),
            "ASan/UBSan clean on any configuration, bus event and application script; every ACK/NACK, "
            "committed message and read-back value as the mailbox models say",
        ),
        Target(
            "fuzz_can",
            ("firmware/include", "gen/c", "tests/firmware/can", "tests/firmware/dl_common", "tests/fuzz"),
            (
                "tests/fuzz/fuzz_can.c",
                "tests/firmware/can/can_bus.c",
                "tests/firmware/dl_common/fake_mailbox.c",
                "firmware/downlink/can/urb_can_transfer.c",
                "firmware/downlink/can/urb_can_master.c",
                "firmware/downlink/can/urb_can_slave.c",
                *GEN,
            ),
            "ASan/UBSan clean on any script of CAN transactions, injected frames, bus faults and bus-off; "
            "mailbox calling rules kept; every outcome in time, named by the contract and truthful",
        ),
        Target(
            "fuzz_rs485",
            ("firmware/include", "gen/c", "tests/firmware/dl_common", "tests/fuzz"),
            (
                "tests/fuzz/fuzz_rs485.c",
                "tests/firmware/dl_common/fake_mailbox.c",
                "firmware/downlink/rs485/urb_rs485_frame.c",
                "firmware/downlink/rs485/urb_rs485_master.c",
                "firmware/downlink/rs485/urb_rs485_slave.c",
                *GEN,
            ),
            "ASan/UBSan clean on any script of RS485 polls, babbling, corrupted bytes and stalls; "
            "mailbox calling rules kept; every outcome in time, named by the contract and truthful",
        ),
    )
}


class SetupError(Exception):
    """clang or libFuzzer missing, a mutant that no longer applies."""


@dataclass
class Row:
    function: str
    properties: str
    bound: str
    result: str
    expected: bool
    time_s: float
    detail: str
    #: for the evidence record: the target, the mutant (with its kind), what the run measured
    target: str = ""
    mutant: dict[str, Any] | None = None
    stats: dict[str, Any] | None = None

    def as_json(self) -> dict[str, Any]:
        return {
            "function": self.function,
            "tool": "libFuzzer",
            "properties": self.properties,
            "bound": self.bound,
            "result": self.result,
            "expected": self.expected,
            "time_s": round(self.time_s, 1),
            "detail": self.detail,
        }


def build(target: Target, out: Path, src_root: Path = ROOT, defines: tuple[str, ...] = ()) -> Path:
    """Compiles `target` from the sources under src_root into `out`; returns the binary."""
    if shutil.which(CLANG) is None:
        raise SetupError("clang not found: install clang and libclang-rt-14-dev (tools/setup.sh does)")
    out.parent.mkdir(parents=True, exist_ok=True)
    cmd = [CLANG, *CFLAGS, *defines]
    cmd += [f"-I{src_root / inc}" for inc in target.includes]
    cmd += [str(src_root / s) for s in target.sources]
    cmd += ["-o", str(out)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise SetupError(f"building {target.name} failed:\n{' '.join(cmd)}\n{proc.stderr[-3000:]}")
    return out


def run_fuzzer(binary: Path, found: Path, corpus: Path, seconds: int, log: Path) -> tuple[int, str, dict[str, Any]]:
    """Runs libFuzzer for `seconds` from `corpus` (read only), new inputs into `found`.
    Returns the exit code, the final statistics line and the same as numbers (inputs run, edges,
    corpus inputs, new inputs found)."""
    found.mkdir(parents=True, exist_ok=True)
    cmd = [
        str(binary),
        f"-max_total_time={seconds}",
        *LIBFUZZER_FLAGS,
        f"-artifact_prefix={found.parent}/",
        str(found),
        str(corpus),
    ]
    with log.open("w", encoding="utf-8") as f:
        proc = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT, timeout=seconds + 120)
    text = log.read_text(encoding="utf-8", errors="replace")
    runs = re.findall(r"stat::number_of_executed_units:\s*(\d+)", text)
    cov = re.findall(r"cov: (\d+)", text)
    stats = f"{runs[-1] if runs else '?'} runs, coverage {cov[-1] if cov else '?'} edges"
    numbers: dict[str, Any] = {"inputs_run": int(runs[-1]) if runs else None, "edges": int(cov[-1]) if cov else None,
                               "corpus_inputs": sum(1 for _ in corpus.iterdir()) if corpus.is_dir() else 0,
                               "new_inputs": sum(1 for _ in found.iterdir()), "max_total_time_s": seconds,
                               "seed": SEED}
    return proc.returncode, stats, numbers


def apply_mutant(mutant: dict[str, Any], dest: Path) -> Path:
    """A copy of the sources the mutant touches, under dest, with its find/replace applied once."""
    if dest.exists():
        shutil.rmtree(dest)
    for folder in ("gen", "firmware", "tests/fuzz"):
        shutil.copytree(ROOT / folder, dest / folder)
    path = dest / mutant["file"]
    text = path.read_text(encoding="utf-8")
    if text.count(mutant["find"]) < 1:
        raise SetupError(f"mutant {mutant['name']}: `{mutant['find']}` not found in {mutant['file']}; update tests/fuzz/mutants.json")
    path.write_text(text.replace(mutant["find"], mutant["replace"], 1), encoding="utf-8")
    return dest


def load_mutants() -> list[dict[str, Any]]:
    mutants: list[dict[str, Any]] = json.loads((FUZZ_DIR / "mutants.json").read_text(encoding="utf-8"))
    for m in mutants:
        if m["target"] not in TARGETS:
            raise SetupError(f"mutant {m['name']}: unknown target {m['target']}")
        if ("define" in m) == ("find" in m):
            raise SetupError(f"mutant {m['name']}: give either `define` or `file`/`find`/`replace`")
        if m.get("kind") not in MUTANT_KINDS:
            raise SetupError(f"mutant {m['name']}: give its \"kind\", one of {', '.join(MUTANT_KINDS)} "
                             "(tests/fuzz/mutants.json)")
    return mutants


def fuzz_targets(names: list[str], seconds: int) -> list[Row]:
    rows = []
    for name in names:
        t = TARGETS[name]
        binary = build(t, BUILD / name / name)
        start = time.monotonic()
        code, stats, numbers = run_fuzzer(binary, BUILD / name / "found", CORPUS / name, seconds, BUILD / name / "fuzz.log")
        ok = code == 0
        rows.append(
            Row(
                name,
                t.properties,
                f"{seconds} s from {len(list((CORPUS / name).iterdir()))} corpus inputs",
                "pass" if ok else "CRASH",
                ok,
                time.monotonic() - start,
                stats if ok else f"{stats}; reproducer and log in {BUILD / name}",
                target=name,
                stats=numbers,
            )
        )
        print(f"{'ok  ' if ok else 'FAIL'} {name:<20} {rows[-1].result:<6} {rows[-1].time_s:6.1f} s  {stats}", flush=True)
    return rows


def fuzz_mutants(mutants: list[dict[str, Any]], seconds: int) -> list[Row]:
    rows = []
    for m in mutants:
        t = TARGETS[m["target"]]
        work = BUILD / "mutants" / m["name"]
        if "define" in m:
            binary = build(t, work / t.name, defines=(f"-D{m['define']}",))
        else:
            binary = build(t, work / t.name, apply_mutant(m, work / "src"))
        start = time.monotonic()
        found = work / "found"
        if found.exists():
            shutil.rmtree(found)
        code, stats, numbers = run_fuzzer(binary, found, CORPUS / t.name, seconds, work / "fuzz.log")
        killed = code != 0
        rows.append(
            Row(
                f"{t.name} mutant {m['name']}",
                m["why"],
                f"{seconds} s",
                "killed" if killed else "SURVIVED",
                killed,
                time.monotonic() - start,
                stats,
                target=t.name,
                mutant=m,
                stats=numbers,
            )
        )
        print(f"{'ok  ' if killed else 'FAIL'} {t.name} mutant {m['name']:<22} {rows[-1].result:<8} {rows[-1].time_s:6.1f} s", flush=True)
    return rows


def write_results(rows: list[Row]) -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "summary.json").write_text(
        json.dumps({"part": "fuzz", "rows": [r.as_json() for r in rows]}, indent=2) + "\n", encoding="utf-8"
    )
    suite = ET.Element(
        "testsuite",
        name="fuzz",
        tests=str(len(rows)),
        failures=str(sum(not r.expected for r in rows)),
        time=f"{sum(r.time_s for r in rows):.1f}",
    )
    for r in rows:
        case = ET.SubElement(suite, "testcase", classname="fuzz", name=r.function, time=f"{r.time_s:.1f}")
        if not r.expected:
            ET.SubElement(case, "failure", message=r.result).text = r.detail
    root = ET.Element("testsuites")
    root.append(suite)
    ET.ElementTree(root).write(OUT / "junit.xml", encoding="utf-8", xml_declaration=True)


def evidence_items(rows: list[Row]) -> list[dict[str, Any]]:
    """The evidence items of a run: fuzz:<target> and fuzz-mutant:<target>/<mutant> (records.Item fields)."""
    items: list[dict[str, Any]] = []
    for r in rows:
        data: dict[str, Any] = {"result": r.result, "time_s": round(r.time_s, 1), **(r.stats or {})}
        if r.mutant is None:
            items.append({"id": f"fuzz:{r.target}", "kind": "fuzz", "verdict": "pass" if r.expected else "fail",
                          "expected": "no crash: " + r.properties, "measured": f"{r.result}: {r.detail}",
                          "source": f"tests/fuzz/{r.target}.c",
                          "rerun": f"python3 tools/fuzz.py run --target {r.target} --no-mutants --seconds "
                                   f"{(r.stats or {}).get('max_total_time_s', 20)}",
                          "data": data})
        else:
            m = r.mutant
            items.append({"id": f"fuzz-mutant:{r.target}/{m['name']}", "kind": "mutant",
                          "verdict": "pass" if r.expected else "fail", "expected": "killed: the fuzzer crashes",
                          "measured": f"{r.result} ({r.detail})", "source": "tests/fuzz/mutants.json",
                          "rerun": f"python3 tools/fuzz.py run --target {r.target}",
                          "data": {**data, "kind": m["kind"], "why": m["why"],
                                   "change": m.get("define") or f"{m['file']}: {m['find']} -> {m['replace']}"}})
    return items


def write_evidence(rows: list[Row], complete: bool, config: dict[str, Any]) -> Path:
    """build/evidence/fuzz.json for a run of every target with its mutants, else build/fuzz/partial/fuzz.json."""
    from urb_report.records import Item, command_version, write_record

    tools = {"clang": command_version([CLANG, "--version"]), "clang flags": " ".join(CFLAGS),
             "libFuzzer flags": " ".join(["-max_total_time=<seconds>", *LIBFUZZER_FLAGS])}
    return write_record("fuzz", [Item(**kw) for kw in evidence_items(rows)], tools, config=config, seed=SEED,
                        out_dir=None if complete else BUILD / "partial")


def message_table() -> list[tuple[str, int]]:
    """Name and implicit-prefix size of each entry of the generated codec table, in table order."""
    text = (ROOT / "gen" / "c" / "test" / "urb_test_support.c").read_text(encoding="utf-8")
    return [(m.group(1), int(m.group(2))) for m in re.finditer(r'\{"(\w+)", sizeof\(\w+\), (\d+)u,', text)]


def seed(corpus: Path = CORPUS) -> int:
    """Seed inputs: every hand-derived vector as a decoder input, and bridge scripts that send
    well-formed requests on both uplinks, garbage, idle gaps and node faults."""
    table = message_table()
    index = {name: i for i, (name, _) in enumerate(table)}
    out = corpus / "fuzz_decoders"
    out.mkdir(parents=True, exist_ok=True)
    for old in out.glob("seed-*"):
        old.unlink()
    count = 0
    for path in sorted((ROOT / "tests" / "vectors").glob("*.json")):
        if path.name == "errors.json":
            continue
        for k, v in enumerate(json.loads(path.read_text(encoding="utf-8"))):
            i = index[v["message"]]
            prefix = b""
            if table[i][1]:
                sel = v["implicit"]["select"]
                prefix = bytes([sel["mailbox"] | (0x80 if sel.get("read") else 0)])
            (out / f"seed-{path.stem}-{k:02d}-{v['message']}").write_bytes(bytes([i]) + prefix + bytes.fromhex(v["hex"]))
            count += 1
    scripts = {
        # conf: FIFO depth 2, heartbeat on; RS232 read of node 0x10 outbox 1 (6 bytes), a write to
        # its inbox 1, then the same over USB (seq bit 7), garbage bytes, an idle gap, a USB frame.
        "rs232-read-write": bytes([0x11, 6, 0x10, 1, 6, 3, 7, 0x10, 1, 4, 4, 1 | 8 * 4]),
        "usb-read-write": bytes([0x11, 6, 0x10, 1, 6, 0x83, 7, 0x11, 1, 32, 0x85, 3, 3, 3]),
        "garbage-then-read": bytes([0x0F, 0, 0x43, 0, 0x31, 0, 0x06, 1 | 8 * 10, 6, 0x10, 1, 6, 2, 1 | 8 * 2]),
        "faults": bytes([0x10, 5, 0x0B, 6, 0x10, 1, 6, 1, 5, 0x41, 6, 0x10, 0, 25, 2, 4 | 8 * 31]),
        "fill-fifo": bytes([0x00, *([6, 0x11, 1, 32, 5] * 6), 7, 0x11, 1, 32, 6, 4 | 8 * 31]),
        "usb-small-in-buffer": bytes([0x1F, *([6, 0x91, 1, 32, 0x81] * 3), 4 | 8 * 31, 3 | 8 * 2, 3, 3]),
        "bridge-self": bytes([0x1F, 6, 0x00, 0, 10, 1, 6, 0x00, 1, 16, 2, 7, 0x00, 0, 3, 3, 4 | 8 * 20]),
        # the longest request (a write of 32 bytes to node 0x11's inbox 1) and one behind it: over
        # USB (seq bit 7), then on a quiet RS232 line (seq bit 6); both must be admitted
        "long-write-usb": bytes([0x11, 7, 0x11, 1, 32, 0x85, 6, 0x11, 1, 32, 0x86, 3, 4 | 8 * 31]),
        "long-write-rs232": bytes([0x11, 7, 0x11, 1, 32, 0x45, 6, 0x11, 1, 32, 0x46, 4 | 8 * 31]),
    }
    out = corpus / "fuzz_bridge_uplink"
    out.mkdir(parents=True, exist_ok=True)
    for old in out.glob("seed-*"):
        old.unlink()
    for name, data in scripts.items():
        (out / f"seed-{name}").write_bytes(data)
    print(f"seeded {count} decoder inputs and {len(scripts)} bridge scripts")
    return 0


def merge() -> int:
    """Adds the inputs of the last run that reach new coverage to the committed corpus."""
    for name, t in TARGETS.items():
        found = BUILD / name / "found"
        if not found.is_dir():
            print(f"{name}: no run to merge (run `python3 tools/fuzz.py run` first)")
            continue
        binary = build(t, BUILD / name / name)
        before = len(list((CORPUS / name).iterdir()))
        subprocess.run([str(binary), "-merge=1", str(CORPUS / name), str(found)], capture_output=True, check=True)
        after = len(list((CORPUS / name).iterdir()))
        print(f"{name}: corpus {before} -> {after} inputs")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="tools/fuzz.py",
        description="Bounded libFuzzer runs of the C decoders, the bridge uplink and a node (tests/fuzz/README.md).",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="fuzz every target, then check each seeded mutant is caught")
    run.add_argument("--seconds", type=int, default=20, help="fuzzing time per target (default 20)")
    run.add_argument("--mutant-seconds", type=int, default=60, help="time limit to catch each mutant (default 60)")
    run.add_argument("--target", action="append", choices=sorted(TARGETS), help="only this target (repeatable)")
    run.add_argument("--no-mutants", action="store_true", help="skip the mutant check")
    sub.add_parser("merge", help="add new-coverage inputs of the last run to tests/fuzz/corpus/")
    sub.add_parser("seed", help="rewrite the seed inputs from tests/vectors/")
    args = parser.parse_args(argv)
    try:
        if args.command == "seed":
            return seed()
        if args.command == "merge":
            return merge()
        names = args.target or sorted(TARGETS)
        rows = fuzz_targets(names, args.seconds)
        if not args.no_mutants:
            rows += fuzz_mutants([m for m in load_mutants() if m["target"] in names], args.mutant_seconds)
        write_results(rows)
        complete = set(names) == set(TARGETS) and not args.no_mutants
        record = write_evidence(rows, complete, {"seconds": args.seconds, "mutant_seconds": args.mutant_seconds,
                                                 "targets": names, "mutants": not args.no_mutants})
        print(f"fuzz: evidence record {record}")
    except SetupError as e:
        print(f"fuzz: {e}", file=sys.stderr)
        return 2
    bad = [r for r in rows if not r.expected]
    print(f"fuzz: {len(rows) - len(bad)}/{len(rows)} as expected; results in {OUT}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
