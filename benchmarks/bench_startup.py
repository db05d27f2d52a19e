"""Start-up and the render path against its kernel (issue 11).

Run:   python -m pytest benchmarks/bench_startup.py --benchmark-only -s
Quick: python -m pytest benchmarks/bench_startup.py --benchmark-disable   (CI: runs once)

* ``import atmoscatter`` and ``atmoscatter --help`` in a fresh interpreter (target ≤ 0.3 s and
  ≤ 0.5 s on the 2-core machine): timed as whole subprocesses, minus a bare interpreter start
  that is reported alongside.
* The default ``atmoscatter render -o sky.exr`` end to end, cold (empty numba cache: the
  kernels compile) and warm (second process: numba's ``cache=True`` must hit; checked from the
  dispatchers' cache statistics, not from the timing).  Target warm ≤ 1.5 s.
* ``render(Scene(width=1024, height=512))`` (Preetham) against the bare ``preetham_sky`` call
  on the same 262 144 sky directions, in a warm process (target ≤ 2×).
"""

import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
import pytest

import atmoscatter as ac
from atmoscatter.directions import direction_set

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(ac.__file__)))


def _env(**extra):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([ROOT, os.environ.get("PYTHONPATH", "")]))
    env.update(extra)
    return env


def _run(args, cwd=None, env=None):
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, *args], capture_output=True, text=True,
                       env=env or _env(), cwd=cwd, timeout=600)
    dt = time.perf_counter() - t0
    assert r.returncode == 0, r.stderr
    return dt, r


def _best_run(args, repeats):
    return min(_run(args)[0] for _ in range(repeats))


@pytest.mark.parametrize("what,args", [
    ("import", ["-c", "import atmoscatter"]),
    ("help", ["-m", "atmoscatter", "--help"]),
])
def test_startup_subprocess(benchmark, what, args):
    benchmark.pedantic(_run, args=(args,), rounds=1 if benchmark.disabled else 5, iterations=1)
    if benchmark.disabled:
        return
    bare = _best_run(["-c", "pass"], 5)
    total = _best_run(args, 5)
    benchmark.extra_info.update(total_s=total, interpreter_s=bare)
    print(f"\n{what}: {total:.3f} s in a fresh process (bare interpreter {bare:.3f} s)")


_CACHE_PROBE = """
import json, sys
from atmoscatter.cli import main
assert main(["render", "-o", sys.argv[1], "--quiet"]) == 0
from atmoscatter.sky import _preetham_kernels as k
hits = sum(sum(f.stats.cache_hits.values()) for f in (k._direct_rows,))
misses = sum(sum(f.stats.cache_misses.values()) for f in (k._direct_rows,))
print(json.dumps({"hits": hits, "misses": misses}))
"""


def test_default_render_cold_and_warm():
    """The README's ``atmoscatter render -o sky.exr``: cold (kernels compile into an empty numba
    cache) then warm (a second process loads them from the cache: ``cache=True`` hits)."""
    pytest.importorskip("numba")
    with tempfile.TemporaryDirectory() as tmp:
        env = _env(NUMBA_CACHE_DIR=os.path.join(tmp, "numba"))
        out = os.path.join(tmp, "sky.exr")
        cold, r1 = _run(["-c", _CACHE_PROBE, out], env=env)
        warm, r2 = _run(["-c", _CACHE_PROBE, out], env=env)
        first = json.loads(r1.stdout.strip().splitlines()[-1])
        second = json.loads(r2.stdout.strip().splitlines()[-1])
    assert first["misses"] >= 1 and first["hits"] == 0, first
    assert second["hits"] >= 1 and second["misses"] == 0, second  # numba's cache=True works
    print(f"\ndefault render end to end: cold {cold:.2f} s, warm {warm:.2f} s")


def _best(fn, repeats):
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def test_render_1024x512_against_the_bare_kernel(benchmark):
    """Whole ``render`` (plan, directions, ground fill, XYZ → RGB, alpha, metadata) against
    ``preetham_sky`` on the sky directions the render evaluates (best of several runs each)."""
    scene = ac.Scene(width=1024, height=512)
    p = ac.plan(scene)
    d = direction_set(scene, p).all_directions().reshape(-1, 3)
    sky = d[d[:, 2] >= p.horizon_z] if p.skip_below_horizon else d
    img = benchmark(ac.render, scene)
    xyz = ac.preetham_sky(sky, p.sun_direction, scene.turbidity)
    rgb_sky = img.rgb.reshape(-1, 3)[img.alpha.ravel() > 0]
    # float32 output of the same float64 values: within float32 rounding
    np.testing.assert_allclose(rgb_sky, ac.XYZ_to_linear_rgb(xyz), rtol=1e-6, atol=1e-6)
    if benchmark.disabled:
        return
    t_kernel = _best(lambda: ac.preetham_sky(sky, p.sun_direction, scene.turbidity), 15)
    t_render = _best(lambda: ac.render(scene), 15)
    ratio = t_render / t_kernel
    benchmark.extra_info.update(render_s=t_render, kernel_s=t_kernel, ratio=ratio,
                                directions=len(sky))
    print(f"\nrender 1024x512: {t_render * 1e3:.1f} ms; bare preetham_sky on its {len(sky)} "
          f"sky directions: {t_kernel * 1e3:.1f} ms; ratio {ratio:.2f}")
    assert ratio < 2.0, f"render is {ratio:.2f}x its kernel (target <= 2x)"
