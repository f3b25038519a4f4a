"""Hardware profiles: the model's inputs as data, each value with its source (issue #40).

A profile (sim/profiles/<name>.toml) sets simulation parameters (sim/world/params.h, `urb sim
params`) to the values of one kind of hardware. Every value names where it comes from (a
datasheet and its section, the firmware's code, or "calibrated to the paper's Table I: fitted value
X, tolerance Y") and which experiments it affects; a value may instead come from the firmware's code
(`from_code`: a critical section of sim/profiles/critical_sections.json, measured by
urb_sim.critical). A profile with `[[target]]` entries states how closely its runs must reproduce
the paper (table1 checks them).

    [profile]
    title = "Cortex-M0+ at 48 MHz (STM32G0-class), conservative datasheet values"
    about = "..."

    [[assumption]]
    param = "node.irq_cycles"
    value = 15
    source = "ARM DDI 0484C (Cortex-M0+ TRM) 3.6.1: worst-case latency 15 cycles, zero wait states"
    affects = ["table1", "fig18_19"]

    [[target]]                     # the paper profile only
    metric = "internode_us"        # a Table I metric (TARGET_METRICS)
    statistic = "average"          # average | max of runs
    paper = 0.19
    tolerance = 0.06               # absolute, in the metric's unit; or, instead:
    # tolerance_sds = 2            # from the paper's spread: that many standard deviations of the
    # paper_runs = 20              # difference between its figure and ours (Target; the metric needs
                                   # both an average and a max-of-runs target)
    required = true                # false: reported (a deviation when missed), with `why`

The loader refuses what it cannot trust, with a message that says what to change: an unknown key,
an unknown parameter, a value without a source, a parameter set twice, a value outside its
physical range (RANGES), a bus outside UM10204's Fast-mode rise time, an unknown experiment.

While a profile is active (`applied`), every `World` created in that context starts from its
values; an experiment's own rig settings (`System(params=...)`) are applied after and win.
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
import math
import tomllib
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from .build import REPO

PROFILES_DIR = REPO / "sim" / "profiles"
#: The profile `urb sim sensorhex` runs every experiment under; item ids of the others carry theirs.
DEFAULT = "cortex-m0plus"
#: Experiments every profile runs in `urb sim sensorhex` (the default profile runs them all).
PROFILE_EXPERIMENTS = ("table1", "fig15", "fig16")
#: Metrics a target may name, with their unit: Table I's (table1: the per-run figures of sync.Run;
#: average = the mean of the runs', max of runs = the largest) and Fig. 16's round trip (fig16:
#: average = the mean over every read, max of runs = the slowest).
TABLE1_METRICS = {"convergence_ms": "ms", "internode_us": "us", "jitter_us": "us"}
TARGET_METRICS = {**TABLE1_METRICS, "fig16_ms": "ms"}
TARGET_STATISTICS = ("average", "max of runs")

#: Physical ranges a parameter's value must lie in (inclusive); parameters not listed need a finite
#: value >= 0.
RANGES: dict[str, tuple[float, float]] = {
    "node.cpu_hz": (1e6, 1e9), "bridge.cpu_hz": (1e6, 1e9),
    "node.ticks_per_us": (1, 1000),
    "node.irq_cycles": (0, 1000), "bridge.irq_cycles": (0, 1000),
    "node.irq_jitter_cycles": (0, 10000), "bridge.irq_jitter_cycles": (0, 10000),
    "node.flash_ws": (0, 15), "bridge.flash_ws": (0, 15),
    "node.vth_min": (0.05, 0.95), "node.vth_max": (0.05, 0.95),
    "node.ppm_mean": (-1e5, 1e5), "bridge.ppm_mean": (-1e5, 1e5), "cpu.ppm_mean": (-1e5, 1e5),
    "node.ppm_sd": (0, 1e5), "bridge.ppm_sd": (0, 1e5),
    "node.heartbeat_us": (100, 40000), "bridge.heartbeat_us": (0, 40000),
    "i2c.bus_pf": (0, 4000), "i2c.vdd": (1.0, 5.5), "i2c.sink_ma": (0.1, 100),
    "i2c.bitrate": (1e3, 3.4e6),
}
#: UM10204 (rev. 7) Table 10: SCL/SDA rise time (30 % to 70 %) at most 1000 ns in Standard-mode,
#: 300 ns in Fast-mode, 120 ns in Fast-mode Plus; a pull-up no smaller than (VDD - 0.4 V) / 3 mA
#: (Fast-mode V_OL at 3 mA), 20 mA in Fast-mode Plus.
T_RISE_NS = ((100e3, 1000.0), (400e3, 300.0), (1e6, 120.0))
ALLOWED = {"profile": {"title", "about"},
           "assumption": {"param", "value", "from_code", "source", "affects"},
           "target": {"metric", "statistic", "paper", "tolerance", "tolerance_sds", "paper_runs", "required", "why"}}


class ProfileError(ValueError):
    """A profile that cannot be used; the message names the file, the entry and what to change."""


@dataclass(frozen=True)
class Assumption:
    """One model input: a parameter, its value, where the value comes from, what it affects."""

    param: str
    value: float
    source: str
    affects: tuple[str, ...]
    from_code: str | None = None


@functools.lru_cache(maxsize=None)
def normal_max(n: int) -> tuple[float, float]:
    """Mean and standard deviation of the largest of n independent standard normal draws (n >= 1),
    by numerical integration of n phi(x) Phi(x)^(n-1)."""
    step, lo = 0.001, -9.0
    m1 = m2 = 0.0
    for i in range(18001):
        x = lo + i * step
        f = n * math.exp(-0.5 * x * x) / math.sqrt(2 * math.pi) * (0.5 * (1 + math.erf(x / math.sqrt(2)))) ** (n - 1)
        w = step * (0.5 if i in (0, 18000) else 1.0)
        m1 += w * x * f
        m2 += w * x * x * f
    return m1, math.sqrt(max(0.0, m2 - m1 * m1))


@dataclass(frozen=True)
class Target:
    """How closely a profile must reproduce one of the paper's figures. The tolerance is either
    stated (`tolerance`) or derived from the paper's own spread (`tolerance_sds`): its Table I gives,
    per metric, the average and the largest of `paper_runs` runs, so one run's figure varies by about
    sd = (Max - Average) / E[largest of paper_runs standard normals]. Our n runs are compared with
    that: the average with the paper's Average, within tolerance_sds x sd x sqrt(1/paper_runs + 1/n);
    the largest of our n runs with what the paper's runs predict for n runs, Average + sd x E[largest
    of n], within tolerance_sds x sd x sqrt(SD[largest of paper_runs]^2 + SD[largest of n]^2)."""

    metric: str
    statistic: str
    paper: float
    tolerance: float
    #: True: table1 checks it (the calibration's claim); False: reported, a deviation when missed
    required: bool = True
    why: str = ""
    #: tolerance from the paper's spread: standard deviations of the difference (0: `tolerance`)
    tolerance_sds: float = 0.0
    paper_runs: int = 0
    #: with tolerance_sds: the paper's Average of the metric and one run's sd derived from its spread
    paper_average: float = 0.0
    run_sd: float = 0.0

    def reference(self, runs: int) -> float:
        """The figure our `runs` runs should give: the paper's, or for the largest of fewer or more
        runs than the paper's, what its spread predicts."""
        if self.tolerance_sds and self.statistic == "max of runs":
            return self.paper_average + self.run_sd * normal_max(max(1, runs))[0]
        return self.paper

    def tolerance_for(self, runs: int) -> float:
        if not self.tolerance_sds:
            return self.tolerance
        n = max(1, runs)
        if self.statistic == "average":
            return self.tolerance_sds * self.run_sd * math.sqrt(1 / self.paper_runs + 1 / n)
        return self.tolerance_sds * self.run_sd * math.hypot(normal_max(self.paper_runs)[1], normal_max(n)[1])

    def holds(self, value: float, runs: int = 0) -> bool:
        runs = runs or self.paper_runs
        return math.isfinite(value) and abs(value - self.reference(runs)) <= self.tolerance_for(runs)


