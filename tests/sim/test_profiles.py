"""Hardware profiles (sim/profiles, urb_sim.profiles; issue #40): the committed profiles load, the
loader refuses what it cannot trust with a message that says what to change, a profile really
changes the simulated world, and sim/README.md lists every assumption once, as the profiles say."""

from __future__ import annotations

import copy
import math
import re
import tomllib
from pathlib import Path
from typing import Any

import pytest

from urb_sim import profiles
from urb_sim.native import World, params

REPO = Path(__file__).resolve().parents[2]


def _data(name: str) -> dict[str, Any]:
    return tomllib.loads((profiles.PROFILES_DIR / f"{name}.toml").read_text(encoding="utf-8"))


def test_every_committed_profile_loads_the_default_first() -> None:
    names = profiles.names()
    assert names[0] == profiles.DEFAULT == "cortex-m0plus"
    assert {"ideal", "paper"} <= set(names)
    for name in names:
        prof = profiles.load(name)
        assert prof.assumptions and all(a.source and a.affects for a in prof.assumptions)


def test_the_ideal_profile_is_the_parameters_defaults() -> None:
    """`ideal` documents the model before profiles: each of its values is params.h's default."""
    defaults = {p.name: p.default for p in params()}
    for a in profiles.load("ideal").assumptions:
        assert a.value == defaults[a.param], a.param


def test_mask_cycles_come_from_the_measured_critical_sections() -> None:
    from urb_sim import critical

    table = critical.load()
    prof = profiles.load("cortex-m0plus")
    node = next(a for a in prof.assumptions if a.param == "node.mask_cycles")
    assert node.from_code == "node:urb_hal_cm0_sleep"
    ws = prof.params["node.flash_ws"]
    section = next(s for s in table["sections"] if s["id"] == node.from_code)
    assert node.value == section["cycles"] + ws * section["fetches"]


def _refused(data: dict[str, Any], message: str) -> None:
    with pytest.raises(profiles.ProfileError) as exc:
        profiles.parse("t", data)
    assert message in str(exc.value), str(exc.value)


def _with(entry_change: dict[str, Any], index: int = 0) -> dict[str, Any]:
    data = copy.deepcopy(_data("cortex-m0plus"))
    data["assumption"][index].update(entry_change)
    return data


def test_the_loader_refuses_what_it_cannot_trust() -> None:
    base = _data("cortex-m0plus")
    profiles.parse("t", base)  # the unchanged data loads: each case below fails for its own change
    _refused({**base, "extras": {}}, "unknown section(s) extras")
    _refused(_with({"unit": "cycles"}), "unknown key(s) unit")
    _refused(_with({"param": "node.irq_latency"}), "unknown parameter 'node.irq_latency'")
    _refused(_with({"source": " "}), "node.cpu_hz has no source")
    missing = _with({})
    del missing["assumption"][0]["source"]
    _refused(missing, "node.cpu_hz has no source")
    _refused(_with({"affects": ["table9"]}), "affects unknown experiment(s) table9")
    _refused(_with({"affects": []}), "`affects` must list the experiments")
    _refused(_with({"value": 5e9}), "node.cpu_hz = 5e+09 is outside its physical range")
    _refused(_with({"value": "48 MHz"}), "is not a number")
    _refused(_with({"from_code": "node:urb_hal_cm0_sleep"}), "give exactly one of `value` and `from_code`")
    twice = copy.deepcopy(base)
    twice["assumption"].append(dict(base["assumption"][0]))
    _refused(twice, "node.cpu_hz is set twice")
    unknown_section = copy.deepcopy(base)
    mask = next(e for e in unknown_section["assumption"] if e["param"] == "node.mask_cycles")
    mask["from_code"] = "node:urb_hal_cm0_nap"
    _refused(unknown_section, "no critical section 'node:urb_hal_cm0_nap'")
    _refused({"assumption": base["assumption"]}, "[profile] needs a title")


