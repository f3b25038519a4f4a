"""TLC runs of trace validation (urb_sim.tracecheck): all the traces in one run.

A trace module of sim/tla (TraceBridge.tla, ...) takes its trace and the constants of the
specification it extends as CONSTANTS. `check_jobs()` writes a module, TraceBatch, that
instantiates the trace modules once per trace with that trace's values (T1, T2, ...), and whose
initial states pick the trace: a variable t, never changed by a step, so that the traces' state
spaces are disjoint and TLC explores them side by side in one breadth-first search, with each
instance's invariants checked on its own states (a trace's states hold a placeholder in the
variables of the other specifications). One JVM instead of one per trace: JVM start, class loading
and parsing the specifications cost about 0.9 s of CPU per run, more than most traces' search (the
28 traces of `urb sim sensorhex`: 16 CPU s in one run, 38 in 28).

The verdicts stay per trace. TLC checks the invariants once on every new (distinct) state, and
invariant Visited prints each one's trace and matched prefix, <<"visited", t, l - 1>>: a trace's
state count is its number of lines (the "distinct states found" of a run of its own), its matched
prefix their largest l - 1, and it is accepted when that is its whole length
(tests/sim/test_trace_batch.py compares both). A violated invariant of a specification stops the
whole run: then no trace gets a verdict (TraceCheckError, naming the trace whose state violated it).
"""

from __future__ import annotations

import re
import shutil
import subprocess
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from .build import REPO, unpreloaded_env
from .tlc import JVM_QUICK, TlcSetupError, class_archive, find_jar, find_java

SPEC = REPO / "spec" / "tla"
TRACE_SPEC = REPO / "sim" / "tla"


class TraceCheckError(RuntimeError):
    """TLC could not be run (no Java, no tla2tools.jar; the message says what to install) or did not
    finish its check (killed, out of memory, an error in a specification): then the trace is neither
    accepted nor rejected."""


@dataclass
class TraceResult:
    """The verdict on one trace. `seconds`: wall time of the TLC run that checked it, shared by the
    `batch` traces of that run."""

    accepted: bool
    events: int
    matched_prefix: int
    states: int | None
    seconds: float
    message: str
    batch: int = 1


@dataclass
class TraceJob:
    """One trace to check against sim/tla/<spec>.tla: its constants (name -> TLA+ expression of
    constant level, for every constant of the trace module and of the specification it extends),
    its events, and a name for error messages."""

    spec: str
    constants: dict[str, str]
    events: Sequence[object]
    name: str = ""


@dataclass(frozen=True)
class TraceSpec:
    """What a trace module's run checks: the module of spec/tla it extends, that module's invariants
    (checked on every state) and its constants that are TLC model values (the same in every trace)."""

    base: str
    invariants: tuple[str, ...]
    model_values: tuple[str, ...] = ()


TRACE_SPECS = {
    "TraceBridge": TraceSpec("Bridge", ("TypeOK", "NoSilentDrop", "AtMostOneResponse", "ResponsesInRequestOrder",
                                        "ResponseMatchesRequest", "ErrorNamesCause", "WriteStatusTruthful",
                                        "BusyOnlyWhenFull", "BoundedMemory")),
    "TraceOutbox": TraceSpec("MailboxOutbox", ("TypeOK", "AppLockExclusive", "IsrReadNotTorn", "IsrReadFresh")),
    "TraceInbox": TraceSpec("MailboxInbox", ("TypeOK", "AppLockExclusive", "AppReadNotTorn", "AppReadFresh",
                                             "NoAbortedDelivered")),
    "TraceUsbUplink": TraceSpec("UsbUplink", ("TypeOK", "NothingLost", "ResponsesMatched", "LatencyBound")),
    "TraceDiscovery": TraceSpec("Discovery", ("TypeOK", "NeverMerged", "DuplicatesReported", "MismatchReported",
                                              "NoPhantoms", "VanishedNodesKept", "StableNodesFound",
                                              "VanishedGetNoNode"), model_values=("NONE",)),
}

#: The batch module's own names: its trace variable and definitions (a specification's variable of
#: the same name would clash).
TRACE_VAR = "t"
_OWN_NAMES = {TRACE_VAR, "BatchInit", "BatchNext", "Visited"}

_VISITED_RE = re.compile(r'^<<"visited", (\d+), (\d+)>>$', re.M)


