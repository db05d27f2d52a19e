"""Throughput of atmoscatter.sun_position against pvlib's NREL SPA (numpy) and ephemeris.

Run:  PYTHONPATH=. python -m pytest benchmarks/bench_sun.py --benchmark-only
      (``--benchmark-disable`` runs each case once, as CI does).

Cases
-----
- ``hourly``: n consecutive hourly timestamps at one site (the usual time-series use).
- ``random``: n times drawn uniformly over 1900–2100 (worst case for the node interpolation:
  every 2-day interval holds a sample when n ≳ 1e5).
- ``grid``: one year hourly (8760) × 1000 sites, times broadcast against sites (ours only).

pvlib's 1e6 cases take 5–20 s per call, too long for CI's quick pass; they run only with
``ATMOSCATTER_BENCH_FULL=1`` in the environment (as for the numbers in docs/sun.md).
"""

from __future__ import annotations

import os

import numpy as np
import pytest

import atmoscatter as ac

pvlib = pytest.importorskip("pvlib")
pd = pytest.importorskip("pandas")

LAT, LON = 39.742476, -105.1786


def _times(kind: str, n: int) -> np.ndarray:
    if kind == "hourly":
        return np.datetime64("2000-01-01T00:00", "ns") + np.arange(n) * np.timedelta64(1, "h")
    rng = np.random.default_rng(0)
    span = int(200 * 365.25 * 86400)
    return np.datetime64("1900-01-01", "ns") + (
        rng.integers(0, span, n).astype("timedelta64[s]")
    ).astype("timedelta64[ns]")


CASES = [("hourly", 100_000), ("hourly", 1_000_000), ("random", 100_000), ("random", 1_000_000)]


@pytest.mark.parametrize("kind, n", CASES, ids=[f"{k}-{n:.0e}" for k, n in CASES])
def test_atmoscatter_spa(benchmark, kind, n):
    t = _times(kind, n)
    benchmark.group = f"sun {kind} n={n:.0e}"
    res = benchmark(ac.sun_position, t, LAT, LON)
    assert res.zenith.shape == (n,)


@pytest.mark.parametrize("kind, n", CASES, ids=[f"{k}-{n:.0e}" for k, n in CASES])
def test_pvlib_nrel_numpy(benchmark, kind, n):
    if n > 100_000 and not os.environ.get("ATMOSCATTER_BENCH_FULL"):
        pytest.skip("set ATMOSCATTER_BENCH_FULL=1 for pvlib's 1e6 cases (5-20 s per call)")
    idx = pd.DatetimeIndex(_times(kind, n)).tz_localize("UTC")
    benchmark.group = f"sun {kind} n={n:.0e}"
    res = benchmark(pvlib.solarposition.spa_python, idx, LAT, LON, how="numpy", delta_t=None)
    assert len(res) == n


@pytest.mark.parametrize("kind, n", CASES, ids=[f"{k}-{n:.0e}" for k, n in CASES])
def test_pvlib_ephemeris(benchmark, kind, n):
    idx = pd.DatetimeIndex(_times(kind, n)).tz_localize("UTC")
    benchmark.group = f"sun {kind} n={n:.0e}"
    res = benchmark(pvlib.solarposition.ephemeris, idx, LAT, LON)
    assert len(res) == n


def test_atmoscatter_grid_year_by_1000_sites(benchmark):
    t = np.datetime64("2024-01-01T00:00", "ns") + np.arange(8760) * np.timedelta64(1, "h")
    rng = np.random.default_rng(1)
    lat, lon = rng.uniform(-60, 60, 1000), rng.uniform(-180, 180, 1000)
    benchmark.group = "sun grid 8760x1000"
    res = benchmark.pedantic(ac.sun_position, args=(t[:, None], lat, lon), rounds=3)
    assert res.zenith.shape == (8760, 1000)


def test_sunrise_sunset_year_by_1000_sites(benchmark):
    dates = np.datetime64("2024-01-01") + np.arange(366).astype("timedelta64[D]")
    rng = np.random.default_rng(2)
    lat, lon = rng.uniform(-70, 70, 1000), rng.uniform(-180, 180, 1000)
    benchmark.group = "sunrise_sunset 366x1000"
    res = benchmark.pedantic(ac.sunrise_sunset, args=(dates[:, None], lat, lon), rounds=3)
    assert res.sunrise.shape == (366, 1000)


def _interleaved(repeats: int = 5) -> None:
    """Ratios robust to a busy machine: alternate the implementations, keep each one's best."""
    import time

    impls = {
        "atmoscatter spa": lambda t, idx: ac.sun_position(t, LAT, LON),
        "pvlib nrel_numpy": lambda t, idx: pvlib.solarposition.spa_python(
            idx, LAT, LON, how="numpy", delta_t=None
        ),
        "pvlib ephemeris": lambda t, idx: pvlib.solarposition.ephemeris(idx, LAT, LON),
    }
    print("case            " + "".join(f"{k:>20s}" for k in impls) + "   nrel/ours  eph/ours")
    for kind, n in CASES:
        t = _times(kind, n)
        idx = pd.DatetimeIndex(t).tz_localize("UTC")
        best = dict.fromkeys(impls, np.inf)
        for _ in range(repeats if n <= 100_000 else max(2, repeats // 2)):
            for name, fn in impls.items():
                t0 = time.perf_counter()
                fn(t, idx)
                best[name] = min(best[name], time.perf_counter() - t0)
        ours = best["atmoscatter spa"]
        print(
            f"{kind:6s} n={n:.0e}  "
            + "".join(f"{1e3 * v:17.1f} ms" for v in best.values())
            + f"   {best['pvlib nrel_numpy'] / ours:8.1f}x {best['pvlib ephemeris'] / ours:8.2f}x"
        )


if __name__ == "__main__":  # PYTHONPATH=. python benchmarks/bench_sun.py
    _interleaved()
