#!/usr/bin/env python3
"""Checks of the native host library that are not pytest: its cmocka tests' evidence, the seeded
bugs they (and the fuzz targets) must catch, and libFuzzer on its receive paths.

    python3 tests/host_c/check_host_c.py cmocka BINARY...       run the cmocka binaries (built by
                                                               mk/host_c.mk), JUnit XML and the record
                                                               build/evidence/cmocka-host_c.json
    python3 tests/host_c/check_host_c.py mutants [--only NAME]  every seeded bug of tests/host_c/mutants.json
                                                               must make each checker it names fail
                                                               (the cmocka tests; a fuzz target within
                                                               --mutant-seconds)
    python3 tests/host_c/check_host_c.py fuzz [--seconds 20]    both fuzz targets from their committed
                                                               corpus (tests/host_c/corpus/), then the
                                                               fuzz mutants; the proofs part "hostfuzz"
                                                               (build/proofs/hostfuzz/summary.json)

A mutant is a literal find/replace (its `occurrence`-th match) in one source under host/c, applied to a
copy under build/host_c/mutants/; a `find` that no longer matches is an error (exit 2), so a mutant
never goes stale silently. Exit status: 0 as expected, 1 a check failed or a mutant survived, 2 setup.
"""

from __future__ import annotations

import argparse
import hashlib
import importlib.util
import json
import shutil
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
HERE = ROOT / "tests" / "host_c"
BUILD = ROOT / "build" / "host_c"
sys.path.insert(0, str(ROOT / "report"))

from urb_report.records import Item, write_record  # noqa: E402

CORE = sorted(str(p.relative_to(ROOT)) for p in (ROOT / "host/c/core").glob("*.c"))
PORT = sorted(str(p.relative_to(ROOT)) for p in (ROOT / "host/c/port").glob("*.c"))
GEN = ["gen/c/urb_core.c", "gen/c/urb_runtime.c", "gen/c/urb_sensorhex.c"]
FIRMWARE = ["firmware/bridge/bridge.c", "firmware/bridge/bridge_uplink.c", "firmware/bridge/i2c_master.c",
            "firmware/hal/hosted/bridge_hosted.c", "firmware/hal/hosted/bridge_fake_i2c.c"]
TESTS = sorted(str(p.relative_to(ROOT)) for p in HERE.glob("*.c")
               if p.name != "core_shim.c" and not p.name.startswith("fuzz_"))
INCLUDES = ["host/c/include", "host/c/core", "gen/c", "firmware/include", "firmware/hal/hosted", "firmware/bridge"]
FUZZ_TARGETS = {"fuzz_host_rs232": [], "fuzz_host_usb": ["-DFUZZ_USB"]}
FUZZ_PROPERTIES = ("ASan/UBSan clean on any script of submissions, responses (right, corrupted, garbage, any "
                   "chunking or batch), time steps, losses, resets, drains and hand-overs; every request completes "
                   "exactly once; a response is matched only to a request carrying its sequence number")


class SetupError(Exception):
    """A compiler missing, a mutant whose find no longer matches."""


def _tool(name: str) -> Any:
    """tools/<name>.py as a module (run_fuzzer from fuzz.py, write_part from proofs.py)."""
    key = f"urb_tools_{name}"
    if key not in sys.modules:
        spec = importlib.util.spec_from_file_location(key, ROOT / "tools" / f"{name}.py")
        assert spec is not None and spec.loader is not None
        mod = importlib.util.module_from_spec(spec)
        sys.modules[key] = mod  # its dataclasses look their module up there
        spec.loader.exec_module(mod)
    return sys.modules[key]


def compile_(cmd: list[str]) -> None:
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    if proc.returncode != 0:
        raise SetupError(f"build failed:\n{' '.join(cmd)}\n{proc.stderr[-3000:]}")


