"""Speed of the foundation primitives (pytest-benchmark).

Run: ``python -m pytest benchmarks/bench_foundation.py`` (quick check without timing:
``--benchmark-disable``).  Sizes are parameters so scaling is visible in the table.
"""

from __future__ import annotations

import numpy as np
import pytest

import atmoscatter as ac

KW = {"planet_radius": 6.36e6, "top_radius": 6.42e6}
_RNG = np.random.default_rng(0)


# The tabulated US 1976 profile has ~90 breakpoints, so it costs ~20x an exponential per
# ray; it runs at 1e4 rays only to keep the quick (--benchmark-disable) pass short.
OPTICAL_LENGTH_CASES = [
    (10_000, ac.ExponentialProfile(8000.0)),
    (100_000, ac.ExponentialProfile(8000.0)),
    (10_000, ac.TentProfile(25e3, 15e3)),
    (100_000, ac.TentProfile(25e3, 15e3)),
    (10_000, ac.us_standard_1976_profile()),
]


@pytest.mark.parametrize(
    ("n", "profile"),
    OPTICAL_LENGTH_CASES,
    ids=["exponential-1e4", "exponential-1e5", "tent-1e4", "tent-1e5", "us1976-1e4"],
)
def test_optical_length(benchmark, n, profile):
    h = _RNG.uniform(0.0, 20e3, n)
    mu = _RNG.uniform(-1.0, 1.0, n)
    out = benchmark(ac.optical_length, profile, h, mu, **KW)
    assert out.shape == (n,)
    assert np.all(np.isfinite(out))


@pytest.mark.parametrize("n", [1_000_000])
@pytest.mark.parametrize(
    "phase",
    [
        ac.rayleigh_phase,
        lambda mu: ac.henyey_greenstein_phase(mu, 0.8),
        lambda mu: ac.cornette_shanks_phase(mu, 0.8),
    ],
    ids=["rayleigh", "henyey_greenstein", "cornette_shanks"],
)
def test_phase_functions(benchmark, n, phase):
    mu = _RNG.uniform(-1.0, 1.0, n)
    out = benchmark(phase, mu)
    assert out.shape == (n,)


@pytest.mark.parametrize("n", [1_000_000])
def test_rayleigh_scattering(benchmark, n):
    wl = _RNG.uniform(380.0, 780.0, n)
    out = benchmark(ac.rayleigh_scattering, wl)
    assert out.shape == (n,)


@pytest.mark.parametrize("n", [1_000_000])
def test_relative_optical_length(benchmark, n):
    z = _RNG.uniform(0.0, np.pi / 2, n)
    out = benchmark(ac.relative_optical_length, z)
    assert out.shape == (n,)
