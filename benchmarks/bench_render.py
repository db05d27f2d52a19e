"""Per-vertex throughput of the evaluator and its overhead over calling the model directly.

Run:   python -m pytest benchmarks/bench_render.py --benchmark-only
Quick: python -m pytest benchmarks/bench_render.py --benchmark-disable   (CI: runs once)

``ATMOSCATTER_BENCH_FULL=1`` runs the numerical models at 10^4-10^6 directions (minutes);
by default they run at 2000 directions so that the quick CI pass stays short.
Targets: 10^4-10^6 vertices per model; evaluator overhead < 10 % over the direct call
(render → float32 linear RGB against model → XYZ → linear RGB as float32), measured by
timing the evaluator with a no-cost model (see ``test_evaluator_overhead``).
"""

import os
import time

import numpy as np
import pytest

import atmoscatter as ac
from atmoscatter.render.models import ModelAdapter, register_model, unregister_model

SUN = np.array([0.0, np.cos(np.radians(35.0)), np.sin(np.radians(35.0))])
FULL = os.environ.get("ATMOSCATTER_BENCH_FULL") == "1"


def _toy_prepare(scene, plan):
    sun = plan.sun_direction

    def evaluate(d):
        y = 2000.0 + 3000.0 * (d @ sun) ** 2 + 1000.0 * d[:, 2]
        return {"XYZ": np.stack([0.95 * y, y, 1.09 * y], -1)}

    return evaluate


@pytest.fixture(scope="module", autouse=True)
def toy():
    register_model(ModelAdapter(name="bench_toy", description="cheap analytic stand-in",
                                prepare=_toy_prepare), replace=True)
    yield
    unregister_model("bench_toy")


def upper_directions(n, seed=0):
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d[:, 2] = np.abs(d[:, 2])
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def scene_for(model):
    return ac.Scene(model=model, sun_elevation_deg=35.0, sun_azimuth_deg=0.0, turbidity=3.0)


ANALYTIC = [m for m in ("preetham", "hoffman_preetham", "cie_overcast", "cie_clear")
            if m in ac.MODELS] + ["bench_toy"]
NUMERICAL = [m for m in ("single_scattering", "multiple_scattering") if m in ac.MODELS]
CASES = [(m, n) for m in ANALYTIC for n in (10**4, 10**5, 10**6)]
# the numerical models cost µs to ms per direction (plus set-up): 2000 directions in the quick
# run, 10^4-10^6 with ATMOSCATTER_BENCH_FULL=1
CASES += [(m, n) for m in NUMERICAL for n in ((10**4, 10**5, 10**6) if FULL else (2000,))]


@pytest.mark.parametrize("model,n", CASES)
def test_vertex_throughput(benchmark, model, n):
    d = upper_directions(n)
    scene = scene_for(model)
    img = benchmark(ac.render, scene, directions=d)
    assert img.rgb.shape == (n, 3) and np.all(np.isfinite(img.rgb))
    if benchmark.stats is not None:
        benchmark.extra_info["vertices_per_second"] = n / benchmark.stats.stats.min


def _direct(model, d):
    """The model called directly, producing the same float32 linear-RGB output."""
    if model == "preetham":
        xyz = ac.preetham_sky(d, SUN, 3.0)
    else:
        y = 2000.0 + 3000.0 * (d @ SUN) ** 2 + 1000.0 * d[:, 2]
        xyz = np.stack([0.95 * y, y, 1.09 * y], -1)
    return ac.XYZ_to_linear_rgb(xyz).astype(np.float32)


def _best(fn, repeats):
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


_CONST = np.array([1000.0, 1100.0, 1200.0])


def _null_prepare(scene, plan):
    # a model that costs nothing: rendering it measures the evaluator alone
    return lambda d: {"XYZ": np.broadcast_to(_CONST, (len(d), 3))}


@pytest.mark.parametrize("model", ["preetham" if "preetham" in ac.MODELS else "bench_toy"])
@pytest.mark.parametrize("n", [10**6])
def test_evaluator_overhead(benchmark, model, n):
    """Overhead = (evaluator alone − the XYZ→RGB step the direct call also does) / direct call.

    Timing the pieces separately (best of several runs each) is far less sensitive to a shared,
    loaded machine than comparing two whole timings.
    """
    d = upper_directions(n)
    scene = scene_for(model)
    out = benchmark(ac.render, scene, directions=d)
    np.testing.assert_allclose(out.rgb, _direct(model, d), rtol=1e-5, atol=1e-3)
    if benchmark.disabled:
        return
    register_model(ModelAdapter(name="bench_null", description="no-cost model",
                                prepare=_null_prepare), replace=True)
    try:
        null_scene = scene_for("bench_null")
        t_evaluator = _best(lambda: ac.render(null_scene, directions=d), 9)
    finally:
        unregister_model("bench_null")
    xyz = ac.preetham_sky(d, SUN, 3.0) if model == "preetham" else None
    t_model = _best(lambda: ac.preetham_sky(d, SUN, 3.0), 9) if model == "preetham" else _best(
        lambda: _direct(model, d), 9)
    t_convert = _best(lambda: ac.XYZ_to_linear_rgb(xyz).astype(np.float32), 9) if xyz is not None else 0.0
    t_direct = t_model + t_convert
    overhead = (t_evaluator - t_convert) / t_direct
    benchmark.extra_info.update(model_s=t_model, convert_s=t_convert, evaluator_s=t_evaluator,
                                overhead=overhead)
    print(f"\n{model} n={n}: model {t_model * 1e3:.1f} ms + XYZ->RGB {t_convert * 1e3:.1f} ms; "
          f"evaluator alone {t_evaluator * 1e3:.1f} ms; overhead {overhead * 100:+.1f} %")
    assert overhead < 0.10, f"evaluator overhead {overhead:.1%} exceeds the 10 % target"


@pytest.mark.parametrize("projection,size", [("latlong", (2048, 1024)), ("cubemap", (512, 512)),
                                             ("fisheye", (1024, 1024)), ("dome", (256, 64))])
def test_projection_render(benchmark, projection, size):
    model = "preetham" if "preetham" in ac.MODELS else "bench_toy"
    scene = ac.Scene(model=model, sun_elevation_deg=35.0, sun_azimuth_deg=120.0,
                     projection=projection, width=size[0], height=size[1])
    img = benchmark(ac.render, scene)
    assert np.all(np.isfinite(img.rgb))
