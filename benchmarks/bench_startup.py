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
from atmoscatter.render.directions import direction_set

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(ac.__file__)))


def _env(**extra):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([ROOT, os.environ.get("PYTHONPATH", "")]))
    # as installed (pip writes bytecode): without this, every process would compile the
    # package's source again (~0.1 s) and the timings would measure the compiler
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    env.update(extra)
    return env


def _best(fn, repeats):
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def _run(args, cwd=None, env=None):
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, *args], capture_output=True, text=True,
                       env=env or _env(), cwd=cwd, timeout=600)
    dt = time.perf_counter() - t0
    assert r.returncode == 0, r.stderr
    return dt, r


def _best_run(args, repeats):
    _run(args)  # writes the bytecode of what it imports
    return min(_run(args)[0] for _ in range(repeats))


def _cold_warm():
    """Seconds of the default CLI render in a process with an empty numba cache, then in a
    second process with the same cache, and the cache statistics of both."""
    with tempfile.TemporaryDirectory() as tmp:
        env = _env(NUMBA_CACHE_DIR=os.path.join(tmp, "numba"))
        out = os.path.join(tmp, "sky.exr")
        cold, r1 = _run(["-c", _CACHE_PROBE, out], env=env)
        warm = []
        for _ in range(5):
            dt, r2 = _run(["-c", _CACHE_PROBE, out], env=env)
            warm.append(dt)
    stats = [json.loads(r.stdout.strip().splitlines()[-1]) for r in (r1, r2)]
    return cold, min(warm), stats


def _render_and_kernel(repeats=15):
    scene = ac.Scene(width=1024, height=512)
    p = ac.plan(scene)
    d = direction_set(scene, p).all_directions().reshape(-1, 3)
    sky = d[d[:, 2] >= p.horizon_z] if p.skip_below_horizon else d
    ac.render(scene)
    t_kernel = _best(lambda: ac.preetham_sky(sky, p.sun_direction, scene.turbidity), repeats)
    t_render = _best(lambda: ac.render(scene), repeats)
    return t_render, t_kernel, len(sky)


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
    cache) then warm (later processes load them from the cache: ``cache=True`` hits)."""
    pytest.importorskip("numba")
    cold, warm, (first, second) = _cold_warm()
    assert first["misses"] >= 1 and first["hits"] == 0, first
    assert second["hits"] >= 1 and second["misses"] == 0, second  # numba's cache=True works
    print(f"\ndefault render end to end: cold {cold:.2f} s, warm {warm:.2f} s")


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
    t_render, t_kernel, n_sky = _render_and_kernel()
    ratio = t_render / t_kernel
    benchmark.extra_info.update(render_s=t_render, kernel_s=t_kernel, ratio=ratio,
                                directions=n_sky)
    print(f"\nrender 1024x512: {t_render * 1e3:.1f} ms; bare preetham_sky on its {len(sky)} "
          f"sky directions: {t_kernel * 1e3:.1f} ms; ratio {ratio:.2f}")
    assert ratio < 2.0, f"render is {ratio:.2f}x its kernel (target <= 2x)"


BEGIN = "<!-- bench_startup:begin (generated by benchmarks/bench_startup.py) -->"
END = "<!-- bench_startup:end -->"


def table(repeats: int = 5, inproc: int = 15) -> str:
    """The Markdown table of docs/cli.md, with the machine, date and command."""
    import datetime  # noqa: PLC0415
    import platform  # noqa: PLC0415

    bare = _best_run(["-c", "pass"], repeats)
    imp = _best_run(["-c", "import atmoscatter"], repeats)
    hlp = _best_run(["-m", "atmoscatter", "--help"], repeats)
    cold, warm, (first, second) = _cold_warm()
    t_render, t_kernel, n_sky = _render_and_kernel(inproc)
    rows = [
        ("bare interpreter (`python -c pass`)", f"{bare:.2f} s"),
        ("`python -c \"import atmoscatter\"`", f"{imp:.2f} s"),
        ("`atmoscatter --help`", f"{hlp:.2f} s"),
        ("`atmoscatter render -o sky.exr`, first run (kernels compile)", f"{cold:.2f} s"),
        ("`atmoscatter render -o sky.exr`, later runs (numba cache hit: "
         f"{second['hits']} hit, {second['misses']} miss)", f"{warm:.2f} s"),
        (f"`render(Scene())` in a warm process / bare `preetham_sky` on its {n_sky} sky "
         "directions", f"{t_render * 1e3:.0f} ms / {t_kernel * 1e3:.0f} ms "
                       f"({t_render / t_kernel:.2f}×)"),
    ]
    try:
        load = f"load average {os.getloadavg()[0]:.1f}"
    except OSError:  # pragma: no cover - not on every platform
        load = "load not known"
    head = (f"Measured on {datetime.date.today().isoformat()}, {platform.machine()}, "
            f"{os.cpu_count()} CPUs ({load} at the end), best of {repeats} processes and "
            f"{inproc} in-process calls, by `PYTHONPATH=. python benchmarks/bench_startup.py "
            "--write`:")
    lines = [head, "", "| what | time |", "| --- | --- |"]
    lines += [f"| {what} | {t} |" for what, t in rows]
    return "\n".join(lines)


def main(argv=None) -> int:
    """Print the table; ``--write`` replaces it in docs/cli.md; ``--quick`` (1 run each,
    CI) checks that the script still works."""
    import argparse  # noqa: PLC0415

    ap = argparse.ArgumentParser(description=main.__doc__)
    ap.add_argument("--write", action="store_true", help="update docs/cli.md")
    ap.add_argument("--quick", action="store_true", help="1 run of each (smoke test)")
    args = ap.parse_args(argv)
    text = table(1, 1) if args.quick else table()
    print(text)
    if args.write and not args.quick:
        doc = os.path.join(os.path.dirname(__file__), os.pardir, "docs", "cli.md")
        with open(doc, encoding="utf-8") as f:
            page = f.read()
        head, rest = page.split(BEGIN, 1)
        _, tail = rest.split(END, 1)
        from atmoscatter.exr import atomic_write  # noqa: PLC0415

        with atomic_write(doc) as tmp, open(tmp, "w", encoding="utf-8") as f:
            f.write(head + BEGIN + "\n" + text + "\n" + END + tail)
    return 0


if __name__ == "__main__":
    sys.exit(main())
