"""Speed of numerical single and multiple scattering (issue 5; pytest-benchmark).

Run: ``python -m pytest benchmarks/bench_scattering.py`` (quick check without timing:
``--benchmark-disable``).  Target of issue 5: 10⁶ ground-observer directions at ≤ 1e-3
maximum relative error in ≤ 1.5 s on a 2-core machine — the default method switches to
the symmetric table path for such batches (``docs/numerical_scattering.md``).
"""

from __future__ import annotations

import numpy as np
import pytest

import atmoscatter as ac

_RNG = np.random.default_rng(0)
_SUN = np.array([0.0, np.cos(np.radians(30.0)), np.sin(np.radians(30.0))])


def _upper_hemisphere(n):
    v = _RNG.normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2])
    return v / np.linalg.norm(v, axis=1)[:, None]


@pytest.fixture(scope="module")
def earth():
    return ac.earth_atmosphere()


@pytest.mark.parametrize("n", [10_000, 100_000, 1_000_000], ids=["1e4", "1e5", "1e6"])
def test_single_scattering_default_ground(benchmark, earth, n):
    """Default method (table path for these batch sizes), clear sky, sun 30° high.

    The table cache is cleared before every round, so the time includes building it."""
    import atmoscatter.sky._single_table as table_mod

    v = _upper_hemisphere(n)

    def setup():
        table_mod._TABLE_CACHE.clear()  # time the table build too, every round
        return (earth, v, _SUN), {}

    out = benchmark.pedantic(ac.single_scattering, setup=setup, rounds=3)
    assert out.shape == (n, 3)
    assert np.all(np.isfinite(out)) and np.all(out > 0)


@pytest.mark.parametrize("method, samples", [("graded", 4), ("keller_bohn", 16),
                                             ("gauss_legendre", 16)])
def test_single_scattering_per_direction(benchmark, earth, method, samples):
    """Direct integration (no table): 2000 directions."""
    v = _upper_hemisphere(2000)
    out = benchmark(ac.single_scattering, earth, v, _SUN, method=method, samples=samples)
    assert np.all(np.isfinite(out))


def test_single_scattering_twilight_graded(benchmark, earth):
    """Sun 4° below the horizon: shadows, so the default stays on the graded rule."""
    v = _upper_hemisphere(2000)
    sun = np.array([0.0, np.cos(np.radians(-4.0)), np.sin(np.radians(-4.0))])
    out = benchmark(ac.single_scattering, earth, v, sun)
    assert np.all(np.isfinite(out)) and np.all(out >= 0)


def test_multiple_scattering_gather(benchmark, earth):
    """Orders 1–6 for 2000 directions once the field is cached (first call builds it)."""
    v = _upper_hemisphere(2000)
    ac.multiple_scattering(earth, v[:1], _SUN, orders=6)  # build and cache the field
    out = benchmark(ac.multiple_scattering, earth, v, _SUN, orders=6)
    assert np.all(np.isfinite(out)) and np.all(out > 0)


def test_multiple_scattering_large_batch(benchmark, earth):
    """10⁵ directions: the multiple-scattering part is tabulated over (μ, φ)."""
    v = _upper_hemisphere(100_000)
    ac.multiple_scattering(earth, v[:1], _SUN, orders=6)  # build and cache the field
    out = benchmark(ac.multiple_scattering, earth, v, _SUN, orders=6)
    assert np.all(np.isfinite(out)) and np.all(out > 0)


def test_peak_memory_bounded(earth):
    """Peak memory beyond input and output does not grow with the number of directions."""
    import tracemalloc

    import atmoscatter.sky._single_table as table_mod

    extra = {}
    for n in (100_000, 1_000_000):
        v = _upper_hemisphere(n)
        table_mod._TABLE_CACHE.clear()
        tracemalloc.start()
        out = ac.single_scattering(earth, v, _SUN)
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        extra[n] = peak - out.nbytes - v.nbytes  # v is copied once (normalised float64)
        del out
    assert extra[1_000_000] < 150e6
    assert extra[1_000_000] < extra[100_000] + 60e6


# twilight and hazy low-sun large batches (issue 10).  The default size keeps a CI run
# (--benchmark-disable) at seconds; measure the 10⁶ case with
#   ATMOSCATTER_BENCH_N=1000000 python -m pytest benchmarks/bench_scattering.py -k "twilight_large or low_sun"
_N_LARGE = int(__import__("os").environ.get("ATMOSCATTER_BENCH_N", "4096"))


@pytest.mark.parametrize("elev", [-6.0, -12.0, -18.0])
def test_single_scattering_twilight_large(benchmark, earth, elev):
    """Sun below the horizon, default method (graded; fully shadowed paths are skipped)."""
    v = _upper_hemisphere(_N_LARGE)
    e = np.radians(elev)
    sun = np.array([0.0, np.cos(e), np.sin(e)])
    out = benchmark.pedantic(ac.single_scattering, args=(earth, v, sun), rounds=1)
    assert np.all(np.isfinite(out)) and np.all(out >= 0)


def test_single_scattering_low_sun_hazy_large(benchmark):
    """Turbidity 6, sun 1° high: the checked table (build included, cache cleared)."""
    import atmoscatter.sky._single_table as table_mod

    atm = ac.earth_turbidity_atmosphere(6)
    v = _upper_hemisphere(_N_LARGE)
    sun = np.array([0.0, np.cos(np.radians(1.0)), np.sin(np.radians(1.0))])

    def setup():
        table_mod._TABLE_CACHE.clear()
        return (atm, v, sun), {}

    out = benchmark.pedantic(ac.single_scattering, setup=setup, rounds=1)
    assert np.all(np.isfinite(out)) and np.all(out >= 0)
