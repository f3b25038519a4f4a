"""`urb sim sensitivity`: Table I, the latency figures and the control loop's lag as functions of
the hardware (issue #40), so that a user can read off what their MCU and bus will give.

Each factor is varied alone from a base hardware profile (the default, the Cortex-M0+ one), over
values that span the hardware a URB node might run on:

  irq_jitter  the node's interrupt latency jitter (node.irq_jitter_cycles, shown in us at 48 MHz)
  timer       the node's heartbeat timer resolution (node.ticks_per_us, MHz)
  crystal     the crystals' frequency error, nodes and bridge (node.ppm_sd, bridge.ppm_sd)
  bus         the downlink's capacitance (i2c.bus_pf), with the largest pull-up that keeps UM10204's
              300-ns rise time (profiles.pullup_for) until its 3-mA minimum takes over
  heartbeat   the heartbeat rate (node.heartbeat_us, bridge.heartbeat_us), SYNC at the same rate, at
              most 1 kHz: the table1 rig derives the SYNC from the 1-ms USB frames

One point (a task `sens:<factor>=<index>`, run by the same runner, sweep and Dask backends as the
experiments) measures, at its seed:
  Table I     `runs` synchronised runs of the table1 rig (sync.one_run): convergence, inter-node
              difference and jitter, average, max of runs and worst single cycle;
  latency     Figs. 15 and 16 at a 6-byte payload (latency.measure): mean and max round trip;
  lag         the PD loop over USB with fixed gains (control.pd_tracking, Kp 5 V/rad, Kd 0.05):
              its tracking lag and median sensor-to-actuator delay.
`summarize` plots every factor (sensitivity_<factor>.png) and says, per factor, from which value
on the PLL no longer meets the paper's Table I (its Average and its Max, read as the max of runs).
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any


from .experiments import Progress, Result, no_progress, pyplot, write_csv
from .profiles import pullup_for

#: The paper's Table I (average, max), as experiments/sync.py has it.
PAPER = {"convergence_ms": (78.4, 88.4), "internode_us": (0.19, 0.56), "jitter_us": (0.92, 1.33)}
NODE_HZ = 48e6  #: the base profile's core clock, to show jitter cycles in us


@dataclass(frozen=True)
class Factor:
    """One hardware factor: its values (as shown) and the parameters each sets."""

    id: str
    title: str
    unit: str
    values: tuple[float, ...]
    quick_values: tuple[float, ...]
    #: from a shown value to the simulation parameters it sets
    params: Callable[[float], dict[str, float]]
    #: the direction in which the hardware gets worse: +1 larger values, -1 smaller ones
    worse: int = 1

    def shown(self, quick: bool) -> tuple[float, ...]:
        return self.quick_values if quick else self.values


def _bus(pf: float) -> dict[str, float]:
    return {"i2c.bus_pf": pf, "i2c.pullup_ohm": pullup_for(pf)}


def _heartbeat(khz: float) -> dict[str, float]:
    us = round(1000.0 / khz)
    return {"node.heartbeat_us": us, "bridge.heartbeat_us": us}


FACTORS: dict[str, Factor] = {f.id: f for f in (
    Factor("irq_jitter", "node interrupt latency jitter", "us", (0.0, 0.1, 0.25, 0.5, 1.0, 2.0), (0.0, 0.5, 2.0),
           lambda us: {"node.irq_jitter_cycles": round(us * NODE_HZ / 1e6)}),
    Factor("timer", "node heartbeat timer resolution", "MHz", (48.0, 16.0, 8.0, 4.0, 2.0, 1.0), (48.0, 4.0, 1.0),
           lambda mhz: {"node.ticks_per_us": mhz}, worse=-1),
    Factor("crystal", "crystal frequency error (sd, nodes and bridge)", "ppm",
           (10.0, 30.0, 100.0, 300.0, 1000.0, 3000.0), (30.0, 300.0, 3000.0),
           lambda ppm: {"node.ppm_sd": ppm, "bridge.ppm_sd": ppm}),
    Factor("bus", "downlink bus capacitance (pull-up for a 300-ns rise)", "pF", (50.0, 100.0, 200.0, 300.0, 400.0),
           (50.0, 200.0, 400.0), _bus),
    # at most 1 kHz: the table1 rig derives the SYNC from the 1-ms USB frames (bridge.heartbeat_sof)
    Factor("heartbeat", "heartbeat and SYNC rate", "kHz", (1.0, 0.5, 0.25, 0.1), (1.0, 0.25), _heartbeat, worse=-1),
)}


def point_key(factor: str, index: int) -> str:
    return f"sens:{factor}={index}"


def keys(only: Sequence[str] | None, *, quick: bool) -> list[str]:
    """The sensitivity tasks (without profile) of the factors `only` (None: all)."""
    chosen = list(FACTORS) if not only else list(only)
    unknown = [f for f in chosen if f not in FACTORS]
    if unknown:
        raise ValueError(f"unknown factor(s) {', '.join(unknown)}; choose from {', '.join(FACTORS)}")
    return [point_key(f, i) for f in chosen for i in range(len(FACTORS[f].shown(quick)))]


def parse_key(key: str) -> tuple[Factor, int]:
    """`sens:<factor>=<index>` -> (factor, index); raises ValueError."""
    body = key.partition("@")[0]
    name, eq, index = body[len("sens:"):].partition("=")
    if not body.startswith("sens:") or not eq or name not in FACTORS or not index.isdigit():
        raise ValueError(f"{key!r} is not a sensitivity point (sens:<factor>=<index>, factors {', '.join(FACTORS)})")
    return FACTORS[name], int(index)


def point_function(key: str) -> Callable[..., Result]:
    """The experiment function of one sensitivity point."""
    factor, index = parse_key(key)

    def run(out: Path, *, quick: bool = False, seed: int = 1, progress: Progress = no_progress) -> Result:
        return measure_point(factor, index, out, quick=quick, seed=seed, progress=progress)

    return run


def measure_point(factor: Factor, index: int, out: Path, *, quick: bool, seed: int,
                  progress: Progress = no_progress) -> Result:
    """Table I, Figs. 15-16 at 6 bytes and the PD loop's lag at one value of one factor."""
    from . import profiles
    from .experiments import control, latency, sync

    values = factor.shown(quick)
    if index >= len(values):
        raise ValueError(f"sensitivity point {factor.id}={index}: only {len(values)} values")
    value = values[index]
    extra = factor.params(value)
    res = Result(point_key(factor.id, index), f"Sensitivity: {factor.title} = {value:g} {factor.unit}",
                 "Table I: " + ", ".join(f"{k} {a} / {m}" for k, (a, m) in PAPER.items()))
    t0 = time.perf_counter()
    runs_n, duration = (2, 700) if quick else (5, 1000)
    reads, seconds = (100, 2.0) if quick else (300, 3.0)
    base = profiles.active()
    with profiles.applied(base, extra):
        runs = []
        for i in range(runs_n):
            progress(i / (runs_n + 2), f"{factor.id}={value:g}: Table I run {i + 1}/{runs_n}")
            runs.append(sync.one_run(seed + i, True, duration))
        progress(runs_n / (runs_n + 2), f"{factor.id}={value:g}: latency")
        lat = {up: [s.latency_ns / 1e6 for s in latency.measure(up, 6, reads, seed) if s.ok and s.latency_ns]
               for up in ("rs232", "usb")}
        progress((runs_n + 1) / (runs_n + 2), f"{factor.id}={value:g}: PD loop over USB")
        axis, _, lag, _, s = control.pd_tracking("usb", seed, seconds, 5.0, 0.05)
        s.close()
    row: dict[str, Any] = {"factor": factor.id, "value": value, "unit": factor.unit,
                           "params": ", ".join(f"{k}={v:g}" for k, v in extra.items())}
    per_run: dict[str, tuple[list[float], list[float] | None]] = {
        "convergence_ms": ([r.convergence_ms for r in runs], None),
        "internode_us": ([r.internode_us for r in runs], [r.internode_max_us for r in runs]),
        "jitter_us": ([r.jitter_us for r in runs], [r.jitter_max_us for r in runs])}
    for metric, (figures_of_runs, worst) in per_run.items():
        figures = [v for v in figures_of_runs if v == v]
        row[f"{metric} average"] = round(statistics.mean(figures), 4) if figures else math.nan
        row[f"{metric} max of runs"] = round(max(figures), 4) if figures else math.nan
        if worst is not None:
            cycles = [v for v in worst if v == v]
            row[f"{metric} worst cycle"] = round(max(cycles), 4) if cycles else math.nan
    for up, ms in lat.items():
        row[f"{up} latency mean ms"] = round(statistics.mean(ms), 4) if ms else math.nan
        row[f"{up} latency max ms"] = round(max(ms), 4) if ms else math.nan
    row["usb PD lag ms"] = round(lag, 3)
    row["usb PD delay median ms"] = round(statistics.median(axis.delays), 3) if axis.delays else math.nan
    row["meets Table I"] = meets(row)
    res.table.append(row)
    failed = sum(r.failed_reads for r in runs) + axis.fails
    measured = [v for k, v in row.items() if isinstance(v, float)]
    res.check("measured", "every figure measured (Table I runs, both latencies, the PD loop's lag)",
              f"{failed} failed reads, {sum(1 for v in measured if v != v)} figures missing",
              all(v == v for v in measured))
    res.wall_s = time.perf_counter() - t0
    res.sim_s = runs_n * duration / 1000 + 2 * (reads + 200) / 1000 + seconds + 0.2
    out.mkdir(parents=True, exist_ok=True)
    res.files.append(write_csv(out / "point.csv", list(row), [list(row.values())]))
    return res