def mutated_copy(m: dict[str, Any]) -> Path:
    """build/host_c/mutants/<name>/ holding host/c with the mutant applied."""
    dest: Path = BUILD / "mutants" / m["name"]
    if dest.exists():
        shutil.rmtree(dest)
    shutil.copytree(ROOT / "host" / "c", dest / "host" / "c")
    path = dest / m["file"]
    text = path.read_text(encoding="utf-8")
    occurrence = int(m.get("occurrence", 1))
    at = -1
    for _ in range(occurrence):
        at = text.find(m["find"], at + 1)
        if at < 0:
            raise SetupError(f"mutant {m['name']}: `{m['find']}` (occurrence {occurrence}) not found in {m['file']}; "
                             f"update tests/host_c/mutants.json")
    path.write_text(text[:at] + m["replace"] + text[at + len(m["find"]):], encoding="utf-8")
    return dest


def sources_from(root: Path, files: list[str]) -> list[str]:
    return [str(root / f) if f.startswith("host/") else str(ROOT / f) for f in files]


def includes_from(root: Path) -> list[str]:
    return [f"-I{root / i}" if i.startswith("host/") else f"-I{ROOT / i}" for i in INCLUDES]


TEST_FLAGS = ["gcc", "-std=c99", "-D_DEFAULT_SOURCE", "-g", "-O0"]
# As mk/host_c.mk links the cmocka binaries: test_loop_waits.c stands in for epoll_pwait2.
TEST_LIBS = ["-Wl,--wrap=epoll_pwait2", "-lcmocka", "-lutil", "-lpthread"]
FUZZ_FLAGS = ["clang", "-std=c99", "-g", "-O1", "-fsanitize=fuzzer,address,undefined", "-fno-sanitize-recover=all"]


def unmutated_objects(flags: list[str], files: list[str], out: Path, objects: dict[Path, Path]) -> list[Path]:
    """`files` compiled from the unmutated tree into `out`, each once per run (`objects` remembers
    them): a mutant then recompiles only its own file, and the 23 mutants cost one build plus 23
    small ones instead of 23 builds of the whole program."""
    paths = []
    for f in files:
        obj = out / (f.replace("/", "_").removesuffix(".c") + ".o")
        if obj not in objects:
            out.mkdir(parents=True, exist_ok=True)
            compile_([*flags, *includes_from(ROOT), "-c", str(ROOT / f), "-o", str(obj)])
            objects[obj] = obj
        paths.append(obj)
    return paths


def build_program(flags: list[str], files: list[str], libs: list[str], root: Path, out: Path, mutated: str,
                  objects: dict[Path, Path]) -> Path:
    """The program of `files` with `mutated` (a .c file of host/c) taken from `root`, the rest from
    the unmutated objects ("" : everything from `root`, for a mutant of a header)."""
    out.parent.mkdir(parents=True, exist_ok=True)
    if not mutated.endswith(".c") or mutated not in files:
        compile_([*flags, *includes_from(root), *sources_from(root, files), *libs, "-o", str(out)])
        return out
    where = BUILD / "objects" / hashlib.sha256(" ".join(flags).encode()).hexdigest()[:12]  # per compiler and flags
    kept = unmutated_objects(flags, [f for f in files if f != mutated], where, objects)
    compile_([*flags, *includes_from(root), str(root / mutated), *map(str, kept), *libs, "-o", str(out)])
    return out


def build_tests(root: Path, out: Path, mutated: str = "", objects: dict[Path, Path] | None = None) -> Path:
    return build_program(TEST_FLAGS, CORE + PORT + GEN + FIRMWARE + TESTS, TEST_LIBS, root, out,
                         mutated, {} if objects is None else objects)


def build_fuzz(root: Path, target: str, out: Path, mutated: str = "", objects: dict[Path, Path] | None = None) -> Path:
    if shutil.which("clang") is None:
        raise SetupError("clang not found: install clang and libclang-rt-14-dev (tools/setup.sh does)")
    return build_program([*FUZZ_FLAGS, *FUZZ_TARGETS[target]], ["tests/host_c/fuzz_host_core.c"] + CORE + GEN[:2], [],
                         root, out, mutated, {} if objects is None else objects)


