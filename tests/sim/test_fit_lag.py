"""fit_lag (Figs. 18-19) finds the same lag as the direct search over every step, which evaluates
the squared error sample by sample, and the same RMS error to many digits."""

from __future__ import annotations

import math
import random

import pytest

from urb_sim.experiments.control import fit_lag


def _direct(samples: list[tuple[int, float, float]], amp: float, omega: float) -> tuple[float, float]:
    best = (0.0, float("inf"))
    for k in range(-500, 2001):
        lag = k * 1e-5
        sse = sum((p - amp * math.sin(omega * (t * 1e-9 - lag))) ** 2 for t, p, _ in samples)
        if sse < best[1]:
            best = (lag, sse)
    return best[0] * 1e3, math.sqrt(best[1] / len(samples))


@pytest.mark.parametrize("seed, lag_s, noise", [(1, 0.00213, 0.01), (2, 0.00307, 0.05), (3, -0.0012, 0.0),
                                                 (4, 0.0179, 0.2)])
def test_fit_lag_matches_the_direct_search(seed: int, lag_s: float, noise: float) -> None:
    rng = random.Random(seed)
    amp, omega = 4 * math.pi, 2 * math.pi * 0.5
    samples = []
    for i in range(600):
        t = 1_000_000_000 + i * 1_000_000 + rng.randrange(1000)
        samples.append((t, amp * math.sin(omega * (t * 1e-9 - lag_s)) + rng.gauss(0.0, noise), 0.0))
    lag, rms = fit_lag(samples, amp, omega)
    ref_lag, ref_rms = _direct(samples, amp, omega)
    assert lag == ref_lag
    # the grid step is 10 us; the noise moves the best fit by about noise / (A omega sqrt(n / 2))
    spread_ms = noise / (amp * omega * math.sqrt(len(samples) / 2)) * 1e3
    assert lag == pytest.approx(lag_s * 1e3, abs=0.011 + 5 * spread_ms)
    assert rms == pytest.approx(ref_rms, rel=1e-6, abs=1e-9)