def test_values_that_only_hold_together_are_checked_together() -> None:
    base = _data("cortex-m0plus")
    vth = copy.deepcopy(base)
    next(e for e in vth["assumption"] if e["param"] == "node.vth_min")["value"] = 0.8
    _refused(vth, "node.vth_min = 0.8 is above node.vth_max = 0.7")
    slow = copy.deepcopy(base)
    next(e for e in slow["assumption"] if e["param"] == "i2c.bus_pf")["value"] = 400
    _refused(slow, "exceeds UM10204's 300 ns at 400 kb/s")
    strong = copy.deepcopy(base)
    next(e for e in strong["assumption"] if e["param"] == "i2c.pullup_ohm")["value"] = 500
    _refused(strong, "below UM10204's minimum")


def test_targets_are_validated() -> None:
    base = _data("paper")
    profiles.parse("t", base)
    unsaid = copy.deepcopy(base)
    unsaid["target"][-1]["required"] = False  # and no `why`
    _refused(unsaid, "a target that is not required says why")
    wrong = copy.deepcopy(base)
    wrong["target"][0]["metric"] = "latency_ms"
    _refused(wrong, "metric 'latency_ms'")


def test_an_unknown_profile_names_the_known_ones() -> None:
    with pytest.raises(profiles.ProfileError, match="no hardware profile 'pic18': choose one of cortex-m0plus"):
        profiles.load("pic18")


def test_pullup_for_keeps_the_rise_time_within_fast_mode() -> None:
    for pf in (50, 100, 200, 300):
        r = profiles.pullup_for(pf)
        assert 0.8473 * r * pf * 1e-3 <= 300 and r >= (3.3 - 0.4) / 3e-3
    assert profiles.pullup_for(200) == 1500  # what the cortex-m0plus profile states
    assert profiles.bus_problem({"i2c.bus_pf": 400, "i2c.pullup_ohm": profiles.pullup_for(400), "i2c.vdd": 3.3,
                                 "i2c.bitrate": 400e3}) is not None  # beyond what any legal pull-up can drive


def test_an_applied_profile_sets_every_new_world() -> None:
    prof = profiles.load("cortex-m0plus")
    with profiles.applied(prof, {"i2c.bus_pf": 100.0}):
        w = World(1)
        assert w.get("node.flash_ws") == 1 and w.get("node.mask_cycles") == prof.params["node.mask_cycles"]
        assert w.get("i2c.bus_pf") == 100  # the extra (a sensitivity point) over the profile
        w.close()
    w = World(1)
    assert w.get("node.flash_ws") == 0  # outside: the defaults again
    w.close()


README_START = "<!-- profiles:start (generated: urb sim profiles --markdown) -->"
README_END = "<!-- profiles:end -->"


def test_the_readme_lists_every_assumption_as_the_profiles_state_it() -> None:
    text = (REPO / "sim" / "README.md").read_text(encoding="utf-8")
    found = re.search(re.escape(README_START) + r"\n(.*?)\n" + re.escape(README_END), text, re.S)
    assert found, "sim/README.md lacks the generated table of assumptions"
    assert found.group(1) == profiles.markdown([profiles.load(n) for n in profiles.names()]), (
        "sim/README.md's table of assumptions is stale: replace it with `urb sim profiles --markdown`")