@dataclass(frozen=True)
class Profile:
    """A hardware profile: its name, title, description, assumptions and targets."""

    name: str
    title: str
    about: str
    assumptions: tuple[Assumption, ...]
    targets: tuple[Target, ...] = field(default_factory=tuple)
    path: Path | None = None

    @property
    def params(self) -> dict[str, float]:
        return {a.param: a.value for a in self.assumptions}

    def value(self, param: str, default: float) -> float:
        return self.params.get(param, default)


def names() -> list[str]:
    """The profiles in sim/profiles, the default first."""
    found = sorted(p.stem for p in PROFILES_DIR.glob("*.toml"))
    return sorted(found, key=lambda n: (n != DEFAULT, n))


def load(name: str) -> Profile:
    """The profile sim/profiles/<name>.toml (or a path to a .toml file), validated."""
    path = Path(name) if name.endswith(".toml") else PROFILES_DIR / f"{name}.toml"
    if not path.exists():
        raise ProfileError(f"no hardware profile {name!r}: choose one of {', '.join(names())} "
                           f"(files in {PROFILES_DIR.relative_to(REPO)}/) or give the path of a .toml file")
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, OSError) as exc:
        raise ProfileError(f"{path}: not a readable TOML file: {exc}") from exc
    return parse(path.stem, data, path=path)