def run_cmocka(binary: Path, xml_dir: Path | None = None) -> tuple[int, str]:
    env = {"CMOCKA_MESSAGE_OUTPUT": "stdout", "PATH": "/usr/bin:/bin"}
    if xml_dir is not None:
        xml_dir.mkdir(parents=True, exist_ok=True)
        env = {"CMOCKA_MESSAGE_OUTPUT": "xml", "CMOCKA_XML_FILE": str(xml_dir / "%g.xml"), "PATH": "/usr/bin:/bin"}
    proc = subprocess.run([str(binary)], capture_output=True, text=True, env=env, timeout=900)
    return proc.returncode, proc.stdout + proc.stderr


# ---------------------------------------------------------------------------------------------------
def cmd_cmocka(binaries: list[str]) -> int:
    items: list[Item] = []
    status = 0
    for binary in binaries:
        compiler = Path(binary).parent.name
        xml_dir = BUILD / "junit" / compiler
        for old in xml_dir.glob("*.xml"):
            old.unlink()
        code, _ = run_cmocka(Path(binary), xml_dir)
        status |= int(code != 0)
        for xml in sorted(xml_dir.glob("*.xml")):
            for suite in ET.parse(xml).getroot().iter("testsuite"):
                for case in suite.iter("testcase"):
                    failed = case.find("failure") is not None or case.find("error") is not None
                    items.append(Item(f"cmocka:{suite.get('name')}-{compiler}/{case.get('name')}", "test",
                                      "fail" if failed else "pass", expected="passes under ASan+UBSan",
                                      measured="failed" if failed else "passed", source="tests/host_c/",
                                      rerun=f"CMOCKA_MESSAGE_OUTPUT=stdout {binary}"))
    if not items:
        print("host_c cmocka: no results (the binaries did not write their XML)", file=sys.stderr)
        return 1
    write_record("cmocka", items, {"cmocka": "1.1", "compilers": "gcc, clang"}, name="cmocka-host_c")
    passed = sum(1 for i in items if i.verdict == "pass")
    print(f"host_c cmocka: {passed}/{len(items)} test runs passed ({', '.join(binaries)})")
    return status


def load_mutants(only: list[str]) -> list[dict[str, Any]]:
    mutants: list[dict[str, Any]] = json.loads((HERE / "mutants.json").read_text(encoding="utf-8"))
    for m in mutants:
        for key in ("name", "file", "find", "replace", "why", "caught_by"):
            if key not in m:
                raise SetupError(f"tests/host_c/mutants.json: mutant {m.get('name')!r} lacks {key!r}")
    return [m for m in mutants if not only or any(o in m["name"] for o in only)]


def fuzz_kills(binary: Path, target: str, seconds: int, log: Path) -> tuple[bool, str]:
    fz = _tool("fuzz")
    found = BUILD / "fuzz-mutants" / "found"
    shutil.rmtree(found, ignore_errors=True)
    code, stats, _ = fz.run_fuzzer(binary, found, HERE / "corpus" / target, seconds, log)
    text = log.read_text(encoding="utf-8", errors="replace")
    why = next((ln.strip() for ln in text.splitlines() if "fuzz_host_core:" in ln or "ERROR: " in ln), stats)
    return code != 0, why