def meets(row: dict[str, Any]) -> bool:
    """Whether a point's Table I is within the paper's: each average <= its Average, each max of runs
    <= its Max (the worst single cycle is shown, not judged: the paper does not define its Max)."""
    return all(row[f"{m} average"] <= a and row[f"{m} max of runs"] <= x for m, (a, x) in PAPER.items())


def summarize(results: Sequence[Result], out: Path, profile_title: str) -> tuple[list[Path], list[dict[str, Any]],
                                                                                  list[str]]:
    """The report's sensitivity section from the points' Results: one figure per factor, every
    point's row, and per factor where the paper's Table I stops being met."""
    rows = [r.table[0] for r in results if r.table and str(r.key).startswith("sens:")]
    by_factor: dict[str, list[dict[str, Any]]] = {}
    for row in rows:
        by_factor.setdefault(str(row["factor"]), []).append(row)
    files, notes = [], []
    out.mkdir(parents=True, exist_ok=True)
    for fid, points in by_factor.items():
        factor = FACTORS[fid]
        points.sort(key=lambda r: float(r["value"]) * factor.worse)
        files.append(_plot(out / f"sensitivity_{fid}.png", factor, points, profile_title))
        failing = [p for p in points if not p["meets Table I"]]
        if not failing:
            notes.append(f"{factor.title}: the paper's Table I is met at every value tried "
                         f"({_span(factor, points)}).")
        else:
            first = failing[0]
            ok = [p for p in points if p["meets Table I"] and float(p["value"]) * factor.worse
                  < float(first["value"]) * factor.worse]
            last_ok = f"; met up to {ok[-1]['value']:g} {factor.unit}" if ok else "; not met at any value tried"
            why = ", ".join(f"{m} {first[f'{m} average']:.3g} / {first[f'{m} max of runs']:.3g} (paper {a} / {x})"
                            for m, (a, x) in PAPER.items()
                            if first[f"{m} average"] > a or first[f"{m} max of runs"] > x)
            notes.append(f"{factor.title}: the PLL stops meeting the paper's Table I at {first['value']:g} "
                         f"{factor.unit}{last_ok} (there: {why}).")
    files.append(write_csv(out / "sensitivity.csv", list(rows[0]) if rows else ["factor"],
                           ([r.get(c, "") for c in rows[0]] for r in rows) if rows else []))
    return files, rows, notes