def test_targets_become_checks_and_deviations() -> None:
    """A calibrated profile's required targets are checks that fail when the figure is off; a target
    that is not required is a deviation (with its reason) only when it is missed."""
    from urb_sim.experiments import Result, profile_targets

    prof = profiles.load("paper")
    with profiles.applied(prof):
        near, off = Result("table1", "Table I: t", "p"), Result("table1", "Table I: t", "p")
        profile_targets(near, {"internode_us": (0.2, 0.5), "jitter_us": (0.9, 1.3), "convergence_ms": (80.0, 90.0)})
        profile_targets(off, {"internode_us": (0.4, 0.1), "jitter_us": (0.9, 1.3), "convergence_ms": (40.0, 50.0)})
    # the paper profile requires all six figures of Table I
    assert len(near.checks) == 6 and all(c.passed for c in near.checks) and near.deviations == []
    assert [c.name for c in off.checks if not c.passed] == [
        "paper profile reproduces the paper's internode_us average",
        "paper profile reproduces the paper's internode_us max of runs",
        "paper profile reproduces the paper's convergence_ms average",
        "paper profile reproduces the paper's convergence_ms max of runs"]
    relaxed = copy.deepcopy(_data("paper"))
    for t in relaxed["target"]:
        if t["metric"] == "convergence_ms":
            t.update(required=False, why="a seeded reason")
    with profiles.applied(profiles.parse("relaxed", relaxed)):
        reported = Result("table1", "Table I: t", "p")
        profile_targets(reported, {"convergence_ms": (40.0, 90.0)})
    assert reported.checks == [] and len(reported.deviations) == 1
    assert "convergence_ms average 40.000 ms" in reported.deviations[0] and "a seeded reason" in reported.deviations[0]
    plain = Result("table1", "Table I: t", "p")
    profile_targets(plain, {"internode_us": (9.0, 9.0)})  # no profile applied: nothing to check
    assert plain.checks == [] and plain.deviations == []


def test_the_largest_of_n_standard_normals() -> None:
    """normal_max against values known in closed form or tabulated: n = 1 is the normal itself, the
    largest of two has mean 1/sqrt(pi), the largest of 20 mean 1.8675 and sd 0.5251."""
    assert profiles.normal_max(1) == pytest.approx((0.0, 1.0), abs=1e-6)
    assert profiles.normal_max(2)[0] == pytest.approx(1 / math.sqrt(math.pi), abs=1e-6)
    assert profiles.normal_max(20) == pytest.approx((1.8675, 0.5251), abs=1e-4)


def test_a_tolerance_from_the_papers_spread() -> None:
    """tolerance_sds: one run's sd from the paper's Average and Max of its runs, the average compared
    over both sets of runs, the largest of ours with what the paper's spread predicts for as many runs."""
    prof = profiles.load("paper")
    inter = {t.statistic: t for t in prof.targets if t.metric == "internode_us"}
    sd = (0.56 - 0.19) / profiles.normal_max(20)[0]
    assert inter["average"].run_sd == pytest.approx(sd)
    assert inter["average"].tolerance_for(20) == pytest.approx(2 * sd * math.sqrt(2 / 20))
    assert inter["max of runs"].reference(20) == pytest.approx(0.56)  # as many runs as the paper: its Max
    assert inter["max of runs"].reference(5) == pytest.approx(0.19 + sd * profiles.normal_max(5)[0])
    assert inter["max of runs"].tolerance_for(20) == pytest.approx(2 * sd * math.hypot(0.5251, 0.5251), rel=1e-3)
    edge = inter["average"].tolerance_for(20)
    assert inter["average"].holds(0.19 + 0.99 * edge, 20) and not inter["average"].holds(0.19 + 1.01 * edge, 20)
    assert not inter["average"].holds(math.nan, 20)


def test_a_tolerance_from_the_spread_needs_both_figures() -> None:
    base = _data("paper")
    lone = copy.deepcopy(base)
    lone["target"] = [t for t in lone["target"] if (t["metric"], t["statistic"]) != ("jitter_us", "max of runs")]
    _refused(lone, "needs the paper's average and max of runs of jitter_us")
    both = copy.deepcopy(base)
    both["target"][1]["tolerance"] = 0.1
    _refused(both, "give exactly one of `tolerance`")
    inverted = copy.deepcopy(base)
    for t in inverted["target"]:
        if t["metric"] == "jitter_us":
            t["paper"] = 1.0
    _refused(inverted, "must be above its average")
    few = copy.deepcopy(base)
    few["target"][1]["paper_runs"] = 1
    _refused(few, "`paper_runs` the paper's number of runs")
