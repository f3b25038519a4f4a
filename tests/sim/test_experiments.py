"""Each experiment's acceptance criterion, on the short runs (`quick=True`: fewer payloads,
reads and seeds than the full report, same criteria)."""

from __future__ import annotations

import math
import statistics
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from urb_sim import native, profiles
from urb_sim.experiments import SEED_SPAN, Result, control, latency, no_progress, sync, usb_bound
from urb_sim.runner import EXPERIMENTS, run_experiments


@pytest.fixture(autouse=True)
def seeds_within_the_span(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """Every world a test here builds comes from one base seed and the SEED_SPAN seeds after it (each
    test runs one experiment, or part of one, at one base seed): sweeps rely on that
    (sim/urb_sim/sweep.py)."""
    seeds: list[int] = []
    real = native.World.__init__

    def recording(world: native.World, seed: int) -> None:
        seeds.append(seed)
        real(world, seed)

    monkeypatch.setattr(native.World, "__init__", recording)
    yield
    if seeds:
        assert max(seeds) - min(seeds) < SEED_SPAN, f"worlds seeded {min(seeds)} .. {max(seeds)}"


def _assert_passed(res: Result) -> None:
    failed = [f"{c.name}: required {c.required}, measured {c.measured}" for c in res.checks if not c.passed]
    assert res.passed, "; ".join(failed)
    for f in res.files:
        assert f.exists() and f.stat().st_size > 0


def test_fig15_rs232_latency(tmp_path: Path) -> None:
    res = latency.fig15(tmp_path, quick=True)
    _assert_passed(res)
    rows = {r["payload"]: r for r in res.table}
    assert rows[1]["mean_ms"] < rows[9]["mean_ms"] <= 2.0
    assert any("10-byte payload" in n for n in res.notes)  # the over-budget point is explained
    # and named as not reproducing the paper (its 2-ms maximum covers 10 bytes), for the headline
    [deviation] = res.deviations
    assert deviation.startswith("Fig. 15: the 10-byte payload at 1 kHz takes up to ")


def test_fig16_usb_latency(tmp_path: Path) -> None:
    res = latency.fig16(tmp_path, quick=True)
    _assert_passed(res)
    assert res.deviations == []  # within the paper's three frames


def _fig16_constant(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, latency_ms: Callable[[int, int], float]) -> bool:
    """fig16's "constant" verdict on synthetic round trips: latency_ms(payload, request)."""
    def sweep(uplink: str, payloads: list[int], reads: int, *_: object) -> tuple[list[latency.Sample], float]:
        return [latency.Sample(p, i, round(latency_ms(p, i) * 1e6), True, "") for p in payloads
                for i in range(reads)], 0.0

    monkeypatch.setattr(latency, "_sweep", sweep)
    [check] = [c for c in latency.fig16(tmp_path, quick=True).checks if c.name == "constant"]
    return check.passed


def test_fig16_constant_allows_whole_frames_sooner_and_nothing_else(tmp_path: Path,
                                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    def frame_more_from_16_bytes(p: int, i: int) -> float:
        return 2.95 + i % 7 * 0.02 + (1.0 if p >= 16 else 0.0)

    def one_long_read_a_frame_later(p: int, i: int) -> float:
        return 2.95 + i % 7 * 0.02 + (1.0 if p > 16 and i == 5 else 0.0)

    def payload_within_the_frame(p: int, i: int) -> float:  # 10 us per byte: 0.3 ms from 1 to 31 bytes
        return 2.95 + i % 7 * 0.02 + p * 0.01

    def few_short_reads_a_frame_sooner(p: int, i: int) -> float:  # seeds 2814, 3045, 3885
        return 2.95 + i % 7 * 0.02 - (1.0 if p < 16 and i % 20 == 0 else 0.0)

    def about_half_a_frame_sooner(p: int, i: int) -> float:  # seed 4662: the share falls with the payload
        return 2.95 + i % 7 * 0.02 - (1.0 if i % 100 < (56 if p < 18 else 49) else 0.0)

    assert not _fig16_constant(tmp_path, monkeypatch, frame_more_from_16_bytes)
    assert not _fig16_constant(tmp_path, monkeypatch, one_long_read_a_frame_later)
    assert not _fig16_constant(tmp_path, monkeypatch, payload_within_the_frame)
    assert _fig16_constant(tmp_path, monkeypatch, few_short_reads_a_frame_sooner)
    assert _fig16_constant(tmp_path, monkeypatch, about_half_a_frame_sooner)


@pytest.mark.parametrize("phase_us, low_ms, high_ms", [(100, 2.1, 2.3), (999, 3.0, None)])
def test_usb_latency_follows_the_frame_phase(phase_us: int, low_ms: float, high_ms: float | None) -> None:
    """The USB frames' phase against the OS tick sets where the round trip lands: just after the
    tick about 2.1 ms, just before it over 3 ms, and still within three frames and the last frame's
    path to the callback (usb_bound, from the parameters), which a bound of 3.0 ms alone would not be."""
    lat = [s.latency_ns / 1e6 for s in latency.measure("usb", 31, 50, 16, {"usb.phase_us": phase_us})
           if s.ok and s.latency_ns is not None]
    assert len(lat) == 50
    high = usb_bound.three_frames_ms(profiles.model_values(), 31) if high_ms is None else high_ms
    assert low_ms < min(lat) and max(lat) <= high


# lobster-trace: urb.SYN_001
@pytest.mark.slow
def test_table1_synchronisation(tmp_path: Path) -> None:
    res = sync.table1(tmp_path, quick=True)
    _assert_passed(res)


# lobster-trace: urb.CRC_006
def test_faults_nothing_lost_silently(tmp_path: Path) -> None:
    from urb_sim.experiments import faults

    res = faults.faults(tmp_path)
    _assert_passed(res)
    assert len(res.table) == 9  # every fault of the issue: I2C bit errors, SDA/SCL stuck, node power,
    # bridge reset, babbling node, uplink byte loss, UART bit errors, USB IN loss


# lobster-trace: urb.ORD_007
@pytest.mark.slow
def test_trace_validation_with_tlc(tmp_path: Path) -> None:
    from urb_sim.experiments import traces

    res = traces.traces(tmp_path, quick=True)
    _assert_passed(res)
    names = {c.name for c in res.checks}
    assert {"inbox trace accepted", "inbox mutant rejected: torn read",
            "inbox mutant rejected: aborted write visible", "outbox mutant rejected: stale byte",
            "usb trace under I2C bit errors accepted", "USB uplink trace accepted",
            "USB uplink mutant rejected: responses one frame late", "USB uplink mutant rejected: batch out of order",
            "USB uplink mutant rejected: callbacks swapped", "USB uplink premise measured at the motor load",
            "discovery trace accepted", "discovery mutant rejected: phantom identity",
            "discovery mutant rejected: duplicate not flagged", "discovery mutant rejected: duplicates merged"} <= names
    # one row per USB frame phase (all traces in one TLC run): accepted exactly where every callback came
    # within UsbUplink.tla's 3 frames; no wall time in the CSV (same seed, same bytes)
    phases = [r for r in res.table if "after the OS tick" in r["trace"]]
    assert len(phases) == len(traces.USB_PHASES_US[::2])
    assert all(r["accepted"] == ("within 3 host frames" in r["trace"]) for r in phases)
    assert 0 < sum(r["accepted"] for r in phases) < len(phases)
    header = (tmp_path / "traces.csv").read_text().splitlines()[0]
    assert header == "uplink,trace,events,accepted,matched_prefix,tlc_states"


@pytest.mark.parametrize("uplink, seed, seconds, median_ms",
                         [("rs232", 1, 1.2, 2.0), ("rs232", 14, 1.6, 3.0), ("usb", 19, 3.0, 5.0)])
def test_loop_delay_is_whole_node_periods(uplink: str, seed: int, seconds: float, median_ms: float) -> None:
    """The node samples and drives on its 1-kHz update, so a loop's sensor-to-actuator delay is whole
    update periods: over RS232 two (the paper's 2 ms) or, at phases of the host loop where the command
    arrives just after the update it was due at, three; over USB the USB frames' phase can add one
    more to the paper's 3 ms (at seed 19 after 0.75 s: the phases drift, every crystal has its own
    error). All are within Figs. 18-19's criterion. (Seed 14 runs 1.6 s: since slave interrupts are
    raised at their bus instants (2026-11-26) its phase reaches the 3-ms side after about 1.2 s.)"""
    axis, _, _, _, s = control.pd_tracking(uplink, seed, seconds, 5.0, 0.05)
    s.close()
    med = statistics.median(axis.delays)
    assert abs(med - median_ms) < 0.05
    paper = control.PAPER_LAG_MS[uplink]
    assert paper - 0.05 <= med <= paper + control.PHASE_PERIODS[uplink] * control.NODE_PERIOD_MS + 0.05


def test_figs18_19_pd_control(tmp_path: Path) -> None:
    res = control.figs18_19(tmp_path, quick=True)
    _assert_passed(res)
    assert "USB not faster than RS232 (medians)" in {c.name for c in res.checks}


def test_fig20_tripod_gait(tmp_path: Path) -> None:
    from urb_sim.experiments import gait

    res = gait.fig20(tmp_path, quick=True)
    _assert_passed(res)
    # the criteria hold at 500 Hz; the paper's 1 kHz is named as not reproduced, for the headline
    [deviation] = res.deviations
    assert deviation.startswith("Fig. 20: the paper's six legs under 1-kHz control do not fit")


def test_bandwidth_limits(tmp_path: Path) -> None:
    from urb_sim.experiments import bandwidth

    res = bandwidth.bandwidth(tmp_path, quick=True)
    _assert_passed(res)
    assert [d.split(":")[1].split(" at ")[0].strip() for d in res.deviations] == [
        "RS232 sustains 9-byte reads", "three motors per USB bridge"]
    # the uplink table holds uplink rows only; the motor workload has its own table and columns
    assert all(r["uplink"] in ("rs232", "usb") and isinstance(r["payload B"], int) for r in res.table)
    [(caption, motors)] = res.tables
    assert "motor workload" in caption
    assert [(r["motors per bridge"], r["loop rate Hz"]) for r in motors] == [(m, hz) for m in (1, 2, 3)
                                                                            for hz in (1000, 500)]
    assert all(r["sustained"] in ("yes", "NO") and r["read latency max ms"] >= r["read latency mean ms"]
               for r in motors)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [8, 14])
def test_every_experiment_passes_at_other_seeds(tmp_path: Path, seed: int) -> None:
    """The acceptance criteria are claims about the system, not about one seed. Seed 14 draws USB
    frame and host-loop phases at which Fig. 16's old 3.0-ms bound, Figs. 18-19's old delay window
    and the motor workload's old deadline failed; seed 8 an inbox trace too short for its seeded
    bug (`urb sim sensorhex --quick --seed N`)."""
    results = run_experiments(list(EXPERIMENTS), tmp_path, quick=True, seed=seed, jobs=2, progress=no_progress)
    failed = [f"{r.key}: {c.name}: {c.measured}" for r in results for c in r.checks if not c.passed]
    assert not failed, failed
    assert [r.key for r in results] == list(EXPERIMENTS)


# lobster-trace: urb.CRC_006
@pytest.mark.parametrize("detected", [0, 1, 40, 255, 2000])
def test_crc8_residual_bound_is_the_poisson_quantile(detected: int) -> None:
    """The largest count of undetected frames that a correct CRC-8 exceeds less than once in a
    million runs: P(X > bound) < 1e-6 <= P(X > bound - 1) for X ~ Poisson(detected / 255)."""
    from urb_sim.experiments.faults import crc8_residual_bound

    lam = detected / 255
    bound = crc8_residual_bound(detected)

    def above(k: int) -> float:  # P(X > k), summed from the top so that it stays exact when tiny
        return sum(math.exp(-lam) * lam ** i / math.factorial(i) for i in range(k + 1, k + 60))

    assert above(bound) < 1e-6
    assert bound == 0 or above(bound - 1) >= 1e-6