def find_tlc() -> tuple[str, Path]:
    """java and tla2tools.jar, found as tools/modelcheck.py finds them (urb_sim.tlc)."""
    try:
        return find_java(), find_jar()
    except TlcSetupError as exc:
        raise TraceCheckError(str(exc)) from exc


def declared_variables(text: str) -> list[str]:
    """The variables a TLA+ module declares (VARIABLE / VARIABLES, comments skipped), in order."""
    text = re.sub(r"\(\*.*?\*\)", " ", text, flags=re.S)
    text = re.sub(r"\\\*[^\n]*", " ", text)
    out: list[str] = []
    for m in re.finditer(r"\bVARIABLES?\b((?:\s*\w+\s*,)*\s*\w+)", text):
        out += [v.strip() for v in m.group(1).split(",")]
    return out


def _variables(spec: str) -> list[str]:
    base = TRACE_SPECS[spec].base
    return (declared_variables((SPEC / f"{base}.tla").read_text())
            + declared_variables((TRACE_SPEC / f"{spec}.tla").read_text()))


#: The value of a variable that trace k's specification does not have, in its states.
UNUSED = '"unused"'


def batch_module(jobs: Sequence[TraceJob]) -> tuple[str, str]:
    """The module TraceBatch that checks `jobs` in one TLC run, and its TLC configuration. Its
    variables are those of every specification of `jobs` (a trace's states hold UNUSED in the
    others') and t, the trace."""
    specs = list(dict.fromkeys(job.spec for job in jobs))
    own = {spec: _variables(spec) for spec in specs}
    variables = list(dict.fromkeys(v for spec in specs for v in own[spec]))
    clash = _OWN_NAMES & set(variables)
    if clash:
        raise TraceCheckError(f"a module of sim/tla or spec/tla declares a variable named {', '.join(sorted(clash))}, "
                              "a name urb_sim/tracebatch.py's batch module uses: rename one")
    model_values = list(dict.fromkeys(v for spec in specs for v in TRACE_SPECS[spec].model_values))
    invariants = list(dict.fromkeys(inv for spec in specs for inv in TRACE_SPECS[spec].invariants))
    lines = ["---- MODULE TraceBatch ----", "EXTENDS Naturals, Sequences, TLC"]
    if model_values:
        lines.append("CONSTANTS " + ", ".join(model_values))
    lines.append("VARIABLES " + ", ".join([*variables, TRACE_VAR]))
    init, nxt = [], []
    for k, job in enumerate(jobs, 1):
        names = sorted(job.constants)
        # named definitions of constant level: TLC evaluates each once, before the search
        lines += [f"C{k}_{n} == {job.constants[n]}" for n in names]
        lines.append(f"T{k} == INSTANCE {job.spec} WITH " + ", ".join(f"{n} <- C{k}_{n}" for n in names))
        unused = [v for v in variables if v not in own[job.spec]]
        init.append(f"({TRACE_VAR} = {k} /\\ T{k}!TraceInit" + "".join(f" /\\ {v} = {UNUSED}" for v in unused) + ")")
        nxt.append(f"({TRACE_VAR} = {k} /\\ T{k}!TraceNext /\\ {TRACE_VAR}' = {k}"
                   + (f" /\\ UNCHANGED <<{', '.join(unused)}>>" if unused else "") + ")")
    lines.append("BatchInit == " + "\n    \\/ ".join(init))
    lines.append("BatchNext == " + "\n    \\/ ".join(nxt))
    lines.append(f'Visited == PrintT(<<"visited", {TRACE_VAR}, l - 1>>)')
    for inv in invariants:
        arms = [f"{TRACE_VAR} = {k} -> T{k}!{inv}" for k, job in enumerate(jobs, 1)
                if inv in TRACE_SPECS[job.spec].invariants]
        lines.append(f"{inv} == CASE " + " [] ".join(arms) + " [] OTHER -> TRUE")
    lines += ["====", ""]
    cfg = [f"CONSTANTS {' '.join(f'{v} = {v}' for v in model_values)}"] if model_values else []
    cfg += ["INIT BatchInit", "NEXT BatchNext", f"INVARIANTS Visited {' '.join(invariants)}", ""]
    return "\n".join(lines), "\n".join(cfg)


