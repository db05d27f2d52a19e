"""Benchmarks of the analytic skies (issue 4): Preetham → linear RGB per direction.

Run with timing::

    PYTHONPATH=. python -m pytest benchmarks/bench_analytic.py --benchmark-only
    PYTHONPATH=. python benchmarks/bench_analytic.py          # table: directions/s, speed-up

Targets (issue 4): float32 input ~3e7 directions/s on 2 cores and >= 6x the straightforward
float64 NumPy expression below (the baseline); float32 within 2e-4 relative of float64,
float64 within 1e-6 relative of the published model (checked here against the baseline).
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

import atmoscatter as ac

SIZES = [10**4, 10**5, 10**6]
TURBIDITY = 3.0
SUN = np.array([0.0, math.sin(math.radians(50.0)), math.cos(math.radians(50.0))])


def directions(n: int, dtype=np.float64, seed: int = 0) -> np.ndarray:
    v = np.random.default_rng(seed).normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2])
    return (v / np.linalg.norm(v, axis=1, keepdims=True)).astype(dtype)


def baseline_rgb(v: np.ndarray, sun: np.ndarray, T: float) -> np.ndarray:
    """The straightforward float64 NumPy expression of the Preetham model → linear sRGB.

    Preetham et al. (1999) Appendix A.2 / errata 003.3, written the obvious way: whole-array
    temporaries, no fusion, no chunking. Upper-hemisphere directions only.
    """
    v = v.astype(np.float64)
    ts = math.acos(sun[2])
    cos_t = v[:, 2]
    gamma = np.arccos(np.clip(v @ sun, -1.0, 1.0))
    chi = (4 / 9 - T / 120) * (math.pi - 2 * ts)
    zen_Y = ((4.0453 * T - 4.9710) * math.tan(chi) - 0.2155 * T + 2.4192) * 1000.0
    Mx = np.array([[0.00166, -0.00375, 0.00209, 0], [-0.02903, 0.06377, -0.03202, 0.00394],
                   [0.11693, -0.21196, 0.06052, 0.25886]])  # fmt: skip
    My = np.array([[0.00275, -0.00610, 0.00317, 0], [-0.04214, 0.08970, -0.04153, 0.00516],
                   [0.15346, -0.26756, 0.06670, 0.26688]])  # fmt: skip
    tp = np.array([T * T, T, 1.0])
    sp = np.array([ts**3, ts**2, ts, 1.0])
    zen = [zen_Y, tp @ Mx @ sp, tp @ My @ sp]
    tables = [
        [(0.1787, -1.4630), (-0.3554, 0.4275), (-0.0227, 5.3251), (0.1206, -2.5771), (-0.0670, 0.3703)],
        [(-0.0193, -0.2592), (-0.0665, 0.0008), (-0.0004, 0.2125), (-0.0641, -0.8989), (-0.0033, 0.0452)],
        [(-0.0167, -0.2608), (-0.0950, 0.0092), (-0.0079, 0.2102), (-0.0441, -1.6537), (-0.0109, 0.0529)],
    ]
    out = []
    for z, tab in zip(zen, tables, strict=True):
        A, B, C, D, E = (a * T + b for a, b in tab)
        F = (1 + A * np.exp(B / cos_t)) * (1 + C * np.exp(D * gamma) + E * np.cos(gamma) ** 2)
        F0 = (1 + A * math.exp(B)) * (1 + C * math.exp(D * ts) + E * math.cos(ts) ** 2)
        out.append(z * F / F0)
    Y, x, y = out
    XYZ = np.stack([x / y * Y, Y, (1 - x - y) / y * Y], axis=-1)
    return ac.XYZ_to_linear_rgb(XYZ, "sRGB")


@pytest.fixture(scope="module", params=SIZES, ids=lambda n: f"n={n:.0e}")
def views(request):
    n = request.param
    return directions(n), directions(n, np.float32)


def _check(rgb, ref, tol):
    scale = np.abs(ref).max(axis=1, keepdims=True)
    err = float(np.max(np.abs(rgb - ref) / scale))
    assert err < tol, err


def test_bench_preetham_rgb_numpy_baseline(benchmark, views):
    v64, _ = views
    benchmark(baseline_rgb, v64, SUN, TURBIDITY)


def test_bench_preetham_rgb_float64(benchmark, views):
    v64, _ = views
    rgb = benchmark(ac.preetham_sky_rgb, v64, SUN, TURBIDITY)
    _check(rgb, baseline_rgb(v64, SUN, TURBIDITY), 1e-6)


def test_bench_preetham_rgb_float32(benchmark, views):
    v64, v32 = views
    rgb = benchmark(ac.preetham_sky_rgb, v32, SUN, TURBIDITY)
    assert rgb.dtype == np.float32
    _check(rgb, baseline_rgb(v32.astype(np.float64), SUN, TURBIDITY), 2e-4)


def _rate(fn, *args, repeat=5):
    fn(*args)  # warm-up (JIT compile / cache load)
    best = math.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn(*args)
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> None:  # pragma: no cover - manual table
    import os

    print(f"cores: {os.cpu_count()}  (shared machine: numbers are noisy; best of 7)")
    print(f"{'n':>8} {'baseline/s':>12} {'f64/s':>12} {'f32/s':>12} {'f64 x':>7} {'f32 x':>7}")
    for n in SIZES:
        v64, v32 = directions(n), directions(n, np.float32)
        tb = _rate(baseline_rgb, v64, SUN, TURBIDITY, repeat=7)
        t64 = _rate(ac.preetham_sky_rgb, v64, SUN, TURBIDITY, repeat=7)
        t32 = _rate(ac.preetham_sky_rgb, v32, SUN, TURBIDITY, repeat=7)
        print(f"{n:>8.0e} {n / tb:>12.3g} {n / t64:>12.3g} {n / t32:>12.3g} {tb / t64:>7.1f} {tb / t32:>7.1f}")
    H, W = 1080, 1920
    rng = np.random.default_rng(0)
    L0 = rng.uniform(0.0, 2e3, (H, W, 3)).astype(np.float32)
    depth = rng.uniform(0.0, 3e4, (H, W))
    t = _rate(ac.aerial_perspective, L0, depth, np.array([0.0, 1.0, 0.05]), SUN, repeat=3)
    print(f"aerial_perspective 1920x1080: {t * 1e3:.0f} ms ({H * W / t:.3g} pixels/s)")


if __name__ == "__main__":  # pragma: no cover
    main()


# ------------------------------------------------------------------------------------------------
# Hoffman–Preetham aerial perspective on a depth buffer (1920 x 1080, one view per pixel)
# ------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def depth_buffer():
    H, W = 1080, 1920
    rng = np.random.default_rng(0)
    depth = rng.uniform(0.0, 3e4, (H, W))
    L0 = rng.uniform(0.0, 2e3, (H, W, 3)).astype(np.float32)
    az = np.linspace(-0.6, 0.6, W)[None, :]
    el = np.linspace(0.3, -0.3, H)[:, None]
    views = np.stack(np.broadcast_arrays(np.sin(az) * np.cos(el), np.cos(az) * np.cos(el), np.sin(el)), axis=-1)
    return L0, depth, views.astype(np.float32)


def test_bench_aerial_perspective_1080p(benchmark, depth_buffer):
    L0, depth, views = depth_buffer
    out = benchmark.pedantic(ac.aerial_perspective, args=(L0, depth, views, SUN), rounds=1, iterations=1)
    assert out.shape == L0.shape and out.dtype == np.float32