def _known_params() -> dict[str, float]:
    from .native import params

    return {p.name: p.default for p in params()}


def _experiments() -> set[str]:
    from .runner import EXPERIMENTS

    return set(EXPERIMENTS)


def parse(name: str, data: Mapping[str, Any], *, path: Path | None = None) -> Profile:
    """Validate a profile's parsed TOML (see the module's docstring); raises ProfileError."""
    where = str(path) if path is not None else name
    unknown = set(data) - set(ALLOWED)
    if unknown:
        raise ProfileError(f"{where}: unknown section(s) {', '.join(sorted(unknown))}; a profile has "
                           f"{', '.join(ALLOWED)}")
    head = data.get("profile")
    if not isinstance(head, dict) or not str(head.get("title", "")).strip():
        raise ProfileError(f"{where}: [profile] needs a title (and an about)")
    _no_extra(where, "[profile]", head, ALLOWED["profile"])
    known = _known_params()
    experiments = _experiments()
    from . import critical

    table = critical.load()
    raw = data.get("assumption", [])
    if not isinstance(raw, list) or not raw:
        raise ProfileError(f"{where}: no [[assumption]]: a profile states at least one model input")
    seen: dict[str, int] = {}
    entries: list[dict[str, Any]] = []
    for i, entry in enumerate(raw, 1):
        label = f"{where}: assumption {i}"
        if not isinstance(entry, dict):
            raise ProfileError(f"{label}: expected a table")
        _no_extra(where, f"assumption {i}", entry, ALLOWED["assumption"])
        param = entry.get("param")
        if param not in known:
            raise ProfileError(f"{label}: unknown parameter {param!r}; `urb sim params` lists them")
        label = f"{where}: {param}"
        if param in seen:
            raise ProfileError(f"{label} is set twice (assumptions {seen[param]} and {i}): set each once")
        seen[param] = i
        if not str(entry.get("source", "")).strip():
            raise ProfileError(f"{label} has no source: say where the value comes from (datasheet and section, "
                               "the code, or the calibration that fitted it)")
        affects = entry.get("affects")
        if not isinstance(affects, list) or not affects or not all(isinstance(a, str) for a in affects):
            raise ProfileError(f"{label}: `affects` must list the experiments the value changes")
        bad = sorted(set(affects) - experiments)
        if bad:
            raise ProfileError(f"{label}: affects unknown experiment(s) {', '.join(bad)}; choose from "
                               f"{', '.join(sorted(experiments))}")
        if ("value" in entry) == ("from_code" in entry):
            raise ProfileError(f"{label}: give exactly one of `value` and `from_code`")
        entries.append(entry)
    values = {e["param"]: e.get("value") for e in entries}
    assumptions = []
    for entry in entries:
        param = entry["param"]
        if "from_code" in entry:
            section = str(entry["from_code"])
            device = param.split(".", 1)[0]
            ws_value = values.get(f"{device}.flash_ws")
            ws = float(ws_value) if isinstance(ws_value, (int, float)) else known.get(f"{device}.flash_ws", 0.0)
            try:
                value = critical.cycles(table, section, ws)
            except KeyError:
                ids = ", ".join(s["id"] for s in table["sections"])
                raise ProfileError(f"{where}: {param}: no critical section {section!r} in "
                                   f"{critical.TABLE.relative_to(REPO)}; measured: {ids}") from None
        else:
            value = entry["value"]
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ProfileError(f"{where}: {param} = {value!r} is not a number")
            value = float(value)
        _check_range(where, param, value)
        assumptions.append(Assumption(param, value, str(entry["source"]).strip(), tuple(entry["affects"]),
                                      str(entry["from_code"]) if "from_code" in entry else None))
    profile = Profile(name, str(head["title"]).strip(), str(head.get("about", "")).strip(), tuple(assumptions),
                      tuple(_targets(where, data.get("target", []))), path)
    _check_together(where, profile, known)
    return profile


def _no_extra(where: str, what: str, entry: Mapping[str, Any], allowed: set[str]) -> None:
    extra = set(entry) - allowed
    if extra:
        raise ProfileError(f"{where}: {what}: unknown key(s) {', '.join(sorted(extra))}; allowed: "
                           f"{', '.join(sorted(allowed))}")


def _check_range(where: str, param: str, value: float) -> None:
    lo, hi = RANGES.get(param, (0.0, math.inf))
    if not math.isfinite(value) or not lo <= value <= hi:
        raise ProfileError(f"{where}: {param} = {value:g} is outside its physical range [{lo:g}, {hi:g}]")