def _tlc(jobs: Sequence[TraceJob]) -> tuple[str, float]:
    """Run TLC on the batch module of `jobs` until it has explored every state: (TLC's output,
    seconds). Anything else (TLC killed, out of memory, an error in a specification, an invariant
    of the specification violated on the way) raises TraceCheckError: the traces are then neither
    accepted nor rejected, and a crashed check can never count as a rejected mutant."""
    java, jar = find_tlc()
    module, cfg = batch_module(jobs)
    specs = list(dict.fromkeys(job.spec for job in jobs))
    with tempfile.TemporaryDirectory(prefix="urb-trace-") as tmp_s:
        tmp = Path(tmp_s)
        for f in SPEC.glob("*.tla"):
            shutil.copy2(f, tmp / f.name)
        for spec in specs:
            shutil.copy2(TRACE_SPEC / f"{spec}.tla", tmp / f"{spec}.tla")
        (tmp / "TraceBatch.tla").write_text(module)
        (tmp / "TraceBatch.cfg").write_text(cfg)
        # Each trace explores a few thousand states at most: a quick JVM (as for modelcheck's mutants;
        # measured on the 28 traces of `urb sim sensorhex`, C2 as well costs 1.5x the CPU).
        with class_archive(java, jar) as cds:
            cmd = [java, *JVM_QUICK, *cds, f"-Djava.io.tmpdir={tmp}", "-cp", str(jar), "tlc2.TLC", "-deadlock",
                   "-workers", "1", "-config", "TraceBatch.cfg", "-metadir", str(tmp / "meta"), "TraceBatch.tla"]
            t0 = time.monotonic()
            proc = subprocess.run(cmd, cwd=tmp, capture_output=True, text=True, check=False, env=unpreloaded_env())
            dt = time.monotonic() - t0
    log = proc.stdout + proc.stderr
    if proc.returncode == 0 and "No error has been found" in log:
        return log, dt
    how = f"killed by signal {-proc.returncode}" if proc.returncode < 0 else f"exit status {proc.returncode}"
    errors = [ln for ln in log.splitlines() if ln.startswith("Error") or "is violated" in ln]
    semantic = log.split("*** Errors:", 1)[1].split("\n\n\n", 1)[0].split("\n", 1)[-1] if "*** Errors:" in log else ""
    if semantic.strip():  # SANY's first complaint (where, and what) says more than "Parsing ... failed"
        errors.insert(0, " ".join(semantic.split()))
    which = re.search(rf"^/\\ {TRACE_VAR} = (\d+)$", log, re.M)
    where = ""
    if which is not None and 1 <= int(which.group(1)) <= len(jobs):
        k = int(which.group(1))
        job = jobs[k - 1]
        where = f" in trace {k} of {len(jobs)} ({job.spec}{f': {job.name}' if job.name else ''})"
    raise TraceCheckError(f"TLC did not finish checking {len(jobs)} trace(s) against "
                          f"{', '.join(f'sim/tla/{s}.tla' for s in specs)} ({how}){where}: "
                          + (errors[0] if errors else log[-500:].strip() or "no output")
                          + ". The traces are neither accepted nor rejected; run the check again, and if it fails "
                          "the same way, fix the specification or give TLC more memory.")


def check_jobs(jobs: Sequence[TraceJob]) -> list[TraceResult]:
    """Check every trace of `jobs` in one TLC run; the results in the order of `jobs`. A full match
    violates no invariant (TLC would print the whole trace as its counterexample): TLC explores
    every state the traces allow, and a trace is accepted when one of its states has matched all
    its events; a rejected one says how far it matched."""
    for job in jobs:
        if job.spec not in TRACE_SPECS:
            raise ValueError(f"no trace module {job.spec}: one of {', '.join(TRACE_SPECS)}")
    if not jobs:
        return []
    log, dt = _tlc(jobs)
    states = [0] * len(jobs)
    matched = [0] * len(jobs)
    for m in _VISITED_RE.finditer(log):
        k, n = int(m.group(1)) - 1, int(m.group(2))
        states[k] += 1
        matched[k] = max(matched[k], n)
    out = []
    for job, count, got in zip(jobs, states, matched):
        n = len(job.events)
        if got == n:
            out.append(TraceResult(True, n, got, count, dt, "every event matched", len(jobs)))
        else:
            out.append(TraceResult(False, n, got, count, dt,
                                   f"TLC found no behaviour matching the whole trace; the trace matches up to event "
                                   f"{got} of {n} (next: {job.events[got]})", len(jobs)))
    return out
