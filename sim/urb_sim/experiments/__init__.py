"""The paper's experiments (Sec. VI) on the simulated SensoRHex buses.

Each experiment is a function (`fig15`, `fig16`, `table1`, `figs18_19`, `fig20`, `bandwidth`,
`faults`, `traces`) with the signature `(out: Path, *, quick: bool, seed: int, progress: Progress)`
that writes its CSV and PNG into `out` and returns a `Result` stating pass/fail against its
acceptance criterion. `quick=True` runs fewer samples (the test suite); the criterion is the same.
"""

from __future__ import annotations

import csv
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

#: progress(done_fraction, message)
Progress = Callable[[float, str], None]


def no_progress(fraction: float, message: str) -> None:
    """A Progress that ignores everything."""


@dataclass
class Check:
    """One acceptance check: what was required, what was measured, and whether it held."""

    name: str
    required: str
    measured: str
    passed: bool


#: An experiment run at base seed s builds its simulated worlds from seeds s .. s + SEED_SPAN - 1
#: (table1's runs s .. s + 19, one per fault scenario, the trace recordings up to s + 20): runs at
#: base seeds this far apart or more share no world (tests/sim/test_experiments.py checks the span).
SEED_SPAN = 21

#: The check of an experiment that raised instead of returning (sim/urb_sim/runner.py).
RAN_TO_COMPLETION = "ran to completion"


@dataclass
class Result:
    """What an experiment produced."""

    key: str
    title: str
    paper: str
    checks: list[Check] = field(default_factory=list)
    files: list[Path] = field(default_factory=list)
    table: list[dict[str, Any]] = field(default_factory=list)
    #: further tables with their own columns, each (caption, rows), shown after `table`
    tables: list[tuple[str, list[dict[str, Any]]]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    #: results that do not reproduce the paper, each saying what the paper states and what the
    #: simulation found: the simulation does worse than the paper states, or a capability the paper
    #: claims does not hold. A criterion may still pass (the gait is checked at the 500 Hz that
    #: fits, not at the paper's 1 kHz); the report's headline names every one.
    deviations: list[str] = field(default_factory=list)
    wall_s: float = 0.0
    sim_s: float = 0.0

    @property
    def passed(self) -> bool:
        return bool(self.checks) and all(c.passed for c in self.checks)

    @property
    def verdict(self) -> str:
        """PASS; FAIL (a criterion not met); ERROR (the experiment raised: a bug, not a measurement)."""
        if self.passed:
            return "PASS"
        return "ERROR" if any(c.name == RAN_TO_COMPLETION for c in self.checks) else "FAIL"

    def check(self, name: str, required: str, measured: str, passed: bool) -> bool:
        self.checks.append(Check(name, required, measured, bool(passed)))
        return bool(passed)


def write_csv(path: Path, header: Sequence[str], rows: Iterable[Sequence[object]]) -> Path:
    """Write rows with a header line; returns the path."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        for r in rows:
            w.writerow(r)
    return path


def pyplot() -> Any:
    """matplotlib.pyplot with the non-interactive backend (figures are files, never windows)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def profile_targets(res: Result, figures: dict[str, tuple[float, float]], runs: int = 0) -> None:
    """The active hardware profile's targets for the metrics in `figures` (metric -> (average, max)),
    each from `runs` runs (0: as many as the paper's): each required one becomes a check of `res`,
    each other one a deviation when it is missed (sim/profiles: a profile calibrated to the paper
    states how closely it reproduces each figure, a tolerance that may come from the paper's spread
    and depend on the number of runs)."""
    from .. import profiles

    prof = profiles.active()
    if prof is None:
        return
    for t in prof.targets:
        if t.metric not in figures:
            continue
        av, mx = figures[t.metric]
        value = av if t.statistic == "average" else mx
        unit = profiles.TARGET_METRICS[t.metric]
        n = runs or t.paper_runs
        ref, tol = t.reference(n), t.tolerance_for(n)
        what = f"{prof.name} profile reproduces the paper's {t.metric} {t.statistic}"
        basis = (f"the paper's {t.statistic} {t.paper:g}" if ref == t.paper else
                 f"the paper's runs' spread predicts {ref:.3g} for the largest of {n} runs (its max of "
                 f"{t.paper_runs}: {t.paper:g})")
        how = (f"{t.tolerance_sds:g} sd of the difference, from the paper's spread over {t.paper_runs} runs and our "
               f"{n}" if t.tolerance_sds else "calibration")
        required = f"{ref:.3g} +- {tol:.2g} {unit} ({basis}; {how}; sim/profiles)"
        if t.required:
            res.check(what, required, f"{value:.3f} {unit}", t.holds(value, n))
        elif not t.holds(value, n):
            res.deviations.append(f"{res.title.split(':')[0]} under the {prof.name} profile: {t.metric} {t.statistic} "
                                  f"{value:.3f} {unit}, not {ref:.3g} +- {tol:.2g} ({basis}): {t.why}")