def _targets(where: str, raw: Any) -> list[Target]:
    if not isinstance(raw, list):
        raise ProfileError(f"{where}: [[target]] entries expected")
    out = []
    for i, entry in enumerate(raw, 1):
        if not isinstance(entry, dict):
            raise ProfileError(f"{where}: target {i}: expected a table")
        _no_extra(where, f"target {i}", entry, ALLOWED["target"])
        metric, stat = entry.get("metric"), entry.get("statistic")
        if metric not in TARGET_METRICS:
            raise ProfileError(f"{where}: target {i}: metric {metric!r}; choose from {', '.join(TARGET_METRICS)}")
        if stat not in TARGET_STATISTICS:
            raise ProfileError(f"{where}: target {i}: statistic {stat!r}; choose from {', '.join(TARGET_STATISTICS)}")
        paper, tol, sds = entry.get("paper"), entry.get("tolerance"), entry.get("tolerance_sds")
        if not isinstance(paper, (int, float)) or isinstance(paper, bool):
            raise ProfileError(f"{where}: target {i}: `paper` must be a number")
        if (tol is None) == (sds is None):
            raise ProfileError(f"{where}: target {i}: give exactly one of `tolerance` (absolute) and `tolerance_sds` "
                               "(from the paper's spread, with `paper_runs`)")
        if tol is not None and (not isinstance(tol, (int, float)) or isinstance(tol, bool) or tol <= 0):
            raise ProfileError(f"{where}: target {i}: `tolerance` must be a positive number")
        runs = entry.get("paper_runs", 0)
        if sds is not None and (not isinstance(sds, (int, float)) or isinstance(sds, bool) or sds <= 0
                                or not isinstance(runs, int) or isinstance(runs, bool) or runs < 2):
            raise ProfileError(f"{where}: target {i}: `tolerance_sds` must be a positive number and `paper_runs` "
                               "the paper's number of runs (at least 2)")
        required = entry.get("required", True)
        if not isinstance(required, bool):
            raise ProfileError(f"{where}: target {i}: `required` is true or false")
        if not required and not str(entry.get("why", "")).strip():
            raise ProfileError(f"{where}: target {i}: a target that is not required says why (`why`)")
        out.append(Target(str(metric), str(stat), float(paper), float(tol or 0.0), required, str(entry.get("why", "")),
                          float(sds or 0.0), int(runs)))
    return [_with_spread(where, t, out) for t in out]


def _with_spread(where: str, t: Target, all_targets: list[Target]) -> Target:
    """A target whose tolerance comes from the paper's spread, with that spread: the metric's paper
    Average and Max (both targets must be there, over the same runs, Max above Average)."""
    if not t.tolerance_sds:
        return t
    pair = {x.statistic: x for x in all_targets if x.metric == t.metric and x.tolerance_sds}
    if set(pair) != set(TARGET_STATISTICS) or pair["average"].paper_runs != pair["max of runs"].paper_runs:
        raise ProfileError(f"{where}: target {t.metric} {t.statistic}: a tolerance from the paper's spread needs "
                           f"the paper's average and max of runs of {t.metric}, both with `tolerance_sds` and the "
                           "same `paper_runs`")
    average, largest = pair["average"].paper, pair["max of runs"].paper
    if largest <= average:
        raise ProfileError(f"{where}: target {t.metric}: the paper's max of runs ({largest:g}) must be above its "
                           f"average ({average:g}) to give a spread")
    return replace(t, paper_average=average, run_sd=(largest - average) / normal_max(t.paper_runs)[0])


def _check_together(where: str, profile: Profile, known: Mapping[str, float]) -> None:
    """Values that are only meaningful together: threshold and delay ranges, the bus's rise time."""
    v = {**known, **profile.params}
    for lo, hi in (("node.vth_min", "node.vth_max"), ("node.filter_ns_min", "node.filter_ns_max"),
                   ("node.i2c_sync_min_cycles", "node.i2c_sync_max_cycles")):
        if v[lo] > v[hi]:
            raise ProfileError(f"{where}: {lo} = {v[lo]:g} is above {hi} = {v[hi]:g}")
    problem = bus_problem(v)
    if problem:
        raise ProfileError(f"{where}: {problem}")


def rise_ns(values: Mapping[str, float]) -> float:
    """The bus's 30-70 % rise time through its pull-up, ns (UM10204: 0.8473 R C)."""
    return 0.8473 * values["i2c.pullup_ohm"] * values["i2c.bus_pf"] * 1e-3