def cmd_mutants(only: list[str], mutant_seconds: int, fuzz: bool) -> tuple[int, list[dict[str, Any]]]:
    rows: list[dict[str, Any]] = []
    status = 0
    items: list[Item] = []
    objects: dict[Path, Path] = {}
    for m in load_mutants(only):
        root = mutated_copy(m)
        for checker in m["caught_by"]:
            if checker.startswith("fuzz") != fuzz:
                continue
            start = time.monotonic()
            log = root / f"{checker}.log"
            if checker == "cmocka":
                code, out = run_cmocka(build_tests(root, root / "host-tests", m["file"], objects))
                log.write_text(out, encoding="utf-8")
                failed = sorted({ln.split("] ", 1)[1].strip() for ln in out.splitlines() if ln.startswith("[  FAILED  ] test_")})
                killed, why = code != 0, f"caught by {len(failed)} test(s): {', '.join(failed)[:150]}"
            else:
                killed, why = fuzz_kills(build_fuzz(root, checker, root / checker, m["file"], objects), checker,
                                         mutant_seconds, log)
            status |= int(not killed)
            print(f"mutant {m['name']} [{checker}]: {'caught' if killed else 'SURVIVED'} ({why})")
            kind = "fuzz-mutant" if checker.startswith("fuzz") else "cmocka-mutant"
            name = f"{checker}/{m['name']}" if checker.startswith("fuzz") else f"host_c/{m['name']}"
            items.append(Item(f"{kind}:{name}", "mutant", "pass" if killed else "fail", expected=f"caught: {m['why']}",
                              measured=why, source=m["file"],
                              rerun=f"python3 tests/host_c/check_host_c.py mutants --only {m['name']}"))
            rows.append({"function": f"{checker} [mutant {m['name']}]", "tool": "libFuzzer" if fuzz else "cmocka",
                         "properties": m["why"], "bound": f"{mutant_seconds} s" if fuzz else "all tests",
                         "result": "killed" if killed else "SURVIVED", "expected": killed,
                         "time_s": round(time.monotonic() - start, 1), "detail": why})
    if items:
        write_record("fuzz" if fuzz else "mutants", items, {"host_c": "tests/host_c/mutants.json"},
                     name="fuzz-mutants-host_c" if fuzz else "cmocka-mutants-host_c")
    return status, rows


def cmd_fuzz(seconds: int, mutant_seconds: int) -> int:
    fz = _tool("fuzz")
    rows: list[dict[str, Any]] = []
    items: list[Item] = []
    status = 0
    for target in FUZZ_TARGETS:
        binary = build_fuzz(ROOT, target, BUILD / "fuzz" / target / target)
        start = time.monotonic()
        code, stats, numbers = fz.run_fuzzer(binary, BUILD / "fuzz" / target / "found", HERE / "corpus" / target, seconds,
                                    BUILD / "fuzz" / target / "fuzz.log")
        ok = code == 0
        status |= int(not ok)
        print(f"{target}: {'no failure' if ok else 'FAILED'} in {seconds} s ({stats})")
        rows.append({"function": target, "tool": "libFuzzer", "properties": FUZZ_PROPERTIES, "bound": f"{seconds} s",
                     "result": "no failure" if ok else "FAILED", "expected": ok,
                     "time_s": round(time.monotonic() - start, 1), "detail": stats})
        items.append(Item(f"fuzz:{target}", "fuzz", "pass" if ok else "fail", expected="no failure",
                          measured=stats, source="tests/host_c/fuzz_host_core.c",
                          rerun=f"python3 tests/host_c/check_host_c.py fuzz --seconds {seconds}", data=numbers))
    write_record("fuzz", items, {"libFuzzer": "clang 14"}, name="fuzz-host_c", seed=1)
    mstatus, mrows = cmd_mutants([], mutant_seconds, fuzz=True)
    rows += mrows
    _tool("proofs").write_part("hostfuzz", rows)  # build/proofs/hostfuzz/: summary.json, junit.xml
    return status | mstatus


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("cmocka")
    c.add_argument("binaries", nargs="+")
    mu = sub.add_parser("mutants")
    mu.add_argument("--only", action="append", default=[])
    mu.add_argument("--mutant-seconds", type=int, default=60)
    mu.add_argument("--fuzz", action="store_true", help="the fuzz targets' mutants instead of the cmocka ones")
    f = sub.add_parser("fuzz")
    f.add_argument("--seconds", type=int, default=20)
    f.add_argument("--mutant-seconds", type=int, default=60)
    args = ap.parse_args(argv)
    try:
        if args.cmd == "cmocka":
            return cmd_cmocka(args.binaries)
        if args.cmd == "mutants":
            status, rows = cmd_mutants(args.only, args.mutant_seconds, args.fuzz)
            if not rows:
                print("no mutant matched", file=sys.stderr)
                return 2
            print(f"host_c mutants: {sum(1 for r in rows if r['expected'])}/{len(rows)} caught")
            return status
        return cmd_fuzz(args.seconds, args.mutant_seconds)
    except SetupError as exc:
        print(f"check_host_c: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
