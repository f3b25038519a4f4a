#!/usr/bin/env python3
"""The SensoRHex experiments on a build of the simulation with AddressSanitizer and
UndefinedBehaviorSanitizer.

The proofs cover the firmware's entry points one at a time; this runs all of it together, with the
simulation HALs and the world that drive it, through the experiments' scenarios and every fault
the faults experiment injects (bit errors, stuck lines, power loss, bridge reset, babbling node,
uplink byte loss). An access out of bounds, a use after free, a signed overflow, an invalid shift...
stops the experiment with the sanitizer's report, which this prints.

The sanitized build (-O1, no link-time optimisation) must also give the same trace as the normal
one (-O3, LTO): the same trace hash for bench/sim_speed.py --fingerprint. A difference would mean
the results depend on how the code was compiled: an uninitialised read, undefined behaviour that
the optimiser exploits differently, or floating-point contraction.

Leaks are checked apart: Python's own blocks at exit would drown LeakSanitizer's report, so
tests/sim/world_leaks.c, a C program linked against the sanitized library, builds, runs and frees
worlds through every allocating call of sim/world/urbsim.h (SensoRHex with every fault, a downlink
with more nodes than it takes, a world never started), and LeakSanitizer must find nothing left.

It then shows that each check can fail: with a seeded off-by-one in the ring of marks the HALs log
(URBSIM_MUTANT_LOG_WRAP in firmware/hal/sim/sim_log.h) the sanitizer must report an error; with a
babbling node that urbsim_free forgets (URBSIM_MUTANT_LEAK_BABBLER in sim/world/world.c)
LeakSanitizer must report a leak; with a sequence number read from memory that the two builds fill
differently (URBSIM_MUTANT_UNINIT_SEQ in sim/world/native_host.c) the two builds' traces must
differ.

    python3 tools/sim_sanitized.py                      # all: `make test-sim-san`, in `make check`
    python3 tools/sim_sanitized.py --only fig20,faults  # the clean run of some experiments only
    python3 tools/sim_sanitized.py --no-mutant          # the clean runs only

Exit status 0 when the clean runs pass with no sanitizer report and the three seeded bugs are caught;
1 otherwise (the reports and the experiments' verdicts say why); 2 when a build fails.
The experiments' report of each run is in build/sim/san/<run>/, its error output (with the
sanitizers' reports) in build/sim/san/<run>.stderr; the leak check's in build/sim/san/leaks*.stderr.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "sim"))

from urb_sim.build import BUILD, CC, SANITIZE_FLAGS, BuildError, sanitizer_preload, unpreloaded_env  # noqa: E402
from urb_sim.runner import select  # noqa: E402

OUT = BUILD / "san"
#: The seeded bug, and the experiment that runs long enough for the mark log to wrap.
MUTANT, MUTANT_EXPERIMENT = "LOG_WRAP", "fig20"
#: The leak check's program, and the seeded leak it must report.
LEAK_PROGRAM, LEAK_MUTANT = REPO / "tests" / "sim" / "world_leaks.c", "LEAK_BABBLER"
#: The seeded bug that makes the optimised and the sanitized build simulate different things.
TRACE_MUTANT = "UNINIT_SEQ"
#: What a sanitizer report starts with (UBSan: "<file>:<line>:<col>: runtime error: ...").
REPORT_MARKS = ("runtime error:", "ERROR: AddressSanitizer", "ERROR: LeakSanitizer")


def _env(*, sanitized: bool, mutant: str | None = None, loads: bool = False) -> dict[str, str]:
    """This process's environment with the library variant chosen (build.py reads URBSIM_*);
    `loads`: for a process that loads the sanitized library (runtimes preloaded, reports on)."""
    env = {k: v for k, v in unpreloaded_env().items() if k not in ("URBSIM_SANITIZE", "URBSIM_MUTANT")}
    if sanitized:
        env["URBSIM_SANITIZE"] = "1"
    if mutant is not None:
        env["URBSIM_MUTANT"] = mutant
    if sanitized and loads:
        env["LD_PRELOAD"] = sanitizer_preload()
        # Python's own allocations at exit are not ours to judge: no leak check. (log_path is not
        # used: UBSan combined with ASan ignores it, so the reports are taken from the error output.)
        env["ASAN_OPTIONS"] = "detect_leaks=0"
        env["UBSAN_OPTIONS"] = "print_stacktrace=1:halt_on_error=1"
    return env


def build(mutant: str | None, sanitized: bool = True) -> None:
    """Build the sanitized (or optimised) library, with the seeded bug `mutant`, if it is stale."""
    proc = subprocess.run([sys.executable, "-m", "urb_sim.build"], env=_env(sanitized=sanitized, mutant=mutant),
                          cwd=REPO, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise BuildError(proc.stdout + proc.stderr)


def run(name: str, experiments: list[str], mutant: str | None) -> tuple[int, list[str]]:
    """Run `urb sim sensorhex --quick --only experiments` on the sanitized build; returns its exit
    status and the first line of each sanitizer report it printed (its whole error output, which
    the workers share, is echoed and kept in build/sim/san/<name>.stderr)."""
    out = OUT / name
    shutil.rmtree(out, ignore_errors=True)
    env = _env(sanitized=True, mutant=mutant, loads=True)
    cmd = [sys.executable, "-m", "urb", "sim", "sensorhex", "--quick", "--no-progress", "--out", str(out),
           "--only", ",".join(experiments)]
    print(f"$ URBSIM_SANITIZE=1{f' URBSIM_MUTANT={mutant}' if mutant else ''} {' '.join(cmd[1:])}", flush=True)
    proc = subprocess.run(cmd, env=env, cwd=REPO, stderr=subprocess.PIPE, text=True, errors="replace", check=False)
    sys.stderr.write(proc.stderr)
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / f"{name}.stderr").write_text(proc.stderr, encoding="utf-8")
    return proc.returncode, [line for line in proc.stderr.splitlines() if any(m in line for m in REPORT_MARKS)]


def leak_program(mutant: str | None) -> Path:
    """Build tests/sim/world_leaks.c against the sanitized library (with the seeded bug `mutant`),
    into build/sim/san/leaks[-mutant-NAME]."""
    library = BUILD / ("san" + (f"-mutant-{mutant}" if mutant else "")) / "liburbsim.so"
    program = OUT / ("leaks" + (f"-mutant-{mutant}" if mutant else ""))
    OUT.mkdir(parents=True, exist_ok=True)
    cmd = [CC, "-std=c99", "-g", "-Wall", "-Wextra", "-Werror", "-Wpedantic", *SANITIZE_FLAGS,
           f"-I{REPO / 'sim' / 'world'}", str(LEAK_PROGRAM), str(library), f"-Wl,-rpath,{library.parent}", "-o",
           str(program)]
    proc = subprocess.run(cmd, env=unpreloaded_env(), capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise BuildError(" ".join(cmd) + "\n" + proc.stdout + proc.stderr)
    return program


def run_leak_program(program: Path) -> tuple[int, list[str]]:
    """Run a leak check program with LeakSanitizer on; returns its exit status and the first line
    of each report (its error output is echoed and kept in build/sim/san/<program>.stderr)."""
    env = {**unpreloaded_env(), "ASAN_OPTIONS": "detect_leaks=1",
           "UBSAN_OPTIONS": "print_stacktrace=1:halt_on_error=1"}
    print(f"$ {program.relative_to(REPO)}", flush=True)
    proc = subprocess.run([str(program), str(program.with_suffix(".ndjson"))], env=env, cwd=REPO,
                          capture_output=True, text=True, errors="replace", check=False)
    sys.stdout.write(proc.stdout)
    sys.stderr.write(proc.stderr)
    program.with_suffix(".stderr").write_text(proc.stderr, encoding="utf-8")
    return proc.returncode, [line for line in proc.stderr.splitlines() if any(m in line for m in REPORT_MARKS)]


def fingerprint(sanitized: bool, mutant: str | None = None) -> str:
    """bench/sim_speed.py --fingerprint on the normal or the sanitized build (with the seeded bug
    `mutant`): its one-line answer."""
    proc = subprocess.run([sys.executable, str(REPO / "bench" / "sim_speed.py"), "--fingerprint"],
                          env=_env(sanitized=sanitized, mutant=mutant, loads=True), cwd=REPO, capture_output=True,
                          text=True, check=False)
    if proc.returncode != 0:
        return f"(failed with exit status {proc.returncode}: {proc.stderr.strip()})"
    return proc.stdout.strip()


def answered(answer: str) -> bool:
    """The fingerprint run gave its answer (not a failure)."""
    return answer.startswith("fingerprint")


def clean(what: str, outcome: tuple[int, list[str]], stderr: Path, passed: str) -> bool:
    """Say whether a run that must end well with no sanitizer report did; True when it did."""
    status, reports = outcome
    if status == 0 and not reports:
        print(f"sim_sanitized: {passed}")
        return True
    print(f"sim_sanitized: FAIL: {what} ended with exit status {status} and {len(reports)} sanitizer report(s):",
          *reports, f"(the whole output is in {stderr})", sep="\n  ", file=sys.stderr)
    return False


def caught(mutant: str, outcome: tuple[int, list[str]], marks: tuple[str, ...], check: str) -> bool:
    """Say whether a run with the seeded bug `mutant` failed with a report starting with one of
    `marks`."""
    status, reports = outcome
    found = [line for line in reports if any(m in line for m in marks)]
    if status != 0 and found:
        print(f"sim_sanitized: seeded bug {mutant} caught: {found[0]}")
        return True
    print(f"sim_sanitized: FAIL: the seeded bug URBSIM_MUTANT_{mutant} was not reported (exit status {status}, "
          f"{len(reports)} report(s)): {check} no longer catches it", file=sys.stderr)
    return False


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--only", metavar="LIST", default=None,
                    help="comma-separated experiments for the clean run (default: all)")
    ap.add_argument("--no-mutant", action="store_true", help="skip the seeded-bug runs")
    args = ap.parse_args(argv)
    try:
        experiments = select(args.only)
    except ValueError as exc:
        print(f"sim_sanitized: {exc}", file=sys.stderr)
        return 2
    mutants = [] if args.no_mutant else [MUTANT, LEAK_MUTANT, TRACE_MUTANT]
    try:
        for mutant in [None, *mutants]:
            build(mutant)
        if not args.no_mutant:
            build(TRACE_MUTANT, sanitized=False)
        leaks = leak_program(None)
        seeded_leaks = None if args.no_mutant else leak_program(LEAK_MUTANT)
    except BuildError as exc:
        print(f"sim_sanitized: building the sanitized simulation failed:\n{exc}", file=sys.stderr)
        return 2

    ok = clean("the sanitized run", run("clean", experiments, None), OUT / "clean.stderr",
               f"{len(experiments)} experiment(s) ran under ASan+UBSan with no report")

    optimised, sanitized = fingerprint(False), fingerprint(True)
    if answered(optimised) and optimised == sanitized:
        print(f"sim_sanitized: the sanitized and the optimised build give the same trace: {sanitized}")
    else:
        ok = False
        print(f"sim_sanitized: FAIL: the builds give different traces:\n  optimised: {optimised}\n  sanitized: "
              f"{sanitized}", file=sys.stderr)

    ok = clean("the leak check", run_leak_program(leaks), leaks.with_suffix(".stderr"),
               "every world built, ran and freed by tests/sim/world_leaks.c gave all its memory back") and ok

    if seeded_leaks is not None:
        ok = caught(LEAK_MUTANT, run_leak_program(seeded_leaks), ("ERROR: LeakSanitizer",), "the leak check") and ok
        ok = caught(MUTANT, run(f"mutant-{MUTANT}", [MUTANT_EXPERIMENT], MUTANT),
                    ("runtime error:", "ERROR: AddressSanitizer"), "the sanitized run") and ok
        optimised, sanitized = fingerprint(False, TRACE_MUTANT), fingerprint(True, TRACE_MUTANT)
        if answered(optimised) and answered(sanitized) and optimised != sanitized:
            print(f"sim_sanitized: seeded bug {TRACE_MUTANT} caught: the builds give different traces "
                  f"({optimised.split(': ', 1)[1]} against {sanitized.split(': ', 1)[1]})")
        else:
            ok = False
            print(f"sim_sanitized: FAIL: the seeded bug URBSIM_MUTANT_{TRACE_MUTANT} was not caught: the comparison "
                  f"of the builds' traces no longer tells them apart\n  optimised: {optimised}\n  sanitized: "
                  f"{sanitized}", file=sys.stderr)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