def bus_problem(values: Mapping[str, float]) -> str | None:
    """Why the downlink's pull-up and capacitance are outside UM10204 at its bit rate, or None."""
    if values["i2c.bus_pf"] <= 0:
        return None
    rate = values["i2c.bitrate"]
    limit = next((t for r, t in T_RISE_NS if rate <= r), T_RISE_NS[-1][1])
    t_r = rise_ns(values)
    if t_r > limit:
        return (f"the downlink's rise time 0.8473 x {values['i2c.pullup_ohm']:g} ohm x {values['i2c.bus_pf']:g} pF = "
                f"{t_r:.0f} ns exceeds UM10204's {limit:.0f} ns at {rate / 1e3:g} kb/s: a smaller pull-up, less "
                "capacitance or a bus buffer")
    sink = 20e-3 if rate > 400e3 else 3e-3
    r_min = (values["i2c.vdd"] - 0.4) / sink
    if values["i2c.pullup_ohm"] < r_min:
        return (f"the pull-up {values['i2c.pullup_ohm']:g} ohm is below UM10204's minimum (VDD - 0.4 V) / "
                f"{sink * 1e3:g} mA = {r_min:.0f} ohm")
    return None


def pullup_for(bus_pf: float, vdd: float = 3.3, rise_limit_ns: float = 300.0) -> float:
    """The largest E12 pull-up that keeps the rise time within `rise_limit_ns` on `bus_pf`, but no
    smaller than UM10204's Fast-mode minimum (the designer's choice the sensitivity study makes)."""
    e12 = [1.0, 1.2, 1.5, 1.8, 2.2, 2.7, 3.3, 3.9, 4.7, 5.6, 6.8, 8.2]
    r_min = (vdd - 0.4) / 3e-3
    best = r_min
    for decade in (100.0, 1000.0, 10000.0):
        for m in e12:
            r = m * decade
            if r >= r_min and 0.8473 * r * bus_pf * 1e-3 <= rise_limit_ns:
                best = max(best, r)
    return best


# ---------------------------------------------------------------- the active profile of this process

#: The profile in force (a context variable: each thread that runs tasks has its own).
_active: contextvars.ContextVar[Profile | None] = contextvars.ContextVar("urb_sim_profile", default=None)


@contextlib.contextmanager
def applied(profile: Profile | None, extra: Mapping[str, float] | None = None) -> Iterator[None]:
    """While inside, every World created in this context starts from `profile`'s values, then
    `extra` (a sensitivity point); None: the parameters' defaults (params.h)."""
    if extra:
        base = profile or Profile("defaults", "params.h defaults", "", ())
        more = tuple(Assumption(k, float(v), "sensitivity point", ()) for k, v in extra.items())
        kept = tuple(a for a in base.assumptions if a.param not in extra)
        profile = Profile(base.name, base.title, base.about, kept + more, base.targets, base.path)
    token = _active.set(profile)
    try:
        yield
    finally:
        _active.reset(token)


def active() -> Profile | None:
    """The profile in force now (None: params.h defaults)."""
    return _active.get()


def active_params() -> dict[str, float]:
    """The parameter values a new World starts from (empty: params.h defaults)."""
    prof = _active.get()
    return dict(prof.params) if prof is not None else {}


def model_values(extra: Mapping[str, float] | None = None) -> dict[str, float]:
    """Every parameter's value as a World created now starts with it: params.h's default, then the
    active profile's value, then `extra` (an experiment's rig settings, which win)."""
    values = dict(_known_params())
    values.update(active_params())
    values.update(extra or {})
    return values


def markdown(profiles: Sequence[Profile]) -> str:
    """Every assumption once, a column per profile: the table sim/README.md holds (and the report)."""
    params: list[str] = []
    for p in profiles:
        params.extend(a.param for a in p.assumptions if a.param not in params)
    head = "| parameter | " + " | ".join(f"`{p.name}`" for p in profiles) + " | affects | source |"
    lines = [head, "|" + "---|" * (len(profiles) + 3)]
    for param in params:
        cells: list[str] = []
        sources: list[str] = []
        affects: list[str] = []
        for p in profiles:
            a = next((x for x in p.assumptions if x.param == param), None)
            cells.append("(default)" if a is None else f"{a.value:g}")
            if a is not None:
                sources.append(f"`{p.name}`: {a.source}" + (f" (from `{a.from_code}`)" if a.from_code else ""))
                affects.extend(x for x in a.affects if x not in affects)
        lines.append(f"| `{param}` | " + " | ".join(cells) + f" | {', '.join(affects)} | {'; '.join(sources)} |")
    return "\n".join(lines)