def _span(factor: Factor, points: Sequence[dict[str, Any]]) -> str:
    vals = [float(p["value"]) for p in points]
    return f"{min(vals):g} to {max(vals):g} {factor.unit}"


def _plot(path: Path, factor: Factor, points: Sequence[dict[str, Any]], profile_title: str) -> Path:
    plt = pyplot()
    x = [float(p["value"]) for p in points]
    fig, axes = plt.subplots(1, 4, figsize=(16, 3.6))
    log = factor.id in ("crystal", "timer") or (min(x) > 0 and max(x) / min(x) >= 10)
    for ax in axes:
        if log and min(x) > 0:
            ax.set_xscale("log")
        ax.set_xlabel(f"{factor.title} ({factor.unit})", fontsize=8)
        ax.grid(alpha=0.3)
    ax = axes[0]
    for metric, color in (("internode_us", "tab:blue"), ("jitter_us", "tab:red")):
        ax.plot(x, [p[f"{metric} average"] for p in points], "o-", color=color, label=f"{metric[:-3]} average")
        ax.plot(x, [p[f"{metric} worst cycle"] for p in points], "x--", color=color, label=f"{metric[:-3]} worst cycle")
        for v, style in zip(PAPER[metric], (":", "-.")):
            ax.axhline(v, color=color, ls=style, lw=0.8)
    ax.set_yscale("log")
    ax.set_ylabel("us (paper: dotted average, dash-dot max)", fontsize=8)
    ax.set_title("Table I: inter-node difference, jitter", fontsize=9)
    ax.legend(fontsize=6)
    ax = axes[1]
    ax.plot(x, [p["convergence_ms average"] for p in points], "o-", label="average")
    ax.plot(x, [p["convergence_ms max of runs"] for p in points], "x--", label="max of runs")
    for v, style in zip(PAPER["convergence_ms"], (":", "-.")):
        ax.axhline(v, color="k", ls=style, lw=0.8)
    ax.set_ylabel("ms")
    ax.set_title("Table I: convergence", fontsize=9)
    ax.legend(fontsize=6)
    ax = axes[2]
    for up, color in (("rs232", "tab:green"), ("usb", "tab:purple")):
        ax.plot(x, [p[f"{up} latency mean ms"] for p in points], "o-", color=color, label=f"{up} mean")
        ax.plot(x, [p[f"{up} latency max ms"] for p in points], "x--", color=color, label=f"{up} max")
    ax.set_ylabel("ms")
    ax.set_title("Figs. 15-16: 6-byte round trip", fontsize=9)
    ax.legend(fontsize=6)
    ax = axes[3]
    ax.plot(x, [p["usb PD lag ms"] for p in points], "o-", label="tracking lag")
    ax.plot(x, [p["usb PD delay median ms"] for p in points], "x--", label="sensor-to-actuator delay (median)")
    ax.set_ylabel("ms")
    ax.set_title("PD loop over USB (Kp 5, Kd 0.05)", fontsize=9)
    ax.legend(fontsize=6)
    fig.suptitle(f"Sensitivity to the {factor.title}, from the profile: {profile_title}", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
